"""Tests of ilpss.metrics (transfer metrics, bootstrap intervals) and ilpss.plots."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from ilpss.metrics import (
    MetricEstimate,
    area_above_floor,
    asymptotic_gain,
    asymptotic_performance,
    compare,
    episodes_below,
    fieller_interval,
    format_metrics_markdown,
    holm,
    improvement_test,
    jumpstart,
    kaplan_meier,
    km_median,
    largest_dip,
    mean_curve_band,
    median_interval,
    percentile_bootstrap_interval,
    restricted_mean_time,
    smooth,
    t_interval,
    t_test_pvalue,
    threshold_times,
    time_to_threshold,
    time_to_threshold_ratio,
    total_reward,
    total_reward_gain,
    transfer_ratio,
    trend_slopes,
    wilson_interval,
)
from ilpss.plots import LEGEND_INSIDE_AT_MOST, plot_learning_curves, plot_score_profiles

# Tiny hand-checked curves (length 6).
T = np.array([0.0, 0.5, 0.5, 1.0, 1.0, 1.0])
B = np.array([-1.0, -0.5, 0.0, 0.0, 0.5, 0.5])


# --------------------------------------------------------------------------- smoothing
def test_smooth_expanding_and_valid_by_hand():
    np.testing.assert_allclose(smooth(T, 2), [0.0, 0.25, 0.5, 0.75, 1.0, 1.0])
    np.testing.assert_allclose(smooth(T, 2, edges="valid"), [0.25, 0.5, 0.75, 1.0, 1.0])
    np.testing.assert_allclose(smooth(B, 3), [-1.0, -0.75, -0.5, -1 / 6, 1 / 6, 1 / 3])
    np.testing.assert_allclose(smooth(B, 1), B)
    # 2-D: row by row
    np.testing.assert_allclose(smooth(np.stack([T, B]), 6, edges="valid"), [[4 / 6], [-0.5 / 6]])


def test_smooth_validation():
    with pytest.raises(ValueError, match="window"):
        smooth(T, 7)
    with pytest.raises(ValueError, match="window"):
        smooth(T, 0)
    with pytest.raises(ValueError, match="edges"):
        smooth(T, 2, edges="centered")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="NaN"):
        smooth([0.0, np.nan], 1)
    with pytest.raises(ValueError, match="empty"):
        smooth([], 1)


# --------------------------------------------------------------------------- per-curve metrics
def test_jumpstart_by_hand():
    assert jumpstart(T, B, first=1) == pytest.approx(1.0)  # 0 - (-1)
    assert jumpstart(T, B, first=2) == pytest.approx(1.0)  # 0.25 - (-0.75)
    assert jumpstart(T, B, first=3) == pytest.approx(5 / 6)  # 1/3 - (-1/2)
    assert jumpstart(B, T, first=3) == pytest.approx(-5 / 6)


def test_asymptotic_by_hand():
    assert asymptotic_performance(T, last=3) == pytest.approx(1.0)
    assert asymptotic_performance(B, last=3) == pytest.approx(1 / 3)
    assert asymptotic_performance(B, last=6) == pytest.approx(-0.5 / 6)
    assert asymptotic_gain(T, B, last=3) == pytest.approx(2 / 3)
    assert asymptotic_gain(T, B, last=1) == pytest.approx(0.5)


def test_total_reward_by_hand():
    assert total_reward(T) == pytest.approx(4.0)
    assert total_reward(B) == pytest.approx(-0.5)
    assert total_reward_gain(T, B) == pytest.approx(4.5)


def test_transfer_ratio_by_hand():
    assert area_above_floor(T) == pytest.approx(10.0)  # 4 + 6 * 1
    assert area_above_floor(B) == pytest.approx(5.5)  # -0.5 + 6 * 1
    assert transfer_ratio(T, B) == pytest.approx(10 / 5.5)
    assert transfer_ratio(T, B, floor=-2.0) == pytest.approx(16 / 11.5)
    assert transfer_ratio(B, B) == pytest.approx(1.0)


def test_transfer_ratio_baseline_area_zero_is_nan():
    floor_curve = np.full(6, -1.0)
    assert math.isnan(transfer_ratio(T, floor_curve))
    assert math.isnan(transfer_ratio(floor_curve, floor_curve))


def test_transfer_ratio_refuses_rewards_below_floor():
    with pytest.raises(ValueError, match="floor"):
        transfer_ratio(T, B, floor=-0.5)


def test_time_to_threshold_by_hand():
    # T smoothed (full windows of 2) = 0.25, 0.5, ... ending at episodes 2, 3, ...
    assert time_to_threshold(T, 0.5, window=2) == 3
    # B full windows of 2: -0.75, -0.25, 0, 0.25, 0.5 ending at episodes 2..6
    assert time_to_threshold(B, 0.5, window=2) == 6
    assert time_to_threshold(T, 1.0, window=1) == 4
    assert time_to_threshold(T, 1.0, window=3) == 6  # only T[3:6] averages 1
    assert time_to_threshold(T, 0.0, window=1) == 1
    # the expanding edge never counts: T[0] = 0 alone is not a full window of 2
    assert time_to_threshold(T, 0.0, window=2) == 2
    assert time_to_threshold_ratio(T, B, 0.5, window=2) == pytest.approx(0.5)
    assert time_to_threshold_ratio(B, T, 0.5, window=2) == pytest.approx(2.0)


def test_time_to_threshold_never_reached():
    assert time_to_threshold(B, 0.9, window=2) == math.inf
    assert time_to_threshold_ratio(T, B, 0.9, window=1) == 0.0  # only transfer reaches it
    assert time_to_threshold_ratio(B, T, 0.9, window=1) == math.inf  # only baseline does
    assert math.isnan(time_to_threshold_ratio(B, B, 0.9, window=1))  # neither


def test_time_to_threshold_tolerates_rounding():
    # sum of ten 0.1 is 0.9999999999999999 in floating point; still "reaches" 0.1
    assert time_to_threshold([0.1] * 10, 0.1, window=10) == 10


@pytest.mark.parametrize(
    "call",
    [
        lambda c: jumpstart(c, B, first=2),
        lambda c: jumpstart(T, c, first=2),
        lambda c: asymptotic_performance(c, last=2),
        lambda c: asymptotic_gain(c, B, last=2),
        lambda c: total_reward(c),
        lambda c: total_reward_gain(T, c),
        lambda c: transfer_ratio(c, B),
        lambda c: time_to_threshold(c, 0.5, window=2),
        lambda c: time_to_threshold_ratio(T, c, 0.5),
    ],
)
def test_per_curve_metrics_refuse_nan(call):
    bad = T.copy()
    bad[2] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        call(bad)


def test_per_curve_validation():
    with pytest.raises(ValueError, match="same length"):
        jumpstart(T, B[:5], first=2)
    with pytest.raises(ValueError, match="same length"):
        transfer_ratio(T, B[:5])
    with pytest.raises(ValueError, match="first"):
        jumpstart(T, B, first=7)
    with pytest.raises(ValueError, match="last"):
        asymptotic_performance(T, last=0)
    with pytest.raises(ValueError, match="window"):
        time_to_threshold(T, 0.5, window=7)
    with pytest.raises(ValueError, match="empty"):
        total_reward([])
    with pytest.raises(ValueError, match="1-D"):
        total_reward(np.stack([T, B]))
    with pytest.raises(ValueError, match="threshold"):
        time_to_threshold(T, math.nan)


# --------------------------------------------------------------------------- Wilson
def test_wilson_interval_known_values():
    low, high = wilson_interval(8, 10)
    assert low == pytest.approx(0.4902, abs=1e-4)
    assert high == pytest.approx(0.9433, abs=1e-4)
    low, high = wilson_interval(0, 10)
    assert low == 0.0
    assert high == pytest.approx(0.27753, abs=1e-5)  # z²/n / (1 + z²/n)
    assert wilson_interval(10, 10)[1] == 1.0
    with pytest.raises(ValueError):
        wilson_interval(11, 10)
    with pytest.raises(ValueError):
        wilson_interval(0, 0)


# --------------------------------------------------------------------------- compare
def test_compare_values_by_hand():
    t = np.stack([T, np.zeros(6)])
    b = np.stack([B, np.full(6, -0.5)])
    est = compare(t, b, first=2, last=3, threshold=0.5, window=2)
    assert est["jumpstart"].value == pytest.approx((1.0 + 0.5) / 2)
    assert est["final_transfer"].value == pytest.approx((1.0 + 0.0) / 2)
    assert est["final_baseline"].value == pytest.approx((1 / 3 - 0.5) / 2)
    assert est["final_gain"].value == pytest.approx((2 / 3 + 0.5) / 2)
    assert est["total_reward_transfer"].value == pytest.approx(2.0)
    assert est["total_reward_baseline"].value == pytest.approx((-0.5 - 3.0) / 2)
    assert est["total_reward_gain"].value == pytest.approx((4.5 + 3.0) / 2)
    # the budget of 6 is shorter than 20: the first 20 episodes are all of them
    assert est["total_reward_gain_first_20"].value == pytest.approx((4.5 + 3.0) / 2)
    # ratio of mean areas: ((10 + 6) / 2) / ((5.5 + 3) / 2), not the mean of ratios
    assert est["transfer_ratio"].value == pytest.approx(16 / 8.5)
    # per seed, censored at the budget of 6: transfer reaches 0.5 at 3 (T) and never
    # (zeros); baseline at 6 (B) and never (-0.5)
    assert est["time_to_threshold_transfer"].value == pytest.approx((3 + 6) / 2)
    assert est["time_to_threshold_baseline"].value == pytest.approx(6.0)
    assert est["time_to_threshold_gain"].value == pytest.approx(-1.5)
    assert est["time_to_threshold_ratio"].value == pytest.approx(4.5 / 6)
    assert est["median_time_to_threshold_transfer"].value == 3  # S drops to 1/2 at 3
    assert est["median_time_to_threshold_baseline"].value == 6
    assert est["threshold_reached_transfer"].value == 0.5
    assert est["threshold_reached_baseline"].value == 0.5
    # the jumpstart's t interval by hand: per-seed values 1.0 and 0.5, t(1) quantile
    half = stats.t.ppf(0.975, 1) * np.std([1.0, 0.5], ddof=1) / np.sqrt(2)
    assert (est["jumpstart"].low, est["jumpstart"].high) == pytest.approx((0.75 - half,
                                                                          0.75 + half))
    assert est["jumpstart"].interval == "Student t"
    assert est["transfer_ratio"].interval == "Fieller"
    assert est["threshold_reached_transfer"].interval == "Wilson"
    for e in est.values():
        assert isinstance(e, MetricEstimate)
        assert e.n == 2
        assert e.definition
        assert e.low <= e.high
    # p-values exactly where there is a difference to test
    with_p = {k for k, e in est.items() if not math.isnan(e.p_value)}
    assert with_p == {"jumpstart", "final_gain", "total_reward_gain", "transfer_ratio",
                      "largest_dip_gain", "time_to_threshold_gain", "time_to_threshold_ratio",
                      "time_to_threshold_ratio_warm", "total_reward_gain_first_20",
                      "total_reward_gain_first_50"}
    # the transfer ratio's test at 1 is the total-reward gain's test at 0
    assert est["transfer_ratio"].p_value == pytest.approx(est["total_reward_gain"].p_value)


def test_compare_transfer_ratio_nan_when_baseline_area_zero():
    t = np.stack([T, T])
    b = np.full((2, 6), -1.0)
    est = compare(t, b, first=1, last=1, threshold=None, window=1)
    assert math.isnan(est["transfer_ratio"].value)
    assert (est["transfer_ratio"].low, est["transfer_ratio"].high) == (-math.inf, math.inf)
    assert "time_to_threshold_ratio" not in est
    boot = compare(t, b, first=1, last=1, threshold=None, window=1, interval="percentile",
                   n_boot=200)
    assert math.isnan(boot["transfer_ratio"].value) and math.isnan(boot["transfer_ratio"].low)


def test_compare_threshold_never_reached_intervals():
    rng = np.random.default_rng(1)
    t = np.clip(0.8 + 0.05 * rng.standard_normal((10, 20)), -1, 1)
    b = np.clip(-0.5 + 0.05 * rng.standard_normal((10, 20)), -1, 1)
    est = compare(t, b, first=2, last=5, threshold=0.5, window=3)
    assert est["time_to_threshold_transfer"].value == 3
    # never reached: every baseline seed is censored at the budget of 20 episodes
    base = est["time_to_threshold_baseline"]
    assert (base.value, base.low, base.high) == (20, 20, 20)
    ratio = est["time_to_threshold_ratio"]
    assert (ratio.value, ratio.low, ratio.high) == pytest.approx((0.15, 0.15, 0.15))
    median = est["median_time_to_threshold_baseline"]
    assert (median.value, median.low, median.high) == (math.inf, math.inf, math.inf)
    assert est["median_time_to_threshold_transfer"].value == 3
    assert est["threshold_reached_transfer"].value == 1.0
    assert est["threshold_reached_transfer"].high == 1.0
    assert est["threshold_reached_baseline"].value == 0.0


@pytest.mark.parametrize("interval", ["t", "percentile"])
def test_paired_intervals_keep_pairs(interval):
    rng = np.random.default_rng(7)
    n_seeds, n_eps = 30, 40
    level = rng.uniform(-0.8, 0.6, size=(n_seeds, 1))  # huge between-seed variance
    baseline = np.clip(level + 0.1 * rng.standard_normal((n_seeds, n_eps)), -0.95, 0.85)
    transfer = baseline + 0.1
    kw = dict(first=5, last=5, threshold=None, window=1, interval=interval, n_boot=2000)
    est = compare(transfer, baseline, **kw)
    for key, expected in (("jumpstart", 0.1), ("final_gain", 0.1), ("total_reward_gain", 4)):
        e = est[key]
        assert e.value == pytest.approx(expected)
        assert e.low == pytest.approx(expected, abs=1e-9)
        assert e.high == pytest.approx(expected, abs=1e-9)
    # the check has teeth: breaking the pairing widens the interval enormously
    broken = compare(transfer, baseline[rng.permutation(n_seeds)], **kw)
    assert broken["jumpstart"].high - broken["jumpstart"].low > 0.2


def test_compare_is_deterministic():
    rng = np.random.default_rng(3)
    t = rng.uniform(-1, 1, size=(8, 30))
    b = rng.uniform(-1, 1, size=(8, 30))
    kw = dict(first=5, last=5, threshold=0.0, window=5)
    assert compare(t, b, **kw) == compare(t, b, **kw)
    assert compare(t, b, seed=1, **kw) == compare(t, b, seed=2, **kw)  # t: no resampling
    boot = dict(kw, interval="percentile", n_boot=500)
    a1, a2 = compare(t, b, seed=11, **boot), compare(t, b, seed=11, **boot)
    assert a1 == a2
    a3 = compare(t, b, seed=12, **boot)
    assert a3["jumpstart"].value == a1["jumpstart"].value
    assert (a3["jumpstart"].low, a3["jumpstart"].high) != (
        a1["jumpstart"].low,
        a1["jumpstart"].high,
    )


# --------------------------------------------------------------------------- bootstrap coverage
def test_mean_curve_band_coverage():
    # 400 "episodes" = 400 independent data sets of 30 seeds each, known mean 0.3.
    rng = np.random.default_rng(2024)
    curves = 0.3 + 0.5 * rng.standard_normal((30, 400))
    mean, low, high = mean_curve_band(curves, n_boot=2000, seed=5)
    np.testing.assert_allclose(mean, curves.mean(axis=0))
    assert np.all(low <= mean) and np.all(mean <= high)
    coverage = np.mean((low <= 0.3) & (0.3 <= high))
    assert 0.9 <= coverage <= 0.99, coverage
    # band width close to the normal-theory 2 * 1.96 * sd / sqrt(n)
    assert np.mean(high - low) == pytest.approx(2 * 1.96 * 0.5 / np.sqrt(30), rel=0.15)


def test_compare_validation():
    good = np.zeros((3, 6))
    kw = dict(first=2, last=2, threshold=0.5, window=2, n_boot=10)
    with pytest.raises(ValueError, match="same"):
        compare(good, np.zeros((3, 5)), **kw)
    with pytest.raises(ValueError, match="same"):
        compare(good, np.zeros((4, 6)), **kw)
    bad = good.copy()
    bad[1, 1] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        compare(bad, good, **kw)
    with pytest.raises(ValueError, match="NaN"):
        compare(good, bad, **kw)
    with pytest.raises(ValueError, match="shape"):
        compare(np.zeros(6), np.zeros(6), **kw)
    with pytest.raises(ValueError, match="empty"):
        compare(np.zeros((3, 0)), np.zeros((3, 0)), **kw)
    with pytest.raises(ValueError, match="2 seeds"):
        compare(good[:1], good[:1], **kw)
    with pytest.raises(ValueError, match="window"):
        compare(good, good, **{**kw, "window": 7})
    # before, any truthy warmup ("no", 1) switched the time-to-threshold definition
    with pytest.raises(ValueError, match="warmup must be true or false, got 'no'"):
        compare(good, good, **{**kw, "warmup": "no"})
    with pytest.raises(ValueError, match="first"):
        compare(good, good, **{**kw, "first": 7})
    with pytest.raises(ValueError, match="floor"):
        compare(good - 2.0, good, **kw)
    with pytest.raises(ValueError, match="confidence"):
        compare(good, good, **{**kw, "confidence": 1.0})
    with pytest.raises(ValueError, match="interval must be one of"):
        compare(good, good, **{**kw, "interval": "bca"})
    with pytest.raises(ValueError, match="n_boot"):
        compare(good, good, **{**kw, "n_boot": 0})


def _symmetric_sets(rng, n_sets, n_seeds, n_eps=12):
    """Data sets of paired curves whose per-seed jumpstart and total-reward gain are
    normal: true jumpstart 0.2, true total-reward gain 0.2 * n_eps."""
    level = rng.uniform(-0.5, 0.3, size=(n_sets, n_seeds, 1))
    baseline = level + 0.1 * rng.standard_normal((n_sets, n_seeds, n_eps))
    transfer = baseline + 0.2 + 0.3 * rng.standard_normal((n_sets, n_seeds, 1))
    return transfer, baseline


def test_compare_default_intervals_cover_at_10_seeds():
    # 1000 data sets of 10 paired seeds (coverage's standard error about 0.007); the
    # percentile bootstrap this default replaced covers about 0.91 here
    rng = np.random.default_rng(99)
    transfer, baseline = _symmetric_sets(rng, 1000, 10)
    hits = {"jumpstart": 0, "total_reward_gain": 0}
    for t, b in zip(transfer, baseline, strict=True):
        est = compare(t, b, first=3, last=3, threshold=None, window=1, floor=-3.0)
        hits["jumpstart"] += est["jumpstart"].low <= 0.2 <= est["jumpstart"].high
        gain = est["total_reward_gain"]
        hits["total_reward_gain"] += gain.low <= 0.2 * 12 <= gain.high
    for key, h in hits.items():
        assert 0.93 <= h / 1000 <= 0.97, (key, h / 1000)


def test_t_interval_covers_and_the_percentile_bootstrap_does_not_at_10_seeds():
    rng = np.random.default_rng(5)
    x = 0.3 + 0.5 * rng.standard_normal((4000, 10))  # 4000 data sets, known mean 0.3
    _, low, high = t_interval(x)
    assert 0.935 <= np.mean((low <= 0.3) & (0.3 <= high)) <= 0.965
    _, low, high = percentile_bootstrap_interval(x, n_boot=2000, seed=1)
    assert np.mean((low <= 0.3) & (0.3 <= high)) < 0.925  # about 0.90: too narrow
    # at 30 seeds the two agree better, and t still covers
    x = 0.3 + 0.5 * rng.standard_normal((4000, 30))
    _, low, high = t_interval(x)
    assert 0.935 <= np.mean((low <= 0.3) & (0.3 <= high)) <= 0.965


def test_fieller_interval_covers_at_10_seeds():
    rng = np.random.default_rng(6)
    den = 300 + 60 * rng.standard_normal((4000, 10))  # areas of learning anew
    num = 1.1 * den + 30 * rng.standard_normal((4000, 10))  # paired, true ratio 1.1
    ratio, low, high = fieller_interval(num, den)
    assert np.all(low <= ratio) and np.all(ratio <= high)
    assert 0.935 <= np.mean((low <= 1.1) & (1.1 <= high)) <= 0.965


def test_rmst_ratio_covers_with_20_percent_negative_transfer():
    # Times to threshold with a 300-episode budget: learning anew reaches it after
    # U(120, 240) episodes; transfer after U(60, 180), except 20 % of seeds that never do
    # (censored at 300). True restricted-mean ratio (0.8 * 120 + 0.2 * 300) / 180.
    rng = np.random.default_rng(8)
    base = rng.uniform(120, 240, size=(4000, 10))
    never = rng.random((4000, 10)) < 0.2
    transfer = np.where(never, 300.0, rng.uniform(60, 180, size=(4000, 10)))
    truth = (0.8 * 120 + 0.2 * 300) / 180
    _, low, high = fieller_interval(transfer, base)
    coverage = np.mean((low <= truth) & (truth <= high))
    # below the nominal 0.95 (skewed per-seed times; 11 % of 10-seed samples hold no
    # seed that never reaches), but far from the 0.83 of the seed-mean-curve ratio
    assert 0.9 <= coverage <= 0.97, coverage


def test_t_interval_and_test_agree_with_scipy():
    x = np.array([0.3, -0.1, 0.5, 0.2, 0.9, 0.05, 0.4])
    mean, low, high = t_interval(x, 0.9)
    ref = stats.t.interval(0.9, len(x) - 1, loc=x.mean(), scale=stats.sem(x))
    assert mean == pytest.approx(x.mean()) and (low, high) == pytest.approx(ref)
    assert t_test_pvalue(x) == pytest.approx(stats.ttest_1samp(x, 0.0).pvalue)
    assert t_test_pvalue(x, null=0.1) == pytest.approx(stats.ttest_1samp(x, 0.1).pvalue)
    # the interval excludes a value exactly when the test rejects it
    for null in np.linspace(-0.5, 1.0, 61):
        _, lo, hi = t_interval(x)
        assert (t_test_pvalue(x, null) < 0.05) == (not lo <= null <= hi)
    # vectorised over leading axes; zero spread gives a point and p in {0, 1}
    rows = np.stack([x, x + 1.0, np.full(7, 2.0)])
    means, lows, highs = t_interval(rows, 0.9)
    assert lows[1] == pytest.approx(low + 1.0) and lows[2] == highs[2] == 2.0
    assert t_test_pvalue(np.full(4, 2.0)) == 0.0 and t_test_pvalue(np.zeros(4)) == 1.0
    with pytest.raises(ValueError, match="at least 2"):
        t_interval([1.0])
    with pytest.raises(ValueError, match="NaN"):
        t_interval([1.0, np.nan])
    with pytest.raises(ValueError, match="scalar"):
        t_interval(1.0)


def test_fieller_interval_by_hand():
    rng = np.random.default_rng(2)
    den = rng.uniform(200, 400, size=10)
    num = 1.2 * den + rng.normal(0, 20, size=10)
    ratio, low, high = fieller_interval(num, den)
    assert ratio == pytest.approx(num.mean() / den.mean())
    # the ends are exactly the ratios r at which the t-test of num - r * den has p = 0.05
    for r in (low, high):
        assert t_test_pvalue(num - r * den) == pytest.approx(0.05, abs=1e-9)
    assert t_test_pvalue(num - ratio * den) == pytest.approx(1.0)
    # the interval excludes 1 exactly when the t interval of num - den excludes 0
    _, d_low, _ = t_interval(num - den)
    assert (low > 1) == (d_low > 0)
    # no spread: the ratio itself; a denominator indistinguishable from 0: unbounded
    assert fieller_interval([2.0, 2.0], [1.0, 1.0]) == (2.0, 2.0, 2.0)
    assert fieller_interval([1.0, 2.0, 3.0], [-1.0, 1.0, 0.5])[1:] == (-math.inf, math.inf)
    with pytest.raises(ValueError, match="same shape"):
        fieller_interval([1.0, 2.0], [1.0, 2.0, 3.0])


def test_holm_by_hand():
    # sorted 0.005, 0.01, 0.03, 0.04 -> x4, x3, x2, x1 = 0.02, 0.03, 0.06, 0.04 -> running max
    np.testing.assert_allclose(holm([0.01, 0.04, 0.03, 0.005]), [0.03, 0.06, 0.06, 0.02])
    np.testing.assert_allclose(holm([0.5, 0.9]), [1.0, 1.0])  # monotone, capped at 1
    out = holm([0.01, np.nan, 0.02])  # nan is left out of the family
    assert math.isnan(out[1]) and out[[0, 2]] == pytest.approx([0.02, 0.02])
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        holm([0.5, 1.5])


# --------------------------------------------------------------------------- censored times
def _step_curves(times, n_eps=100, low=-1.0, high=1.0):
    """Curves at ``low`` up to episode ``time - 1`` and ``high`` from episode ``time`` on
    (1-based); ``inf`` never rises."""
    episode = np.arange(1, n_eps + 1)
    return np.where(episode[None, :] >= np.asarray(times, float)[:, None], high, low)


def test_threshold_times_of_step_curves():
    times, reached = threshold_times(_step_curves([10, 37, np.inf, 100]), 0.0, window=1)
    np.testing.assert_array_equal(times, [10, 37, 100, 100])
    np.testing.assert_array_equal(reached, [True, True, False, True])
    # a window of 4: the trailing mean is >= 0 once 2 of the 4 episodes are high
    times, reached = threshold_times(_step_curves([10, 99, 100]), 0.0, window=4)
    np.testing.assert_array_equal(times, [11, 100, 100])
    np.testing.assert_array_equal(reached, [True, True, False])
    with pytest.raises(ValueError, match="window"):
        threshold_times(np.zeros((2, 3)), 0.0, window=4)


def test_kaplan_meier_by_hand():
    # times 2, 3+, 3, 5, 6+, 8 ('+' censored): at 2, 6 at risk, S = 5/6; at 3 (the
    # censored seed at 3 still at risk), 5 at risk, S = 5/6 * 4/5 = 2/3; at 5, 3 at risk,
    # S = 2/3 * 2/3 = 4/9; at 8, 1 at risk, S = 0
    times = [2, 3, 3, 5, 6, 8]
    reached = np.array([True, False, True, True, False, True])
    event_times, survival = kaplan_meier(times, reached)
    np.testing.assert_array_equal(event_times, [2, 3, 5, 8])
    np.testing.assert_allclose(survival, [5 / 6, 2 / 3, 4 / 9, 0.0])
    assert km_median(times, reached) == 5
    # area under S: 2 * 1 + 1 * 5/6 + 2 * 2/3 + 3 * 4/9 up to 8
    assert restricted_mean_time(times, reached, 8) == pytest.approx(2 + 5 / 6 + 4 / 3 + 4 / 3)
    assert restricted_mean_time(times, reached, 4) == pytest.approx(2 + 5 / 6 + 2 / 3)
    with pytest.raises(ValueError, match="boolean"):
        kaplan_meier(times, [1, 0, 1, 1, 0, 1])
    with pytest.raises(ValueError, match="not known"):
        restricted_mean_time([2, 3], np.array([True, False]), 5)
    with pytest.raises(ValueError, match="censoring at the budget"):
        median_interval(times, reached)


def test_censored_at_the_budget_km_is_the_share_and_rmst_the_mean():
    rng = np.random.default_rng(4)
    times = rng.integers(20, 300, size=25).astype(float)
    reached = rng.random(25) < 0.7
    times[~reached] = 300.0  # censored at the budget
    event_times, survival = kaplan_meier(times, reached)
    for t, s in zip(event_times, survival, strict=True):
        assert s == pytest.approx(np.mean(np.where(reached, times, np.inf) > t))
    assert restricted_mean_time(times, reached, 300) == pytest.approx(times.mean())


def test_median_interval_order_statistics():
    times = np.arange(10, 110, 10, dtype=float)  # 10 seeds: [x_(2), x_(9)] at 95 %
    everyone = np.ones(10, dtype=bool)
    assert median_interval(times, everyone) == (20.0, 90.0)
    assert median_interval(times, everyone, 0.8) == (30.0, 80.0)  # 2 P(Bin <= 2) = 0.109
    late = everyone.copy()
    late[-2:] = False  # two seeds censored at the budget: the upper end is beyond it
    times[-2:] = 300.0
    assert median_interval(times, late) == (20.0, math.inf)
    assert median_interval(times[:5], everyone[:5]) == (-math.inf, math.inf)
    # the interval covers the median at least at its level, whatever the distribution
    rng = np.random.default_rng(9)
    draws = rng.exponential(100.0, size=(2000, 10))
    covered = [median_interval(d, np.ones(10, bool))[0] <= 100 * math.log(2)
               <= median_interval(d, np.ones(10, bool))[1] for d in draws]
    assert np.mean(covered) >= 0.95


def test_time_to_threshold_per_seed_with_20_percent_negative_transfer():
    # 10 seeds, budget 300. Learning anew reaches the threshold at 150..240; transfer
    # reaches it 60 episodes earlier on 8 seeds and never on 2 (negative transfer).
    base_times = np.arange(150, 250, 10, dtype=float)
    transfer_times = base_times - 60
    transfer_times[[3, 7]] = np.inf
    est = compare(_step_curves(transfer_times, 300), _step_curves(base_times, 300),
                  first=20, last=50, threshold=0.0, window=1)
    censored = np.where(np.isinf(transfer_times), 300.0, transfer_times)
    assert est["threshold_reached_transfer"].value == 0.8
    assert est["threshold_reached_baseline"].value == 1.0
    assert est["time_to_threshold_transfer"].value == pytest.approx(censored.mean())
    assert est["time_to_threshold_baseline"].value == pytest.approx(195.0)
    assert est["time_to_threshold_ratio"].value == pytest.approx(censored.mean() / 195.0)
    # Kaplan-Meier median: S falls to 1/2 at the 5th reached time, 90, 100, 110, 130, 140
    assert est["median_time_to_threshold_transfer"].value == 140
    assert est["median_time_to_threshold_baseline"].value == 190


def test_seeds_that_never_reach_the_threshold_stay_visible():
    # 4 of 10 seeds jump to 1.0 at episode 50, 6 stay at 0.3 below the threshold 0.5: the
    # seed-mean curve (0.4 + 0.18 = 0.58) crosses at 50, yet most seeds never reach it.
    curves = np.where(np.arange(10)[:, None] < 4, _step_curves([50] * 10, 100, 0.3, 1.0), 0.3)
    est = compare(curves, np.full((10, 100), -0.5), first=5, last=5, threshold=0.5,
                  window=1)
    assert est["threshold_reached_transfer"].value == 0.4
    assert est["median_time_to_threshold_transfer"].value == math.inf  # not within budget
    assert est["time_to_threshold_transfer"].value == pytest.approx((4 * 50 + 6 * 100) / 10)
def test_mean_curve_band_deterministic_and_validated():
    rng = np.random.default_rng(0)
    curves = rng.uniform(-1, 1, size=(5, 50))
    a = mean_curve_band(curves, n_boot=300, seed=1)
    b = mean_curve_band(curves, n_boot=300, seed=1)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)
    with pytest.raises(ValueError, match="2 seeds"):
        mean_curve_band(curves[:1])
    with pytest.raises(ValueError, match="NaN"):
        mean_curve_band(np.where(curves > 0.9, np.nan, curves))


# --------------------------------------------------------------------------- markdown
def test_format_metrics_markdown():
    est = {
        "jumpstart": MetricEstimate("jumpstart", 0.25, 0.1, 0.4, 30, "a | b", 0.95, "Student t",
                                     0.0123),
        "transfer_ratio": MetricEstimate("transfer_ratio", math.nan, math.nan, math.nan, 30, "r"),
        "time": MetricEstimate("time", 12.0, 10.0, math.inf, 30, "t"),
    }
    md = format_metrics_markdown(est)
    lines = md.strip().split("\n")
    assert lines[0] == "| metric | value | 95% CI | interval | p | n | definition |"
    assert len(lines) == 2 + 3
    assert lines[2] == "| jumpstart | 0.25 | [0.1, 0.4] | Student t | 0.012 | 30 | a \\| b |"
    assert "| n/a | [n/a, n/a] |" in lines[3]
    assert "[10, inf]" in lines[4]


# --------------------------------------------------------------------------- plots
def test_plot_learning_curves_writes_png(tmp_path):
    rng = np.random.default_rng(0)
    curves = {
        "ilpss": np.clip(rng.normal(0.2, 0.3, size=(5, 60)), -1, 1),
        "scratch": np.clip(rng.normal(-0.1, 0.3, size=(5, 60)), -1, 1),
        "single": rng.uniform(-1, 1, size=60),  # 1-D: one seed, no band
    }
    out = tmp_path / "figs" / "curves.png"
    result = plot_learning_curves(
        curves, out, title="test", window=5, markers={"opponent 4": 30}, n_boot=200
    )
    assert result == out
    data = out.read_bytes()
    assert len(data) > 1000
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in out.parent.iterdir()) == ["curves.png"]  # no temp file left
    # evaluation points with explicit x; overwrite in place
    plot_learning_curves(
        {"ilpss": curves["ilpss"][:, :6]}, out, title="eval", x=np.arange(100, 700, 100),
        band=False,
    )  # fmt: skip
    assert sorted(p.name for p in out.parent.iterdir()) == ["curves.png"]


def test_many_curves_get_their_legend_below_the_axes_where_it_hides_none(tmp_path):
    from PIL import Image

    rng = np.random.default_rng(0)
    curves = {f"method {i}": rng.normal(0.0, 0.3, size=(3, 40)) for i in range(11)}

    def height(n: int) -> int:
        out = plot_learning_curves(dict(list(curves.items())[:n]), tmp_path / f"{n}.png",
                                   title="t", n_boot=50)
        with Image.open(out) as image:
            return image.size[1]

    few = height(LEGEND_INSIDE_AT_MOST)
    assert height(LEGEND_INSIDE_AT_MOST + 1) > few  # the legend takes rows of its own
    assert height(11) > height(LEGEND_INSIDE_AT_MOST + 1)


def test_a_legend_of_long_method_names_fits_the_figures_width(tmp_path):
    """Names as long as the report's ("fine-tuning chained (from its own latest policy),
    values bounded") in two columns ran off both edges of the figure: the legend goes
    into one column then, and no mark touches the image's left or right edge below the axes."""
    from PIL import Image

    rng = np.random.default_rng(0)
    curves = {f"method {i}, a long description of its settings and of what it reuses (n=30)":
              rng.normal(0.0, 0.3, size=(3, 40)) for i in range(8)}
    out = plot_learning_curves(curves, tmp_path / "long.png", title="t", n_boot=50)
    with Image.open(out) as image:
        pixels = np.asarray(image.convert("L"))
    below = pixels[pixels.shape[0] // 2:]  # the legend's rows
    assert (below[:, :3] > 250).all() and (below[:, -3:] > 250).all()


def test_no_two_of_thirty_curves_share_a_colour_and_a_line_style():
    from ilpss.plots import curve_style

    # the held-out panels drew "C{i}" alone: the 11th method looked like the first
    assert len({curve_style(i) for i in range(30)}) == 30


def test_plot_learning_curves_validation(tmp_path):
    with pytest.raises(ValueError, match="empty"):
        plot_learning_curves({}, tmp_path / "a.png", title="x")
    with pytest.raises(ValueError, match="NaN"):
        plot_learning_curves({"m": np.array([[0.0, np.nan]] * 2)}, tmp_path / "a.png", title="x")
    with pytest.raises(ValueError, match="x for method"):
        plot_learning_curves({"m": np.zeros((2, 5))}, tmp_path / "a.png", title="x", x=[1, 2])
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- seed-level tests
def test_improvement_test_by_hand():
    d = np.array([0.3, 0.1, -0.2, 0.4, 0.0, 0.25, 0.6, 0.05, 0.2, 0.15])
    res = improvement_test(d)
    assert (res.better, res.worse, res.n) == (8, 1, 10)
    assert res.probability == pytest.approx((8 + 0.5) / 10)  # the tie counts one half
    assert res.sign_p == pytest.approx(stats.binomtest(8, 9).pvalue)  # tie dropped
    assert res.wilcoxon_p == pytest.approx(stats.wilcoxon(d[d != 0]).pvalue)
    none = improvement_test(np.zeros(4))
    assert none.probability == 0.5 and math.isnan(none.sign_p) and math.isnan(none.wilcoxon_p)


def test_trend_slopes_with_seeds_as_clusters():
    x = np.arange(1, 20, dtype=float)
    rng = np.random.default_rng(0)
    slopes = rng.normal(0.02, 0.01, size=10)
    values = 0.1 + slopes[:, None] * x[None, :] + rng.normal(0, 0.05, size=(10, 19))
    fitted = trend_slopes(values, x)
    # each row's least-squares slope, and their mean is the pooled slope
    for row, slope in zip(values, fitted, strict=True):
        assert slope == pytest.approx(np.polyfit(x, row, 1)[0])
    pooled = np.polyfit(np.tile(x, 10), values.ravel(), 1)[0]
    assert fitted.mean() == pytest.approx(pooled)
    # a flat stream with large per-task noise: the trend's t interval contains 0
    flat = rng.normal(0.3, 0.2, size=(10, 19))
    _, low, high = t_interval(trend_slopes(flat, x))
    assert low < 0 < high
    with pytest.raises(ValueError, match="constant"):
        trend_slopes(values, np.ones(19))
    with pytest.raises(ValueError, match="positions"):
        trend_slopes(values, x[:-1])


def test_plot_score_profiles_writes_png(tmp_path):
    rng = np.random.default_rng(0)
    scores = {"jumpstart": {"a": rng.normal(0.2, 0.1, 80), "b": rng.normal(0, 0.1, 80)},
              "total-reward gain": {"a": rng.normal(5, 10, 80)}}
    out = plot_score_profiles(scores, tmp_path / "p" / "profiles.png", title="t")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in out.parent.iterdir()) == ["profiles.png"]
    with pytest.raises(ValueError, match="at least one"):
        plot_score_profiles({"jumpstart": {}}, tmp_path / "x.png", title="t")
    with pytest.raises(ValueError, match="finite"):
        plot_score_profiles({"j": {"a": [0.0, np.nan]}}, tmp_path / "x.png", title="t")
    assert not (tmp_path / "x.png").exists()


