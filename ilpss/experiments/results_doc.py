"""``ilpss-results``: run (or resume) protocols A, B and C and regenerate ``docs/results.md``.

    ilpss-results                                   # the documented run (A: 30 seeds, B, C: 10)
    ilpss-results --protocols A                     # only A; the other sections are kept
    ilpss-results --runs /tmp/r --docs /tmp/d --seeds-a 2 --seeds-b 2 --seeds-c 2 \\
        --episodes 4 --rollouts 2 --stream-length 3 --teams interceptors_press goal_guards

Read top to bottom: :func:`main` builds each chosen protocol's configuration
(:func:`protocol_config`; the learner's settings are ``ExperimentConfig``'s defaults),
runs or resumes it into ``<runs>/protocol_x`` (a finished job is never run again; a
folder holding another configuration is refused), writes that folder's ``report.md``,
and then assembles ``<docs>/results.md``: per protocol the command that regenerates it
(:func:`command_for`), its saved configuration (copied to ``<docs>/results/``), its wall
time, figures (copied to ``<docs>/figures/``), tables and verdicts, all computed from the
result files. Protocol A also gets diagnostics, the kernels of seed 0 drawn on the field
and a GIF of the ILPSS agent against the held-out team. A protocol not chosen with
``--protocols`` keeps its section if its folder holds a finished run.
"""

from __future__ import annotations

import argparse
import json
import shlex
import time
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ilpss import metrics
from ilpss._io import atomic_write_bytes, read_json
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.drill import PAPER_TEAMS
from ilpss.experiments.report import (
    ENDPOINT_LABELS,
    LABELS,
    PRIMARY,
    collect,
    comparable,
    interval_text,
    library_sizes,
    metrics_note,
    plot_held_out_panels,
    pooled_lines,
    protocol_c_lines,
    stream_estimates,
    stream_jumpstarts,
    stream_trend,
    structure_b,
    target_curves,
    trend_line,
    verdict_lines,
    windows,
    write_report,
)
from ilpss.experiments.run import load_result, read_config, run_experiment
from ilpss.metrics import format_metrics_markdown

PROTOCOLS = ("A", "B", "C")
C_METHODS = ("ilpss", "scratch", "ilpss_no_discount")
"""Protocol C compares ILPSS with and without option discounting to learning anew."""
DEFAULT_RUNS, DEFAULT_DOCS = "results", "docs"
GIF_SEEDS = range(1, 51)
"""Environment seeds of the greedy episodes scanned for the GIF."""
TIMING_FILE = "wall_time.json"
"""In each run folder: seconds spent by the ``ilpss-results`` invocations that finished jobs."""


