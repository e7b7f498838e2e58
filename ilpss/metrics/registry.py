"""The metrics of a paired comparison, each declared once, and :func:`compare`.

Every metric is one :class:`Metric` entry of :data:`METRICS`: its per-seed values, the
interval that summarises them, its written definition, and how reports name and format it.
:func:`compare` takes ``(n_seeds, n_episodes)`` arrays for a transfer method and a
baseline whose rows are *paired* (row ``s`` of both was run with the same seed and
opponent order) and returns a :class:`MetricEstimate` per metric.

Metrics and point estimates (every metric is first computed per seed, and the seed is the
unit of every interval and test):

* ``jumpstart``, ``final_*``, ``total_reward_*``: mean over seeds of the per-seed
  value. ``final_*`` is the mean of the last ``last`` episodes, the *final
  performance within the budget*: the learner may still be improving, so it is not an
  asymptote.
* ``transfer_ratio``: ratio of the mean areas above the floor,
  ``mean_s area_T[s] / mean_s area_B[s]`` (Taylor & Stone's definition on averaged
  curves; a mean of per-seed ratios would be biased and unstable).
* ``time_to_threshold_*``: per seed, the episodes until the trailing mean reaches
  ``threshold``, *censored at the budget* (:func:`~ilpss.metrics.threshold_times`),
  summarised by the restricted mean time (:func:`~ilpss.metrics.restricted_mean_time` up
  to the budget: a seed that never reaches the threshold counts the whole budget).
  ``time_to_threshold_gain`` is the paired difference and ``time_to_threshold_ratio`` the
  ratio of the two restricted means (``< 1`` favours transfer; always defined).
  ``median_time_to_threshold_*`` is the Kaplan-Meier median
  (:func:`~ilpss.metrics.km_median`, ``inf`` when fewer than half of the seeds reach the
  threshold) and ``threshold_reached_*`` the share of seeds that reach it.

Intervals (``interval="t"``, the default): Student t on the per-seed values
(:func:`~ilpss.metrics.t_interval`; for differences, on the paired differences), Fieller
for the two ratios of means (:func:`~ilpss.metrics.fieller_interval`), Wilson for the
shares (:func:`~ilpss.metrics.wilson_interval`) and order statistics for the medians
(:func:`~ilpss.metrics.median_interval`). Differences and ratios carry the p-value of the
test the interval inverts. ``interval="percentile"`` replaces the t and Fieller intervals
by a paired percentile bootstrap over seeds (``n_boot`` replicates from
``np.random.default_rng(seed)``, the same resampled seeds for every metric; no
p-values), which covers too rarely at 10 seeds (``docs/statistics.md``); it is kept to
measure that.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ilpss.metrics._validation import (
    FloatArray,
    _as_curves,
    _check_count,
    _check_floor,
    _check_real,
)
from ilpss.metrics.dips import BELOW_MARGIN, episodes_below, largest_dip
from ilpss.metrics.inference import (
    INTERVALS,
    _check_boot,
    _percentile_interval,
    _resample_counts,
    fieller_interval,
    sign_flip_pvalue,
    t_interval,
    t_test_pvalue,
    wilson_interval,
)
from ilpss.metrics.survival import km_median, median_interval, threshold_times
from soccer_drill.constraints import Bool, checked

SIGN_FLIP_RESAMPLES = 20_000
"""Random sign assignments of the sign-flip p beside a report's t p (beyond 16 seeds; up to
16 every one is used): p to about +-0.003 at 0.05."""


def per_seed_gains(
    transfer_curves: ArrayLike, baseline_curves: ArrayLike, *, first: int, last: int
) -> dict[str, FloatArray]:
    """Each seed's jumpstart, final-performance gain and total-reward gain.

    Row ``s`` of both arrays is one seed (or one run); the values are the per-curve
    metrics :func:`jumpstart`, :func:`asymptotic_gain` (final performance within the
    budget) and :func:`total_reward_gain` of that row, as :func:`compare` averages them.

    Parameters
    ----------
    transfer_curves, baseline_curves : array_like, shape (n_seeds, n_episodes)
        Paired curves, same shape, finite.
    first, last : int
        Episodes averaged for the jumpstart and for the final performance.

    Returns
    -------
    dict
        ``{"jumpstart": ..., "final_gain": ..., "total_reward_gain": ...}``, each of
        shape ``(n_seeds,)``.
    """
    t = _as_curves(transfer_curves, "transfer_curves")
    b = _as_curves(baseline_curves, "baseline_curves")
    if t.shape != b.shape:
        raise ValueError(f"transfer_curves and baseline_curves must have the same shape, got "
                         f"{t.shape} and {b.shape}")
    paired = Paired(t, b, first=_check_count(first, "first", t.shape[1]),
                    last=_check_count(last, "last", t.shape[1]))
    return {m.name: m.values(paired) for m in METRICS if m.name in GAINS}


# --------------------------------------------------------------------------- paired comparison
@dataclass(frozen=True)
class MetricEstimate:
    """A metric estimated over seeds, with its interval.

    Attributes
    ----------
    name : str
        Metric key, e.g. ``"jumpstart"``.
    value : float
        Point estimate on all seeds (see ``definition``).
    low, high : float
        Interval bounds (infinite when the interval is unbounded, ``nan`` when the metric
        is undefined).
    n : int
        Number of (paired) seeds.
    definition : str
        Exact written definition, with the parameters used.
    confidence : float
        Coverage of the interval (default 0.95).
    interval : str
        Which interval: ``"Student t"``, ``"Fieller"``, ``"Wilson"``,
        ``"order statistics"`` or ``"percentile bootstrap"``.
    p_value : float
        For a difference (ratio): two-sided p-value of "no difference" (ratio 1) from the
        test the interval inverts; ``nan`` where there is none.
    p_sign_flip : float
        For a headline difference: the two-sided p-value of the sign-flip permutation
        test of the same hypothesis (:func:`~ilpss.metrics.sign_flip_pvalue`, 20,000
        resamples beyond 16 seeds), the distribution-free check beside the t-test;
        ``nan`` elsewhere.
    """

    name: str
    value: float
    low: float
    high: float
    n: int
    definition: str
    confidence: float = 0.95
    interval: str = ""
    p_value: float = math.nan
    p_sign_flip: float = math.nan


@dataclass(frozen=True)
class Paired:
    """Paired curves and the windows of their metrics (what every :class:`Metric` reads).

    ``transfer`` and ``baseline`` are ``(n_seeds, n_episodes)``, row ``s`` of both from
    the same seed. The threshold times are computed once, when first read.
    """

    transfer: FloatArray
    baseline: FloatArray
    first: int
    last: int
    threshold: float | None = None
    window: int = 1
    floor: float = -1.0
    warmup: bool = False

    @property
    def n_episodes(self) -> int:
        """Episodes per curve."""
        return int(self.transfer.shape[1])

    @functools.cached_property
    def times(self) -> tuple[tuple[FloatArray, NDArray[np.bool_]],
                             tuple[FloatArray, NDArray[np.bool_]]]:
        """``((times, reached) of transfer, (times, reached) of baseline)``."""
        assert self.threshold is not None
        return (threshold_times(self.transfer, self.threshold, self.window,
                                warmup=self.warmup),
                threshold_times(self.baseline, self.threshold, self.window,
                                warmup=self.warmup))

    @functools.cached_property
    def warm_times(self) -> tuple[tuple[FloatArray, NDArray[np.bool_]],
                                  tuple[FloatArray, NDArray[np.bool_]]]:
        """:attr:`times` with the first episodes counted (:func:`threshold_times`'
        ``warmup``), whatever :attr:`warmup` says: a second view, in which one good first
        episode gives time 1."""
        assert self.threshold is not None
        return (threshold_times(self.transfer, self.threshold, self.window, warmup=True),
                threshold_times(self.baseline, self.threshold, self.window, warmup=True))


@dataclass(frozen=True)
class Metric:
    """One metric of :func:`compare`, declared once: how it is computed per seed, which
    interval summarises it, its definition, and how reports name and format it.

    ``kind``: ``"mean"`` (``values`` gives one value per seed; Student t, or a
    percentile bootstrap), ``"ratio"`` (``values`` gives the per-seed numerators and
    denominators; Fieller), ``"median"`` (censored times and whether each seed reached
    the threshold; order statistics) or ``"share"`` (whether each seed reached it;
    Wilson).
    """

    name: str
    label: str
    fmt: str
    kind: Literal["mean", "ratio", "median", "share"]
    values: Callable[[Paired], Any]
    definition: Callable[[Paired], str]
    test: bool = False
    """Whether it carries the p-value of "no difference" (of a difference or a ratio)."""
    threshold: bool = False
    """Whether it needs the time-to-threshold level."""
    better: int = 1
    """+1: a larger value favours the method; -1: a smaller one does."""
    headline: bool = False
    """Shown in every report's table of each method against the baseline."""
    pairwise: bool = False
    """Compared method against method too (a paired difference: ``kind == "mean"``)."""

    def estimate(self, paired: Paired, confidence: float = 0.95,
                 weights: FloatArray | None = None) -> MetricEstimate:
        """This metric over the seeds of ``paired``, with its interval (a percentile
        bootstrap of the means and ratios when resampling ``weights`` are given)."""
        values = self.values(paired)
        n = paired.transfer.shape[0]
        text = self.definition(paired)

        def made(value: float, low: float, high: float, how: str,
                 p: float = math.nan, flip: float = math.nan) -> MetricEstimate:
            return MetricEstimate(self.name, float(value), float(low), float(high), n, text,
                                  confidence, how, float(p), float(flip))

        if self.kind == "mean":
            if weights is not None:
                low, high = _percentile_interval(weights @ values, confidence)
                return made(values.mean(), low, high, "percentile bootstrap")
            value, low, high = t_interval(values, confidence)
            flip = (sign_flip_pvalue(values, n_resamples=SIGN_FLIP_RESAMPLES)
                    if self.test and self.headline else math.nan)
            return made(value, low, high, "Student t",
                        t_test_pvalue(values) if self.test else math.nan, flip)
        if self.kind == "ratio":
            num, den = values
            if weights is not None:
                with np.errstate(divide="ignore", invalid="ignore"):
                    reps = np.where(weights @ den == 0.0, np.nan,
                                    (weights @ num) / (weights @ den))
                low, high = _percentile_interval(reps, confidence, (0.0, math.inf))
                value = num.mean() / den.mean() if den.mean() != 0.0 else math.nan
                return made(value, low, high, "percentile bootstrap")
            value, low, high = fieller_interval(num, den, confidence)
            return made(value, low, high, "Fieller",
                        t_test_pvalue(num - den) if self.test else math.nan)
        if self.kind == "median":
            times, reached = values
            low, high = median_interval(times, reached, confidence)
            return made(km_median(times, reached), low, high, "order statistics")
        k = int(np.sum(values))
        low, high = wilson_interval(k, n, confidence)
        return made(k / n, low, high, "Wilson")


