"""``ilpss-results``: run (or resume) protocols A, R, B and C and regenerate ``docs/results.md``.

    ilpss-results                                   # the documented run (A: 30 seeds, R, B, C: 10)
    ilpss-results --protocols A                     # only A; the other sections are kept
    ilpss-results --runs /tmp/r --docs /tmp/d --seeds-a 2 --seeds-b 2 --seeds-c 2 \\
        --episodes 4 --rollouts 2 --stream-length 3 --teams interceptors_press goal_guards

Read top to bottom: :func:`main` builds each chosen protocol's configuration
(:func:`protocol_config`, from :data:`PAGE`; the learner's settings are
``ExperimentConfig``'s defaults), runs or resumes it into ``<runs>/protocol_x`` (a
finished job is never run again; a folder holding another configuration is refused),
writes that folder's ``report.md``, and then assembles ``<docs>/results.md``: per
protocol the command that regenerates it (:func:`command_for`), its saved configuration
(copied to ``<docs>/results/``), its wall time, and the section that the protocol writes
(:func:`ilpss.experiments.sections.page_section`: figures copied to
``<docs>/figures/``, tables and verdicts, all computed from the result files). A protocol not chosen with
``--protocols`` keeps its section if its folder holds a finished run.
"""

from __future__ import annotations

import argparse
import json
import shlex
import tempfile
import time
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from ilpss._io import MAX_JSON_BYTES, FolderInUseError, atomic_write_bytes, read_regular
from ilpss.experiments.checkpoints import StorageError
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.drill_facts import (
    PAPER_TEAMS,
    REGION_SOURCES,
    REGION_TARGETS,
    TEAM_ERROR,
    drill_exception,
)
from ilpss.experiments.executor import stop_on_sigterm, stopped_in_one_line
from ilpss.experiments.folder import RunFolder
from ilpss.experiments.outputs import check_out_dir, check_utf8, description, unwritten_report
from ilpss.experiments.protocols import PROTOCOLS as PROTOCOLS_REGISTRY
from ilpss.experiments.provenance import code_line, code_record
from ilpss.experiments.report import write_report
from ilpss.experiments.report_text import counted, doc_reference, label, metrics_note
from ilpss.experiments.run import JobError, load_result, read_config, run_experiment
from ilpss.experiments.sections import page_section
from ilpss.experiments.seed_data import SeedData

PAGE = {
    "A": {"teams": "teams", "targets": "targets"},
    "R": {"teams": REGION_SOURCES, "targets": REGION_TARGETS,
          "methods": (*ExperimentConfig().methods, "ilpss_ft_oracle")},
    "B": {"teams": "teams", "n_shuffles": "shuffles"},
    "C": {"stream_length": "stream_length",
          "methods": (*ExperimentConfig().methods, "ilpss_plus_no_discount")},
}
"""The protocols of the page, in its order, and the fields of each configuration that the
page sets: from the named argument, or to the given value. Protocol C also runs ILPSS+
without option discounting, to measure what discounting costs; protocol R (targets
composed by region) also the oracle arm whose kernels are the true regions. Everything else
is ``ExperimentConfig``'s default."""
PROTOCOLS = tuple(PAGE)
DEFAULT_RUNS, DEFAULT_DOCS = "results", "docs"


