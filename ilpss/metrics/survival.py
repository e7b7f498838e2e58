"""Time to threshold over seeds as censored survival data.

Each seed's time is taken on its own curve and censored at the budget
(:func:`threshold_times`), then summarised: :func:`kaplan_meier`, :func:`km_median` (with
:func:`median_interval`) and :func:`restricted_mean_time`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import stats

from ilpss.metrics._validation import (
    FloatArray,
    _as_curves,
    _as_floats,
    _check_confidence,
    _check_count,
    _check_real,
)
from ilpss.metrics.curves import _first_crossing, smooth


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
    t = _as_floats(times, "times")  # text and objects refused by name, not parsed
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
