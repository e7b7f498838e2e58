r"""Command line: ``ilpss-experiment`` runs a protocol (A, B, C, L, R or S) and writes its report.

Examples::

    ilpss-experiment --protocol A --seeds 30 --out results/protocol_a
    ilpss-experiment --protocol C --seeds 10 --episodes 200 --out results/protocol_c
    # the paper's teams in the 3 v 2 drill
    ilpss-experiment --protocol A --scenario drill_3v2 --methods scratch ilpss \
        --out results/protocol_a_3v2
    ilpss-experiment --config results/protocol_a/config.json --out results/protocol_a  # resume
    # the paper's three sources learnt once per seed, then each of three targets from there
    ilpss-experiment --protocol A --teams interceptors_press interceptors_cover \
        interceptor_guard --targets goal_guards chasers parametric --out results/targets
    # on a running Ray cluster, checkpoints where every node reaches them
    ilpss-experiment --executor ray --ray-address HEAD:6379 --workers 16 \
        --storage s3://bucket/ilpss/protocol_a --out results/protocol_a
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path

from ilpss._io import FolderInUseError
from ilpss.experiments.checkpoints import StorageError
from ilpss.experiments.config import TRAIN_EPISODES, ExperimentConfig
from ilpss.experiments.drill_facts import TEAM_ERROR, drill_exception, scenario_names
from ilpss.experiments.executor import check_executor, stop_on_sigterm, stopped_in_one_line
from ilpss.experiments.methods import METHODS
from ilpss.experiments.outputs import check_utf8, description, unwritten_report
from ilpss.experiments.protocols import PROTOCOLS
from ilpss.experiments.run import JobError, read_config, run_experiment
from soccer_drill.constraints import check


def build_config(args: argparse.Namespace) -> ExperimentConfig:
    """The configuration from ``--config`` (if given) with the other flags on top."""
    if args.config:
        try:
            cfg = read_config(Path(args.config))
        except ValueError as exc:
            raise ValueError(f"--config {exc}") from exc
        if cfg.storage is not None and args.storage is None:  # a file never leads a write
            raise ValueError(  # outside its folder: the command line says where, again
                f"--config {args.config} sets storage to {cfg.storage!r}; where checkpoints "
                f"are written is never taken from a file: give --storage {cfg.storage} on "
                "the command line to write there")
    else:
        cfg = ExperimentConfig(protocol=args.protocol or "A")
    flags = {"protocol": "protocol", "seeds": "n_seeds", "first_seed": "first_seed",
             "methods": "methods", "workers": "workers", "executor": "executor",
             "stream_length": "stream_length", "teams": "teams", "targets": "targets",
             "storage": "storage", "baseline": "baseline", "featured": "featured",
             "scenario": "scenario"}
    changes: dict = {field: getattr(args, flag) for flag, field in flags.items()
                     if getattr(args, flag) is not None}
    for role in ("baseline", "featured"):
        if changes.get(role) == "none":
            changes[role] = None
    repeated = [m for i, m in enumerate(args.methods or ()) if m in args.methods[:i]]
    if repeated:  # said as the flag: which method, and that each is given once
        raise ValueError(f"--methods: {repeated[0]!r} is given twice; name each method once")
    methods = changes.get("methods", cfg.methods)
    if args.no_report and "baseline" not in changes and cfg.baseline not in methods:
        changes["baseline"] = None  # an ablation run, compared by ilpss-compare
    if args.episodes is not None:  # said as the flag, with what an experiment allows
        check("--episodes", args.episodes, TRAIN_EPISODES)
    lifelong: dict = {field: getattr(args, flag) for flag, field in
                      (("episodes", "train_episodes"), ("rollouts", "rollout_episodes"))
                      if getattr(args, flag) is not None}
    given: set[str] = set()
    for item in args.set or ():
        key, value = _setting(item)
        if key in given:  # as a JSON object's repeated key: which one was meant?
            raise ValueError(f"--set {key} is given twice; give each setting once")
        given.add(key)
        flag = {"train_episodes": "--episodes", "rollout_episodes": "--rollouts"}.get(key)
        if flag is not None and key in lifelong:  # which of the two was meant?
            raise ValueError(f"{flag} {lifelong[key]} and --set {item} both set {key}; give "
                             "one of them")
        *path, name = key.split(".")  # learner.alpha, library.discount, n_kernels
        target = lifelong
        for part in path:
            target = target.setdefault(part, {})
            if not isinstance(target, dict):
                raise ValueError(f"--set {key}: {part} is not a group of settings")
        target[name] = value
    if lifelong:
        changes["lifelong"] = lifelong
    return cfg.with_overrides(**changes)


def _setting(item: str) -> tuple[str, object]:
    """``KEY=VALUE`` of ``--set``; the value is read as JSON, else kept as a string."""
    key, sep, text = item.partition("=")
    if not sep or not key:
        raise ValueError(f"--set takes KEY=VALUE (e.g. n_kernels=2), got {item!r}")
    try:
        return key, json.loads(text)
    except json.JSONDecodeError:
        return key, text


def parser() -> argparse.ArgumentParser:
    """The command-line parser of ``ilpss-experiment``."""
    p = argparse.ArgumentParser(
        prog="ilpss-experiment", description=description(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__,
    )
    p.add_argument("--protocol", choices=PROTOCOLS.names(),
                   help="the protocol run (default A, or --config's)")
    p.add_argument("--config", help="a config.json to start from (e.g. to resume a run)")
    p.add_argument("--seeds", type=int, help="number of seeds (default 30)")
    p.add_argument("--first-seed", type=int,
                   help="the first seed; the run uses --seeds seeds from it (default 0)")
    p.add_argument("--episodes", type=int, help="learning episodes per task (default 300; "
                   "not with --set train_episodes)")
    p.add_argument("--rollouts", type=int, help="greedy rollouts per trial (default 50; not "
                   "with --set rollout_episodes)")
    p.add_argument("--stream-length", type=int,
                   help="protocol C: opponents in the stream (default 20)")
    p.add_argument("--methods", nargs="+", choices=METHODS.names(), metavar="METHOD",
                   help="the methods run, each once (default: ExperimentConfig's, or --config's); one of "
                   f"{', '.join(METHODS.names())}")
    p.add_argument("--baseline", metavar="METHOD",
                   help="the method every other is compared with (default scratch: learning "
                   "anew); 'none' for a run without one, which is not reported: give it with "
                   "--no-report (which implies it when --methods leaves the baseline out)")
    p.add_argument("--featured", metavar="METHOD",
                   help="the method whose kernels and GIF the report shows (default: the "
                   "first with ILPSS's kernels)")
    p.add_argument("--teams", nargs="+", metavar="TEAM",
                   help="protocols A and B (and R with --targets): the teams (A: the last one "
                   "is held out, unless --targets are given; then all of them are sources)")
    p.add_argument("--targets", nargs="+", metavar="TEAM",
                   help="protocol A: held-out teams, each learnt from the state after the "
                   "sources (learnt once per seed); results per target and pooled")
    p.add_argument("--scenario", choices=scenario_names(),
                   help="the drill played (default drill_2v2, the paper's); its holder's "
                   "features give the learner's tile widths (protocols A, B and C)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="a LifelongConfig field (or learner.FIELD, library.FIELD), value as "
                   "JSON; repeatable, e.g. --set n_kernels=2 --set learner.intra_option=true "
                   "--set library.continuation_exponent=0.5")
    p.add_argument("--workers", type=int,
                   help="parallel jobs (default 2); on a Ray cluster, the most in flight")
    p.add_argument("--executor", choices=["local", "ray"],
                   help="where the jobs run: local (default), worker processes of this "
                   "machine; ray, a Ray cluster's (see --ray-address)")
    p.add_argument("--ray-address", metavar="ADDRESS",
                   help="with --executor ray: join the running cluster at ADDRESS (default: "
                   "RAY_ADDRESS if set, else start a local Ray instance)")
    p.add_argument("--storage", metavar="PATH_OR_URI",
                   help="where the checkpoints go (default: the run folder); on a cluster, a "
                   "path or URI every node reaches (s3://..., gs://..., file:///...)")
    p.add_argument("--out", required=True, help="output folder (one per run)")
    p.add_argument("--allow-mixed-code", action="store_true",
                   help="resume a run folder whose results were made by other code (refused "
                   "otherwise); the report names every version of the code it mixes")
    p.add_argument("--no-report", action="store_true", help="skip figures and tables")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run the experiment and write its report."""
    with stopped_in_one_line("ilpss-experiment"):  # Ctrl-C or SIGTERM: one line, 130 or 143
        return _main(argv)


