"""The statistics of a report: curves gathered from the results, the windows and threshold
of the metrics, the comparisons against the baseline and between methods, and the declared
families of tests that Holm's method adjusts together.

Nothing here writes markdown or draws: :mod:`ilpss.experiments.report_text` says the
numbers in words, :mod:`ilpss.experiments.report_figures` draws them.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ilpss import metrics
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.methods import METHODS, LifelongMethod

JUMPSTART_EPISODES = 20
"""Jumpstart: mean reward over the first this many learning episodes."""


FINAL_EPISODES = 50
"""Final performance within the budget: mean reward over the last this many learning
episodes (not an asymptote: the learner may still be improving)."""


SMOOTHING = 20
"""Moving-average window of the plotted curves and of time to threshold."""


THRESHOLD_SHARE = 0.9
"""Time to threshold: the threshold is this share of the way from the floor (-1) to the
baseline's mean final performance."""


@dataclass(frozen=True)
class HolmFamily:
    """The tests of one table of a report that Holm's method adjusts together, declared by
    the section that shows the table: every comparison of the table (each method against
    the baseline, or each pair of methods) times the metrics named here.

    A metric joins a family only by being named here: declaring a metric ``pairwise`` (or
    ``headline``) shows it in the tables, with an unadjusted p-value, and leaves the
    family of every existing table, and so its adjusted p-values, as they were.

    Attributes
    ----------
    name : str
        What the family is, for readers of the code.
    metrics : tuple of str
        Names of entries of :data:`ilpss.metrics.METRICS` whose paired differences are
        tested (``kind == "mean"``), at least one, no repeats.
    """

    name: str
    metrics: tuple[str, ...]

    def __post_init__(self) -> None:
        names = self.metrics
        if not isinstance(names, tuple) or not names or \
                not all(isinstance(n, str) and n for n in names):
            raise ValueError(f"HolmFamily {self.name!r}: metrics must be a non-empty tuple of "
                             f"metric names, got {names!r}")
        if len(set(names)) != len(names):
            raise ValueError(f"HolmFamily {self.name!r}: metrics must be distinct, got "
                             f"{names!r}")

    def members(self) -> tuple[metrics.Metric, ...]:
        """The family's metrics, as declared in :data:`ilpss.metrics.METRICS` now.

        Raises
        ------
        ValueError
            A name that is not a metric, or a metric that is not a paired difference.
        """
        declared = {m.name: m for m in metrics.registry.METRICS}
        unknown = [n for n in self.metrics if n not in declared]
        if unknown:
            raise ValueError(f"HolmFamily {self.name!r} names {unknown}, which are not "
                             f"metrics; known: {sorted(declared)}")
        found = tuple(declared[n] for n in self.metrics)
        wrong = [m.name for m in found if m.kind != "mean"]
        if wrong:
            raise ValueError(f"HolmFamily {self.name!r}: {wrong} are not paired differences "
                             "(kind 'mean'), which is what a family's tests are")
        return found


PRIMARY_FAMILY = HolmFamily("primary endpoints", ("jumpstart", "total_reward_gain"))
"""The primary endpoints of every protocol, per method against the baseline (pooled over
the protocol's comparisons); their p-values are Holm-adjusted across methods and endpoints.
Everything else (final performance, time to threshold, the dips, per-stream and
per-opponent rows) is descriptive, and the method-against-method comparisons are their
own family (:data:`METHOD_PAIRS_FAMILY`), Holm-adjusted within it."""
PRIMARY = PRIMARY_FAMILY.metrics
"""The names of the :data:`PRIMARY_FAMILY` endpoints."""
METHOD_PAIRS_FAMILY = HolmFamily("method against method",
                                 ("jumpstart", "final_gain", "total_reward_gain"))
"""Every transfer method against every other, paired by seed: the tests adjusted together
in each method-against-method table (all pairs x these metrics). Another ``pairwise``
metric is shown beside them, unadjusted, unless a family names it."""


ALPHA = 0.05
"""Family-wise error rate of the primary endpoints."""


