"""What standard deep-RL learners reach on the drill, beside the fixed rules and ILPSS.

    soccer-drill-reference --out docs/reference_rl_results.md

Trains, evaluates and plots every setting of :data:`~ilpss.reference.settings.SETTINGS`
(``--settings``): SB3's PPO and sb3-contrib's MaskablePPO on the holder against each team
(``--teams``: the paper's four; ``chasers`` is ``interceptors_press`` cycle for cycle,
so its rows would repeat that team's), a shared masked PPO for the two
attackers of the parallel drill against each team, one self-play run of all four players
(its attackers then evaluated against each team), and the transfer row (PPO fine-tuned
after the paper's first three teams against learning anew, on the fourth: protocol A's
order). ``--seeds N`` training seeds each, or more for some settings (``--seeds 5
ppo=10``); seed ``s`` trains from episode seed
``1,000,000 (s + 1)``); each greedy policy is evaluated on ``--eval`` held-out episode
seeds, the same ones every fixed holder rule is evaluated on.

Each job (a setting, a team, a seed) is kept in ``--keep`` as soon as it ends
(:mod:`ilpss.experiments.kept_jobs`: a JSON record with schema and SHA-256, written
atomically, naming the code that computed it): the same command loads the finished jobs
and computes only what is left, and a changed setting is a new job. ``--ppo KEY=VALUE``
changes a field of every selected setting's PPO configuration (for a small run), and
``--timeout-reward`` the holder's reward
(:class:`~ilpss.reference.settings.RewardOption`, off by default), ``--timeout-bootstrap``
SB3's treatment of the drill's timeout (see
:class:`~ilpss.reference.settings.HolderSetting`); each is recorded in every result and
shown in the page's command.

Needs ``pip install -e ".[integrations]"`` (torch); the parser and the checks of the flags
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
from ilpss.experiments.drill import HOLDER_RULES, PAPER_TEAMS, TEAM_ERROR, drill_exception
from ilpss.experiments.executor import LocalExecutor, stop_on_sigterm, stopped_in_one_line
from ilpss.experiments.holder_learning import check_rule_result, rule_key, rule_rewards
from ilpss.experiments.kept_jobs import KeptJobs, KeptJobsFailed, run_kept
from ilpss.experiments.outputs import check_out_dir, check_out_file, check_utf8, unwritten_report
from ilpss.experiments.provenance import code_line
from ilpss.reference.jobs import KIND, Job, check_result, job_key, run_job
from ilpss.reference.settings import (
    SETTINGS,
    EvalSettings,
    HolderSetting,
    PPOConfig,
    RewardOption,
    SelfPlaySetting,
    TransferSetting,
)

PROG = "soccer-drill-reference"
DEFAULT_TEAMS = PAPER_TEAMS
PPO_FIELDS = {f.name: f.type for f in dataclasses.fields(PPOConfig)}


def parse_ppo(items: Sequence[str]) -> dict[str, Any]:
    """``["steps=512", "net_arch=32,32"]`` as PPOConfig fields; ``ValueError`` naming a
    field that is not one, or a value that is not a number."""
    out: dict[str, Any] = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not sep or name not in PPO_FIELDS:
            raise ValueError(f"--ppo {item!r}: give KEY=VALUE with KEY one of {sorted(PPO_FIELDS)}")
        try:
            if name == "net_arch":
                out[name] = tuple(int(w) for w in text.split(","))
            elif "int" in str(PPO_FIELDS[name]):
                out[name] = int(text)
            else:
                out[name] = float(text)
        except ValueError:
            raise ValueError(f"--ppo {item!r}: {name} takes "
                             f"{'widths such as 64,64' if name == 'net_arch' else 'a number'}"
                             ) from None
    return out


def build_settings(args: argparse.Namespace) -> dict[str, Any]:
    """The selected settings with the flags' changes, checked by the dataclasses."""
    ppo = parse_ppo(args.ppo)
    reward = RewardOption(args.timeout_reward)

    def holder(h: HolderSetting) -> HolderSetting:
        return dataclasses.replace(h, ppo=dataclasses.replace(h.ppo, **ppo), reward=reward,
                                   timeout_terminal=not args.timeout_bootstrap)

    out = {}
    for name in args.settings:
        s = SETTINGS[name]
        if isinstance(s, HolderSetting):
            s = holder(s)
        elif isinstance(s, TransferSetting):
            s = dataclasses.replace(s, holder=holder(s.holder), source_steps=args.source_steps
                                    or s.source_steps, target_episodes=args.target_episodes
                                    or s.target_episodes, window=args.window or s.window)
        else:
            s = dataclasses.replace(s, ppo=dataclasses.replace(s.ppo, **ppo))
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
              ev: EvalSettings) -> list[Job]:
    """Every job, seed by seed (so that a stopped run has every setting's first seeds);
    ``seeds`` by setting name."""
    jobs = []
    for seed in range(max(seeds.values())):
        for name, s in settings.items():
            if seed >= seeds[name]:
                continue
            if isinstance(s, TransferSetting):
                jobs.append(Job(name, s, seed, PAPER_TEAMS[-1], tuple(PAPER_TEAMS[:-1]), ev))
            elif isinstance(s, SelfPlaySetting):
                jobs.append(Job(name, s, seed, None, tuple(teams), ev))
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


