"""The markdown of a report: methods' labels, intervals and verdicts in words, the tables
of the methods against the baseline and against each other, the handover, the notes on
what the metrics are and on how a protocol's comparisons depend on each other.

The numbers come from :mod:`ilpss.experiments.report_stats`; nothing here draws.
"""

from __future__ import annotations

import math
import os
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ilpss import metrics
from ilpss.experiments.methods import METHODS
from ilpss.experiments.report_stats import (
    ALPHA,
    FINAL_EPISODES,
    JUMPSTART_EPISODES,
    METHOD_PAIRS_FAMILY,
    PRIMARY_FAMILY,
    SMOOTHING,
    THRESHOLD_SHARE,
    HolmFamily,
    baseline_shared_across_orders,
    collect,
    dip_and_below,
    holm_primary,
    pairwise_estimates,
    pairwise_metrics_shown,
    success_rates,
    team_streams,
    trailing_mean,
    windows,
)


def counted(n: int, noun: str) -> str:
    """``n`` and ``noun``, plural unless ``n`` is 1 ("1 seed", "30 seeds")."""
    return f"{n} {noun}{'' if n == 1 else 's'}"


def label(method: str) -> str:
    """How reports call a method: its registered label, else its name."""
    return METHODS.get(method).label if method in METHODS else method


ENDPOINT_LABELS = {"jumpstart": "jumpstart", "total_reward_gain": "total-reward gain"}


def _signed(x: float, spec: str) -> str:
    return "n/a" if math.isnan(x) else ("inf" if x == math.inf else "-inf" if x == -math.inf
                                        else format(x, spec))


def interval_text(est: metrics.MetricEstimate, spec: str) -> str:
    """``value [low, high]`` of an estimate, with ``inf`` and ``n/a`` spelt out."""
    return f"{_signed(est.value, spec)} [{_signed(est.low, spec)}, {_signed(est.high, spec)}]"


def _effect(est: metrics.MetricEstimate, adjusted: float | None, up: str, down: str,
            none: str) -> str:
    """The word for a difference: shown by its (Holm-adjusted, when given) test, or not."""
    p = est.p_value if adjusted is None else adjusted
    if math.isnan(p) or p >= ALPHA:
        return none
    return up if est.value > 0 else down


def time_text(est: dict[str, metrics.MetricEstimate]) -> str:
    """Time to threshold in words: censored per seed, with the shares that reach it.

    "Never" (no seed of the method reaches the threshold while the baseline does) is a
    clear negative result and is said so; "neither reaches it" leaves the time undefined.
    """
    reached_t, reached_b = est["threshold_reached_transfer"], est["threshold_reached_baseline"]
    n = reached_t.n
    kt, kb = round(reached_t.value * n), round(reached_b.value * n)
    shares = f"{kt} of {n} seeds reach the threshold, {kb} of {n} of the baseline"
    if kt == 0 and kb == 0:
        return ("time to threshold undefined: neither the method nor the baseline reaches "
                "the threshold within the budget on any seed")
    if kt == 0:
        return (f"time to threshold: never within the budget (no seed reaches the "
                f"threshold, while {kb} of {n} of the baseline do), a clear negative result")

    def median(e: metrics.MetricEstimate) -> str:
        return "beyond the budget" if e.value == math.inf else f"{e.value:.0f} episodes"

    ratio = est["time_to_threshold_ratio"]
    aim = "at most half: aim met" if ratio.high <= 0.5 else "aim of at most half not shown"
    return (f"time to threshold (restricted mean, censored at the budget) "
            f"{interval_text(ratio, '.2f')} times that of the baseline ({aim}); {shares}; "
            f"Kaplan-Meier medians {median(est['median_time_to_threshold_transfer'])} and "
            f"{median(est['median_time_to_threshold_baseline'])}")