def parser() -> argparse.ArgumentParser:
    """The command-line parser of ``ilpss-results``."""
    p = argparse.ArgumentParser(
        prog="ilpss-results", description=__doc__.splitlines()[0],
        formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__,
    )
    p.add_argument("--runs", default=DEFAULT_RUNS,
                   help="folder of the runs, one subfolder per protocol (default: results)")
    p.add_argument("--docs", default=DEFAULT_DOCS,
                   help="where results.md, figures/ and results/ go (default: docs)")
    p.add_argument("--protocols", nargs="+", choices=PROTOCOLS, default=list(PROTOCOLS),
                   help="protocols to run or resume (default: A B C); the sections of the "
                        "others are kept if their runs are finished")
    p.add_argument("--seeds-a", type=int, default=30, help="protocol A seeds (default 30)")
    p.add_argument("--seeds-b", type=int, default=10, help="protocol B seeds (default 10)")
    p.add_argument("--seeds-c", type=int, default=10, help="protocol C seeds (default 10)")
    p.add_argument("--episodes", type=int, default=300,
                   help="learning episodes per opponent (default 300)")
    p.add_argument("--rollouts", type=int, default=None,
                   help="greedy rollouts per trial (default: ExperimentConfig's, 50)")
    p.add_argument("--shuffles", type=int, default=1,
                   help="protocol B: shuffled source orders per held-out team (default 1)")
    p.add_argument("--stream-length", type=int, default=20,
                   help="protocol C: opponents in the stream (default 20)")
    p.add_argument("--teams", nargs="+", default=list(PAPER_TEAMS),
                   help="protocols A and B: the teams, the last one held out in A "
                        "(default: the paper's four)")
    p.add_argument("--workers", type=int, default=2, help="parallel jobs (default 2)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run or resume the chosen protocols and regenerate ``<docs>/results.md``."""
    args = parser().parse_args(argv)
    runs, docs = Path(args.runs), Path(args.docs)
    for sub in ("figures", "results"):
        (docs / sub).mkdir(parents=True, exist_ok=True)
    configs: dict[str, ExperimentConfig] = {}
    sections: list[str] = []
    for protocol in PROTOCOLS:
        folder = runs / f"protocol_{protocol.lower()}"
        if protocol in args.protocols:
            cfg = protocol_config(protocol, args)
            results = run_timed(cfg, folder, progress=not args.quiet)
        else:  # keep the section of an earlier, finished run
            if not (folder / "config.json").exists():
                continue
            cfg = read_config(folder / "config.json")
            results = finished_results(cfg, folder)
            if results is None:
                print(f"protocol {protocol}: {folder} is unfinished; its section is left out")
                continue
        configs[protocol] = cfg
        command = command_for({protocol: cfg}, args.runs, args.docs)
        write_report(cfg, results, folder, command=command or "(see config.json)")
        config_copy = docs / "results" / f"protocol_{protocol.lower()}_config.json"
        atomic_write_bytes(config_copy, (folder / "config.json").read_bytes())
        section = SECTIONS[protocol]
        sections += [*header(protocol, cfg, folder, command, config_copy.name),
                     *section(cfg, results, folder, docs)]
    text = [*intro(configs, args.runs, args.docs), *sections]
    path = docs / "results.md"
    atomic_write_bytes(path, ("\n".join(text).rstrip() + "\n").encode())
    print(f"results: {path}")
    return 0


# ---------------------------------------------------------------- configurations and runs
def protocol_config(protocol: str, args: argparse.Namespace) -> ExperimentConfig:
    """One protocol's configuration from the arguments; everything else (the learner's
    settings included) is ``ExperimentConfig``'s default."""
    changes: dict[str, Any] = {
        "n_seeds": getattr(args, f"seeds_{protocol.lower()}"), "workers": args.workers,
    }
    if protocol in ("A", "B"):
        changes["teams"] = tuple(args.teams)
    if protocol == "B":
        changes["n_shuffles"] = args.shuffles
    if protocol == "C":
        changes["stream_length"] = args.stream_length
        changes["methods"] = C_METHODS
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
    teams = {cfg.teams for p, cfg in configs.items() if p in ("A", "B")}
    if len(episodes) > 1 or len(rollouts) > 1 or len(teams) > 1:
        return None
    argv += ["--episodes", str(episodes.pop()), "--rollouts", str(rollouts.pop())]
    if teams and teams != {PAPER_TEAMS}:
        argv += ["--teams", *next(iter(teams))]
    if "B" in configs:
        argv += ["--shuffles", str(configs["B"].n_shuffles)]
    if "C" in configs:
        argv += ["--stream-length", str(configs["C"].stream_length)]
    args = parser().parse_args(argv)
    for p, cfg in configs.items():
        if protocol_config(p, args) != replace(cfg, workers=args.workers, executor="local"):
            return None
    return "ilpss-results " + " ".join(shlex.quote(a) for a in argv)


def job_files(cfg: ExperimentConfig, folder: Path) -> list[Path]:
    """The ``result.json`` of every job, as :func:`ilpss.experiments.run.run_stream` names them."""
    return [
        folder / f"seed_{seed:03d}" / f"stream_{index:02d}" / "result.json"
        for seed in cfg.seeds for index in range(len(cfg.streams(seed)))
    ]


def finished_results(cfg: ExperimentConfig, folder: Path) -> list[dict[str, Any]] | None:
    """Every job's result (checked) if all are finished, else ``None`` (nothing is run)."""
    files = job_files(cfg, folder)
    if not all(f.exists() for f in files):
        return None
    return [load_result(folder / f"seed_{seed:03d}" / f"stream_{index:02d}" / "result.json",
                        cfg, seed, index, stream)
            for seed in cfg.seeds for index, stream in enumerate(cfg.streams(seed))]


def run_timed(cfg: ExperimentConfig, folder: Path, progress: bool) -> list[dict[str, Any]]:
    """:func:`run_experiment`, adding its wall time to the folder's timing record when it
    finished jobs (also when interrupted after some); a finished run adds nothing."""
    files = job_files(cfg, folder)
    todo = [f for f in files if not f.exists()]
    start = time.perf_counter()
    try:
        return run_experiment(cfg, folder, progress=progress)
    finally:
        if any(f.exists() for f in todo):
            timing = folder / TIMING_FILE
            seconds = read_json(timing)["seconds"] if timing.exists() else 0.0
            record = {"seconds": seconds + time.perf_counter() - start,
                      "workers": cfg.workers, "executor": cfg.executor}
            atomic_write_bytes(timing, json.dumps(record).encode())


def wall_time(cfg: ExperimentConfig, folder: Path) -> str:
    """The recorded wall time of a run, in words; for a run made without
    ``ilpss-results``, the span from its ``config.json`` to its last ``result.json``."""
    timing = folder / TIMING_FILE
    if timing.exists():
        record = read_json(timing)
        return (f"{_duration(record['seconds'])} with {record['workers']} {record['executor']} "
                "worker(s), summed over the `ilpss-results` invocations that finished jobs")
    last = max(f.stat().st_mtime for f in job_files(cfg, folder))
    span = last - (folder / "config.json").stat().st_mtime
    return (f"not recorded (run without `ilpss-results`); {_duration(span)} from its "
            "`config.json` to its last `result.json`, pauses included")


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
        "to try next, is discussed in [`discussion.md`](discussion.md).", "",
        every, "",
        metrics_note(), "",
    ]