def test_many_score_profiles_share_one_legend_below_the_panels(tmp_path):
    """Fourteen methods' legends drawn inside each panel covered the curves and ran off the
    figure's right edge: one legend now sits below both panels, inside the figure."""
    from PIL import Image

    rng = np.random.default_rng(0)
    names = [f"method {i}, with a description as long as the report's (fine-tuned start)"
             for i in range(14)]
    scores = {panel: {n: rng.normal(0, 1, 80) for n in names}
              for panel in ("jumpstart", "total-reward gain")}
    out = plot_score_profiles(scores, tmp_path / "profiles.png", title="t")
    with Image.open(out) as image:
        pixels = np.asarray(image.convert("L"))
    assert (pixels[:, :3] > 250).all() and (pixels[:, -3:] > 250).all()
    few = plot_score_profiles({p: dict(list(v.items())[:2]) for p, v in scores.items()},
                              tmp_path / "few.png", title="t")
    with Image.open(few) as image:
        assert pixels.shape[0] > image.size[1]  # the legend takes rows of its own


def _dip_by_loops(curve, window):
    means = [np.mean(curve[t - window + 1:t + 1]) for t in range(window - 1, len(curve))]
    return max(max(means[:i + 1]) - m for i, m in enumerate(means))


def test_largest_dip_and_episodes_below_against_plain_loops():
    from ilpss.metrics import episodes_below, largest_dip

    rng = np.random.default_rng(3)
    curves = rng.uniform(-1, 1, size=(5, 40))
    baseline = rng.uniform(-1, 1, size=(5, 40))
    for window in (1, 4, 20):
        assert largest_dip(curves, window) == pytest.approx(
            [_dip_by_loops(c, window) for c in curves])
        below = [sum(np.mean(c[t - window + 1:t + 1]) < np.mean(b[t - window + 1:t + 1]) - 0.05
                     for t in range(window - 1, 40)) for c, b in zip(curves, baseline, strict=True)]
        assert episodes_below(curves, baseline, window).tolist() == below
    rising = np.linspace(-1, 1, 30)
    assert largest_dip(rising[None], 5).tolist() == [0.0]  # never falls
    start_high = np.r_[np.ones(10), -np.ones(10), np.ones(10)]  # a handover that collapses
    assert largest_dip(start_high[None], 5)[0] == pytest.approx(2.0)


