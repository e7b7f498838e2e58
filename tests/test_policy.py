"""Tests of ilpss.policy: linear action values, greedy choice, freezing, save/load."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pytest

from ilpss.policy import FrozenPolicy, LinearPolicy, greedy_choice
from ilpss.tiles import TileCoder


def coder() -> TileCoder:
    return TileCoder([0.0, -1.0], [10.0, 1.0], [1.0, 0.5], n_tilings=8)


def trained_policy(seed: int = 0, option_ids: tuple[int, ...] = (7, 3)) -> LinearPolicy:
    c = coder()
    rng = np.random.default_rng(seed)
    return LinearPolicy(
        c, 3, option_ids, weights=rng.normal(size=(3 + len(option_ids), c.n_weights))
    )


def test_shapes_and_choice_mapping() -> None:
    pol = trained_policy()
    assert pol.weights.shape == (5, pol.tile_coder.n_weights)
    assert pol.n_choices == 5
    assert not pol.is_option(2) and pol.is_option(3)
    assert pol.option_id(3) == 7 and pol.option_id(4) == 3
    assert pol.choice_of_option(3) == 4
    with pytest.raises(KeyError, match="unknown option id 99"):
        pol.choice_of_option(99)
    with pytest.raises(ValueError, match="primitive"):
        pol.option_id(0)
    with pytest.raises(ValueError, match="out of range"):
        pol.is_option(5)


def test_q_values_are_sums_of_active_weights() -> None:
    pol = trained_policy()
    s = np.array([3.3, 0.2])
    a = pol.tile_coder.active(s)
    np.testing.assert_allclose(pol.q_values(s), pol.weights[:, a].sum(axis=1))


@pytest.mark.parametrize("n_tilings", [1, 7, 8, 9, 16, 32])
@pytest.mark.parametrize("n_choices", [1, 3, 4, 40, 183])
def test_q_values_are_numpys_row_sums_bit_for_bit(n_tilings: int, n_choices: int) -> None:
    """Whatever the storage, every value is the sum NumPy gives for the choice's row of
    weights at the active tiles, to the last bit, for every choice or a subset."""
    c = TileCoder([0.0] * 9, [10.0] * 9, [0.7] * 9, n_tilings=n_tilings)
    rng = np.random.default_rng(n_tilings * 1000 + n_choices)
    weights = rng.normal(size=(n_choices, c.n_weights)) * rng.choice([1e-3, 1.0, 1e3], n_choices)[:, None]
    pol = LinearPolicy(c, 1, tuple(range(n_choices - 1)), weights=weights)
    frozen = pol.freeze()
    for _ in range(20):
        a = c.active(rng.uniform(-1.0, 11.0, 9))
        expected = np.take(weights, a, axis=1).sum(axis=1)
        subset = np.flatnonzero(rng.random(n_choices) < 0.3)
        few = rng.choice(n_choices, max(1, n_choices // 8), replace=False)  # any order
        for policy in (pol, frozen):
            assert policy.q_from_tiles(a).tobytes() == expected.tobytes()
            assert policy.q_from_tiles(a, subset).tobytes() == expected[subset].tobytes()
            assert policy.q_from_tiles(a, few).tobytes() == expected[few].tobytes()
        assert [pol.value(a, k) for k in range(n_choices)] == expected.tolist()


def near_tie_weights(n_choices: int, n_weights: int, seed: int) -> np.ndarray:
    """Weights whose choices tie exactly (copies) or nearly (a few ulps apart at many
    tiles, so that sums in another order often rank them the other way) at every
    state, or are clearly worse, at magnitudes from 1e-3 to 1e3."""
    rng = np.random.default_rng(seed)
    base = rng.normal(size=n_weights) * rng.choice([1e-3, 1.0, 1e3])
    rows = [base]
    for _ in range(n_choices - 1):
        kind = rng.integers(3)
        if kind == 0:  # an exact copy of an earlier choice
            rows.append(rows[rng.integers(len(rows))].copy())
        elif kind == 1:  # base, a few ulps off at a third of the tiles
            ulps = rng.integers(-3, 4, n_weights) * (rng.random(n_weights) < 0.3)
            rows.append(base + ulps * np.spacing(base))
        else:  # clearly worse
            rows.append(base - abs(rng.normal(size=n_weights)) * abs(base).mean())
    return np.array(rows)


@pytest.mark.parametrize("frozen", [False, True])
@pytest.mark.parametrize("n_choices", [1, 3, 4, 40, 183])
def test_greedy_from_tiles_is_the_greedy_choice_of_the_values(frozen: bool, n_choices: int) -> None:
    """The same choice and the same draws from the generator as ``greedy_choice`` of
    every value, with exact and near ties, of every choice or of the primitives."""
    c = TileCoder([0.0] * 9, [10.0] * 9, [0.7] * 9, n_tilings=32)
    weights = near_tie_weights(n_choices, c.n_weights, n_choices)
    n_primitive = min(3, n_choices)
    pol = LinearPolicy(c, n_primitive, tuple(range(n_choices - n_primitive)), weights=weights)
    policy = pol.freeze() if frozen else pol
    rng = np.random.default_rng(1)
    ties = 0
    for t in range(300):
        a = c.active(rng.uniform(-1.0, 11.0, 9))
        for primitive_only in (False, True):
            q = policy.q_from_tiles(a)[: n_primitive if primitive_only else None]
            expected_rng, got_rng = np.random.default_rng(t), np.random.default_rng(t)
            expected = greedy_choice(q, expected_rng)
            got = policy.greedy_from_tiles(a, got_rng, primitive_only=primitive_only)
            assert got == expected, (t, primitive_only)
            assert got_rng.random() == expected_rng.random()  # the same draws
            ties += int((q == q.max()).sum() > 1)
    assert n_choices < 4 or ties > 0


def test_greedy_from_tiles_sums_exactly_when_sums_may_overflow() -> None:
    c = TileCoder([0.0], [10.0], [1.0], n_tilings=4)
    weights = np.array([[1e308] * c.n_weights, [-1e308] * c.n_weights, [1e308] * c.n_weights])
    policy = FrozenPolicy(c, 3, (), weights)
    with np.errstate(over="ignore"):
        q = policy.q_from_tiles(c.active([5.0]))
        assert np.isinf(q).all()
        expected = greedy_choice(q, np.random.default_rng(0))
        assert policy.greedy_from_tiles(c.active([5.0]), np.random.default_rng(0)) == expected


def test_weights_can_be_replaced_in_place() -> None:
    pol = trained_policy()
    w = np.arange(pol.weights.size, dtype=float).reshape(pol.weights.shape)
    pol.weights = w
    np.testing.assert_array_equal(pol.weights, w)
    w[0, 0] = -1.0  # a copy was taken
    assert pol.weights[0, 0] == 0.0
    with pytest.raises(ValueError, match="shape"):
        pol.weights = w[1:]


def test_initial_value() -> None:
    pol = LinearPolicy(coder(), 3, initial_value=0.7)
    np.testing.assert_allclose(pol.q_values(np.array([5.0, 0.0])), 0.7)


def test_greedy_ties_broken_by_seeded_generator() -> None:
    q = np.array([1.0, 3.0, 3.0, 0.0, 3.0])
    picks = [greedy_choice(q, np.random.default_rng(s)) for s in range(300)]
    assert set(picks) == {1, 2, 4}
    counts = np.bincount(picks, minlength=5)[[1, 2, 4]]
    assert counts.min() > 70  # roughly uniform over the ties
    again = [greedy_choice(q, np.random.default_rng(s)) for s in range(300)]
    assert picks == again
    # No tie: no random draw at all.
    rng = np.random.default_rng(0)
    state = rng.bit_generator.state
    assert greedy_choice(np.array([0.0, 2.0, 1.0]), rng) == 1
    assert rng.bit_generator.state == state


def test_greedy_with_mask_and_primitive_only() -> None:
    pol = trained_policy()
    s = np.array([4.0, 0.5])
    q = pol.q_values(s)
    rng = np.random.default_rng(0)
    assert pol.greedy(s, rng) == int(q.argmax())
    mask = np.array([True, False, True, False, False])
    assert pol.greedy(s, rng, mask) == [0, 2][int(q[[0, 2]].argmax())]
    assert pol.greedy(s, rng, primitive_only=True) == int(q[:3].argmax())
    with pytest.raises(ValueError, match="no choice"):
        greedy_choice(q, rng, np.zeros(5, dtype=bool))
    with pytest.raises(ValueError, match="mask"):
        pol.greedy(s, rng, np.ones(3, dtype=bool))


def test_epsilon_greedy_frequencies() -> None:
    pol = trained_policy()
    s = np.array([4.0, 0.5])
    best = int(pol.q_values(s).argmax())
    rng = np.random.default_rng(1)
    n = 4000
    picks = np.array([pol.epsilon_greedy(s, rng, 0.2) for _ in range(n)])
    # P(best) = 0.8 + 0.2 / 5 = 0.84.
    assert abs((picks == best).mean() - 0.84) < 0.03
    with pytest.raises(ValueError, match="epsilon"):
        pol.epsilon_greedy(s, rng, 1.5)


def test_freeze_is_an_immutable_copy() -> None:
    pol = trained_policy()
    frozen = pol.freeze()
    assert isinstance(frozen, FrozenPolicy)
    before = frozen.weights.copy()
    pol.update(pol.tile_coder.active(np.array([1.0, 0.0])), 0, 5.0)
    np.testing.assert_array_equal(frozen.weights, before)
    with pytest.raises(ValueError, match="read-only"):
        frozen.weights[0, 0] = 1.0
    with pytest.raises(AttributeError, match="immutable"):
        frozen.weights = np.zeros_like(before)  # type: ignore[misc]
    with pytest.raises(AttributeError, match="immutable"):
        frozen.option_ids = ()  # type: ignore[misc]
    assert frozen.freeze() is frozen
    thawed = frozen.thaw()
    thawed.update(thawed.tile_coder.active(np.array([1.0, 0.0])), 0, 1.0)
    np.testing.assert_array_equal(frozen.weights, before)


@pytest.mark.parametrize("cls", [FrozenPolicy, LinearPolicy])
def test_save_load_round_trip_acts_identically(tmp_path: Path, cls: type) -> None:
    pol = trained_policy(3).freeze()
    # Force ties in some states so that tie-breaking is exercised too.
    w = pol.weights.copy()
    w[1] = w[0]
    pol = FrozenPolicy(pol.tile_coder, 3, pol.option_ids, w)
    path = tmp_path / "pol.npz"
    pol.save(path)
    loaded = cls.load(path)
    assert isinstance(loaded, cls)
    assert loaded.option_ids == pol.option_ids and loaded.n_primitive == 3
    assert loaded.tile_coder == pol.tile_coder
    np.testing.assert_array_equal(loaded.weights, pol.weights)
    states = np.random.default_rng(0).uniform([0, -1], [10, 1], size=(300, 2))
    r1, r2 = np.random.default_rng(9), np.random.default_rng(9)
    a1 = [pol.greedy(s, r1) for s in states]
    a2 = [loaded.greedy(s, r2) for s in states]
    assert a1 == a2


def test_wrong_shapes_and_ids_rejected() -> None:
    c = coder()
    with pytest.raises(ValueError, match="shape"):
        LinearPolicy(c, 3, (), weights=np.zeros((4, c.n_weights)))
    with pytest.raises(ValueError, match="NaN"):
        LinearPolicy(c, 3, (), weights=np.full((3, c.n_weights), np.nan))
    with pytest.raises(ValueError, match="unique"):
        LinearPolicy(c, 3, (1, 1))
    with pytest.raises(ValueError, match="non-negative"):
        LinearPolicy(c, 3, (-1,))
    with pytest.raises(ValueError, match="n_primitive"):
        LinearPolicy(c, 0)
    with pytest.raises(TypeError, match="TileCoder"):
        LinearPolicy("coder", 3)  # type: ignore[arg-type]
    pol = LinearPolicy(c, 3)
    with pytest.raises(ValueError, match="shape"):
        pol.q_values(np.zeros(3))
    with pytest.raises(ValueError, match="NaN"):
        pol.q_values(np.array([np.nan, 0.0]))


def test_tampered_and_foreign_files_rejected(tmp_path: Path) -> None:
    pol = trained_policy().freeze()
    path = tmp_path / "pol.npz"
    pol.save(path)
    data = path.read_bytes()

    # Truncated file.
    bad = tmp_path / "truncated.npz"
    bad.write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match=r"truncated|readable"):
        FrozenPolicy.load(bad)

    # Weights modified after saving (rewrite one member, keep the JSON record).
    tampered = tmp_path / "tampered.npz"
    with zipfile.ZipFile(path) as zin, zipfile.ZipFile(tampered, "w") as zout:
        for item in zin.infolist():
            content = zin.read(item.filename)
            if item.filename == "weights.npy":
                arr = np.load(path)["weights"].copy()
                arr[0, 0] += 1.0
                import io

                buf = io.BytesIO()
                np.save(buf, arr)
                content = buf.getvalue()
            zout.writestr(item, content)
    with pytest.raises(ValueError, match="checksum"):
        FrozenPolicy.load(tampered)

    # A pickle-bearing npz written by someone else.
    evil = tmp_path / "evil.npz"
    np.savez(evil, weights=np.array([object()], dtype=object))
    with pytest.raises(ValueError):
        FrozenPolicy.load(evil)

    # Another schema.
    from ilpss._io import save_npz_atomic

    other = tmp_path / "other.npz"
    save_npz_atomic(other, {"x": np.zeros(2)}, {"schema": "ilpss.kernels/1"})
    with pytest.raises(ValueError, match="schema"):
        FrozenPolicy.load(other)

    with pytest.raises(FileNotFoundError):
        FrozenPolicy.load(tmp_path / "missing.npz")
