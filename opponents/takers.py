"""Keepaway's hand-coded takers (Stone, Sutton and Kuhlmann 2005), the keepaway task's team.

Every cycle, the takers are ranked by their distance to the ball: the two nearest go for
it (``INTERCEPT``: the earliest point of its path they can reach); each other taker
marks the keeper most open for a pass, standing :data:`MARK_DISTANCE` metres from it
toward the ball (at most half the way), so blocking the pass. The most open keeper is,
of the keepers other than the one nearest the ball (who has it, or will), the one with
the fewest takers in the cone of a pass to it from the ball (half-width
:data:`CONE` per metre), and among those the one whose nearest taker makes the widest
angle at the ball. With two takers (3v2) both always go for the ball.

Written once in batched form (:class:`TakersBatch`, one compiled loop over the drills):
it plays one drill as it plays many. It draws nothing.
"""

from __future__ import annotations

import math

import numpy as np

from soccer_drill import DrillConfig, Skill
from soccer_drill.constraints import Real, checked
from soccer_drill.teams import (
    BatchCommands,
    BatchRandom,
    BatchView,
    compiled,
    every_drill,
    hypot,
    in_cone,
    state_record,
    warms,
)

CHASERS = 2
"""How many takers go for the ball."""
MARK_DISTANCE = 4.0
"""How far from the keeper it marks a marking taker stands, toward the ball (metres)."""
CONE = 0.3
"""Half-width per metre of the cone a taker blocks a pass in."""
SPEED = Real(0.0, 1.0, low_open=True)
"""What ``speed`` may be: a fraction of the takers' top speed in (0, 1]."""
_INTERCEPT, _MOVE_TO = int(Skill.INTERCEPT), int(Skill.MOVE_TO)
_DEGREES = 180.0 / math.pi


@compiled
def plan_into(skill, target, pos, keepers):
    """The takers' commands in one drill (``pos``: ``(players + 1, 2)``, the first
    ``keepers`` of them keepers) into ``skill`` and ``target`` (one row per taker)."""
    players = pos.shape[0] - 1
    takers = players - keepers
    bx, by = pos[players, 0], pos[players, 1]
    order = np.empty(4, np.int64)
    dist = np.empty(4)
    mx, my = bx, by  # where a marking taker stands (set below when there is one)
    for j in range(takers):  # the takers by their distance to the ball, the lower first
        d = hypot(pos[keepers + j, 0] - bx, pos[keepers + j, 1] - by)
        k = j
        while k > 0 and dist[k - 1] > d:
            order[k], dist[k] = order[k - 1], dist[k - 1]
            k -= 1
        order[k], dist[k] = j, d
    if takers > CHASERS:
        with_ball, near = 0, math.inf
        for q in range(keepers):
            d = hypot(pos[q, 0] - bx, pos[q, 1] - by)
            if d < near:
                with_ball, near = q, d
        best, fewest, widest = -1, takers + 1, -1.0
        for q in range(keepers):
            if q == with_ball:
                continue
            count, lane = 0, 180.0
            ux, uy = pos[q, 0] - bx, pos[q, 1] - by
            du = hypot(ux, uy)
            for j in range(takers):
                o = keepers + j
                if in_cone(bx, by, pos[q, 0], pos[q, 1], pos[o, 0], pos[o, 1], CONE):
                    count += 1
                ax, ay = pos[o, 0] - bx, pos[o, 1] - by
                da = hypot(ax, ay)
                if du >= 1e-9 and da >= 1e-9:
                    cosine = (ux * ax + uy * ay) / (du * da)
                    cosine = -1.0 if cosine < -1.0 else 1.0 if cosine > 1.0 else cosine
                    a = _DEGREES * math.acos(cosine)
                    lane = a if a < lane else lane
            if count < fewest or (count == fewest and lane > widest):
                best, fewest, widest = q, count, lane
        mx, my = pos[best, 0], pos[best, 1]
        dx, dy = bx - mx, by - my
        gap = hypot(dx, dy)
        step = MARK_DISTANCE if MARK_DISTANCE < gap / 2 else gap / 2
        if gap > 1e-9:
            mx, my = mx + dx / gap * step, my + dy / gap * step
    for r in range(takers):
        j = order[r]
        if r < CHASERS:
            skill[j] = _INTERCEPT
        else:
            skill[j] = _MOVE_TO
            target[j, 0] = mx
            target[j, 1] = my


@compiled
def _plans_of_drills(skill, target, state, keepers):
    for r in range(state.shape[0]):
        plan_into(skill[r], target[r], state[r].pos, keepers)


class KeepawayTakers:
    """Keepaway's hand-coded takers: the two nearest the ball go for it, the others block
    the pass to the most open keeper (the module's docstring).

    Parameters
    ----------
    speed
        Fraction of the takers' top speed, in (0, 1].
    """

    def __init__(self, speed: float = 1.0) -> None:
        self.speed = checked("speed", speed, SPEED)

    def batch(self, n: int) -> TakersBatch:
        """This team for ``n`` drills at once."""
        return TakersBatch(self.speed)


class TakersBatch:
    """:class:`KeepawayTakers` in many drills: one compiled loop over them."""

    def __init__(self, speed: float) -> None:
        self.speed = speed

    def reset(self, view: BatchView, drills: np.ndarray, rng: BatchRandom) -> None:
        """Nothing to remember between cycles, nothing to draw."""

    def act(self, view: BatchView, drills: np.ndarray) -> BatchCommands:
        """The takers' commands in each of ``drills``."""
        m, d = len(drills), len(view.players)
        state = view.state if every_drill(drills, view.n) else view.state[drills]
        skill = np.full((m, d), _INTERCEPT, dtype=np.int64)
        target = np.zeros((m, d, 2))
        _plans_of_drills(skill, target, state, int(view.params[0]["attackers"]))
        return BatchCommands(skill, target, np.full((m, d), self.speed))


@warms
def _compile_plans(config: DrillConfig | None) -> None:
    """The takers' compiled plan with its callers' types, for a keepaway configuration
    (before a team's time-bounded call reaches it)."""
    if config is None or config.task != "keepaway":
        return
    state = np.zeros(2, dtype=state_record(config.players))
    state["pos"][:] = np.arange(2 * (config.players + 1)).reshape(config.players + 1, 2)
    shown = state.copy()
    shown.flags.writeable = False  # as the view hands every drill (some: a writable gather)
    for seen in (state, shown):
        _plans_of_drills(np.zeros((2, config.defenders), dtype=np.int64),
                         np.zeros((2, config.defenders, 2)), seen, config.attackers)
