"""Per-curve transfer metrics (Taylor & Stone 2009), and the trailing mean they read.

A *learning curve* is a 1-D array of rewards indexed by training episode (or by evaluation
point: every function below treats the index generically, so "episode" may be read as
"evaluation point" throughout; the caller converts to episodes if needed). Rewards are
assumed to lie in ``[floor, ...]`` with ``floor = -1.0`` by default.

Taylor & Stone 2009, "Transfer Learning for Reinforcement Learning Domains: A Survey",
JMLR 10, section 2.1:

* :func:`jumpstart` -- initial advantage: mean of the first ``K`` points, transfer minus
  baseline.
* :func:`asymptotic_performance` / :func:`asymptotic_gain` -- mean of the last ``K``
  points, and its difference. On a finite budget this is the *final performance within
  the budget*, not an asymptote: the learner may still be improving.
* :func:`total_reward` / :func:`total_reward_gain` -- discrete area under the curve.
* :func:`transfer_ratio` -- ratio of areas measured above a reward floor.
* :func:`time_to_threshold` / :func:`time_to_threshold_ratio` -- episodes until the
  trailing-mean curve (:func:`smooth`) first reaches a threshold, and their ratio.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from ilpss.metrics._validation import (
    FloatArray,
    _as_curve,
    _as_curves,
    _as_floats,
    _check_count,
    _check_floor,
    _check_real,
    _pair,
)

#: Absolute tolerance of the threshold test ``smoothed >= threshold - THRESHOLD_ATOL``; it
#: only absorbs rounding in the running sums of :func:`smooth` (e.g. a window mean that is
#: exactly 0.5 in real arithmetic but 0.49999999999999994 in floating point).
THRESHOLD_ATOL = 1e-9


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
    arr = _as_floats(curve, "curve")  # text, objects and ragged rows refused by name
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
