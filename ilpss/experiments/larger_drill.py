"""``ilpss-larger-drill``: protocol A in a larger drill, and a transfer across sizes, on one page.

    ilpss-larger-drill --runs results/larger_drill            # 30 seeds at 3 v 2, then the page
    ilpss-larger-drill --runs results/larger_drill --finished # the page from the seeds done so far
    ilpss-larger-drill --from-data docs/data/larger_drill     # the page from the kept numbers
    ilpss-larger-drill --runs /tmp/l --docs /tmp/d --seeds 2 --episodes 4 --rollouts 2

Read top to bottom: :func:`larger_drill_config` is protocol A (the paper's four teams,
the last held out) in the scenario ``--scenario`` (default ``drill_3v2``) with learning
anew, fine-tuning from the latest source, whole past policies as options, ILPSS, and the
transfer across sizes (``transfer_2v2``: the sources learnt anew in the paper's 2 v 2
drill, the latest policy carried to this drill by keepaway's inter-task mapping, then
fine-tuned); every other setting is ``ExperimentConfig``'s default. :func:`main` runs or
resumes it into ``--runs`` (a finished job is never run again), keeps its per-seed numbers
in ``<docs>/data/larger_drill.csv.gz`` and ``.json`` and writes ``<docs>/larger_drill.md``
from them (:func:`page`): one section on protocol A in this drill (the four methods, one
family of tests), one on the transfer across sizes against learning anew (its own family)
and against fine-tuning from sources learnt in this drill.
"""

from __future__ import annotations

import argparse
import shlex
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ilpss._io import FolderInUseError, atomic_write_bytes
from ilpss.experiments.checkpoints import StorageError
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.cross_size import keepaway_mapping
from ilpss.experiments.drill_facts import (
    SCENARIO,
    TEAM_ERROR,
    drill_exception,
    holder_drill,
    scenario_names,
)
from ilpss.experiments.executor import stop_on_sigterm, stopped_in_one_line
from ilpss.experiments.folder import RunFolder
from ilpss.experiments.methods import METHODS
from ilpss.experiments.outputs import check_out_dir, check_utf8, description
from ilpss.experiments.provenance import code_line
from ilpss.experiments.report_figures import plot_comparison
from ilpss.experiments.report_stats import collect, compare_to_baseline, target_curves
from ilpss.experiments.report_text import (
    dip_lines,
    headline_table,
    label,
    metrics_note,
    pairwise_lines,
    verdict_lines,
)
from ilpss.experiments.results_doc import run_timed, wall_time
from ilpss.experiments.run import JobError, read_config
from ilpss.experiments.seed_data import SeedData, seed_ranges

DEFAULT_SCENARIO = "drill_3v2"
PROTOCOL_A_METHODS = ("scratch", "finetune", "whole_policies", "ilpss")
"""The methods of the page's first section: learning anew (the baseline), fine-tuning from
the latest source, whole past policies as options and ILPSS."""
TRANSFER = "transfer_2v2"
"""The transfer across sizes (:class:`~ilpss.experiments.methods.CrossSizeMethod`)."""
FINE_TUNING = "finetune"
"""The method the transfer is also compared with: its sources learnt in this drill."""
STEM = "larger_drill"
"""The page is ``<docs>/larger_drill.md``, its numbers ``<docs>/data/larger_drill.*``."""


