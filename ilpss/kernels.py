"""Kernel model of ILPSS: a Gaussian mixture with shared components over bags of states.

The paper (section 4, step 3, eqs. 1-4) pools the states of the successful traces of each
task instance ``i`` into a *bag of states* and fits

    log P[D; theta] = sum_i sum_{s in bag i} log sum_k p_k^i N(s; mu_k, Sigma_k)

by EM, where the means ``mu_k`` and full covariances ``Sigma_k`` are shared by every
instance and only the mixture weights ``p_k^i`` belong to instance ``i``. In the M-step
the means and covariances use all states pooled (weighted by their responsibilities) and
the weights of instance ``i`` use only instance ``i``'s states. The components are the
*kernels* of the option library; :meth:`SharedKernelModel.membership` is the kernel
membership ``K(s, mu_k)`` in [0, 1] that gates when an option may start and continue.

Data contract: one 2-D float array ``(n_states, n_features)`` per task instance, passed
as a ``list``. With a single instance the model is an ordinary full-covariance Gaussian
mixture and reproduces ``sklearn.mixture.GaussianMixture`` from the same start (tested;
scikit-learn is not a dependency of :mod:`ilpss`).

Example
-------
>>> model = SharedKernelModel(n_components=5, random_state=0).fit(bags)  # doctest: +SKIP
>>> model.membership(state)           # (5,) values in [0, 1]           # doctest: +SKIP
>>> model.save("kernels.npz"); SharedKernelModel.load("kernels.npz")   # doctest: +SKIP
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, Self, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment
from scipy.special import chdtrc

from ilpss import _gmm_numerics as num
from ilpss._io import load_archive, save_npz_atomic
from ilpss._schema import BOOL, FLOAT, INTEGER, ArchiveSchema, Field, RowsSumToOne, Symmetric
from soccer_drill.constraints import Bool, Integer, NoneOr, Real, check, check_fields, is_int

__all__ = [
    "KernelModel",
    "RegionKernels",
    "SharedKernelModel",
    "UniformKernel",
    "kernel_distances",
    "match_kernels",
    "select_n_components",
]

#: Schema (name/version) of the files written by :meth:`SharedKernelModel.save`.
SCHEMA = "ilpss.kernels/1"
#: Lloyd iterations after k-means++ seeding: cheap, and they move seeds (often outlying
#: states) to cluster centres, which gives EM a much better start.
_LLOYD_ITERS = 10

Array = NDArray[np.float64]


class KernelConvergenceWarning(UserWarning):
    """EM reached ``max_iter`` before the mean log-likelihood settled within ``tol``."""


class NotFittedError(RuntimeError):
    """A method that needs a fitted model was called before :meth:`SharedKernelModel.fit`."""


# --------------------------------------------------------------------------- validation


def validate_bags(bags: Sequence[ArrayLike], n_features: int | None = None) -> list[Array]:
    """Check and convert bags of states to a list of C-contiguous float64 arrays.

    Parameters
    ----------
    bags : sequence of array_like
        One 2-D array ``(n_states, n_features)`` per task instance. A bag may have zero
        states (shape ``(0, n_features)``).
    n_features : int, optional
        Required number of features (that of a fitted model).

    Returns
    -------
    list of numpy.ndarray

    Raises
    ------
    ValueError
        If ``bags`` is not a non-empty sequence, a bag is not 2-D numeric, the bags do not
        share one feature count, or a value is NaN or infinite. The message names the
        instance index.
    """
    if isinstance(bags, np.ndarray) and bags.ndim == 2:
        raise ValueError(
            "bags must be a list of 2-D arrays, one per task instance; got a single 2-D "
            "array: wrap it in a list ([X]) if it is the bag of one instance"
        )
    if isinstance(bags, str | bytes) or not isinstance(bags, Iterable):
        raise ValueError(f"bags must be a list of 2-D arrays, got {type(bags).__name__}")
    bags = list(bags)
    if not bags:
        raise ValueError("bags is empty: give at least one task instance's bag of states")
    out: list[Array] = []
    for i, bag in enumerate(bags):
        try:
            raw = np.asarray(bag)
            if raw.dtype.kind != "c":
                a = np.ascontiguousarray(raw, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ValueError(
                f"instance {i}: cannot convert to a float array (n_states, n_features): {exc}"
            ) from exc
        if raw.dtype.kind == "c":
            _real(raw, f"instance {i}")  # raises, saying so
        if a.ndim != 2:
            raise ValueError(
                f"instance {i}: expected a 2-D array (n_states, n_features), got shape "
                f"{a.shape}; an instance without states is np.empty((0, n_features))"
            )
        want = n_features if n_features is not None else (out[0].shape[1] if out else None)
        if a.shape[1] == 0:
            raise ValueError(f"instance {i}: states have no features (shape {a.shape})")
        if want is not None and a.shape[1] != want:
            source = "the model" if n_features is not None else "instance 0"
            raise ValueError(
                f"instance {i}: has {a.shape[1]} features but {source} has {want}; all "
                "bags must describe states with the same features"
            )
        finite = np.isfinite(a)
        if not finite.all():
            row = int(np.argwhere(~finite)[0, 0])
            raise ValueError(
                f"instance {i}: contains NaN or infinite values (first at state {row}); "
                "only finite values are allowed"
            )
        out.append(a)
    return out


def _real(a: np.ndarray, what: str) -> Array:
    """``a`` as float64, refusing complex values (a cast would drop the imaginary part)."""
    if a.dtype.kind == "c":
        raise ValueError(f"{what}: complex values ({a.dtype}); states are real feature vectors")
    return a.astype(np.float64, copy=False)


def _as_states(X: ArrayLike, n_features: int) -> tuple[Array, bool]:
    """``X`` as a (n, d) float array; ``True`` if a single 1-D state was given."""
    a = np.asarray(X)
    if a.dtype != np.float64:
        a = _real(a, "states")
    single = a.ndim == 1
    if single:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != n_features:
        raise ValueError(
            f"expected a state of shape ({n_features},) or states of shape "
            f"(n, {n_features}), got shape {np.shape(X)}"
        )
    if not np.isfinite(a).all():
        raise ValueError("states contain NaN or infinite values; only finite values are allowed")
    return a, single


KERNEL_CONSTRAINTS = {
    "n_components": Integer(1, 1000),
    # The features are standardised (unit variance): far beyond 1e6 nothing of the data
    # is left, and 1e308 overflows the determinant.
    "reg_covar": Real(0.0, 1e6),
    "tol": Real(0.0),
    "max_iter": Integer(0, 1_000_000),
    "n_init": Integer(1, 1000),
}
"""What each hyperparameter of :class:`SharedKernelModel` allows (the lifelong
configuration's kernel settings are checked with these too)."""

_HYPERPARAMETERS = (*KERNEL_CONSTRAINTS, "random_state")

FEATURE_SCALE = Real(1e-150, 1e150)
"""What a feature's scale (the spread of its values in the bags) may be: its square, in
the covariances in the features' units, must be a normal float64 number (a scale of
5e-324 standardises every state but the mean to infinity, where each membership is 0).
Fits refuse bags beyond it, loads refuse a model beyond it."""
STANDARDISED_MEAN = Real(-1e150, 1e150)
"""What a kernel's mean may be in standardised units: far inside float64, so that the
distance of a state to it cannot overflow (a mean at 1e308 gives every state a membership
of 0). A fitted mean lies within the standardised states, at most ``sqrt(n)`` for n
states; fits refuse starting means beyond it, loads refuse a model beyond it."""

KERNELS_ARCHIVE = ArchiveSchema(
    SCHEMA,
    {
        "weights": Field(("I", "K"), FLOAT, each=Real(0.0), whole=(RowsSumToOne(1e-9),)),
        "std_means": Field(("K", "d"), FLOAT, each=STANDARDISED_MEAN),
        "std_covariances": Field(("K", "d", "d"), FLOAT, each=Real(),
                                 whole=(Symmetric(1e-10),)),
        "feature_mean": Field(("d",), FLOAT, each=Real()),
        "feature_scale": Field(("d",), FLOAT, each=FEATURE_SCALE),
        "n_states_per_instance": Field(("I",), INTEGER, each=Integer(0)),
        "log_likelihood_trace": Field((None,), FLOAT, each=Real()),
    },
    record={
        **{f"hyperparameters.{k}": c for k, c in KERNEL_CONSTRAINTS.items()},
        "hyperparameters.random_state": NoneOr(Integer(0)),
        "fit.converged": Bool(),
        "fit.n_iter": Integer(0),
        "fit.lower_bound": Real(),
    },
    dims={"I": Integer(1), "d": Integer(1)},
    sizes={"hyperparameters.n_components": "K"},
)
"""What :meth:`SharedKernelModel.save` writes: K kernels over d features, I instances."""


# --------------------------------------------------------------------------- the model


@dataclass
class _Fit:
    """Parameters and diagnostics of one EM run, in standardised units."""

    weights: Array
    means: Array
    covariances: Array
    prec_chol: Array
    trace: list[float]  # mean log-likelihood of parameters after 0, 1, ..., n_iter M-steps
    n_iter: int
    converged: bool


class SharedKernelModel:
    """Gaussian mixture whose components are shared by task instances (ILPSS kernels).

    Means and full covariances are shared by all instances; each instance has its own
    mixture weights (paper eqs. 1-4). The interface follows scikit-learn's
    ``GaussianMixture``.

    Parameters
    ----------
    n_components : int, default 5
        Number of kernels K (the paper uses 5). See :func:`select_n_components`.
    reg_covar : float, default 1e-6
        Added to the diagonal of every covariance, **in standardised units** (a fraction
        of each feature's variance), so it means the same whatever the feature units.
        It keeps covariances positive definite for duplicated states, fewer states than
        dimensions, or constant features.
    tol : float, default 1e-4
        EM stops when the mean (per state) log-likelihood changes by less than ``tol``.
    max_iter : int, default 200
        Maximum number of EM iterations per start; 0 keeps the initial parameters.
    n_init : int, default 3
        Number of k-means++ starts; the fit with the highest final log-likelihood is kept.
        Ignored (one start) when ``fit`` is given ``init_params``.
    random_state : int, numpy.random.Generator or None
        Seed of the k-means++ starts. The same int gives bit-identical fits.

    Attributes
    ----------
    weights_ : ndarray (n_instances, K)
        Mixture weights ``p_k^i`` of each instance (rows sum to 1).
    means_ : ndarray (K, d)
        Kernel centres in original feature units.
    covariances_ : ndarray (K, d, d)
        Kernel covariances in original feature units.
    std_means_, std_covariances_, std_precisions_cholesky_ : ndarray
        The same in standardised units, with ``P @ P.T = inv(Sigma)`` (used internally).
    feature_mean_, feature_scale_ : ndarray (d,)
        The scaler: ``z = (x - feature_mean_) / feature_scale_``.
    converged_ : bool
        Whether the kept EM run converged within ``max_iter``.
    n_iter_ : int
        EM iterations (M-steps) of the kept run.
    lower_bound_ : float
        Mean log-likelihood per state of the training bags under the fitted model, in
        original units (equals ``score(bags)``).
    log_likelihood_trace_ : list of float
        Mean log-likelihood after 0, 1, ..., ``n_iter_`` M-steps (original units).
        ``log_likelihood_trace_[-1] == lower_bound_``. With ``reg_covar=0`` EM never
        decreases it (up to rounding); with ``reg_covar > 0`` the M-step does not
        maximise the likelihood (the regularised covariances are not its maximisers),
        so it may decrease: slightly for a small ``reg_covar`` (steps down of about
        1e-8 at the default), visibly for a large one (0.1, 1), as scikit-learn's
        ``GaussianMixture``'s does.
    n_features_in_, n_instances_ : int
    n_states_per_instance_ : ndarray (n_instances,) of int
        Number of training states of each instance.

    Notes
    -----
    *Standardisation.* Features are standardised (pooled mean and population standard
    deviation) before EM so that distances, ``reg_covar`` and the k-means++ seeding do
    not depend on feature units (metres against radians). A constant feature (zero
    variance up to rounding) gets scale 1: it is only centred, never divided by zero, and
    its variance in every kernel is ``reg_covar``.

    *Instances without states.* Allowed, so that instance indices stay aligned with the
    policies they come from even when a policy produced no successful trace. Such an
    instance contributes nothing to the likelihood, its weights stay uniform (``1/K``:
    there is nothing to estimate them from), it is left out of the parameter count of
    :meth:`bic` and of the mean weights used when ``instance=None``.

    *Initialisation.* Greedy k-means++ seeding on the pooled standardised states, a few
    Lloyd iterations, then means, covariances and (pooled) weights of the hard
    assignment; the first M-step makes the weights instance-specific. ``fit`` can
    instead start from given parameters (``init_params``), e.g. the previous model's
    kernels in the lifelong loop.
    """

    def __init__(
        self,
        n_components: int = 5,
        *,
        reg_covar: float = 1e-6,
        tol: float = 1e-4,
        max_iter: int = 200,
        n_init: int = 3,
        random_state: int | np.random.Generator | None = None,
    ) -> None:
        self.n_components = n_components
        self.reg_covar = reg_covar
        self.tol = tol
        self.max_iter = max_iter
        self.n_init = n_init
        self.random_state = random_state

    def __repr__(self) -> str:
        return (
            f"SharedKernelModel(n_components={self.n_components!r}, reg_covar="
            f"{self.reg_covar!r}, tol={self.tol!r}, max_iter={self.max_iter!r}, n_init="
            f"{self.n_init!r}, random_state={self.random_state!r})"
        )

    def _check_hyperparameters(self) -> None:
        check_fields("", self, KERNEL_CONSTRAINTS)

    # ----------------------------------------------------------------------- fitting

    def fit(
        self, bags: Sequence[ArrayLike], init_params: Mapping[str, ArrayLike] | None = None
    ) -> Self:
        """Fit the kernels to bags of states by EM.

        Parameters
        ----------
        bags : list of array_like
            One ``(n_states, n_features)`` array per task instance (see
            :func:`validate_bags`); an instance may have no states.
        init_params : mapping, optional
            Start EM from these parameters, in **original feature units**, instead of
            k-means++ (one start, no randomness):

            - ``"means"`` (K, d), required;
            - ``"covariances"`` (K, d, d), optional: else the covariances of the states
              nearest to each mean;
            - ``"weights"`` (K,) or (n_instances, K), optional: else the fractions of
              states nearest to each mean.

        Returns
        -------
        self

        Raises
        ------
        ValueError
            On invalid hyperparameters, bags (see :func:`validate_bags`) or
            ``init_params``, or fewer states in total than components.

        Warns
        -----
        KernelConvergenceWarning
            If the kept run did not converge within ``max_iter`` iterations.
        """
        self._check_hyperparameters()
        Z, slices, n_states, feature_mean, feature_scale = self._standardised_bags(bags)
        best, n_runs = self._best_run(Z, slices, init_params, feature_mean, feature_scale)
        self._keep(best, feature_mean, feature_scale, n_states)
        if not best.converged and self.max_iter > 0:
            change = abs(best.trace[-1] - best.trace[-2])
            warnings.warn(
                f"EM did not converge within max_iter={self.max_iter} iterations (best of "
                f"{n_runs} start(s); last change of the mean log-likelihood {change:.3g}, "
                f"tol={self.tol}); increase max_iter or tol, or check for degenerate data",
                KernelConvergenceWarning,
                stacklevel=2,
            )
        return self

    def _standardised_bags(
        self, bags: Sequence[ArrayLike]
    ) -> tuple[Array, list[slice], NDArray[np.int64], Array, Array]:
        """The pooled states standardised, each instance's slice of them, the number of
        states of each instance, and the scaler."""
        arrays = validate_bags(bags)
        n_states = np.array([a.shape[0] for a in arrays], dtype=np.int64)
        total = int(n_states.sum())
        if total < self.n_components:
            raise ValueError(
                f"fewer states in total ({total}) than components ({self.n_components}); "
                "collect more successful traces or lower n_components"
            )
        pooled = np.concatenate(arrays, axis=0)
        ends = np.cumsum(n_states)
        slices = [slice(int(e - n), int(e)) for e, n in zip(ends, n_states, strict=True)]
        # Overflows here (features near float64's limits) are refused just below.
        with np.errstate(over="ignore", invalid="ignore"):
            feature_mean, feature_scale = _fit_scaler(pooled)
            Z = (pooled - feature_mean) / feature_scale
        _check_standardised(Z, feature_scale)
        return Z, slices, n_states, feature_mean, feature_scale

    def _best_run(
        self,
        Z: Array,
        slices: list[slice],
        init_params: Mapping[str, ArrayLike] | None,
        feature_mean: Array,
        feature_scale: Array,
    ) -> tuple[_Fit, int]:
        """The EM run of the highest final likelihood, and the number of runs: one from
        ``init_params`` if given, else ``n_init`` from k-means++."""
        if init_params is not None:
            starts = [self._start_from_params(Z, slices, init_params, feature_mean, feature_scale)]
            n_runs = 1
        else:
            starts, n_runs = [], self.n_init
        rng = np.random.default_rng(self.random_state)
        best: _Fit | None = None
        for run in range(n_runs):
            start = starts[run] if starts else self._start_kmeans(Z, slices, rng)
            result = self._run_em(Z, slices, *start)
            # Strictly greater: ties keep the earlier run.
            if best is None or result.trace[-1] > best.trace[-1]:
                best = result
        assert best is not None
        return best, n_runs

    def _keep(self, best: _Fit, feature_mean: Array, feature_scale: Array,
              n_states: NDArray[np.int64]) -> None:
        """Set the fitted attributes from the kept run; a run whose parameters are not
        finite in original units leaves no model."""
        self._set_state(
            weights=best.weights,
            std_means=best.means,
            std_covariances=best.covariances,
            feature_mean=feature_mean,
            feature_scale=feature_scale,
            n_states_per_instance=n_states,
            prec_chol=best.prec_chol,
        )
        offset = self._log_jacobian()
        self.log_likelihood_trace_ = [float(v + offset) for v in best.trace]
        self.lower_bound_ = self.log_likelihood_trace_[-1]
        fitted = (self.weights_, self.std_precisions_cholesky_,
                  np.asarray(self.log_likelihood_trace_))
        if not all(np.isfinite(a).all() for a in fitted) or self._units_problem() is not None \
                or not (np.abs(self.std_means_) <= STANDARDISED_MEAN.high).all():
            del self.std_precisions_cholesky_  # not fitted: a failed fit leaves no model
            raise ValueError(
                "the fit gave non-finite parameters: the states' scales are beyond float64 "
                "arithmetic for this model (e.g. covariances in original units overflow, or "
                "starting means far outside the states); rescale the features"
            )
        self.n_iter_ = best.n_iter
        self.converged_ = best.converged

    def _units_problem(self) -> str | None:
        """What is not finite among the parameters in the features' units (the
        standardised ones times the feature scales), or ``None``."""
        for what, values in (("means", self.means_), ("covariances", self.covariances_)):
            if not np.isfinite(values).all():
                return (f"its {what} in the features' units are not finite (the standardised "
                        f"{what} times feature_scale overflow float64)")
        return None

    def _start_kmeans(
        self, Z: Array, slices: list[slice], rng: np.random.Generator
    ) -> tuple[Array, Array, Array]:
        centres = num.kmeans_plusplus(Z, self.n_components, rng)
        centres = num.lloyd(Z, centres, _LLOYD_ITERS)
        return self._hard_moments(Z, slices, centres)

    def _hard_moments(
        self, Z: Array, slices: list[slice], centres: Array
    ) -> tuple[Array, Array, Array]:
        """Weights, means and covariances of the assignment of states to nearest centres."""
        resp = np.zeros((Z.shape[0], self.n_components))
        resp[np.arange(Z.shape[0]), num.nearest(Z, centres)] = 1.0
        pooled_weights, means, covariances = num.m_step(
            Z, [slice(0, Z.shape[0])], resp, self.reg_covar
        )
        # Pooled weights for every instance: before EM nothing is instance-specific, and a
        # weight of ~0 would be nearly a fixed point of EM.
        weights = np.repeat(pooled_weights, len(slices), axis=0)
        return weights, means, covariances

    def _start_from_params(
        self,
        Z: Array,
        slices: list[slice],
        init_params: Mapping[str, ArrayLike],
        feature_mean: Array,
        feature_scale: Array,
    ) -> tuple[Array, Array, Array]:
        """Standardised starting parameters from user parameters in original units."""
        K, d, n_inst = self.n_components, Z.shape[1], len(slices)
        unknown = set(init_params) - {"means", "covariances", "weights"}
        if unknown:
            raise ValueError(
                f"init_params: unknown keys {sorted(unknown)}; allowed: 'means', "
                "'covariances', 'weights'"
            )
        if "means" not in init_params:
            raise ValueError("init_params: 'means' (n_components, n_features) is required")

        def get(key: str, shapes: list[tuple[int, ...]]) -> Array:
            a = np.asarray(init_params[key], dtype=np.float64)
            if a.shape not in shapes:
                raise ValueError(
                    f"init_params[{key!r}] has shape {a.shape}, expected "
                    + " or ".join(str(s) for s in shapes)
                )
            if not np.isfinite(a).all():
                raise ValueError(f"init_params[{key!r}] contains NaN or infinite values")
            return a

        means = (get("means", [(K, d)]) - feature_mean) / feature_scale
        if "covariances" not in init_params or "weights" not in init_params:
            weights, _, covariances = self._hard_moments(Z, slices, means)
        if "covariances" in init_params:
            cov = get("covariances", [(K, d, d)])
            if not np.allclose(cov, cov.transpose(0, 2, 1), rtol=1e-8, atol=0.0):
                raise ValueError("init_params['covariances'] must be symmetric")
            covariances = cov / np.outer(feature_scale, feature_scale)
            try:
                num.precision_cholesky(covariances)
            except ValueError as exc:
                raise ValueError(f"init_params['covariances']: {exc}") from exc
        if "weights" in init_params:
            w = get("weights", [(K,), (n_inst, K)])
            w = np.broadcast_to(w, (n_inst, K)).copy()
            if (w < 0).any() or not np.allclose(w.sum(axis=1), 1.0, rtol=0.0, atol=1e-6):
                raise ValueError("init_params['weights'] must be >= 0 with rows summing to 1")
            weights = w / w.sum(axis=1, keepdims=True)
        return weights, means, covariances

    def _run_em(
        self, Z: Array, slices: list[slice], weights: Array, means: Array, covariances: Array
    ) -> _Fit:
        """EM from the given start, in scikit-learn's order (E, M, then the test on tol).

        The tested likelihood is that of the parameters before the M-step, as in
        scikit-learn, so that both stop after the same number of M-steps; the likelihood
        of the final parameters is computed once more at the end.
        """
        n = Z.shape[0]
        prec_chol = _data_precision_cholesky(covariances)
        trace: list[float] = []
        previous = -np.inf
        converged = False
        n_iter = 0
        for n_iter in range(1, self.max_iter + 1):  # noqa: B007 (n_iter is used after the loop)
            total, resp = num.e_step(Z, slices, _safe_log(weights), means, prec_chol)
            current = total / n
            trace.append(current)
            weights, means, covariances = num.m_step(Z, slices, resp, self.reg_covar)
            prec_chol = _data_precision_cholesky(covariances)
            if abs(current - previous) < self.tol:
                converged = True
                break
            previous = current
        trace.append(num.log_likelihood(Z, slices, _safe_log(weights), means, prec_chol) / n)
        return _Fit(weights, means, covariances, prec_chol, trace, n_iter, converged)

    def _set_state(
        self,
        *,
        weights: Array,
        std_means: Array,
        std_covariances: Array,
        feature_mean: Array,
        feature_scale: Array,
        n_states_per_instance: NDArray[np.int64],
        prec_chol: Array | None = None,
    ) -> None:
        """Set the learned attributes from the standardised parameters and the scaler."""
        self.weights_ = weights
        self.std_means_ = std_means
        self.std_covariances_ = std_covariances
        self.std_precisions_cholesky_ = (
            num.precision_cholesky(std_covariances) if prec_chol is None else prec_chol
        )
        self.feature_mean_ = feature_mean
        self.feature_scale_ = feature_scale
        self.means_ = std_means * feature_scale + feature_mean
        self.covariances_ = std_covariances * np.outer(feature_scale, feature_scale)
        self.n_states_per_instance_ = n_states_per_instance
        self._stacked = num.stack_components(std_means, self.std_precisions_cholesky_)
        self.n_features_in_ = int(std_means.shape[1])
        self.n_instances_ = int(weights.shape[0])

    # ----------------------------------------------------------------------- inference

    def _check_fitted(self) -> None:
        if not hasattr(self, "std_precisions_cholesky_"):
            raise NotFittedError(
                "this SharedKernelModel is not fitted yet; call fit(bags) or load(path) first"
            )

    def _log_jacobian(self) -> float:
        """``log |dz/dx|``: converts standardised log densities to original units."""
        return float(-np.log(self.feature_scale_).sum())

    def _standardise(self, X: ArrayLike) -> tuple[Array, bool]:
        self._check_fitted()
        a, single = _as_states(X, self.n_features_in_)
        return (a - self.feature_mean_) / self.feature_scale_, single

    def _log_weights(self, instance: int | None) -> Array:
        """Log weights of ``instance``, or of the mean of the instances that had states."""
        if instance is None:
            with_data = self.n_states_per_instance_ > 0
            return _safe_log(self.weights_[with_data].mean(axis=0))
        if not is_int(instance) or not 0 <= instance < self.n_instances_:
            raise ValueError(
                f"instance must be None or an int in [0, {self.n_instances_}), got {instance!r}"
            )
        return _safe_log(self.weights_[int(instance)])

    def sq_mahalanobis(self, X: ArrayLike) -> Array:
        """Squared Mahalanobis distance of states to every kernel centre.

        Parameters
        ----------
        X : array_like (n, d) or (d,)

        Returns
        -------
        ndarray (n, K), or (K,) for a single state.
        """
        Z, single = self._standardise(X)
        d2 = num.sq_mahalanobis(Z, self.std_means_, self.std_precisions_cholesky_, self._stacked)
        return d2[0] if single else d2

    def membership(self, X: ArrayLike) -> Array:
        """Kernel membership ``K(s, mu_k)`` in [0, 1] of states in every kernel.

        ``K(s, mu_k) = P[chi2_d >= D_k(s)^2]``, the chi-square tail probability (``d``
        degrees of freedom, ``d`` = number of features) of the squared Mahalanobis
        distance ``D_k(s)^2 = (s - mu_k)^T Sigma_k^{-1} (s - mu_k)``. If ``s`` is drawn
        from kernel ``k`` then ``D_k(s)^2 ~ chi2_d``, so ``K(s, mu_k)`` is the probability
        that a state of the kernel lies farther from its centre than ``s``: 1 at the
        centre, 0.5 at the median distance, 0.05 on the 95 % ellipsoid, and uniform on
        [0, 1] for states drawn from the kernel, in any dimension.

        Why not ``exp(-D^2 / 2)``: in ``d`` dimensions a typical in-kernel state has
        ``D^2`` near ``d``, so for the drill's 9 features ``exp(-9 / 2) = 0.011`` (and
        its mean over the kernel is ``2^(-d/2) = 0.044``): options gated by it would
        almost never start and would stop at once. The tail probability at ``D^2 = d``
        is 0.44 for ``d = 9``.

        Parameters
        ----------
        X : array_like (n, d) or (d,)
            States in original feature units.

        Returns
        -------
        ndarray (n, K), or (K,) for a single state.
        """
        d2 = self.sq_mahalanobis(X)  # +inf where it overflows: membership 0
        return chdtrc(float(self.n_features_in_), d2)

    def responsibilities(self, X: ArrayLike, instance: int | None = None) -> Array:
        """Posterior probability of each kernel for states (rows sum to 1).

        A state so far from every kernel that its squared Mahalanobis distances overflow
        float64 (every density is 0) gets the posterior's limit as the state moves away
        along its direction: all on the kernel whose Mahalanobis distance grows the
        slowest that way (shared equally by exact ties), among the kernels of positive
        weight.

        Parameters
        ----------
        X : array_like (n, d) or (d,)
        instance : int, optional
            Use this instance's weights; by default the mean weights of the instances that
            had states.

        Returns
        -------
        ndarray (n, K), or (K,) for a single state.
        """
        Z, single = self._standardise(X)
        log_prob = num.estimate_log_gaussian_prob(
            Z, self.std_means_, self.std_precisions_cholesky_, self._stacked
        )
        log_weights = self._log_weights(instance)
        log_prob += log_weights
        lost = ~(log_prob > -np.inf).any(axis=1)
        num.logsumexp_rows(log_prob)  # log_prob now holds the posteriors
        if lost.any():
            states, _ = _as_states(X, self.n_features_in_)
            log_prob[lost] = self._far_posteriors(states[lost], log_weights)
        return log_prob[0] if single else log_prob

    def _far_posteriors(self, states: Array, log_weights: Array) -> Array:
        """Posteriors of states whose densities all underflow (see :meth:`responsibilities`).

        As a state ``t u`` moves away, ``log p_k ~ -t^2 D_k(u)^2 / 2``: the kernel of the
        smallest Mahalanobis distance of the direction wins. Distances are taken of the
        states scaled by their largest magnitude, which keeps them finite.
        """
        size = np.maximum(np.abs(states).max(axis=1), np.abs(self.feature_mean_).max())
        size = np.where(size > 0, size, 1.0)[:, None]
        with np.errstate(over="ignore", invalid="ignore"):
            Z = (states / size - self.feature_mean_ / size) / self.feature_scale_
            d2 = np.vstack([
                num.sq_mahalanobis(Z[i:i + 1], self.std_means_ / size[i],
                                   self.std_precisions_cholesky_)
                for i in range(Z.shape[0])
            ])
        d2 = np.where(log_weights > -np.inf, d2, np.nan)  # a kernel of weight 0 never wins
        nearest = d2 == np.nanmin(d2, axis=1, keepdims=True)
        return nearest / nearest.sum(axis=1, keepdims=True)

    def score_samples(self, X: ArrayLike, instance: int | None = None) -> Array | float:
        """Log density of states under the mixture, in original feature units.

        Parameters
        ----------
        X : array_like (n, d) or (d,)
        instance : int, optional
            As in :meth:`responsibilities`.

        Returns
        -------
        ndarray (n,), or a float for a single state.
        """
        Z, single = self._standardise(X)
        log_prob = num.estimate_log_gaussian_prob(
            Z, self.std_means_, self.std_precisions_cholesky_, self._stacked
        )
        log_prob += self._log_weights(instance)
        out = num.logsumexp_rows(log_prob) + self._log_jacobian()
        return float(out[0]) if single else out

    def _total_log_likelihood(self, bags: Sequence[ArrayLike]) -> tuple[float, int]:
        """Total log-likelihood (original units) of bags and their number of states."""
        self._check_fitted()
        arrays = validate_bags(bags, self.n_features_in_)
        if len(arrays) != self.n_instances_:
            raise ValueError(
                f"expected {self.n_instances_} bags (one per fitted instance), got {len(arrays)}"
            )
        n = sum(a.shape[0] for a in arrays)
        if n == 0:
            raise ValueError("the bags hold no states")
        ends = np.cumsum([a.shape[0] for a in arrays])
        slices = [slice(int(e - a.shape[0]), int(e)) for e, a in zip(ends, arrays, strict=True)]
        Z = (np.concatenate(arrays, axis=0) - self.feature_mean_) / self.feature_scale_
        total = num.log_likelihood(
            Z, slices, _safe_log(self.weights_), self.std_means_, self.std_precisions_cholesky_
        )
        return total + n * self._log_jacobian(), n

    def score(self, bags: Sequence[ArrayLike]) -> float:
        """Mean log-likelihood per state of bags (one per fitted instance), original units."""
        total, n = self._total_log_likelihood(bags)
        return total / n

    def n_parameters(self) -> int:
        """Free parameters: shared means and covariances, K - 1 weights per instance.

        Instances without training states have no estimated weights and are not counted.
        The scaler (2 d numbers) is the same for every K and is left out.
        """
        self._check_fitted()
        K, d = self.std_means_.shape
        n_weighted = int((self.n_states_per_instance_ > 0).sum())
        return K * d + K * d * (d + 1) // 2 + n_weighted * (K - 1)

    def bic(self, bags: Sequence[ArrayLike]) -> float:
        """Bayesian information criterion ``-2 log L + p log N`` of bags (lower is better)."""
        total, n = self._total_log_likelihood(bags)
        return -2.0 * total + self.n_parameters() * math.log(n)

    # ----------------------------------------------------------------------- persistence

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the fitted model to ``path`` (an ``.npz`` archive) atomically.

        The archive holds plain arrays and a JSON record (schema ``"ilpss.kernels/1"``,
        hyperparameters, fit diagnostics) with a checksum; see :mod:`ilpss._io`. A
        ``random_state`` that is not an int or None (a Generator) is recorded as None.
        """
        self._check_fitted()
        seed = self.random_state
        seed = int(seed) if is_int(seed) else None
        meta = {
            "schema": SCHEMA,
            "hyperparameters": {
                "n_components": int(self.n_components),
                "reg_covar": float(self.reg_covar),
                "tol": float(self.tol),
                "max_iter": int(self.max_iter),
                "n_init": int(self.n_init),
                "random_state": seed,
            },
            "fit": {
                "converged": bool(self.converged_),
                "n_iter": int(self.n_iter_),
                "lower_bound": float(self.lower_bound_),
            },
        }
        arrays = {
            "weights": self.weights_,
            "std_means": self.std_means_,
            "std_covariances": self.std_covariances_,
            "feature_mean": self.feature_mean_,
            "feature_scale": self.feature_scale_,
            "n_states_per_instance": self.n_states_per_instance_.astype(np.int64),
            "log_likelihood_trace": np.asarray(self.log_likelihood_trace_, dtype=np.float64),
        }
        save_npz_atomic(path, arrays, meta)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Self:
        """Read a model written by :meth:`save`; never unpickles.

        Raises
        ------
        FileNotFoundError
            If ``path`` does not exist.
        ValueError
            If the file is truncated or corrupt, modified after saving, of another schema
            version, lacks an array or a field, or holds arrays of the wrong shape, dtype
            or values (non-finite, weights not summing to 1, covariances not positive
            definite); the message says which.
        """
        checked = load_archive(path, KERNELS_ARCHIVE)
        arrays, meta = checked.arrays, checked.meta
        where = os.fspath(path)
        model = cls(**{k: meta["hyperparameters"][k] for k in _HYPERPARAMETERS})
        n_iter = meta["fit"]["n_iter"]
        trace = arrays["log_likelihood_trace"].astype(np.float64)
        counts = arrays["n_states_per_instance"].astype(np.int64)
        cov = arrays["std_covariances"].astype(np.float64)
        if counts.sum() < model.n_components:
            raise ValueError(f"{where}: invalid kernel model: n_states_per_instance totals "
                             f"{counts.sum()}, fewer than n_components={model.n_components}")
        if trace.shape[0] != n_iter + 1:
            raise ValueError(f"{where}: invalid kernel model: log_likelihood_trace has "
                             f"{trace.shape[0]} values for n_iter={n_iter}")
        try:
            prec_chol = num.precision_cholesky(cov)
        except ValueError as exc:
            raise ValueError(f"{where}: invalid kernel model: {exc}") from exc
        with np.errstate(over="ignore"):  # an overflow is refused just below
            model._set_state(
                weights=arrays["weights"].astype(np.float64),
                std_means=arrays["std_means"].astype(np.float64),
                std_covariances=cov,
                feature_mean=arrays["feature_mean"].astype(np.float64),
                feature_scale=arrays["feature_scale"].astype(np.float64),
                n_states_per_instance=counts,
                prec_chol=prec_chol,
            )
        problem = model._units_problem()
        if problem is not None:
            raise ValueError(f"{where}: invalid kernel model: {problem}")
        model.converged_ = bool(meta["fit"]["converged"])
        model.n_iter_ = n_iter
        model.lower_bound_ = float(meta["fit"]["lower_bound"])
        model.log_likelihood_trace_ = [float(v) for v in trace]
        return model


def _data_precision_cholesky(covariances: Array) -> Array:
    """:func:`num.precision_cholesky` of covariances estimated from data, with a hint."""
    try:
        return num.precision_cholesky(covariances)
    except ValueError as exc:
        raise ValueError(
            f"{exc}: the data are degenerate for this model (e.g. duplicated states with "
            "reg_covar=0); increase reg_covar or use fewer components"
        ) from exc


def _safe_log(a: Array) -> Array:
    """``log`` that maps an exact zero weight to ``-inf`` without a warning."""
    with np.errstate(divide="ignore"):
        return np.log(a)


def _check_standardised(Z: Array, scale: Array) -> None:
    """Refuse states whose standardisation lost them to float64 limits.

    Standardised by the population standard deviation, no value can exceed ``sqrt(n)``
    in magnitude, and a constant feature is only centred (its values are then ~0). Values
    beyond that come from an overflow (features near 1e300) or from a constant feature so
    large (an offset of 1e200) that centring it leaves rounding errors of ~1e184. A scale
    outside :data:`FEATURE_SCALE` is refused too: a spread below 1e-150 (but not within
    rounding of constant) gives covariances that underflow in the features' units.
    """
    bound = math.sqrt(Z.shape[0]) + 1.0
    extent = np.max(np.abs(Z), axis=0, initial=0.0)
    bad = ~((scale >= FEATURE_SCALE.low) & (scale <= FEATURE_SCALE.high)
            & np.isfinite(extent) & (extent <= bound))
    if bad.any():
        raise ValueError(
            f"feature(s) {np.flatnonzero(bad).tolist()} of the bags cannot be standardised "
            "in float64 (a spread beyond about 1e150 or below 1e-150, or an offset so large "
            "that the values no longer differ); rescale or recentre the features"
        )


def _fit_scaler(X: Array) -> tuple[Array, Array]:
    """Per-feature mean and scale; constant features get scale 1 (documented above).

    A feature counts as constant when its variance is within rounding of zero, with
    scikit-learn's bound ``n eps var + (n eps mean)^2``: the mean of n equal values is not
    always exactly that value, so the computed variance of a constant may be ~1e-33.
    """
    n = X.shape[0]
    mean = X.mean(axis=0)
    var = X.var(axis=0)
    eps = np.finfo(np.float64).eps
    constant = var <= n * eps * var + (n * mean * eps) ** 2
    scale = np.sqrt(var)
    scale[constant] = 1.0
    return mean, scale


def select_n_components(
    bags: Sequence[ArrayLike], candidates: Iterable[int] = range(1, 9), **kwargs: Any
) -> tuple[int, dict[int, float]]:
    """Choose the number of kernels by BIC.

    Parameters
    ----------
    bags : list of array_like
        Bags of states, as for :meth:`SharedKernelModel.fit`.
    candidates : iterable of int, default 1..8
        Numbers of components to try. Those above the number of states cannot be fitted
        and are skipped (so a small bag is fitted with the counts it allows); at least
        one must remain.
    **kwargs
        Other arguments of :class:`SharedKernelModel` (``random_state``, ``n_init``, ...).

    Returns
    -------
    best_k : int
        The candidate with the lowest BIC (the smallest such on ties).
    bics : dict of int to float
        BIC of each candidate fitted.

    Raises
    ------
    ValueError
        A candidate that is not a valid ``n_components``, no candidates, or none that
        the states allow.
    """
    if "n_components" in kwargs:
        raise ValueError("give the numbers of components as candidates, not n_components")
    candidates = list(candidates)
    for k in candidates:
        check("select_n_components candidate", k, KERNEL_CONSTRAINTS["n_components"])
    if not candidates:
        raise ValueError("candidates is empty")
    arrays = validate_bags(bags)
    n_states = sum(a.shape[0] for a in arrays)
    possible = sorted({int(k) for k in candidates if k <= n_states})
    if not possible:
        raise ValueError(
            f"no candidate can be fitted to {n_states} states: the numbers of components "
            f"must be at most the number of states (1 to {n_states}), got "
            f"{sorted(set(candidates))}"
        )
    bics: dict[int, float] = {}
    for k in possible:
        bics[k] = SharedKernelModel(n_components=k, **kwargs).fit(arrays).bic(arrays)
    best_k = min(bics, key=lambda k: (bics[k], k))
    return best_k, bics


UNIFORM_SCHEMA = "ilpss.uniform_kernel/1"
#: What a given kernel shape allows as its dimension (a saved file names it, and the
#: covariances are n x n).
N_FEATURES = Integer(1, 1024)
UNIFORM_ARCHIVE = ArchiveSchema(UNIFORM_SCHEMA, {}, record={"n_features": N_FEATURES})
"""What :meth:`UniformKernel.save` writes: its dimension only."""


class UniformKernel:
    """One kernel covering the whole state space: membership 1 everywhere.

    The ablation "whole past policies as options, without kernels": options built on it
    may start anywhere (with probability equal to their scale) and never terminate
    before the episode ends. It has the attributes the option library needs
    (``n_components``, ``means_``, ``covariances_``) so that refits always match it
    with itself.

    Parameters
    ----------
    n_features : int
        Dimension of the states.
    """

    n_components = 1

    def __init__(self, n_features: int) -> None:
        check("n_features", n_features, N_FEATURES)
        self.n_features_in_ = int(n_features)
        self.means_ = np.zeros((1, self.n_features_in_))
        self.covariances_ = np.eye(self.n_features_in_)[None]

    def membership(self, X: ArrayLike) -> Array:
        """Ones: shape (n, 1) for a 2-D batch, (1,) for a single state."""
        X, single = _as_states(X, self.n_features_in_)
        out = np.ones((X.shape[0], 1))
        return out[0] if single else out

    def save(self, path: str | os.PathLike[str]) -> None:
        """Save atomically (``.npz`` + JSON record, schema ``ilpss.uniform_kernel/1``)."""
        save_npz_atomic(
            path, {}, {"schema": UNIFORM_SCHEMA, "n_features": self.n_features_in_}
        )

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> UniformKernel:
        """Load a file written by :meth:`save` (refuses any other schema)."""
        return cls(load_archive(path, UNIFORM_ARCHIVE).meta["n_features"])


REGION_SCHEMA = "ilpss.region_kernels/1"
_FLOAT32_MAX = float(np.finfo(np.float32).max)
REGION_THRESHOLD = Real(-_FLOAT32_MAX, _FLOAT32_MAX)
"""What a region's threshold may be: states are compared with it in float32, where a
threshold beyond float32's range would be infinite (every state inside, or none)."""
REGION_ARCHIVE = ArchiveSchema(
    REGION_SCHEMA,
    {"features": Field(("K",), INTEGER, each=Integer(0)),
     "thresholds": Field(("K",), FLOAT, each=REGION_THRESHOLD),
     "below": Field(("K",), BOOL)},
    record={"n_features": N_FEATURES},
    dims={"K": Integer(1, 1000)},
)
"""What :meth:`RegionKernels.save` writes: K regions."""


class RegionKernels:
    """Kernels that are given regions of the state space rather than fitted: kernel ``k``
    has membership 1 where feature ``features[k]`` is at most ``thresholds[k]`` (compared
    in float32, as observations often are) if ``below[k]``, where it is above otherwise,
    and 0 elsewhere.

    The oracle arm of a stream whose opponents change behaviour across known regions:
    options built on it start and run exactly inside a region (``K(s)`` is 1 there, 0
    outside), which separates "fragments of past policies help where regions matter" from
    "EM finds the regions". It has the attributes the option library needs
    (``n_components``, ``means_``, ``covariances_``): distinct means, so that refits
    match every region with itself.

    Parameters
    ----------
    n_features : int
        Dimension of the states.
    features, thresholds, below : sequences of equal length
        Each region's feature index, threshold and side.
    """

    def __init__(self, n_features: int, features: Sequence[int], thresholds: Sequence[float],
                 below: Sequence[bool]) -> None:
        check("n_features", n_features, N_FEATURES)
        self.n_features_in_ = int(n_features)
        self.features = np.asarray(features, dtype=np.int64)
        self.thresholds = np.asarray(thresholds, dtype=np.float64)
        self.below = np.asarray(below, dtype=bool)
        k = self.features.shape[0]
        if not (1 <= k <= 1000 and self.features.shape == self.thresholds.shape
                == self.below.shape == (k,)):
            raise ValueError("RegionKernels: features, thresholds and below must be 1-D "
                             f"sequences of one equal length in [1, 1000], got {k}")
        if ((self.features < 0) | (self.features >= n_features)).any() or \
                not all(REGION_THRESHOLD.allows(t) for t in self.thresholds):
            raise ValueError(f"RegionKernels: feature indices must lie in [0, {n_features}) "
                             f"and thresholds be {REGION_THRESHOLD.describe()} (states are "
                             "compared with them in float32)")
        self.n_components = k
        # Pseudo-parameters for the library's matching: one distinct point per region.
        self.means_ = np.zeros((k, n_features))
        self.means_[np.arange(k), self.features] = self.thresholds + np.where(self.below, -1, 1)
        self.covariances_ = np.repeat(np.eye(n_features)[None], k, axis=0)
        self._thresholds32 = self.thresholds.astype(np.float32)

    def membership(self, X: ArrayLike) -> Array:
        """1 inside each region, 0 outside: shape (n, K) for a 2-D batch, (K,) for one state."""
        X, single = _as_states(X, self.n_features_in_)
        inside = (X[:, self.features].astype(np.float32) <= self._thresholds32) == self.below
        out = inside.astype(np.float64)
        return out[0] if single else out

    def save(self, path: str | os.PathLike[str]) -> None:
        """Save atomically (``.npz`` + JSON record, schema ``ilpss.region_kernels/1``)."""
        save_npz_atomic(path, {"features": self.features, "thresholds": self.thresholds,
                               "below": self.below},
                        {"schema": REGION_SCHEMA, "n_features": self.n_features_in_})

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> RegionKernels:
        """Load a file written by :meth:`save` (refuses any other schema)."""
        checked = load_archive(path, REGION_ARCHIVE)
        arrays = checked.arrays
        try:
            return cls(checked.meta["n_features"], arrays["features"], arrays["thresholds"],
                       arrays["below"])
        except ValueError as exc:
            raise ValueError(f"{os.fspath(path)}: {exc}") from exc


# --------------------------------------------------------------------------- matching
# How a refit keeps kernel identities (:meth:`ilpss.options.OptionLibrary.refit`): the
# kernels of two models are paired by the Bhattacharyya distance of their Gaussians.


@runtime_checkable
class KernelModel(Protocol):
    """What the library needs from a fitted kernel model (e.g. ``SharedKernelModel``)."""

    n_components: int
    means_: np.ndarray
    covariances_: np.ndarray

    def membership(self, X: np.ndarray) -> np.ndarray:  # pragma: no cover - protocol
        """Kernel memberships of the state(s) ``X``, in [0, 1]."""
        ...


def _logdet_pd(cov: np.ndarray) -> tuple[np.ndarray, float]:
    """Cholesky factor and log-determinant of a covariance.

    A covariance that is not numerically positive definite (a degenerate kernel) gets a
    tiny ridge relative to its own diagonal, so that it still has a distance; well
    conditioned covariances are used exactly (keeping the distance affine-invariant).
    """
    try:
        chol = np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        diag = np.diag(cov).copy()
        floor = max(float(diag.max()), 1e-300) * 1e-12
        ridged = cov + np.diag(np.maximum(diag, floor) * 1e-9 + floor)
        try:
            chol = np.linalg.cholesky(ridged)
        except np.linalg.LinAlgError:
            raise ValueError("kernel covariance is not positive semi-definite") from None
    return chol, 2.0 * float(np.log(np.diag(chol)).sum())


def bhattacharyya_distance(
    mean1: np.ndarray, cov1: np.ndarray, mean2: np.ndarray, cov2: np.ndarray
) -> float:
    """Bhattacharyya distance between two Gaussians.

    ``D = 1/8 (m1 - m2)' S^-1 (m1 - m2) + 1/2 ln(det S / sqrt(det S1 det S2))`` with
    ``S = (S1 + S2) / 2``. Zero for identical Gaussians, symmetric, and invariant to an
    invertible affine change of coordinates (so feature units do not matter).
    """
    m1, m2 = np.asarray(mean1, float), np.asarray(mean2, float)
    s1, s2 = np.asarray(cov1, float), np.asarray(cov2, float)
    _, logdet1 = _logdet_pd(s1)
    _, logdet2 = _logdet_pd(s2)
    chol, logdet_s = _logdet_pd((s1 + s2) / 2.0)
    z = np.linalg.solve(chol, m1 - m2)
    return float(z @ z / 8.0 + 0.5 * (logdet_s - 0.5 * (logdet1 + logdet2)))


def kernel_distances(old: KernelModel, new: KernelModel) -> np.ndarray:
    """Bhattacharyya distances, shape (K_old, K_new), between two models' kernels."""
    om, oc = kernel_parameters(old)
    nm, nc = kernel_parameters(new)
    if om.shape[1] != nm.shape[1]:
        raise ValueError(
            f"kernel models have different dimensions ({om.shape[1]} and {nm.shape[1]})"
        )
    out = np.empty((om.shape[0], nm.shape[0]))
    for i in range(om.shape[0]):
        for j in range(nm.shape[0]):
            out[i, j] = bhattacharyya_distance(om[i], oc[i], nm[j], nc[j])
    return out


def match_kernels(
    old: KernelModel, new: KernelModel, max_distance: float | None = 3.0
) -> dict[int, tuple[int, float]]:
    """Match the kernels of ``new`` to those of ``old``.

    Returns
    -------
    dict
        ``{new_index: (old_index, distance)}`` for every matched pair: the minimum-cost
        one-to-one assignment on :func:`kernel_distances`, keeping pairs whose distance
        is at most ``max_distance`` (all assigned pairs if ``None``).
    """
    dist = kernel_distances(old, new)
    rows, cols = linear_sum_assignment(dist)
    out: dict[int, tuple[int, float]] = {}
    for i, j in zip(rows, cols, strict=True):
        if max_distance is None or dist[i, j] <= max_distance:
            out[int(j)] = (int(i), float(dist[i, j]))
    return out


def kernel_parameters(model: KernelModel) -> tuple[np.ndarray, np.ndarray]:
    """The ``means_`` (K, d) and ``covariances_`` (K, d, d) of a kernel model, as float64,
    checked for shape and finiteness."""
    means = np.asarray(getattr(model, "means_", None), dtype=np.float64)
    covs = np.asarray(getattr(model, "covariances_", None), dtype=np.float64)
    if means.ndim != 2 or covs.shape != (means.shape[0], means.shape[1], means.shape[1]):
        raise ValueError(
            "kernel model must have means_ of shape (K, d) and covariances_ of shape "
            f"(K, d, d); got {means.shape} and {covs.shape}"
        )
    if not (np.isfinite(means).all() and np.isfinite(covs).all()):
        raise ValueError("kernel model means_/covariances_ contain NaN or infinity")
    return means, covs
