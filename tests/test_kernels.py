"""Tests of ilpss.kernels: the shared-component Gaussian mixture (paper section 4, step 3)."""

from __future__ import annotations

import io
import json
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy import stats
from scipy.optimize import linear_sum_assignment

from ilpss import _gmm_numerics as num
from ilpss import _io
from ilpss.kernels import (
    KernelConvergenceWarning,
    NotFittedError,
    SharedKernelModel,
    select_n_components,
)

D = 9


def _random_covariance(rng: np.random.Generator, d: int, scale: float = 1.0) -> np.ndarray:
    a = rng.normal(size=(d, d))
    return scale * (a @ a.T / d + 0.3 * np.eye(d))


def planted(
    seed: int = 0,
    n_components: int = 4,
    weights: np.ndarray | None = None,
    n_states: int = 400,
    separation: float = 12.0,
) -> tuple[list[np.ndarray], list[np.ndarray], np.ndarray, np.ndarray]:
    """Bags from shared, well-separated 9-D Gaussians with per-instance weights.

    Features get very different units (x0.01 .. x100) so standardisation matters.
    Returns bags, labels per bag, true means and true covariances (original units).
    """
    rng = np.random.default_rng(seed)
    if weights is None:
        weights = np.array(
            [
                [0.7, 0.1, 0.1, 0.1],
                [0.1, 0.6, 0.1, 0.2],
                [0.25, 0.25, 0.25, 0.25],
                [0.05, 0.05, 0.3, 0.6],
            ]
        )[:, :n_components]
        weights = weights / weights.sum(axis=1, keepdims=True)
    units = np.geomspace(0.01, 100.0, D)
    means = rng.normal(size=(n_components, D)) * separation / np.sqrt(2 * D) * 2
    covs = np.array([_random_covariance(rng, D) for _ in range(n_components)])
    bags, labels = [], []
    for w in weights:
        lab = rng.choice(n_components, size=n_states, p=w)
        x = np.empty((n_states, D))
        for k in range(n_components):
            idx = lab == k
            x[idx] = rng.multivariate_normal(means[k], covs[k], size=idx.sum())
        bags.append(x * units)
        labels.append(lab)
    return bags, labels, means * units, covs * np.outer(units, units)


@pytest.fixture(scope="module")
def planted_fit():
    bags, labels, means, covs = planted()
    model = SharedKernelModel(4, random_state=0).fit(bags)
    return model, bags, labels, means, covs