def header(protocol: str, cfg: ExperimentConfig, folder: Path, command: str | None,
           config_name: str) -> list[str]:
    """A protocol's title, what it does, its command, configuration and wall time."""
    lc = cfg.lifelong
    budget = (f"{cfg.n_seeds} seeds, {lc.train_episodes} learning episodes per opponent, "
              f"{lc.rollout_episodes} greedy rollouts per trial for the traces, "
              f"{lc.n_kernels} kernels.")
    others = ", ".join(LABELS.get(m, m) for m in cfg.methods if m not in ("ilpss", "scratch"))
    if protocol == "A":
        title = "Protocol A: the paper's Figure 3"
        what = (f"Opponent teams {', '.join(f'`{t}`' for t in cfg.teams[:-1])} in sequence, "
                f"with extraction after each; then against the held-out team "
                f"`{cfg.teams[-1]}`: learning with the extracted options (ILPSS) against "
                f"learning anew" + (f", beside {others} under the same budget." if others
                                    else "."))
    elif protocol == "B":
        title = "Protocol B: every team held out in turn"
        what = (f"Each of {', '.join(f'`{t}`' for t in cfg.teams)} is held out in turn, "
                f"after the others in the paper's order and in {cfg.n_shuffles} shuffled "
                f"order(s) drawn per seed; methods: ILPSS, learning anew"
                + (f", {others}." if others else "."))
    else:
        title = "Protocol C: a long stream of parametric opponents"
        what = (f"A stream of {cfg.stream_length} opponents of the `{cfg.sampler_team}` "
                f"family (`{cfg.sampler}`, drawn per seed); from the second on, ILPSS and "
                f"{others} against learning anew on every opponent.")
    shown = f"`{command}`" if command else "not expressible as an `ilpss-results` command"
    return [
        f"## {title}", "", what, budget, "",
        f"- Command: {shown}",
        f"- Configuration: [`results/{config_name}`](results/{config_name})",
        f"- Wall time: {wall_time(cfg, folder)}", "",
    ]


