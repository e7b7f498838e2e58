"""Fine-tuning whose start chooses its source per state, with ILPSS's kernels as the gate.

Fine-tuning starts a new task from one past policy's values: the latest one, or the one
that does best in a few greedy episodes on the task. Either way one source serves the
whole task. When the task plays one source's game in one part of the field and another's
elsewhere (protocol S), no single source is right everywhere; options can switch between
whole past policies as the state changes, at the price of a second kind of choice in the
learner. :class:`StatewiseStart` keeps fine-tuning's one learner and no option, and makes
the *start* choose per state:

1. ILPSS's shared-kernel model (:class:`~ilpss.kernels.SharedKernelModel`, EM with the
   kernels shared by every source and weights per source) is fitted on the sources' bags
   of states, the states of their successful greedy rollouts. Each source's weights make
   a density ``p(s | j)`` over states, high where source ``j``'s successful play goes.
2. The start's value of each primitive at ``s`` is the sources' values mixed by the
   posterior ``p(j | s)`` (equal priors): in a state that looks like source ``j``'s
   successful play, source ``j``'s values.
3. The learner's values are sums of one-dimensional tiles and cannot hold that mixture
   exactly, so the start is its least-squares projection on the bags' states, damped
   towards the latest source's values (what plain fine-tuning starts from), which it
   keeps wherever the bags say nothing.

No episode is spent choosing: the whole budget is learning, as with plain fine-tuning.
With fewer than two sources that have states, the start is plain fine-tuning's.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from scipy import sparse
from scipy.sparse.linalg import lsqr

from ilpss.episode import EpisodeResult
from ilpss.kernels import KERNEL_CONSTRAINTS, SharedKernelModel
from ilpss.policy import FrozenPolicy
from ilpss.smdp import SmdpLearner
from soccer_drill.constraints import Integer, Real, check_fields

__all__ = ["StatewiseStart"]


def source_posteriors(model: SharedKernelModel, states: np.ndarray) -> np.ndarray:
    """``p(j | s)`` for every state (rows) and source (columns): each source's density
    under ``model`` (fitted with one instance per source), equal priors."""
    log_p = np.column_stack([np.atleast_1d(model.score_samples(states, instance=j))
                             for j in range(model.n_instances_)])
    log_p -= log_p.max(axis=1, keepdims=True)
    p = np.exp(log_p)
    return p / p.sum(axis=1, keepdims=True)


def statewise_values(policies: Sequence[FrozenPolicy], posteriors: np.ndarray,
                     active: np.ndarray, n_primitive: int) -> np.ndarray:
    """The primitives' values at each state (rows of ``active``, its active tiles): every
    source's values mixed by ``posteriors``. Shape ``(n_states, n_primitive)``."""
    values = np.stack([p.weights[:n_primitive][:, active].sum(axis=2).T for p in policies],
                      axis=1)  # (n_states, n_sources, n_primitive)
    return np.einsum("sj,sja->sa", posteriors, values)


@dataclass(frozen=True)
class StatewiseStart:
    """The start rule of the module docstring (a :class:`~ilpss.reuse.StartRule` that
    reads the sources' bags of states)."""

    n_kernels: int = 5
    reg_covar: float = 0.1
    """The kernels' covariance floor in standardised units: ILPSS+'s broad kernels, so that
    the gate is smooth between the sources' states rather than a hard boundary."""
    damping: float = 1.0
    """How strongly the projection keeps the latest source's weights (the ridge towards
    them, in squared value units per weight)."""
    max_states: int = 2000
    """At most this many states of each bag enter the fit (drawn without replacement)."""
    min_states: int = 10
    """A source whose bag holds fewer states is left out of the gate."""

    uses_bags: ClassVar[bool] = True

    def __post_init__(self) -> None:
        check_fields("StatewiseStart", self, {
            "n_kernels": KERNEL_CONSTRAINTS["n_components"],
            "reg_covar": KERNEL_CONSTRAINTS["reg_covar"],
            "damping": Real(0.0, 1e6, low_open=True), "max_states": Integer(1),
            "min_states": Integer(1)})

    def start(self, learner: SmdpLearner, policies: Sequence[FrozenPolicy], env: Any,
              seed: int, *, budget: int | None = None,
              bags: Sequence[np.ndarray] | None = None) -> list[EpisodeResult]:
        if not policies:
            return []
        learner.start_from(policies[-1])
        if bags is None or len(bags) < len(policies):
            raise ValueError(f"StatewiseStart needs a bag of states per past policy, got "
                             f"{0 if bags is None else len(bags)} for {len(policies)}")
        rng = np.random.default_rng(seed)
        usable = [j for j in range(len(policies)) if len(bags[j]) >= self.min_states]
        if len(usable) < 2:
            return []  # one source at most: nothing to choose between
        chosen = [_subsample(np.asarray(bags[j], dtype=np.float64), self.max_states, rng)
                  for j in usable]
        model = SharedKernelModel(self.n_kernels, reg_covar=self.reg_covar,
                                  random_state=int(rng.integers(2**31))).fit(chosen)
        states = np.concatenate(chosen)
        active = learner.tile_coder.active_batch(states)
        targets = statewise_values([policies[j] for j in usable],
                                   source_posteriors(model, states), active,
                                   learner.n_primitive)
        learner.q.weights[: learner.n_primitive] = _projected(
            active, targets, learner.q.weights[: learner.n_primitive], self.damping)
        return []


def _subsample(bag: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    if len(bag) <= n:
        return bag
    return bag[np.sort(rng.choice(len(bag), n, replace=False))]


def _projected(active: np.ndarray, targets: np.ndarray, start: np.ndarray,
               damping: float) -> np.ndarray:
    """Per primitive, the weights ``w`` minimising ``|Phi w - targets|^2 + damping |w -
    start|^2`` (``Phi``: the states' active tiles as a 0/1 matrix)."""
    n_states, n_active = active.shape
    phi = sparse.csr_matrix((np.ones(active.size), active.ravel(),
                             np.arange(0, active.size + 1, n_active)),
                            shape=(n_states, start.shape[1]))
    out = start.copy()
    for a in range(start.shape[0]):
        residual = targets[:, a] - phi @ start[a]
        out[a] += lsqr(phi, residual, damp=np.sqrt(damping), atol=1e-10, btol=1e-10,
                       iter_lim=2000)[0]
    return out
