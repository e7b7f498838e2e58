"""Does SMDP learning beat the best fixed holder rule against each opponent?

    ilpss-holder-learning --episodes 1000 --eval 500 --seeds 10 --out docs/learning.md

For every team: learn with :class:`~ilpss.smdp.SmdpLearner` (the settings of
:class:`~ilpss.lifelong.LearnerConfig` unless overridden by ``--method``,
``--trace-decay``, ``--initial-value``, ``--alpha``; no options) for ``--episodes``
episodes per seed, then evaluate the greedy policy on ``--eval`` seeded episodes;
evaluate every fixed holder rule on the same episode seeds.

The unit of replication is the learning seed: each seed's learnt policy is one draw of
what learning produces, while the evaluation episodes of one seed share its policy and
are not independent of each other. So the comparison (:func:`compare_to_rule`) takes,
per learning seed, the mean over the evaluation episodes of (learnt reward - rule
reward) on the *same* episode seed (paired by episode seed, which removes the
episodes' difficulty), and puts a Student t interval over the learning seeds on those
means. "The learnt policy beats the best rule" is claimed for a team when the
Holm-adjusted p-value across the teams is below 0.05. The inference is conditional on
the evaluation episodes, which are the same for every seed and rule. The best rule is
picked on those same episodes, which can only favour the rule. The fixed rules are
looked up by name (``--rules module:attribute``, by default the drill's, see
:data:`ilpss.experiments.drill_facts.HOLDER_RULES`), so this module imports no drill code.

The page goes to ``--out`` (default ``results/holder_learning.md``; the documented run
above writes ``docs/learning.md``). Each learning job (a team and a seed) and each rule's
evaluation is kept in ``--keep`` (default ``results/holder_learning``) as soon as it ends
(:mod:`ilpss.experiments.kept_jobs`): if a job fails, or the command is stopped, the
same command loads the finished ones and computes only what is left; other settings
never take them. The numbers the page is computed from (every seed's learning curve and
greedy rewards, every rule's rewards, and how they were made) go beside it (``--data``,
by default ``<page>_seeds.json.gz``), and ``--from-data`` writes the page from them
alone, learning nothing::

    ilpss-holder-learning --from-data docs/learning_seeds.json.gz --out page.md
"""

from __future__ import annotations

import argparse
import functools
import shlex
import sys
import time
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from ilpss._io import (
    FolderInUseError,
    atomic_write_bytes,
    load_gzip_record,
    save_gzip_record,
)
from ilpss.experiments.config import EXPERIMENT_CONSTRAINTS
from ilpss.experiments.drill_facts import (
    ENV_ID,
    EPISODE_REWARD,
    HOLDER_RULES,
    PAPER_TEAMS,
    TEAM_CODE,
    TEAM_ERROR,
    TILE_WIDTHS,
    drill_exception,
    drill_object,
)
from ilpss.experiments.executor import LocalExecutor, stop_on_sigterm, stopped_in_one_line
from ilpss.experiments.kept_jobs import KeptJobs, KeptJobsFailed, run_kept
from ilpss.experiments.outputs import (
    check_out_dir,
    check_out_file,
    check_utf8,
    unwritten_report,
)
from ilpss.experiments.provenance import code_line
from ilpss.lifelong import LIFELONG_CONSTRAINTS, LearnerConfig
from ilpss.metrics import holm, improvement_test, t_interval, t_test_pvalue, wilson_interval
from ilpss.smdp import SmdpLearner
from soccer_drill.constraints import (
    Integer,
    JsonObject,
    ListOf,
    OneOf,
    Real,
    Text,
    check,
    check_fields,
    check_keys,
)

EVAL_SEED = 10_000  # evaluation episodes use seeds EVAL_SEED + i, never seen in learning
NUMBERS_SCHEMA = "ilpss.holder_learning_numbers/1"
"""The schema of the numbers a page is computed from (``--data``)."""
MAX_NUMBERS_BYTES = 64 * 2**20

