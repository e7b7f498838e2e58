"""What standard deep-RL learners reach on the drill, beside the fixed rules and ILPSS.

The smallest reproduction, one setting, one team, one seed (about 5 minutes on one core)::

    soccer-drill-reference --settings mappo --teams goal_guards --seeds 1

writes ``results/reference_rl.md`` (the default ``--out``; the shipped page,
``docs/reference_rl_results.md``, is written only when ``--out`` names it).

Trains, evaluates and plots every setting of :data:`~ilpss.reference.settings.SETTINGS`
(``--settings``): SB3's PPO and sb3-contrib's MaskablePPO on the holder against each team
(``--teams``: the paper's four; ``chasers`` is ``interceptors_press`` cycle for cycle,
so its rows would repeat that team's); MAPPO and IPPO for the two attackers of the
parallel drill against each team; MAPPO for the two defenders against the scripted
attacks (the fixed holder rules playing both attackers, ``--attacks``); self-play of
both sides against a pool of their checkpoints; and the transfer row (PPO fine-tuned
after the paper's first three teams against learning anew, on the fourth: protocol A's
order). ``--seeds N`` training seeds each, or more for some settings (``--seeds 5
ppo=10``); seed ``s`` trains from episode seed ``1,000,000 (s + 1)``; each policy is
evaluated on ``--eval`` held-out episode seeds, the same ones every fixed holder rule is
evaluated on.

Each job (a setting, a team, a seed) is kept in ``--keep`` as soon as it ends
(:mod:`ilpss.experiments.kept_jobs`: a JSON record with schema and SHA-256, written
atomically, naming the code and the learners' library versions that computed it): the
same command loads the finished jobs and computes only what is left, and a changed
setting is a new job. Jobs run in local processes (``--workers``) or on a Ray cluster
(``--executor ray --ray-address HOST:PORT``; the driver keeps the results, so only it
needs ``--keep``). ``--ppo KEY=VALUE`` changes a field of every selected setting's PPO
configuration (for a small run), ``--marl KEY=VALUE`` one of the multi-agent settings
(:class:`~ilpss.reference.settings.MarlSetting`), ``--timeout-reward`` the holder's
reward, ``--timeout-bootstrap`` SB3's treatment of the drill's timeout (see
:class:`~ilpss.reference.settings.HolderSetting`); each is recorded in every result and
shown in the page's command.

Needs ``pip install 'soccer-drill-ilpss[integrations]'`` (torch); the parser and the checks of the flags
run without it.
"""

from __future__ import annotations

import argparse
import dataclasses
import shlex
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ilpss._io import FolderInUseError, atomic_write_bytes
from ilpss.experiments.drill_facts import (
    ATTACKS,
    HOLDER_RULES,
    PAPER_TEAMS,
    TEAM_ERROR,
    drill_exception,
    drill_object,
)
from ilpss.experiments.executor import (
    EXECUTOR,
    check_executor,
    check_ray_address,
    make_executor,
    stop_on_sigterm,
    stopped_in_one_line,
)
from ilpss.experiments.holder_learning import check_rule_result, rule_key, rule_rewards
from ilpss.experiments.kept_jobs import KeptJobs, KeptJobsFailed, run_kept
from ilpss.experiments.outputs import check_out_dir, check_out_file, check_utf8, unwritten_report
from ilpss.experiments.provenance import code_line
from ilpss.reference.jobs import KIND, Job, check_result, job_key, library_versions, run_job
from ilpss.reference.settings import (
    SETTINGS,
    EvalSettings,
    HolderSetting,
    MarlSetting,
    PPOConfig,
    RewardOption,
    SelfPlaySetting,
    TransferSetting,
)
from soccer_drill.constraints import Integer, check

PROG = "soccer-drill-reference"
DEFAULT_TEAMS = PAPER_TEAMS
DEFAULT_ATTACKS = ("late_pass", "early_pass", "shield_pass", "keepaway", "lane", "pass_first",
                   "dribble", "hold", "random")
"""The scripted attacks the learnt defenders are evaluated against: every fixed rule."""
PPO_FIELDS = {f.name: f.type for f in dataclasses.fields(PPOConfig)}
MARL_FIELDS = {f.name: f.type for f in dataclasses.fields(MarlSetting)
               if f.name not in ("ppo", "side")}