def parser() -> argparse.ArgumentParser:
    """The command-line parser of ``ilpss-results``."""
    p = argparse.ArgumentParser(
        prog="ilpss-results", description=description(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__,
    )
    p.add_argument("--runs", default=DEFAULT_RUNS,
                   help="folder of the runs, one subfolder per protocol (default: results)")
    p.add_argument("--docs", default=DEFAULT_DOCS,
                   help="where results.md, figures/ and results/ go (default: docs)")
    p.add_argument("--protocols", nargs="+", choices=PROTOCOLS, default=list(PROTOCOLS),
                   help=f"protocols to run or resume (default: {' '.join(PROTOCOLS)}); the sections of the "
                        "others are kept if their runs are finished")
    p.add_argument("--seeds-a", type=int, default=30, help="protocol A seeds (default 30)")
    p.add_argument("--seeds-b", type=int, default=10, help="protocol B seeds (default 10)")
    p.add_argument("--seeds-c", type=int, default=10, help="protocol C seeds (default 10)")
    p.add_argument("--seeds-r", type=int, default=10, help="protocol R seeds (default 10)")
    p.add_argument("--episodes", type=int, default=300,
                   help="learning episodes per opponent (default 300)")
    p.add_argument("--rollouts", type=int, default=None,
                   help="greedy rollouts per trial (default: ExperimentConfig's, 50)")
    p.add_argument("--shuffles", type=int, default=1,
                   help="protocol B: shuffled source orders per held-out team (default 1)")
    p.add_argument("--stream-length", type=int, default=20,
                   help="protocol C: opponents in the stream (default 20)")
    p.add_argument("--teams", nargs="+", default=list(PAPER_TEAMS),
                   help="protocols A and B: the teams, the last one held out in A unless "
                        "--targets are given (default: the paper's four)")
    p.add_argument("--targets", nargs="+", default=[],
                   help="protocol A: held-out teams, each learnt from the state after all of "
                        "--teams (default: none, the last team is held out)")
    p.add_argument("--workers", type=int, default=2, help="parallel jobs (default 2)")
    p.add_argument("--allow-mixed-code", action="store_true",
                   help="use or resume runs whose results were made by other code (refused "
                   "otherwise); the page names every version of the code it mixes")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.add_argument("--from-data", metavar="STEM",
                   help="run nothing: regenerate the page from the per-seed numbers "
                        "STEM.csv.gz and STEM.json (what <docs>/data/results holds); the "
                        "kernels and GIFs, which need the runs' checkpoints, are left out")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run or resume the chosen protocols and regenerate ``<docs>/results.md``."""
    with stopped_in_one_line("ilpss-results"):  # Ctrl-C or SIGTERM: one line, 130 or 143
        return _main(argv)


def _main(argv: Sequence[str] | None) -> int:
    p = parser()
    args = p.parse_args(argv)
    try:  # every input, output and configuration checked before any work or folder
        check_utf8(args)
        chosen = {protocol: protocol_config(protocol, args) for protocol in args.protocols}
        kept = _results_data(args.from_data) if args.from_data else None
        # the page from kept numbers runs nothing: no folder of runs is made for it
        runs = Path(args.runs) if kept is not None else check_out_dir(
            args.runs, "--runs", run_folder=False)
        docs = check_out_dir(args.docs, "--docs", run_folder=False)
        for sub in ("figures", "results", "data"):
            check_out_dir(docs / sub, "--docs", run_folder=False)
    except ValueError as exc:
        p.error(str(exc))
    if kept is not None:
        with tempfile.TemporaryDirectory() as scratch:  # the reports' figures, discarded
            folders = {protocol: Path(scratch) / protocol for protocol in kept.configs}
            for folder in folders.values():
                folder.mkdir()
            return _write_page(p, args, kept, folders, docs, runs)
    stop_on_sigterm()
    data = _run(p, args, chosen, runs)
    stem = docs / "data" / "results"
    try:  # the page is computed from the numbers kept, as --from-data computes it
        data.write(stem)
        data = SeedData.read(stem)
    except (ValueError, OSError) as exc:
        p.exit(1, f"{p.prog}: error: {exc}\n")
    folders = {protocol: runs / f"protocol_{protocol.lower()}" for protocol in data.configs}
    return _write_page(p, args, data, folders, docs, runs)


def _results_data(stem: str) -> SeedData:
    """The per-seed numbers ``stem`` of ``--from-data``, refused (``ValueError``) if they
    cannot be read or are another experiment's: the results page's are protocols of
    :data:`PAGE`, each with the page's methods in the paper's drill."""
    try:
        data = SeedData.read(stem)
    except OSError as exc:
        raise ValueError(f"--from-data {stem}: {exc.strerror or exc}"
                         f"{f' ({exc.filename})' if exc.filename else ''}") from None
    expected = "protocols A, R, B and C of ilpss-results, as <docs>/data/results holds them"
    other = [protocol for protocol in data.configs if protocol not in PAGE]
    if other:
        raise ValueError(f"--from-data {stem}: another experiment's data: it holds protocol(s) "
                         f"{', '.join(other)}, which ilpss-results does not run; expected "
                         f"{expected}")
    default = ExperimentConfig()
    for protocol, cfg in data.configs.items():
        methods = tuple(PAGE[protocol].get("methods", default.methods))
        if tuple(cfg.methods) != methods or cfg.scenario != default.scenario:
            raise ValueError(
                f"--from-data {stem}: another experiment's data: its protocol {protocol} runs "
                f"{', '.join(cfg.methods)} in {cfg.scenario}, where ilpss-results runs "
                f"{', '.join(methods)} in {default.scenario}; expected {expected}")
    return data


def _run(p: argparse.ArgumentParser, args: argparse.Namespace,
         chosen: dict[str, ExperimentConfig], runs: Path) -> SeedData:
    """Run or resume the chosen protocols; keep the finished runs of the others."""
    configs: dict[str, ExperimentConfig] = {}
    jobs: dict[str, list[dict[str, Any]]] = {}
    times: dict[str, dict[str, Any] | None] = {}
    for protocol in PROTOCOLS:
        folder = RunFolder(runs / f"protocol_{protocol.lower()}")
        if protocol in chosen:
            cfg = chosen[protocol]
            try:
                results = run_timed(cfg, folder, progress=not args.quiet,
                                    allow_mixed_code=args.allow_mixed_code)
            except (FolderInUseError, StorageError, JobError, ValueError, OSError,
                    drill_exception(TEAM_ERROR)) as exc:  # TeamError: a team fails to load
                p.exit(1, f"{p.prog}: error: protocol {protocol}: {exc}\n")
        else:  # keep the section of an earlier, finished run
            if not folder.config.exists():
                continue
            cfg = read_config(folder.config)
            try:
                results = finished_results(cfg, folder, args.allow_mixed_code)
            except ValueError as exc:  # another code's results, or a damaged file
                p.exit(1, f"{p.prog}: error: protocol {protocol}: {exc}\n")
            if results is None:
                print(f"protocol {protocol}: {folder.root} is unfinished; its section is left out")
                continue
        configs[protocol], jobs[protocol] = cfg, results
        times[protocol] = folder.wall_time() or _span(cfg, folder)
    return SeedData(configs, jobs, times)


def _write_page(p: argparse.ArgumentParser, args: argparse.Namespace, data: SeedData,
                folders: dict[str, Path], docs: Path, runs: Path) -> int:
    """Each protocol's report (into its folder) and section, and the page, all from
    ``data``."""
    configs = {protocol: data.configs[protocol] for protocol in PROTOCOLS
               if protocol in data.configs}
    sections: list[str] = []
    for protocol, cfg in configs.items():
        results, folder = data.results(protocol), folders[protocol]
        command = command_for({protocol: cfg}, args.runs, args.docs)
        config_copy = docs / "results" / f"protocol_{protocol.lower()}_config.json"
        try:
            write_report(cfg, results, folder, command=command or "(see config.json)")
            run_config = RunFolder(folder).config
            if run_config.is_file():  # as the run wrote it, run-only fields included
                saved = read_regular(run_config, MAX_JSON_BYTES)
            else:  # from the numbers kept: the fields that decide the results
                saved = json.dumps({**cfg.to_dict(), "code": results[0]["code"]},
                                   indent=2).encode()
            atomic_write_bytes(config_copy, saved)
            sections += [*header(cfg, data.wall_times.get(protocol), command, config_copy.name),
                         *page_section(cfg, results, folder, docs)]
        except OSError as exc:  # a full disk: the results stay, a rerun writes the pages
            p.exit(1, f"{p.prog}: error: protocol {protocol}: "
                      f"{unwritten_report(folder, exc)}\n")
    every_result = [r for protocol in configs for r in data.results(protocol)]
    text = [*intro(configs, args.runs, args.docs), code_line(every_result), "", *sections]
    path = docs / "results.md"
    try:
        atomic_write_bytes(path, ("\n".join(text).rstrip() + "\n").encode())
    except OSError as exc:
        p.exit(1, f"{p.prog}: error: {unwritten_report(runs, exc)}\n")
    print(f"results: {path}")
    return 0


# ---------------------------------------------------------------- configurations and runs
def protocol_config(protocol: str, args: argparse.Namespace) -> ExperimentConfig:
    """One protocol's configuration from the arguments; everything else (the learner's
    settings included) is ``ExperimentConfig``'s default."""
    changes: dict[str, Any] = {
        "n_seeds": getattr(args, f"seeds_{protocol.lower()}"), "workers": args.workers,
    }
    for field, value in PAGE[protocol].items():
        changes[field] = getattr(args, value) if isinstance(value, str) else value
    for name in ("teams", "targets"):
        if name in changes:
            changes[name] = tuple(changes[name])
    lifelong: dict[str, Any] = {"train_episodes": args.episodes}
    if args.rollouts is not None:
        lifelong["rollout_episodes"] = args.rollouts
    return ExperimentConfig(protocol=protocol).with_overrides(**changes, lifelong=lifelong)


