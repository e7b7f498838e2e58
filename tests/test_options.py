"""Tests of ilpss.options: option semantics, discounting, pruning, refits, persistence."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from synthetic_smdp import (
    FunctionKernels,
    IntervalKernels,
    binomial_ok,
    constant_kernels,
    constant_policy,
)

from ilpss.kernels import bhattacharyya_distance, kernel_distances, match_kernels
from ilpss.options import OptionLibrary, OptionSettings
from ilpss.tiles import TileCoder


# --------------------------------------------------------------------------- building
def test_build_k_by_n_options() -> None:
    model = IntervalKernels([(0, 3), (3, 6)])
    lib = OptionLibrary(model, [constant_policy(0), constant_policy(1), constant_policy(2)])
    assert len(lib) == 6
    np.testing.assert_array_equal(lib.option_ids, np.arange(6))
    infos = lib.options()
    assert [(o.kernel_id, o.policy_id) for o in infos] == [
        (0, 0),
        (0, 1),
        (0, 2),
        (1, 0),
        (1, 1),
        (1, 2),
    ]
    assert all(o.scale == 1.0 and o.uses == 0 for o in infos)
    assert 3 in lib and 6 not in lib
    assert "n_options=6" in repr(lib)


def test_build_rejects_bad_inputs() -> None:
    model = IntervalKernels([(0, 3)])
    with pytest.raises(ValueError, match="unknown option id"):
        OptionLibrary(model, [constant_policy(0, option_ids=(4,))])
    with pytest.raises(TypeError, match="FrozenPolicy"):
        OptionLibrary(model, [constant_policy(0).thaw()])  # type: ignore[list-item]
    with pytest.raises(ValueError, match="primitive"):
        OptionLibrary(model, [constant_policy(0), constant_policy(0, n_primitive=4)])
    with pytest.raises(ValueError, match="features"):
        OptionLibrary(IntervalKernels([(0, 3)], n_features=2), [constant_policy(0)])
    with pytest.raises(ValueError, match="discount"):
        OptionLibrary(model, [constant_policy(0)], OptionSettings(discount=1.5))
    with pytest.raises(ValueError, match="max_depth"):
        OptionLibrary(model, [constant_policy(0)], OptionSettings(max_depth=0))
    bad = IntervalKernels([(0, 3)])
    bad.means_ = np.zeros((2, 1))
    with pytest.raises(ValueError, match=r"means_|n_components"):
        OptionLibrary(bad, [constant_policy(0)])


def test_membership_shapes_and_state_checks() -> None:
    funcs = [lambda x: 0.25, lambda x: 0.75]
    means, covs = np.zeros((2, 1)), np.ones((2, 1, 1))
    for return_2d in (False, True):
        lib = OptionLibrary(FunctionKernels(funcs, means, covs, return_2d), [constant_policy(0)])
        np.testing.assert_allclose(lib.membership(np.array([1.0])), [0.25, 0.75])
    with pytest.raises(ValueError, match="NaN"):
        lib.membership(np.array([np.nan]))
    with pytest.raises(ValueError, match="shape"):
        lib.membership(np.array([1.0, 2.0]))
    broken = FunctionKernels([lambda x: np.nan, lambda x: 0.5], means, covs)
    with pytest.raises(ValueError, match="NaN"):
        OptionLibrary(broken, [constant_policy(0)]).membership(np.array([1.0]))
    wrong = FunctionKernels(funcs, means, covs)
    wrong.membership = lambda X: np.zeros(3)  # type: ignore[method-assign]
    with pytest.raises(ValueError, match="expected 2"):
        OptionLibrary(wrong, [constant_policy(0)]).membership(np.array([1.0]))


def test_membership_is_the_models_clipped_bit_for_bit() -> None:
    """In range (signed zeros included) the model's values as they come, else clipped."""
    values = [[0.0, -0.0, 1.0, 0.3], [-0.0, 0.5, 0.5, 1e-300], [1.5, -0.2, 0.4, -0.0],
              [-1e-300, 0.1, 1.0 + 1e-16, 0.9]]
    means, covs = np.zeros((4, 1)), np.ones((4, 1, 1))
    for row in values:
        model = FunctionKernels([lambda x, v=v: v for v in row], means, covs)
        lib = OptionLibrary(model, [constant_policy(0)])
        got = lib.membership(np.array([1.0]))
        assert got.tobytes() == np.clip(np.array(row), 0.0, 1.0).tobytes()
        got[0] = 0.7  # a copy: the next call is unchanged
        assert lib.membership(np.array([1.0])).tobytes() == np.clip(row, 0.0, 1.0).tobytes()