def collect(results: list[dict[str, Any]]) -> dict[str, dict[str, dict[int, np.ndarray]]]:
    """``{stream: {method: {task index: curves (n_seeds, episodes)}}}``, seeds in order."""
    table: dict = defaultdict(lambda: defaultdict(lambda: defaultdict(list)))
    for res in sorted(results, key=lambda r: (r["stream_index"], r["seed"])):
        for method, data in res["methods"].items():
            for t, curve in data["curves"].items():
                table[res["stream"]][method][int(t)].append(curve)
    return {
        s: {m: {t: np.asarray(c, dtype=float) for t, c in tasks.items()} for m, tasks in ms.items()}
        for s, ms in table.items()
    }


def windows(n_episodes: int) -> tuple[int, int, int]:
    """(jumpstart, final performance, smoothing) episode counts, shortened for short curves."""
    return (min(JUMPSTART_EPISODES, n_episodes), min(FINAL_EPISODES, n_episodes),
            min(SMOOTHING, n_episodes))


def threshold_for(baseline: np.ndarray) -> float:
    """The time-to-threshold level (see :data:`THRESHOLD_SHARE`)."""
    _, last, _ = windows(baseline.shape[1])
    asym = float(np.mean(baseline[:, -last:]))
    return -1.0 + THRESHOLD_SHARE * (asym + 1.0)


def compare_to_baseline(curves: dict[str, np.ndarray], baseline: str,
                        seed: int = 0) -> dict[str, dict]:
    """Taylor & Stone metrics of every method against ``baseline`` (time to threshold
    over full windows; the warm start, :func:`ilpss.metrics.threshold_times`' warmup, is
    its own column)."""
    base = curves[baseline]
    threshold = threshold_for(base)
    first, last, window = windows(base.shape[1])
    return {method: metrics.compare(c, base, first=first, last=last, threshold=threshold,
                                    window=window, seed=seed)
            for method, c in curves.items() if method != baseline}


def target_curves(methods: dict[str, dict[int, np.ndarray]]) -> dict[str, np.ndarray]:
    """Protocols A and B: each method's curves ``(n_seeds, episodes)`` on the stream's
    single target (the held-out team)."""
    (target,) = sorted(next(iter(methods.values())))
    return {m: by_task[target] for m, by_task in methods.items()}


def comparable(curves: dict[str, np.ndarray], baseline: str) -> bool:
    """Whether the metrics against the baseline are defined (it ran, on 2 seeds or more)."""
    return baseline in curves and len(curves[baseline]) >= 2


def stream_estimates(
    table: dict, baseline: str
) -> dict[str, dict[str, dict[str, metrics.MetricEstimate]]]:
    """Protocols A and B: ``{stream: {method: metrics against the baseline}}`` on each
    stream's held-out target (``{}`` for a stream where they are undefined, see
    :func:`comparable`). ``table`` is the output of :func:`collect`."""
    out = {}
    for stream, methods in table.items():
        curves = target_curves(methods)
        out[stream] = compare_to_baseline(curves, baseline) if comparable(curves, baseline) \
            else {}
    return out


