"""Kernel options ``o_k^i = <K_k, K_k, pi_i>`` and the option library across trials.

Option semantics
----------------
Option ``o_k^i`` pairs kernel ``k`` of the current kernel model with frozen policy
``pi_i`` (paper section 4, step 4), as implemented here:

* **Initiation.** At a decision state ``s`` the option may be chosen with probability
  ``c * K_k(s)``, where ``c`` is the option's *scale* (1 when created) and ``K_k(s)`` in
  [0, 1] is the kernel membership. Availability is sampled once per decision, for all
  options at once (:meth:`OptionLibrary.available`); the learner then chooses among the
  primitives and the available options.
* **Execution.** Once started, the option acts at its start state and at every later
  decision it reaches: it takes ``pi_i``'s greedy choice at ``s`` (ties broken by the
  caller's generator). ``pi_i`` may itself have learnt to choose options: such a choice
  is a *pointer* to that option's policy, so the greedy choice of the pointed policy at
  the same ``s`` is taken instead, and so on. Pointers are followed by option id through
  the library's registry of every option id ever issued, so they stay valid after the
  pointed option is pruned or its kernel retired. Only the running option's kernel
  governs termination; a pointed option's kernel is not consulted (it may no longer
  exist) and its availability is not sampled. At most ``max_depth`` policies are
  consulted per decision (the running option's own policy is depth 1); the policy at
  depth ``max_depth`` takes its best *primitive* action, so execution always ends and
  a cycle of pointers cannot loop.
* **Termination.** After each step that does not end the episode, the option continues
  at the new decision state ``s'`` with probability ``K_k(s')`` (the scale is not
  applied) and stops otherwise. So an option runs for at least one decision, and in a
  region where ``K_k ~ p`` it runs for ``1 / (1 - p)`` decisions on average.

Discounting and pruning (paper section 6)
-----------------------------------------
After each trial, :meth:`OptionLibrary.end_trial` is told which options the *learnt*
policy used (normally: the options chosen while rolling out the final greedy policy,
see :func:`ilpss.smdp.options_used`). Every option that was offered in the trial and not
used has its scale multiplied by ``discount`` (< 1); an option whose scale falls below
``prune_threshold`` (or to 0, by underflow) is pruned: it leaves the active set for
good, and its (kernel id, policy id) pair is remembered so that a refit never recreates
it. Options reached only through pointers of a used option do not count as used.

Identity across refits
----------------------
Every kernel carries a stable *kernel id*; an option's identity is the pair
(kernel id, policy id), and its stable *option id* is issued once for that pair. When
:meth:`OptionLibrary.refit` replaces the kernel model (step 5 of Algorithm 1, after
every trial):

1. Old and new kernels are compared by the Bhattacharyya distance between their
   Gaussians (means and covariances in original feature units; the distance is
   invariant to any affine change of units, so standardisation does not matter).
2. A minimum-cost one-to-one assignment (Hungarian algorithm,
   :func:`scipy.optimize.linear_sum_assignment`) pairs old and new kernels; a pair is
   a *match* only if its distance is at most ``max_match_distance`` (default 3.0, i.e.
   a Bhattacharyya coefficient of at least ``exp(-3) ~ 0.05``; ``None`` accepts every
   assigned pair).
3. A matched new kernel inherits the old kernel id, so each of its options keeps its
   option id, scale and usage counts (or stays pruned).
4. An unmatched new kernel (a new region, or more kernels than before) gets a fresh
   kernel id; its options are new, with scale 1.
5. An unmatched old kernel is retired: its options leave the active set (their ids
   remain resolvable as pointers, and their policies are kept).
6. New policies are appended with the next policy ids and get one new option (scale 1)
   with every current kernel.

Policy ids are positions in the lifelong sequence of frozen policies ``pi_0, pi_1, ...``;
policies are never removed, because later policies may point to them.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from ilpss._io import check_inside, load_archive, save_npz_atomic, sha256_file
from ilpss._schema import FLOAT, INTEGER, SAVED_INTEGERS, ArchiveSchema, Field, MappingOf
from ilpss.kernels import (
    KernelModel,
    SharedKernelModel,
    kernel_parameters,
    match_kernels,
)
from ilpss.policy import FrozenPolicy
from ilpss.tiles import TileCoder
from soccer_drill.constraints import Integer, NoneOr, Real, Text, check_fields, from_json, is_int

__all__ = [
    "LibraryState",
    "OptionLibrary",
    "OptionSettings",
]

LIBRARY_SCHEMA = "ilpss.options/1"
_KERNELS_FILE = "kernels.npz"
_LIBRARY_FILE = "library.npz"


# --------------------------------------------------------------------------- reports
@dataclass(frozen=True)
class OptionInfo:
    """Public description of one active option."""

    option_id: int
    kernel_id: int
    kernel_index: int
    policy_id: int
    scale: float
    uses: int
    trial_uses: int


@dataclass(frozen=True)
class TrialReport:
    """What :meth:`OptionLibrary.end_trial` did."""

    used: tuple[int, ...]
    discounted: tuple[int, ...]
    pruned: tuple[int, ...]


@dataclass(frozen=True)
class RefitReport:
    """What :meth:`OptionLibrary.refit` did (kernel ids are stable ids, not indices)."""

    matched: dict[int, tuple[int, float]]  # new kernel index -> (old kernel index, distance)
    kept_kernel_ids: tuple[int, ...]
    new_kernel_ids: tuple[int, ...]
    retired_kernel_ids: tuple[int, ...]
    new_policy_ids: tuple[int, ...]
    kept_option_ids: tuple[int, ...]
    new_option_ids: tuple[int, ...]
    retired_option_ids: tuple[int, ...]


# --------------------------------------------------------------------------- settings
OPTION_CONSTRAINTS = {
    "discount": Real(0.0, 1.0, low_open=True),
    "prune_threshold": Real(0.0, 1.0, high_open=True),
    "max_depth": Integer(1, 1000),
    "max_match_distance": NoneOr(Real(0.0)),
    "continuation_exponent": Real(0.0),
    "used_min_decisions": Integer(1, 1_000_000),
}
"""What each field of :class:`OptionSettings` allows."""


@dataclass(frozen=True)
class OptionSettings:
    """How an option library discounts, prunes, follows pointers, keeps identities across
    refits, and how long its options run. Held by :class:`~ilpss.lifelong.LifelongConfig`
    as ``library`` and kept by every library made from one (refits, saves, loads)."""

    discount: float = 0.5
    """Factor in (0, 1] applied to the scale of every offered, unused option per trial
    (1: no discounting, so nothing is ever pruned)."""
    prune_threshold: float = 0.1
    """Options whose scale falls below this are pruned (0: only a scale discounted to
    exactly 0, by underflow, is pruned)."""
    max_depth: int = 4
    """Policies consulted at most when following option pointers."""
    max_match_distance: float | None = 3.0
    """Largest Bhattacharyya distance at which a refit kernel keeps an old identity
    (``None``: every assigned pair)."""
    continuation_exponent: float = 1.0
    """A running option continues with probability ``K_k(s) ** continuation_exponent``:
    1 is the paper's rule; below 1 options run longer (0: until the episode ends), an
    ablation of option duration. Initiation is unchanged."""
    used_min_decisions: int = 1
    """An option counts as used by the learnt policy (and escapes the discount) when the
    greedy rollouts ran it for at least this many decisions in all (1: any start, the
    paper's rule)."""

    def __post_init__(self) -> None:
        check_fields("OptionSettings", self, OPTION_CONSTRAINTS)
        # Plain floats and ints, so that saved records do not depend on how they came.
        for name in ("discount", "prune_threshold", "continuation_exponent"):
            object.__setattr__(self, name, float(getattr(self, name)))
        object.__setattr__(self, "max_depth", int(self.max_depth))
        object.__setattr__(self, "used_min_decisions", int(self.used_min_decisions))
        if self.max_match_distance is not None:
            object.__setattr__(self, "max_match_distance", float(self.max_match_distance))

    @classmethod
    def from_dict(cls, values: Mapping[str, Any]) -> OptionSettings:
        """Settings from a JSON object (``dataclasses.asdict``'s); unknown keys refused."""
        return from_json(cls, values)


@dataclass(frozen=True)
class LibraryState:
    """The identities, scales and usage counts of a library's options: what a fresh
    library starts from (:meth:`initial`), a refit carries over and a load restores.

    Attributes
    ----------
    kernel_ids : numpy.ndarray of int64, shape (K,)
        Stable id of each kernel of the kernel model.
    registry : mapping of int to (kernel_id, policy_id)
        Every option id ever issued.
    option_ids : numpy.ndarray of int64
        Active option ids, increasing.
    scales, uses, trial_uses : numpy.ndarray
        Per active option.
    pruned : frozenset of (kernel_id, policy_id)
    next_option_id, next_kernel_id : int
        The ids the next new option and kernel get.
    """

    kernel_ids: np.ndarray
    registry: Mapping[int, tuple[int, int]]
    option_ids: np.ndarray
    scales: np.ndarray
    uses: np.ndarray
    trial_uses: np.ndarray
    pruned: frozenset[tuple[int, int]]
    next_option_id: int
    next_kernel_id: int

    @classmethod
    def initial(cls, n_kernels: int, n_policies: int) -> LibraryState:
        """Every (kernel, policy) pair a new option with scale 1, kernel-major."""
        pairs = [(k, p) for k in range(n_kernels) for p in range(n_policies)]
        return cls(
            kernel_ids=np.arange(n_kernels, dtype=np.int64),
            registry={i: (k, p) for i, (k, p) in enumerate(pairs)},
            option_ids=np.arange(len(pairs), dtype=np.int64),
            scales=np.ones(len(pairs)),
            uses=np.zeros(len(pairs), dtype=np.int64),
            trial_uses=np.zeros(len(pairs), dtype=np.int64),
            pruned=frozenset(),
            next_option_id=len(pairs),
            next_kernel_id=n_kernels,
        )

    def check(self, n_kernels: int, n_policies: int) -> None:
        """Refuse a state that cannot belong to a model of ``n_kernels`` kernels and
        ``n_policies`` policies (``ValueError`` saying what is wrong)."""
        kernel_ids = [int(k) for k in self.kernel_ids]
        if len(kernel_ids) != n_kernels or len(set(kernel_ids)) != len(kernel_ids):
            raise ValueError("kernel ids do not match the kernel model")
        oids = [int(o) for o in self.option_ids]
        if oids != sorted(set(oids)):
            raise ValueError("active option ids must be unique and increasing")
        n = len(oids)
        if not (len(self.scales) == len(self.uses) == len(self.trial_uses) == n):
            raise ValueError("scales and counts must have one entry per active option")
        for o in oids:
            if o not in self.registry:
                raise ValueError(f"active option {o} is not in the registry")
            kid, pid = self.registry[o]
            if kid not in kernel_ids:
                raise ValueError(f"active option {o} refers to a kernel id not in the model")
            if (kid, pid) in self.pruned:
                raise ValueError(f"active option {o} is marked as pruned")
        for _, pid in self.registry.values():
            if not 0 <= pid < n_policies:
                raise ValueError(f"registry refers to policy {pid} of {n_policies}")
        scales = np.asarray(self.scales)
        if not (np.isfinite(scales).all() and (scales > 0).all() and (scales <= 1).all()):
            raise ValueError("scales must be finite and in (0, 1]")
        if (np.asarray(self.uses) < 0).any() or (np.asarray(self.trial_uses) < 0).any():
            raise ValueError("usage counts must be non-negative")
        next_o, next_k = self.next_option_id, self.next_kernel_id
        if not (is_int(next_o) and is_int(next_k)):
            raise ValueError("next_option_id/next_kernel_id must be ints")
        if self.registry and next_o <= max(self.registry):
            raise ValueError("next_option_id must exceed every issued option id")
        if kernel_ids and next_k <= max(kernel_ids):
            raise ValueError("next_kernel_id must exceed every kernel id")


_ID = Integer(0, SAVED_INTEGERS.high)  # ids become int64 array values
LIBRARY_ARCHIVE = ArchiveSchema(
    LIBRARY_SCHEMA,
    {
        "kernel_ids": Field(("K",), INTEGER, each=_ID),
        "option_ids": Field(("n",), INTEGER, each=_ID),
        "scales": Field(("n",), FLOAT, each=Real(0.0, 1.0, low_open=True)),
        "uses": Field(("n",), INTEGER, each=Integer(0)),
        "trial_uses": Field(("n",), INTEGER, each=Integer(0)),
        **{f"registry_{ids}": Field(("r",), INTEGER, each=_ID)
           for ids in ("option_ids", "kernel_ids", "policy_ids")},
        **{f"pruned_{ids}": Field(("q",), INTEGER, each=_ID)
           for ids in ("kernel_ids", "policy_ids")},
    },
    record={
        "n_policies": Integer(0),
        **OPTION_CONSTRAINTS,
        "next_option_id": _ID,
        "next_kernel_id": _ID,
        "files": MappingOf(Text(), Text()),
    },
)
"""What :meth:`OptionLibrary.save` writes: K kernels, n active options, r issued option
ids (the registry), q pruned (kernel, policy) pairs; the other files' digests."""


# --------------------------------------------------------------------------- library
class OptionLibrary:
    """The options ``o_k^i`` of one kernel model and all frozen policies learnt so far.

    Parameters
    ----------
    kernel_model : KernelModel
        A fitted model with ``membership``, ``n_components``, ``means_``, ``covariances_``.
    policies : sequence of FrozenPolicy
        Policies ``pi_0 .. pi_{n-1}``; policy id = position. In a fresh library they
        must not refer to options (there are none yet); use :meth:`refit` to add
        policies learnt with options.
    settings : OptionSettings, optional
        Discounting, pruning, pointers, matching and option duration (default:
        :class:`OptionSettings`'s defaults). Kept by :meth:`refit`, saved and loaded.
    state : LibraryState, optional
        Identities, scales and counts to continue from (what :meth:`refit` and
        :meth:`load` give); by default :meth:`LibraryState.initial`, every (kernel,
        policy) pair a new option with scale 1. It is checked against the model and the
        policies.

    Attributes
    ----------
    option_ids : numpy.ndarray of int64
        Active option ids, increasing; this is the order in which a learner offers them.
    scales, uses, trial_uses : numpy.ndarray
        Per active option, aligned with ``option_ids``.
    kernel_ids : numpy.ndarray of int64, shape (K,)
        Stable id of each kernel of ``kernel_model``.
    policies : tuple of FrozenPolicy
    registry : mapping of int to (kernel_id, policy_id)
        Every option id ever issued (for pointers), active or not.
    pruned : frozenset of (kernel_id, policy_id)
    settings : OptionSettings
    refit_report : RefitReport or None
        Set on libraries made by :meth:`refit`.
    version : int
        Incremented whenever the active set changes (pruning), for caches.
    """

    def __init__(
        self,
        kernel_model: KernelModel,
        policies: Sequence[FrozenPolicy],
        settings: OptionSettings | None = None,
        *,
        state: LibraryState | None = None,
    ) -> None:
        settings = OptionSettings() if settings is None else settings
        if not isinstance(settings, OptionSettings):
            raise TypeError(f"settings must be an OptionSettings, got {type(settings).__name__}")
        policies = tuple(policies)
        self._check_model(kernel_model, policies)
        n_kernels = int(kernel_model.n_components)
        if state is None:
            state = LibraryState.initial(n_kernels, len(policies))
        else:
            state.check(n_kernels, len(policies))
        self._check_policies(policies, state.registry)
        self.settings = settings
        self.kernel_model = kernel_model
        self.n_kernels = n_kernels
        self.n_features = int(np.asarray(kernel_model.means_).shape[1])
        self.policies = policies
        self.n_primitive = policies[0].n_primitive if policies else None
        self.kernel_ids = np.asarray(state.kernel_ids, dtype=np.int64)
        self.registry = dict(state.registry)
        self.option_ids = np.asarray(state.option_ids, dtype=np.int64)
        self.scales = np.asarray(state.scales, dtype=np.float64)
        self.uses = np.asarray(state.uses, dtype=np.int64)
        self.trial_uses = np.asarray(state.trial_uses, dtype=np.int64)
        self.pruned = frozenset(state.pruned)
        self._next_option_id = int(state.next_option_id)
        self._next_kernel_id = int(state.next_kernel_id)
        self.refit_report: RefitReport | None = None
        self._reindex()

    # ------------------------------------------------------------ construction
    @staticmethod
    def _check_model(model: KernelModel, policies: Sequence[FrozenPolicy]) -> None:
        if not callable(getattr(model, "membership", None)):
            raise TypeError("kernel_model must have a membership(X) method")
        means, _ = kernel_parameters(model)
        K = getattr(model, "n_components", None)
        if not is_int(K) or K != means.shape[0]:
            raise ValueError(
                f"kernel_model.n_components ({K!r}) must equal the number of means "
                f"({means.shape[0]})"
            )
        for i, pol in enumerate(policies):
            if pol.tile_coder.n_features != means.shape[1]:
                raise ValueError(
                    f"policy {i} has {pol.tile_coder.n_features} features but the kernels "
                    f"have {means.shape[1]}"
                )

    @staticmethod
    def _check_policies(
        policies: Sequence[FrozenPolicy], registry: Mapping[int, tuple[int, int]]
    ) -> None:
        if not policies:
            return
        n_primitive = None
        for i, pol in enumerate(policies):
            if not isinstance(pol, FrozenPolicy):
                raise TypeError(
                    f"policy {i} must be a FrozenPolicy (use LinearPolicy.freeze()), "
                    f"got {type(pol).__name__}"
                )
            if n_primitive is None:
                n_primitive = pol.n_primitive
            elif pol.n_primitive != n_primitive:
                raise ValueError(
                    f"policy {i} has {pol.n_primitive} primitive actions, policy 0 has "
                    f"{n_primitive}"
                )
            for oid in pol.option_ids:
                if oid not in registry:
                    raise ValueError(
                        f"policy {i} refers to unknown option id {oid}; policies learnt "
                        "with options must be added to the library that issued them "
                        "(OptionLibrary.refit)"
                    )

    def _reindex(self) -> None:
        # Bumped whenever the active set changes, so learners can cache positions.
        self.version = getattr(self, "version", 0) + 1
        kindex = {int(kid): k for k, kid in enumerate(self.kernel_ids)}
        self._position = {int(oid): j for j, oid in enumerate(self.option_ids)}
        self.option_kernel = np.array(
            [kindex[self.registry[int(o)][0]] for o in self.option_ids], dtype=np.int64
        )
        self.option_policy = np.array(
            [self.registry[int(o)][1] for o in self.option_ids], dtype=np.int64
        )

    # ------------------------------------------------------------------ queries
    def __len__(self) -> int:
        return int(self.option_ids.shape[0])

    def __contains__(self, option_id: object) -> bool:
        return is_int(option_id) and int(option_id) in self._position

    def options(self) -> list[OptionInfo]:
        """Description of every active option, in offering order."""
        return [
            OptionInfo(
                option_id=int(o),
                kernel_id=int(self.kernel_ids[self.option_kernel[j]]),
                kernel_index=int(self.option_kernel[j]),
                policy_id=int(self.option_policy[j]),
                scale=float(self.scales[j]),
                uses=int(self.uses[j]),
                trial_uses=int(self.trial_uses[j]),
            )
            for j, o in enumerate(self.option_ids)
        ]

    def position(self, option_id: int) -> int:
        """Index of active option ``option_id`` in :attr:`option_ids`."""
        try:
            return self._position[int(option_id)]
        except (KeyError, TypeError, ValueError):
            if is_int(option_id) and int(option_id) in self.registry:
                raise KeyError(
                    f"option id {option_id} is not active (pruned or its kernel retired)"
                ) from None
            raise KeyError(f"unknown option id {option_id!r}") from None

    def positions(self, option_ids: Iterable[int]) -> np.ndarray:
        """Positions of ``option_ids`` in :attr:`option_ids`; -1 for inactive ids."""
        return np.array([self._position.get(int(o), -1) for o in option_ids], dtype=np.int64)

    def scale(self, option_id: int) -> float:
        """Current scale ``c`` of active option ``option_id``."""
        return float(self.scales[self.position(option_id)])

    def _check_state(self, state: np.ndarray) -> np.ndarray:
        x = np.asarray(state, dtype=np.float64)
        if x.shape != (self.n_features,):
            raise ValueError(f"state must have shape ({self.n_features},), got {x.shape}")
        if not np.isfinite(x).all():
            raise ValueError(f"state contains NaN or infinite values: {x}")
        return x

    def membership(self, state: np.ndarray) -> np.ndarray:
        """Kernel memberships ``K_k(s)`` in [0, 1] of one state, shape (K,)."""
        x = self._check_state(state)
        m = np.asarray(self.kernel_model.membership(x), dtype=np.float64).reshape(-1)
        if m.shape != (self.n_kernels,):
            raise ValueError(
                f"kernel_model.membership returned {m.size} values for one state, "
                f"expected {self.n_kernels}"
            )
        if 0.0 <= m.min() and m.max() <= 1.0:  # what np.clip would return, and cheaper
            return m.copy()
        if not np.isfinite(m).all():
            raise ValueError("kernel_model.membership returned NaN or infinity")
        return np.clip(m, 0.0, 1.0)

    def initiation_probabilities(
        self, state: np.ndarray, membership: np.ndarray | None = None
    ) -> np.ndarray:
        """``c * K_k(s)`` for every active option, shape (n_options,)."""
        m = self.membership(state) if membership is None else membership
        return np.minimum(self.scales * m[self.option_kernel], 1.0)

    def available(
        self,
        state: np.ndarray,
        rng: np.random.Generator,
        membership: np.ndarray | None = None,
    ) -> np.ndarray:
        """Sample which options may start at ``state``: mask of shape (n_options,).

        Draws exactly ``n_options`` uniforms from ``rng``. Pass ``membership`` (from
        :meth:`membership`) to avoid evaluating the kernels twice at one state.
        """
        p = self.initiation_probabilities(state, membership)
        return rng.random(p.shape[0]) < p

    def memberships(self, membership: np.ndarray) -> np.ndarray:
        """``K_k(s)`` of every active option's kernel, shape (n_options,), from the kernel
        memberships of one state (:meth:`membership`)."""
        return membership[self.option_kernel]

    def continuation_probabilities(self, membership: np.ndarray) -> np.ndarray:
        """``K_k(s) ** continuation_exponent`` of every active option (its scale does not
        apply), shape (n_options,), from the kernel memberships of one state."""
        e = self.settings.continuation_exponent
        if e == 1.0:
            return membership[self.option_kernel]
        # One power per kernel, with Python's floats: NumPy's vectorised power may differ
        # from it in the last bit, and continuation must not depend on how it is asked.
        per_kernel = np.array([float(v) ** e for v in membership])
        return per_kernel[self.option_kernel]

    def continuation_probability(
        self, option_id: int, state: np.ndarray, membership: np.ndarray | None = None
    ) -> float:
        """:meth:`continuation_probabilities` of active option ``option_id`` at ``state``."""
        j = self.position(option_id)
        m = self.membership(state) if membership is None else membership
        # Of one kernel only, as continuation_probabilities computes it.
        value = float(m[self.option_kernel[j]])
        e = self.settings.continuation_exponent
        return value if e == 1.0 else value**e

    def continues(
        self,
        option_id: int,
        state: np.ndarray,
        rng: np.random.Generator,
        membership: np.ndarray | None = None,
    ) -> bool:
        """Sample whether running option ``option_id`` continues at ``state`` (one draw)."""
        return bool(rng.random() < self.continuation_probability(option_id, state, membership))

    # ---------------------------------------------------------------- execution
    def policy_of(self, option_id: int) -> int:
        """Policy id of any option ever issued (active or not)."""
        try:
            return self.registry[int(option_id)][1]
        except (KeyError, TypeError, ValueError):
            raise KeyError(f"unknown option id {option_id!r}") from None

    def resolve(
        self,
        option_id: int,
        state: np.ndarray,
        rng: np.random.Generator,
        tiles: dict[TileCoder, np.ndarray] | None = None,
    ) -> tuple[int, tuple[int, ...]]:
        """Primitive action option ``option_id`` takes at ``state``, following pointers.

        Parameters
        ----------
        option_id : int
            Any option id ever issued.
        state : array_like, shape (n_features,)
        rng : numpy.random.Generator
            Breaks ties between equal action values.
        tiles : dict, optional
            Cache ``{tile_coder: active tiles of state}``, filled as needed.

        Returns
        -------
        action : int
            A primitive action.
        path : tuple of int
            Ids of the policies consulted, the option's own first.
        """
        x = self._check_state(state)
        if tiles is None:
            tiles = {}
        pid = self.policy_of(option_id)
        path = [pid]
        max_depth = self.settings.max_depth
        for depth in range(1, max_depth + 1):
            pol = self.policies[pid]
            active = tiles.get(pol.tile_coder)
            if active is None:
                active = tiles[pol.tile_coder] = pol.tile_coder.active(x)
            if depth == max_depth:
                # At the bound: best primitive of this policy.
                return pol.greedy_from_tiles(active, rng, primitive_only=True), tuple(path)
            c = pol.greedy_from_tiles(active, rng)
            if c < pol.n_primitive:
                return c, tuple(path)
            pid = self.policy_of(pol.option_ids[c - pol.n_primitive])
            path.append(pid)
        raise AssertionError("unreachable")  # pragma: no cover

    def act(
        self,
        option_id: int,
        state: np.ndarray,
        rng: np.random.Generator,
        tiles: dict[TileCoder, np.ndarray] | None = None,
    ) -> int:
        """Primitive action of option ``option_id`` at ``state`` (see :meth:`resolve`)."""
        return self.resolve(option_id, state, rng, tiles)[0]

    # -------------------------------------------------------- usage, discounting
    def record_use(self, option_id: int, n: int = 1) -> None:
        """Count ``n`` starts of active option ``option_id`` (statistics only)."""
        j = self.position(option_id)
        self.uses[j] += n
        self.trial_uses[j] += n

    def end_trial(self, used: Iterable[int], offered: Iterable[int] | None = None) -> TrialReport:
        """Apply discounting and pruning at the end of a trial.

        Parameters
        ----------
        used : iterable of int
            Option ids the learnt policy used in this trial. Ids that are no longer
            active are ignored; ids never issued raise ``KeyError``.
        offered : iterable of int, optional
            Option ids offered to the learner in this trial (default: all active).
            Only offered options are discounted.

        Returns
        -------
        TrialReport
            The used, discounted and pruned option ids.
        """
        used_set = {self._known(o) for o in used}
        if offered is None:
            offered_set = {int(o) for o in self.option_ids}
        else:
            offered_set = {self._known(o) for o in offered}
        discounted: list[int] = []
        keep = np.ones(len(self), dtype=bool)
        for j, oid in enumerate(int(o) for o in self.option_ids):
            if oid in offered_set and oid not in used_set:
                self.scales[j] *= self.settings.discount
                discounted.append(oid)
                # A scale that underflowed to 0 never lets the option start again, and
                # a library holds scales in (0, 1]: pruned whatever the threshold.
                if self.scales[j] < self.settings.prune_threshold or self.scales[j] == 0.0:
                    keep[j] = False
        pruned_ids = tuple(int(o) for o in self.option_ids[~keep])
        self.pruned = self.pruned | {self.registry[o] for o in pruned_ids}
        self.option_ids = self.option_ids[keep]
        self.scales = self.scales[keep]
        self.uses = self.uses[keep]
        self.trial_uses = np.zeros(int(keep.sum()), dtype=np.int64)
        self._reindex()
        return TrialReport(
            used=tuple(sorted(used_set)), discounted=tuple(discounted), pruned=pruned_ids
        )

    def only(self, pairs: Iterable[tuple[int, int]]) -> OptionLibrary:
        """A library offering only the options of ``pairs`` (``(kernel position, policy
        id)``), under their ids in this library, pruned ones included (with scale 1), so
        that the policies' pointers and this library's :meth:`end_trial` still read them.
        What an oracle offers a task whose regions and their sources it knows.

        Raises
        ------
        ValueError
            If a pair names a kernel or policy this library does not have.
        """
        wanted: set[tuple[int, int]] = set()
        for k, p in pairs:
            if not (0 <= int(k) < self.n_kernels and 0 <= int(p) < len(self.policies)):
                raise ValueError(
                    f"OptionLibrary.only: pair {(k, p)!r} is not a (kernel position in "
                    f"[0, {self.n_kernels}), policy id in [0, {len(self.policies)})) pair"
                )
            wanted.add((int(self.kernel_ids[int(k)]), int(p)))
        latest = {pair: oid for oid, pair in sorted(self.registry.items())}
        missing = sorted(wanted - latest.keys())
        if missing:
            raise ValueError(f"OptionLibrary.only: no option was ever issued for the "
                             f"(kernel id, policy id) pairs {missing}")
        ids = np.array(sorted(latest[pair] for pair in wanted), dtype=np.int64)
        at = [self._position.get(int(o)) for o in ids]
        state = LibraryState(
            kernel_ids=self.kernel_ids.copy(), registry=dict(self.registry), option_ids=ids,
            scales=np.array([1.0 if j is None else self.scales[j] for j in at]),
            uses=np.array([0 if j is None else self.uses[j] for j in at], dtype=np.int64),
            trial_uses=np.zeros(len(ids), dtype=np.int64),
            pruned=self.pruned - wanted, next_option_id=self._next_option_id,
            next_kernel_id=self._next_kernel_id,
        )
        return OptionLibrary(self.kernel_model, self.policies, self.settings, state=state)

    def undo_point(self) -> Callable[[], None]:
        """A function that puts the options back as they are now: active set, scales,
        usage counts and pruned pairs (what :meth:`end_trial` and :meth:`record_use`
        change), for a caller whose later step fails. Caches keyed on :attr:`version`
        are invalidated, not reused."""
        saved = dict(vars(self))
        arrays = {k: v.copy() for k, v in saved.items() if isinstance(v, np.ndarray)}

        def undo() -> None:
            version = self.version
            for k, values in arrays.items():
                if saved[k].flags.writeable:  # in place: end_trial scales its array so
                    saved[k][...] = values
                else:
                    saved[k] = values
            vars(self).clear()
            vars(self).update(saved)
            self.version = version
            self._reindex()

        return undo

    def _known(self, option_id: object) -> int:
        if not is_int(option_id) or int(option_id) not in self.registry:
            raise KeyError(f"unknown option id {option_id!r}")
        return int(option_id)

    # ------------------------------------------------------------------- refit
    def refit(
        self, kernel_model: KernelModel, new_policies: Sequence[FrozenPolicy] = ()
    ) -> OptionLibrary:
        """A new library on ``kernel_model`` with ``new_policies`` appended.

        Kernel and option identities carry over by the rule in the module docstring.
        ``self`` is left unchanged. The result's :attr:`refit_report` says what happened.
        """
        new_policies = tuple(new_policies)
        policies = self.policies + new_policies
        self._check_model(kernel_model, policies)
        self._check_policies(policies, self.registry)
        if self.n_primitive is not None and new_policies:
            if new_policies[0].n_primitive != self.n_primitive:
                raise ValueError("new policies have a different number of primitive actions")

        matched = match_kernels(self.kernel_model, kernel_model,
                                self.settings.max_match_distance)
        kernel_ids, next_kid = self._carried_kernel_ids(matched, int(kernel_model.n_components))
        state, kept_oids, new_oids = self._carried_options(kernel_ids, next_kid, len(policies))
        lib = OptionLibrary(kernel_model, policies, self.settings, state=state)
        kept_kids = tuple(int(self.kernel_ids[matched[j][0]]) for j in sorted(matched))
        lib.refit_report = RefitReport(
            matched=dict(matched),
            kept_kernel_ids=kept_kids,
            new_kernel_ids=tuple(range(self._next_kernel_id, next_kid)),
            retired_kernel_ids=tuple(sorted(set(map(int, self.kernel_ids)) - set(kept_kids))),
            new_policy_ids=tuple(range(len(self.policies), len(policies))),
            kept_option_ids=tuple(kept_oids),
            new_option_ids=tuple(new_oids),
            retired_option_ids=tuple(sorted(set(map(int, self.option_ids)) - set(kept_oids))),
        )
        return lib

    def _carried_kernel_ids(
        self, matched: Mapping[int, tuple[int, float]], n_kernels: int
    ) -> tuple[np.ndarray, int]:
        """The ids of a new model's ``n_kernels`` kernels (a matched kernel keeps its old
        kernel's id, the others get fresh ones, in index order), and the next fresh id."""
        next_kid = self._next_kernel_id
        kernel_ids = np.empty(n_kernels, dtype=np.int64)
        for j in range(n_kernels):
            if j in matched:
                kernel_ids[j] = self.kernel_ids[matched[j][0]]
            else:
                kernel_ids[j] = next_kid
                next_kid += 1
        return kernel_ids, next_kid

    def _carried_options(
        self, kernel_ids: np.ndarray, next_kid: int, n_policies: int
    ) -> tuple[LibraryState, list[int], list[int]]:
        """The state of a refit library on kernels ``kernel_ids`` and ``n_policies``
        policies: every (kernel, policy) pair not pruned, an active option keeping its id,
        scale and counts, a new one a fresh id and scale 1; and the kept and new ids."""
        by_pair = {self.registry[int(o)]: j for j, o in enumerate(self.option_ids)}
        registry = dict(self.registry)
        next_oid = self._next_option_id
        ids, scales, uses, trial_uses = [], [], [], []
        kept_oids, new_oids = [], []
        # Kept options first, in id order, then new ones: ids stay increasing.
        pairs = [(int(kid), p) for kid in kernel_ids for p in range(n_policies)]
        for pair in sorted(pairs, key=lambda pr: (pr not in by_pair, pr)):
            if pair in self.pruned:
                continue
            if pair in by_pair:
                j = by_pair[pair]
                oid = int(self.option_ids[j])
                ids.append(oid)
                scales.append(self.scales[j])
                uses.append(self.uses[j])
                trial_uses.append(self.trial_uses[j])
                kept_oids.append(oid)
            else:
                oid = next_oid
                next_oid += 1
                registry[oid] = pair
                ids.append(oid)
                scales.append(1.0)
                uses.append(0)
                trial_uses.append(0)
                new_oids.append(oid)
        order = np.argsort(ids, kind="stable")
        state = LibraryState(
            kernel_ids=kernel_ids,
            registry=registry,
            option_ids=np.asarray(ids, dtype=np.int64)[order],
            scales=np.asarray(scales, dtype=np.float64)[order],
            uses=np.asarray(uses, dtype=np.int64)[order],
            trial_uses=np.asarray(trial_uses, dtype=np.int64)[order],
            pruned=self.pruned,
            next_option_id=next_oid,
            next_kernel_id=next_kid,
        )
        return state, kept_oids, new_oids

    # ------------------------------------------------------------- persistence
    def save(self, directory: str | os.PathLike[str]) -> None:
        """Save the library into ``directory`` (created if needed).

        Writes ``kernels.npz`` (by the kernel model's own ``save``), one
        ``policy_<id>.npz`` per policy, then ``library.npz`` last: options, scales,
        counts, ids, the registry, the pruned pairs, the parameters, and the SHA-256 of
        every other file, so that a load detects files mixed from different saves.
        Every file is written atomically.
        """
        save = getattr(self.kernel_model, "save", None)
        if not callable(save):
            raise TypeError(
                f"the kernel model ({type(self.kernel_model).__name__}) has no save(path) "
                "method, so the library cannot be saved"
            )
        root = Path(directory)
        root.mkdir(parents=True, exist_ok=True)
        save(root / _KERNELS_FILE)
        digests = {_KERNELS_FILE: sha256_file(root / _KERNELS_FILE)}
        for pid, pol in enumerate(self.policies):
            name = f"policy_{pid}.npz"
            pol.save(root / name)
            digests[name] = sha256_file(root / name)
        reg = sorted(self.registry.items())
        pruned = sorted(self.pruned)
        arrays = {
            "kernel_ids": self.kernel_ids,
            "option_ids": self.option_ids,
            "scales": self.scales,
            "uses": self.uses,
            "trial_uses": self.trial_uses,
            "registry_option_ids": np.array([o for o, _ in reg], dtype=np.int64),
            "registry_kernel_ids": np.array([k for _, (k, _) in reg], dtype=np.int64),
            "registry_policy_ids": np.array([p for _, (_, p) in reg], dtype=np.int64),
            "pruned_kernel_ids": np.array([k for k, _ in pruned], dtype=np.int64),
            "pruned_policy_ids": np.array([p for _, p in pruned], dtype=np.int64),
        }
        meta = {
            "schema": LIBRARY_SCHEMA,
            "n_policies": len(self.policies),
            **asdict(self.settings),
            "next_option_id": self._next_option_id,
            "next_kernel_id": self._next_kernel_id,
            "files": digests,
        }
        save_npz_atomic(root / _LIBRARY_FILE, arrays, meta)

    @classmethod
    def load(
        cls,
        directory: str | os.PathLike[str],
        kernel_loader: Callable[[Path], KernelModel] | None = None,
    ) -> OptionLibrary:
        """Load a library saved by :meth:`save`.

        Parameters
        ----------
        directory : path
        kernel_loader : callable, optional
            ``path -> kernel model``; default ``ilpss.kernels.SharedKernelModel.load``.

        Raises
        ------
        ValueError
            If any file is missing its schema, was modified, or does not belong to the
            same save, or the contents are inconsistent.
        """
        root = Path(directory)
        lib_path = root / _LIBRARY_FILE
        where = os.fspath(lib_path)
        checked = load_archive(lib_path, LIBRARY_ARCHIVE)
        arrays, meta = checked.arrays, checked.meta
        n_policies = meta["n_policies"]
        _check_saved_files(root, meta["files"], n_policies, where)
        if kernel_loader is None:
            kernel_loader = SharedKernelModel.load
        model = kernel_loader(root / _KERNELS_FILE)
        policies = tuple(FrozenPolicy.load(root / f"policy_{p}.npz") for p in range(n_policies))
        try:
            settings = OptionSettings.from_dict(
                {f.name: meta[f.name] for f in fields(OptionSettings)})
            return cls(model, policies, settings, state=_saved_state(arrays, meta))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{where}: inconsistent library: {exc}") from exc

    def __repr__(self) -> str:
        return (
            f"OptionLibrary(n_kernels={self.n_kernels}, n_policies={len(self.policies)}, "
            f"n_options={len(self)}, pruned={len(self.pruned)})"
        )


def _check_saved_files(root: Path, files: Mapping[str, str], n_policies: int,
                       where: str) -> None:
    """The files a library record lists are those of ``n_policies`` policies and the
    kernels, inside ``root``, each with the digest it was saved with."""
    if n_policies != len(files) - 1:  # bounded by the record before anything is built
        raise ValueError(f"{where}: n_policies is {n_policies}, but the record lists "
                         f"{len(files)} files (the kernels and one per policy)")
    expected = {_KERNELS_FILE} | {f"policy_{p}.npz" for p in range(n_policies)}
    if set(files) != expected:
        raise ValueError(
            f"{where}: meta lists files {sorted(files)}, expected {sorted(expected)}"
        )
    for name, digest in files.items():
        path = check_inside(root, root / name, "option library folder")
        if not path.is_file():
            raise ValueError(f"{root}: missing file {name}")
        if sha256_file(path) != digest:
            raise ValueError(
                f"{path}: content differs from the file saved with {where} "
                "(modified, or from another save)"
            )


def _saved_state(arrays: Mapping[str, np.ndarray], meta: Mapping[str, Any]) -> LibraryState:
    """The :class:`LibraryState` a library archive holds (checked by the library)."""
    registry = {
        int(o): (int(k), int(p))
        for o, k, p in zip(arrays["registry_option_ids"], arrays["registry_kernel_ids"],
                           arrays["registry_policy_ids"], strict=True)
    }
    if len(registry) != arrays["registry_option_ids"].shape[0]:
        raise ValueError("duplicate option ids in the registry")
    pruned = frozenset(
        (int(k), int(p))
        for k, p in zip(arrays["pruned_kernel_ids"], arrays["pruned_policy_ids"], strict=True)
    )
    return LibraryState(
        kernel_ids=arrays["kernel_ids"].astype(np.int64),
        registry=registry,
        option_ids=arrays["option_ids"].astype(np.int64),
        scales=arrays["scales"].astype(np.float64),
        uses=arrays["uses"].astype(np.int64),
        trial_uses=arrays["trial_uses"].astype(np.int64),
        pruned=pruned,
        next_option_id=meta["next_option_id"],
        next_kernel_id=meta["next_kernel_id"],
    )