def section_a(cfg: ExperimentConfig, results: list[dict], folder: Path, docs: Path) -> list[str]:
    """Protocol A: curves, verdicts, diagnostics, full metric tables, kernels and GIF."""
    table = collect(results)
    ((stream, methods),) = table.items()
    curves = target_curves(methods)
    figure = docs / "figures" / "protocol_a_curves.png"
    atomic_write_bytes(figure, (folder / "curves_00.png").read_bytes())
    lines = [f"![protocol A learning curves](figures/{figure.name})", ""]
    estimates = stream_estimates(table)[stream]
    if comparable(curves):
        lines += ["### Verdicts", "", *verdict_lines(estimates, cfg.lifelong.train_episodes), ""]
    else:
        lines += ["Transfer metrics need at least 2 seeds.", ""]
    lines += diagnostics(cfg, results)
    for method, est in estimates.items():
        lines += [f"### Every metric: {LABELS.get(method, method)} vs learning anew", "",
                  format_metrics_markdown(est)]
    return lines + kernels_and_gif(cfg, folder, docs)


def diagnostics(cfg: ExperimentConfig, results: list[dict]) -> list[str]:
    """Protocol A: per lifelong method, the greedy rollouts' success on every trial, and
    the options offered and used against the held-out team, mean over seeds."""
    tasks, target = results[0]["tasks"], results[0]["first_target"]
    lifelong = [m for m in cfg.methods if m != "prq"]
    head = ["method", *(f"rollout success vs `{t}`" for t in tasks),
            "options offered at the target", "options used at the target",
            "options active after the target"]
    rows = ["| " + " | ".join(head) + " |", "|---|" + "---:|" * (len(head) - 1)]
    for method in lifelong:
        def mean(key: str, m: str = method) -> np.ndarray:
            return np.mean([r["methods"][m][key] for r in results], axis=0)
        success = mean("rollout_success_rate")
        rows.append("| " + " | ".join([
            LABELS.get(method, method), *(f"{100 * s:.0f} %" for s in success),
            f"{mean('options_offered')[target]:.1f}", f"{mean('options_used')[target]:.1f}",
            f"{mean('library_size')[target]:.1f}",
        ]) + " |")
    return [
        "### Diagnostics", "",
        f"Means over {len(results)} seeds. Rollout success: share of the "
        f"{cfg.lifelong.rollout_episodes} greedy rollouts of each trial's learnt policy that "
        "succeed (its bag of states comes from these). Options used: options the greedy "
        "learnt policy ran in those rollouts. The option durations are not in the result "
        "files, so they are not shown here.", "",
        *rows, "",
    ]