def command_for(configs: dict[str, ExperimentConfig], runs: str, docs: str) -> str | None:
    """The ``ilpss-results`` command that runs exactly these configurations, or ``None``
    if the arguments cannot express them (checked by parsing the command back)."""
    argv = []
    if runs != DEFAULT_RUNS:
        argv += ["--runs", runs]
    if docs != DEFAULT_DOCS:
        argv += ["--docs", docs]
    if sorted(configs) != list(PROTOCOLS):
        argv += ["--protocols", *sorted(configs)]
    argv += [a for p, cfg in sorted(configs.items()) for a in (f"--seeds-{p.lower()}",
                                                               str(cfg.n_seeds))]
    episodes = {cfg.lifelong.train_episodes for cfg in configs.values()}
    rollouts = {cfg.lifelong.rollout_episodes for cfg in configs.values()}
    teams = {cfg.teams for p, cfg in configs.items() if isinstance(PAGE[p].get("teams"), str)}
    if len(episodes) > 1 or len(rollouts) > 1 or len(teams) > 1:
        return None
    argv += ["--episodes", str(episodes.pop()), "--rollouts", str(rollouts.pop())]
    if teams and teams != {PAPER_TEAMS}:
        argv += ["--teams", *next(iter(teams))]
    targets = [cfg.targets for p, cfg in configs.items()
               if isinstance(PAGE[p].get("targets"), str)]
    if targets and targets[0]:
        argv += ["--targets", *targets[0]]
    for field, flag in (("n_shuffles", "shuffles"), ("stream_length", "stream_length")):
        values = {getattr(cfg, field) for p, cfg in configs.items() if field in PAGE[p]}
        if len(values) > 1:
            return None
        if values:
            argv += [f"--{flag.replace('_', '-')}", str(values.pop())]
    args = parser().parse_args(argv)
    for p, cfg in configs.items():
        if protocol_config(p, args) != replace(cfg, workers=args.workers, executor="local",
                                               storage=None):
            return None
    return "ilpss-results " + " ".join(shlex.quote(a) for a in argv)


