"""Transfer metrics for learning curves (Taylor & Stone 2009), with paired bootstrap intervals.

A *learning curve* is a 1-D array of rewards indexed by training episode (or by evaluation
point: every function below treats the index generically, so "episode" may be read as
"evaluation point" throughout; the caller converts to episodes if needed). Rewards are
assumed to lie in ``[floor, ...]`` with ``floor = -1.0`` by default.

Per-curve metrics (Taylor & Stone 2009, "Transfer Learning for Reinforcement Learning
Domains: A Survey", JMLR 10, section 2.1):

* :func:`jumpstart` -- initial advantage: mean of the first ``K`` points, transfer minus
  baseline.
* :func:`asymptotic_performance` / :func:`asymptotic_gain` -- mean of the last ``K``
  points, and its difference.
* :func:`total_reward` / :func:`total_reward_gain` -- discrete area under the curve.
* :func:`transfer_ratio` -- ratio of areas measured above a reward floor.
* :func:`time_to_threshold` / :func:`time_to_threshold_ratio` -- episodes until the
  trailing-mean curve first reaches a threshold, and their ratio.

Seed-level statistics: :func:`compare` takes ``(n_seeds, n_episodes)`` arrays for a transfer
method and a baseline whose rows are *paired* (row ``s`` of both was run with the same seed
and opponent order) and returns a :class:`MetricEstimate` per metric with a seeded
percentile-bootstrap interval over seeds; pairs are resampled together. Every replicate of
every metric uses the same resampled seed indices. :func:`mean_curve_band` gives pointwise
bootstrap bands for plotting, :func:`wilson_interval` a binomial-proportion interval, and
:func:`format_metrics_markdown` a markdown table.

All inputs are validated: NaN or infinite rewards, empty curves, mismatched shapes and
curves shorter than a requested window raise :class:`ValueError`.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import stats

__all__ = [
    "MetricEstimate",
    "area_above_floor",
    "asymptotic_gain",
    "asymptotic_performance",
    "compare",
    "format_metrics_markdown",
    "jumpstart",
    "mean_curve_band",
    "smooth",
    "time_to_threshold",
    "time_to_threshold_ratio",
    "total_reward",
    "total_reward_gain",
    "transfer_ratio",
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
    zeros = np.zeros((*arr.shape[:-1], 1))
    csum = np.concatenate([zeros, np.cumsum(arr, axis=-1)], axis=-1)
    full = (csum[..., window:] - csum[..., :-window]) / window
    if edges == "valid":
        return full
    head = csum[..., 1:window] / np.arange(1, window)  # expanding means of the first points
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


# --------------------------------------------------------------------------- intervals
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


# --------------------------------------------------------------------------- paired comparison
@dataclass(frozen=True)
class MetricEstimate:
    """A metric estimated over seeds, with its bootstrap (or Wilson) interval.

    Attributes
    ----------
    name : str
        Metric key, e.g. ``"jumpstart"``.
    value : float
        Point estimate on all seeds (see ``definition`` for whether it is a mean over seeds
        of a per-seed metric, a ratio of means, or a metric of the seed-mean curve).
    low, high : float
        Interval bounds (``nan`` if undefined on some bootstrap resample).
    n : int
        Number of (paired) seeds.
    definition : str
        Exact written definition, with the parameters used.
    confidence : float
        Coverage of the interval (default 0.95).
    """

    name: str
    value: float
    low: float
    high: float
    n: int
    definition: str
    confidence: float = 0.95


_UNDEFINED_NOTE = (
    "; bootstrap resamples on which the ratio is undefined count as 0 for the lower "
    "bound and inf for the upper bound (conservative)"
)


def _mean_curve_times(
    arr: FloatArray, weights: FloatArray, threshold: float, window: int
) -> FloatArray:
    """Time to threshold of each replicate's seed-mean curve (``weights @ arr``)."""
    n_boot, n_eps = weights.shape[0], arr.shape[1]
    out = np.empty(n_boot)
    step = max(1, _MAX_CHUNK_ELEMENTS // n_eps)
    for start in range(0, n_boot, step):  # chunk over replicates to bound memory
        rows = slice(start, start + step)
        means = weights[rows] @ arr
        out[rows] = _first_crossing(smooth(means, window, edges="valid"), threshold, window)
    return out


def compare(
    transfer_curves: ArrayLike,
    baseline_curves: ArrayLike,
    *,
    first: int,
    last: int,
    threshold: float | None,
    window: int,
    floor: float = -1.0,
    n_boot: int = 10000,
    confidence: float = 0.95,
    seed: int = 0,
) -> dict[str, MetricEstimate]:
    """Paired, seed-level Taylor & Stone transfer metrics with percentile-bootstrap intervals.

    Row ``s`` of ``transfer_curves`` and of ``baseline_curves`` must come from the same
    seed (same opponent order / environment seed). Each bootstrap replicate draws
    ``n_seeds`` seed indices with replacement (``np.random.default_rng(seed)``) and
    applies them to *both* arrays, so pairs stay together and between-seed variation
    common to both methods cancels in the differences. The same replicates serve every
    metric. Intervals are percentile intervals (see ``_percentile_interval``); for the
    two ratios, resamples on which the ratio is undefined (``nan``: baseline area 0, or
    neither method reaching the threshold) count as 0 for the lower bound and ``inf`` for
    the upper bound, which can only widen the interval.

    Point estimates:

    * per-seed metrics (jumpstart, asymptotic performance and gain, total reward and
      gain): mean over seeds of the per-seed value;
    * ``transfer_ratio``: ratio of the mean areas, ``mean_s area_T[s] / mean_s area_B[s]``
      -- the area ratio of the seed-mean curves, which is Taylor & Stone's definition on
      averaged learning curves (a mean of per-seed ratios would be biased and unstable);
    * times to threshold: of the seed-mean curve (per-seed times are ``inf`` for seeds
      that never reach the threshold, making their mean undefined); the time ratio is the
      ratio of those two times;
    * ``threshold_reached_*``: fraction of seeds whose own curve reaches the threshold,
      with a Wilson interval instead of a bootstrap one.

    Parameters
    ----------
    transfer_curves, baseline_curves : array_like, shape (n_seeds, n_episodes)
        Paired learning curves, same shape, finite, ``n_seeds >= 2``, every value
        ``>= floor``.
    first : int
        Episodes averaged for the jumpstart.
    last : int
        Episodes averaged for the asymptotic performance.
    threshold : float or None
        Reward level for the time-to-threshold metrics; ``None`` omits them.
    window : int
        Trailing-mean window for time to threshold.
    floor : float
        Minimum possible reward, the zero of the areas in ``transfer_ratio`` (default -1).
    n_boot : int
        Bootstrap replicates (default 10000).
    confidence : float
        Interval coverage (default 0.95).
    seed : int
        Seed of the resampling; same seed, same intervals.

    Returns
    -------
    dict of str to MetricEstimate
        Keys, in order: ``jumpstart``, ``asymptotic_transfer``, ``asymptotic_baseline``,
        ``asymptotic_gain``, ``total_reward_transfer``, ``total_reward_baseline``,
        ``total_reward_gain``, ``transfer_ratio`` and, if ``threshold`` is given,
        ``time_to_threshold_transfer``, ``time_to_threshold_baseline``,
        ``time_to_threshold_ratio``, ``threshold_reached_transfer``,
        ``threshold_reached_baseline``.

    Raises
    ------
    ValueError
        Non-finite/empty input, shape mismatch, fewer than 2 seeds, parameters out of
        range (``first``, ``last``, ``window`` longer than the curves), rewards below
        ``floor``.
    """
    t = _as_curves(transfer_curves, "transfer_curves")
    b = _as_curves(baseline_curves, "baseline_curves")
    if t.shape != b.shape:
        raise ValueError(
            f"transfer_curves and baseline_curves must have the same (n_seeds, n_episodes) "
            f"shape with paired rows, got {t.shape} and {b.shape}"
        )
    n_seeds, n_eps = t.shape
    n_boot, confidence = _check_boot(n_boot, n_seeds, confidence)
    first = _check_count(first, "first", n_eps)
    last = _check_count(last, "last", n_eps)
    floor = _check_floor(t, floor, "transfer_curves")
    _check_floor(b, floor, "baseline_curves")
    if threshold is not None:
        threshold = _check_real(threshold, "threshold")
        window = _check_count(window, "window", n_eps)

    weights = _resample_counts(n_seeds, n_boot, seed) / n_seeds  # (n_boot, n_seeds)
    out: dict[str, MetricEstimate] = {}

    def add(
        name: str,
        value: float,
        reps: FloatArray,
        definition: str,
        undefined: tuple[float, float] = (-math.inf, math.inf),
    ) -> None:
        low, high = _percentile_interval(reps, confidence, undefined)
        out[name] = MetricEstimate(name, float(value), low, high, n_seeds, definition, confidence)

    def add_mean(name: str, per_seed: FloatArray, definition: str) -> None:
        add(name, per_seed.mean(), weights @ per_seed, "mean over seeds of " + definition)

    js = t[:, :first].mean(axis=1) - b[:, :first].mean(axis=1)
    add_mean(
        "jumpstart",
        js,
        f"(mean reward of the first {first} episodes with transfer) - (same for baseline), "
        "paired by seed; reward units",
    )
    asym_t, asym_b = t[:, -last:].mean(axis=1), b[:, -last:].mean(axis=1)
    add_mean("asymptotic_transfer", asym_t, f"mean reward of the last {last} episodes, transfer")
    add_mean("asymptotic_baseline", asym_b, f"mean reward of the last {last} episodes, baseline")
    add_mean(
        "asymptotic_gain",
        asym_t - asym_b,
        f"(mean reward of the last {last} episodes with transfer) - (same for baseline), "
        "paired by seed; reward units",
    )
    tot_t, tot_b = t.sum(axis=1), b.sum(axis=1)
    add_mean(
        "total_reward_transfer",
        tot_t,
        f"total reward = sum of the {n_eps} per-episode rewards (discrete area), transfer",
    )
    add_mean(
        "total_reward_baseline",
        tot_b,
        f"total reward = sum of the {n_eps} per-episode rewards (discrete area), baseline",
    )
    add_mean(
        "total_reward_gain",
        tot_t - tot_b,
        f"(sum of the {n_eps} rewards with transfer) - (same for baseline), paired by seed",
    )

    area_t, area_b = (t - floor).sum(axis=1), (b - floor).sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio_reps = (weights @ area_t) / (weights @ area_b)
        ratio_reps = np.where(weights @ area_b == 0.0, np.nan, ratio_reps)
    mean_area_b = area_b.mean()
    add(
        "transfer_ratio",
        area_t.mean() / mean_area_b if mean_area_b != 0.0 else math.nan,
        ratio_reps,
        f"ratio of mean areas: mean over seeds of sum(transfer - ({floor:g})) / mean over "
        f"seeds of sum(baseline - ({floor:g})), areas above the reward floor {floor:g}; "
        "nan if the baseline area is 0; > 1 favours transfer" + _UNDEFINED_NOTE,
        (0.0, math.inf),
    )

    if threshold is not None:
        ones = np.full((1, n_seeds), 1.0 / n_seeds)
        tt = float(_mean_curve_times(t, ones, threshold, window)[0])
        tb = float(_mean_curve_times(b, ones, threshold, window)[0])
        tt_reps = _mean_curve_times(t, weights, threshold, window)
        tb_reps = _mean_curve_times(b, weights, threshold, window)
        crit = (
            f"first episode number t (1-based = episodes played, t >= {window}) at which the "
            f"mean of episodes t-{window}+1..t of the seed-mean curve is >= {threshold:g}; "
            "inf if never"
        )
        add("time_to_threshold_transfer", tt, tt_reps, "transfer: " + crit)
        add("time_to_threshold_baseline", tb, tb_reps, "baseline: " + crit)
        with np.errstate(divide="ignore", invalid="ignore"):
            # IEEE: finite/inf = 0, inf/finite = inf, inf/inf = nan (neither reaches it).
            ratio_t = tt_reps / tb_reps
        add(
            "time_to_threshold_ratio",
            _time_ratio(tt, tb),
            ratio_t,
            "time_to_threshold_transfer / time_to_threshold_baseline (seed-mean curves); "
            "< 1 favours transfer; 0 if only transfer reaches the threshold, inf if only "
            "baseline does, nan if neither" + _UNDEFINED_NOTE,
            (0.0, math.inf),
        )
        for label, arr in (("transfer", t), ("baseline", b)):
            times = _first_crossing(smooth(arr, window, edges="valid"), threshold, window)
            k = int(np.isfinite(times).sum())
            low, high = wilson_interval(k, n_seeds, confidence)
            name = f"threshold_reached_{label}"
            out[name] = MetricEstimate(
                name,
                k / n_seeds,
                low,
                high,
                n_seeds,
                f"fraction of seeds whose own trailing mean over {window} episodes reaches "
                f"{threshold:g}, {label}; Wilson score interval",
                confidence,
            )
    return out


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
    """A markdown table of estimates: metric, value, CI, n, definition.

    The CI column is headed with the common confidence level (e.g. "95% CI"); if the
    estimates use different levels each cell states its own. ``nan`` prints as ``n/a``,
    infinities as ``inf``; ``|`` in definitions is escaped.

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
    lines = [f"| metric | value | {head} | n | definition |", "|---|---:|---|---:|---|"]
    for key, e in estimates.items():
        ci = f"[{_fmt(e.low)}, {_fmt(e.high)}]"
        if not uniform:
            ci += f" ({e.confidence * 100:g}%)"
        definition = e.definition.replace("|", "\\|")
        lines.append(f"| {key} | {_fmt(e.value)} | {ci} | {e.n} | {definition} |")
    return "\n".join(lines) + "\n"