def _match(estimated: np.ndarray, true: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Permutation p with estimated[p[j]] ~ true[j] (distances in units of ``scale``)."""
    cost = np.linalg.norm((estimated[:, None, :] - true[None, :, :]) / scale, axis=2)
    rows, cols = linear_sum_assignment(cost)
    perm = np.empty_like(rows)
    perm[cols] = rows
    return perm


# ------------------------------------------------------------------------------ oracle


def _sklearn_start(rng: np.random.Generator, z: np.ndarray, k: int):
    means = z[rng.choice(z.shape[0], size=k, replace=False)] + 0.1 * rng.normal(size=(k, D))
    covs = np.array([_random_covariance(rng, D, 0.5) for _ in range(k)])
    weights = rng.dirichlet(np.full(k, 5.0))
    return weights, means, covs


@pytest.mark.parametrize(("tol", "max_iter"), [(1e-4, 200), (0.0, 30)])
def test_single_instance_agrees_with_sklearn(tol: float, max_iter: int) -> None:
    sklearn_mixture = pytest.importorskip("sklearn.mixture")
    bags, *_ = planted(seed=3, n_components=3, weights=np.array([[0.5, 0.3, 0.2]]), separation=3)
    x = bags[0]
    mean, scale = x.mean(axis=0), x.std(axis=0)
    z = (x - mean) / scale
    weights, means, covs = _sklearn_start(np.random.default_rng(7), z, 3)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # tol=0 never converges, in both implementations
        reference = sklearn_mixture.GaussianMixture(
            3,
            covariance_type="full",
            reg_covar=1e-6,
            tol=tol,
            max_iter=max_iter,
            weights_init=weights,
            means_init=means,
            precisions_init=np.linalg.inv(covs),
        ).fit(z)
        model = SharedKernelModel(3, reg_covar=1e-6, tol=tol, max_iter=max_iter).fit(
            [x],
            init_params={
                "weights": weights,
                "means": means * scale + mean,
                "covariances": covs * np.outer(scale, scale),
            },
        )

    np.testing.assert_allclose(model.feature_mean_, mean, rtol=1e-12)
    np.testing.assert_allclose(model.feature_scale_, scale, rtol=1e-12)
    assert model.n_iter_ == reference.n_iter_
    assert model.converged_ == reference.converged_
    # Log-likelihood: same model, up to the Jacobian of the standardisation.
    reference_ll = reference.score(z) - np.log(scale).sum()
    assert model.lower_bound_ == pytest.approx(reference_ll, rel=1e-6)
    assert model.score([x]) == pytest.approx(reference_ll, rel=1e-6)
    np.testing.assert_allclose(model.weights_[0], reference.weights_, atol=1e-7)
    np.testing.assert_allclose(model.std_means_, reference.means_, atol=1e-6)
    np.testing.assert_allclose(model.std_covariances_, reference.covariances_, atol=1e-6)
    np.testing.assert_allclose(
        model.responsibilities(x, instance=0), reference.predict_proba(z), atol=1e-6
    )


def test_one_em_step_matches_direct_equations() -> None:
    """Multi-instance M-step: shared moments from pooled data, weights per instance."""
    rng = np.random.default_rng(11)
    scale = np.array([1.0, 5.0, 0.2])
    bags = [(rng.normal(size=(n, 3)) + i) * scale for i, n in enumerate([40, 25, 60])]
    start = {
        "weights": np.array([[0.5, 0.5], [0.2, 0.8], [0.9, 0.1]]),
        "means": np.array([[0.0, 0.0, 0.0], [2.0, 10.0, 0.4]]),
        "covariances": np.array([np.diag([1.0, 25.0, 0.04]), np.diag([2.0, 20.0, 0.05])]),
    }
    with pytest.warns(KernelConvergenceWarning):
        model = SharedKernelModel(2, max_iter=1, reg_covar=0.0).fit(bags, init_params=start)

    # Direct implementation of one EM step in original units (standardisation is affine,
    # so with reg_covar=0 it changes nothing).
    resp = []
    for i, x in enumerate(bags):
        dens = np.column_stack(
            [
                start["weights"][i, k]
                * stats.multivariate_normal(start["means"][k], start["covariances"][k]).pdf(x)
                for k in range(2)
            ]
        )
        resp.append(dens / dens.sum(axis=1, keepdims=True))
    pooled, r = np.concatenate(bags), np.concatenate(resp)
    nk = r.sum(axis=0)
    means = r.T @ pooled / nk[:, None]
    covs = np.array(
        [((pooled - means[k]) * r[:, k : k + 1]).T @ (pooled - means[k]) / nk[k] for k in range(2)]
    )
    weights = np.array([ri.mean(axis=0) for ri in resp])
    np.testing.assert_allclose(model.weights_, weights, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(model.means_, means, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(model.covariances_, covs, rtol=1e-9, atol=1e-12)

    # And the log-likelihood and densities of the final model, from scipy.
    log_dens = [
        np.log(
            sum(
                model.weights_[i, k]
                * stats.multivariate_normal(model.means_[k], model.covariances_[k]).pdf(x)
                for k in range(2)
            )
        )
        for i, x in enumerate(bags)
    ]
    np.testing.assert_allclose(model.score_samples(bags[1], instance=1), log_dens[1], rtol=1e-9)
    assert model.lower_bound_ == pytest.approx(np.concatenate(log_dens).mean(), rel=1e-9)
    assert model.score(bags) == pytest.approx(model.lower_bound_, rel=1e-12)


# ------------------------------------------------------------------------ planted model


def test_recovers_planted_shared_components(planted_fit) -> None:
    model, bags, labels, means, covs = planted_fit
    assert model.converged_
    pooled, pooled_labels = np.concatenate(bags), np.concatenate(labels)
    scale = pooled.std(axis=0)
    perm = _match(model.means_, means, scale)
    # Against the planted parameters, within sampling error (~300-500 states per component).
    assert np.abs((model.means_[perm] - means) / scale).max() < 0.1
    rel = np.linalg.norm(model.covariances_[perm] - covs, axis=(1, 2)) / np.linalg.norm(
        covs, axis=(1, 2)
    )
    assert rel.max() < 0.25
    # Against the sample moments of each planted cluster: well separated, so EM's soft
    # assignment is practically the planted hard one.
    for j in range(4):
        cluster = pooled[pooled_labels == j]
        np.testing.assert_allclose(
            model.means_[perm[j]] / scale, cluster.mean(axis=0) / scale, rtol=0, atol=1e-4
        )
        np.testing.assert_allclose(
            model.covariances_[perm[j]] / np.outer(scale, scale),
            np.cov(cluster.T, bias=True) / np.outer(scale, scale),
            rtol=0,
            atol=1e-4,
        )
    empirical = np.array([np.bincount(lab, minlength=4) / lab.size for lab in labels])
    np.testing.assert_allclose(model.weights_[:, perm], empirical, atol=0.01)
    assert model.weights_.shape == (4, 4)
    np.testing.assert_allclose(model.weights_.sum(axis=1), 1.0)


def test_log_likelihood_never_decreases() -> None:
    # Overlapping clusters and too many components: many iterations, slow progress.
    bags, *_ = planted(seed=5, separation=2.0, n_states=150)
    with pytest.warns(KernelConvergenceWarning):
        model = SharedKernelModel(6, tol=0.0, max_iter=150, n_init=1, random_state=1).fit(bags)
    trace = np.array(model.log_likelihood_trace_)
    assert len(trace) == model.n_iter_ + 1 == 151
    assert np.all(np.diff(trace) >= -1e-9 * np.abs(trace[1:]))
    assert trace[-1] == model.lower_bound_ == pytest.approx(model.score(bags), rel=1e-12)


def test_bic_selects_planted_k() -> None:
    bags, *_ = planted(seed=2, n_components=3, weights=np.array([[0.6, 0.2, 0.2], [0.2, 0.2, 0.6]]))
    best_k, bics = select_n_components(bags, candidates=range(1, 7), random_state=0)
    assert best_k == 3
    assert set(bics) == set(range(1, 7))
    assert min(bics.values()) == bics[3]


def test_bic_counts_per_instance_weights(planted_fit) -> None:
    model, bags, *_ = planted_fit
    K, d, n = 4, D, sum(len(b) for b in bags)
    assert model.n_parameters() == K * d + K * d * (d + 1) // 2 + 4 * (K - 1)
    expected = -2 * model.score(bags) * n + model.n_parameters() * np.log(n)
    assert model.bic(bags) == pytest.approx(expected, rel=1e-12)


# ------------------------------------------------------------------------------ inference


def test_membership_definition(planted_fit) -> None:
    model = planted_fit[0]
    # 1 at every kernel centre, for a single 1-D state too.
    for k in range(4):
        single = model.membership(model.means_[k])
        assert single.shape == (4,)
        assert single[k] == pytest.approx(1.0, abs=1e-12)
    # A state at squared Mahalanobis distance exactly d from kernel 0.
    chol = np.linalg.cholesky(model.covariances_[0])
    u = np.random.default_rng(0).normal(size=D)
    state = model.means_[0] + chol @ (u / np.linalg.norm(u) * np.sqrt(D))
    assert model.sq_mahalanobis(state)[0] == pytest.approx(D, rel=1e-9)
    assert model.membership(state)[0] == pytest.approx(stats.chi2.sf(D, D), rel=1e-9)
    assert model.membership(state)[0] == pytest.approx(0.437, abs=1e-3)
    assert np.exp(-D / 2) < 0.012  # what the naive kernel would give: options stop at once


def test_membership_range_monotone_and_uniform_in_kernel(planted_fit) -> None:
    model, bags, *_ = planted_fit
    rng = np.random.default_rng(1)
    x = np.concatenate(bags)
    far = x[:200] + rng.normal(size=(200, D)) * x.std(axis=0) * 5
    m = model.membership(np.concatenate([x, far]))
    assert m.shape == (x.shape[0] + 200, 4)
    assert np.all((m >= 0.0) & (m <= 1.0))
    # Monotone (non-increasing) in the squared Mahalanobis distance.
    d2 = model.sq_mahalanobis(np.concatenate([x, far]))
    for k in range(4):
        order = np.argsort(d2[:, k])
        assert np.all(np.diff(m[order, k]) <= 0.0)
    # Along a ray out of a centre.
    ray = model.means_[1] + np.linspace(0, 3, 50)[:, None] * x.std(axis=0)
    assert np.all(np.diff(model.membership(ray)[:, 1]) <= 0.0)
    # States drawn from a kernel have uniform membership in it: mean 1/2 in any dimension.
    samples = rng.multivariate_normal(model.means_[2], model.covariances_[2], size=4000)
    mk = model.membership(samples)[:, 2]
    assert mk.mean() == pytest.approx(0.5, abs=0.02)
    assert stats.kstest(mk, "uniform").pvalue > 1e-3


def test_responsibilities_and_score_samples(planted_fit) -> None:
    model, bags, *_ = planted_fit
    r = model.responsibilities(bags[1], instance=1)
    np.testing.assert_allclose(r.sum(axis=1), 1.0)
    assert model.responsibilities(bags[1][0]).shape == (4,)
    # Original-unit density from scipy, mean weights of the instances for instance=None.
    x = bags[2][:20]
    w = model.weights_.mean(axis=0)
    dens = sum(
        w[k] * stats.multivariate_normal(model.means_[k], model.covariances_[k]).pdf(x)
        for k in range(4)
    )
    np.testing.assert_allclose(model.score_samples(x), np.log(dens), rtol=1e-8)
    assert isinstance(model.score_samples(x[0], instance=3), float)
    with pytest.raises(ValueError, match=r"instance must be None or an int in \[0, 4\)"):
        model.responsibilities(x, instance=4)
    with pytest.raises(ValueError, match=r"expected a state of shape \(9,\)"):
        model.membership(np.zeros(8))
    with pytest.raises(ValueError, match="NaN or infinite"):
        model.membership(np.full(D, np.nan))


# ------------------------------------------------------------------------------ validation


@pytest.mark.parametrize(
    ("bags", "match"),
    [
        ([], "bags is empty"),
        (np.zeros((10, 3)), r"wrap it in a list \(\[X\]\)"),
        ([np.zeros((10, 3)), np.zeros((10, 4))], "instance 1: has 4 features but instance 0 has 3"),
        ([np.zeros((5, 3)), np.zeros((5, 3)), np.array([[0.0, np.nan, 0.0]])], "instance 2: .*NaN"),
        ([np.array([[np.inf, 0.0, 0.0]])], "instance 0: contains NaN or infinite"),
        ([np.zeros(3)], r"instance 0: expected a 2-D array .* got shape \(3,\)"),
        ([np.zeros((2, 2, 2))], "instance 0: expected a 2-D array"),
        ([np.zeros((4, 0))], "instance 0: states have no features"),
        ([[[1.0, 2.0], [3.0]]], "instance 0: cannot convert"),
        (
            [np.zeros((1, 3)), np.zeros((1, 3))],
            r"fewer states in total \(2\) than components \(3\)",
        ),
        ([np.empty((0, 3))], r"fewer states in total \(0\)"),
    ],
)
def test_invalid_bags_are_refused(bags, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        SharedKernelModel(3).fit(bags)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n_components": 0}, r"n_components must be an integer in \[1, 1,000\], got 0"),
        ({"reg_covar": -1.0}, r"reg_covar must be a finite number in \[0, 1e\+06\]"),
        ({"tol": float("nan")}, "tol must be"),
        ({"max_iter": 1.5}, r"max_iter must be an integer in \[0, 1,000,000\], got 1.5"),
        ({"n_init": 0}, r"n_init must be an integer in \[1, 1,000\]"),
    ],
)
def test_invalid_hyperparameters(kwargs, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        SharedKernelModel(**kwargs).fit([np.random.default_rng(0).normal(size=(20, 2))])


@pytest.mark.parametrize(
    ("init", "match"),
    [
        ({"weights": np.ones(2) / 2}, "'means'.* is required"),
        (
            {"means": np.zeros((3, 2))},
            r"init_params\['means'\] has shape \(3, 2\), expected \(2, 2\)",
        ),
        (
            {"means": np.zeros((2, 2)), "covariances": np.array([[[1.0, 1.0], [0.0, 1.0]]] * 2)},
            "symmetric",
        ),
        (
            {"means": np.zeros((2, 2)), "covariances": -np.array([np.eye(2)] * 2)},
            r"init_params\['covariances'\]: covariance of component 0 is not positive definite",
        ),
        ({"means": np.zeros((2, 2)), "weights": np.array([0.9, 0.3])}, "rows summing to 1"),
        ({"means": np.zeros((2, 2)), "extra": 1}, "unknown keys"),
        ({"means": np.full((2, 2), np.nan)}, "NaN"),
    ],
)
def test_invalid_init_params(init, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        SharedKernelModel(2).fit([np.random.default_rng(0).normal(size=(20, 2))], init_params=init)


def test_not_fitted_and_not_converged() -> None:
    with pytest.raises(NotFittedError, match="not fitted"):
        SharedKernelModel().membership(np.zeros(D))
    bags, *_ = planted(seed=1, separation=2.0, n_states=100)
    with pytest.warns(KernelConvergenceWarning, match="did not converge within max_iter=2"):
        model = SharedKernelModel(4, max_iter=2, random_state=0).fit(bags)
    assert not model.converged_ and model.n_iter_ == 2


def test_empty_instance_is_allowed_with_uniform_weights() -> None:
    bags, *_ = planted(seed=4, n_states=200)
    with_empty = [bags[0], np.empty((0, D)), bags[1]]
    model = SharedKernelModel(4, random_state=0).fit(with_empty)
    assert model.n_instances_ == 3
    np.testing.assert_array_equal(model.n_states_per_instance_, [200, 0, 200])
    np.testing.assert_allclose(model.weights_[1], 0.25)
    # Same fit as without the empty bag, apart from its row of weights.
    reference = SharedKernelModel(4, random_state=0).fit([bags[0], bags[1]])
    np.testing.assert_allclose(model.means_, reference.means_, rtol=1e-12)
    np.testing.assert_allclose(model.weights_[[0, 2]], reference.weights_, rtol=1e-12)
    assert model.n_parameters() == reference.n_parameters()
    # instance=None averages over instances with states only.
    np.testing.assert_allclose(
        model.responsibilities(bags[2][:5]), reference.responsibilities(bags[2][:5]), rtol=1e-10
    )
    assert model.score(with_empty) == pytest.approx(reference.score([bags[0], bags[1]]))
    with pytest.raises(ValueError, match="expected 3 bags"):
        model.score(bags[:2])


@pytest.mark.parametrize(
    "case", ["duplicate_states", "fewer_states_than_dims", "constant_feature", "single_state"]
)
def test_degenerate_data_is_regularised(case: str) -> None:
    rng = np.random.default_rng(0)
    if case == "duplicate_states":
        bags, k = (
            [np.tile(rng.normal(size=(1, D)), (50, 1)), np.tile(rng.normal(size=(2, D)), (20, 1))],
            3,
        )
    elif case == "fewer_states_than_dims":
        bags, k = [rng.normal(size=(4, D)), rng.normal(size=(3, D))], 2
    elif case == "constant_feature":
        x = rng.normal(size=(200, D))
        x[:, 3] = 0.1  # the mean of 200 copies of 0.1 is not exactly 0.1
        bags, k = [x[:100], x[100:]], 3
    else:
        bags, k = [rng.normal(size=(1, D))], 1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", KernelConvergenceWarning)
        model = SharedKernelModel(k, random_state=0).fit(bags)
    for name in ("weights_", "means_", "covariances_", "std_precisions_cholesky_"):
        assert np.isfinite(getattr(model, name)).all(), name
    # The floor is reg_covar; eigvalsh's own error is a few ulps of the largest eigenvalue.
    eig = np.linalg.eigvalsh(model.std_covariances_)
    assert np.all(eig >= 1e-6 - 16 * np.finfo(float).eps * eig.max(axis=-1, keepdims=True))
    assert np.isfinite(model.lower_bound_)
    m = model.membership(np.concatenate(bags))
    assert np.isfinite(m).all() and (m >= 0).all() and (m <= 1).all()
    if case == "constant_feature":
        assert model.feature_scale_[3] == 1.0
        np.testing.assert_allclose(model.std_covariances_[:, 3, 3], 1e-6, rtol=1e-6)


# ---------------------------------------------------------------- determinism and files


def test_same_random_state_gives_bit_identical_fit() -> None:
    bags, *_ = planted(seed=6, separation=4.0, n_states=200)
    a = SharedKernelModel(4, random_state=123).fit(bags)
    b = SharedKernelModel(4, random_state=123).fit(bags)
    for name in ("weights_", "means_", "covariances_", "std_precisions_cholesky_"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert a.log_likelihood_trace_ == b.log_likelihood_trace_


def test_save_load_round_trip(planted_fit, tmp_path: Path) -> None:
    model, bags, *_ = planted_fit
    path = tmp_path / "kernels.npz"
    model.save(path)
    loaded = SharedKernelModel.load(path)
    states = np.concatenate(bags)
    np.testing.assert_array_equal(loaded.membership(states), model.membership(states))
    np.testing.assert_array_equal(loaded.means_, model.means_)
    np.testing.assert_array_equal(loaded.covariances_, model.covariances_)
    assert loaded.score(bags) == model.score(bags)
    assert loaded.log_likelihood_trace_ == model.log_likelihood_trace_
    assert (loaded.converged_, loaded.n_iter_, loaded.lower_bound_) == (
        model.converged_,
        model.n_iter_,
        model.lower_bound_,
    )
    assert repr(loaded) == repr(model)
    assert [p.name for p in tmp_path.iterdir()] == ["kernels.npz"]  # no temporary left


def _resave(path: Path, target: Path, arrays=None, meta=None, drop=()) -> None:
    """Rewrite a saved model with changes, keeping a valid checksum (values must be checked)."""
    with np.load(path) as f:
        data = {k: f[k] for k in f.files}
    record = json.loads(str(data.pop("__meta__")))
    data.update(arrays or {})
    for key in drop:
        data.pop(key)
    _io.save_npz_atomic(target, data, meta if meta is not None else record["meta"])


def test_damaged_or_foreign_files_are_refused(planted_fit, tmp_path: Path) -> None:
    model = planted_fit[0]
    good = tmp_path / "good.npz"
    model.save(good)
    raw = good.read_bytes()
    meta = json.loads(str(np.load(good)["__meta__"]))["meta"]

    def refused(match: str, data: bytes | None = None, **resave) -> None:
        bad = tmp_path / "bad.npz"
        if data is not None:
            bad.write_bytes(data)
        else:
            _resave(good, bad, **resave)
        with pytest.raises(ValueError, match=match):
            SharedKernelModel.load(bad)

    refused("not a readable .npz", data=raw[: len(raw) // 2])
    refused("not a readable .npz", data=b"")
    refused("not a readable .npz", data=b"\x80\x04garbage that looks like a pickle")
    # Tampered: one array changed behind the checksum's back.
    with np.load(good) as f:
        data = {k: f[k] for k in f.files}
    data["weights"] = data["weights"][::-1].copy()
    buffer = io.BytesIO()
    np.savez(buffer, **data)
    refused("checksum mismatch", data=buffer.getvalue())
    refused(
        r"wrong schema 'ilpss.kernels/2', expected 'ilpss.kernels/1'",
        meta={**meta, "schema": "ilpss.kernels/2"},
    )
    refused("missing array 'weights'", drop=("weights",))
    refused(r"array 'std_means' has shape \(4, 9, 1\)", arrays={"std_means": np.zeros((4, 9, 1))})
    refused(
        r"'std_covariances' axis 1 has length 9, but d = 8", arrays={"std_means": np.zeros((4, 8))}
    )
    refused(
        "array 'n_states_per_instance' has dtype float64",
        arrays={"n_states_per_instance": np.ones(4)},
    )
    refused("array 'weights' must be probabilities", arrays={"weights": np.full((4, 4), 0.3)})
    refused("non-finite", arrays={"feature_mean": np.full(D, np.nan)})
    refused("not positive definite", arrays={"std_covariances": -np.tile(np.eye(D), (4, 1, 1))})
    refused(
        "missing field hyperparameters.tol",
        meta={
            **meta,
            "hyperparameters": {k: v for k, v in meta["hyperparameters"].items() if k != "tol"},
        },
    )
    refused(
        "n_components",
        meta={**meta, "hyperparameters": {**meta["hyperparameters"], "n_components": 3}},
    )
    with pytest.raises(FileNotFoundError):
        SharedKernelModel.load(tmp_path / "missing.npz")
    with pytest.raises(NotFittedError):
        SharedKernelModel().save(tmp_path / "x.npz")


def test_degenerate_data_without_regularisation_is_refused() -> None:
    bags = [np.tile(np.arange(float(D)), (10, 1))]
    with pytest.raises(ValueError, match="not positive definite: the data are degenerate"):
        SharedKernelModel(1, reg_covar=0.0).fit(bags)


# ------------------------------------------------------------ extreme scales
@pytest.mark.parametrize("scale", [1e-300, 1e-150, 1e-8, 1e8, 1e150, 1e155, 1e300])
@pytest.mark.parametrize("offset", [0.0, 1e8, -1e100, 1e200])
def test_a_fit_at_any_scale_gives_finite_parameters_or_raises(scale, offset) -> None:
    rng = np.random.default_rng(0)
    X = rng.normal(size=(120, 3)) * scale + offset
    model = SharedKernelModel(2, random_state=0)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)  # no silent overflow either
            warnings.simplefilter("ignore", KernelConvergenceWarning)
            model.fit([X])
    except ValueError as exc:
        assert "rescale" in str(exc)
        with pytest.raises(NotFittedError):  # a failed fit leaves no usable model
            model.membership(X[0])
        return
    for a in (model.weights_, model.means_, model.covariances_, model.std_means_):
        assert np.isfinite(a).all()
    assert np.isfinite(model.score([X]))
    m = model.membership(X)
    assert np.isfinite(m).all() and (m >= 0).all() and (m <= 1).all()


def test_the_documented_failures_are_refused() -> None:
    X = np.random.default_rng(0).normal(size=(200, 3))
    for bad in (X * 1e300, X + 1e200):
        with pytest.raises(ValueError, match=r"feature\(s\) \[0, 1, 2\] of the bags cannot be "
                           r"standardised in float64"):
            SharedKernelModel(2, random_state=0).fit([bad])
    # The normal case is untouched.
    assert np.isfinite(SharedKernelModel(2, random_state=0).fit([X]).means_).all()


@pytest.mark.parametrize("feature_scales", [(1.0, 1.0, 1.0), (1e-3, 1.0, 1e6), (1e-8, 1e8, 1.0)])
def test_membership_lies_in_0_1_for_every_finite_state(feature_scales) -> None:
    rng = np.random.default_rng(1)
    X = rng.normal(size=(300, 3)) * np.asarray(feature_scales)
    model = SharedKernelModel(3, random_state=0).fit([X])
    magnitudes = [0.0, *(10.0**k for k in range(0, 309, 7)), np.finfo(float).max]
    states = np.array([sign * m * np.array(pattern) for m in magnitudes
                       for sign in (1.0, -1.0)
                       for pattern in ((1, 1, 1), (1, 0, 0), (0, -1, 1), (1, -1, 0.5))])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # overflow on the way to +inf
        batch = model.membership(states)
        single = np.array([model.membership(s) for s in states])
        d2 = model.sq_mahalanobis(states)
    for m in (batch, single):
        assert not np.isnan(m).any()
        assert (m >= 0).all() and (m <= 1).all()
    assert (d2 >= 0).all() and not np.isnan(d2).any()
    assert (batch[-8:] == 0).all()  # the largest floats are outside every kernel


@pytest.mark.parametrize("n", [1, 7, num.CHUNK, num.CHUNK + 1, 2 * num.CHUNK + 5])
def test_sq_mahalanobis_is_the_blockwise_products_bit_for_bit(n: int) -> None:
    """One state (a learner's every decision) or many, the numbers of products over
    blocks of at most CHUNK rows written into one array."""
    rng = np.random.default_rng(n)
    means = rng.normal(size=(5, 9))
    prec_chol = np.linalg.cholesky(np.linalg.inv(
        np.array([np.cov(rng.normal(size=(40, 9)), rowvar=False) for _ in range(5)])))
    Z = rng.normal(size=(n, 9)) * 3.0
    p_all, b, block_sum = num.stack_components(means, prec_chol)
    expected = np.empty((n, 5))
    for start in range(0, n, num.CHUNK):
        y = Z[start : start + num.CHUNK] @ p_all
        y -= b
        np.square(y, out=y)
        np.matmul(y, block_sum, out=expected[start : start + num.CHUNK])
    got = num.sq_mahalanobis(Z, means, prec_chol)
    assert got.tobytes() == np.fmin(expected, np.inf).tobytes()