def verdict(estimates: dict[str, metrics.MetricEstimate],
            adjusted: dict[str, float] | None = None, episodes: int | None = None) -> str:
    """One sentence on the jumpstart, the total-reward gain, the final performance and
    the time to threshold.

    With ``adjusted`` (Holm-adjusted p-values of the :data:`PRIMARY` endpoints) the
    jumpstart and total-reward gain are judged by them; without, by their unadjusted
    tests (descriptive rows). Final performance is always judged unadjusted.
    """
    js, gain, final = (estimates["jumpstart"], estimates["total_reward_gain"],
                       estimates["final_gain"])

    def p_text(key: str) -> str:
        flip = estimates[key].p_sign_flip
        beside = "" if math.isnan(flip) else f"; sign-flip p = {flip:.2g}, unadjusted"
        if adjusted is None:
            return f"p = {estimates[key].p_value:.2g}{beside}"
        return f"Holm-adjusted p = {adjusted[key]:.2g}{beside}"

    over = f" over {episodes} episodes" if episodes else ""
    parts = [
        _effect(js, None if adjusted is None else adjusted["jumpstart"], "a head start",
                "a worse start", "no demonstrated head start")
        + f": jumpstart {interval_text(js, '+.3f')} ({p_text('jumpstart')})",
        _effect(gain, None if adjusted is None else adjusted["total_reward_gain"],
                "more total reward", "less total reward", "no demonstrated total-reward gain")
        + f": total-reward gain {interval_text(gain, '+.1f')}{over} "
        f"({p_text('total_reward_gain')})",
        _effect(final, None, "a higher final performance", "a lower final performance",
                "no demonstrated change in final performance")
        + f" within the budget: {interval_text(final, '+.3f')}",
    ]
    if "time_to_threshold_ratio" in estimates:
        parts.append(time_text(estimates))
    return "; ".join(parts)


def verdict_lines(estimates: dict[str, dict[str, metrics.MetricEstimate]],
                  episodes: int, pooled: str = "") -> list[str]:
    """The primary verdicts: one bullet per method, Holm-adjusted across the methods and
    the endpoints of :data:`~ilpss.experiments.report_stats.PRIMARY_FAMILY`."""
    adjusted = holm_primary(estimates, family=PRIMARY_FAMILY)
    n = len(estimates) * len(PRIMARY_FAMILY.metrics)
    lines = [f"Primary endpoints{pooled}: per method, the jumpstart and the total-reward gain "
             f"against the baseline, {n} tests in one family with Holm's adjustment "
             f"(family-wise error {ALPHA:g}). Intervals are unadjusted 95% intervals; final "
             "performance and time to threshold are descriptive.", ""]
    for method, est in estimates.items():
        lines.append(f"- **{label(method)}** vs the baseline: "
                     f"{verdict(est, adjusted[method], episodes)}.")
    return lines


def doc_reference(name: str, folder: str | os.PathLike[str] | None = None) -> str:
    """A reference to the repository's page ``docs/<name>`` from a file written into
    ``folder``: a link if the page is there beside it (the repository's ``docs/``), else
    the page's place in the repository as plain text, which a run folder copied anywhere
    keeps right."""
    if folder is not None and (Path(folder) / name).is_file():
        return f"[`{name}`]({name})"
    return f"`docs/{name}` in the repository"