def _first_mean(curves: FloatArray, p: Paired) -> FloatArray:
    return curves[:, :p.first].mean(axis=1)


def _last_mean(curves: FloatArray, p: Paired) -> FloatArray:
    return curves[:, -p.last:].mean(axis=1)


_PAIRED = "paired by seed"
_FINAL = ("mean reward of the last {last} of the {n} episodes (final performance within the "
          "budget), ")
_TOTAL = "total reward = sum of the {n} per-episode rewards (discrete area), "
_RMST = "restricted mean time to threshold (up to the budget): mean over seeds of "
_DIP = ("mean over seeds of the largest fall of the {window}-episode trailing mean below its "
        "earlier maximum (from episode {window} on), ")
_MEDIAN = ("Kaplan-Meier median of the censored times to threshold, {who}; inf when fewer "
           "than half of the seeds reach the threshold within the budget")
_REACHED = ("share of seeds whose own trailing mean over {window} episodes reaches "
            "{threshold:g} within the budget, {who}")


def _crit(p: Paired) -> str:
    """The time-to-threshold criterion, as :func:`compare` defines it for ``p``."""
    if p.warmup:
        return (f"the first episode number t (1-based = episodes played, t >= 1) at which "
                f"the mean of the last {p.window} episodes (of all episodes so far before "
                f"episode {p.window}) is >= {p.threshold:g}, censored at the budget of "
                f"{p.n_episodes} episodes")
    return (f"the first episode number t (1-based = episodes played, t >= {p.window}) at "
            f"which the mean of episodes t-{p.window}+1..t is >= {p.threshold:g}, censored "
            f"at the budget of {p.n_episodes} episodes")


