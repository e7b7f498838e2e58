"""Linear action-value functions over tiles, and frozen policies.

A policy's *choices* are the primitive actions ``0 .. n_primitive - 1`` followed by the
options that were offered to it when it was learnt, identified by their stable option
ids (``option_ids``). Choice ``n_primitive + j`` is option ``option_ids[j]``. Keeping the
ids, not positions in some library, is what lets a policy learnt in one trial be
executed later as an option whose greedy choices point to older policies
(see :mod:`ilpss.options`).

* :class:`LinearPolicy` is the learner's mutable ``Q(s, c) = sum(weights[c, tiles(s)])``.
* :class:`FrozenPolicy` is an immutable snapshot (read-only weights), which is what
  options execute and what is saved. :meth:`LinearPolicy.freeze` makes one.

Ties between equal action values are broken uniformly at random with a caller-supplied
:class:`numpy.random.Generator`, as keepaway's ``argmaxQ`` does, so behaviour is
reproducible from a seed. Saved files are ``.npz`` archives without pickles plus a JSON
record (schema ``ilpss.policy/1``), written atomically; see :mod:`ilpss._io`.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Self

import numpy as np

from ilpss._io import load_archive, save_npz_atomic
from ilpss._schema import FLOAT, INTEGER, ArchiveSchema, Field
from ilpss.tiles import TileCoder
from soccer_drill.constraints import Integer, Real, check, is_int

__all__ = [
    "FrozenPolicy",
    "LinearPolicy",
    "epsilon_greedy_choice",
    "greedy_choice",
]

POLICY_SCHEMA = "ilpss.policy/1"
POLICY_ARCHIVE = ArchiveSchema(
    POLICY_SCHEMA,
    {
        "weights": Field(("C", "W"), FLOAT),
        "option_ids": Field((None,), INTEGER),
        "tiles_low": Field(("d",), FLOAT),
        "tiles_high": Field(("d",), FLOAT),
        "tiles_widths": Field(("d",), FLOAT),
        "tiles_n_tilings": Field((), INTEGER),
    },
    record={"n_primitive": Integer(1)},
)
"""What a policy's ``save`` writes: C choices of W weights each, and its tile coder over d
features (whose values the tile coder and the policy check themselves)."""
EPSILON = Real(0.0, 1.0)
"""What an exploration rate allows (the learners' ``epsilon`` setting is checked with it)."""


def greedy_choice(q: np.ndarray, rng: np.random.Generator, mask: np.ndarray | None = None) -> int:
    """Index of the largest value in ``q`` (among ``mask``), ties broken by ``rng``.

    Parameters
    ----------
    q : numpy.ndarray, shape (n,)
    rng : numpy.random.Generator
        Used only when several choices tie, so a run without ties draws nothing.
    mask : numpy.ndarray of bool, shape (n,), optional
        Allowed choices; at least one must be allowed.

    Returns
    -------
    int
    """
    if mask is not None:
        if not mask.any():
            raise ValueError("no choice is allowed by the mask")
        q = np.where(mask, q, -np.inf)
    best = q.max()
    ties = np.flatnonzero(q == best)
    if ties.shape[0] == 1:
        return int(ties[0])
    return int(ties[rng.integers(ties.shape[0])])


def epsilon_greedy_choice(
    q: np.ndarray, rng: np.random.Generator, epsilon: float, mask: np.ndarray
) -> tuple[int, bool]:
    """With probability ``epsilon`` a uniform choice among ``mask``, else the greedy one.

    Returns ``(choice, explored)``, ``explored`` telling whether the choice was the random
    one. With ``epsilon = 0`` nothing is drawn but the tie-breaks of :func:`greedy_choice`.
    """
    if epsilon > 0.0 and rng.random() < epsilon:
        allowed = np.flatnonzero(mask)
        return int(allowed[rng.integers(allowed.shape[0])]), True
    return greedy_choice(q, rng, mask), False


def _check_option_ids(option_ids: Sequence[int] | np.ndarray) -> tuple[int, ...]:
    ids = np.asarray(option_ids)
    if ids.size and (ids.ndim != 1 or ids.dtype.kind not in "iu"):
        raise ValueError(f"option_ids must be a 1-D sequence of ints, got {option_ids!r}")
    out = tuple(int(i) for i in ids.reshape(-1))
    if any(i < 0 for i in out):
        raise ValueError(f"option ids must be non-negative, got {out}")
    if len(set(out)) != len(out):
        raise ValueError(f"option ids must be unique, got {out}")
    return out


def _sum_gap(n: int, bound: float) -> float | None:
    """The largest difference between two float64 sums of the same ``n`` numbers of
    magnitude at most ``bound``, added in any two orders (``None`` if a sum may overflow).

    Any order is within ``gamma_n * n * bound`` of the exact sum, with
    ``gamma_n = n u / (1 - n u)`` and ``u = 2 ** -53`` (Higham, *Accuracy and Stability
    of Numerical Algorithms*, section 4.2).
    """
    total = n * bound
    if not total < 1e300:
        return None
    u = 2.0**-53
    return 2.0 * n * u / (1.0 - n * u) * total


class _LinearQ:
    """Shared read-only behaviour of mutable and frozen linear action values."""

    tile_coder: TileCoder
    n_primitive: int
    option_ids: tuple[int, ...]
    weights: np.ndarray

    def _init(
        self,
        tile_coder: TileCoder,
        n_primitive: int,
        option_ids: Sequence[int] | np.ndarray,
        weights: np.ndarray | None,
        initial_value: float,
    ) -> None:
        if not isinstance(tile_coder, TileCoder):
            raise TypeError(f"tile_coder must be a TileCoder, got {type(tile_coder).__name__}")
        if not is_int(n_primitive):
            raise TypeError("n_primitive must be an int")
        if n_primitive < 1:
            raise ValueError(f"n_primitive must be >= 1, got {n_primitive}")
        self.tile_coder = tile_coder
        self.n_primitive = int(n_primitive)
        self.option_ids = _check_option_ids(option_ids)
        shape = (self.n_choices, tile_coder.n_weights)
        if weights is None:
            if not np.isfinite(initial_value):
                raise ValueError("initial_value must be finite")
            # Keepaway initialises weights so that every Q starts at initial_value.
            self._by_tile = np.full(shape[::-1], float(initial_value) / tile_coder.n_active)
        else:
            w = np.asarray(weights, dtype=np.float64)
            if w.shape != shape:
                raise ValueError(f"weights must have shape {shape}, got {w.shape}")
            if not np.isfinite(w).all():
                raise ValueError("weights contain NaN or infinite values")
            self._by_tile = np.array(w.T, order="C")  # always a private copy
        self._choice_of = {oid: self.n_primitive + j for j, oid in enumerate(self.option_ids)}

    # ------------------------------------------------------------ structure
    @property
    def weights(self) -> np.ndarray:
        """The weights, shape (n_choices, n_weights): ``Q(s, c)`` sums row ``c`` at the
        active tiles of ``s``.

        A view of storage kept tile by tile (all the choices' weights of one tile side
        by side), so that the values of every choice at a state are read as
        ``n_active`` short contiguous runs rather than ``n_choices x n_active``
        scattered numbers: that read is what grows with the number of options.
        """
        return self._by_tile.T

    @weights.setter
    def weights(self, value: np.ndarray) -> None:
        w = np.asarray(value, dtype=np.float64)
        if w.shape != self._by_tile.shape[::-1]:
            raise ValueError(f"weights must have shape {self._by_tile.shape[::-1]}, got {w.shape}")
        self._by_tile[...] = w.T

    @property
    def n_choices(self) -> int:
        """Number of choices: primitives plus options."""
        return self.n_primitive + len(self.option_ids)

    def is_option(self, choice: int) -> bool:
        """Whether choice index ``choice`` is an option (not a primitive)."""
        self._check_choice(choice)
        return choice >= self.n_primitive

    def option_id(self, choice: int) -> int:
        """Stable option id of choice ``choice`` (which must be an option)."""
        if not self.is_option(choice):
            raise ValueError(f"choice {choice} is a primitive action, not an option")
        return self.option_ids[choice - self.n_primitive]

    def choice_of_option(self, option_id: int) -> int:
        """Choice index of option ``option_id``; ``KeyError`` if the policy lacks it."""
        try:
            return self._choice_of[int(option_id)]
        except KeyError:
            raise KeyError(
                f"unknown option id {option_id}; this policy knows {self.option_ids}"
            ) from None

    def _check_choice(self, choice: int) -> None:
        if not 0 <= choice < self.n_choices:
            raise ValueError(f"choice {choice} out of range [0, {self.n_choices})")

    # -------------------------------------------------------------- values
    def q_from_tiles(self, active: np.ndarray, choices: np.ndarray | None = None) -> np.ndarray:
        """Action values of every choice given the active tiles of a state.

        Parameters
        ----------
        active : numpy.ndarray of int, shape (n_active,)
            The state's active tiles (:meth:`TileCoder.active`).
        choices : numpy.ndarray of int, optional
            Only the values of these choices, in this order (default: every choice).

        Each value is NumPy's sum of the choice's weights at ``active``, in that order,
        bit for bit the same as ``np.take(weights, active, axis=1).sum(axis=1)``,
        whichever choices are asked for.
        """
        if choices is not None and 4 * len(choices) <= self.n_choices:
            # A few choices: read only their weights, straight into one row per choice.
            flat = active * self.n_choices + np.asarray(choices)[:, None]
            return np.take(self._by_tile.reshape(-1), flat).sum(axis=1)
        by_tile = np.take(self._by_tile, active, axis=0)  # (n_active, n_choices)
        if choices is not None:
            by_tile = by_tile[:, choices]
        # One contiguous row per choice, as np.take(weights, active, axis=1) gives: the
        # same reduction over the same numbers in the same order.
        return np.ascontiguousarray(by_tile.T).sum(axis=1)

    def greedy_from_tiles(
        self, active: np.ndarray, rng: np.random.Generator, primitive_only: bool = False
    ) -> int:
        """:func:`greedy_choice` of :meth:`q_from_tiles` (of the primitives only if
        ``primitive_only``): the same choice, with the same draws from ``rng``.

        Only the choices that may be the best are summed exactly. A sum of the same
        numbers in another order (a matrix-vector product, much cheaper) is within
        ``gap`` of each exact value (:func:`_sum_gap`), so every choice whose exact value
        is the largest has a rough sum within ``2 gap`` of the largest rough sum; when one
        choice alone does, it is the greedy choice, with no tie to break.
        """
        by_tile = np.take(self._by_tile, active, axis=0)  # (n_active, n_choices)
        if primitive_only:
            by_tile = by_tile[:, : self.n_primitive]
        gap = _sum_gap(active.shape[0], self._abs_bound(by_tile))
        if gap is None:
            return greedy_choice(np.ascontiguousarray(by_tile.T).sum(axis=1), rng)
        rough = np.ones(active.shape[0]) @ by_tile
        # 4 gaps rather than 2: room for the rounding of the subtraction.
        near = np.flatnonzero(rough >= rough.max() - 4.0 * gap)
        if near.shape[0] == 1:
            return int(near[0])
        exact = np.ascontiguousarray(by_tile[:, near].T).sum(axis=1)  # as q_from_tiles
        return int(near[greedy_choice(exact, rng)])

    def _abs_bound(self, by_tile: np.ndarray) -> float:
        """A bound on the magnitude of the weights in ``by_tile``."""
        return float(np.abs(by_tile).max())

    def q_values(self, state: np.ndarray) -> np.ndarray:
        """Action values of every choice at ``state``, shape (n_choices,)."""
        return self.q_from_tiles(self.tile_coder.active(state))

    def greedy(
        self,
        state: np.ndarray,
        rng: np.random.Generator,
        mask: np.ndarray | None = None,
        primitive_only: bool = False,
    ) -> int:
        """Greedy choice at ``state``, ties broken by ``rng``.

        Parameters
        ----------
        state : array_like, shape (n_features,)
        rng : numpy.random.Generator
        mask : numpy.ndarray of bool, shape (n_choices,), optional
            Allowed choices (e.g. primitives plus the options that may start here).
        primitive_only : bool, default False
            Restrict the choice to primitive actions.
        """
        q = self.q_values(state)
        mask = self._mask(mask, primitive_only)
        return greedy_choice(q, rng, mask)

    def epsilon_greedy(
        self,
        state: np.ndarray,
        rng: np.random.Generator,
        epsilon: float,
        mask: np.ndarray | None = None,
    ) -> int:
        """With probability ``epsilon`` a uniform allowed choice, else the greedy one
        (:func:`epsilon_greedy_choice` at ``state``)."""
        check("epsilon", epsilon, EPSILON)
        mask = self._mask(mask, False)
        allowed = np.ones(self.n_choices, dtype=bool) if mask is None else mask
        return epsilon_greedy_choice(self.q_values(state), rng, epsilon, allowed)[0]

    def _mask(self, mask: np.ndarray | None, primitive_only: bool) -> np.ndarray | None:
        if mask is not None:
            mask = np.asarray(mask, dtype=bool)
            if mask.shape != (self.n_choices,):
                raise ValueError(f"mask must have shape ({self.n_choices},), got {mask.shape}")
        if primitive_only:
            prim = np.zeros(self.n_choices, dtype=bool)
            prim[: self.n_primitive] = True
            mask = prim if mask is None else mask & prim
        return mask

    # --------------------------------------------------------- persistence
    def save(self, path: str | os.PathLike[str]) -> None:
        """Save weights, option ids and tile coder atomically (no pickles)."""
        arrays = {
            "weights": np.ascontiguousarray(self.weights),
            "option_ids": np.asarray(self.option_ids, dtype=np.int64),
            **self.tile_coder.to_arrays(),
        }
        meta = {"schema": POLICY_SCHEMA, "n_primitive": self.n_primitive}
        save_npz_atomic(path, arrays, meta)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Self:
        """Load a policy saved by :meth:`save` (of either class) as one of this class."""
        coder, n_primitive, option_ids, weights = cls._read(path)
        try:
            return cls(coder, n_primitive, option_ids, weights)
        except (ValueError, TypeError) as exc:
            raise ValueError(f"{os.fspath(path)}: {exc}") from exc

    @staticmethod
    def _read(path: str | os.PathLike[str]) -> tuple[TileCoder, int, np.ndarray, np.ndarray]:
        checked = load_archive(path, POLICY_ARCHIVE)
        arrays, n_primitive = checked.arrays, checked.meta["n_primitive"]
        where = os.fspath(path)
        try:
            coder = TileCoder.from_arrays(arrays)
        except (ValueError, TypeError) as exc:
            raise ValueError(f"{where}: invalid tile coder: {exc}") from exc
        # A value sums n_active weights: a saved policy's must not overflow (weights of
        # 1e308 give infinite values). Sums beyond 1e300, far past any return, only come
        # from a learner that diverged.
        bound = float(np.abs(arrays["weights"]).max(initial=0.0))
        if np.isfinite(bound) and _sum_gap(coder.n_active, bound) is None:
            raise ValueError(
                f"{where}: weights up to {bound:g} in magnitude: a value sums "
                f"{coder.n_active} of them, which float64 cannot hold (the values would be "
                "infinite)"
            )
        return coder, n_primitive, arrays["option_ids"], arrays["weights"]

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(n_primitive={self.n_primitive}, "
            f"option_ids={self.option_ids}, n_weights={self.tile_coder.n_weights})"
        )


class LinearPolicy(_LinearQ):
    """Mutable linear action-value function ``Q(s, c) = sum_i weights[c, tiles(s)_i]``.

    Parameters
    ----------
    tile_coder : TileCoder
    n_primitive : int
        Number of primitive actions (the environment's ``Discrete(n)``).
    option_ids : sequence of int, default ()
        Stable ids of the options offered while learning, in choice order.
    weights : array_like, shape (n_choices, n_weights), optional
        Initial weights (copied). Default: every Q equal to ``initial_value``.
    initial_value : float, default 0.0
    """

    def __init__(
        self,
        tile_coder: TileCoder,
        n_primitive: int,
        option_ids: Sequence[int] | np.ndarray = (),
        weights: np.ndarray | None = None,
        initial_value: float = 0.0,
    ) -> None:
        self._init(tile_coder, n_primitive, option_ids, weights, initial_value)

    def update(self, active: np.ndarray, choice: int, step: float) -> None:
        """Add ``step`` to the weights of ``choice`` at tiles ``active``.

        ``step`` is already ``alpha / n_active * delta``. Tiles of one state are unique
        (one per feature and tiling), so fancy-index addition is exact.
        """
        self._by_tile[active, choice] += step

    def add_at(self, tiles: np.ndarray, choices: np.ndarray, steps: np.ndarray) -> None:
        """Add ``steps[i]`` to the weight of choice ``choices[i]`` at tile ``tiles[i]``.

        The (tile, choice) pairs must be unique, so that each weight gets one addition
        (exact, as :meth:`update` on each pair would be).
        """
        self._by_tile[tiles, choices] += steps

    def value(self, active: np.ndarray, choice: int) -> float:
        """``Q(s, choice)`` from the active tiles of ``s`` (one choice of
        :meth:`q_from_tiles`, the same number)."""
        return float(np.take(self._by_tile[:, choice], active).sum())

    def update_toward(
        self, active: np.ndarray, choice: int, target: float, step_size: float
    ) -> None:
        """Move ``Q(s, choice)`` toward ``target``: ``step_size * (target - Q(s, choice))``
        on each of the active tiles (``Q`` read now: earlier updates may share tiles)."""
        self.update(active, choice, step_size * (target - self.value(active, choice)))

    def freeze(self) -> FrozenPolicy:
        """An immutable copy of the current policy."""
        return FrozenPolicy(self.tile_coder, self.n_primitive, self.option_ids, self.weights)


class FrozenPolicy(_LinearQ):
    """Immutable snapshot of a :class:`LinearPolicy` (same parameters as its ``__init__``).

    The weights array is a private read-only copy; attributes cannot be reassigned.
    """

    def __init__(
        self,
        tile_coder: TileCoder,
        n_primitive: int,
        option_ids: Sequence[int] | np.ndarray = (),
        weights: np.ndarray | None = None,
    ) -> None:
        self._init(tile_coder, n_primitive, option_ids, weights, 0.0)
        self._by_tile.flags.writeable = False
        self._abs_max = float(np.abs(self._by_tile).max())
        self._frozen = True

    def __setattr__(self, name: str, value: object) -> None:
        if getattr(self, "_frozen", False):
            raise AttributeError(f"FrozenPolicy is immutable; cannot set {name!r}")
        super().__setattr__(name, value)

    def _abs_bound(self, by_tile: np.ndarray) -> float:
        return self._abs_max  # the weights never change

    def freeze(self) -> FrozenPolicy:
        """Already frozen: returns ``self``."""
        return self

    def thaw(self) -> LinearPolicy:
        """A mutable copy (e.g. to continue learning from this policy)."""
        return LinearPolicy(self.tile_coder, self.n_primitive, self.option_ids, self.weights)