@pytest.mark.parametrize("exponent", [1.0, 0.0, 0.5, 2.0, 1.7])
def test_continuation_of_one_option_is_its_entry_of_every_option(exponent: float) -> None:
    rng = np.random.default_rng(int(exponent * 10))
    model = FunctionKernels([lambda x, k=k: (np.sin(x[0] * (k + 1)) + 1) / 2 for k in range(3)],
                            np.zeros((3, 1)), np.ones((3, 1, 1)))
    lib = OptionLibrary(model, [constant_policy(0), constant_policy(1)],
                        OptionSettings(continuation_exponent=exponent))
    for x in rng.uniform(0.0, 9.0, 50):
        m = lib.membership(np.array([x]))
        every = lib.continuation_probabilities(m)
        for j, oid in enumerate(lib.option_ids):
            assert lib.continuation_probability(int(oid), np.array([x]), m) == every[j]
            assert lib.continuation_probability(int(oid), np.array([x])) == every[j]


# --------------------------------------------------------------------------- semantics
def test_initiation_frequency_matches_scale_times_membership() -> None:
    model = constant_kernels([0.3, 0.8])
    lib = OptionLibrary(model, [constant_policy(0)], OptionSettings(discount=0.5, prune_threshold=0.1))
    # Discount option 1 (kernel 1) once: c = 0.5.
    lib.end_trial(used=[0])
    assert lib.scale(0) == 1.0 and lib.scale(1) == 0.5
    rng = np.random.default_rng(0)
    n = 20_000
    s = np.array([4.0])
    hits = np.zeros(2, dtype=int)
    for _ in range(n):
        hits += lib.available(s, rng)
    assert binomial_ok(hits[0], n, 0.3)
    assert binomial_ok(hits[1], n, 0.5 * 0.8)
    np.testing.assert_allclose(lib.initiation_probabilities(s), [0.3, 0.4])


def test_initiation_follows_state_dependent_membership() -> None:
    model = FunctionKernels([lambda x: x[0] / 9.0], np.zeros((1, 1)), np.ones((1, 1, 1)))
    lib = OptionLibrary(model, [constant_policy(0)])
    rng = np.random.default_rng(1)
    n = 8000
    for x in (0.9, 4.5, 8.1):
        hits = sum(bool(lib.available(np.array([x]), rng)[0]) for _ in range(n))
        assert binomial_ok(hits, n, x / 9.0)


def test_continuation_frequency_matches_membership_without_scale() -> None:
    model = constant_kernels([0.6])
    lib = OptionLibrary(model, [constant_policy(0)], OptionSettings(discount=0.5))
    lib.end_trial(used=[])  # scale 0.5 must not affect continuation
    assert lib.scale(0) == 0.5
    rng = np.random.default_rng(2)
    n = 20_000
    hits = sum(lib.continues(0, np.array([1.0]), rng) for _ in range(n))
    assert binomial_ok(hits, n, 0.6)
    assert lib.continuation_probability(0, np.array([1.0])) == 0.6


@pytest.mark.parametrize("exponent", [0.0, 0.5, 2.0])
def test_continuation_exponent_scales_the_stopping_rule(exponent: float, tmp_path) -> None:
    lib = OptionLibrary(constant_kernels([0.6]), [constant_policy(0)], OptionSettings(continuation_exponent=exponent))
    rng = np.random.default_rng(3)
    n = 20_000
    hits = sum(lib.continues(0, np.array([1.0]), rng) for _ in range(n))
    if exponent == 0.0:
        assert hits == n  # runs until the episode ends
    else:
        assert binomial_ok(hits, n, 0.6**exponent)
    # initiation does not change, and the exponent survives a refit and a save/load
    np.testing.assert_allclose(lib.initiation_probabilities(np.array([1.0])), [0.6])
    assert lib.refit(constant_kernels([0.6]), []).settings.continuation_exponent == exponent
    saved = OptionLibrary(IntervalKernels([(0, 9)]), [constant_policy(0)], OptionSettings(continuation_exponent=exponent))
    saved.save(tmp_path / "lib")
    again = OptionLibrary.load(tmp_path / "lib", kernel_loader=IntervalKernels.load)
    assert again.settings.continuation_exponent == exponent