def test_time_to_threshold_with_warmup_is_not_floored_by_the_window():
    from ilpss.metrics import threshold_times

    at_once = np.ones((1, 50))
    assert threshold_times(at_once, 0.5, 20)[0].tolist() == [20.0]
    assert threshold_times(at_once, 0.5, 20, warmup=True)[0].tolist() == [1.0]
    late = np.r_[-np.ones(30), np.ones(20)][None]
    assert threshold_times(late, 0.5, 10, warmup=True)[0].tolist() == \
        threshold_times(late, 0.5, 10)[0].tolist() == [38.0]


def test_every_metric_is_one_entry_that_compare_estimates():
    from ilpss.metrics import METRICS

    rng = np.random.default_rng(0)
    est = compare(rng.uniform(-1, 1, (4, 30)), rng.uniform(-1, 1, (4, 30)), first=5, last=5,
                  threshold=0.0, window=5)
    assert list(est) == [m.name for m in METRICS]
    for m in METRICS:
        assert m.kind != "mean" or np.asarray(m.values(_paired(rng))).shape == (4,)
        assert not m.pairwise or m.kind == "mean"


def _paired(rng):
    from ilpss.metrics import Paired

    return Paired(rng.uniform(-1, 1, (4, 30)), rng.uniform(-1, 1, (4, 30)), first=5, last=5,
                  threshold=0.0, window=5)