def metrics_note(n_episodes: int | None = None,
                 folder: str | os.PathLike[str] | None = None) -> str:
    """The paragraph defining the metrics and intervals of every report; with
    ``n_episodes`` (the curves' length), its windows as :func:`windows` shortens them;
    ``folder`` is where the paragraph is written (see :func:`doc_reference`)."""
    first, last, smoothing = (windows(n_episodes) if n_episodes is not None else
                              (JUMPSTART_EPISODES, FINAL_EPISODES, SMOOTHING))
    return (
        f"Metrics (Taylor & Stone 2009), each against the baseline with the same seeds, "
        f"counting only the episodes on the target task (the source tasks' episodes are not "
        f"charged to transfer: weak-transfer accounting): jumpstart over the first "
        f"{first} episodes; final performance within the budget, the mean of "
        f"the last {last} (not an asymptote: the learners may still be "
        f"improving); total reward (area); transfer ratio (areas above the floor -1); time "
        f"to threshold ({THRESHOLD_SHARE:.0%} of the way from -1 to the baseline's final "
        f"performance, on a {smoothing}-episode trailing mean), taken per seed and censored "
        "at the budget, summarised by the restricted mean time, the Kaplan-Meier median and "
        "the share of seeds that reach it. Intervals: 95%, over seeds (the seed is the unit; "
        "differences are paired by seed): Student t for means and differences, Fieller for "
        "ratios of means, Wilson for shares, order statistics for medians; why these "
        f"intervals, and their simulated coverage, is in {doc_reference('statistics.md', folder)}."
    )


def structure_b(table: dict, baseline: str) -> str:
    """Protocol B: what its streams are, and what they are not."""
    teams = team_streams(table)
    orders = sorted({len(s) for s in teams.values()})
    k = orders[0] if len(orders) == 1 else f"{orders[0]}-{orders[-1]}"
    text = f"The {len(table)} streams are {len(teams)} held-out teams x {k} source orders. "
    if baseline_shared_across_orders(table, baseline):
        text += (f"The baseline does not depend on the source order: its curves against a "
                 f"team are identical in the team's {k} orders (checked on the result files). "
                 f"So the streams of a team share their baseline and their seeds; they are "
                 f"{k} looks at one team, not {k} independent confirmations.")
    else:
        text += ("The baseline's curves differ between the source orders of a team, yet the "
                 "orders of a team share their seeds, so they are not independent "
                 "confirmations.")
    return text + (" Per-stream rows are descriptive: they are neither adjusted for "
                   "multiplicity nor counted as confirmations; the primary endpoints are "
                   "the pooled ones.")


def structure_targets(n: int) -> str:
    """Several targets after one source history: what they are, and what they are not."""
    return (f"The {n} targets all start from each seed's state after the sources, and learn "
            "with the same seeds of that trial: they share the seed's source history, so "
            f"they are {n} looks after one history, not {n} independent confirmations. "
            "Per-target rows are descriptive: they are neither adjusted for multiplicity "
            "nor counted as confirmations; the primary endpoints are the pooled ones.")


def trend_line(trend: tuple[float, float, float, float, int] | None, label: str) -> str:
    """Protocol C's trend test in words."""
    if trend is None:
        return "- The trend along the stream needs at least 2 seeds and 2 opponents."
    value, low, high, p, n = trend
    said = ("grows" if low > 0 else "shrinks" if high < 0 else "shows no demonstrated trend")
    return (f"- **Along the stream**, the jumpstart of {label} {said}: slope "
            f"{value:+.4f} per opponent, 95% interval [{low:+.4f}, {high:+.4f}], p = {p:.2g} "
            f"(one test: each seed's least-squares slope over the opponents, t over the {n} "
            "seeds, so a seed's opponents count as one cluster).")


def comparison_row(name: str, est: dict[str, metrics.MetricEstimate]) -> str:
    """One row of a table against the baseline: every headline metric
    (:func:`ilpss.metrics.headline_metrics`) with its interval, and the seeds that reach
    the threshold."""
    n = est["jumpstart"].n
    reached = (f"{round(est['threshold_reached_transfer'].value * n)}/{n}, "
               f"{round(est['threshold_reached_baseline'].value * n)}/{n}")
    cells = [interval_text(est[m.name], m.fmt) for m in metrics.headline_metrics()
             if m.name in est]
    return f"| {name} | " + " | ".join(cells) + f" | {reached} |"


def comparison_head(what: str) -> list[str]:
    """The head of a table of :func:`comparison_row` rows."""
    cells = [f"{m.label} [95% CI]" for m in metrics.headline_metrics()]
    return [f"| {what} | " + " | ".join(cells) + " | seeds reaching the threshold "
            "(method, baseline) |", "|---|" + "---:|" * (len(cells) + 1)]


