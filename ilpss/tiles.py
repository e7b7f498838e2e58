"""Hashless one-dimensional tile coding, in the style of keepaway.

Keepaway's learner (Stone, Sutton and Kuhlmann 2005; ``LinearSarsaAgent``) codes each
state variable separately: one group of 32 one-dimensional tilings per variable, each
tiling shifted by ``width / n_tilings`` from the previous one, with tile widths of about
3 m for distances and 10 degrees for angles. The learning rate ``alpha = 0.125`` is
spread over *all* active tiles: each update adds ``alpha / n_active * delta`` to every
active weight, where ``n_active = n_features * n_tilings`` (keepaway's ``numTilings``
counts the tilings of every variable). These are the defaults used here.

Keepaway hashes tiles into a large table; here every feature has a declared range
``[low, high]`` and values are clipped to it, so the tiles can be enumerated exactly:

    index = feature_offset[f] + t * n_bins[f] + bin(f, t)

with ``bin(f, t) = floor((clip(x_f) - low_f) / width_f + t / n_tilings)``. The number of
weights is known in advance and small (for the drill's 9 features, about 5,500 per
choice), and there are no hash collisions.
"""

from __future__ import annotations

import math

import numpy as np

from soccer_drill.constraints import Integer, Real, check

__all__ = ["TileCoder"]

#: Keepaway's number of one-dimensional tilings per state variable.
KEEPAWAY_N_TILINGS = 32
#: Keepaway's learning rate, divided by the number of active tiles at each update.
KEEPAWAY_ALPHA = 0.125
#: Keepaway's tile widths: metres for distances, degrees for angles.
KEEPAWAY_DISTANCE_WIDTH = 3.0
KEEPAWAY_ANGLE_WIDTH = 10.0
#: Most weights a coder may have (per choice of a value function: 32 MiB of float64).
#: The drill's coder has about 5,500; tiny widths would ask for terabytes.
MAX_WEIGHTS = 2**22
TILE_CONSTRAINTS = {"n_tilings": Integer(1, 1024), "width": Real(0.0, math.inf, low_open=True)}
"""The number of tilings, and each feature's tile width (in its units)."""


def _as_1d_float(name: str, value: object, n: int | None = None) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {arr.shape}")
    if n is not None and arr.shape[0] != n:
        raise ValueError(f"{name} must have {n} entries, got {arr.shape[0]}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {arr}")
    return arr


def box_bounds(space: object) -> tuple[np.ndarray, np.ndarray]:
    """The ``low`` and ``high`` of a 1-D Gymnasium ``Box`` with finite bounds.

    Raises
    ------
    ValueError
        Naming ``space``: it is not such a box (a ``Dict``, a ``Discrete``, an unbounded
        or a 2-D ``Box``); a tile coder needs one bounded range per feature.
    """
    try:
        low = np.asarray(getattr(space, "low", None), dtype=np.float64)
        high = np.asarray(getattr(space, "high", None), dtype=np.float64)
    except (TypeError, ValueError):
        low = high = np.empty((0, 0))  # bounds that are not numbers: refused below
    if low.ndim != 1 or high.shape != low.shape or not (
            np.isfinite(low).all() and np.isfinite(high).all()):
        raise ValueError(
            f"the observation space is {space!r}; tile coding needs a 1-D Box with finite "
            "low and high (one bounded range per feature), e.g. Box(low, high, (n,))"
        )
    return low, high