FLAG_CONSTRAINTS = {
    # A repeated team would count each of its seeds twice (intervals too narrow).
    "teams": ListOf(Text(), min_len=1, unique=True),
    # The bounds of the fields these flags play the part of: learning episodes per task,
    # greedy evaluation episodes, seeds (at least 2: the interval is over them), workers.
    "episodes": Integer(1, LIFELONG_CONSTRAINTS["train_episodes"].high),
    "eval": Integer(1, LIFELONG_CONSTRAINTS["rollout_episodes"].high),
    "seeds": Integer(2, EXPERIMENT_CONSTRAINTS["n_seeds"].high),
    "workers": EXPERIMENT_CONSTRAINTS["workers"],
}
"""What the flags of ``ilpss-holder-learning`` allow, by flag name."""
LEARNING_FLAGS = ("episodes", "eval", "seeds", "method", "trace_decay", "initial_value", "alpha")
"""The flags the page's command always shows (they define what is learnt and evaluated);
every other flag is shown when it differs from its default."""


def _rules(spec: str) -> dict[str, Any]:
    return dict(drill_object(spec))


def evaluation_rewards(env: gym.Env, act, n: int) -> np.ndarray:
    """Rewards of ``n`` episodes with seeds EVAL_SEED.. (``act(obs) -> action``), the
    evaluation episodes of the learnt policies and of the rules."""
    rewards = np.empty(n)
    for i in range(n):
        obs, _ = env.reset(seed=EVAL_SEED + i)
        done, total = False, 0.0
        while not done:
            obs, r, term, trunc, _ = env.step(act(obs))
            total += r
            done = term or trunc
        rewards[i] = total
    return rewards


def learn_and_evaluate(job: tuple[str, int, int, int, LearnerConfig]) -> dict[str, Any]:
    """Learn on one team with one seed, then evaluate the greedy policy."""
    team, seed, episodes, n_eval, lc = job
    env = gym.make(ENV_ID, opponent=team, disable_env_checker=True)
    coder = lc.tile_coder(env.observation_space)
    learner = SmdpLearner(int(env.action_space.n), coder, None, lc, seed=seed)
    curve = [r.total_reward for r in learner.train(env, episodes, seed=seed)]
    rng = np.random.default_rng(seed)
    rewards = evaluation_rewards(env, lambda obs: learner.q.greedy(np.asarray(obs, float), rng), n_eval)
    return {"team": team, "seed": seed, "curve": curve, "eval": rewards.tolist()}


@functools.cache
def _team_code(team: str) -> dict[str, str]:
    """The team's code (:data:`~ilpss.experiments.drill_facts.TEAM_CODE`), once per process
    (each key takes a copy)."""
    return drill_object(TEAM_CODE)(team)


def learning_key(job: tuple[str, int, int, int, LearnerConfig]) -> dict[str, Any]:
    """What a learning job's result depends on (its kept file's key): the team's code
    too, so that a team changed since is played again."""
    team, seed, episodes, n_eval, lc = job
    return {"team": team, "team_code": dict(_team_code(team)), "seed": seed,
            "episodes": episodes, "eval": n_eval, "eval_seed": EVAL_SEED, "learner": asdict(lc)}


def rule_key(job: tuple[str, str, str, int]) -> dict[str, Any]:
    """What a fixed rule's evaluation depends on (its kept file's key), the team's code
    included."""
    team, spec, name, n_eval = job
    return {"team": team, "team_code": dict(_team_code(team)), "rules": spec, "rule": name,
            "eval": n_eval, "eval_seed": EVAL_SEED}