def headline_table(estimates: dict[str, dict[str, metrics.MetricEstimate]],
                   scope: str) -> list[str]:
    """Every method against the baseline on the headline metrics, one row each (unadjusted
    95% intervals; ``scope`` says over what)."""
    return [f"Against the baseline ({scope}; unadjusted 95% intervals over seeds; the dip "
            "and the episodes below the baseline are described under the next heading):", "",
            *comparison_head("method"),
            *[comparison_row(label(m), est) for m, est in estimates.items()]]


def dip_lines(curves: dict[str, np.ndarray], baseline: str) -> list[str]:
    """The handover, per method: how far the seed-mean curve's trailing mean falls below
    its earlier maximum, how many episodes it lies more than
    :data:`~ilpss.metrics.BELOW_MARGIN` below the baseline's, and the same per seed with an
    interval."""
    window = windows(curves[baseline].shape[1])[2]
    base = trailing_mean(curves[baseline])
    rows = []
    for method, c in curves.items():
        mine = trailing_mean(c)
        dip, below = dip_and_below(mine, base)
        per_seed = metrics.largest_dip(c, window)
        value, low, high = (metrics.t_interval(per_seed) if len(per_seed) >= 2
                            else (float(per_seed.mean()), math.nan, math.nan))
        rows.append(f"| {label(method)} | {dip:.2f} | {below} | {value:.2f} "
                    f"[{_signed(low, '.2f')}, {_signed(high, '.2f')}] |")
    return [f"The handover (descriptive): the largest fall of the {window}-episode trailing "
            "mean below its earlier maximum (from the first full window on), on the seed-mean "
            "curve the figures show and per seed (mean, 95% t interval), and the episodes at "
            f"which the seed-mean trailing mean lies more than {metrics.BELOW_MARGIN:g} below "
            "the baseline's.", "",
            "| method | largest dip, seed-mean curve | episodes below the baseline | largest "
            "dip per seed [95% CI] |", "|---|---:|---:|---:|", *rows, ""]


def per_target_dips(per_target: dict[int, dict[str, np.ndarray]], names: Sequence[str],
                    baseline: str) -> list[str]:
    """Several targets: each method's seed-mean largest dip and episodes below the
    baseline on every target (a method that never collapses does not on any)."""
    methods = list(next(iter(per_target.values())))
    head = "| method | " + " | ".join(f"`{names[t]}`: dip, below" for t in per_target) + " |"
    rows = []
    for method in methods:
        cells = []
        for curves in per_target.values():
            dip, below = dip_and_below(trailing_mean(curves[method]), trailing_mean(curves[baseline]))
            cells.append(f"{dip:.2f}, {below}")
        rows.append(f"| {label(method)} | " + " | ".join(cells) + " |")
    return ["### The handover on each target (descriptive)", "",
            "Seed-mean curves: the largest fall of the trailing mean below its earlier "
            f"maximum, and the episodes more than {metrics.BELOW_MARGIN:g} below the "
            "baseline's.", "",
            head, "|---|" + "---:|" * len(per_target), *rows, ""]


def worst_target_dips(per_target: dict[int, dict[str, np.ndarray]], names: Sequence[str],
                      baseline: str) -> list[str]:
    """Many targets: each method's largest seed-mean dip and most episodes below the
    baseline over all of them, with the target where each occurs (a method that never
    collapses does not on any; a table per target would be too wide to read)."""
    methods = list(next(iter(per_target.values())))
    rows = []
    for method in methods:
        found = {t: dip_and_below(trailing_mean(curves[method]), trailing_mean(curves[baseline]))
                 for t, curves in per_target.items()}
        deepest = max(found, key=lambda t: found[t][0])
        longest = max(found, key=lambda t: found[t][1])
        rows.append(f"| {label(method)} | {found[deepest][0]:.2f} (`{names[deepest]}`) | "
                    f"{found[longest][1]} (`{names[longest]}`) |")
    return ["### The handover on the worst target (descriptive)", "",
            f"Seed-mean curves on each of the {len(per_target)} targets: the largest fall of "
            "the trailing mean below its earlier maximum, and the most episodes more than "
            f"{metrics.BELOW_MARGIN:g} below the baseline's, over all targets, with the "
            "target where each occurs.", "",
            "| method | largest dip on any target | most episodes below the baseline on any "
            "target |", "|---|---:|---:|", *rows, ""]


