"""Keepaway's replacing eligibility traces on tiles, for any linear action-value learner.

One :class:`ReplacingTraces` holds one eligibility per weight of a
:class:`~ilpss.policy.LinearPolicy` for one episode. :meth:`~ReplacingTraces.update`
applies a choice point's TD error to every eligible weight: the tiles of this state get
eligibility 1 for the choice made and 0 for the other choices (replacing, so tiles
shared by successive states are not counted twice; accumulating traces would multiply
the step size by about ``1 / (1 - lambda)``), then every eligibility decays by the
given factor (``gamma ** D * lambda`` for a choice of duration ``D``) and is dropped
below 0.01 (keepaway's cut-off). Only eligible weights are touched, which gives the same
numbers as a dense update at a fraction of its cost, however many choices there are.

With ``lambda = 0`` (``traces=None`` in :func:`td_update`) the update is the one-step
one: ``Q(s, c) += step * (target - Q(s, c))``.
"""

from __future__ import annotations

import math

import numpy as np

from ilpss.policy import LinearPolicy

__all__ = ["DivergedError"]


class DivergedError(FloatingPointError):
    """Learning diverged: an update met a value that is not finite."""

MIN_TRACE = 0.01
"""Eligibilities below this are dropped (keepaway's cut-off)."""


class ReplacingTraces:
    """The eligibility traces of one episode over the weights of ``q``.

    Kept sparse: the eligible (tile, choice) pairs side by side in three flat arrays
    (tiles, choices, eligibilities, all of these at least :data:`MIN_TRACE`), so that an
    update costs the same few array operations however many choices hold eligible
    tiles. The update touches only eligible weights, with the numbers the dense rule
    gives: elsewhere it would add ``step * delta * 0``, which changes no weight (only a
    weight of ``-0.0`` would become ``+0.0``, and no update makes one); a non-finite
    ``step * delta`` is applied densely, as the rule says.
    """

    def __init__(self, q: LinearPolicy) -> None:
        self.q = q
        self._tiles = np.zeros(0, dtype=np.int64)
        self._choices = np.zeros(0, dtype=np.int64)
        self._values = np.zeros(0)
        self._marked = np.zeros(q.tile_coder.n_weights, dtype=bool)  # scratch: tiles of s

    @property
    def rows(self) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        """``{choice: (tiles, eligibilities)}`` for every choice with eligible tiles."""
        return {int(c): (self._tiles[self._choices == c], self._values[self._choices == c])
                for c in np.unique(self._choices)}

    def eligibility(self, choice: int) -> np.ndarray:
        """Eligibilities of ``choice``'s weights, shape (n_weights,) (dense, a copy)."""
        out = np.zeros(self.q.tile_coder.n_weights)
        mine = self._choices == choice
        out[self._tiles[mine]] = self._values[mine]
        return out

    def update(
        self, active: np.ndarray, choice: int, target: float, step: float, decay: float,
        cut: bool,
    ) -> None:
        """Move ``Q(s, choice)`` (tiles ``active``) toward ``target`` and every eligible
        weight with it, then decay the traces by ``decay`` (or clear them if ``cut``)."""
        q, marked = self.q, self._marked
        delta = target - q.value(active, choice)
        scaled = step * delta
        if not math.isfinite(scaled):
            # The dense rule: every choice with eligible tiles before or after the
            # replacement below gets its whole row of weights moved.
            rows = set(self._choices.tolist()) | {choice}
        # Replacing: the tiles of s lose their eligibility for every other choice ...
        marked[active] = True
        keep = ~marked[self._tiles]
        marked[active] = False
        # ... and get eligibility 1 for the choice made.
        tiles = np.concatenate((self._tiles[keep], active))
        choices = np.concatenate((self._choices[keep], np.full(active.shape[0], choice)))
        values = np.concatenate((self._values[keep], np.ones(active.shape[0])))
        self._tiles, self._choices, self._values = tiles, choices, values
        if math.isfinite(scaled):
            q.add_at(tiles, choices, scaled * values)  # unique pairs: one addition each
        else:
            weights = q.weights
            for row in sorted(rows):
                weights[row] += scaled * self.eligibility(row)
        if cut:
            self.clear()
            return
        values = values * decay
        keep = ~(values < MIN_TRACE)
        self._tiles, self._choices, self._values = tiles[keep], choices[keep], values[keep]

    def clear(self) -> None:
        """Drop every eligibility."""
        self._tiles = self._tiles[:0]
        self._choices = self._choices[:0]
        self._values = self._values[:0]


def td_update(
    q: LinearPolicy, traces: ReplacingTraces | None, active: np.ndarray, choice: int,
    target: float, step: float, decay: float, cut: bool,
) -> None:
    """One choice point's update: along ``traces``, or one-step when they are ``None``.

    Raises
    ------
    DivergedError
        If ``target`` is not finite: the action values have diverged (a step size or
        initial values too large for the rewards), and every later update would only
        spread NaN.
    """
    if not math.isfinite(target):
        raise DivergedError(f"a TD target of {target} (the action values are no longer finite)")
    if traces is None:
        q.update_toward(active, choice, target, step)
    else:
        traces.update(active, choice, target, step, decay, cut)
