"""The sections of ``docs/results.md``, one per protocol, computed from its results.

Protocols A, B and C have their own (:func:`section_a`, :func:`section_b`,
:func:`section_c`, in :data:`PAGE_SECTIONS`, keyed by protocol name); any other protocol
gets its report's body with the figures copied (:func:`report_section`).
``ilpss-results`` (:mod:`ilpss.experiments.results_doc`) asks :func:`page_section` for
each protocol's.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from ilpss import metrics
from ilpss._io import MAX_ARCHIVE_BYTES, atomic_write_bytes, check_inside, read_regular
from ilpss.experiments.checkpoints import checkpoint_store
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.folder import RunFolder, checkpoint_key
from ilpss.experiments.methods import METHODS, LifelongMethod
from ilpss.experiments.report import report_body
from ilpss.experiments.report_bodies import pooled_lines
from ilpss.experiments.report_figures import plot_held_out_panels
from ilpss.experiments.report_stats import (
    METHOD_PAIRS_FAMILY,
    PRIMARY,
    collect,
    comparable,
    compare_to_baseline,
    library_sizes,
    per_target_curves,
    stream_estimates,
    stream_jumpstarts,
    stream_trend,
    target_curves,
    windows,
)
from ilpss.experiments.report_text import (
    ENDPOINT_LABELS,
    comparison_head,
    comparison_row,
    counted,
    dip_lines,
    headline_table,
    interval_text,
    label,
    pairwise_lines,
    per_target_dips,
    protocol_c_lines,
    structure_b,
    structure_targets,
    target_tables,
    trend_line,
    verdict_lines,
    worst_target_dips,
)
from ilpss.metrics import format_metrics_markdown

__all__ = ["PAGE_SECTIONS"]


def _copy_figure(folder: Path, name: str, destination: Path) -> None:
    """Copy the run folder's figure ``name`` to ``destination`` (a regular file inside
    the run folder, bounded as any saved file)."""
    source = check_inside(folder, folder / name, "run folder")
    atomic_write_bytes(destination, read_regular(source, MAX_ARCHIVE_BYTES, "a figure"))


def report_section(cfg: ExperimentConfig, results: list[dict[str, Any]], folder: Path,
                   docs: Path) -> list[str]:
    """A protocol's report body as its section of the page: the same markdown, its
    figures copied to ``<docs>/figures`` as ``protocol_<name>_<figure>``, headings one
    level down."""
    lines = []
    for line in report_body(cfg, results, folder):
        for name in re.findall(r"\]\(([^)/]+\.png)\)", line):
            copy = f"protocol_{cfg.protocol.lower()}_{name}"
            _copy_figure(folder, name, docs / "figures" / copy)
            line = line.replace(f"]({name})", f"](figures/{copy})")
        lines.append("#" + line if line.startswith("#") else line)
    return lines


def section_a(cfg: ExperimentConfig, results: list[dict], folder: Path, docs: Path) -> list[str]:
    """Protocol A (and R): curves, verdicts, diagnostics, full metric tables, kernels and GIF
    (with several targets: :func:`section_a_targets`)."""
    table = collect(results)
    ((stream, methods),) = table.items()
    if len(next(iter(methods.values()))) > 1:
        return section_a_targets(cfg, results, folder, docs)
    curves = target_curves(methods)
    figure = docs / "figures" / f"protocol_{cfg.protocol.lower()}_curves.png"
    _copy_figure(folder, "curves_00.png", figure)
    lines = [f"![protocol A learning curves](figures/{figure.name})", ""]
    estimates = stream_estimates(table, cfg.baseline)[stream]
    if comparable(curves, cfg.baseline):
        lines += ["### Verdicts", "", *verdict_lines(estimates, cfg.lifelong.train_episodes), "",
                  *headline_table(estimates, counted(cfg.n_seeds, "seed")), "",
                  *dip_lines(curves, cfg.baseline),
                  *pairwise_lines(curves, cfg.baseline, family=METHOD_PAIRS_FAMILY)]
    else:
        lines += ["Transfer metrics need at least 2 seeds.", ""]
    lines += diagnostics(cfg, results)
    for method, est in estimates.items():
        lines += [f"### Every metric: {label(method)} vs the baseline", "",
                  format_metrics_markdown(est)]
    return lines + kernels_and_gif(cfg, folder, docs)


def section_a_targets(
    cfg: ExperimentConfig, results: list[dict], folder: Path, docs: Path
) -> list[str]:
    """Protocol A with several targets: the curves against each, the primary verdicts
    pooled over the targets with a descriptive table per method, diagnostics, the
    kernels and a GIF against the first target."""
    ((_, methods),) = collect(results).items()
    names = results[0]["tasks"]
    per_target = per_target_curves(methods)
    lines = []
    for t in per_target:
        figure = docs / "figures" / f"protocol_{cfg.protocol.lower()}_curves_{t:02d}.png"
        _copy_figure(folder, f"curves_00_{t:02d}.png", figure)
        lines += [f"![protocol {cfg.protocol} learning curves against {names[t]}]"
                  f"(figures/{figure.name})", ""]
    if not all(comparable(c, cfg.baseline) for c in per_target.values()):
        return [*lines, "Transfer metrics need at least 2 seeds.", "",
                *diagnostics(cfg, results), *kernels_and_gif(cfg, folder, docs)]
    profiles = docs / "figures" / f"protocol_{cfg.protocol.lower()}_profiles.png"
    estimates = {t: compare_to_baseline(c, cfg.baseline) for t, c in per_target.items()}
    lines += [structure_targets(len(per_target)), "", "### Verdicts", "",
              *pooled_lines(list(per_target.values()), cfg.baseline, cfg.lifelong.train_episodes,
                            f"the {len(per_target)} targets", profiles,
                            f"figures/{profiles.name}"),
              *target_tables(estimates, names),
              *per_target_dips(per_target, names, cfg.baseline)]
    return [*lines, *diagnostics(cfg, results), *kernels_and_gif(cfg, folder, docs)]


def diagnostics(cfg: ExperimentConfig, results: list[dict]) -> list[str]:
    """Protocol A: per lifelong method, the greedy rollouts' success on every trial, and
    the options offered and used against the held-out team (each target), mean over
    seeds."""
    tasks, first = results[0]["tasks"], results[0]["first_target"]
    targets = range(first, len(tasks))
    lifelong = [m for m in cfg.methods if isinstance(METHODS.get(m), LifelongMethod)]
    at = (["options offered at the target", "options used at the target",
           "options active after the target"] if len(targets) == 1 else
          [f"options offered / used / active at `{tasks[t]}`" for t in targets])
    head = ["method", *(f"rollout success vs `{t}`" for t in tasks), *at]
    rows = ["| " + " | ".join(head) + " |", "|---|" + "---:|" * (len(head) - 1)]
    for method in lifelong:
        def mean(key: str, m: str = method) -> np.ndarray:
            return np.mean([r["methods"][m][key] for r in results], axis=0)
        success = mean("rollout_success_rate")
        offered, used, active = mean("options_offered"), mean("options_used"), \
            mean("library_size")
        cells = ([f"{offered[first]:.1f}", f"{used[first]:.1f}", f"{active[first]:.1f}"]
                 if len(targets) == 1 else
                 [f"{offered[t]:.1f} / {used[t]:.1f} / {active[t]:.1f}" for t in targets])
        rows.append("| " + " | ".join([
            label(method), *(f"{100 * s:.0f} %" for s in success), *cells]) + " |")
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
    """The first seed's learner of the featured method (``ExperimentConfig.featured_method``):
    its kernels on the field, and a GIF against the held-out team with the active option
    written under the field."""
    featured = cfg.featured_method
    if featured is None:
        return []
    name = label(featured)
    if not RunFolder(folder).config.is_file():  # a page from the kept per-seed numbers
        return ["### The kernels and the agent", "",
                "This section is made from the kept per-seed numbers, which hold no "
                "checkpoints, so there is no kernel picture or GIF.", ""]
    import gymnasium as gym

    from ilpss.experiments.figures import (
        GIF_SEEDS,
        gif_episode,
        greedy_episodes,
        plot_kernels_on_field,
        write_agent_gif,
    )
    (stream,) = cfg.streams(cfg.first_seed)
    held_out = stream.tasks[stream.first_target].name
    several = len(stream.tasks) - stream.first_target > 1
    seed = cfg.first_seed
    env = gym.make(cfg.env_id, opponent=held_out, disable_env_checker=True)
    key = checkpoint_key(seed, 0, featured, stream.first_target if several else None)
    store = checkpoint_store(cfg, folder)
    try:
        learner = store.restore(key, env.observation_space)
    finally:
        store.close()
    if learner is None:
        env.close()
        return ["### The kernels and the agent", "",
                f"Seed {seed}'s {name} checkpoint is not kept ({store.location}/{key}), so "
                "there is no kernel picture or GIF.", ""]
    lines = ["### The kernels and the agent", ""]
    if learner.kernel_model is not None:
        kernels = plot_kernels_on_field(
            learner, docs / "figures" / f"protocol_{cfg.protocol.lower()}_kernels.png",
            drill=cfg.drill)
        bags = ", ".join(f"{len(b)} ({r.name})" for b, r in
                         zip(learner.bags, learner.records, strict=True))
        lines += [f"![kernels](figures/{kernels.name})", "",
                  f"The {learner.kernel_model.n_components} kernels of seed {seed}'s {name} "
                  f"learner as they stand after its {learner.n_trials} trials, projected on the "
                  "holder's position, with the active options of each kernel (policy and "
                  "scale). Dots: the bags of states, from the successful greedy rollouts of "
                  f"each trial; states per bag: {bags}.", ""]
    else:
        lines += [f"Seed {seed}'s {name} learner fitted no kernels at this budget (too few "
                  "states from successful rollouts), so there is no kernel picture.", ""]
    episodes = greedy_episodes(learner, env, GIF_SEEDS)
    with_options = [e for e in episodes if e["options"]]
    shown = gif_episode(episodes)
    gif_path = docs / "figures" / f"{featured}_vs_{held_out}.gif"
    filmed = gym.make(cfg.env_id, opponent=held_out, render_mode="rgb_array_list",
                      disable_env_checker=True)
    gif = write_agent_gif(learner, filmed, gif_path, seed=shown["seed"])
    filmed.close()
    env.close()
    options = ", ".join(str(o) for o in gif["options"]) or "none"
    successes = sum(e["outcome"] == "success" for e in episodes)
    why = (("the first that runs an option" + (" and succeeds" if shown["outcome"] == "success"
                                                else ""))
           if with_options else "no episode runs an option; the first one")
    lines += [f"![{name} against {held_out}](figures/{gif_path.name})", "",
              f"Seed {seed}'s {name} agent, greedy with the policy it learnt against "
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
             structure_b(table, cfg.baseline), ""]
    per_stream = stream_estimates(table, cfg.baseline)
    if not all(per_stream.values()):
        return [*lines, "Transfer metrics need at least 2 seeds.", ""]
    profiles = docs / "figures" / "protocol_b_profiles.png"
    lines += ["### Verdicts", "",
              *pooled_lines([target_curves(m) for m in table.values()], cfg.baseline,
                            cfg.lifelong.train_episodes, f"the {len(table)} streams", profiles,
                            f"figures/{profiles.name}")]
    compared = list(per_stream[next(iter(table))])
    n = len(table)
    for method in compared:
        lines += [f"### {label(method)} vs the baseline, per stream "
                  "(descriptive)", "", *comparison_head("stream")]
        for stream in table:
            lines.append(comparison_row(stream, per_stream[stream][method]))
        lines.append("")
    lines.append(f"Unadjusted 95% intervals over the {counted(cfg.n_seeds, 'seed')} of each of "
                 f"the {counted(n, 'stream')}; the pooled rows are the verdicts above.")
    per_stream_curves = {i: target_curves(methods) for i, methods in enumerate(table.values())}
    return [*lines, "", *per_target_dips(per_stream_curves, list(table), cfg.baseline)]


def ablation_lines(cfg: ExperimentConfig, methods: dict[str, dict[int, np.ndarray]],
                   targets: list[int], sizes: dict[str, np.ndarray]) -> list[str]:
    """Protocol C: every method that ablates another (``Method.ablates``, e.g. a method
    without discounting) against the method it ablates, paired by seed: the library's
    final size, and the pooled jumpstart and total-reward gain."""
    lines = []
    for name in cfg.methods:
        ablates = METHODS.get(name).ablates
        if ablates is None or ablates[0] not in cfg.methods:
            continue
        full, what = ablates
        if full in sizes and name in sizes and len(sizes[full]) >= 2:
            with_, without = sizes[full][:, -1], sizes[name][:, -1]
            value, low, high = metrics.t_interval(with_ - without)
            effect = ("keeps the library smaller" if high < 0 else "makes the library larger"
                      if low > 0 else "shows no demonstrated effect on the library's size")
            lines.append(f"- **{what[:1].upper()}{what[1:]}** in {label(full)} {effect}: after "
                         f"the last trial {with_.mean():.1f} active options with it, "
                         f"{without.mean():.1f} without; difference {value:+.1f}, 95% "
                         f"interval [{low:+.1f}, {high:+.1f}] (paired by seed, Student t).")
        a = np.mean([methods[full][t] for t in targets], axis=0)
        b = np.mean([methods[name][t] for t in targets], axis=0)
        if len(a) < 2:
            continue
        first, last, _ = windows(a.shape[1])
        est = metrics.compare(a, b, first=first, last=last, threshold=None, window=1)
        cells = [f"{ENDPOINT_LABELS[e]} {interval_text(est[e], metrics.METRIC[e].fmt)}"
                 f" (p = {est[e].p_value:.2g})" for e in PRIMARY]
        said = ("costs transfer" if any(est[e].high < 0 for e in PRIMARY) else
                "helps transfer" if any(est[e].low > 0 for e in PRIMARY) else
                "shows no demonstrated effect on transfer")
        lines.append(f"- **{label(full)} with against without {what}, paired by seed** "
                     f"(pooled over the opponents, descriptive): {what} {said}: "
                     + "; ".join(cells) + ".")
    return lines


def section_c(cfg: ExperimentConfig, results: list[dict], folder: Path, docs: Path) -> list[str]:
    """Protocol C: the primary verdicts pooled over the stream's opponents, the seeds on
    which each method is ahead, the score distributions, the trend along the stream, the
    effect of each ablation, and the featured method's jumpstart on each new opponent."""
    table = collect(results)
    ((_, methods),) = table.items()
    baseline, featured = cfg.baseline, cfg.featured_method
    figure = docs / "figures" / "protocol_c_stream.png"
    _copy_figure(folder, "stream.png", figure)
    sizes = library_sizes(cfg, results)
    lines = []
    if len(results) >= 2:
        targets = sorted(methods[baseline])
        profiles = docs / "figures" / "protocol_c_profiles.png"
        lines += ["### Verdicts", "",
                  *pooled_lines([{m: methods[m][t] for m in methods} for t in targets],
                                baseline, cfg.lifelong.train_episodes,
                                f"the {len(targets)} opponents after the first", profiles,
                                f"figures/{profiles.name}"),
                  *[trend_line(stream_trend(methods, m, baseline), label(m))
                    for m in methods if m != baseline],
                  *ablation_lines(cfg, methods, targets, sizes), "",
                  *worst_target_dips({t: {m: methods[m][t] for m in methods} for t in targets},
                                     {t: f"opponent {t + 1}" for t in targets}, baseline)]
    jumpstarts = stream_jumpstarts(methods, featured, baseline) if featured else []
    return [*lines, "### Library size and jumpstart on each new opponent", "",
            *protocol_c_lines(jumpstarts, sizes, f"figures/{figure.name}", featured), ""]


PAGE_SECTIONS = {"A": section_a, "B": section_b, "C": section_c, "R": section_a}
"""The section of ``docs/results.md`` per protocol name; others get :func:`report_section`."""


def page_section(cfg: ExperimentConfig, results: list[dict[str, Any]], folder: Path,
                 docs: Path) -> list[str]:
    """The body of ``cfg``'s protocol's section of the results page, its figures copied
    to ``<docs>/figures``."""
    return PAGE_SECTIONS.get(cfg.protocol, report_section)(cfg, results, folder, docs)
