"""The sections of ``docs/results.md``, one per protocol, computed from its results.

Protocols A, B and C have their own (:func:`section_a`, :func:`section_b`,
:func:`section_c`); any other protocol gets its report's body with the figures copied
(:func:`report_section`). ``ilpss-results`` (:mod:`ilpss.experiments.results_doc`)
asks each protocol for its section
(:meth:`~ilpss.experiments.protocols.Protocol.results_section`).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from ilpss import metrics
from ilpss._io import atomic_write_bytes
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.folder import checkpoint_key
from ilpss.experiments.methods import METHODS, LifelongMethod
from ilpss.experiments.protocols import Protocol
from ilpss.experiments.report import (
    ENDPOINT_LABELS,
    PRIMARY,
    collect,
    comparable,
    compare_to_scratch,
    comparison_head,
    comparison_row,
    interval_text,
    label,
    library_sizes,
    per_target_curves,
    plot_held_out_panels,
    pooled_lines,
    protocol_c_lines,
    stream_estimates,
    stream_jumpstarts,
    stream_trend,
    structure_b,
    structure_targets,
    target_curves,
    target_tables,
    trend_line,
    verdict_lines,
    windows,
)
from ilpss.metrics import format_metrics_markdown

__all__ = ["report_section", "section_a", "section_b", "section_c"]


def report_section(
    protocol: Protocol, cfg: ExperimentConfig, results: list[dict[str, Any]], folder: Path,
    docs: Path,
) -> list[str]:
    """A protocol's report body as its section of the page: the same markdown, its
    figures copied to ``<docs>/figures`` as ``protocol_<name>_<figure>``, headings one
    level down."""
    lines = []
    for line in protocol.report(cfg, results, folder):
        for name in re.findall(r"\]\(([^)/]+\.png)\)", line):
            copy = f"protocol_{protocol.name.lower()}_{name}"
            atomic_write_bytes(docs / "figures" / copy, (folder / name).read_bytes())
            line = line.replace(f"]({name})", f"](figures/{copy})")
        lines.append("#" + line if line.startswith("#") else line)
    return lines


def section_a(cfg: ExperimentConfig, results: list[dict], folder: Path, docs: Path) -> list[str]:
    """Protocol A: curves, verdicts, diagnostics, full metric tables, kernels and GIF
    (with several targets: :func:`section_a_targets`)."""
    table = collect(results)
    ((stream, methods),) = table.items()
    if len(next(iter(methods.values()))) > 1:
        return section_a_targets(cfg, results, folder, docs)
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
        lines += [f"### Every metric: {label(method)} vs learning anew", "",
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
        figure = docs / "figures" / f"protocol_a_curves_{t:02d}.png"
        atomic_write_bytes(figure, (folder / f"curves_00_{t:02d}.png").read_bytes())
        lines += [f"![protocol A learning curves against {names[t]}](figures/{figure.name})", ""]
    if not all(comparable(c) for c in per_target.values()):
        return [*lines, "Transfer metrics need at least 2 seeds.", "",
                *diagnostics(cfg, results), *kernels_and_gif(cfg, folder, docs)]
    profiles = docs / "figures" / "protocol_a_profiles.png"
    estimates = {t: compare_to_scratch(c) for t, c in per_target.items()}
    lines += [structure_targets(len(per_target)), "", "### Verdicts", "",
              *pooled_lines(list(per_target.values()), cfg.lifelong.train_episodes,
                            f"the {len(per_target)} targets", profiles,
                            f"figures/{profiles.name}"),
              *target_tables(estimates, names)]
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
    """The first seed's ILPSS learner: its kernels on the field, and a GIF against the
    held-out team with the active option written under the field."""
    if "ilpss" not in cfg.methods:
        return []
    import gymnasium as gym

    from ilpss.experiments.figures import (
        GIF_SEEDS,
        gif_episode,
        greedy_episodes,
        plot_kernels_on_field,
        write_agent_gif,
    )
    from ilpss.experiments.run import checkpoint_store

    (stream,) = cfg.streams(cfg.first_seed)
    held_out = stream.tasks[stream.first_target].name
    several = len(stream.tasks) - stream.first_target > 1
    seed = cfg.first_seed
    env = gym.make(cfg.env_id, opponent=held_out, disable_env_checker=True)
    key = checkpoint_key(seed, 0, "ilpss", stream.first_target if several else None)
    store = checkpoint_store(cfg, folder)
    try:
        learner = store.restore(key, env.observation_space)
    finally:
        store.close()
    if learner is None:
        env.close()
        return ["### The kernels and the agent", "",
                f"Seed {seed}'s ILPSS checkpoint is not kept ({store.location}/{key}), so "
                "there is no kernel picture or GIF.", ""]
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
    episodes = greedy_episodes(learner, env, GIF_SEEDS)
    with_options = [e for e in episodes if e["options"]]
    shown = gif_episode(episodes)
    gif_path = docs / "figures" / f"ilpss_vs_{held_out}.gif"
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
        lines += [f"### {label(method)} vs learning anew, per stream "
                  "(descriptive)", "", *comparison_head("stream")]
        for stream in table:
            lines.append(comparison_row(stream, per_stream[stream][method]))
        lines.append("")
    lines.append(f"Unadjusted 95% intervals over the {cfg.n_seeds} seeds of each of the {n} "
                 "streams; the pooled rows are the verdicts above.")
    return [*lines, ""]


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
                  *[trend_line(stream_trend(methods, m), label(m))
                    for m in methods if m != "scratch"],
                  *discounting_lines(methods, targets, sizes), ""]
    return [*lines, "### Library size and jumpstart on each new opponent", "",
            *protocol_c_lines(stream_jumpstarts(methods), sizes, f"figures/{figure.name}"), ""]
