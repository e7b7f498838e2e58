"""A scenario's learning curve: the paper's holder learner learning anew against the
scenario's default team, beside the best fixed holder rule (``docs/learning_curves.md``).

For each seed ``s`` (the unit of every interval) and scenario, one learner, learning
anew (the ``scratch`` method's learner: :class:`~ilpss.smdp.SmdpLearner` with
``ExperimentConfig(scenario=...).lifelong.learner``, the paper's Watkins's Q(0.9) over
keepaway's tile coding at the scenario's size, no options), plays ``--episodes``
training episodes of the scenario's holder SMDP (its Gymnasium id) against the
scenario's default team, its training episodes seeded from ``s``. Every ``--every``
episodes its greedy policy plays ``--eval-episodes`` evaluation episodes, seeds ``0 ..
eval_episodes - 1``: the first episodes the fixed rules of ``docs/scenarios.md`` played
(``docs/data/scenarios_fixed_rules.json``), so the learned policy and the best rule are
compared on the same episodes, paired by episode. Each finished seed is kept as a JSON
record under ``--runs`` (a rerun computes only what is missing); the page and the
per-seed numbers (``<out>/data/learning_curve_<scenario>.json``) are written from the
records, and ``--from-data`` writes the page from the kept numbers alone::

    python -m ilpss.experiments.learning_curves --scenario drill_1v1 --seeds 0-9 \\
        --episodes 300 --every 100 --eval-episodes 50 --runs results/learning_curves --out docs

Seeds from 1000 are for development; the page's are from 0.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from ilpss.experiments import drill_facts
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.outputs import kept_seed_record, seed_range, written_or_exit
from ilpss.metrics.inference import t_interval
from ilpss.smdp import SmdpLearner
from soccer_drill.files import atomic_write_text, read_digested_json, write_digested_json

SCHEMA_VERSION = 1
SEED_SCHEMA = 2
"""The schema of a seed's record under ``--runs`` (2: digested, checked when read)."""
"""The version of the kept records' and the page data's layout."""
STEM = "learning_curve_"
"""Each scenario's per-seed numbers are ``<out>/data/learning_curve_<scenario>.json``."""
FIXED_RULES = "scenarios_fixed_rules.json"
"""The fixed rules' per-episode outcomes, beside the page's data (``docs/data``)."""
TRAINING_SEED_STRIDE = 100_003
"""Seed ``s`` trains from episode seed ``s * TRAINING_SEED_STRIDE`` (evaluation's are
``0 .. eval_episodes - 1``, far below)."""


def learner_and_env(scenario: str, seed: int) -> tuple[SmdpLearner, gym.Env]:
    """Learning anew's learner at ``scenario``'s size and the scenario's holder SMDP
    against its default team."""
    cfg = ExperimentConfig(scenario=scenario)
    env = gym.make(cfg.env_id, disable_env_checker=True)
    learner_cfg = cfg.lifelong.learner
    learner = SmdpLearner(int(env.action_space.n), learner_cfg.tile_coder(env.observation_space),
                          config=learner_cfg, seed=seed)
    return learner, env


def greedy_successes(learner: SmdpLearner, env: gym.Env, episodes: int) -> list[bool]:
    """Whether each evaluation episode (seeds ``0 .. episodes - 1``) of the greedy policy
    was a success."""
    return [bool(learner.run_episode(env, learn=False, seed=s).success) for s in range(episodes)]


def learn_curve(scenario: str, seed: int, episodes: int, every: int,
                eval_episodes: int) -> dict[str, Any]:
    """One seed's training successes, and its greedy evaluation before learning and
    after every ``every`` training episodes."""
    learner, env = learner_and_env(scenario, seed)
    start = time.process_time()
    points, evaluations, training = [0], [greedy_successes(learner, env, eval_episodes)], []
    first = seed * TRAINING_SEED_STRIDE
    while len(training) < episodes:
        chunk = min(every, episodes - len(training))
        played = learner.train(env, chunk, seed=first if not training else None)
        training += [bool(r.success) for r in played]
        points.append(len(training))
        evaluations.append(greedy_successes(learner, env, eval_episodes))
    env.close()
    return {"training_success": training, "points": points, "evaluation_success": evaluations,
            "cpu_seconds": time.process_time() - start}


def _record_path(runs: Path, scenario: str, seed: int, episodes: int, every: int,
                 eval_episodes: int) -> Path:
    return (runs / scenario / f"episodes_{episodes}_every_{every}_eval_{eval_episodes}"
            / f"seed_{seed:03d}.json")


def run_seed(runs: Path, scenario: str, seed: int, episodes: int, every: int,
             eval_episodes: int) -> dict[str, Any]:
    """Seed ``seed``'s record, read if kept, else computed and kept (atomically)."""
    identity = {"scenario": scenario, "seed": seed, "episodes": episodes, "every": every,
                "eval_episodes": eval_episodes,
                "learner": asdict(ExperimentConfig(scenario=scenario).lifelong.learner)}
    return kept_seed_record(
        _record_path(runs, scenario, seed, episodes, every, eval_episodes), SEED_SCHEMA,
        identity, lambda: learn_curve(scenario, seed, episodes, every, eval_episodes))


