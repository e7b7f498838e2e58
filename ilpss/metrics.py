"""Transfer metrics for learning curves (Taylor & Stone 2009), with intervals over seeds.

A *learning curve* is a 1-D array of rewards indexed by training episode (or by evaluation
point: every function below treats the index generically, so "episode" may be read as
"evaluation point" throughout; the caller converts to episodes if needed). Rewards are
assumed to lie in ``[floor, ...]`` with ``floor = -1.0`` by default.

Per-curve metrics (Taylor & Stone 2009, "Transfer Learning for Reinforcement Learning
Domains: A Survey", JMLR 10, section 2.1):

* :func:`jumpstart` -- initial advantage: mean of the first ``K`` points, transfer minus
  baseline.
* :func:`asymptotic_performance` / :func:`asymptotic_gain` -- mean of the last ``K``
  points, and its difference. On a finite budget this is the *final performance within
  the budget*, not an asymptote: the learner may still be improving.
* :func:`total_reward` / :func:`total_reward_gain` -- discrete area under the curve.
* :func:`transfer_ratio` -- ratio of areas measured above a reward floor.
* :func:`time_to_threshold` / :func:`time_to_threshold_ratio` -- episodes until the
  trailing-mean curve first reaches a threshold, and their ratio.

Time to threshold over seeds is taken per seed and censored at the budget
(:func:`threshold_times`), then summarised as survival data: :func:`kaplan_meier`,
:func:`km_median` (with :func:`median_interval`) and :func:`restricted_mean_time`.

Intervals and tests on per-seed values: :func:`t_interval` and :func:`t_test_pvalue`
(Student t; on paired differences, the paired t), :func:`fieller_interval` (ratio of two
paired means), :func:`wilson_interval` (a share), :func:`percentile_bootstrap_interval`
(kept for comparison: it covers too rarely at 10 seeds), :func:`holm` (family-wise
adjustment), :func:`improvement_test` (paired probability of improvement, sign and
Wilcoxon tests) and :func:`trend_slopes` (a trend along a stream with seeds as clusters).
Which interval is used where, and why, is in ``docs/statistics.md``.

:func:`compare` takes ``(n_seeds, n_episodes)`` arrays for a transfer method and a
baseline whose rows are *paired* (row ``s`` of both was run with the same seed and
opponent order) and returns a :class:`MetricEstimate` per metric. :func:`mean_curve_band`
gives pointwise bootstrap bands for plotting and :func:`format_metrics_markdown` a
markdown table.

All inputs are validated: NaN or infinite rewards, empty curves, mismatched shapes and
curves shorter than a requested window raise :class:`ValueError`.
"""

from __future__ import annotations

import functools
import math
import numbers
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import stats

__all__ = [
    "INTERVALS",
    "ImprovementTest",
    "MetricEstimate",
    "area_above_floor",
    "asymptotic_gain",
    "asymptotic_performance",
    "compare",
    "fieller_interval",
    "format_metrics_markdown",
    "headline_metrics",
    "holm",
    "improvement_test",
    "jumpstart",
    "kaplan_meier",
    "km_median",
    "mean_curve_band",
    "median_interval",
    "pairwise_metrics",
    "per_seed_gains",
    "percentile_bootstrap_interval",
    "restricted_mean_time",
    "smooth",
    "t_interval",
    "t_test_pvalue",
    "threshold_times",
    "time_to_threshold",
    "time_to_threshold_ratio",
    "total_reward",
    "total_reward_gain",
    "transfer_ratio",
    "trend_slopes",
    "wilson_interval",
]

FloatArray = NDArray[np.float64]

#: Absolute tolerance of the threshold test ``smoothed >= threshold - THRESHOLD_ATOL``; it
#: only absorbs rounding in the running sums of :func:`smooth` (e.g. a window mean that is
#: exactly 0.5 in real arithmetic but 0.49999999999999994 in floating point).
THRESHOLD_ATOL = 1e-9

#: Replicates of the seed-mean curve processed at once (bounds memory to
#: ``chunk * n_episodes`` floats).
_MAX_CHUNK_ELEMENTS = 2_000_000


# --------------------------------------------------------------------------- validation
def _as_curve(curve: ArrayLike, name: str = "curve") -> FloatArray:
    """``curve`` as a finite, non-empty 1-D float64 array, or :class:`ValueError`."""
    arr = np.asarray(curve, dtype=np.float64)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be 1-D (one reward per episode), got shape {arr.shape}")
    if arr.size == 0:
        raise ValueError(f"{name} is empty")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return arr


def _as_curves(curves: ArrayLike, name: str = "curves") -> FloatArray:
    """``curves`` as a finite, non-empty ``(n_seeds, n_episodes)`` float64 array."""
    arr = np.asarray(curves, dtype=np.float64)
    if arr.ndim != 2:
        raise ValueError(f"{name} must have shape (n_seeds, n_episodes), got shape {arr.shape}")
    if arr.size == 0:
        raise ValueError(f"{name} is empty (shape {arr.shape})")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return arr


def _pair(transfer: ArrayLike, baseline: ArrayLike) -> tuple[FloatArray, FloatArray]:
    t = _as_curve(transfer, "transfer")
    b = _as_curve(baseline, "baseline")
    if t.shape != b.shape:
        raise ValueError(
            f"transfer and baseline must have the same length, got {t.size} and {b.size}"
        )
    return t, b