def pool(curve_sets: Sequence[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """Per method, each seed's curve averaged over several comparisons (streams, targets).

    Rows must be the same seeds in every set (as :func:`collect` gives them). Metrics that
    are linear in the curve (jumpstart, asymptotic performance, total reward and their
    gains) of the pooled curves equal the per-seed averages of the per-comparison metrics,
    and the bootstrap over seeds keeps each seed's comparisons together. Time to
    threshold and the transfer ratio are those of the pooled curves.
    """
    methods = list(curve_sets[0])
    return {m: np.mean([cs[m] for cs in curve_sets], axis=0) for m in methods}


def held_out_team(stream: str) -> str:
    """The held-out team of a protocol A or B stream label (``held_out=X[,shuffle=k]``)."""
    return stream.split(",")[0].removeprefix("held_out=")


def holm_primary(estimates: dict[str, dict[str, metrics.MetricEstimate]], *,
                 family: HolmFamily = PRIMARY_FAMILY) -> dict[str, dict]:
    """``{method: {endpoint: Holm-adjusted p}}`` for the endpoints of ``family`` (by
    default the primary ones) of every method, adjusted as one family (methods x
    endpoints)."""
    keys = [(m, e) for m in estimates for e in family.metrics]
    adjusted = metrics.holm([estimates[m][e].p_value for m, e in keys])
    out: dict[str, dict] = {m: {} for m in estimates}
    for (m, e), p in zip(keys, adjusted, strict=True):
        out[m][e] = float(p)
    return out


def pooled_estimates(curve_sets: Sequence[dict[str, np.ndarray]],
                     baseline: str) -> dict[str, dict]:
    """Every method against the baseline on each seed's curves averaged over several
    comparisons (:func:`pool`): the primary comparison of protocols B and C."""
    return compare_to_baseline(pool(curve_sets), baseline)


def seed_improvements(
    curve_sets: Sequence[dict[str, np.ndarray]], baseline: str,
) -> dict[str, dict[str, metrics.ImprovementTest]]:
    """``{method: {endpoint: paired probability of improvement over seeds}}`` on each
    seed's pooled curves: the seed, not the run, is the unit of the sign and Wilcoxon
    tests."""
    pooled = pool(curve_sets)
    first, last, _ = windows(pooled[baseline].shape[1])
    out = {}
    for method, c in pooled.items():
        if method != baseline:
            gains = metrics.per_seed_gains(c, pooled[baseline], first=first, last=last)
            out[method] = {e: metrics.improvement_test(gains[e]) for e in PRIMARY}
    return out


def team_streams(table: dict) -> dict[str, list[str]]:
    """Protocol B: ``{held-out team: its streams (one per source order)}``."""
    out: dict[str, list[str]] = defaultdict(list)
    for stream in table:
        out[held_out_team(stream)].append(stream)
    return dict(out)


def baseline_shared_across_orders(table: dict, baseline: str) -> bool:
    """Protocol B: whether the baseline's curves against each held-out team are the same
    in all of that team's source orders (a baseline that never sees the sources)."""
    for streams in team_streams(table).values():
        ref = target_curves(table[streams[0]]).get(baseline)
        for s in streams[1:]:
            other = target_curves(table[s]).get(baseline)
            if ref is None or other is None or not np.array_equal(ref, other):
                return False
    return True


def stream_trend(
    methods: dict[str, dict[int, np.ndarray]], method: str, baseline: str
) -> tuple[float, float, float, float, int] | None:
    """Protocol C: does ``method``'s jumpstart grow along the stream? One trend test.

    Per seed, the least-squares slope of its jumpstart on each new opponent against the
    opponent's index (:func:`ilpss.metrics.trend_slopes`); then the mean slope with a
    Student t interval and t-test over seeds, which treats the seed (its whole stream,
    sharing one library) as the unit. Returns ``(slope, low, high, p, n_seeds)`` per
    opponent, or ``None`` with fewer than 2 seeds or 2 opponents.
    """
    targets = sorted(methods[method])
    if len(targets) < 2 or len(methods[baseline][targets[0]]) < 2:
        return None
    per_target = []
    for t in targets:
        first, last, _ = windows(methods[baseline][t].shape[1])
        gains = metrics.per_seed_gains(methods[method][t], methods[baseline][t],
                                       first=first, last=last)
        per_target.append(gains["jumpstart"])
    slopes = metrics.trend_slopes(np.stack(per_target, axis=1), np.asarray(targets, float))
    value, low, high = metrics.t_interval(slopes)
    return float(value), float(low), float(high), float(metrics.t_test_pvalue(slopes)), \
        len(slopes)


def per_target_curves(methods: dict[str, dict[int, np.ndarray]]) -> dict[int, dict[str, np.ndarray]]:
    """``{target task index: {method: curves (n_seeds, episodes)}}``, targets in order."""
    targets = sorted(next(iter(methods.values())))
    return {t: {m: by_task[t] for m, by_task in methods.items()} for t in targets}


def trailing_mean(curves: np.ndarray) -> np.ndarray:
    """The seed-mean curve's trailing mean over the smoothing window (full windows)."""
    window = windows(curves.shape[1])[2]
    return metrics.smooth(curves.mean(axis=0), window, edges="valid")


def dip_and_below(mine: np.ndarray, base: np.ndarray) -> tuple[float, int]:
    """The largest dip of the trailing mean ``mine`` and the episodes at which it lies
    more than :data:`~ilpss.metrics.BELOW_MARGIN` below the baseline's ``base``."""
    return (float(metrics.largest_dip(mine, 1)),
            int(np.sum(mine < base - metrics.BELOW_MARGIN)))


def pairwise_metrics_shown(family: HolmFamily = METHOD_PAIRS_FAMILY) -> tuple[metrics.Metric, ...]:
    """The metrics of a method-against-method table, in the order of
    :data:`ilpss.metrics.METRICS`: the ``pairwise`` ones and those of ``family``."""
    wanted = {m.name for m in family.members()}
    return tuple(m for m in metrics.registry.METRICS if m.pairwise or m.name in wanted)


def pairwise_estimates(
    curves: dict[str, np.ndarray], baseline: str, *, family: HolmFamily = METHOD_PAIRS_FAMILY,
) -> dict[tuple[str, str], dict[str, tuple[float, float, float, float]]]:
    """Every transfer method against every other, paired by seed, on the metrics of
    :func:`pairwise_metrics_shown`: ``{(a, b): {metric: (value, low, high, p)}}``.

    The p-values of the metrics of ``family`` are Holm-adjusted within it (all pairs x
    its metrics); those of any other ``pairwise`` metric are unadjusted.
    """
    methods = [m for m in curves if m != baseline]
    first, last, window = windows(curves[baseline].shape[1])
    shown = pairwise_metrics_shown(family)
    raw: dict[tuple[str, str], dict[str, tuple[float, float, float, float]]] = {}
    for i, a in enumerate(methods):
        for b in methods[i + 1:]:
            paired = metrics.Paired(curves[a], curves[b], first=first, last=last,
                                    window=window)
            raw[a, b] = {m.name: _paired_difference(m.values(paired)) for m in shown}
    in_family = [(pair, m.name) for pair in raw for m in shown if m.name in family.metrics]
    adjusted = metrics.holm([raw[pair][m][3] for pair, m in in_family]) if in_family else []
    for (pair, m), p in zip(in_family, adjusted, strict=True):
        value, low, high, _ = raw[pair][m]
        raw[pair][m] = (value, low, high, float(p))
    return raw


def _paired_difference(diff: np.ndarray) -> tuple[float, float, float, float]:
    """``(mean, low, high, p)`` of per-seed differences: Student t interval and test."""
    value, low, high = metrics.t_interval(diff)
    return value, low, high, float(metrics.t_test_pvalue(diff))


def stream_jumpstarts(
    methods: dict[str, dict[int, np.ndarray]], method: str, baseline: str
) -> list[tuple[int, metrics.MetricEstimate]]:
    """Protocol C: ``(task index, jumpstart of method against the baseline)`` on every
    target of the stream (none with fewer than 2 seeds)."""
    out: list[tuple[int, metrics.MetricEstimate]] = []
    if len(methods[baseline][min(methods[baseline])]) < 2:
        return out
    for t in sorted(methods[method]):
        first, last, window = windows(methods[baseline][t].shape[1])
        est = metrics.compare(methods[method][t], methods[baseline][t], first=first,
                              last=last, threshold=None, window=window)
        out.append((t, est["jumpstart"]))
    return out


def library_sizes(cfg: ExperimentConfig,
                  results: list[dict[str, Any]]) -> dict[str, np.ndarray]:
    """``{method: active options after each trial, (n_seeds, n_trials)}`` of every lifelong
    method that offers options, seeds in order."""
    sizes: dict[str, list] = defaultdict(list)
    with_options = {m for m in cfg.methods if _offers_options(m, cfg)}
    for res in sorted(results, key=lambda r: (r["stream_index"], r["seed"])):
        for method, data in res["methods"].items():
            if method in with_options:
                sizes[method].append(data["library_size"])
    return {m: np.asarray(runs, dtype=float) for m, runs in sizes.items()}


def _offers_options(method: str, cfg: ExperimentConfig) -> bool:
    """Whether ``method`` is a lifelong method whose learners are offered options."""
    entry = METHODS.get(method)
    return isinstance(entry, LifelongMethod) and entry.config(cfg.lifelong).reuse.offers_options


def success_rates(curves: np.ndarray) -> tuple[float, float]:
    """Share of successful episodes (reward above 0: the drill pays at least 0.5 for a
    success and -1 otherwise) over the first and over the last episodes of
    :func:`windows`, pooled over the seeds of ``curves`` (n_seeds, episodes)."""
    first, last, _ = windows(curves.shape[1])
    won = curves > 0
    return float(won[:, :first].mean()), float(won[:, -last:].mean())