def test_reported_time_to_threshold_needs_a_full_window_the_warm_start_is_its_own_column():
    """One lucky first episode (1.0, then failures until the method learns) gives time 1
    with the warm start; the reported time needs a whole window at the threshold."""
    lucky = np.array([[1.0, -1, -1, -1, -1, 1, 1, 1, 1, 1]] * 2)
    baseline = np.array([[-1.0, -1, -1, -1, -1, -1, 1, 1, 1, 1]] * 2)
    lucky[1, -1] = baseline[1, -1] = 0.9  # two seeds, not two copies of one
    est = compare(lucky, baseline, first=2, last=2, threshold=0.5, window=3)
    # full windows: transfer at 8 (episodes 6-8), baseline at 9 (7-9)
    assert est["time_to_threshold_ratio"].value == pytest.approx(8 / 9)
    # warm start: transfer at 1 (its first episode alone), baseline at 9
    assert est["time_to_threshold_ratio_warm"].value == pytest.approx(1 / 9)


def test_the_gain_over_the_first_episodes_reads_only_those_episodes():
    """The short-budget endpoints: the total-reward gain over the first 20 and 50
    episodes, paired by seed, whatever follows them."""
    rng = np.random.default_rng(5)
    transfer, baseline = rng.uniform(-1, 1, (4, 80)), rng.uniform(-1, 1, (4, 80))
    est = compare(transfer, baseline, first=5, last=5, threshold=None, window=5)
    later = transfer.copy()
    later[:, 50:] = 1.0  # only episodes after the 50th change
    est_later = compare(later, baseline, first=5, last=5, threshold=None, window=5)
    for k in (20, 50):
        by_hand = (transfer[:, :k].sum(axis=1) - baseline[:, :k].sum(axis=1)).mean()
        assert est[f"total_reward_gain_first_{k}"].value == pytest.approx(by_hand)
        assert est_later[f"total_reward_gain_first_{k}"].value == pytest.approx(by_hand)
    assert est_later["total_reward_gain"].value != pytest.approx(est["total_reward_gain"].value)


@pytest.mark.parametrize(("call", "said"), [
    (lambda: smooth(["0", "1", "2"], 2), "curve holds"),
    (lambda: smooth([[0, 1], [2]], 1), "rows of different lengths"),
    (lambda: largest_dip(["0", "1", "0"], 1), "curves holds"),
    (lambda: largest_dip(3.0, 1), "one curve or rows of curves"),
    (lambda: largest_dip([], 1), "not empty"),
    (lambda: episodes_below([[0, 0, 0]], [[1, 1, 1]], 1, margin=float("nan")), "margin"),
    (lambda: episodes_below([[0, 0, 0]], [[1, 1, 1]], 1, margin="x"), "margin"),
    (lambda: kaplan_meier(["1", "2"], [True, False]), "times holds"),
])
def test_every_metric_checks_its_inputs_as_the_others_do(call, said):
    # before, these parsed text as numbers, passed a NaN margin as no margin, or ended in
    # NumPy's IndexError and "inhomogeneous shape" errors
    with pytest.raises(ValueError, match=said):
        call()