def pairwise_lines(curves: dict[str, np.ndarray], baseline: str, *,
                   family: HolmFamily = METHOD_PAIRS_FAMILY) -> list[str]:
    """The transfer methods against each other (:func:`pairwise_estimates`), as a table
    whose tests of ``family`` are Holm-adjusted together, and the metrics of the family on
    which one method beats every other by a Holm-adjusted test."""
    if len(curves[baseline]) < 2 or len(curves) < 3:
        return []
    pairs = pairwise_estimates(curves, baseline, family=family)
    compared = pairwise_metrics_shown(family)
    rows = [_pair_row(a, b, est, compared, family) for (a, b), est in pairs.items()]
    methods = [m for m in curves if m != baseline]
    best = [f"**{label(a)}** is ahead of every other transfer method on {m.label} in these "
            f"runs, each difference above zero with a Holm-adjusted p below {ALPHA:g} "
            "(descriptive: a ranking read from these seeds is confirmed only on fresh ones)."
            for m in compared if m.name in family.metrics for a in methods
            if _beats_every_other(pairs, a, methods, m)]
    said = best or ["No transfer method is ahead of every other on any of these metrics by "
                    "a Holm-adjusted test."]
    return [_pairs_intro(len(pairs), compared, family), "",
            "| methods | " + " | ".join(f"{m.label} [95% CI]" for m in compared) + " |",
            "|---|" + "---:|" * len(compared), *rows, "", *[f"- {t}" for t in said], ""]


def _pairs_intro(n_pairs: int, compared: Sequence[metrics.Metric], family: HolmFamily) -> str:
    """What a method-against-method table shows, and which of its tests are adjusted."""
    text = ("Method against method (descriptive family of its own): the paired difference "
            "over seeds (the first named minus the second), 95% t interval, and the p-value ")
    outside = [m.label for m in compared if m.name not in family.metrics]
    if not outside:
        return text + f"Holm-adjusted across the {n_pairs} pairs x {len(compared)} metrics."
    return text + (f"Holm-adjusted across the {n_pairs} pairs x {len(family.metrics)} metrics "
                   f"of its family; the p-values of {', '.join(outside)} are unadjusted.")


def _pair_row(a: str, b: str, est: dict[str, tuple[float, float, float, float]],
              compared: Sequence[metrics.Metric], family: HolmFamily) -> str:
    """One row of a method-against-method table: each metric's difference, interval and
    p-value (marked when it is outside the adjusted family)."""
    cells = [f"{interval_text(_Estimate(*est[m.name][:3]), m.fmt)} (p = {est[m.name][3]:.2g}"
             + ("" if m.name in family.metrics else ", unadjusted") + ")" for m in compared]
    return f"| {label(a)} - {label(b)} | " + " | ".join(cells) + " |"


def _beats_every_other(pairs: dict, a: str, methods: Sequence[str],
                       metric: metrics.Metric) -> bool:
    """Whether ``a`` beats every other of ``methods`` on ``metric`` (:func:`_beats`)."""
    wins = [_beats(pairs, a, b, metric) for b in methods if b != a]
    return bool(wins) and all(wins)


@dataclass(frozen=True)
class _Estimate:
    """A value and its interval, for :func:`interval_text`."""

    value: float
    low: float
    high: float