def job_files(cfg: ExperimentConfig, folder: RunFolder) -> list[Path]:
    """The ``result.json`` of every job of ``cfg``."""
    return [folder.result(seed, index)
            for seed in cfg.seeds for index in range(len(cfg.streams(seed)))]


def finished_results(
    cfg: ExperimentConfig, folder: RunFolder, allow_mixed_code: bool = False,
) -> list[dict[str, Any]] | None:
    """Every job's result (checked, and made by this code unless ``allow_mixed_code``) if
    all are finished, else ``None`` (nothing is run)."""
    if not all(f.exists() for f in job_files(cfg, folder)):
        return None
    return [load_result(folder.result(seed, index), cfg, seed, index, stream,
                        code=code_record(), allow_mixed_code=allow_mixed_code)
            for seed in cfg.seeds for index, stream in enumerate(cfg.streams(seed))]


def run_timed(cfg: ExperimentConfig, folder: RunFolder, progress: bool,
              allow_mixed_code: bool = False) -> list[dict[str, Any]]:
    """:func:`run_experiment`, adding its wall time to the folder's timing record when it
    finished jobs (also when interrupted after some); a finished run adds nothing."""
    todo = [f for f in job_files(cfg, folder) if not f.exists()]
    start = time.perf_counter()
    try:
        return run_experiment(cfg, folder.root, progress=progress,
                              allow_mixed_code=allow_mixed_code)
    finally:
        if any(f.exists() for f in todo):
            folder.add_wall_time(time.perf_counter() - start, cfg.workers, cfg.executor)