def _main(argv: Sequence[str] | None) -> int:
    p = parser()
    args = p.parse_args(argv)
    try:
        if not args.no_report:
            check_utf8(args)
        cfg = build_config(args)
        check_executor(cfg.executor)
    except OSError as exc:
        p.error(f"--config {args.config}: {exc.strerror or exc}")
    except (ValueError, TypeError) as exc:
        p.error(str(exc))
    if args.ray_address is not None and cfg.executor != "ray":
        p.error("--ray-address needs --executor ray")
    if cfg.unreportable is not None and not args.no_report:  # it would fail after the run
        p.error(("a run without a baseline (--baseline none) cannot be reported"
                 if cfg.baseline is None else cfg.unreportable) + ": add --no-report"
                + (", and compare it with another run's baseline by ilpss-compare"
                   if cfg.baseline is None else ""))
    stop_on_sigterm()
    try:
        results = run_experiment(cfg, args.out, progress=not args.quiet,
                                 ray_address=args.ray_address,
                                 on_done=None if args.quiet else _say_resumed,
                                 allow_mixed_code=args.allow_mixed_code)
    except (FolderInUseError, StorageError, JobError, ValueError, OSError,
            drill_exception(TEAM_ERROR)) as exc:
        # another run's folder, a bad file, a failed job, a full disk (naming the file), a
        # team that fails to load
        p.exit(1, f"{p.prog}: error: {exc}\n")
    if not args.no_report:
        from ilpss.experiments.report import write_report

        try:
            path = write_report(cfg, results, args.out)
        except OSError as exc:  # a full disk: the results stay, a rerun writes the report
            p.exit(1, f"{p.prog}: error: {unwritten_report(args.out, exc)}\n")
        except drill_exception(TEAM_ERROR) as exc:  # playing the report's GIF; results stay
            p.exit(1, f"{p.prog}: error: {exc}\n")
        print(f"report: {path}")
    return 0


def _say_resumed(spec, done) -> None:
    """Name the methods of a finished job that resumed from checkpoints."""
    resumed = {m: n for m, n in done.resumed.items() if n}
    if resumed:
        from tqdm.auto import tqdm

        said = ", ".join(f"{m} after {n} trial(s)" for m, n in resumed.items())
        tqdm.write(f"seed {spec.seed}, stream {spec.stream_index}: resumed {said}")


if __name__ == "__main__":
    raise SystemExit(main())
