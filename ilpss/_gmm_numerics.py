"""Numerical kernels of the shared-component Gaussian mixture (see :mod:`ilpss.kernels`).

Pure functions on standardised, pooled data ``Z`` (n, d) whose rows are grouped by task
instance: ``slices[i]`` is the row range of instance ``i``. Everything is float64.

Conventions follow scikit-learn's ``GaussianMixture`` (covariance_type="full") so that
with one instance the two give the same iterates: ``prec_chol[k]`` is a matrix ``P`` with
``P @ P.T == inv(cov[k])``, so that the squared Mahalanobis distance of ``z`` is
``|(z - mu_k) @ P|^2``; component counts get ``10 * eps`` added so that no division is
by zero; ``reg_covar`` is added to every covariance diagonal.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import lapack

Array = NDArray[np.float64]

_LOG_2PI = float(np.log(2.0 * np.pi))
#: Rows per block. Blocks keep temporaries in cache and bound memory for large bags, and
#: keep every matrix product below OpenBLAS's multithreading threshold (about 2.6e5
#: multiply-adds): threading such small products gains little, and when other processes
#: load the CPUs it made an EM iteration 2-6 times slower in our measurements.
CHUNK = 1024
#: Floor on component counts, as in scikit-learn: keeps empty components finite.
EPS_COUNT = 10.0 * np.finfo(np.float64).eps


def precision_cholesky(covariances: Array) -> Array:
    """Cholesky factors of the precisions, ``P_k = inv(chol(cov_k)).T`` (K, d, d).

    Calls LAPACK ``potrf`` and ``trtri`` directly: for 9 x 9 matrices the checks and
    dispatch of :func:`scipy.linalg.solve_triangular` cost far more than the arithmetic.

    Raises
    ------
    ValueError
        If a covariance is not symmetric positive definite (to working precision).
    """
    out = np.empty_like(covariances)
    for k, cov in enumerate(covariances):
        chol, info = lapack.dpotrf(cov, lower=1, clean=1)
        if info == 0:
            inverse, info = lapack.dtrtri(chol, lower=1)
        if info != 0:
            raise ValueError(f"covariance of component {k} is not positive definite")
        out[k] = inverse.T
    return out


def stack_components(means: Array, prec_chol: Array) -> tuple[Array, Array, Array]:
    """Precisions side by side (d, K*d), their offsets (K*d,), and a block-sum matrix.

    ``(z @ P_all - b)**2 @ S`` gives all K squared Mahalanobis distances of ``z`` with two
    matrix products instead of K small ones and a strided reduction.
    """
    n_components, d = means.shape
    p_all = np.ascontiguousarray(prec_chol.transpose(1, 0, 2).reshape(d, n_components * d))
    b = np.einsum("kd,kde->ke", means, prec_chol).reshape(-1)
    block_sum = np.kron(np.eye(n_components), np.ones((d, 1)))
    return p_all, b, block_sum


def sq_mahalanobis(
    Z: Array,
    means: Array,
    prec_chol: Array,
    stacked: tuple[Array, Array, Array] | None = None,
) -> Array:
    """Squared Mahalanobis distance of every row of ``Z`` to every component (n, K), in
    ``[0, inf]`` (``inf`` where it overflows float64).

    ``stacked`` is :func:`stack_components` of ``means`` and ``prec_chol`` if the caller
    has it already (a fitted model keeps it: it matters when scoring single states).
    """
    p_all, b, block_sum = stack_components(means, prec_chol) if stacked is None else stacked
    if Z.shape[0] <= CHUNK:  # one block (a learner asks for one state at every decision)
        out = _block_sq_mahalanobis(Z, p_all, b, block_sum)
    else:
        out = np.empty((Z.shape[0], means.shape[0]))
        for start in range(0, Z.shape[0], CHUNK):
            out[start : start + CHUNK] = _block_sq_mahalanobis(Z[start : start + CHUNK],
                                                               p_all, b, block_sum)
    # A NaN here only comes from an overflow (inf * 0 in the block sum, inf - inf): the
    # distance is beyond float64, so it is +inf. fmin(x, inf) is x for every other value.
    return np.fmin(out, np.inf, out=out)


def _block_sq_mahalanobis(
    Z: Array, p_all: Array, b: Array, block_sum: Array
) -> Array:
    """:func:`sq_mahalanobis` of at most :data:`CHUNK` rows, before the overflow fix."""
    y = Z @ p_all
    y -= b
    np.square(y, out=y)
    return y @ block_sum


def _log_det_half(prec_chol: Array) -> Array:
    """``log det(P_k)`` = minus half the log-determinant of the covariance (K,)."""
    return np.log(np.diagonal(prec_chol, axis1=1, axis2=2)).sum(axis=1)


def estimate_log_gaussian_prob(
    Z: Array,
    means: Array,
    prec_chol: Array,
    stacked: tuple[Array, Array, Array] | None = None,
) -> Array:
    """``log N(z; mu_k, Sigma_k)`` for every row and component (n, K)."""
    d = means.shape[1]
    out = sq_mahalanobis(Z, means, prec_chol, stacked)
    out *= -0.5
    out += _log_det_half(prec_chol) - 0.5 * d * _LOG_2PI
    return out


def logsumexp_rows(a: Array) -> Array:
    """Row-wise log-sum-exp, overwriting ``a`` with the normalised ``exp`` (posteriors).

    Returns the (n,) log normalisers. Rows whose maximum is not finite (all ``-inf``)
    are left as they are rather than producing NaN from ``-inf - -inf``. For the few
    columns of a mixture, a loop over columns and a matrix-vector product are several
    times faster than numpy's ``max``/``sum`` along a short last axis.
    """
    row_max = a[:, 0].copy()
    for k in range(1, a.shape[1]):
        np.maximum(row_max, a[:, k], out=row_max)
    shift = np.where(np.isfinite(row_max), row_max, 0.0)
    a -= shift[:, None]
    np.exp(a, out=a)
    total = a @ np.ones(a.shape[1])
    with np.errstate(divide="ignore", invalid="ignore"):
        a /= total[:, None]
        return np.log(total) + shift


def e_step(
    Z: Array, slices: list[slice], log_weights: Array, means: Array, prec_chol: Array
) -> tuple[float, Array]:
    """Expectation step of the shared mixture.

    Parameters
    ----------
    Z : (n, d) standardised pooled states.
    slices : row range of each instance in ``Z``.
    log_weights : (n_instances, K) log mixture weights of each instance.
    means, prec_chol : (K, d) and (K, d, d) shared components.

    Returns
    -------
    total_log_likelihood : float
        ``sum_i sum_{s in bag i} log sum_k p_k^i N(s; mu_k, Sigma_k)`` (paper eqs. 1-4).
    resp : (n, K) array
        Posterior of each component for each state, with the state's own instance weights.
    """
    resp = estimate_log_gaussian_prob(Z, means, prec_chol)
    total = 0.0
    for i, rows in enumerate(slices):
        block = resp[rows]  # a view: normalised in place below
        if block.shape[0] == 0:
            continue
        block += log_weights[i]
        total += float(logsumexp_rows(block).sum())
    return total, resp


def log_likelihood(
    Z: Array, slices: list[slice], log_weights: Array, means: Array, prec_chol: Array
) -> float:
    """Total log-likelihood (the first output of :func:`e_step`)."""
    return e_step(Z, slices, log_weights, means, prec_chol)[0]


def m_step(
    Z: Array, slices: list[slice], resp: Array, reg_covar: float
) -> tuple[Array, Array, Array]:
    """Maximisation step: shared means and covariances, per-instance weights.

    The means and covariances use all states pooled, each weighted by its
    responsibility; the weights of instance ``i`` use only instance ``i``'s states. An
    instance without states keeps uniform weights (there is nothing to estimate them
    from).

    Returns
    -------
    weights : (n_instances, K), means : (K, d), covariances : (K, d, d)
    """
    n_components = resp.shape[1]
    d = Z.shape[1]
    nk = resp.sum(axis=0) + EPS_COUNT
    means = np.zeros((n_components, d))
    for start in range(0, Z.shape[0], CHUNK):
        means += resp[start : start + CHUNK].T @ Z[start : start + CHUNK]
    means /= nk[:, None]
    # Centred two-pass form, as scikit-learn (no cancellation for components far from the
    # origin), accumulated over row blocks that stay in cache.
    covariances = np.zeros((n_components, d, d))
    for start in range(0, Z.shape[0], CHUNK):
        z = Z[start : start + CHUNK]
        r = resp[start : start + CHUNK]
        for k in range(n_components):
            diff = z - means[k]
            covariances[k] += (diff * r[:, k : k + 1]).T @ diff
    covariances /= nk[:, None, None]
    # Symmetrise (the products are symmetric only up to rounding), then regularise.
    covariances += covariances.transpose(0, 2, 1)
    covariances *= 0.5
    for k in range(n_components):
        covariances[k].flat[:: d + 1] += reg_covar
    weights = np.full((len(slices), n_components), 1.0 / n_components)
    for i, rows in enumerate(slices):
        if rows.stop > rows.start:
            w = resp[rows].sum(axis=0) + EPS_COUNT
            weights[i] = w / w.sum()
    return weights, means, covariances


def kmeans_plusplus(Z: Array, n_components: int, rng: np.random.Generator) -> Array:
    """Greedy k-means++ seeding (Arthur and Vassilvitskii 2007), as in scikit-learn.

    Each new centre is the best of ``2 + log K`` candidates drawn with probability
    proportional to the squared distance to the nearest centre so far. When every state
    coincides with a centre (duplicated data) candidates are drawn uniformly.
    """
    n = Z.shape[0]
    n_trials = 2 + int(np.log(n_components))
    centres = np.empty((n_components, Z.shape[1]))
    centres[0] = Z[rng.integers(n)]
    closest = ((Z - centres[0]) ** 2).sum(axis=1)
    potential = closest.sum()
    for c in range(1, n_components):
        if potential > 0.0:
            draws = rng.random(n_trials) * potential
            candidates = np.minimum(np.searchsorted(np.cumsum(closest), draws), n - 1)
        else:
            candidates = rng.integers(n, size=n_trials)
        dist = ((Z[None, :, :] - Z[candidates][:, None, :]) ** 2).sum(axis=2)
        np.minimum(dist, closest, out=dist)
        potentials = dist.sum(axis=1)
        best = int(np.argmin(potentials))
        closest, potential = dist[best], potentials[best]
        centres[c] = Z[candidates[best]]
    return centres


def nearest(Z: Array, centres: Array) -> NDArray[np.intp]:
    """Index of the nearest centre (Euclidean) of every row of ``Z``."""
    sq_norms = (centres**2).sum(axis=1)
    labels = np.empty(Z.shape[0], dtype=np.intp)
    for start in range(0, Z.shape[0], CHUNK):
        d2 = sq_norms - 2.0 * (Z[start : start + CHUNK] @ centres.T)
        labels[start : start + CHUNK] = np.argmin(d2, axis=1)
    return labels


def lloyd(Z: Array, centres: Array, max_iter: int) -> Array:
    """A few Lloyd (k-means) iterations from ``centres``; empty clusters keep their centre."""
    centres = centres.copy()
    labels = nearest(Z, centres)
    for _ in range(max_iter):
        n_centres = centres.shape[0]
        counts = np.bincount(labels, minlength=n_centres)
        sums = np.column_stack(
            [np.bincount(labels, weights=Z[:, j], minlength=n_centres) for j in range(Z.shape[1])]
        )
        filled = counts > 0
        centres[filled] = sums[filled] / counts[filled, None]
        new_labels = nearest(Z, centres)
        if np.array_equal(new_labels, labels):
            break
        labels = new_labels
    return centres