def parser() -> argparse.ArgumentParser:
    """The command-line parser of ``soccer-drill-reference``."""
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.splitlines()[0])
    p.add_argument("--settings", nargs="+", choices=list(SETTINGS), default=list(SETTINGS),
                   help="the settings to run (default: all, in this order)")
    p.add_argument("--teams", nargs="+", default=list(DEFAULT_TEAMS),
                   help="distinct opponent teams of the per-team settings (default: the "
                        "paper's four); the transfer row always takes the paper's")
    p.add_argument("--seeds", nargs="+", default=["10"], metavar="N [SETTING=N]",
                   help="training seeds per setting and team, and optionally more or fewer "
                        "for named settings, e.g. 5 ppo=10 (default: 10)")
    p.add_argument("--eval", type=int, default=EvalSettings.episodes,
                   help="held-out evaluation episodes per policy (default: %(default)s)")
    p.add_argument("--ppo", nargs="+", default=[], metavar="KEY=VALUE",
                   help=f"change a field of every selected setting's PPO configuration "
                        f"({', '.join(PPO_FIELDS)})")
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
                   help="transfer: episodes of the jumpstart and of the final (default: the setting's)")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--out", default="results/reference_rl.md",
                   help="the markdown page to write (default: %(default)s)")
    p.add_argument("--figures", default=None, metavar="DIR",
                   help="where the figures go (default: a folder figures beside --out)")
    p.add_argument("--keep", default="results/reference_rl", metavar="DIR",
                   help="folder where each finished job is kept as it ends; the same command "
                        "loads them and computes only what is left (default: %(default)s)")
    p.add_argument("--learning-page", default="docs/learning.md",
                   help="the tile-coded learners' page whose final row is shown beside")
    p.add_argument("--allow-mixed-code", action="store_true",
                   help="use kept jobs that other code computed (refused otherwise)")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run the reference jobs and write the page."""
    with stopped_in_one_line(PROG):
        return _main(argv)


def _check_flags(args: argparse.Namespace) -> dict[str, int]:
    """Refuse bad flags; the training seeds of each selected setting."""
    if len(set(args.teams)) != len(args.teams):
        raise ValueError(f"--teams must not repeat a team, got {args.teams}")
    if len(set(args.settings)) != len(args.settings):
        raise ValueError(f"--settings must not repeat a setting, got {args.settings}")
    every, per = parse_seeds(args.seeds)
    if unselected := sorted(set(per) - set(args.settings)):
        raise ValueError(f"--seeds names {unselected}, which --settings does not select")
    seeds = {name: per.get(name, every) for name in args.settings}
    for flag, value, low in (("--seeds", every, 2), *((f"--seeds {name}=N", n, 2)
                                                      for name, n in per.items()),
                             ("--eval", args.eval, 1), ("--workers", args.workers, 1)):
        if value < low:
            raise ValueError(f"{flag} must be at least {low}, got {value}")
    for flag in ("source_steps", "target_episodes", "window"):
        value = getattr(args, flag)
        if value is not None and value < 1:
            raise ValueError(f"--{flag.replace('_', '-')} must be at least 1, got {value}")
    return seeds


def _main(argv: Sequence[str] | None) -> int:
    p = parser()
    args = p.parse_args(argv)
    try:
        check_utf8(args)
        seeds = _check_flags(args)
        settings = build_settings(args)
        out = check_out_file(args.out)
        figures = Path(args.figures) if args.figures else out.parent / "figures"
        keep = check_out_dir(args.keep, "--keep", run_folder=False)
        import gymnasium as gym

        from ilpss.experiments.drill import ENV_ID
        for team in args.teams:  # an unknown team: the drill's error, naming the known ones
            gym.make(ENV_ID, opponent=team, disable_env_checker=True).close()
    except (ValueError, drill_exception(TEAM_ERROR)) as exc:
        p.error(str(exc))
    try:
        import sb3_contrib  # noqa: F401
        import torch  # noqa: F401
    except ImportError as exc:
        p.error(f"{exc}: the reference runs need torch, Stable-Baselines3 and sb3-contrib: "
                "pip install -e '.[integrations]'")
    ev = EvalSettings(episodes=args.eval)
    jobs = make_jobs(settings, args.teams, seeds, ev)
    rule_teams = list(dict.fromkeys(
        [j.team for j in jobs if j.team] + [t for j in jobs if j.team is None for t in j.teams]))
    from ilpss.experiments.drill import drill_object
    names = sorted(drill_object(HOLDER_RULES))
    stop_on_sigterm()
    start = time.perf_counter()
    pool = LocalExecutor(args.workers)
    kept = KeptJobs(keep, allow_mixed_code=args.allow_mixed_code)
    try:
        with kept.held():
            fixed, _ = run_kept(pool, rule_rewards,
                                [(t, HOLDER_RULES, n, args.eval) for t in rule_teams for n in names],
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
    from ilpss.reference.page import learning_md_rows, write_page
    try:
        text = write_page(command(p, args), code_line({"code": c} for c in kept.codes.values()),
                          took, jobs, results, rules, learning_md_rows(Path(args.learning_page)),
                          ev, figures, out)
        atomic_write_bytes(out, text.encode())
    except OSError as exc:
        print(f"{PROG}: error: {unwritten_report(keep, exc)}", file=sys.stderr)
        return 1
    print(f"page written to {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