def kernels_and_gif(cfg: ExperimentConfig, folder: Path, docs: Path) -> list[str]:
    """The first seed's ILPSS learner: its kernels on the field, and a GIF against the
    held-out team with the active option written under the field."""
    if "ilpss" not in cfg.methods:
        return []
    import gymnasium as gym

    from ilpss.experiments.figures import (
        greedy_episodes,
        plot_kernels_on_field,
        write_agent_gif,
    )
    from ilpss.lifelong import LifelongLearner

    held_out = cfg.teams[-1]
    seed = cfg.first_seed
    env = gym.make(cfg.env_id, opponent=held_out, render_mode="rgb_array",
                   disable_env_checker=True)
    learner = LifelongLearner.load(folder / f"seed_{seed:03d}" / "stream_00" / "ilpss",
                                   env.observation_space)
    lines = ["### The kernels and the agent", ""]
    if learner.kernel_model is not None:
        kernels = plot_kernels_on_field(learner, docs / "figures" / "protocol_a_kernels.png")
        bags = ", ".join(f"{len(b)} ({r.name})" for b, r in
                         zip(learner.bags, learner.records, strict=True))
        lines += [f"![kernels](figures/{kernels.name})", "",
                  f"The {learner.kernel_model.n_components} kernels of seed {seed}'s ILPSS "
                  f"learner as they stand after its {learner.n_trials} trials, projected on the "
                  "holder's position, with the active options of each kernel (policy and "
                  "scale). Dots: the bags of states, from the successful greedy rollouts of "
                  f"each trial; states per bag: {bags}.", ""]
    else:
        lines += [f"Seed {seed}'s ILPSS learner fitted no kernels at this budget (too few "
                  "states from successful rollouts), so there is no kernel picture.", ""]
    # The GIF shows an option at work if any greedy episode runs one: the first such
    # success among the scanned environment seeds, else the first such episode.
    episodes = greedy_episodes(learner, env, GIF_SEEDS)
    with_options = [e for e in episodes if e["options"]]
    shown = next((e for e in with_options if e["outcome"] == "success"),
                 with_options[0] if with_options else episodes[0])
    gif_path = docs / "figures" / f"ilpss_vs_{held_out}.gif"
    gif = write_agent_gif(learner, env, gif_path, seed=shown["seed"])
    env.close()
    options = ", ".join(str(o) for o in gif["options"]) or "none"
    successes = sum(e["outcome"] == "success" for e in episodes)
    why = (("the first that runs an option" + (" and succeeds" if shown["outcome"] == "success"
                                                else ""))
           if with_options else "no episode runs an option; the first one")
    lines += [f"![ILPSS against {held_out}](figures/{gif_path.name})", "",
              f"Seed {seed}'s ILPSS agent, greedy with the policy it learnt against "
              f"`{held_out}` and the options as refitted at the end of that trial (the "
              f"checkpoint keeps no earlier library). Over {len(episodes)} greedy episodes (environment seeds "
              f"{GIF_SEEDS.start}-{GIF_SEEDS.stop - 1}) it succeeds in {successes} and runs an "
              f"option in {len(with_options)}. The GIF shows environment seed {shown['seed']} "
              f"({why}): outcome {gif['outcome']}, reward {gif['reward']:+.2f}, options run: "
              f"{options}. The action and, when one runs, the active option are written under "
              "the field.", ""]
    return lines


def section_b(cfg: ExperimentConfig, results: list[dict], folder: Path, docs: Path) -> list[str]:
    """Protocol B: a panel per held-out team; the primary verdicts pooled over the streams,
    the seeds on which each method is ahead and the score distributions; then per method
    a descriptive table over the streams."""
    table = collect(results)
    figure = plot_held_out_panels(table, cfg.teams,
                                  docs / "figures" / "protocol_b_held_out.png")
    lines = [f"![protocol B learning curves](figures/{figure.name})", "",
             "Each panel: the learning curves against one held-out team, each seed's curve "
             "averaged over its source orders (paper's and shuffled), mean over seeds with a "
             "95% bootstrap band (pointwise, for the eye).", "",
             structure_b(table), ""]
    per_stream = stream_estimates(table)
    if not all(per_stream.values()):
        return [*lines, "Transfer metrics need at least 2 seeds.", ""]
    profiles = docs / "figures" / "protocol_b_profiles.png"
    lines += ["### Verdicts", "",
              *pooled_lines([target_curves(m) for m in table.values()],
                            cfg.lifelong.train_episodes, f"the {len(table)} streams", profiles,
                            f"figures/{profiles.name}")]
    compared = list(per_stream[next(iter(table))])
    n = len(table)
    for method in compared:
        lines += [f"### {LABELS.get(method, method)} vs learning anew, per stream "
                  "(descriptive)", "",
                  "| stream | jumpstart [95% CI] | total-reward gain [95% CI] | final "
                  "performance gain [95% CI] | time to threshold ratio [95% CI] | seeds "
                  "reaching the threshold (method, anew) |", "|---|---:|---:|---:|---:|---:|"]
        for stream in table:
            lines.append(_row(stream, per_stream[stream][method]))
        lines.append("")
    lines.append(f"Unadjusted 95% intervals over the {cfg.n_seeds} seeds of each of the {n} "
                 "streams; the pooled rows are the verdicts above.")
    return [*lines, ""]


