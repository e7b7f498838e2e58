"""Keepaway's replacing eligibility traces on tiles, for any linear action-value learner.

One :class:`ReplacingTraces` holds one eligibility per weight of a
:class:`~ilpss.policy.LinearPolicy` for one episode. :meth:`~ReplacingTraces.update`
applies a choice point's TD error to every eligible weight: the tiles of this state get
eligibility 1 for the choice made and 0 for the other choices (replacing, so tiles
shared by successive states are not counted twice; accumulating traces would multiply
the step size by about ``1 / (1 - lambda)``), then every eligibility decays by the
given factor (``gamma ** D * lambda`` for a choice of duration ``D``) and is dropped
below 0.01 (keepaway's cut-off). Only rows with eligible tiles are touched, which gives
the same numbers as a dense update at a fraction of its cost.

With ``lambda = 0`` (``traces=None`` in :func:`td_update`) the update is the one-step
one: ``Q(s, c) += step * (target - Q(s, c))``.
"""

from __future__ import annotations

import numpy as np

from ilpss.policy import LinearPolicy

__all__ = ["MIN_TRACE", "ReplacingTraces", "td_update"]

MIN_TRACE = 0.01
"""Eligibilities below this are dropped (keepaway's cut-off)."""


class ReplacingTraces:
    """The eligibility traces of one episode over the weights of ``q``."""

    def __init__(self, q: LinearPolicy) -> None:
        self.q = q
        self.traces = np.zeros_like(q.weights)
        self.live: set[int] = set()  # rows with a non-zero eligibility

    def update(
        self, active: np.ndarray, choice: int, target: float, step: float, decay: float,
        cut: bool,
    ) -> None:
        """Move ``Q(s, choice)`` (tiles ``active``) toward ``target`` and every eligible
        weight with it, then decay the traces by ``decay`` (or clear them if ``cut``)."""
        weights, traces, live = self.q.weights, self.traces, self.live
        delta = target - float(np.take(weights[choice], active).sum())
        for row in live:
            traces[row, active] = 0.0
        traces[choice, active] = 1.0
        live.add(choice)
        scaled = step * delta
        for row in live:  # only rows with eligible tiles: other rows would add zeros
            weights[row] += scaled * traces[row]
        if cut:
            for row in live:
                traces[row] = 0.0
            live.clear()
            return
        for row in list(live):
            e = traces[row]
            e *= decay
            e[e < MIN_TRACE] = 0.0
            if not e.any():
                live.discard(row)


def td_update(
    q: LinearPolicy, traces: ReplacingTraces | None, active: np.ndarray, choice: int,
    target: float, step: float, decay: float, cut: bool,
) -> None:
    """One choice point's update: along ``traces``, or one-step when they are ``None``."""
    if traces is None:
        q.update_toward(active, choice, target, step)
    else:
        traces.update(active, choice, target, step, decay, cut)