def _check_count(value: int, name: str, length: int) -> int:
    """A positive integer ``value`` that does not exceed ``length``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ValueError(f"{name} must be a positive integer, got {value!r}")
    value = int(value)
    if value < 1:
        raise ValueError(f"{name} must be >= 1, got {value}")
    if value > length:
        raise ValueError(f"{name}={value} exceeds the curve length {length}")
    return value


def _check_real(value: float, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite real number, got {value!r}")
    return float(value)


def _check_confidence(confidence: float) -> float:
    confidence = _check_real(confidence, "confidence")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")
    return confidence


def _check_floor(arr: FloatArray, floor: float, name: str) -> float:
    floor = _check_real(floor, "floor")
    if np.any(arr < floor):
        raise ValueError(
            f"{name} has rewards below floor={floor} (min {arr.min()}); the floor must be "
            "the minimum possible reward"
        )
    return floor


# --------------------------------------------------------------------------- smoothing
def smooth(
    curve: ArrayLike, window: int, *, edges: Literal["expanding", "valid"] = "expanding"
) -> FloatArray:
    """Trailing moving average along the last axis.

    ``out[t] = mean(curve[t - window + 1 : t + 1])``: each point averages itself and the
    ``window - 1`` points *before* it, never later ones, so a smoothed curve never
    anticipates the future.

    Parameters
    ----------
    curve : array_like, shape (n,) or (n_seeds, n)
        Rewards; NaN/inf refused. A 2-D array is smoothed row by row.
    window : int
        Window length, ``1 <= window <= n``; ``window=1`` returns a copy.
    edges : {"expanding", "valid"}
        Handling of the first ``window - 1`` points, which have no full window.
        ``"expanding"`` (default, for plots) keeps length ``n`` and averages the points
        available so far: ``out[t] = mean(curve[:t + 1])`` for ``t < window - 1``.
        ``"valid"`` returns only full windows, length ``n - window + 1``; ``out[j]`` then
        ends at episode index ``j + window - 1``.

    Returns
    -------
    ndarray of float64
        Smoothed curve(s).

    Raises
    ------
    ValueError
        Empty or non-finite input, ``ndim`` not 1 or 2, or ``window`` not in ``[1, n]``.
    """
    arr = np.asarray(curve, dtype=np.float64)
    if arr.ndim == 1:
        arr = _as_curve(arr)
    elif arr.ndim == 2:
        arr = _as_curves(arr)
    else:
        raise ValueError(f"curve must be 1-D or 2-D, got shape {arr.shape}")
    n = arr.shape[-1]
    window = _check_count(window, "window", n)
    if edges not in ("expanding", "valid"):
        raise ValueError(f"edges must be 'expanding' or 'valid', got {edges!r}")
    if window == 1:
        return arr.copy()
    zeros = np.zeros((*arr.shape[:-1], 1))
    csum = np.concatenate([zeros, np.cumsum(arr, axis=-1)], axis=-1)
    full = (csum[..., window:] - csum[..., :-window]) / window
    head = csum[..., 1:window] / np.arange(1, window)  # expanding means of the first points
    # A window of equal values averages to that value exactly (differences of running
    # sums are off by rounding): a constant stretch must not show a spurious dip.
    changes = np.concatenate(
        [np.zeros((*arr.shape[:-1], 1), dtype=np.int64),
         np.cumsum(arr[..., 1:] != arr[..., :-1], axis=-1)], axis=-1)
    constant = changes[..., window - 1:] == changes[..., :n - window + 1]
    full = np.where(constant, arr[..., window - 1:], full)
    if edges == "valid":
        return full
    head = np.where(changes[..., :window - 1] == 0, arr[..., :window - 1], head)
    return np.concatenate([head, full], axis=-1)


# --------------------------------------------------------------------------- per-curve metrics
def jumpstart(transfer: ArrayLike, baseline: ArrayLike, first: int) -> float:
    """Jumpstart: initial advantage of the transfer learner.

    ``mean(transfer[:first]) - mean(baseline[:first])``, in reward units (reward per
    episode). Positive means transfer starts better.

    Parameters
    ----------
    transfer, baseline : array_like, shape (n,)
        Learning curves of equal length, finite.
    first : int
        Number ``K`` of initial episodes (or evaluation points) averaged, ``1 <= K <= n``.

    Returns
    -------
    float

    Raises
    ------
    ValueError
        Non-finite/empty input, unequal lengths, or ``first`` out of range.
    """
    t, b = _pair(transfer, baseline)
    k = _check_count(first, "first", t.size)
    return float(t[:k].mean() - b[:k].mean())


def asymptotic_performance(curve: ArrayLike, last: int) -> float:
    """Asymptotic performance: ``mean(curve[-last:])``, in reward units.

    Parameters
    ----------
    curve : array_like, shape (n,)
        Learning curve, finite.
    last : int
        Number ``K`` of final episodes (or evaluation points) averaged, ``1 <= K <= n``.

    Returns
    -------
    float

    Raises
    ------
    ValueError
        Non-finite/empty input or ``last`` out of range.
    """
    c = _as_curve(curve)
    k = _check_count(last, "last", c.size)
    return float(c[-k:].mean())


def asymptotic_gain(transfer: ArrayLike, baseline: ArrayLike, last: int) -> float:
    """Asymptotic gain: ``mean(transfer[-last:]) - mean(baseline[-last:])``, reward units.

    Parameters
    ----------
    transfer, baseline : array_like, shape (n,)
        Learning curves of equal length, finite.
    last : int
        Number ``K`` of final points averaged, ``1 <= K <= n``.

    Returns
    -------
    float

    Raises
    ------
    ValueError
        Non-finite/empty input, unequal lengths, or ``last`` out of range.
    """
    t, b = _pair(transfer, baseline)
    k = _check_count(last, "last", t.size)
    return float(t[-k:].mean() - b[-k:].mean())


def total_reward(curve: ArrayLike) -> float:
    """Total reward: the discrete area under the curve, ``sum(curve)``.

    A plain sum over episodes (each episode is a unit-width bar), not the trapezoid rule;
    in reward units x episodes. For evaluation-point curves multiply by the evaluation
    interval to obtain an area in episodes.

    Parameters
    ----------
    curve : array_like, shape (n,)
        Learning curve, finite.

    Returns
    -------
    float
    """
    return float(_as_curve(curve).sum())


def total_reward_gain(transfer: ArrayLike, baseline: ArrayLike) -> float:
    """Total-reward gain: ``sum(transfer) - sum(baseline)`` over curves of equal length.

    Parameters
    ----------
    transfer, baseline : array_like, shape (n,)
        Learning curves of equal length, finite.

    Returns
    -------
    float
    """
    t, b = _pair(transfer, baseline)
    return float(t.sum() - b.sum())


def area_above_floor(curve: ArrayLike, floor: float = -1.0) -> float:
    """Discrete area between the curve and a reward floor: ``sum(curve - floor)``.

    Non-negative whenever ``floor`` is the minimum possible reward, which makes ratios of
    areas meaningful for rewards that can be negative.

    Parameters
    ----------
    curve : array_like, shape (n,)
        Learning curve, finite, every value ``>= floor``.
    floor : float
        Minimum possible reward (default ``-1.0``).

    Returns
    -------
    float

    Raises
    ------
    ValueError
        Non-finite/empty input or a reward below ``floor``.
    """
    c = _as_curve(curve)
    floor = _check_floor(c, floor, "curve")
    return float((c - floor).sum())


def transfer_ratio(transfer: ArrayLike, baseline: ArrayLike, floor: float = -1.0) -> float:
    """Transfer ratio: ratio of the areas under the transfer and baseline curves.

    ``sum(transfer - floor) / sum(baseline - floor)`` over curves of equal length, with
    ``floor`` the minimum possible reward. Taylor & Stone (2009) define the transfer ratio
    as the total reward accumulated by the transfer learner over that of the non-transfer
    learner; because rewards here can be negative, both areas are measured above the
    floor so that they are non-negative and the ratio is invariant to where zero reward
    lies. Dimensionless: ``> 1`` means transfer accumulated more; ``ratio - 1`` is the
    relative form ``(area_T - area_B) / area_B``.

    Parameters
    ----------
    transfer, baseline : array_like, shape (n,)
        Learning curves of equal length, finite, every value ``>= floor``.
    floor : float
        Minimum possible reward (default ``-1.0``).

    Returns
    -------
    float
        The ratio; ``nan`` when the baseline area is 0 (baseline at the floor throughout),
        whatever the transfer area.

    Raises
    ------
    ValueError
        Non-finite/empty input, unequal lengths, or a reward below ``floor``.
    """
    t, b = _pair(transfer, baseline)
    floor = _check_floor(t, floor, "transfer")
    _check_floor(b, floor, "baseline")
    area_b = float((b - floor).sum())
    if area_b == 0.0:
        return math.nan
    return float((t - floor).sum()) / area_b


def _first_crossing(full_windows: FloatArray, threshold: float, window: int) -> FloatArray:
    """Episode number (1-based) at the end of the first full window reaching ``threshold``.

    ``full_windows`` has shape ``(..., n - window + 1)`` (``smooth(..., edges="valid")``);
    returns ``inf`` where no window reaches it.
    """
    reached = full_windows >= threshold - THRESHOLD_ATOL
    first = np.argmax(reached, axis=-1).astype(np.float64) + window  # index j ends at j+W-1
    return np.where(reached.any(axis=-1), first, np.inf)


def time_to_threshold(curve: ArrayLike, threshold: float, window: int = 1) -> float:
    """Time to threshold: episodes played until the trailing mean first reaches a threshold.

    The smallest episode number ``t`` (1-based, i.e. the number of episodes played so
    far; ``window <= t <= n``) such that ``mean(curve[t - window : t]) >= threshold``.
    Only full windows count (the expanding edge of :func:`smooth` is ignored, so a single
    lucky early episode cannot trigger it). The comparison allows an absolute tolerance
    of ``THRESHOLD_ATOL = 1e-9`` for floating-point rounding. Units: episodes (or
    evaluation points).

    Parameters
    ----------
    curve : array_like, shape (n,)
        Learning curve, finite, ``n >= window``.
    threshold : float
        Reward level to reach.
    window : int
        Trailing-mean window ``W`` (default 1: the raw curve).

    Returns
    -------
    float
        ``t`` as a float, or ``math.inf`` if the threshold is never reached (``inf`` rather
        than ``None`` so that arithmetic and ratios follow IEEE rules; see
        :func:`time_to_threshold_ratio`).

    Raises
    ------
    ValueError
        Non-finite/empty input, non-finite threshold, or ``window`` not in ``[1, n]``.
    """
    c = _as_curve(curve)
    threshold = _check_real(threshold, "threshold")
    window = _check_count(window, "window", c.size)
    return float(_first_crossing(smooth(c, window, edges="valid"), threshold, window))


def time_to_threshold_ratio(
    transfer: ArrayLike, baseline: ArrayLike, threshold: float, window: int = 1
) -> float:
    """Time-to-threshold ratio: ``time_to_threshold(transfer) / time_to_threshold(baseline)``.

    Dimensionless; ``< 1`` means transfer reached the threshold sooner. "Never" is
    ``inf`` (see :func:`time_to_threshold`) and the ratio follows IEEE arithmetic:
    transfer reaches it and baseline never -> ``0.0``; transfer never and baseline does ->
    ``inf``; neither -> ``nan`` (undefined). Both times are >= ``window`` >= 1, so there is
    no division by zero.

    Parameters
    ----------
    transfer, baseline : array_like, shape (n,)
        Learning curves of equal length, finite.
    threshold : float
        Reward level to reach.
    window : int
        Trailing-mean window (default 1).

    Returns
    -------
    float
    """
    t, b = _pair(transfer, baseline)
    t_t = time_to_threshold(t, threshold, window)
    t_b = time_to_threshold(b, threshold, window)
    return _time_ratio(t_t, t_b)


def _time_ratio(t_t: float, t_b: float) -> float:
    if math.isinf(t_t) and math.isinf(t_b):
        return math.nan
    if math.isinf(t_b):
        return 0.0
    return t_t / t_b  # inf / finite = inf


# --------------------------------------------------------------------------- censored times
def threshold_times(
    curves: ArrayLike, threshold: float, window: int = 1, *, warmup: bool = False
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Each seed's time to threshold, censored at the budget: ``(times, reached)``.

    ``times[s]`` is :func:`time_to_threshold` of row ``s`` when its trailing mean reaches
    ``threshold`` within the curve (``reached[s]`` is True), else the budget
    ``n_episodes`` (``reached[s]`` False: the seed is *censored* at the budget -- all that
    is known is that it needs more than ``n_episodes`` episodes, if it ever gets there).
    Taking the time per seed, rather than on the seed-mean curve, keeps seeds that never
    reach the threshold visible: a mean curve can cross it when half the seeds never do.

    Parameters
    ----------
    curves : array_like, shape (n_seeds, n_episodes)
        One learning curve per seed, finite.
    threshold : float
        Reward level to reach.
    window : int
        Trailing-mean window (default 1), ``1 <= window <= n_episodes``.
    warmup : bool
        Also count the first ``window - 1`` episodes, on the mean of the episodes played
        so far (``smooth``'s expanding edge): a learner at the threshold from its first
        episode then has time 1, not ``window``. Default: full windows only.

    Returns
    -------
    times : ndarray of float64, shape (n_seeds,)
        Episodes played until the threshold is reached, or ``n_episodes`` if it is not.
    reached : ndarray of bool, shape (n_seeds,)

    Raises
    ------
    ValueError
        Non-finite/empty input, wrong shape, non-finite threshold, ``window`` out of range.
    """
    arr = _as_curves(curves)
    threshold = _check_real(threshold, "threshold")
    window = _check_count(window, "window", arr.shape[1])
    if warmup:
        first = _first_crossing(smooth(arr, window, edges="expanding"), threshold, 1)
    else:
        first = _first_crossing(smooth(arr, window, edges="valid"), threshold, window)
    reached = np.isfinite(first)
    return np.where(reached, first, float(arr.shape[1])), reached