def _span(cfg: ExperimentConfig, folder: RunFolder) -> dict[str, Any]:
    """For a run made without ``ilpss-results``: the span from its ``config.json`` to its
    last ``result.json`` (pauses included), as a timing record with executor ``None``."""
    last = max(f.stat().st_mtime for f in job_files(cfg, folder))
    return {"seconds": max(0.0, last - folder.config.stat().st_mtime),
            "workers": cfg.workers, "executor": None}


def wall_time(record: dict[str, Any] | None, command: str = "ilpss-results") -> str:
    """A run's wall time in words, from its timing record (kept by ``command``)."""
    if record is None:
        return "not recorded"
    if record["executor"] is None:
        return (f"not recorded (run without `{command}`); {_duration(record['seconds'])} "
                "from its `config.json` to its last `result.json`, pauses included")
    return (f"{_duration(record['seconds'])} with {record['workers']} {record['executor']} "
            f"worker(s), summed over the `{command}` invocations that finished jobs")


def _duration(seconds: float) -> str:
    return f"{seconds / 60:.1f} min" if seconds >= 60 else f"{seconds:.0f} s"


# ---------------------------------------------------------------- the page
def intro(configs: dict[str, ExperimentConfig], runs: str, docs: str) -> list[str]:
    """The page's head: what generated it, how to regenerate all of it, the metrics."""
    command = command_for(configs, runs, docs) if configs else None
    every = (f"Regenerate the whole page (resuming the runs in `{runs}/`): `{command}`."
             if command else "Regenerate each section with the command written in it.")
    return [
        "# Results", "",
        "This page is generated by `ilpss-results` (`ilpss/experiments/results_doc.py`) "
        "from the result files of the runs; do not edit it by hand. Every number, table, "
        "figure and verdict below is computed from those files. What they mean, and what "
        f"to try next, is discussed in {doc_reference('discussion.md', docs)}.", "",
        every, "",
        metrics_note(_episodes(configs), docs), "",
    ]


def _episodes(configs: dict[str, ExperimentConfig]) -> int | None:
    """The learning episodes per task of every configuration, if they agree."""
    episodes = {cfg.lifelong.train_episodes for cfg in configs.values()}
    return episodes.pop() if len(episodes) == 1 else None


def header(cfg: ExperimentConfig, timing: dict[str, Any] | None, command: str | None,
           config_name: str) -> list[str]:
    """A protocol's title, what it does, its command, configuration and wall time."""
    protocol = PROTOCOLS_REGISTRY.get(cfg.protocol)
    lc = cfg.lifelong
    budget = (f"{counted(cfg.n_seeds, 'seed')}, "
              f"{counted(lc.train_episodes, 'learning episode')} per opponent, "
              f"{counted(lc.rollout_episodes, 'greedy rollout')} per trial for the traces, "
              f"{counted(lc.n_kernels, 'kernel')}.")
    shown = f"`{command}`" if command else "not expressible as an `ilpss-results` command"
    return [
        f"## Protocol {protocol.name}: {protocol.title}", "", protocol.describe(cfg),
        f"Methods: {', '.join(label(m) for m in cfg.methods)}; each is compared with "
        f"{label(cfg.baseline)}, and with every other.", budget, "",
        f"- Command: {shown}",
        f"- Configuration: [`results/{config_name}`](results/{config_name})",
        f"- Wall time: {wall_time(timing)}", "",
    ]


if __name__ == "__main__":
    raise SystemExit(main())