def test_negative_continuation_exponent_is_refused() -> None:
    with pytest.raises(ValueError, match="continuation_exponent"):
        OptionLibrary(constant_kernels([0.6]), [constant_policy(0)], OptionSettings(continuation_exponent=-1))


def test_option_acts_greedily_with_its_policy() -> None:
    model = IntervalKernels([(0, 9)])
    lib = OptionLibrary(model, [constant_policy(2), constant_policy(1)])
    rng = np.random.default_rng(0)
    assert lib.act(0, np.array([2.0]), rng) == 2
    assert lib.act(1, np.array([2.0]), rng) == 1
    assert lib.resolve(1, np.array([2.0]), rng) == (1, (1,))


def test_nested_pointers_execute_the_pointed_policy() -> None:
    model = IntervalKernels([(0, 9)])
    pi0 = constant_policy(2)  # takes action 2
    lib0 = OptionLibrary(model, [pi0])
    assert list(lib0.option_ids) == [0]  # option 0 = <K_0, K_0, pi_0>
    # pi_1 was learnt with option 0 and prefers it (choice 3) everywhere; its best
    # primitive is 0, so following the pointer is visible (2, not 0).
    pi1 = constant_policy(0, option_ids=(0,), prefer=3)
    lib1 = lib0.refit(model, [pi1])
    assert list(lib1.option_ids) == [0, 1]
    assert lib1.registry[1] == (0, 1)
    rng = np.random.default_rng(0)
    action, path = lib1.resolve(1, np.array([5.0]), rng)
    assert (action, path) == (2, (1, 0))


def test_depth_is_bounded() -> None:
    model = IntervalKernels([(0, 9)])
    lib = OptionLibrary(model, [constant_policy(2)], OptionSettings(max_depth=4))
    # A chain: pi_i (i >= 1) prefers the option of pi_{i-1}; its best primitive is 1.
    for i in range(1, 7):
        prev_option = int(lib.option_ids[-1])
        pol = constant_policy(1, option_ids=(prev_option,), prefer=3)
        lib = lib.refit(model, [pol])
        assert lib.registry[int(lib.option_ids[-1])] == (0, i)
    rng = np.random.default_rng(0)
    s = np.array([5.0])
    # From pi_6: pi_6 -> pi_5 -> pi_4 -> pi_3, where the bound forces a primitive (1).
    action, path = lib.resolve(int(lib.option_ids[-1]), s, rng)
    assert path == (6, 5, 4, 3) and action == 1
    # From pi_3 the chain reaches pi_0 within the bound, which takes 2.
    action, path = lib.resolve(int(lib.option_ids[3]), s, rng)
    assert path == (3, 2, 1, 0) and action == 2
    # max_depth = 1: the option's own policy, best primitive.
    shallow = OptionLibrary(model, [constant_policy(2)], OptionSettings(max_depth=1))
    assert shallow.resolve(0, s, rng) == (2, (0,))


def test_unknown_option_ids_give_clear_errors() -> None:
    lib = OptionLibrary(IntervalKernels([(0, 9)]), [constant_policy(0)])
    rng = np.random.default_rng(0)
    with pytest.raises(KeyError, match="unknown option id 42"):
        lib.act(42, np.array([1.0]), rng)
    with pytest.raises(KeyError, match="unknown option id"):
        lib.continues(42, np.array([1.0]), rng)
    with pytest.raises(KeyError, match="unknown option id"):
        lib.end_trial(used=[42])
    with pytest.raises(KeyError, match="unknown option id"):
        lib.record_use(42)