METRICS: tuple[Metric, ...] = (
    Metric("jumpstart", "jumpstart", "+.3f", "mean",
           lambda p: _first_mean(p.transfer, p) - _first_mean(p.baseline, p),
           lambda p: f"mean over seeds of (mean reward of the first {p.first} episodes with "
                     f"transfer) - (same for baseline), {_PAIRED}; reward units",
           test=True, headline=True, pairwise=True),
    Metric("final_transfer", "final performance", "+.3f", "mean",
           lambda p: _last_mean(p.transfer, p),
           lambda p: "mean over seeds of " + _FINAL.format(last=p.last, n=p.n_episodes)
           + "transfer"),
    Metric("final_baseline", "final performance of the baseline", "+.3f", "mean",
           lambda p: _last_mean(p.baseline, p),
           lambda p: "mean over seeds of " + _FINAL.format(last=p.last, n=p.n_episodes)
           + "baseline"),
    Metric("final_gain", "final performance gain", "+.3f", "mean",
           lambda p: _last_mean(p.transfer, p) - _last_mean(p.baseline, p),
           lambda p: f"mean over seeds of (mean reward of the last {p.last} episodes with "
                     f"transfer) - (same for baseline), {_PAIRED}; final performance within "
                     "the budget, not an asymptote; reward units",
           test=True, headline=True, pairwise=True),
    Metric("total_reward_transfer", "total reward", "+.1f", "mean",
           lambda p: p.transfer.sum(axis=1),
           lambda p: "mean over seeds of " + _TOTAL.format(n=p.n_episodes) + "transfer"),
    Metric("total_reward_baseline", "total reward of the baseline", "+.1f", "mean",
           lambda p: p.baseline.sum(axis=1),
           lambda p: "mean over seeds of " + _TOTAL.format(n=p.n_episodes) + "baseline"),
    Metric("total_reward_gain", "total-reward gain", "+.1f", "mean",
           lambda p: p.transfer.sum(axis=1) - p.baseline.sum(axis=1),
           lambda p: f"mean over seeds of (sum of the {p.n_episodes} rewards with transfer) "
                     f"- (same for baseline), {_PAIRED}",
           test=True, headline=True, pairwise=True),
    # The paper's aim is a quick response: the same gain over the first episodes alone
    # (a run's first 20 or 50 episodes are what a run of that budget would play). Not
    # pairwise: that would enlarge the Holm family of every report's method-against-method
    # table; a plan names them where they are endpoints.
    *(Metric(f"total_reward_gain_first_{k}", f"total-reward gain, first {k} episodes",
             "+.1f", "mean",
             lambda p, k=k: (p.transfer[:, :k].sum(axis=1) - p.baseline[:, :k].sum(axis=1)),
             lambda p, k=k: f"mean over seeds of (sum of the first {min(k, p.n_episodes)} "
                            f"rewards with transfer) - (same for baseline), {_PAIRED}",
             test=True) for k in (20, 50)),
    Metric("transfer_ratio", "transfer ratio", ".2f", "ratio",
           lambda p: ((p.transfer - p.floor).sum(axis=1), (p.baseline - p.floor).sum(axis=1)),
           lambda p: f"ratio of mean areas: mean over seeds of sum(transfer - ({p.floor:g})) "
                     f"/ mean over seeds of sum(baseline - ({p.floor:g})), areas above the "
                     f"reward floor {p.floor:g}; > 1 favours transfer", test=True),
    Metric("largest_dip_transfer", "largest dip", ".2f", "mean",
           lambda p: largest_dip(p.transfer, p.window),
           lambda p: _DIP.format(window=p.window) + "transfer; reward units",
           better=-1, headline=True),
    Metric("largest_dip_baseline", "largest dip of the baseline", ".2f", "mean",
           lambda p: largest_dip(p.baseline, p.window),
           lambda p: _DIP.format(window=p.window) + "baseline; reward units", better=-1),
    Metric("largest_dip_gain", "largest-dip difference", "+.2f", "mean",
           lambda p: largest_dip(p.transfer, p.window) - largest_dip(p.baseline, p.window),
           lambda p: f"mean over seeds of (largest dip with transfer) - (same for baseline), "
                     f"{_PAIRED}, dips of {p.window}-episode trailing means; < 0 favours "
                     "transfer", test=True, better=-1),
    Metric("episodes_below_baseline", "episodes below the baseline", ".1f", "mean",
           lambda p: episodes_below(p.transfer, p.baseline, p.window),
           lambda p: f"mean over seeds of the episodes (from episode {p.window} on) at which "
                     f"the {p.window}-episode trailing mean with transfer lies more than "
                     f"{BELOW_MARGIN:g} below the baseline's, {_PAIRED}", better=-1,
           headline=True),
    Metric("time_to_threshold_transfer", "time to threshold", ".1f", "mean",
           lambda p: p.times[0][0], lambda p: _RMST + _crit(p) + ", transfer",
           threshold=True, better=-1),
    Metric("time_to_threshold_baseline", "time to threshold of the baseline", ".1f", "mean",
           lambda p: p.times[1][0], lambda p: _RMST + _crit(p) + ", baseline",
           threshold=True, better=-1),
    Metric("time_to_threshold_gain", "time-to-threshold difference", "+.1f", "mean",
           lambda p: p.times[0][0] - p.times[1][0],
           lambda p: "mean over seeds of (censored time to threshold with transfer) - (same "
                     f"for baseline), {_PAIRED}; episodes; < 0 favours transfer",
           test=True, threshold=True, better=-1),
    Metric("time_to_threshold_ratio", "time to threshold (ratio)", ".2f", "ratio",
           lambda p: (p.times[0][0], p.times[1][0]),
           lambda p: "time_to_threshold_transfer / time_to_threshold_baseline (ratio of the "
                     "restricted mean times); < 1 favours transfer",
           test=True, threshold=True, better=-1, headline=True),
    Metric("time_to_threshold_ratio_warm", "time to threshold, warm start (ratio)", ".2f",
           "ratio", lambda p: (p.warm_times[0][0], p.warm_times[1][0]),
           lambda p: "the time-to-threshold ratio with the first episodes counted, on the "
                     f"mean of the episodes played so far before episode {p.window} (a "
                     "method at the threshold from its first episode has time 1, so one "
                     "good first episode decides it); < 1 favours transfer",
           test=True, threshold=True, better=-1, headline=True),
    Metric("median_time_to_threshold_transfer", "median time to threshold", ".0f", "median",
           lambda p: p.times[0], lambda p: _MEDIAN.format(who="transfer"),
           threshold=True, better=-1),
    Metric("median_time_to_threshold_baseline", "median time to threshold of the baseline",
           ".0f", "median", lambda p: p.times[1], lambda p: _MEDIAN.format(who="baseline"),
           threshold=True, better=-1),
    Metric("threshold_reached_transfer", "seeds reaching the threshold", ".0%", "share",
           lambda p: p.times[0][1],
           lambda p: _REACHED.format(window=p.window, threshold=p.threshold, who="transfer"),
           threshold=True),
    Metric("threshold_reached_baseline", "seeds of the baseline reaching the threshold",
           ".0%", "share", lambda p: p.times[1][1],
           lambda p: _REACHED.format(window=p.window, threshold=p.threshold, who="baseline"),
           threshold=True),
)
"""Every metric of :func:`compare`, in its output's order. Adding a metric is one entry
here: reports show the ``headline`` ones in their tables against the baseline and
compare the ``pairwise`` ones method against method."""
METRIC = {m.name: m for m in METRICS}
"""The entries of :data:`METRICS` by name."""


