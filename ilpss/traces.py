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

__all__ = ["MIN_TRACE", "ReplacingTraces", "td_update"]

MIN_TRACE = 0.01
"""Eligibilities below this are dropped (keepaway's cut-off)."""


class ReplacingTraces:
    """The eligibility traces of one episode over the weights of ``q``.

    Kept sparse: for each choice with eligible tiles, those tiles and their
    eligibilities (all of them at least :data:`MIN_TRACE`). The update touches only
    eligible weights, with the numbers the dense rule gives: elsewhere it would add
    ``step * delta * 0``, which changes no weight (only a weight of ``-0.0`` would
    become ``+0.0``, and no update makes one); a non-finite ``step * delta`` is
    applied densely, as the rule says.
    """

    def __init__(self, q: LinearPolicy) -> None:
        self.q = q
        # choice -> (tiles, eligibilities), for every choice with eligible tiles
        self.rows: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._marked = np.zeros(q.tile_coder.n_weights, dtype=bool)  # scratch: tiles of s

    def eligibility(self, choice: int) -> np.ndarray:
        """Eligibilities of ``choice``'s weights, shape (n_weights,) (dense, a copy)."""
        out = np.zeros(self.q.tile_coder.n_weights)
        if choice in self.rows:
            tiles, values = self.rows[choice]
            out[tiles] = values
        return out

    def update(
        self, active: np.ndarray, choice: int, target: float, step: float, decay: float,
        cut: bool,
    ) -> None:
        """Move ``Q(s, choice)`` (tiles ``active``) toward ``target`` and every eligible
        weight with it, then decay the traces by ``decay`` (or clear them if ``cut``)."""
        q, rows, marked = self.q, self.rows, self._marked
        delta = target - q.value(active, choice)
        # Replacing: the tiles of s lose their eligibility for every other choice ...
        marked[active] = True
        for row, (tiles, values) in list(rows.items()):
            keep = ~marked[tiles]
            if not keep.all():
                rows[row] = (tiles[keep], values[keep])
        marked[active] = False
        # ... and get eligibility 1 for the choice made.
        tiles, values = rows.get(choice, (active[:0], np.zeros(0)))
        rows[choice] = (np.concatenate((tiles, active)),
                        np.concatenate((values, np.ones(active.shape[0]))))
        scaled = step * delta
        weights = q.weights
        for row, (tiles, values) in rows.items():
            if math.isfinite(scaled):
                weights[row, tiles] += scaled * values
            else:
                weights[row] += scaled * self.eligibility(row)
        if cut:
            rows.clear()
            return
        for row, (tiles, values) in list(rows.items()):
            values = values * decay
            keep = ~(values < MIN_TRACE)
            if keep.any():
                rows[row] = (tiles[keep], values[keep])
            else:
                del rows[row]


def td_update(
    q: LinearPolicy, traces: ReplacingTraces | None, active: np.ndarray, choice: int,
    target: float, step: float, decay: float, cut: bool,
) -> None:
    """One choice point's update: along ``traces``, or one-step when they are ``None``."""
    if traces is None:
        q.update_toward(active, choice, target, step)
    else:
        traces.update(active, choice, target, step, decay, cut)