# --------------------------------------------------------------- discounting/pruning
def test_discounting_and_pruning_rule() -> None:
    model = IntervalKernels([(0, 3), (3, 6)])
    lib = OptionLibrary(model, [constant_policy(0)], OptionSettings(discount=0.5, prune_threshold=0.1))
    # Trial 1: option 0 used, option 1 not -> 0.5.
    rep = lib.end_trial(used=[0])
    assert rep.discounted == (1,) and rep.pruned == ()
    assert lib.scale(1) == 0.5
    # Trials 2 and 3: neither used -> option 1: 0.25, 0.125; option 0: 0.5, 0.25.
    lib.end_trial(used=[])
    rep = lib.end_trial(used=[])
    assert rep.pruned == ()
    assert lib.scale(0) == 0.25 and lib.scale(1) == 0.125
    # Trial 4: option 1 falls to 0.0625 < 0.1 -> pruned; option 0 used again.
    rep = lib.end_trial(used=[0])
    assert rep.discounted == (1,) and rep.pruned == (1,)
    assert list(lib.option_ids) == [0] and 1 not in lib
    assert (1, 0) in lib.pruned
    with pytest.raises(KeyError, match="not active"):
        lib.scale(1)
    # A used id that is no longer active is ignored; counts reset per trial.
    lib.record_use(0, 3)
    assert lib.options()[0].uses == 3 and lib.options()[0].trial_uses == 3
    lib.end_trial(used=[1, 0])
    assert lib.options()[0].uses == 3 and lib.options()[0].trial_uses == 0


def test_only_offered_options_are_discounted() -> None:
    lib = OptionLibrary(IntervalKernels([(0, 3), (3, 6)]), [constant_policy(0)])
    rep = lib.end_trial(used=[], offered=[1])
    assert rep.discounted == (1,)
    assert lib.scale(0) == 1.0 and lib.scale(1) == 0.5


# --------------------------------------------------------------------------- refits
def test_bhattacharyya_distance_properties() -> None:
    rng = np.random.default_rng(0)
    d = 4
    a = rng.normal(size=(d, d))
    c1 = a @ a.T + np.eye(d)
    b = rng.normal(size=(d, d))
    c2 = b @ b.T + np.eye(d)
    m1, m2 = rng.normal(size=d), rng.normal(size=d)
    assert bhattacharyya_distance(m1, c1, m1, c1) == pytest.approx(0.0, abs=1e-9)
    d12 = bhattacharyya_distance(m1, c1, m2, c2)
    assert d12 > 0
    assert bhattacharyya_distance(m2, c2, m1, c1) == pytest.approx(d12)
    # Invariant to a change of units (affine map).
    T = np.diag([1.0, 180 / np.pi, 0.01, 3.0]) @ (np.eye(d) + 0.1 * rng.normal(size=(d, d)))
    shift = rng.normal(size=d)
    dt = bhattacharyya_distance(T @ m1 + shift, T @ c1 @ T.T, T @ m2 + shift, T @ c2 @ T.T)
    assert dt == pytest.approx(d12, rel=1e-6)
    # Equal variances in 1-D: (mu1 - mu2)^2 / (8 sigma^2).
    assert bhattacharyya_distance([0.0], [[4.0]], [2.0], [[4.0]]) == pytest.approx(4 / 32)


def test_refit_with_permuted_kernels_keeps_identities_and_scales() -> None:
    intervals = [(0, 3), (3, 6), (6, 9)]
    model = IntervalKernels(intervals)
    lib = OptionLibrary(model, [constant_policy(0), constant_policy(1)])
    lib.end_trial(used=[0, 1, 2, 3])  # options 4 and 5 (kernel 2) -> 0.5
    lib.end_trial(used=[0, 1, 2, 3, 4])  # option 5 -> 0.25
    lib.record_use(2, 7)
    before = {(o.kernel_id, o.policy_id): o for o in lib.options()}
    perm = [2, 0, 1]
    new = lib.refit(model.permuted(perm))
    np.testing.assert_array_equal(new.kernel_ids, lib.kernel_ids[perm])
    after = {(o.kernel_id, o.policy_id): o for o in new.options()}
    assert set(after) == set(before)
    for pair, o in after.items():
        assert o.option_id == before[pair].option_id
        assert o.scale == before[pair].scale
        assert o.uses == before[pair].uses
        # The option's kernel index points at the same interval in the new model.
        assert new.kernel_model.intervals[o.kernel_index].tolist() == list(
            intervals[before[pair].kernel_index]
        )
    rep = new.refit_report
    assert rep is not None and rep.new_kernel_ids == () and rep.retired_kernel_ids == ()
    assert all(dist == pytest.approx(0.0, abs=1e-9) for _, dist in rep.matched.values())
    # The old library is unchanged.
    assert lib.kernel_model is model and list(lib.kernel_ids) == [0, 1, 2]