LEARNING_PAGE = Path(__file__).resolve().parents[2] / "docs" / "learning.md"
"""The tile-coded learners' page of this source tree (absent from an installed wheel)."""


def _value(flag: str, item: str, name: str, kind: str, text: str) -> Any:
    """``text`` as field ``name`` of type ``kind`` (the dataclass's annotation)."""
    try:
        if name == "net_arch":
            return tuple(int(w) for w in text.split(","))
        if kind == "bool":
            if text not in ("True", "False", "true", "false", "1", "0"):
                raise ValueError
            return text in ("True", "true", "1")
        if "int" in kind:
            return int(text)
        if "float" in kind:
            return float(text)
        return text
    except ValueError:
        what = ("widths such as 64,64" if name == "net_arch" else
                "true or false" if kind == "bool" else "a number")
        raise ValueError(f"{flag} {item!r}: {name} takes {what}") from None


def parse_fields(flag: str, items: Sequence[str], fields: dict[str, Any]) -> dict[str, Any]:
    """``["steps=512", "net_arch=32,32"]`` as fields of ``fields`` (name -> annotation);
    ``ValueError`` naming a field that is not one, or a value of the wrong kind."""
    out: dict[str, Any] = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not sep or name not in fields:
            raise ValueError(f"{flag} {item!r}: give KEY=VALUE with KEY one of {sorted(fields)}")
        out[name] = _value(flag, item, name, str(fields[name]), text)
    return out


def parse_ppo(items: Sequence[str]) -> dict[str, Any]:
    """``--ppo``'s fields of :class:`PPOConfig`."""
    return parse_fields("--ppo", items, PPO_FIELDS)


def build_settings(args: argparse.Namespace) -> dict[str, Any]:
    """The selected settings with the flags' changes, checked by the dataclasses."""
    ppo = parse_ppo(args.ppo)
    marl = parse_fields("--marl", args.marl, MARL_FIELDS)
    # checked whichever settings are selected: a value no selected setting reads would
    # otherwise pass unchecked onto the page's command line
    dataclasses.replace(MarlSetting(), **marl)
    reward = RewardOption(args.timeout_reward)

    def holder(h: HolderSetting) -> HolderSetting:
        return dataclasses.replace(h, ppo=dataclasses.replace(h.ppo, **ppo), reward=reward,
                                   timeout_terminal=not args.timeout_bootstrap)

    def multi(m: MarlSetting) -> MarlSetting:
        return dataclasses.replace(m, ppo=dataclasses.replace(m.ppo, **ppo), **marl)

    out = {}
    for name in args.settings:
        s = SETTINGS[name]
        if isinstance(s, HolderSetting):
            s = holder(s)
        elif isinstance(s, TransferSetting):
            s = dataclasses.replace(s, holder=holder(s.holder), source_steps=args.source_steps
                                    or s.source_steps, target_episodes=args.target_episodes
                                    or s.target_episodes, window=args.window or s.window)
        elif isinstance(s, SelfPlaySetting):
            s = dataclasses.replace(s, marl=multi(s.marl), crossplay_episodes=(
                args.crossplay_episodes or s.crossplay_episodes))
        else:
            s = multi(s)
        out[name] = s
    return out


def parse_seeds(items: Sequence[str]) -> tuple[int, dict[str, int]]:
    """``["5", "ppo=10"]`` as the seeds of every setting and those of named settings;
    ``ValueError`` naming what is not one of them."""
    if not items or not items[0].isdigit():
        raise ValueError(f"--seeds must start with a number of seeds, got {list(items)}")
    per: dict[str, int] = {}
    for item in items[1:]:
        name, sep, text = item.partition("=")
        if not sep or name not in SETTINGS or not text.isdigit():
            raise ValueError(f"--seeds {item!r}: give SETTING=N with SETTING one of "
                             f"{list(SETTINGS)} and N a number of seeds")
        per[name] = int(text)
    return int(items[0]), per


