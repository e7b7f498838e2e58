"""Intervals and tests on per-seed values, the seed being the unit.

:func:`t_interval` and :func:`t_test_pvalue` (Student t; on paired differences, the paired
t), :func:`sign_flip_pvalue` (the sign-flip permutation test beside it), :func:`fieller_interval` (ratio of two paired means), :func:`wilson_interval` (a
share), :func:`percentile_bootstrap_interval` (kept for comparison: it covers too rarely at
10 seeds), :func:`holm` (family-wise adjustment), :func:`improvement_test` (paired
probability of improvement, sign and Wilcoxon tests) and :func:`trend_slopes` (a trend
along a stream with seeds as clusters). Which interval is used where, and why, is in
``docs/statistics.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy import stats

from ilpss.metrics._validation import (
    FloatArray,
    _as_curve,
    _as_curves,
    _as_floats,
    _check_confidence,
    _check_real,
)
from soccer_drill.constraints import Integer, OneOf, check, is_int


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
    arr = _as_floats(values, name)
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


ALTERNATIVES = ("two-sided", "greater")
"""The alternatives of the tests: the mean differs from ``null``, or exceeds it (the one-sided
test of a gain, or of no loss beyond a margin: ``null`` is then the margin)."""


def t_test_pvalue(values: ArrayLike, null: float = 0.0,
                  alternative: str = "two-sided") -> float | FloatArray:
    """p-value of the one-sample t-test that the mean of ``values`` is ``null``.

    The test that matches :func:`t_interval`: ``p < 1 - confidence`` exactly when the
    interval at ``confidence`` excludes ``null``. On per-seed differences it is the paired
    t-test. With zero spread the p-value is 1 if every value is at most ``null`` (two-sided:
    equals it), else 0.

    Parameters
    ----------
    values : array_like, shape (..., n)
        Per-seed values along the last axis, ``n >= 2``, finite.
    null : float
        Mean under the null hypothesis (default 0).
    alternative : {"two-sided", "greater"}
        ``"greater"``: the one-sided test of "the mean exceeds ``null``", whose p is below
        ``(1 - confidence) / 2`` exactly when the lower bound of :func:`t_interval` at
        ``confidence`` lies above ``null``.

    Returns
    -------
    float, or an array of the leading shape
    """
    x = _as_samples(values, "values")
    null = _check_real(null, "null")
    check("alternative", alternative, OneOf(ALTERNATIVES))
    n = x.shape[-1]
    diff = x.mean(axis=-1) - null
    se = x.std(axis=-1, ddof=1) / math.sqrt(n)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = diff / se
    if alternative == "greater":
        p = np.where(se > 0, stats.t.sf(t, n - 1), np.where(diff > 0, 0.0, 1.0))
    else:
        p = np.where(se > 0, 2.0 * stats.t.sf(np.abs(t), n - 1),
                     np.where(diff == 0, 1.0, 0.0))
    # Zero spread is read from the values themselves: equal values can have a computed
    # spread of ~1e-17 and a mean off null by as much.
    equal = np.all(x == x[..., :1], axis=-1)
    at_null = (x[..., 0] <= null) if alternative == "greater" else (x[..., 0] == null)
    p = np.where(equal, np.where(at_null, 1.0, 0.0), p)
    return _scalar_or_array(p)


#: Up to this many seeds :func:`sign_flip_pvalue` enumerates every sign vector (2**16).
EXACT_SIGN_FLIPS = 16


def sign_flip_pvalue(values: ArrayLike, null: float = 0.0, alternative: str = "two-sided",
                     n_resamples: int = 200_000, seed: int = 0) -> float:
    """p-value of the sign-flip permutation test of "the per-seed values are symmetric
    around ``null``", on their mean.

    The distribution-free companion of :func:`t_test_pvalue` for paired differences: under
    the null each seed's ``values[i] - null`` is as likely to have either sign, so the
    observed mean is compared with the means of every assignment of signs. Up to
    :data:`EXACT_SIGN_FLIPS` seeds every one of the ``2**n`` assignments is used (exact);
    beyond, ``n_resamples`` random ones (seeded by ``seed``) and the observed one, so the
    p-value is ``(1 + count) / (1 + n_resamples)`` and never 0. With 10 seeds the smallest
    p is ``2 / 1024`` (two-sided), whatever the effect.

    Parameters
    ----------
    values : array_like, shape (n,)
        Per-seed values (differences), ``n >= 2``, finite.
    null : float
        The centre under the null hypothesis (a margin for a test of no loss beyond it).
    alternative : {"two-sided", "greater"}
        ``"greater"``: the mean exceeds ``null``.
    n_resamples : int
        Random sign assignments when ``n > EXACT_SIGN_FLIPS``.
    seed : int
        Seed of those draws.
    """
    x = _as_samples(values, "values")
    if x.ndim != 1:
        raise ValueError(f"values must be one-dimensional (the seeds), got shape {x.shape}")
    null = _check_real(null, "null")
    check("alternative", alternative, OneOf(ALTERNATIVES))
    check("n_resamples", n_resamples, Integer(1))
    d = x - null
    n = d.size
    observed = d.mean()
    if n <= EXACT_SIGN_FLIPS:
        signs = 1.0 - 2.0 * ((np.arange(2**n)[:, None] >> np.arange(n)) & 1)
        extra = 0
    else:
        rng = np.random.default_rng(seed)
        signs = rng.choice((-1.0, 1.0), size=(n_resamples, n))
        extra = 1  # the observed assignment itself
    means = signs @ d / n
    # A tolerance of rounding: a resampled mean equal to the observed one counts as it.
    tol = 1e-12 * max(1.0, float(np.abs(d).max()))
    if alternative == "greater":
        count = int(np.sum(means >= observed - tol))
    else:
        count = int(np.sum(np.abs(means) >= abs(observed) - tol))
    return float((count + extra) / (len(means) + extra))


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
    p = _as_floats(p_values, "p_values")
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
        if not is_int(value):
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
    if not is_int(n_boot) or n_boot < 1:
        raise ValueError(f"n_boot must be a positive integer, got {n_boot!r}")
    if n_seeds < 2:
        raise ValueError(f"intervals over seeds need at least 2 seeds, got {n_seeds}")
    return int(n_boot), _check_confidence(confidence)


def _resample_counts(n_seeds: int, n_boot: int, seed: int) -> FloatArray:
    """How often each seed is drawn in each bootstrap replicate, shape ``(n_boot, n_seeds)``.

    One draw of ``n_seeds`` indices with replacement per replicate, from
    ``np.random.default_rng(seed)``; identical for identical arguments.
    """
    idx = np.random.default_rng(seed).integers(0, n_seeds, size=(n_boot, n_seeds))
    flat = (idx + n_seeds * np.arange(n_boot)[:, None]).ravel()
    return np.bincount(flat, minlength=n_boot * n_seeds).reshape(n_boot, n_seeds).astype(float)
