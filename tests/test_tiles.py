"""Tests of ilpss.tiles: hashless one-dimensional tile coding."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from ilpss.tiles import KEEPAWAY_ALPHA, KEEPAWAY_N_TILINGS, TileCoder

# The drill's 9 features: distances (m), angles (deg), a signed lateral offset (m).
LOW = np.array([0, 0, 0, 0, 0, 0, -17.5, 0, 0], dtype=float)
HIGH = np.array([50, 50, 50, 50, 180, 50, 17.5, 50, 180], dtype=float)
WIDTHS = np.array([3, 3, 3, 3, 10, 3, 3, 3, 10], dtype=float)


def drill_coder() -> TileCoder:
    return TileCoder(LOW, HIGH, WIDTHS, n_tilings=32)


def test_keepaway_defaults_documented() -> None:
    assert KEEPAWAY_N_TILINGS == 32
    assert KEEPAWAY_ALPHA == 0.125
    coder = drill_coder()
    assert coder.n_active == 9 * 32
    # Small and known in advance: no hashing.
    assert coder.n_weights < 10_000


def test_indices_in_range_unique_and_one_per_feature_tiling() -> None:
    coder = drill_coder()
    rng = np.random.default_rng(0)
    X = rng.uniform(LOW - 5, HIGH + 5, size=(500, 9))  # includes out-of-range values
    A = coder.active_batch(X)
    assert A.shape == (500, coder.n_active)
    assert A.min() >= 0 and A.max() < coder.n_weights
    for row in A:
        assert np.unique(row).shape[0] == coder.n_active
    # Tile (f, t) lies in block (f, t): blocks never overlap.
    blocks = A.reshape(500, 9, 32)
    for f in range(9):
        for t in (0, 17, 31):
            lo = coder._base[f, t]
            assert np.all((blocks[:, f, t] >= lo) & (blocks[:, f, t] < lo + coder.n_bins[f]))


def test_batch_matches_single() -> None:
    coder = drill_coder()
    X = np.random.default_rng(1).uniform(LOW, HIGH, size=(50, 9))
    A = coder.active_batch(X)
    for x, a in zip(X, A, strict=True):
        np.testing.assert_array_equal(coder.active(x), a)


def test_offsets_are_width_over_n_tilings() -> None:
    # One feature in [0, 10], width 2, 4 tilings: tiling t's edges sit at 2k - t/2.
    coder = TileCoder([0.0], [10.0], [2.0], n_tilings=4)
    n_bins = coder.n_bins[0]

    def bins(x: float) -> np.ndarray:
        return coder.active([x]) - np.arange(4) * n_bins

    np.testing.assert_array_equal(bins(0.0), [0, 0, 0, 0])
    np.testing.assert_array_equal(bins(0.5), [0, 0, 0, 1])  # tiling 3 shifted by 1.5
    np.testing.assert_array_equal(bins(1.0), [0, 0, 1, 1])
    np.testing.assert_array_equal(bins(1.5), [0, 1, 1, 1])
    np.testing.assert_array_equal(bins(2.0), [1, 1, 1, 1])
    # Generalisation: states closer than width share more tiles.
    a = coder.active([3.0])
    shared = [np.intersect1d(a, coder.active([3.0 + dx])).size for dx in (0.4, 0.9, 1.6, 2.5)]
    assert shared == sorted(shared, reverse=True) and shared[-1] == 0


def test_values_clipped_to_range() -> None:
    coder = drill_coder()
    x = np.array([60, 50, 0, -3, 200, 25, -40, 10, 90.0])
    clipped = np.clip(x, LOW, HIGH)
    np.testing.assert_array_equal(coder.active(x), coder.active(clipped))


def test_float32_observation_accepted() -> None:
    coder = drill_coder()
    x = np.random.default_rng(2).uniform(LOW, HIGH).astype(np.float32)
    np.testing.assert_array_equal(coder.active(x), coder.active(x.astype(np.float64)))


@pytest.mark.parametrize(
    "state",
    [np.zeros(8), np.zeros((1, 9)), np.full(9, np.nan), np.r_[np.zeros(8), np.inf]],
)
def test_bad_states_rejected(state: np.ndarray) -> None:
    coder = drill_coder()
    with pytest.raises(ValueError, match=r"shape|NaN"):
        coder.active(state)


def test_bad_construction_rejected() -> None:
    with pytest.raises(ValueError, match="high"):
        TileCoder([0.0], [0.0], [1.0])
    with pytest.raises(ValueError, match="width"):
        TileCoder([0.0], [1.0], [0.0])
    with pytest.raises(ValueError, match="entries"):
        TileCoder([0.0, 0.0], [1.0], [1.0])
    with pytest.raises(ValueError, match="n_tilings"):
        TileCoder([0.0], [1.0], [1.0], n_tilings=0)
    with pytest.raises(ValueError, match=r"n_tilings must be an integer in \[1, 1,024\]"):
        TileCoder([0.0], [1.0], [1.0], n_tilings=2.0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="finite"):
        TileCoder([0.0], [np.inf], [1.0])


def test_from_space_and_round_trip() -> None:
    space = gym.spaces.Box(LOW.astype(np.float32), HIGH.astype(np.float32))
    coder = TileCoder.from_space(space, WIDTHS)
    assert coder == drill_coder()
    assert hash(coder) == hash(drill_coder())
    again = TileCoder.from_arrays(coder.to_arrays())
    assert again == coder
    with pytest.raises(ValueError, match="finite"):
        TileCoder.from_space(gym.spaces.Box(-np.inf, np.inf, shape=(3,)))
    with pytest.raises(ValueError, match="missing"):
        TileCoder.from_arrays({"tiles_low": LOW})