def headline_metrics() -> tuple[Metric, ...]:
    """The ``headline`` entries of :data:`METRICS`, in its order: the columns of every
    table of a method against the baseline (read from the table at each call)."""
    return tuple(m for m in METRICS if m.headline)


def pairwise_metrics() -> tuple[Metric, ...]:
    """The ``pairwise`` entries of :data:`METRICS`: what reports compare method against
    method."""
    return tuple(m for m in METRICS if m.pairwise)
GAINS = ("jumpstart", "final_gain", "total_reward_gain")
"""The paired per-seed differences that :func:`per_seed_gains` gives."""


def compare(
    transfer_curves: ArrayLike,
    baseline_curves: ArrayLike,
    *,
    first: int,
    last: int,
    threshold: float | None,
    window: int,
    floor: float = -1.0,
    interval: Literal["t", "percentile"] = "t",
    n_boot: int = 10000,
    confidence: float = 0.95,
    seed: int = 0,
    warmup: bool = False,
) -> dict[str, MetricEstimate]:
    """Paired, seed-level Taylor & Stone transfer metrics with intervals over seeds.

    Every metric is one entry of :data:`METRICS` (its per-seed values, its interval, its
    definition, how reports name and format it); this function estimates each of them.
    Row ``s`` of ``transfer_curves`` and of ``baseline_curves`` must come from the same
    seed (same opponent order / environment seed). The metrics and their intervals are
    described in :mod:`ilpss.metrics.registry`.

    Parameters
    ----------
    transfer_curves, baseline_curves : array_like, shape (n_seeds, n_episodes)
        Paired learning curves, same shape, finite, ``n_seeds >= 2``, every value
        ``>= floor``. Only episodes on the target task belong here (the source tasks'
        episodes are not counted: weak-transfer accounting).
    first : int
        Episodes averaged for the jumpstart.
    last : int
        Episodes averaged for the final performance.
    threshold : float or None
        Reward level for the time-to-threshold metrics; ``None`` omits them.
    window : int
        Trailing-mean window for time to threshold and for the largest dip.
    floor : float
        Minimum possible reward, the zero of the areas in ``transfer_ratio`` (default -1).
    interval : {"t", "percentile"}
        Interval family (default ``"t"``; ``"percentile"``: a paired percentile
        bootstrap over seeds, no p-values).
    n_boot : int
        Bootstrap replicates for ``interval="percentile"`` (default 10000).
    confidence : float
        Interval coverage (default 0.95).
    seed : int
        Seed of the resampling for ``interval="percentile"``.
    warmup : bool
        Time to threshold also over the first ``window - 1`` episodes, on the mean so
        far (:func:`~ilpss.metrics.threshold_times`); default: full windows only.

    Returns
    -------
    dict of str to MetricEstimate
        One estimate per entry of :data:`METRICS`, in its order (``jumpstart``,
        ``final_transfer``, ..., ``episodes_below_baseline``), the time-to-threshold
        ones (``threshold=True``) only if ``threshold`` is given.

    Raises
    ------
    ValueError
        Non-finite/empty input, shape mismatch, fewer than 2 seeds, parameters out of
        range (``first``, ``last``, ``window`` longer than the curves), rewards below
        ``floor``, unknown ``interval``.
    """
    paired, n_boot, confidence = _paired_inputs(
        transfer_curves, baseline_curves, first=first, last=last, threshold=threshold,
        window=window, floor=floor, interval=interval, n_boot=n_boot, confidence=confidence,
        warmup=warmup)
    n_seeds = paired.transfer.shape[0]
    weights = (_resample_counts(n_seeds, n_boot, seed) / n_seeds
               if interval == "percentile" else None)
    return {m.name: m.estimate(paired, confidence, weights) for m in METRICS
            if threshold is not None or not m.threshold}