def test_refit_unmatched_kernels_new_policies_and_pruned_pairs() -> None:
    model = IntervalKernels([(0, 3), (3, 6)])
    lib = OptionLibrary(model, [constant_policy(0), constant_policy(1)])
    # Prune (kernel 0, policy 1) = option 1.
    for _ in range(4):
        lib.end_trial(used=[0, 2, 3])
    assert 1 not in lib and (0, 1) in lib.pruned
    # New model: kernel (0, 3) again (slightly moved), kernel (3, 6) gone, a far new one.
    new_model = IntervalKernels([(20, 23), (0.1, 3.1)], n_features=1)
    new = lib.refit(new_model, [constant_policy(2)])
    rep = new.refit_report
    assert rep is not None
    assert rep.matched.keys() == {1}  # only the moved kernel matched
    assert new.kernel_ids[1] == 0  # inherited id
    assert new.kernel_ids[0] == 2 and rep.new_kernel_ids == (2,)
    assert rep.retired_kernel_ids == (1,)
    assert rep.new_policy_ids == (2,)
    infos = {(o.kernel_id, o.policy_id): o for o in new.options()}
    # Kept: (0, 0) with its id; (0, 1) stays pruned; new: (0, 2), (2, 0), (2, 1), (2, 2).
    assert infos[(0, 0)].option_id == 0
    assert (0, 1) not in infos
    assert set(infos) == {(0, 0), (0, 2), (2, 0), (2, 1), (2, 2)}
    new_ids = [infos[p].option_id for p in [(0, 2), (2, 0), (2, 1), (2, 2)]]
    assert min(new_ids) > max(lib.registry)  # fresh ids
    assert all(infos[p].scale == 1.0 for p in [(0, 2), (2, 0), (2, 1), (2, 2)])
    assert sorted(rep.retired_option_ids) == [2, 3]  # options of kernel 1
    # Retired options still resolve as pointers.
    rng = np.random.default_rng(0)
    assert new.act(3, np.array([1.0]), rng) == 1
    with pytest.raises(KeyError, match="not active"):
        new.continues(3, np.array([1.0]), rng)


def test_refit_max_match_distance_none_matches_everything() -> None:
    model = IntervalKernels([(0, 3)])
    lib = OptionLibrary(model, [constant_policy(0)], OptionSettings(max_match_distance=None))
    new = lib.refit(IntervalKernels([(50, 53)]))
    assert list(new.kernel_ids) == [0] and list(new.option_ids) == [0]


def test_match_kernels_helper() -> None:
    a = IntervalKernels([(0, 3), (3, 6), (6, 9)])
    b = a.permuted([1, 2, 0])
    assert {j: i for j, (i, _) in match_kernels(a, b).items()} == {0: 1, 1: 2, 2: 0}
    assert kernel_distances(a, b).shape == (3, 3)
    with pytest.raises(ValueError, match="dimensions"):
        kernel_distances(a, IntervalKernels([(0, 3)], n_features=2))


# ---------------------------------------------------------------------- persistence
def _library_for_saving() -> OptionLibrary:
    model = IntervalKernels([(0, 3), (3, 6)])
    lib = OptionLibrary(model, [constant_policy(2)], OptionSettings(max_depth=3))
    lib = lib.refit(model, [constant_policy(0, option_ids=(0, 1), prefer=4)])
    lib.end_trial(used=[0, 1, 2])  # option 3 discounted
    lib.record_use(2, 5)
    return lib