def _as_censored(times: ArrayLike, reached: ArrayLike) -> tuple[FloatArray, NDArray[np.bool_]]:
    t = np.asarray(times, dtype=np.float64)
    r = np.asarray(reached)
    if t.ndim != 1 or t.size == 0:
        raise ValueError(f"times must be a non-empty 1-D array, got shape {t.shape}")
    if r.shape != t.shape or r.dtype != np.bool_:
        raise ValueError(
            f"reached must be a boolean array of the shape of times {t.shape}, got "
            f"{r.dtype} of shape {r.shape}"
        )
    if not np.all(np.isfinite(t)) or np.any(t < 0):
        raise ValueError("times must be finite and >= 0 (censored ones at their censoring time)")
    return t, r


def kaplan_meier(times: ArrayLike, reached: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Kaplan-Meier estimate of ``S(t) = P(time > t)`` from right-censored times.

    At each distinct time ``t_j`` at which ``d_j`` seeds reach the threshold, with ``n_j``
    seeds still at risk (time ``>= t_j``; a seed censored at ``t_j`` counts as at risk
    there), ``S`` is multiplied by ``1 - d_j / n_j``. ``S`` is a right-continuous step
    function, 1 before the first time. When every censored time is at or after every
    reached one (censoring at the budget, as :func:`threshold_times` gives), ``S(t)`` is
    the share of seeds whose time exceeds ``t``.

    Parameters
    ----------
    times : array_like, shape (n,)
        Time of each seed: when it reached the threshold, or when it was censored.
    reached : array_like of bool, shape (n,)
        True where the threshold was reached, False where the time is censored.

    Returns
    -------
    event_times : ndarray, shape (k,)
        Distinct times at which some seed reached the threshold, ascending.
    survival : ndarray, shape (k,)
        ``S`` just after each of them.

    Raises
    ------
    ValueError
        Mismatched or empty arrays, non-boolean ``reached``, negative or non-finite times.
    """
    t, r = _as_censored(times, reached)
    event_times = np.unique(t[r])
    at_risk = (t[None, :] >= event_times[:, None]).sum(axis=1)
    events = (r[None, :] & (t[None, :] == event_times[:, None])).sum(axis=1)
    return event_times, np.cumprod(1.0 - events / at_risk)


def km_median(times: ArrayLike, reached: ArrayLike) -> float:
    """Kaplan-Meier median time: the first event time at which ``S(t) <= 1/2``.

    ``inf`` when ``S`` stays above one half, i.e. fewer than half of the seeds are seen
    to reach the threshold: the median time is then longer than the budget (or the
    threshold is never reached), which is a negative result, not a missing one.

    Parameters
    ----------
    times, reached : array_like, shape (n,)
        As for :func:`kaplan_meier`.

    Returns
    -------
    float
    """
    event_times, survival = kaplan_meier(times, reached)
    below = np.flatnonzero(survival <= 0.5 + 1e-12)
    return float(event_times[below[0]]) if below.size else math.inf


def restricted_mean_time(times: ArrayLike, reached: ArrayLike, horizon: float) -> float:
    """Restricted mean time to threshold: ``∫_0^horizon S(t) dt`` of the Kaplan-Meier ``S``.

    The mean of ``min(time, horizon)`` over the population: every seed counts, one that
    never reaches the threshold with the full ``horizon``. With the horizon at the budget
    and censoring only at the budget (:func:`threshold_times`) it equals the mean of the
    censored per-seed times exactly, so the t interval and Fieller's interval apply to it.

    Parameters
    ----------
    times, reached : array_like, shape (n,)
        As for :func:`kaplan_meier`.
    horizon : float
        Upper limit ``> 0``; no later than the last time unless ``S`` has reached 0
        before it (beyond the last time ``S`` is not known).

    Returns
    -------
    float

    Raises
    ------
    ValueError
        Bad arrays (see :func:`kaplan_meier`), non-positive horizon, or a horizon past
        the last time while ``S > 0``.
    """
    t, _ = _as_censored(times, reached)
    horizon = _check_real(horizon, "horizon")
    if horizon <= 0:
        raise ValueError(f"horizon must be > 0, got {horizon}")
    event_times, survival = kaplan_meier(times, reached)
    end_survival = survival[-1] if survival.size else 1.0
    if horizon > t.max() and end_survival > 0:
        raise ValueError(
            f"horizon={horizon} is past the last time {t.max()}, where the Kaplan-Meier "
            f"curve ({end_survival:.3g}) is not known; use a horizon <= {t.max()}"
        )
    edges = np.concatenate([[0.0], event_times[event_times < horizon], [horizon]])
    levels = np.concatenate([[1.0], survival[event_times < horizon]])
    return float(np.sum(levels * np.diff(edges)))


def median_interval(
    times: ArrayLike, reached: ArrayLike, confidence: float = 0.95
) -> tuple[float, float]:
    """Distribution-free interval for the median time, from order statistics.

    ``[x_(k), x_(n-k+1)]`` of the sorted times with ``k`` the largest integer such that
    ``2 P(Binomial(n, 1/2) <= k - 1) <= 1 - confidence``: it covers the population median
    with probability at least ``confidence`` whatever the distribution (discrete times
    only make it more conservative). Censored seeds sort after every reached one, as
    ``inf`` (they need more than the budget), so the upper end is ``inf`` when more than
    ``k - 1`` seeds are censored; both ends are ``inf`` when so many are that the median
    is beyond the budget with that confidence. ``(-inf, inf)`` when ``n`` is too small
    for the level (fewer than 6 seeds at 95%).

    Parameters
    ----------
    times, reached : array_like, shape (n,)
        As for :func:`kaplan_meier`, with every censored time at or after every reached
        one (censoring at the budget).
    confidence : float
        Coverage in ``(0, 1)`` (default 0.95).

    Returns
    -------
    (low, high) : tuple of float

    Raises
    ------
    ValueError
        Bad arrays, a censored time before a reached one, bad ``confidence``.
    """
    t, r = _as_censored(times, reached)
    confidence = _check_confidence(confidence)
    if r.any() and (~r).any() and t[~r].min() < t[r].max():
        raise ValueError(
            "median_interval needs censoring at the budget: a censored time "
            f"({t[~r].min()}) lies before a reached one ({t[r].max()})"
        )
    n = t.size
    alpha = 1.0 - confidence
    k = 0
    while k + 1 <= n and 2.0 * stats.binom.cdf(k, n, 0.5) <= alpha:
        k += 1  # P(Bin <= k) small enough: x_(k+1) is a valid lower end
    if k == 0:
        return -math.inf, math.inf
    ordered = np.sort(np.where(r, t, math.inf))
    return float(ordered[k - 1]), float(ordered[n - k])


# --------------------------------------------------------------------------- seed-level tests
@dataclass(frozen=True)
class ImprovementTest:
    """How often transfer beats the baseline, seed by seed.

    Attributes
    ----------
    probability : float
        Share of seeds whose difference (transfer minus baseline) is positive, ties
        counting one half: the paired probability of improvement.
    better, worse, n : int
        Seeds with a positive / negative difference, and all seeds.
    sign_p : float
        Two-sided exact sign test (binomial, ties dropped) of "better and worse are
        equally likely"; ``nan`` if every difference is 0.
    wilcoxon_p : float
        Two-sided Wilcoxon signed-rank test of "the differences are symmetric around 0"
        (scipy's default: exact for small samples without ties, zeros dropped); ``nan``
        if every difference is 0.
    """

    probability: float
    better: int
    worse: int
    n: int
    sign_p: float
    wilcoxon_p: float


def improvement_test(differences: ArrayLike) -> ImprovementTest:
    """Paired probability of improvement with a sign test and a Wilcoxon test.

    Parameters
    ----------
    differences : array_like, shape (n,)
        Per-seed differences, transfer minus baseline, finite, ``n >= 1``; each seed is
        one independent unit (average a seed's runs first).

    Returns
    -------
    ImprovementTest
    """
    d = _as_curve(differences, "differences")
    better, worse = int((d > 0).sum()), int((d < 0).sum())
    probability = (better + 0.5 * (d.size - better - worse)) / d.size
    if better + worse == 0:
        return ImprovementTest(probability, 0, 0, d.size, math.nan, math.nan)
    sign_p = float(stats.binomtest(better, better + worse, 0.5).pvalue)
    wilcoxon_p = float(stats.wilcoxon(d[d != 0]).pvalue)
    return ImprovementTest(probability, better, worse, d.size, sign_p, wilcoxon_p)


def trend_slopes(values: ArrayLike, x: ArrayLike) -> FloatArray:
    """Least-squares slope of each row of ``values`` against ``x``.

    For a trend along a stream measured on every seed: row ``s`` holds seed ``s``'s
    metric on the stream's tasks at positions ``x``. Because every row has the same
    ``x``, the mean of the row slopes is the pooled least-squares slope, and treating
    each seed's slope as one value (:func:`t_interval` on them) is inference with seeds
    as clusters: the tasks of one seed, which share its library, are never counted as
    independent.

    Parameters
    ----------
    values : array_like, shape (n_seeds, n_tasks)
        Finite.
    x : array_like, shape (n_tasks,)
        Positions, finite, not all equal.

    Returns
    -------
    ndarray, shape (n_seeds,)
    """
    y = _as_curves(values, "values")
    xs = _as_curve(x, "x")
    if xs.size != y.shape[1]:
        raise ValueError(f"x has {xs.size} positions, values has {y.shape[1]} columns")
    xc = xs - xs.mean()
    if not np.any(xc):
        raise ValueError("x must not be constant: a slope needs at least two positions")
    return (y - y.mean(axis=1, keepdims=True)) @ xc / float(xc @ xc)


# --------------------------------------------------------------------------- intervals
#: The intervals :func:`compare` can put on its estimates (see :func:`compare`).
INTERVALS = ("t", "percentile")


def _as_samples(values: ArrayLike, name: str, min_n: int = 2) -> FloatArray:
    """``values`` as a finite float64 array of at least one dimension whose last axis
    (the seeds) holds at least ``min_n`` values."""
    arr = np.asarray(values, dtype=np.float64)
    if arr.ndim == 0:
        raise ValueError(f"{name} must be an array of per-seed values, got a scalar")
    if arr.shape[-1] < min_n:
        raise ValueError(
            f"{name} needs at least {min_n} values along its last axis (one per seed), "
            f"got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return arr


def _scalar_or_array(x: FloatArray) -> float | FloatArray:
    return float(x) if np.ndim(x) == 0 else x


def _t_quantile(confidence: float, df: int) -> float:
    return float(stats.t.ppf(0.5 + confidence / 2.0, df))


def t_interval(
    values: ArrayLike, confidence: float = 0.95
) -> tuple[float | FloatArray, float | FloatArray, float | FloatArray]:
    """Mean of per-seed values with a Student t interval: ``(mean, low, high)``.

    ``mean ± t(n-1) · sd / sqrt(n)``, with ``sd`` the sample standard deviation
    (``ddof=1``) and ``t(n-1)`` the two-sided Student quantile of ``confidence`` with
    ``n - 1`` degrees of freedom. For a paired comparison pass the per-seed differences
    (transfer minus baseline of the same seed): this is the paired t interval. It is exact
    for normal per-seed values and covers close to its level at 10 seeds for symmetric
    ones, where the percentile bootstrap covers about 0.90 (``docs/statistics.md``). When
    every value is equal the interval is that single value.

    Parameters
    ----------
    values : array_like, shape (..., n)
        Per-seed values along the last axis, ``n >= 2``, finite; leading axes are
        independent data sets (vectorised).
    confidence : float
        Coverage in ``(0, 1)`` (default 0.95).

    Returns
    -------
    mean, low, high : float, or arrays of the leading shape

    Raises
    ------
    ValueError
        Fewer than 2 values, NaN or infinite values, bad ``confidence``.
    """
    x = _as_samples(values, "values")
    confidence = _check_confidence(confidence)
    n = x.shape[-1]
    # Equal values are recognised as such: their computed mean and spread may be off by
    # rounding (the mean of three 0.1 is not 0.1).
    equal = np.all(x == x[..., :1], axis=-1)
    mean = np.where(equal, x[..., 0], x.mean(axis=-1))
    half = np.where(equal, 0.0,
                    _t_quantile(confidence, n - 1) * x.std(axis=-1, ddof=1) / math.sqrt(n))
    return _scalar_or_array(mean), _scalar_or_array(mean - half), _scalar_or_array(mean + half)


def t_test_pvalue(values: ArrayLike, null: float = 0.0) -> float | FloatArray:
    """Two-sided p-value of the one-sample t-test that the mean of ``values`` is ``null``.

    The test that matches :func:`t_interval`: ``p < 1 - confidence`` exactly when the
    interval at ``confidence`` excludes ``null``. On per-seed differences it is the paired
    t-test. With zero spread the p-value is 1 if every value equals ``null``, else 0.

    Parameters
    ----------
    values : array_like, shape (..., n)
        Per-seed values along the last axis, ``n >= 2``, finite.
    null : float
        Mean under the null hypothesis (default 0).

    Returns
    -------
    float, or an array of the leading shape
    """
    x = _as_samples(values, "values")
    null = _check_real(null, "null")
    n = x.shape[-1]
    diff = x.mean(axis=-1) - null
    se = x.std(axis=-1, ddof=1) / math.sqrt(n)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.abs(diff) / se
    p = np.where(se > 0, 2.0 * stats.t.sf(t, n - 1), np.where(diff == 0, 1.0, 0.0))
    # Zero spread is read from the values themselves: equal values can have a computed
    # spread of ~1e-17 and a mean off null by as much.
    equal = np.all(x == x[..., :1], axis=-1)
    p = np.where(equal, np.where(x[..., 0] == null, 1.0, 0.0), p)
    return _scalar_or_array(p)


def fieller_interval(
    numerator: ArrayLike, denominator: ArrayLike, confidence: float = 0.95
) -> tuple[float | FloatArray, float | FloatArray, float | FloatArray]:
    """Ratio of two paired means with Fieller's interval: ``(ratio, low, high)``.

    ``ratio = mean(numerator) / mean(denominator)`` over seeds, values of a seed paired.
    The interval is the set of ratios ``r`` that the paired t-test on the per-seed values
    ``numerator - r · denominator`` (mean zero under ``r``) does not reject at
    ``1 - confidence`` (Fieller 1954): the roots of
    ``(m_N - r m_D)² = t² (v_N - 2 r c + r² v_D) / n`` with sample means ``m``, variances
    ``v`` and covariance ``c`` (``ddof=1``) and ``t`` the Student quantile with ``n - 1``
    degrees of freedom. It is exact for normal per-seed values, keeps the pairing (the
    covariance), needs no resampling, and is not symmetric around the ratio. At
    ``r = 1`` the test is the paired t-test on ``numerator - denominator``, so the interval
    excludes 1 exactly when the t interval of the difference excludes 0. When the
    denominator's mean is not clearly away from zero (``m_D² <= t² v_D / n``) the set is
    unbounded and ``(-inf, inf)`` is returned; the ratio is ``nan`` when ``m_D = 0``.

    Parameters
    ----------
    numerator, denominator : array_like, shape (..., n)
        Paired per-seed values along the last axis, same shape, ``n >= 2``, finite.
    confidence : float
        Coverage in ``(0, 1)`` (default 0.95).

    Returns
    -------
    ratio, low, high : float, or arrays of the leading shape

    Raises
    ------
    ValueError
        Shapes differ, fewer than 2 values, NaN or infinite values, bad ``confidence``.
    """
    num = _as_samples(numerator, "numerator")
    den = _as_samples(denominator, "denominator")
    if num.shape != den.shape:
        raise ValueError(
            f"numerator and denominator must have the same shape (paired per-seed values), "
            f"got {num.shape} and {den.shape}"
        )
    confidence = _check_confidence(confidence)
    n = num.shape[-1]
    m_n, m_d = num.mean(axis=-1), den.mean(axis=-1)
    dn, dd = num - m_n[..., None], den - m_d[..., None]
    v_n, v_d = (dn**2).sum(axis=-1) / (n - 1), (dd**2).sum(axis=-1) / (n - 1)
    cov = (dn * dd).sum(axis=-1) / (n - 1)
    g = _t_quantile(confidence, n - 1) ** 2 / n
    a = m_d**2 - g * v_d
    b = m_n * m_d - g * cov  # the quadratic is a r² - 2 b r + c <= 0
    c = m_n**2 - g * v_n
    # b² - a c >= 0 whenever a > 0 (the ratio itself always passes the test); clip rounding.
    root = np.sqrt(np.maximum(b**2 - a * c, 0.0))
    bounded = a > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        low = np.where(bounded, (b - root) / a, -np.inf)
        high = np.where(bounded, (b + root) / a, np.inf)
        ratio = np.where(m_d != 0, m_n / m_d, np.nan)
    return _scalar_or_array(ratio), _scalar_or_array(low), _scalar_or_array(high)


def percentile_bootstrap_interval(
    values: ArrayLike, n_boot: int = 10000, confidence: float = 0.95, seed: int = 0
) -> tuple[float | FloatArray, float | FloatArray, float | FloatArray]:
    """Mean of per-seed values with a percentile-bootstrap interval: ``(mean, low, high)``.

    Kept to measure what it was replaced by: at 10 seeds its 95% interval covers about
    0.90 of the time for symmetric data (it is too narrow by the factor
    ``sqrt((n-1)/n)`` and by using normal rather than t quantiles), see
    ``docs/statistics.md``. Every data set (leading index) uses the same resampled seed
    indices, drawn from ``np.random.default_rng(seed)``.

    Parameters
    ----------
    values : array_like, shape (..., n)
        Per-seed values along the last axis, ``n >= 2``, finite.
    n_boot : int
        Bootstrap replicates (default 10000).
    confidence : float
        Coverage in ``(0, 1)`` (default 0.95).
    seed : int
        Seed of the resampling.

    Returns
    -------
    mean, low, high : float, or arrays of the leading shape
    """
    x = _as_samples(values, "values")
    n_boot, confidence = _check_boot(n_boot, x.shape[-1], confidence)
    weights = _resample_counts(x.shape[-1], n_boot, seed) / x.shape[-1]
    reps = x @ weights.T  # (..., n_boot)
    alpha = 1.0 - confidence
    low, high = np.quantile(reps, [alpha / 2.0, 1.0 - alpha / 2.0], axis=-1)
    return (_scalar_or_array(x.mean(axis=-1)), _scalar_or_array(low),
            _scalar_or_array(high))


def holm(p_values: ArrayLike) -> FloatArray:
    """Holm's step-down adjustment of p-values for a family of tests.

    Sort the ``m`` p-values ascending, multiply the ``i``-th smallest (``i = 0..m-1``) by
    ``m - i``, take running maxima and cap at 1 (Holm 1979). Rejecting every hypothesis
    whose adjusted p-value is below ``alpha`` controls the family-wise error rate at
    ``alpha`` under any dependence between the tests; it is uniformly more powerful than
    Bonferroni. ``nan`` entries (tests that could not be made) are left out of the family
    and stay ``nan``.

    Parameters
    ----------
    p_values : array_like, shape (m,)
        p-values in ``[0, 1]`` (or ``nan``).

    Returns
    -------
    ndarray, shape (m,)
        Adjusted p-values, in the input's order.

    Raises
    ------
    ValueError
        Not 1-D, or a value outside ``[0, 1]``.
    """
    p = np.asarray(p_values, dtype=np.float64)
    if p.ndim != 1:
        raise ValueError(f"p_values must be 1-D, got shape {p.shape}")
    known = ~np.isnan(p)
    if np.any((p[known] < 0) | (p[known] > 1)):
        raise ValueError(f"p_values must lie in [0, 1] (or be nan), got {p[known].tolist()}")
    out = np.full(p.shape, np.nan)
    idx = np.flatnonzero(known)
    order = idx[np.argsort(p[idx], kind="stable")]
    m = order.size
    scaled = p[order] * (m - np.arange(m))
    out[order] = np.minimum(np.maximum.accumulate(scaled), 1.0)
    return out


def wilson_interval(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval for a binomial proportion ``successes / n``.

    ``(p + z²/2n ± z·sqrt(p(1-p)/n + z²/4n²)) / (1 + z²/n)`` with ``p = successes / n``
    and ``z`` the two-sided standard-normal quantile of ``confidence``. Unlike the
    normal-approximation (Wald) interval it stays inside ``[0, 1]`` and is not degenerate
    at ``p = 0`` or ``1`` (it is exactly 0 resp. 1 at those ends).

    Parameters
    ----------
    successes : int
        Number of successes, ``0 <= successes <= n``.
    n : int
        Number of trials, ``>= 1``.
    confidence : float
        Coverage in ``(0, 1)`` (default 0.95).

    Returns
    -------
    (low, high) : tuple of float

    Raises
    ------
    ValueError
        Non-integer counts, ``n < 1``, ``successes`` outside ``[0, n]``, bad confidence.
    """
    for value, name in ((successes, "successes"), (n, "n")):
        if isinstance(value, bool) or not isinstance(value, numbers.Integral):
            raise ValueError(f"{name} must be an integer, got {value!r}")
    k, n = int(successes), int(n)
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    if not 0 <= k <= n:
        raise ValueError(f"successes must be in [0, n={n}], got {k}")
    confidence = _check_confidence(confidence)
    ci = stats.binomtest(k, n).proportion_ci(confidence_level=confidence, method="wilson")
    return float(ci.low), float(ci.high)


def _percentile_interval(
    replicates: FloatArray,
    confidence: float,
    undefined: tuple[float, float] = (-math.inf, math.inf),
) -> tuple[float, float]:
    """Percentile-bootstrap interval of 1-D ``replicates``.

    Linear interpolation between order statistics when every replicate is finite; with
    infinite replicates (e.g. "threshold never reached") the conservative order statistics
    (lower / higher) are used, since interpolating towards ``inf`` is meaningless.
    Undefined (``nan``) replicates -- a ratio on a resample where it has no value -- count
    as the least favourable value on each side: ``undefined[0]`` when computing the lower
    bound, ``undefined[1]`` for the upper one, so the interval is conservative (it widens,
    up to the whole range once more than ``(1 - confidence) / 2`` of replicates are
    undefined). ``(nan, nan)`` if every replicate is undefined.
    """
    alpha = 1.0 - confidence
    lo_q, hi_q = alpha / 2.0, 1.0 - alpha / 2.0
    nan = np.isnan(replicates)
    if nan.all():
        return math.nan, math.nan
    if np.all(np.isfinite(replicates)):
        lo, hi = np.quantile(replicates, [lo_q, hi_q])
        return float(lo), float(hi)
    lo = np.quantile(np.where(nan, undefined[0], replicates), lo_q, method="lower")
    hi = np.quantile(np.where(nan, undefined[1], replicates), hi_q, method="higher")
    return float(lo), float(hi)


def _check_boot(n_boot: int, n_seeds: int, confidence: float) -> tuple[int, float]:
    if isinstance(n_boot, bool) or not isinstance(n_boot, numbers.Integral) or n_boot < 1:
        raise ValueError(f"n_boot must be a positive integer, got {n_boot!r}")
    if n_seeds < 2:
        raise ValueError(f"a bootstrap over seeds needs at least 2 seeds, got {n_seeds}")
    return int(n_boot), _check_confidence(confidence)


def _resample_counts(n_seeds: int, n_boot: int, seed: int) -> FloatArray:
    """How often each seed is drawn in each bootstrap replicate, shape ``(n_boot, n_seeds)``.

    One draw of ``n_seeds`` indices with replacement per replicate, from
    ``np.random.default_rng(seed)``; identical for identical arguments.
    """
    idx = np.random.default_rng(seed).integers(0, n_seeds, size=(n_boot, n_seeds))
    flat = (idx + n_seeds * np.arange(n_boot)[:, None]).ravel()
    return np.bincount(flat, minlength=n_boot * n_seeds).reshape(n_boot, n_seeds).astype(float)


def mean_curve_band(
    curves: ArrayLike, n_boot: int = 2000, confidence: float = 0.95, seed: int = 0
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Mean learning curve over seeds with a pointwise percentile-bootstrap band.

    Each replicate resamples seeds (rows) with replacement once, for all episodes at
    once; ``low``/``high`` are the per-episode percentiles of the replicate means. The
    band is pointwise (not simultaneous over episodes).

    Parameters
    ----------
    curves : array_like, shape (n_seeds, n_episodes)
        One learning curve per seed, finite, ``n_seeds >= 2``.
    n_boot : int
        Bootstrap replicates (default 2000).
    confidence : float
        Coverage in ``(0, 1)`` (default 0.95).
    seed : int
        Seed of the resampling; same seed, same band.

    Returns
    -------
    mean, low, high : ndarray, shape (n_episodes,)

    Raises
    ------
    ValueError
        Non-finite/empty input, wrong shape, fewer than 2 seeds, bad ``n_boot`` or
        ``confidence``.
    """
    arr = _as_curves(curves)
    n_seeds, n_eps = arr.shape
    n_boot, confidence = _check_boot(n_boot, n_seeds, confidence)
    weights = _resample_counts(n_seeds, n_boot, seed) / n_seeds
    alpha = 1.0 - confidence
    low = np.empty(n_eps)
    high = np.empty(n_eps)
    step = max(1, _MAX_CHUNK_ELEMENTS // n_boot)
    for start in range(0, n_eps, step):  # chunk over episodes to bound memory
        cols = slice(start, start + step)
        reps = weights @ arr[:, cols]  # (n_boot, chunk): replicate mean curves
        low[cols], high[cols] = np.quantile(reps, [alpha / 2.0, 1.0 - alpha / 2.0], axis=0)
    return arr.mean(axis=0), low, high


# --------------------------------------------------------------------------- per-seed gains
def largest_dip(curves: ArrayLike, window: int) -> FloatArray:
    """How far each curve's trailing mean falls below its earlier maximum: per row, the
    largest ``max(m[u] for u <= t) - m[t]`` over ``t``, where ``m`` is the trailing mean
    over ``window`` episodes from the first full window on (episode ``window``, so that
    no early few-episode mean counts as a maximum). 0 for a curve whose trailing mean
    never falls. A 1-D curve gives a 0-D array.

    A learner that starts high and then collapses before it recovers (a head start
    handed over too early) has a large dip even when its total reward is good.
    """
    arr = np.asarray(curves, dtype=np.float64)
    m = smooth(arr, _check_count(window, "window", arr.shape[-1]), edges="valid")
    return np.max(np.maximum.accumulate(m, axis=-1) - m, axis=-1)


BELOW_MARGIN = 0.05
"""How far below the baseline's trailing mean a trailing mean must lie to count as below
it (:func:`episodes_below`)."""


def episodes_below(curves: ArrayLike, baseline: ArrayLike, window: int,
                   margin: float = BELOW_MARGIN) -> FloatArray:
    """Per row, the episodes (from the first full window on) at which the trailing mean
    over ``window`` episodes of ``curves`` lies more than ``margin`` below that of the
    paired ``baseline`` row: how long a method does worse than learning anew."""
    t, b = np.asarray(curves, dtype=np.float64), np.asarray(baseline, dtype=np.float64)
    if t.shape != b.shape:
        raise ValueError(f"curves and baseline must have the same shape, got {t.shape} and "
                         f"{b.shape}")
    window = _check_count(window, "window", t.shape[-1])
    below = smooth(t, window, edges="valid") < smooth(b, window, edges="valid") - margin
    return below.sum(axis=-1).astype(np.float64)


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
                 p: float = math.nan) -> MetricEstimate:
            return MetricEstimate(self.name, float(value), float(low), float(high), n, text,
                                  confidence, how, float(p))

        if self.kind == "mean":
            if weights is not None:
                low, high = _percentile_interval(weights @ values, confidence)
                return made(values.mean(), low, high, "percentile bootstrap")
            value, low, high = t_interval(values, confidence)
            return made(value, low, high, "Student t",
                        t_test_pvalue(values) if self.test else math.nan)
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
    seed (same opponent order / environment seed): every metric is first computed per
    seed, and the seed is the unit of every interval and test.

    Metrics and point estimates:

    * ``jumpstart``, ``final_*``, ``total_reward_*``: mean over seeds of the per-seed
      value. ``final_*`` is the mean of the last ``last`` episodes, the *final
      performance within the budget*: the learner may still be improving, so it is not an
      asymptote.
    * ``transfer_ratio``: ratio of the mean areas above the floor,
      ``mean_s area_T[s] / mean_s area_B[s]`` (Taylor & Stone's definition on averaged
      curves; a mean of per-seed ratios would be biased and unstable).
    * ``time_to_threshold_*``: per seed, the episodes until the trailing mean reaches
      ``threshold``, *censored at the budget* (:func:`threshold_times`), summarised by the
      restricted mean time (:func:`restricted_mean_time` up to the budget: a seed that
      never reaches the threshold counts the whole budget). ``time_to_threshold_gain`` is
      the paired difference and ``time_to_threshold_ratio`` the ratio of the two
      restricted means (``< 1`` favours transfer; always defined).
      ``median_time_to_threshold_*`` is the Kaplan-Meier median (:func:`km_median`,
      ``inf`` when fewer than half of the seeds reach the threshold) and
      ``threshold_reached_*`` the share of seeds that reach it.

    Intervals (``interval="t"``, the default): Student t on the per-seed values
    (:func:`t_interval`; for differences, on the paired differences), Fieller for the
    two ratios of means (:func:`fieller_interval`), Wilson for the shares
    (:func:`wilson_interval`) and order statistics for the medians
    (:func:`median_interval`). Differences and ratios carry the p-value of the test the
    interval inverts. ``interval="percentile"`` replaces the t and Fieller intervals by a
    paired percentile bootstrap over seeds (``n_boot`` replicates from
    ``np.random.default_rng(seed)``, the same resampled seeds for every metric; no
    p-values), which covers too rarely at 10 seeds (``docs/statistics.md``); it is kept
    to measure that.

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
        Interval family (see above; default ``"t"``).
    n_boot : int
        Bootstrap replicates for ``interval="percentile"`` (default 10000).
    confidence : float
        Interval coverage (default 0.95).
    seed : int
        Seed of the resampling for ``interval="percentile"``.
    warmup : bool
        Time to threshold also over the first ``window - 1`` episodes, on the mean so
        far (:func:`threshold_times`); default: full windows only.

    Returns
    -------
    dict of str to MetricEstimate
        Keys, in order: ``jumpstart``, ``final_transfer``, ``final_baseline``,
        ``final_gain``, ``total_reward_transfer``, ``total_reward_baseline``,
        ``total_reward_gain``, ``transfer_ratio``, ``largest_dip_transfer``,
        ``largest_dip_baseline``, ``largest_dip_gain``, ``episodes_below_baseline`` and,
        if ``threshold`` is given,
        ``time_to_threshold_transfer``, ``time_to_threshold_baseline``,
        ``time_to_threshold_gain``, ``time_to_threshold_ratio``,
        ``median_time_to_threshold_transfer``, ``median_time_to_threshold_baseline``,
        ``threshold_reached_transfer``, ``threshold_reached_baseline``.

    Raises
    ------
    ValueError
        Non-finite/empty input, shape mismatch, fewer than 2 seeds, parameters out of
        range (``first``, ``last``, ``window`` longer than the curves), rewards below
        ``floor``, unknown ``interval``.
    """
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
    paired = Paired(t, b, first=first, last=last, threshold=threshold, window=window,
                    floor=floor, warmup=warmup)
    weights = (_resample_counts(n_seeds, n_boot, seed) / n_seeds
               if interval == "percentile" else None)
    return {m.name: m.estimate(paired, confidence, weights) for m in METRICS
            if threshold is not None or not m.threshold}


# --------------------------------------------------------------------------- reporting
def _fmt(x: float) -> str:
    x = float(x)
    if math.isnan(x):
        return "n/a"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    if x.is_integer() and abs(x) < 1e15:
        return str(int(x))
    if abs(x) >= 1000:
        return f"{x:.1f}"
    return f"{x:.4g}"


def format_metrics_markdown(estimates: Mapping[str, MetricEstimate]) -> str:
    """A markdown table of estimates: metric, value, CI, interval, p, n, definition.

    The CI column is headed with the common confidence level (e.g. "95% CI"); if the
    estimates use different levels each cell states its own. The interval column names
    the interval (:attr:`MetricEstimate.interval`), the p column the unadjusted p-value of
    "no difference" where there is one. ``nan`` prints as ``n/a``, infinities as ``inf``;
    ``|`` in definitions is escaped.

    Parameters
    ----------
    estimates : mapping of str to MetricEstimate
        E.g. the result of :func:`compare`; rows follow the mapping's order.

    Returns
    -------
    str
        The table, ending with a newline.
    """
    levels = {e.confidence for e in estimates.values()}
    uniform = len(levels) == 1
    head = f"{next(iter(levels)) * 100:g}% CI" if uniform else "CI"
    lines = [f"| metric | value | {head} | interval | p | n | definition |",
             "|---|---:|---|---|---:|---:|---|"]
    for key, e in estimates.items():
        ci = f"[{_fmt(e.low)}, {_fmt(e.high)}]"
        if not uniform:
            ci += f" ({e.confidence * 100:g}%)"
        p = "" if math.isnan(e.p_value) else f"{e.p_value:.2g}"
        definition = e.definition.replace("|", "\\|")
        lines.append(f"| {key} | {_fmt(e.value)} | {ci} | {e.interval} | {p} | {e.n} | "
                     f"{definition} |")
    return "\n".join(lines) + "\n"