def result_of(records: list[dict[str, Any]], seeds: list[int], episodes: int, every: int,
              eval_episodes: int) -> dict[str, Any]:
    """What the page keeps of a scenario's records: per seed, the greedy success rate at
    each point and the training success per episode."""
    return {
        "meta": {"seeds": seeds, "episodes": episodes, "every": every,
                 "eval_episodes": eval_episodes, "learner": records[0]["learner"]},
        "points": records[0]["points"],
        "evaluation_success": [[[int(x) for x in e] for e in r["evaluation_success"]]
                               for r in records],
        "training_success": [[int(x) for x in r["training_success"]] for r in records],
        "cpu_seconds": [round(float(r["cpu_seconds"]), 1) for r in records],
    }


def best_rule(fixed: dict[str, Any], scenario: str) -> tuple[str, list[bool]]:
    """The fixed rule with the highest success rate on every kept episode (as
    ``docs/scenarios.md`` picks it), and its per-episode successes."""
    outcomes = fixed["outcomes"][scenario]
    rates = {rule: np.mean([o == "success" for o in kept]) for rule, kept in outcomes.items()}
    best = max(rates, key=lambda rule: (rates[rule], rule == "random"))
    return best, [o == "success" for o in outcomes[best]]


def _pct(mean: float, low: float, high: float, sign: str = "") -> str:
    """A rate and its interval in whole percents (never a "-0%")."""
    def p(x: float) -> str:
        return f"{round(100 * x):{sign}d}%"
    return f"{p(mean)} [{p(low)}, {p(high)}]"


def section(scenario: str, result: dict[str, Any], fixed: dict[str, Any]) -> list[str]:
    """The page's section of ``scenario``."""
    meta, points = result["meta"], result["points"]
    seeds, n_eval, every = meta["seeds"], meta["eval_episodes"], meta["every"]
    evaluation = np.array(result["evaluation_success"], dtype=float)  # seed, point, episode
    training = np.array(result["training_success"], dtype=float)  # seed, episode
    rule, rule_success = best_rule(fixed, scenario)
    rule_all = float(np.mean(rule_success))
    rule_same = np.array(rule_success[:n_eval], dtype=float)
    team = drill_facts.drill_object(drill_facts.SCENARIOS)[scenario].opponent
    cpu = result["cpu_seconds"]
    lines = [
        f"## `{scenario}`",
        "",
        f"Against `{team}`, {len(seeds)} seeds ({seeds[0]}..{seeds[-1]}), {meta['episodes']} "
        f"training episodes per seed, the greedy policy evaluated on {n_eval} episodes "
        f"(seeds 0..{n_eval - 1}) before learning and every {every} episodes; "
        f"{np.sum(cpu) / 60:.1f} CPU-minutes in all ({np.mean(cpu):.0f} s a seed). Command:",
        "",
        "```bash",
        f"python -m ilpss.experiments.learning_curves --scenario {scenario} --seeds "
        f"{seeds[0]}-{seeds[-1]} --episodes {meta['episodes']} --every {every} "
        f"--eval-episodes {n_eval} --runs results/learning_curves --out docs",
        "```",
        "",
        f"The best fixed rule, `{rule}`, succeeds in {rule_all:.0%} of the 300 episodes of "
        f"`docs/scenarios.md` and in {np.mean(rule_same):.0%} of the {n_eval} evaluation "
        "episodes (the first of them).",
        "",
        "| episodes learnt | greedy success rate, 95% t interval over seeds (unadjusted) "
        f"| learned - `{rule}` on the same episodes (unadjusted) "
        "| success rate of the training episodes before it (exploring) |",
        "|---:|---|---|---|",
    ]
    for k, point in enumerate(points):
        rates = evaluation[:, k].mean(axis=1)
        diff = (evaluation[:, k] - rule_same).mean(axis=1)
        mean, low, high = t_interval(rates)
        d_mean, d_low, d_high = t_interval(diff)
        if k == 0:
            trained = "-"
        else:
            block = training[:, points[k - 1]:point].mean(axis=1)
            trained = _pct(*t_interval(block))
        lines.append(f"| {point} | {_pct(mean, low, high)} | {_pct(d_mean, d_low, d_high, '+')} "
                     f"| {trained} |")
    d_mean, d_low, d_high = t_interval((evaluation[:, -1] - rule_same).mean(axis=1))
    verdict = ("ahead of" if d_low > 0 else "behind" if d_high < 0 else
               "not told apart from")
    lines += ["", f"After {points[-1]} episodes the learned policy is {verdict} `{rule}` on "
              f"the same episodes ({_pct(d_mean, d_low, d_high, '+')}, unadjusted).",
              "", f"Per-seed numbers: `docs/data/{STEM}{scenario}.json`.", ""]
    return lines