def test_save_load_round_trip(tmp_path: Path) -> None:
    lib = _library_for_saving()
    lib.save(tmp_path / "lib")
    again = OptionLibrary.load(tmp_path / "lib", kernel_loader=IntervalKernels.load)
    assert again.options() == lib.options()
    assert again.registry == lib.registry and again.pruned == lib.pruned
    assert again.settings == lib.settings and again.settings.max_depth == 3
    np.testing.assert_array_equal(again.kernel_ids, lib.kernel_ids)
    r1, r2 = np.random.default_rng(4), np.random.default_rng(4)
    for x in np.linspace(0.1, 8.9, 40):
        s = np.array([x])
        for oid in lib.option_ids:
            assert lib.resolve(int(oid), s, r1) == again.resolve(int(oid), s, r2)
        np.testing.assert_array_equal(lib.available(s, r1), again.available(s, r2))
    # Further refits issue the same new ids.
    m2 = IntervalKernels([(6, 9)])
    assert list(lib.refit(m2).option_ids) == list(again.refit(m2).option_ids)


def test_load_rejects_tampered_or_mixed_files(tmp_path: Path) -> None:
    lib = _library_for_saving()
    lib.save(tmp_path / "a")
    other = OptionLibrary(IntervalKernels([(0, 3), (3, 6)]), [constant_policy(1)])
    other = other.refit(other.kernel_model, [constant_policy(0, option_ids=(0,), prefer=3)])
    other.save(tmp_path / "b")
    # A policy file from another save.
    (tmp_path / "a" / "policy_1.npz").write_bytes((tmp_path / "b" / "policy_1.npz").read_bytes())
    with pytest.raises(ValueError, match=r"another save|modified"):
        OptionLibrary.load(tmp_path / "a", kernel_loader=IntervalKernels.load)
    # Missing file.
    lib.save(tmp_path / "c")
    (tmp_path / "c" / "policy_0.npz").unlink()
    with pytest.raises(ValueError, match="missing file"):
        OptionLibrary.load(tmp_path / "c", kernel_loader=IntervalKernels.load)
    # Damaged library record.
    lib.save(tmp_path / "d")
    data = (tmp_path / "d" / "library.npz").read_bytes()
    (tmp_path / "d" / "library.npz").write_bytes(data[:-40])
    with pytest.raises(ValueError):
        OptionLibrary.load(tmp_path / "d", kernel_loader=IntervalKernels.load)
    # A consistent-looking record with impossible contents (scales > 1).
    from synthetic_smdp import read_archive

    from ilpss._io import save_npz_atomic

    lib.save(tmp_path / "e")
    arrays, meta = read_archive(tmp_path / "e" / "library.npz")
    arrays["scales"] = arrays["scales"] * 10
    save_npz_atomic(tmp_path / "e" / "library.npz", arrays, meta)
    with pytest.raises(ValueError, match="scales"):
        OptionLibrary.load(tmp_path / "e", kernel_loader=IntervalKernels.load)


def test_save_needs_a_saveable_kernel_model(tmp_path: Path) -> None:
    lib = OptionLibrary(constant_kernels([0.5]), [constant_policy(0)])
    with pytest.raises(TypeError, match="no save"):
        lib.save(tmp_path / "x")


# ------------------------------------------------------------- with the real kernels
def _clusters(rng: np.random.Generator, centres: np.ndarray, n: int) -> np.ndarray:
    return np.concatenate([c + rng.normal(scale=1.0, size=(n, centres.shape[1])) for c in centres])


