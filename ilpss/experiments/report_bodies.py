"""The bodies of ``report.md``, one per kind of protocol: :func:`held_out_sections` (one
held-out target per stream: A, and B pooled), :func:`several_targets_sections` (A with
several targets), :func:`parametric_stream_sections` (a long stream: C), and
:func:`target_sections` (any stream, every target: the body of a protocol that registers
none). Each composes the statistics (:mod:`~ilpss.experiments.report_stats`), their words
(:mod:`~ilpss.experiments.report_text`) and figures
(:mod:`~ilpss.experiments.report_figures`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ilpss import metrics
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.report_figures import (
    plot_comparison,
    plot_stream,
    run_scores,
)
from ilpss.experiments.report_stats import (
    METHOD_PAIRS_FAMILY,
    PRIMARY,
    collect,
    comparable,
    compare_to_baseline,
    library_sizes,
    per_target_curves,
    pool,
    pooled_estimates,
    seed_improvements,
    stream_estimates,
    stream_jumpstarts,
    stream_trend,
    target_curves,
)
from ilpss.experiments.report_text import (
    ENDPOINT_LABELS,
    counted,
    dip_lines,
    headline_table,
    label,
    pairwise_lines,
    per_target_dips,
    protocol_c_lines,
    structure_b,
    structure_targets,
    target_tables,
    trend_line,
    verdict,
    verdict_lines,
)
from ilpss.plots import plot_score_profiles


def pooled_lines(curve_sets: Sequence[dict[str, np.ndarray]], baseline: str, episodes: int,
                 what: str, figure: Path, figure_link: str) -> list[str]:
    """Protocols B and C: the primary verdicts on the pooled curves, the headline table,
    the dips, the methods against each other, the seeds on which each method is ahead,
    and the score distributions over runs (written to ``figure``)."""
    estimates = pooled_estimates(curve_sets, baseline)
    n_seeds = len(curve_sets[0][baseline])
    lines = [
        f"Pooled over {what}: each seed's learning curves are averaged over them, and the "
        "metrics are computed on these pooled curves, over seeds. The pooled jumpstart and "
        "total-reward gain are the per-seed averages of the per-comparison values; the "
        "pooled time to threshold is taken on each seed's pooled curve, censored at the "
        "budget.", "",
        *verdict_lines(estimates, episodes, pooled=" (pooled)"), "",
        *headline_table(estimates, "pooled"), "",
        *dip_lines(pool(curve_sets), baseline),
        *pairwise_lines(pool(curve_sets), baseline, family=METHOD_PAIRS_FAMILY),
        "Paired probability of improvement: the share of seeds on which the method's pooled "
        "value beats the baseline's (ties count one half), with a two-sided sign test and "
        f"a Wilcoxon signed-rank test over the {counted(n_seeds, 'seed')} (descriptive):", "",
    ]
    for method, tests in seed_improvements(curve_sets, baseline).items():
        cells = []
        for e in PRIMARY:
            t = tests[e]
            sign = "n/a" if math.isnan(t.sign_p) else f"{t.sign_p:.2g}"
            wil = "n/a" if math.isnan(t.wilcoxon_p) else f"{t.wilcoxon_p:.2g}"
            cells.append(f"{ENDPOINT_LABELS[e]} ahead on {t.better} of {t.n} seeds, behind on "
                         f"{t.worse} (probability {t.probability:.2f}; sign test p = {sign}, "
                         f"Wilcoxon p = {wil})")
        lines.append(f"- {label(method)}: " + "; ".join(cells) + ".")
    scores = run_scores(curve_sets, baseline)
    n_runs = len(next(iter(next(iter(scores.values())).values())))
    plot_score_profiles(scores, figure, title=f"Score distributions over {n_runs} runs "
                        f"({counted(n_seeds, 'seed')} x {len(curve_sets)}), against the baseline")
    lines += ["", f"![score distributions]({figure_link})", "",
              f"Score distributions over the {n_runs} runs (one per seed and comparison): "
              "for each value on the x axis, the share of runs whose score is larger. A curve "
              "that lies above another everywhere dominates it; its height at 0 is the share "
              "of runs where the method beats the baseline. The runs of a seed are not "
              "independent, so the tests above are over seeds.", ""]
    return lines


def held_out_sections(
    cfg: ExperimentConfig, results: list[dict[str, Any]], out: Path, *, pooled: bool
) -> list[str]:
    """The body of the report of protocols whose every stream has one target (the
    held-out team): per stream its curves and the metrics of every method against
    the baseline, with verdicts; with ``pooled`` (several streams, as in B) the verdicts
    are on the curves pooled over the streams, and the per-stream ones descriptive."""
    table = collect(results)
    episodes, baseline = cfg.lifelong.train_episodes, cfg.baseline
    estimates = stream_estimates(table, baseline)
    lines: list[str] = []
    if pooled and all(estimates.values()):
        lines += ["## Pooled over the streams (primary)", "", structure_b(table, baseline), "",
                  *pooled_lines([target_curves(m) for m in table.values()], baseline, episodes,
                                f"the {len(table)} streams", out / "profiles.png",
                                "profiles.png")]
    for s, (stream, methods) in enumerate(table.items()):
        curves = target_curves(methods)
        fig = plot_comparison(curves, out / f"curves_{s:02d}.png",
                      f"{stream}: learning against the held-out opponent")
        lines += [f"## {stream}", "", f"![learning curves]({fig.name})", ""]
        if baseline in curves and not comparable(curves, baseline):
            lines += ["Transfer metrics need at least 2 seeds.", ""]
        elif not pooled and estimates[stream]:
            lines += ["### Verdicts", "", *verdict_lines(estimates[stream], episodes), "",
                      *headline_table(estimates[stream], "one stream"), "",
                      *dip_lines(curves, baseline),
                      *pairwise_lines(curves, baseline, family=METHOD_PAIRS_FAMILY)]
        for method, est in estimates[stream].items():
            lines += [f"### {label(method)} vs the baseline", ""]
            if pooled:
                lines += [f"Descriptive (one stream, unadjusted): {verdict(est)}.", ""]
            lines += [metrics.format_metrics_markdown(est), ""]
    return lines


def parametric_stream_sections(
    cfg: ExperimentConfig, results: list[dict[str, Any]], out: Path
) -> list[str]:
    """The body of the report of a long stream whose every task from the second on is a
    target (protocol C): the verdicts pooled over the targets, the trend of the head
    start along the stream, and the jumpstart and library size on each new opponent."""
    (methods,) = collect(results).values()
    episodes, baseline, featured = cfg.lifelong.train_episodes, cfg.baseline, cfg.featured_method
    jumpstarts = stream_jumpstarts(methods, featured, baseline) if featured else []
    sizes = library_sizes(cfg, results)
    plot_stream(jumpstarts, sizes, out / "stream.png", featured, baseline)
    lines: list[str] = []
    targets = sorted(methods[baseline])
    if len(methods[baseline][targets[0]]) >= 2:
        lines += ["## Pooled over the opponents (primary)", "",
                  *pooled_lines([{m: methods[m][t] for m in methods} for t in targets],
                                baseline, episodes,
                                f"the {len(targets)} opponents after the first",
                                out / "profiles.png", "profiles.png"),
                  *[trend_line(stream_trend(methods, m, baseline), label(m))
                    for m in methods if m != baseline], ""]
    return [*lines, "## Jumpstart on each new opponent of the stream (descriptive)", "",
            *protocol_c_lines(jumpstarts, sizes, "stream.png", featured)]


def several_targets_sections(
    cfg: ExperimentConfig, results: list[dict[str, Any]], out: Path
) -> list[str]:
    """The body of the report of a stream with several targets that all start from the
    state after its sources (protocol A with ``targets``): the primary verdicts on each
    seed's curves pooled over the targets, the seeds on which each method is ahead and
    the score distributions, a descriptive row per target; then per target its curves and
    the metrics of every method against the baseline (descriptive, unadjusted)."""
    ((_, methods),) = collect(results).items()
    names = results[0]["tasks"]
    episodes, baseline = cfg.lifelong.train_episodes, cfg.baseline
    per_target = per_target_curves(methods)
    lines: list[str] = []
    if all(comparable(c, baseline) for c in per_target.values()):
        estimates = {t: compare_to_baseline(c, baseline) for t, c in per_target.items()}
        lines += ["## Pooled over the targets (primary)", "", structure_targets(len(per_target)),
                  "", *pooled_lines(list(per_target.values()), baseline, episodes,
                                    f"the {len(per_target)} targets", out / "profiles.png",
                                    "profiles.png"),
                  *target_tables(estimates, names), *per_target_dips(per_target, names, baseline)]
    for t, curves in per_target.items():
        lines += descriptive_lines(curves, baseline, out / f"curves_00_{t:02d}.png",
                                   f"{names[t]}: learning against the target",
                                   f"Target `{names[t]}`", "one target, unadjusted")
    return lines


def descriptive_lines(curves: dict[str, np.ndarray], baseline: str, figure: Path, title: str,
                      heading: str, scope: str) -> list[str]:
    """One comparison's section: its curves (written to ``figure``), the headline table,
    the dips, the methods against each other and, per method, the verdict and every
    metric against the baseline, marked descriptive (``scope``)."""
    fig = plot_comparison(curves, figure, title)
    lines = [f"## {heading}", "", f"![learning curves]({fig.name})", ""]
    if not comparable(curves, baseline):
        return [*lines, "Transfer metrics need the baseline on at least 2 seeds.", ""]
    estimates = compare_to_baseline(curves, baseline)
    lines += [*headline_table(estimates, scope), "", *dip_lines(curves, baseline),
              *pairwise_lines(curves, baseline, family=METHOD_PAIRS_FAMILY)]
    for method, est in estimates.items():
        lines += [f"### {label(method)} vs the baseline", "",
                  f"Descriptive ({scope}): {verdict(est)}.", "",
                  metrics.format_metrics_markdown(est), ""]
    return lines


def target_sections(
    cfg: ExperimentConfig, results: list[dict[str, Any]], out: Path
) -> list[str]:
    """The body of a report for any stream: per stream and target task, the curves and
    the metrics of every method against the baseline (descriptive, unadjusted)."""
    lines: list[str] = []
    for s, (stream, methods) in enumerate(collect(results).items()):
        for t in sorted(next(iter(methods.values()))):
            curves = {m: by_task[t] for m, by_task in methods.items()}
            lines += descriptive_lines(curves, cfg.baseline, out / f"curves_{s:02d}_{t:02d}.png",
                                       f"{stream}: learning on task {t}",
                                       f"{stream}, task {t}", "unadjusted")
    return lines


def protocol_a_sections(cfg: ExperimentConfig, results: list[dict[str, Any]], out: Path) -> list[str]:
    """Protocol A: one held-out target per stream, or several from one source history."""
    if len(results[0]["tasks"]) - results[0]["first_target"] > 1:
        return several_targets_sections(cfg, results, out)
    return held_out_sections(cfg, results, out, pooled=False)