def make_jobs(settings: dict[str, Any], teams: Sequence[str], seeds: dict[str, int],
              ev: EvalSettings, attacks: Sequence[str] = DEFAULT_ATTACKS, first_seed: int = 0
              ) -> list[Job]:
    """Every job, seed by seed (so that a stopped run has every setting's first seeds);
    ``seeds`` by setting name, counted from ``first_seed``."""
    jobs = []
    for seed in range(first_seed, first_seed + max(seeds.values())):
        for name, s in settings.items():
            if seed >= first_seed + seeds[name]:
                continue
            if isinstance(s, TransferSetting):
                jobs.append(Job(name, s, seed, PAPER_TEAMS[-1], tuple(PAPER_TEAMS[:-1]), ev))
            elif isinstance(s, SelfPlaySetting):
                jobs.append(Job(name, s, seed, None, tuple(teams), ev, tuple(attacks)))
            elif isinstance(s, MarlSetting) and s.side == "defenders":
                jobs.append(Job(name, s, seed, None, (), ev, tuple(attacks)))
            else:
                jobs += [Job(name, s, seed, team, (), ev) for team in teams]
    return jobs


def command(p: argparse.ArgumentParser, args: argparse.Namespace) -> str:
    """The command line that reruns ``args`` (every flag that differs from its default)."""
    argv = [p.prog]
    for dest, value in vars(args).items():
        if value == p.get_default(dest):
            continue
        flag = f"--{dest.replace('_', '-')}"
        if isinstance(value, bool):
            argv.append(flag)
        else:
            argv += [flag, *(str(v) for v in (value if isinstance(value, list) else [value]))]
    return shlex.join(argv)


class _Help(argparse.ArgumentDefaultsHelpFormatter):
    """Every flag's default shown, where its help does not say it already."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        if action.default in (None, False, []) or "default:" in (action.help or ""):
            return action.help
        return super()._get_help_string(action)


def parser() -> argparse.ArgumentParser:
    """The command-line parser of ``soccer-drill-reference``."""
    p = argparse.ArgumentParser(
        prog=PROG, description=__doc__.splitlines()[0],
        epilog="The smallest run: --settings mappo --teams goal_guards --seeds 1 (one job, "
               "the full budget: about 5 minutes); a check in seconds: add --ppo steps=4096 "
               "--eval 10 (--ppo sets the budget of every setting; a job trains whole "
               "rollouts, so up to one rollout more).",
        formatter_class=_Help)
    p.add_argument("--settings", nargs="+", choices=list(SETTINGS), default=list(SETTINGS),
                   help="the settings to run, in this order")
    p.add_argument("--teams", nargs="+", default=list(DEFAULT_TEAMS),
                   help="distinct opponent teams of the per-team settings (the transfer row "
                        "always takes the paper's four)")
    p.add_argument("--attacks", nargs="+", default=list(DEFAULT_ATTACKS),
                   help="distinct scripted attacks the learnt defenders are evaluated against")
    p.add_argument("--seeds", nargs="+", default=["10"], metavar="N [SETTING=N]",
                   help="training seeds per setting and team (1 or more), and optionally "
                        "another number for named settings, e.g. 5 ppo=10")
    p.add_argument("--first-seed", type=int, default=0,
                   help="the first training seed (the page's runs use seeds from 0; settings "
                        "are searched on development seeds, from 1000)")
    p.add_argument("--eval", type=int, default=EvalSettings.episodes,
                   help="held-out evaluation episodes per policy")
    p.add_argument("--ppo", nargs="+", default=[], metavar="KEY=VALUE",
                   help=f"change a field of every selected setting's PPO configuration "
                        f"({', '.join(PPO_FIELDS)})")
    p.add_argument("--marl", nargs="+", default=[], metavar="KEY=VALUE",
                   help=f"change a field of every selected multi-agent setting "
                        f"({', '.join(MARL_FIELDS)})")
    p.add_argument("--timeout-reward", type=float, default=None,
                   help="holder: the reward of a timeout (default: the drill's, -1)")
    p.add_argument("--timeout-bootstrap", action="store_true",
                   help="holder: bootstrap the value at the drill's timeout, as SB3 does for a "
                        "truncation (default: the timeout is a terminal end)")
    p.add_argument("--source-steps", type=int, default=None,
                   help="transfer: decisions per source team (default: the setting's)")
    p.add_argument("--target-episodes", type=int, default=None,
                   help="transfer: episodes on the target (default: the setting's)")
    p.add_argument("--window", type=int, default=None,
                   help="transfer: episodes of the jumpstart and of the final (default: the "
                        "setting's)")
    p.add_argument("--crossplay-episodes", type=int, default=None,
                   help="self-play: held-out episodes of each pair of checkpoints in the "
                        "cross-play table (default: the setting's)")
    p.add_argument("--executor", choices=list(EXECUTOR.values), default="local",
                   help="where jobs run: local processes, or a Ray cluster")
    p.add_argument("--ray-address", metavar="HOST:PORT", default=None,
                   help="with --executor ray: the cluster to join (default: RAY_ADDRESS, or "
                        "a local Ray instance)")
    p.add_argument("--workers", type=int, default=2,
                   help="jobs run at once (local processes, or Ray tasks in flight); each "
                        "job uses one core")
    p.add_argument("--out", default="results/reference_rl.md",
                   help="the markdown page to write")
    p.add_argument("--figures", default=None, metavar="DIR",
                   help="where the figures go (default: a folder figures beside --out)")
    p.add_argument("--summary", default=None, metavar="FILE",
                   help="the per-seed numbers behind the page's tables, gzip-compressed JSON "
                        "(default: beside --out, its name ending in _seeds.json.gz)")
    p.add_argument("--keep", default="results/reference_rl", metavar="DIR",
                   help="folder where each finished job is kept as it ends; the same command "
                        "loads them and computes only what is left")
    p.add_argument("--learning-page", default=None, metavar="FILE",
                   help="the tile-coded learners' page whose final row is shown beside "
                        f"(default: this source tree's {LEARNING_PAGE.name} if it has one; "
                        "a path given must exist)")
    p.add_argument("--allow-mixed-code", action="store_true",
                   help="use kept jobs that other code computed (refused otherwise)")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run the reference jobs and write the page."""
    with stopped_in_one_line(PROG):
        return _main(argv)