def parser() -> argparse.ArgumentParser:
    """The command-line parser of ``ilpss-larger-drill``."""
    p = argparse.ArgumentParser(
        prog="ilpss-larger-drill", description=description(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    p.add_argument("--runs", default="results/larger_drill",
                   help="the run folder (default: results/larger_drill)")
    p.add_argument("--docs", default="docs",
                   help="where larger_drill.md, figures/ and data/ go (default: docs)")
    p.add_argument("--scenario", default=DEFAULT_SCENARIO,
                   choices=[s for s in scenario_names() if s != SCENARIO],
                   help=f"the larger drill (default {DEFAULT_SCENARIO})")
    p.add_argument("--seeds", type=int, default=30, help="seeds (default 30)")
    p.add_argument("--first-seed", type=int, default=0,
                   help="the first seed (default 0; development runs from 1000)")
    p.add_argument("--episodes", type=int, default=300,
                   help="learning episodes per opponent (default 300)")
    p.add_argument("--rollouts", type=int, default=None,
                   help="greedy rollouts per trial (default: ExperimentConfig's, 50)")
    p.add_argument("--workers", type=int, default=2, help="parallel jobs (default 2)")
    p.add_argument("--finished", action="store_true",
                   help="run nothing: the page from the seeds of --runs finished so far "
                        "(while the run goes on in another process)")
    p.add_argument("--from-data", metavar="STEM",
                   help="run nothing: the page from the per-seed numbers STEM.csv.gz and "
                        "STEM.json (what <docs>/data/larger_drill holds)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    return p


def larger_drill_config(args: argparse.Namespace) -> ExperimentConfig:
    """Protocol A in ``args.scenario`` with the page's methods; everything else (the
    learner's settings included) is ``ExperimentConfig``'s default."""
    lifelong: dict[str, Any] = {"train_episodes": args.episodes}
    if args.rollouts is not None:
        lifelong["rollout_episodes"] = args.rollouts
    return ExperimentConfig(protocol="A", scenario=args.scenario).with_overrides(
        methods=(*PROTOCOL_A_METHODS, TRANSFER), n_seeds=args.seeds,
        first_seed=args.first_seed, workers=args.workers, lifelong=lifelong)


def main(argv: Sequence[str] | None = None) -> int:
    """Run or resume the run, keep its numbers and write the page."""
    with stopped_in_one_line("ilpss-larger-drill"):  # Ctrl-C or SIGTERM: one line
        return _main(argv)


def _main(argv: Sequence[str] | None) -> int:
    p = parser()
    args = p.parse_args(argv)
    running = not (args.from_data or args.finished)
    try:  # every output and the configuration checked before any work, or any folder made
        check_utf8(args)
        cfg = larger_drill_config(args)
        if running and Path(args.docs).resolve() == Path(args.runs).resolve():
            raise ValueError(f"--docs and --runs name the same folder ({args.runs}): the page "
                             "goes in one, the run's files in another")
        if args.from_data:  # read first: numbers that cannot be read make no folder
            data = SeedData.read(args.from_data)
        elif args.finished:
            data = _finished(cfg, Path(args.runs))
        runs = check_out_dir(args.runs, "--runs") if running else None
        docs = check_out_dir(args.docs, "--docs", run_folder=False)
        for sub in ("figures", "data"):
            check_out_dir(docs / sub, "--docs", run_folder=False)
    except ValueError as exc:
        p.error(str(exc))
    except OSError as exc:
        p.error(f"{exc.filename or args.runs}: {exc.strerror or exc}")
    if runs is not None:
        stop_on_sigterm()
        folder = RunFolder(runs)
        try:
            run_timed(cfg, folder, progress=not args.quiet)
            data = SeedData.from_runs({"A": folder.root})
        except (FolderInUseError, StorageError, JobError, ValueError, OSError,
                drill_exception(TEAM_ERROR)) as exc:
            p.exit(1, f"{p.prog}: error: {exc}\n")
    stem = docs / "data" / STEM
    try:
        if not args.from_data:  # the page is computed from the numbers kept
            data.write(stem)
            data = SeedData.read(stem)
        path = docs / f"{STEM}.md"
        atomic_write_bytes(path, "\n".join(page(data, docs)).encode())
    except (ValueError, OSError) as exc:
        p.exit(1, f"{p.prog}: error: {exc}\n")
    print(f"page: {path}")
    return 0


def _finished(cfg: ExperimentConfig, runs: Path) -> SeedData:
    """The finished seeds of the run at ``runs``, which must be this configuration's."""
    folder = RunFolder(runs)
    if not folder.config.is_file():
        raise ValueError(f"--runs {runs}: no config.json (no run there yet)")
    if read_config(folder.config).results_record() != cfg.results_record():
        raise ValueError(f"--runs {runs}: its run has another configuration than these "
                         "flags give (give the flags it was started with)")
    data = SeedData.from_runs({"A": runs}, require_all=False)
    if not data.jobs["A"]:
        raise ValueError(f"--runs {runs}: no seed is finished yet")
    return data


def run_command(cfg: ExperimentConfig) -> str:
    """The command that runs (or resumes) ``cfg`` into the default run folder."""
    argv = ["--seeds", str(cfg.n_seeds), "--first-seed", str(cfg.first_seed),
            "--episodes", str(cfg.lifelong.train_episodes),
            "--rollouts", str(cfg.lifelong.rollout_episodes)]
    if cfg.scenario != DEFAULT_SCENARIO:
        argv += ["--scenario", cfg.scenario]
    return "ilpss-larger-drill " + " ".join(shlex.quote(a) for a in argv)


# ---------------------------------------------------------------- the page
def page(data: SeedData, docs: Path) -> list[str]:
    """The page's lines, from ``data`` alone (its figures written to ``<docs>/figures``)."""
    cfg = data.configs["A"]
    results = data.results("A")
    ((_, methods),) = collect(results).items()
    curves = target_curves(methods)
    seeds = data.seeds("A")
    drill = holder_drill(cfg.scenario)
    lc = cfg.lifelong
    done = (f"all {cfg.n_seeds} seeds" if len(seeds) == cfg.n_seeds else
            f"**{len(seeds)} of its {cfg.n_seeds} seeds** (the others were not finished "
            "when the page was written)")
    sources, target = cfg.teams[:-1], cfg.teams[-1]
    lines = [
        f"# The larger drill: protocol A at {drill.attackers} v {drill.defenders}, and a "
        "transfer across sizes", "",
        "Generated by `ilpss-larger-drill` (`ilpss/experiments/larger_drill.py`) from the "
        f"per-seed numbers in [`data/{STEM}.csv.gz`](data/{STEM}.csv.gz) (manifest "
        f"[`data/{STEM}.json`](data/{STEM}.json)); do not edit it by hand. Regenerate it "
        f"from them, in this folder, with `ilpss-larger-drill --from-data data/{STEM} --docs .`; "
        "the run "
        f"(`--runs FOLDER` for another folder than `results/larger_drill`): "
        f"`{run_command(cfg)}`.", "",
        f"The scenario `{cfg.scenario}`: {drill.attackers} attackers against "
        f"{drill.defenders} defenders, the holder's {len(drill.feature_names)} keepaway "
        f"features and its actions {', '.join(drill.action_names)}. Opponent teams "
        f"{', '.join(f'`{t}`' for t in sources)} in sequence, then the held-out `{target}` "
        f"(the paper's protocol A, its teams playing {drill.defenders} defenders). Seeds "
        f"{seed_ranges(seeds)}: {done}; {lc.train_episodes} learning episodes per opponent, "
        f"{lc.rollout_episodes} greedy rollouts per trial, {lc.n_kernels} kernels; "
        "everything else is `ExperimentConfig`'s default.", "",
        f"- Wall time: {wall_time(data.wall_times.get('A'), 'ilpss-larger-drill')}",
        f"- {code_line(results)}", "",
        metrics_note(lc.train_episodes, docs), "",
        *protocol_a_section(cfg, curves, docs),
        *transfer_section(cfg, curves, docs),
    ]
    return lines


def protocol_a_section(cfg: ExperimentConfig, curves: dict, docs: Path) -> list[str]:
    """Learning anew, fine-tuning, whole past policies and ILPSS in this drill."""
    shown = {m: curves[m] for m in PROTOCOL_A_METHODS}
    figure = plot_comparison(shown, docs / "figures" / f"{STEM}_protocol_a.png",
                             f"{cfg.scenario}: learning against the held-out team")
    lines = [f"## Protocol A in `{cfg.scenario}`", "",
             f"![learning curves](figures/{figure.name})", ""]
    if len(shown[cfg.baseline]) < 2:
        return [*lines, "Transfer metrics need at least 2 seeds.", ""]
    estimates = compare_to_baseline(shown, cfg.baseline)
    return [*lines, "### Verdicts", "",
            *verdict_lines(estimates, cfg.lifelong.train_episodes), "",
            *headline_table(estimates, f"{len(shown[cfg.baseline])} seeds"), "",
            *dip_lines(shown, cfg.baseline),
            *pairwise_lines(shown, cfg.baseline)]


def transfer_section(cfg: ExperimentConfig, curves: dict, docs: Path) -> list[str]:
    """The transfer across sizes against learning anew (its own family of tests) and
    against fine-tuning from sources learnt in this drill."""
    method = METHODS.get(TRANSFER)
    source, drill = holder_drill(method.source_scenario), holder_drill(cfg.scenario)
    shown = {m: curves[m] for m in (cfg.baseline, FINE_TUNING, TRANSFER)}
    figure = plot_comparison(shown, docs / "figures" / f"{STEM}_transfer.png",
                             f"{cfg.scenario}: sources learnt at {source.scenario} or here")
    lines = [
        f"## Transfer across sizes: {source.scenario} to {cfg.scenario}", "",
        f"`{TRANSFER}` ({label(TRANSFER)}) learns the sources anew in `{source.scenario}` "
        "(the same seeds, learner and budget as learning anew there), carries the latest "
        f"source policy's tile-coded action values to `{cfg.scenario}` by keepaway's "
        "inter-task mapping (after Taylor, Stone and Liu 2007: every variable and action "
        "to the most similar old one, a novel teammate's variables and pass to those of "
        "the farthest teammate the source had, at 2 v 2 its only one; "
        "`ilpss/experiments/cross_size.py`, `ilpss/transfer.py`), and learns from there "
        "with the base learner. Against learning anew only the start differs; against "
        "fine-tuning from the latest source only the drill the sources were learnt in. "
        "The sources' episodes are not charged to the target, as fine-tuning's are not.",
        "", *keepaway_mapping(source, drill).table(source, drill), "",
        f"![learning curves](figures/{figure.name})", ""]
    if len(shown[cfg.baseline]) < 2:
        return [*lines, "Transfer metrics need at least 2 seeds.", ""]
    estimates = compare_to_baseline(shown, cfg.baseline)
    against_anew = {TRANSFER: estimates[TRANSFER]}
    gain = estimates[TRANSFER]["total_reward_gain"]
    return [*lines, "### Against learning anew", "",
            *verdict_lines(against_anew, cfg.lifelong.train_episodes), "",
            *headline_table(estimates, f"{len(shown[cfg.baseline])} seeds"), "",
            *dip_lines(shown, cfg.baseline),
            "### Against fine-tuning from sources learnt in this drill", "",
            *pairwise_lines(shown, cfg.baseline),
            "### In one sentence", "", _plainly(gain, source.scenario), ""]


def _plainly(gain: Any, source: str) -> str:
    """Whether the transfer helps, from its total-reward gain's unadjusted interval."""
    interval = f"{gain.value:+.1f} [{gain.low:+.1f}, {gain.high:+.1f}]"
    if gain.low > 0:
        said = "more total reward than learning anew"
    elif gain.high < 0:
        said = "less total reward than learning anew"
    else:
        said = "no total-reward difference from learning anew that the seeds can show"
    return (f"Starting from the Q-function learnt at `{source}` and mapped gives {said}: "
            f"{interval} over the target's budget (unadjusted 95% interval; the "
            "Holm-adjusted verdict above is the one to quote).")


if __name__ == "__main__":
    raise SystemExit(main())
