"""Tests of ilpss.metrics (transfer metrics, bootstrap intervals) and ilpss.plots."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ilpss.metrics import (
    MetricEstimate,
    area_above_floor,
    asymptotic_gain,
    asymptotic_performance,
    compare,
    format_metrics_markdown,
    jumpstart,
    mean_curve_band,
    smooth,
    time_to_threshold,
    time_to_threshold_ratio,
    total_reward,
    total_reward_gain,
    transfer_ratio,
    wilson_interval,
)
from ilpss.plots import plot_learning_curves

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
    est = compare(t, b, first=2, last=3, threshold=0.5, window=2, n_boot=500)
    assert est["jumpstart"].value == pytest.approx((1.0 + 0.5) / 2)
    assert est["asymptotic_transfer"].value == pytest.approx((1.0 + 0.0) / 2)
    assert est["asymptotic_baseline"].value == pytest.approx((1 / 3 - 0.5) / 2)
    assert est["asymptotic_gain"].value == pytest.approx((2 / 3 + 0.5) / 2)
    assert est["total_reward_transfer"].value == pytest.approx(2.0)
    assert est["total_reward_baseline"].value == pytest.approx((-0.5 - 3.0) / 2)
    assert est["total_reward_gain"].value == pytest.approx((4.5 + 3.0) / 2)
    # ratio of mean areas: ((10 + 6) / 2) / ((5.5 + 3) / 2), not the mean of ratios
    assert est["transfer_ratio"].value == pytest.approx(16 / 8.5)
    # seed-mean curves: transfer (0, .25, .25, .5, .5, .5), baseline (-.75, -.5, -.25, ...)
    assert est["time_to_threshold_transfer"].value == 5  # window (.25+.5)/2, (.5+.5)/2
    assert est["time_to_threshold_baseline"].value == math.inf
    assert est["time_to_threshold_ratio"].value == 0.0
    assert est["threshold_reached_transfer"].value == 0.5
    assert est["threshold_reached_baseline"].value == 0.5  # B alone ends with (.5 + .5) / 2
    for e in est.values():
        assert isinstance(e, MetricEstimate)
        assert e.n == 2
        assert e.definition
        assert e.low <= e.high
    # resamples drawing seed 1 twice: neither mean curve reaches 0.5 -> ratio undefined,
    # counted as 0 (lower) and inf (upper)
    ratio = est["time_to_threshold_ratio"]
    assert (ratio.low, ratio.high) == (0.0, math.inf)


def test_compare_transfer_ratio_nan_when_baseline_area_zero():
    t = np.stack([T, T])
    b = np.full((2, 6), -1.0)
    est = compare(t, b, first=1, last=1, threshold=None, window=1, n_boot=200)
    assert math.isnan(est["transfer_ratio"].value)
    assert math.isnan(est["transfer_ratio"].low)
    assert "time_to_threshold_ratio" not in est


def test_compare_threshold_never_reached_intervals():
    rng = np.random.default_rng(1)
    t = np.clip(0.8 + 0.05 * rng.standard_normal((10, 20)), -1, 1)
    b = np.clip(-0.5 + 0.05 * rng.standard_normal((10, 20)), -1, 1)
    est = compare(t, b, first=2, last=5, threshold=0.5, window=3, n_boot=1000)
    assert est["time_to_threshold_transfer"].value == 3
    assert est["time_to_threshold_baseline"].value == math.inf
    assert (est["time_to_threshold_baseline"].low, est["time_to_threshold_baseline"].high) == (
        math.inf,
        math.inf,
    )
    ratio = est["time_to_threshold_ratio"]
    assert (ratio.value, ratio.low, ratio.high) == (0.0, 0.0, 0.0)
    assert est["threshold_reached_transfer"].value == 1.0
    assert est["threshold_reached_transfer"].high == 1.0


def test_paired_bootstrap_keeps_pairs():
    rng = np.random.default_rng(7)
    n_seeds, n_eps = 30, 40
    level = rng.uniform(-0.8, 0.6, size=(n_seeds, 1))  # huge between-seed variance
    baseline = np.clip(level + 0.1 * rng.standard_normal((n_seeds, n_eps)), -0.95, 0.85)
    transfer = baseline + 0.1
    est = compare(transfer, baseline, first=5, last=5, threshold=None, window=1, n_boot=2000)
    for key, expected in (("jumpstart", 0.1), ("asymptotic_gain", 0.1), ("total_reward_gain", 4)):
        e = est[key]
        assert e.value == pytest.approx(expected)
        assert e.low == pytest.approx(expected, abs=1e-9)
        assert e.high == pytest.approx(expected, abs=1e-9)
    # the check has teeth: breaking the pairing widens the interval enormously
    broken = compare(
        transfer, baseline[rng.permutation(n_seeds)], first=5, last=5, threshold=None,
        window=1, n_boot=2000,
    )  # fmt: skip
    assert broken["jumpstart"].high - broken["jumpstart"].low > 0.2


def test_compare_is_deterministic():
    rng = np.random.default_rng(3)
    t = rng.uniform(-1, 1, size=(8, 30))
    b = rng.uniform(-1, 1, size=(8, 30))
    kw = dict(first=5, last=5, threshold=0.0, window=5, n_boot=500)
    a1, a2 = compare(t, b, seed=11, **kw), compare(t, b, seed=11, **kw)
    assert a1 == a2
    a3 = compare(t, b, seed=12, **kw)
    assert a3["jumpstart"].value == a1["jumpstart"].value
    assert (a3["jumpstart"].low, a3["jumpstart"].high) != (
        a1["jumpstart"].low,
        a1["jumpstart"].high,
    )


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
    with pytest.raises(ValueError, match="first"):
        compare(good, good, **{**kw, "first": 7})
    with pytest.raises(ValueError, match="floor"):
        compare(good - 2.0, good, **kw)
    with pytest.raises(ValueError, match="confidence"):
        compare(good, good, **{**kw, "confidence": 1.0})


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


def test_compare_jumpstart_coverage():
    rng = np.random.default_rng(99)
    hits = 0
    reps = 200
    for _ in range(reps):
        level = rng.uniform(-0.5, 0.3, size=(20, 1))
        baseline = level + 0.1 * rng.standard_normal((20, 10))
        transfer = baseline + 0.2 + 0.3 * rng.standard_normal((20, 1))  # true jumpstart 0.2
        e = compare(
            transfer, baseline, first=3, last=3, threshold=None, window=1, floor=-3.0,
            n_boot=1000, seed=int(rng.integers(1 << 30)),
        )["jumpstart"]  # fmt: skip
        hits += e.low <= 0.2 <= e.high
    assert 0.9 <= hits / reps <= 0.99, hits / reps


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
        "jumpstart": MetricEstimate("jumpstart", 0.25, 0.1, 0.4, 30, "a | b"),
        "transfer_ratio": MetricEstimate("transfer_ratio", math.nan, math.nan, math.nan, 30, "r"),
        "time": MetricEstimate("time", 12.0, 10.0, math.inf, 30, "t"),
    }
    md = format_metrics_markdown(est)
    lines = md.strip().split("\n")
    assert lines[0] == "| metric | value | 95% CI | n | definition |"
    assert len(lines) == 2 + 3
    assert lines[2] == "| jumpstart | 0.25 | [0.1, 0.4] | 30 | a \\| b |"
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


def test_plot_learning_curves_validation(tmp_path):
    with pytest.raises(ValueError, match="empty"):
        plot_learning_curves({}, tmp_path / "a.png", title="x")
    with pytest.raises(ValueError, match="NaN"):
        plot_learning_curves({"m": np.array([[0.0, np.nan]] * 2)}, tmp_path / "a.png", title="x")
    with pytest.raises(ValueError, match="x for method"):
        plot_learning_curves({"m": np.zeros((2, 5))}, tmp_path / "a.png", title="x", x=[1, 2])
    assert list(tmp_path.iterdir()) == []