def _paired_inputs(
    transfer_curves: ArrayLike, baseline_curves: ArrayLike, *, first: int, last: int,
    threshold: float | None, window: int, floor: float, interval: str, n_boot: int,
    confidence: float, warmup: bool,
) -> tuple[Paired, int, float]:
    """:func:`compare`'s arguments checked: the :class:`Paired` curves and windows, the
    replicates and the confidence level."""
    t = _as_curves(transfer_curves, "transfer_curves")
    b = _as_curves(baseline_curves, "baseline_curves")
    if t.shape != b.shape:
        raise ValueError(
            f"transfer_curves and baseline_curves must have the same (n_seeds, n_episodes) "
            f"shape with paired rows, got {t.shape} and {b.shape}"
        )
    if interval not in INTERVALS:
        raise ValueError(f"interval must be one of {INTERVALS}, got {interval!r}")
    n_seeds, n_eps = t.shape
    n_boot, confidence = _check_boot(n_boot, n_seeds, confidence)
    first = _check_count(first, "first", n_eps)
    last = _check_count(last, "last", n_eps)
    floor = _check_floor(t, floor, "transfer_curves")
    _check_floor(b, floor, "baseline_curves")
    if threshold is not None:
        threshold = _check_real(threshold, "threshold")
    window = _check_count(window, "window", n_eps)
    warmup = checked("warmup", warmup, Bool())  # "no" is truthy: a slip, not a choice
    return (Paired(t, b, first=first, last=last, threshold=threshold, window=window,
                   floor=floor, warmup=warmup), n_boot, confidence)