def _row(name: str, est: dict) -> str:
    n = est["jumpstart"].n
    reached = (f"{round(est['threshold_reached_transfer'].value * n)}/{n}, "
               f"{round(est['threshold_reached_baseline'].value * n)}/{n}")
    return (f"| {name} | {interval_text(est['jumpstart'], '+.3f')} | "
            f"{interval_text(est['total_reward_gain'], '+.1f')} | "
            f"{interval_text(est['final_gain'], '+.3f')} | "
            f"{interval_text(est['time_to_threshold_ratio'], '.2f')} | {reached} |")


def discounting_lines(methods: dict[str, dict[int, np.ndarray]], targets: list[int],
                      sizes: dict[str, np.ndarray]) -> list[str]:
    """Protocol C: ILPSS with against without option discounting, paired by seed: the
    library's final size, and the pooled jumpstart and total-reward gain."""
    if not {"ilpss", "ilpss_no_discount"} <= set(sizes) or len(sizes["ilpss"]) < 2:
        return []
    with_, without = sizes["ilpss"][:, -1], sizes["ilpss_no_discount"][:, -1]
    value, low, high = metrics.t_interval(with_ - without)
    effect = ("keeps the library smaller" if high < 0 else "makes the library larger"
              if low > 0 else "shows no demonstrated effect on the library's size")
    lines = [f"- **Option discounting** {effect}: after the last trial {with_.mean():.1f} "
             f"active options with it, {without.mean():.1f} without; difference {value:+.1f}, "
             f"95% interval [{low:+.1f}, {high:+.1f}] (paired by seed, Student t)."]
    a = np.mean([methods["ilpss"][t] for t in targets], axis=0)
    b = np.mean([methods["ilpss_no_discount"][t] for t in targets], axis=0)
    first, last, _ = windows(a.shape[1])
    est = metrics.compare(a, b, first=first, last=last, threshold=None, window=1)
    cells = [f"{ENDPOINT_LABELS[e]} {interval_text(est[e], '+.3f' if e == 'jumpstart' else '+.1f')}"
             f" (p = {est[e].p_value:.2g})" for e in PRIMARY]
    said = ("costs transfer" if any(est[e].high < 0 for e in PRIMARY) else
            "helps transfer" if any(est[e].low > 0 for e in PRIMARY) else
            "shows no demonstrated effect on transfer")
    lines.append(f"- **With against without discounting, paired by seed** (pooled over the "
                 f"opponents, descriptive): discounting {said}: " + "; ".join(cells) + ".")
    return lines


def section_c(cfg: ExperimentConfig, results: list[dict], folder: Path, docs: Path) -> list[str]:
    """Protocol C: the primary verdicts pooled over the stream's opponents, the seeds on
    which each method is ahead, the score distributions, the trend along the stream, the
    effect of discounting, and the jumpstart on each new opponent."""
    table = collect(results)
    ((_, methods),) = table.items()
    figure = docs / "figures" / "protocol_c_stream.png"
    atomic_write_bytes(figure, (folder / "stream.png").read_bytes())
    sizes = library_sizes(results)
    lines = []
    if len(results) >= 2:
        targets = sorted(methods["scratch"])
        profiles = docs / "figures" / "protocol_c_profiles.png"
        lines += ["### Verdicts", "",
                  *pooled_lines([{m: methods[m][t] for m in methods} for t in targets],
                                cfg.lifelong.train_episodes,
                                f"the {len(targets)} opponents after the first", profiles,
                                f"figures/{profiles.name}"),
                  *[trend_line(stream_trend(methods, m), LABELS.get(m, m))
                    for m in methods if m != "scratch"],
                  *discounting_lines(methods, targets, sizes), ""]
    return [*lines, "### Library size and jumpstart on each new opponent", "",
            *protocol_c_lines(stream_jumpstarts(methods), sizes, f"figures/{figure.name}"), ""]


SECTIONS = {"A": section_a, "B": section_b, "C": section_c}


if __name__ == "__main__":
    raise SystemExit(main())