class TileCoder:
    """One-dimensional tilings per feature, hashless, with a fixed number of weights.

    Parameters
    ----------
    low, high : array_like, shape (n_features,)
        Declared range of each feature, in its own units. Values outside are clipped.
    widths : array_like, shape (n_features,)
        Tile width of each feature, in the same units (keepaway: ~3 m for distances,
        10 degrees for angles).
    n_tilings : int, default 32
        Number of tilings per feature; tiling ``t`` is shifted by ``t * width / n_tilings``.

    Attributes
    ----------
    n_features : int
    n_tilings : int
    n_active : int
        Number of active tiles for any state, ``n_features * n_tilings``.
    n_weights : int
        Total number of tiles (weights per choice of a linear value function).

    Examples
    --------
    >>> coder = TileCoder(low=[0.0], high=[10.0], widths=[2.0], n_tilings=4)
    >>> coder.active([3.0]).shape
    (4,)
    """

    def __init__(
        self,
        low: np.ndarray | list[float],
        high: np.ndarray | list[float],
        widths: np.ndarray | list[float],
        n_tilings: int = KEEPAWAY_N_TILINGS,
    ) -> None:
        low_a = _as_1d_float("low", low)
        n = low_a.shape[0]
        if n == 0:
            raise ValueError("at least one feature is required")
        high_a = _as_1d_float("high", high, n)
        widths_a = _as_1d_float("widths", widths, n)
        if np.any(high_a <= low_a):
            raise ValueError("every high must exceed its low")
        width = TILE_CONSTRAINTS["width"]
        if not all(width.allows(w) for w in widths_a):
            raise ValueError(f"every width must be {width.describe()}, got {widths_a}")
        check("n_tilings", n_tilings, TILE_CONSTRAINTS["n_tilings"])
        # Counted before anything is allocated (floats: tiny widths overflow int64).
        bins = np.floor((high_a - low_a) / widths_a) + 2
        if not int(n_tilings) * bins.sum() <= MAX_WEIGHTS:
            f = int(np.argmax(bins))
            raise ValueError(
                f"these widths and {int(n_tilings)} tilings give {int(n_tilings) * bins.sum():.3g} "
                f"weights, at most {MAX_WEIGHTS:,} are allowed (n_tilings x the sum over "
                f"features of (high - low) / width + 2): widen the tiles or use fewer tilings "
                f"(feature {f} spans {high_a[f] - low_a[f]:g} with width {widths_a[f]:g})"
            )
        self.low = low_a
        self.high = high_a
        self.widths = widths_a
        self.n_tilings = int(n_tilings)
        self.n_features = n
        for arr in (self.low, self.high, self.widths):
            arr.flags.writeable = False

        # Largest bin index is floor((high-low)/w + (T-1)/T) <= floor((high-low)/w) + 1.
        self.n_bins = np.floor((high_a - low_a) / widths_a).astype(np.int64) + 2
        block = self.n_tilings * self.n_bins
        feature_offset = np.concatenate(([0], np.cumsum(block)[:-1]))
        self.n_weights = int(block.sum())
        self.n_active = self.n_features * self.n_tilings
        # base[f, t] = feature_offset[f] + t * n_bins[f]; flattened in (f, t) order.
        t = np.arange(self.n_tilings)
        self._base = (feature_offset[:, None] + t[None, :] * self.n_bins[:, None]).astype(np.int64)
        self._inv_w = 1.0 / widths_a
        self._shift = t / self.n_tilings  # tiling t adds t/T of a tile width
        # Hash once: coders are used as cache keys at every decision.
        self._hash = hash(
            (self.n_tilings, self.low.tobytes(), self.high.tobytes(), self.widths.tobytes())
        )

    @classmethod
    def from_space(
        cls,
        space: object,
        widths: np.ndarray | list[float] | None = None,
        n_tilings: int = KEEPAWAY_N_TILINGS,
    ) -> TileCoder:
        """Build a coder over a Gymnasium ``Box`` observation space.

        Parameters
        ----------
        space : gymnasium.spaces.Box
            One-dimensional box with finite bounds (used as ``low``/``high``).
        widths : array_like, optional
            Tile widths in the features' units. Default: a tenth of each range, a
            generic choice; for the drill pass keepaway's (3 m, 10 degrees).
        n_tilings : int, default 32
        """
        low, high = box_bounds(space)
        if widths is None:
            widths = (high - low) / 10.0
        return cls(low, high, widths, n_tilings)

    # ----------------------------------------------------------------- coding
    def _check(self, x: np.ndarray) -> None:
        if not np.isfinite(x).all():
            raise ValueError(f"state contains NaN or infinite values: {x}")

    def active(self, state: np.ndarray | list[float]) -> np.ndarray:
        """Indices of the active tiles for one state.

        Parameters
        ----------
        state : array_like, shape (n_features,)

        Returns
        -------
        numpy.ndarray of int64, shape (n_active,)
            One index per (feature, tiling), feature-major, each in ``[0, n_weights)``.

        Raises
        ------
        ValueError
            If the state has the wrong shape or contains NaN/inf.
        """
        x = np.asarray(state, dtype=np.float64)
        if x.shape != (self.n_features,):
            raise ValueError(f"state must have shape ({self.n_features},), got {x.shape}")
        self._check(x)
        z = (np.minimum(np.maximum(x, self.low), self.high) - self.low) * self._inv_w
        bins = np.floor(z[:, None] + self._shift[None, :]).astype(np.int64)
        return (self._base + bins).ravel()

    def active_batch(self, states: np.ndarray) -> np.ndarray:
        """Active tiles for many states.

        Parameters
        ----------
        states : array_like, shape (n, n_features)

        Returns
        -------
        numpy.ndarray of int64, shape (n, n_active)
        """
        x = np.asarray(states, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != self.n_features:
            raise ValueError(f"states must have shape (n, {self.n_features}), got {x.shape}")
        self._check(x)
        z = (np.clip(x, self.low, self.high) - self.low) * self._inv_w
        bins = np.floor(z[:, :, None] + self._shift[None, None, :]).astype(np.int64)
        return (self._base[None] + bins).reshape(x.shape[0], self.n_active)

    def feature_tiles(self, f: int) -> slice:
        """The indices of feature ``f``'s tiles (its ``n_tilings`` tilings, one after
        another): where its part of a weight vector lies."""
        if not 0 <= f < self.n_features:
            raise ValueError(f"feature {f} out of range [0, {self.n_features})")
        start = int(self._base[f, 0])
        return slice(start, start + self.n_tilings * int(self.n_bins[f]))

    # ---------------------------------------------------------- persistence
    def to_arrays(self) -> dict[str, np.ndarray]:
        """Arrays that fully describe the coder (for saving beside weights)."""
        return {
            "tiles_low": self.low.copy(),
            "tiles_high": self.high.copy(),
            "tiles_widths": self.widths.copy(),
            "tiles_n_tilings": np.array(self.n_tilings, dtype=np.int64),
        }

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> TileCoder:
        """Inverse of :meth:`to_arrays`."""
        try:
            n_tilings = np.asarray(arrays["tiles_n_tilings"])
            if n_tilings.shape != () or n_tilings.dtype.kind not in "iu":
                raise ValueError("tiles_n_tilings must be an integer scalar")
            return cls(
                arrays["tiles_low"],
                arrays["tiles_high"],
                arrays["tiles_widths"],
                int(n_tilings),
            )
        except KeyError as exc:
            raise ValueError(f"tile coder arrays are missing {exc}") from None

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, TileCoder):
            return NotImplemented
        return (
            self.n_tilings == other.n_tilings
            and np.array_equal(self.low, other.low)
            and np.array_equal(self.high, other.high)
            and np.array_equal(self.widths, other.widths)
        )

    def __hash__(self) -> int:
        return self._hash

    def __repr__(self) -> str:
        return (
            f"TileCoder(n_features={self.n_features}, n_tilings={self.n_tilings}, "
            f"n_weights={self.n_weights})"
        )