def _beats(pairs: dict, a: str, b: str, metric: metrics.Metric) -> bool:
    """Whether ``a`` beats ``b`` on ``metric`` (its sign of better) by a Holm-adjusted
    test, whichever way round the pair was stored."""
    if (a, b) in pairs:
        value, _, _, p = pairs[a, b][metric.name]
    else:
        value, _, _, p = pairs[b, a][metric.name]
        value = -value
    return p < ALPHA and value * metric.better > 0


def target_tables(estimates: dict[int, dict[str, dict[str, metrics.MetricEstimate]]],
                  names: Sequence[str]) -> list[str]:
    """Per method, a descriptive row per target (``{target: {method: metrics}}``)."""
    lines: list[str] = []
    for method in next(iter(estimates.values())):
        lines += [f"### {label(method)} vs the baseline, per target (descriptive)", "",
                  *comparison_head("target"),
                  *[comparison_row(f"`{names[t]}`", est[method]) for t, est in estimates.items()],
                  ""]
    n = next(iter(next(iter(estimates.values())).values()))["jumpstart"].n
    return [*lines, f"Unadjusted 95% intervals over the {n} seeds of each of the "
            f"{len(estimates)} targets; the pooled rows are the verdicts above.", ""]


def protocol_c_lines(
    jumpstarts: list[tuple[int, metrics.MetricEstimate]], sizes: dict[str, np.ndarray],
    figure: str, featured: str | None,
) -> list[str]:
    """Protocol C's figure link, the featured method's jumpstart on each opponent and the
    final library sizes, as markdown."""
    rows = ["Per opponent, descriptive: 95% t intervals over seeds, not adjusted for the "
            f"{len(jumpstarts)} opponents; the claim that the head start grows is the one "
            "trend test above.", "",
            f"| opponent | jumpstart ({label(featured or '')} - baseline) | 95% CI |",
            "|---|---:|---|"]
    rows += [f"| {t} | {js.value:+.3f} | [{js.low:+.3f}, {js.high:+.3f}] |"
             for t, js in jumpstarts]
    if not jumpstarts:
        rows = ["Transfer metrics need at least 2 seeds." if featured else
                "No method of this run is featured (ExperimentConfig.featured)."]
    lines = [f"![stream]({figure})", "", *rows, ""]
    for method, runs in sizes.items():
        final = runs[:, -1]
        lines.append(f"- {label(method)}: {final.mean():.1f} active options after the last "
                     f"trial (min {final.min():.0f}, max {final.max():.0f} over seeds).")
    return lines


def success_lines(results: list[dict[str, Any]]) -> list[str]:
    """Per target (stream and task) and method, the success rate early and late in
    learning it: the reward curves say how well, this says how often."""
    table = collect(results)
    names: dict[str, set[tuple[str, ...]]] = defaultdict(set)
    for res in results:
        names[res["stream"]].add(tuple(res["tasks"]))
    methods = list(next(iter(table.values())))
    rows, episodes = [], 0
    for stream, by_method in table.items():
        (tasks,) = names[stream] if len(names[stream]) == 1 else (None,)
        for t in sorted(next(iter(by_method.values()))):
            cells = []
            for m in methods:
                curves = by_method.get(m, {}).get(t)
                if curves is None:
                    cells.append("-")
                    continue
                early, late = success_rates(curves)
                episodes = curves.shape[1]
                cells.append(f"{100 * early:.0f} % -> {100 * late:.0f} %")
            # Protocol C draws each seed's opponents: a task index names no one team.
            target = f"`{tasks[t]}`" if tasks else f"opponent {t} (drawn per seed)"
            rows.append(f"| {stream} | {target} | " + " | ".join(cells) + " |")
    first, last, _ = windows(episodes)
    return ["## Success rate on each target (descriptive)", "",
            f"Share of episodes that end in a success, over the first {first} and the last "
            f"{last} episodes of learning the target, all seeds pooled (first -> last).", "",
            "| stream | target | " + " | ".join(label(m) for m in methods) + " |",
            "|---|---|" + "---:|" * len(methods), *rows, ""]