def _check_result(where: str, result: Any, fields: dict[str, Any],
                  series: dict[str, int]) -> None:
    """A kept result: an object of ``fields`` (each the value its key gives) and
    ``series`` (each a list of that many episode rewards, within the drill's range)."""
    if not isinstance(result, dict):
        raise ValueError(f"{where} must be an object, got {type(result).__name__}")
    check_keys(where, result, (*fields, *series))
    for name, expected in fields.items():
        if result[name] != expected:
            raise ValueError(f"{where}.{name} is {result[name]!r}, but the file is the job "
                             f"of {name} {expected!r}")
    check_fields(where, result, {name: ListOf(Real(*EPISODE_REWARD), n, n)
                                 for name, n in series.items()}, dict.get)


def check_learning_result(where: str, key: dict[str, Any], result: Any) -> None:
    """A kept learning job's result is the key's team and seed, its curve and evaluation
    as long as the key says, every reward one the drill can pay."""
    _check_result(where, result, {"team": key["team"], "seed": key["seed"]},
                  {"curve": key["episodes"], "eval": key["eval"]})


def check_rule_result(where: str, key: dict[str, Any], result: Any) -> None:
    """A kept rule evaluation is the key's team and rule, as many rewards as the key's
    evaluation episodes, each one the drill can pay."""
    _check_result(where, result, {"team": key["team"], "rule": key["rule"]},
                  {"eval": key["eval"]})


def rule_rewards(job: tuple[str, str, str, int]) -> dict[str, Any]:
    """Rewards of one fixed rule against one team on the evaluation seeds."""
    team, spec, name, n_eval = job
    rule = _rules(spec)[name]
    env = gym.make(ENV_ID, opponent=team, disable_env_checker=True)
    rng = np.random.default_rng(0)
    return {"team": team, "rule": name,
            "eval": evaluation_rewards(env, lambda obs: rule(obs, rng), n_eval).tolist()}


def compare_to_rule(learnt: np.ndarray, rule: np.ndarray) -> dict[str, Any]:
    """The learnt policies against one rule, paired by episode seed, seeds as the unit.

    ``learnt`` has shape ``(n_seeds, n_episodes)`` (row: one learning seed's greedy
    policy on the evaluation episodes), ``rule`` shape ``(n_episodes,)`` on the same
    episodes. Returns the per-seed mean differences (``diff``), their mean with a 95%
    Student t interval (``diff_ci``) and paired t-test p-value (``p``), the seeds on which
    learning is ahead (``improvement``, with a sign test), the learnt mean reward with a t
    interval over seeds, the rule's mean reward with a t interval over episodes, and
    success rates (learnt: t interval over the seeds' rates; rule: Wilson over episodes).
    """
    learnt = np.asarray(learnt, dtype=float)
    rule = np.asarray(rule, dtype=float)
    if learnt.ndim != 2 or rule.shape != learnt.shape[1:] or learnt.shape[0] < 2:
        raise ValueError(f"need learnt (n_seeds >= 2, n_episodes) and rule (n_episodes,), "
                         f"got {learnt.shape} and {rule.shape}")
    diff = (learnt - rule).mean(axis=1)
    wins = int((rule > 0).sum())
    return {
        "diff": diff,
        "diff_ci": t_interval(diff),
        "p": float(t_test_pvalue(diff)),
        "improvement": improvement_test(diff),
        "learnt_ci": t_interval(learnt.mean(axis=1)),
        "rule_ci": t_interval(rule),
        "learnt_success_ci": _within_shares(t_interval((learnt > 0).mean(axis=1))),
        "rule_success": (wins / rule.size, *wilson_interval(wins, rule.size)),
    }


def _within_shares(interval: tuple[float, float, float]) -> tuple[float, float, float]:
    """A success rate's t interval clipped to 0-1, the values a share can take (few seeds
    near 0 or 1 reach past them)."""
    mean, low, high = interval
    return mean, max(float(low), 0.0), min(float(high), 1.0)