@pytest.fixture(scope="module")
def real_model():
    kernels = pytest.importorskip("ilpss.kernels")
    rng = np.random.default_rng(0)
    centres = np.array([[10.0] * 9, [30.0] * 9, [10.0] * 4 + [90.0] * 5])
    bags = [_clusters(rng, centres, 150), _clusters(rng, centres, 100)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = kernels.SharedKernelModel(n_components=3, random_state=0).fit(bags)
    return kernels, model, bags, centres


def test_real_kernel_model_library_and_permuted_refit(real_model, tmp_path: Path) -> None:
    kernels, model, bags, centres = real_model
    coder = TileCoder(np.zeros(9), np.full(9, 100.0), np.full(9, 3.0), n_tilings=4)
    pols = [constant_policy(a, coder=coder) for a in (0, 1)]
    lib = OptionLibrary(model, pols)
    s = centres[1]
    m = lib.membership(s)
    assert m.shape == (3,) and m.max() > 0.5 and np.sort(m)[1] < 1e-6
    lib.end_trial(used=[0, 1, 2, 3])  # kernel 2's options discounted
    perm = [1, 2, 0]
    permuted = kernels.SharedKernelModel(n_components=3, max_iter=0).fit(
        bags, init_params={"means": model.means_[perm], "covariances": model.covariances_[perm]}
    )
    new = lib.refit(permuted)
    np.testing.assert_array_equal(new.kernel_ids, lib.kernel_ids[perm])
    assert {(o.option_id, o.scale) for o in new.options()} == {
        (o.option_id, o.scale) for o in lib.options()
    }
    np.testing.assert_allclose(new.membership(s), lib.membership(s)[perm], atol=1e-9)
    # A refit by EM from scratch with another seed finds the same regions: identities kept.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        refit = kernels.SharedKernelModel(n_components=3, random_state=5).fit(bags)
    again = lib.refit(refit)
    assert sorted(again.kernel_ids) == [0, 1, 2]
    assert again.refit_report is not None and again.refit_report.new_kernel_ids == ()
    # Save/load with the real model's own save.
    lib.save(tmp_path / "real")
    loaded = OptionLibrary.load(tmp_path / "real")
    assert loaded.options() == lib.options()
    np.testing.assert_allclose(loaded.membership(s), lib.membership(s))


def test_real_kernel_membership_gives_multi_step_options(real_model) -> None:
    """With the chi-square membership, in-kernel states continue options about half the
    time, so options typically run ~2 decisions on i.i.d. in-kernel states (longer on
    trajectories that stay near a centre)."""
    _, model, _, centres = real_model
    coder = TileCoder(np.zeros(9), np.full(9, 100.0), np.full(9, 3.0), n_tilings=4)
    lib = OptionLibrary(model, [constant_policy(0, coder=coder)])
    rng = np.random.default_rng(1)
    k = int(lib.membership(centres[0]).argmax())
    states = centres[0] + rng.normal(size=(2000, 9))
    conts = np.array([lib.membership(x)[k] for x in states])
    assert 0.4 < conts.mean() < 0.6  # uniform on [0, 1] for states drawn from the kernel


def test_discounting_accumulates_across_permuted_refits() -> None:
    """An option unused for four trials is pruned even though the kernels are refit
    (and reordered) between every trial; used options keep their scale."""
    intervals = [(0, 3), (3, 6), (6, 9)]
    lib = OptionLibrary(IntervalKernels(intervals), [constant_policy(0)])
    perms = [[1, 2, 0], [2, 0, 1], [0, 2, 1], [1, 0, 2]]
    history = []
    for trial, perm in enumerate(perms, start=1):
        report = lib.end_trial(used=[0, 1])  # option 2 (kernel (6, 9)) never used
        history.append(report)
        if trial < 4:
            assert lib.scale(2) == 0.5**trial
        lib = lib.refit(IntervalKernels([intervals[i] for i in perm]))
        assert lib.refit_report is not None and lib.refit_report.new_kernel_ids == ()
    assert [r.pruned for r in history] == [(), (), (), (2,)]
    assert list(lib.option_ids) == [0, 1] and lib.scale(0) == lib.scale(1) == 1.0
    assert (2, 0) in lib.pruned
    # The pruned pair is not recreated by later refits.
    assert 2 not in lib.refit(IntervalKernels(intervals))


def test_no_discounting_keeps_every_option() -> None:
    model = constant_kernels([0.3, 0.8])
    lib = OptionLibrary(model, [constant_policy(0)], OptionSettings(discount=1.0, prune_threshold=0.1))
    for _ in range(10):
        lib.end_trial(used=())
    assert len(lib) == 2 and np.all(lib.scales == 1.0)