def _check_flags(args: argparse.Namespace) -> dict[str, int]:
    """Refuse bad flags; the training seeds of each selected setting."""
    for flag in ("teams", "settings", "attacks"):
        values = getattr(args, flag)
        if len(set(values)) != len(values):
            raise ValueError(f"--{flag} must not repeat one, got {values}")
    every, per = parse_seeds(args.seeds)
    if unselected := sorted(set(per) - set(args.settings)):
        raise ValueError(f"--seeds names {unselected}, which --settings does not select")
    seeds = {name: per.get(name, every) for name in args.settings}
    for flag, value in (("--seeds", every), *((f"--seeds {name}=N", n) for name, n in per.items()),
                        ("--eval", args.eval), ("--workers", args.workers)):
        if value < 1:
            raise ValueError(f"{flag} must be at least 1, got {value}")
    check("--first-seed", args.first_seed, Integer(0))
    for flag in ("source_steps", "target_episodes", "window", "crossplay_episodes"):
        value = getattr(args, flag)
        if value is not None and value < 1:
            raise ValueError(f"--{flag.replace('_', '-')} must be at least 1, got {value}")
    if args.ray_address is not None and args.executor != "ray":
        raise ValueError("--ray-address needs --executor ray")
    if args.learning_page is not None and not Path(args.learning_page).is_file():
        raise ValueError(f"--learning-page {args.learning_page}: no such file (the tile-coded "
                         "learners' page, docs/learning.md of the source tree)")
    registered = drill_object(ATTACKS)
    for attack in args.attacks:
        registered.check("--attacks", attack)
    return seeds


def _learning_page(args: argparse.Namespace) -> Path | None:
    if args.learning_page is not None:
        return Path(args.learning_page)
    return LEARNING_PAGE if LEARNING_PAGE.is_file() else None