def page(results: dict[str, dict[str, Any]], fixed: dict[str, Any]) -> str:
    """``docs/learning_curves.md``'s text from each scenario's kept numbers, in the
    scenarios' order."""
    lines = [
        "# Learning curves of the named scenarios",
        "",
        "Learning anew (the `scratch` method's learner: the paper's Watkins's Q(0.9) over",
        "keepaway's tile coding, `ExperimentConfig(scenario=...).lifelong.learner`, no options)",
        "against the scenario's default team, beside the best fixed holder rule of",
        "`docs/scenarios.md` on the same evaluation episodes. Each seed's value at a point is",
        "its greedy policy's success rate over the evaluation episodes; intervals are 95%",
        "Student t intervals over the seeds (the seed is the unit), **unadjusted** for the",
        "points and scenarios compared. The difference from the rule is paired by episode,",
        "then averaged per seed. Generated by `python -m ilpss.experiments.learning_curves`",
        "(`--from-data docs/data` rewrites the page from the kept numbers).",
        "",
    ]
    order = drill_facts.scenario_names()
    for scenario in sorted(results, key=order.index):
        lines += section(scenario, results[scenario], fixed)
    return "\n".join(lines)


def read_results(data: Path) -> dict[str, dict[str, Any]]:
    """Every scenario's kept numbers in ``data``."""
    out = {}
    for scenario in drill_facts.scenario_names():
        path = data / f"{STEM}{scenario}.json"
        if path.is_file():
            record = read_digested_json(path)
            if record.get("schema_version") != SCHEMA_VERSION:
                raise ValueError(f"{path}: schema version {record.get('schema_version')!r}, "
                                 f"this code reads {SCHEMA_VERSION}")
            out[scenario] = record["result"]
    return out


def write_outputs(out: Path, results: dict[str, dict[str, Any]]) -> None:
    """Each scenario's kept numbers, then the page from every scenario kept in
    ``<out>/data`` (those not run now keep their sections). The page is made first, so
    numbers it cannot be made from never replace the kept ones."""
    data = out / "data"
    text = page({**read_results(data), **results}, read_digested_json(data / FIXED_RULES))
    for scenario, result in results.items():
        write_digested_json(data / f"{STEM}{scenario}.json",
                    {"schema_version": SCHEMA_VERSION, "scenario": scenario,
                     "unit": "success (1) or not (0) per episode", "result": result})
    atomic_write_text(out / "learning_curves.md", text)


def write_page(out: Path) -> None:
    """``<out>/learning_curves.md`` from the numbers kept in ``<out>/data``."""
    data = out / "data"
    atomic_write_text(out / "learning_curves.md",
                      page(read_results(data), read_digested_json(data / FIXED_RULES)))


def main(argv: list[str] | None = None) -> None:
    """Learn, evaluate and write the page (see the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", action="append",
                        choices=[s for s in drill_facts.scenario_names()])
    parser.add_argument("--seeds", default="0-9", help="first-last (inclusive)")
    parser.add_argument("--episodes", type=int, default=300)
    parser.add_argument("--every", type=int, default=100,
                        help="training episodes between greedy evaluations")
    parser.add_argument("--eval-episodes", type=int, default=50)
    parser.add_argument("--runs", default="results/learning_curves")
    parser.add_argument("--out", default=None,
                        help="write learning_curves.md and data/ here (data/ must hold "
                             f"{FIXED_RULES})")
    parser.add_argument("--from-data", metavar="DOCS",
                        help="run nothing: write DOCS/learning_curves.md from DOCS/data")
    args = parser.parse_args(argv)
    if args.from_data is not None:
        written_or_exit(parser, lambda: write_page(Path(args.from_data)),
                        Path(args.from_data) / "learning_curves.md")
        return
    if args.episodes < 1 or args.every < 1 or args.eval_episodes < 2:
        parser.error("--episodes and --every must be at least 1, --eval-episodes at least 2")
    try:
        seeds = seed_range(args.seeds)
    except ValueError as exc:
        parser.error(str(exc))
    runs = Path(args.runs)
    results = {}
    for scenario in args.scenario or ["drill_1v1"]:
        records = []
        for seed in seeds:
            try:
                record = run_seed(runs, scenario, seed, args.episodes, args.every,
                                  args.eval_episodes)
            except ValueError as exc:  # a damaged kept seed: named, with what to do
                parser.exit(1, f"{parser.prog}: error: {exc}\n")
            last = np.mean(record["evaluation_success"][-1])
            print(scenario, seed, f"greedy {last:.2f}", f"{record['cpu_seconds']:.0f} CPU-s",
                  flush=True)
            records.append(record)
        results[scenario] = result_of(records, seeds, args.episodes, args.every,
                                      args.eval_episodes)
    if args.out is not None:
        written_or_exit(parser, lambda: write_outputs(Path(args.out), results),
                        Path(args.out) / "learning_curves.md")


if __name__ == "__main__":
    main()