def command(p: argparse.ArgumentParser, args: argparse.Namespace) -> str:
    """The command line that reruns ``args``: :data:`LEARNING_FLAGS` always, every other
    flag that differs from its default."""
    argv = [p.prog]
    for dest, value in vars(args).items():  # in the parser's order of flags
        if dest not in LEARNING_FLAGS and value == p.get_default(dest):
            continue
        if isinstance(value, bool):  # a switch (store_true), shown only when on
            argv.append(f"--{dest.replace('_', '-')}")
            continue
        values = value if isinstance(value, list) else [value]
        argv += [f"--{dest.replace('_', '-')}", *(_shown(v) for v in values)]
    return shlex.join(argv)


def _shown(value: object) -> str:
    """A flag's value as typed: floats short (``0.125``, ``1``) unless that loses digits."""
    if isinstance(value, float):
        short = f"{value:g}"
        return short if float(short) == value else repr(value)
    return str(value)


def parser() -> argparse.ArgumentParser:
    """The command-line parser of ``ilpss-holder-learning``."""
    p = argparse.ArgumentParser(prog="ilpss-holder-learning", description=__doc__.splitlines()[0])
    p.add_argument("--teams", nargs="+", default=list(PAPER_TEAMS),
                   help="distinct opponent teams (default: the paper's four)")
    p.add_argument("--episodes", type=int, default=1000)
    p.add_argument("--eval", type=int, default=500)
    p.add_argument("--seeds", type=int, default=10, help="learning seeds per team (>= 2)")
    p.add_argument("--rules", default=HOLDER_RULES)
    p.add_argument("--workers", type=int, default=2)
    defaults = LearnerConfig()
    p.add_argument("--method", choices=["sarsa", "q"], default=defaults.method)
    p.add_argument("--trace-decay", type=float, default=defaults.trace_decay, help="lambda")
    p.add_argument("--initial-value", type=float, default=defaults.initial_value)
    p.add_argument("--alpha", type=float, default=defaults.alpha)
    p.add_argument("--out", default="results/holder_learning.md",
                   help="the markdown page to write (default: %(default)s)")
    p.add_argument("--keep", default="results/holder_learning", metavar="DIR",
                   help="folder where each finished job is kept as it ends; the same command "
                        "loads them and computes only what is left (default: %(default)s)")
    p.add_argument("--allow-mixed-code", action="store_true",
                   help="use kept jobs that other code computed (refused otherwise); the "
                   "page names every version of the code it mixes")
    p.add_argument("--data", metavar="FILE",
                   help="where to write the numbers the page is computed from (default: "
                   "beside --out, its name ending in _seeds.json.gz)")
    p.add_argument("--from-data", metavar="FILE",
                   help="write the page from numbers written by --data alone: nothing is "
                   "learnt, and the flags of learning are not read")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run the comparison and write its markdown page."""
    with stopped_in_one_line("ilpss-holder-learning"):  # Ctrl-C, SIGTERM: one line
        return _main(argv)


def _checked_inputs(p: argparse.ArgumentParser, args: argparse.Namespace
                    ) -> tuple[Path, LearnerConfig, list[str], Path, Path]:
    """The page's path, the learner, the rules' names, the keep folder and the numbers'
    file, or the parser's error (before hours of learning, not after; and the keep folder
    made only once everything else passed)."""
    try:
        check_utf8(args)
        check_fields("", args, {f"--{name}": c for name, c in FLAG_CONSTRAINTS.items()},
                     get=lambda a, flag: getattr(a, flag[2:]))
        out = check_out_file(args.out, suffix=".md")
        lc = LearnerConfig(alpha=args.alpha, method=args.method,
                           initial_value=args.initial_value, trace_decay=args.trace_decay,
                           tile_widths=TILE_WIDTHS)
        for team in args.teams:  # an unknown team: the drill's error, naming the known ones
            gym.make(ENV_ID, opponent=team, disable_env_checker=True).close()
        names = sorted(_rules(args.rules))
        data = check_out_file(args.data or out.with_name(f"{out.stem}_seeds.json.gz"),
                              "--data", ".json.gz")
        keep = check_out_dir(args.keep, "--keep", run_folder=False)
    except (ValueError, drill_exception(TEAM_ERROR)) as exc:  # TeamError: a broken plugin
        p.error(str(exc))
    except (ImportError, AttributeError) as exc:
        p.error(f"--rules {args.rules}: {exc}")
    return out, lc, names, keep, data


def _header(numbers: dict[str, Any]) -> list[str]:
    """The page's title, how it was made and how it compares, and the table's head."""
    lc, n_eval = numbers["learner"], numbers["eval"]
    return [
        "# SMDP learning against the best fixed holder rule",
        "",
        f"Command: `{numbers['command']}` ({numbers['took']}). Learning: SMDP "
        f"{'Q' if lc['method'] == 'q' else 'Sarsa'}({lc['trace_decay']:g}) with replacing "
        f"traces, keepaway's tile coding, step size {lc['alpha']:g}, epsilon "
        f"{lc['epsilon']:g}, initial values {lc['initial_value']:g}, no options, "
        f"{numbers['episodes']} episodes per seed, {numbers['seeds']} learning seeds per "
        f"team. Evaluation: the greedy policy of each seed and every fixed rule on the same "
        f"{n_eval} episode seeds (unseen in learning); the best rule is the one with the "
        "highest mean reward on them.",
        "",
        numbers["code"],
        "",
        "How it is compared: the learning seed is the unit. For each seed, the mean over "
        f"the {n_eval} episodes of (learnt reward - rule reward) on the same episode "
        "seed; then the mean of these per-seed differences over the seeds with a 95% "
        "Student t interval and the paired t-test, and the p-value adjusted with Holm's "
        f"method across the {len(numbers['teams'])} teams. Learnt mean reward and success: "
        "mean over seeds of each seed's mean, with a t interval over seeds; the rule's: over "
        "its episodes (t interval; Wilson for the success rate). The evaluation episodes "
        "are the same for every seed and rule, so the comparison is conditional on them.",
        "",
        "| team | learnt: mean reward [95% CI] | learnt: success [95% CI, within 0-100%] | best fixed rule | "
        "rule: mean reward [95% CI] | rule: success [95% CI] | learnt - rule [95% CI] | "
        "seeds ahead (sign test p) | p (Holm) | learnt better? |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]


def _comparisons(teams: Sequence[str], learnt: list[dict[str, Any]],
                 fixed: list[dict[str, Any]]) -> list[str]:
    """A row per team against its best fixed rule (Holm across the teams), and the count
    of teams where learning is better."""
    results = {}
    for team in teams:
        mine = np.array([r["eval"] for r in learnt if r["team"] == team])
        rules = {r["rule"]: np.asarray(r["eval"]) for r in fixed if r["team"] == team}
        best = max(rules, key=lambda n: rules[n].mean())
        results[team] = (best, compare_to_rule(mine, rules[best]))
    adjusted = dict(zip(results, holm([c["p"] for _, c in results.values()]), strict=True))
    lines, beaten = [], 0
    for team, (best, c) in results.items():
        better = c["diff_ci"][0] > 0 and adjusted[team] < 0.05
        beaten += better
        lm, ll, lh = c["learnt_ci"]
        sm, sl, sh = c["learnt_success_ci"]
        rm, rl, rh = c["rule_ci"]
        qm, ql, qh = c["rule_success"]
        dm, dl, dh = c["diff_ci"]
        imp = c["improvement"]
        sign = "n/a" if np.isnan(imp.sign_p) else f"{imp.sign_p:.2g}"
        lines.append(
            f"| {team} | {lm:+.3f} [{ll:+.3f}, {lh:+.3f}] | {sm:.1%} [{sl:.1%}, {sh:.1%}] "
            f"| {best} | {rm:+.3f} [{rl:+.3f}, {rh:+.3f}] | {qm:.1%} [{ql:.1%}, {qh:.1%}] "
            f"| {dm:+.3f} [{dl:+.3f}, {dh:+.3f}] | {imp.better} of {imp.n} ({sign}) "
            f"| {adjusted[team]:.2g} | {'yes' if better else 'no'} |"
        )
    return [*lines, "", f"**The learnt policy beats the best fixed rule on {beaten} of "
            f"{len(teams)} teams** (paired difference over learning seeds above zero, "
            "Holm-adjusted p < 0.05 across the teams).", ""]


def _curves(teams: Sequence[str], learnt: list[dict[str, Any]], episodes: int) -> list[str]:
    """The mean learning reward per 100 episodes, a row per team."""
    curves = {t: np.mean([r["curve"] for r in learnt if r["team"] == t], axis=0) for t in teams}
    blocks = range(0, episodes, 100)
    lines = ["Mean learning reward per 100 episodes (mean over seeds):", "",
             "| team | " + " | ".join(f"{i}-{min(i + 99, episodes - 1)}" for i in blocks)
             + " |", "|---|" + "---|" * len(blocks)]
    for t, c in curves.items():
        cells = [f"{np.mean(c[i:i + 100]):+.2f}" for i in blocks]
        lines.append(f"| {t} | " + " | ".join(cells) + " |")
    return lines


def page_lines(numbers: dict[str, Any]) -> list[str]:
    """The page: a function of the numbers alone (what ``--data`` writes)."""
    teams = numbers["teams"]
    return (_header(numbers) + _comparisons(teams, numbers["learnt"], numbers["rules"])
            + _curves(teams, numbers["learnt"], numbers["episodes"]))


def save_numbers(numbers: dict[str, Any], path: Path) -> None:
    """Write the numbers a page is computed from, gzip-compressed, with schema and digest."""
    save_gzip_record({"schema": NUMBERS_SCHEMA, "numbers": numbers}, path)


def load_numbers(path: Path) -> dict[str, Any]:
    """The numbers written by :func:`save_numbers`; ``ValueError`` naming the file if they
    are not (another schema, changed after they were written, or numbers no run gives:
    :func:`check_numbers`)."""
    numbers = load_gzip_record(path, NUMBERS_SCHEMA, MAX_NUMBERS_BYTES,
                               "holder-learning numbers")["numbers"]
    check_numbers(numbers, str(path))
    return numbers


_NUMBERS = {"command": Text(), "took": Text(), "code": Text(),
            "learner": JsonObject("the learner's settings"), "teams": FLAG_CONSTRAINTS["teams"],
            "episodes": FLAG_CONSTRAINTS["episodes"], "eval": FLAG_CONSTRAINTS["eval"],
            "seeds": FLAG_CONSTRAINTS["seeds"], "learnt": ListOf(JsonObject("a seed's")),
            "rules": ListOf(JsonObject("a rule's"))}
"""The fields of the numbers a page is made from, as a run writes them."""


def check_numbers(numbers: Any, where: str) -> None:
    """The numbers are a run's: its fields (:data:`_NUMBERS`), a learnt row per team and
    seed (a curve of ``episodes`` rewards and ``eval`` greedy ones) and a row per team and
    rule (``eval`` rewards), every reward in the drill's [-1, 1]; else ``ValueError``
    naming ``where`` and the field."""
    check(f"{where}: the numbers", numbers, JsonObject("the numbers"))
    check_keys(where, numbers, _NUMBERS)
    check_fields(where, numbers, _NUMBERS, dict.get)
    episodes, n_eval = numbers["episodes"], numbers["eval"]
    learnt = {"team": OneOf(tuple(numbers["teams"])), "seed": Integer(0),
              "curve": ListOf(Real(-1, 1), episodes, episodes),
              "eval": ListOf(Real(-1, 1), n_eval, n_eval)}
    rules = {"team": learnt["team"], "rule": Text(),
             "eval": ListOf(Real(-1, 1), n_eval, n_eval)}
    for name, rows, fields in (("learnt", numbers["learnt"], learnt),
                               ("rules", numbers["rules"], rules)):
        for k, row in enumerate(rows):
            check_keys(f"{where}: {name}[{k}]", row, fields)
            check_fields(f"{where}: {name}[{k}]", row, fields, dict.get)
    for team in numbers["teams"]:
        seeds = sorted(r["seed"] for r in numbers["learnt"] if r["team"] == team)
        if len(seeds) != numbers["seeds"] or len(set(seeds)) != len(seeds):
            raise ValueError(f"{where}: team {team!r} has the seeds {seeds}, where "
                             f"{numbers['seeds']} distinct ones belong")


def _write_page(out: Path, lines: list[str]) -> None:
    atomic_write_bytes(out, ("\n".join(lines) + "\n").encode())


def _from_data(p: argparse.ArgumentParser, args: argparse.Namespace) -> int:
    try:
        check_utf8(args)
        out = check_out_file(args.out, suffix=".md", inputs=[args.from_data])
        numbers = load_numbers(Path(args.from_data))
    except FileNotFoundError:
        p.error(f"--from-data {args.from_data}: no such file")
    except ValueError as exc:
        p.error(f"--from-data: {exc}")
    try:
        _write_page(out, page_lines(numbers))
    except OSError as exc:
        print(f"ilpss-holder-learning: error: cannot write {out}: {exc}", file=sys.stderr)
        return 1
    print(f"page written to {out} from {args.from_data}")
    return 0


def _main(argv: Sequence[str] | None) -> int:
    p = parser()
    args = p.parse_args(argv)
    if args.from_data is not None:
        return _from_data(p, args)
    out, lc, names, keep, data = _checked_inputs(p, args)
    stop_on_sigterm()
    start = time.perf_counter()
    pool = LocalExecutor(args.workers)
    kept = KeptJobs(keep, allow_mixed_code=args.allow_mixed_code)
    try:
        with kept.held():
            learnt, loaded = run_kept(
                pool, learn_and_evaluate,
                [(t, s, args.episodes, args.eval, lc) for t in args.teams for s in range(args.seeds)],
                "learning", learning_key, kept, desc="learning", check=check_learning_result)
            fixed, loaded_rules = run_kept(
                pool, rule_rewards,
                [(t, args.rules, n, args.eval) for t in args.teams for n in names],
                "rule", rule_key, kept, desc="fixed rules", check=check_rule_result)
    except (KeptJobsFailed, FolderInUseError, ValueError, OSError) as exc:
        # OSError: a full disk while a job is kept, naming the file (the others stay kept)
        print(f"ilpss-holder-learning: error: {exc}", file=sys.stderr)
        return 1
    took = f"{(time.perf_counter() - start) / 60:.1f} min with {args.workers} worker(s)"
    if loaded:
        took += f", {loaded} of its learning jobs kept from an earlier run"
        print(f"{loaded} learning job(s) and {loaded_rules} rule evaluation(s) loaded from {keep}")
    numbers = {"command": command(p, args), "took": took,
               "code": code_line({"code": code} for code in kept.codes.values()),
               "learner": asdict(lc), "teams": list(args.teams), "episodes": args.episodes,
               "eval": args.eval, "seeds": args.seeds, "learnt": learnt, "rules": fixed}
    lines = page_lines(numbers)
    try:
        save_numbers(numbers, data)
        _write_page(out, lines)
    except OSError as exc:  # a full disk: every job is kept, and a rerun writes the page
        print(f"ilpss-holder-learning: error: {unwritten_report(keep, exc)}", file=sys.stderr)
        return 1
    print("\n".join(lines))
    print(f"page written to {out}, the numbers it is computed from to {data}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