def _checked(p: argparse.ArgumentParser, args: argparse.Namespace
             ) -> tuple[dict[str, int], dict[str, Any], Path, Path, Path, Path]:
    """The seeds, settings, teams and outputs (page, kept jobs, per-seed numbers,
    figures), every one checked, and torch found, before any folder is made."""
    try:
        check_utf8(args)
        seeds = _check_flags(args)
        settings = build_settings(args)
        import gymnasium as gym

        from ilpss.experiments.drill_facts import ENV_ID
        for team in args.teams:  # an unknown team: the drill's error, naming the known ones
            gym.make(ENV_ID, opponent=team, disable_env_checker=True).close()
        if args.executor == "ray":
            check_ray_address(args.ray_address)
    except (ValueError, drill_exception(TEAM_ERROR)) as exc:
        p.error(str(exc))
    try:
        import sb3_contrib  # noqa: F401
        import torch  # noqa: F401
    except ImportError as exc:
        p.error(f"{exc}: the reference runs need torch, Stable-Baselines3 and sb3-contrib: "
                "pip install 'soccer-drill-ilpss[integrations]'")
    try:
        check_executor(args.executor)
        out = check_out_file(args.out, suffix=".md")
        summary = check_out_file(args.summary or out.with_name(f"{out.stem}_seeds.json.gz"),
                                 "--summary", ".json.gz")
        figures = check_out_dir(args.figures or out.parent / "figures", "--figures",
                                run_folder=False)
        keep = check_out_dir(args.keep, "--keep", run_folder=False)
    except ValueError as exc:
        p.error(str(exc))
    return seeds, settings, out, keep, summary, figures


def _rule_teams(jobs: list[Job]) -> list[str]:
    """The teams the fixed rules are evaluated against: every job's, and the paper's when
    defenders are learnt (what the paper's teams allow is their bar)."""
    teams = [j.team for j in jobs if j.team] + [t for j in jobs if j.team is None for t in j.teams]
    if any(j.attacks for j in jobs):
        teams += list(PAPER_TEAMS)
    return list(dict.fromkeys(teams))


def _main(argv: Sequence[str] | None) -> int:
    p = parser()
    args = p.parse_args(argv)
    seeds, settings, out, keep, summary_path, figures = _checked(p, args)
    ev = EvalSettings(episodes=args.eval)
    jobs = make_jobs(settings, args.teams, seeds, ev, args.attacks, args.first_seed)
    names = sorted(drill_object(HOLDER_RULES))
    stop_on_sigterm()
    start = time.perf_counter()
    try:
        pool = make_executor(args.executor, args.workers, address=args.ray_address)
    except (ImportError, ValueError) as exc:
        p.error(str(exc))
    kept = KeptJobs(keep, allow_mixed_code=args.allow_mixed_code, libraries=library_versions())
    print(f"{len(jobs)} job(s) of {len(settings)} setting(s); each prints its progress, and "
          "the bar estimates the time left", file=sys.stderr)
    try:
        with kept.held():
            fixed, _ = run_kept(pool, rule_rewards,
                                [(t, HOLDER_RULES, n, args.eval) for t in _rule_teams(jobs)
                                 for n in names],
                                "rule", rule_key, kept, desc="fixed rules", check=check_rule_result)
            results, loaded = run_kept(pool, run_job, jobs, KIND, job_key, kept,
                                       desc="reference jobs", check=check_result)
    except (KeptJobsFailed, FolderInUseError, ValueError, OSError) as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 1
    computed = len(jobs) - loaded
    print(f"{computed} job(s) computed, {loaded} loaded from {keep}")
    took = f"{(time.perf_counter() - start) / 60:.1f} min with {args.workers} worker(s)"
    if loaded:
        took += f", {loaded} of its {len(jobs)} jobs kept from an earlier run"
    rules: dict[str, dict[str, list[float]]] = {}
    for r in fixed:
        rules.setdefault(r["team"], {})[r["rule"]] = r["eval"]
    from ilpss.reference.page import learning_md_rows, save_summary, summarise, write_page
    try:
        summary = summarise(jobs, results, rules, learning_md_rows(_learning_page(args)), ev,
                            PAPER_TEAMS)
        text = write_page(command(p, args), code_line({"code": c} for c in kept.codes.values()),
                          took, jobs, results, summary, figures, out)
        save_summary(summary, summary_path)
        atomic_write_bytes(out, text.encode())
    except OSError as exc:
        print(f"{PROG}: error: {unwritten_report(keep, exc)}", file=sys.stderr)
        return 1
    print(f"page written to {out}, its per-seed numbers to {summary_path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
