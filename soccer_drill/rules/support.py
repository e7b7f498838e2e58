"""The fixed stochastic support behaviour of an attacker that is not an agent."""

from __future__ import annotations

import numpy as np

from soccer_drill.config import DrillConfig
from soccer_drill.rules.compiled import compiled, hypot
from soccer_drill.rules.motion import GO_TO_BALL, MOVE_TO, support_spot
from soccer_drill.skills import Command, Skill
from soccer_drill.state import DrillState

RESAMPLE_CYCLES = 10
"""How often the support spot's random offset changes."""
OFFSET_STD = 2.0
"""Standard deviation of the offset per axis, metres."""
_GO_TO_BALL = Command(Skill.GO_TO_BALL)  # immutable, so one serves every cycle
_MOVE_TO = Skill.MOVE_TO  # read once: an enum member lookup costs ~0.2 us


class SupportPlayer:
    """Chases a loose ball it is nearer to, otherwise gets open with a random offset.

    The offset (normal, :data:`OFFSET_STD` m per axis) is redrawn every
    :data:`RESAMPLE_CYCLES` cycles from the generator given at :meth:`reset`, so the
    teammate is not perfectly predictable but the episode stays seeded.
    """

    def __init__(self) -> None:
        self._rng: np.random.Generator | None = None
        self._offset = (0.0, 0.0)

    def reset(self, rng: np.random.Generator) -> None:
        """Start an episode, drawing from ``rng`` from now on."""
        self._rng = rng
        self._offset = (0.0, 0.0)

    def command(self, state: DrillState, player: int, cfg: DrillConfig) -> Command:
        """This cycle's command for attacker ``player`` (which does not hold the ball)."""
        assert self._rng is not None, "reset() first"
        if state.cycle % RESAMPLE_CYCLES == 0:
            dx, dy = self._rng.normal(0.0, OFFSET_STD, size=2)
            self._offset = (float(dx), float(dy))
        skill, x, y = support_target(
            np.array(state.pos), state.holder, state.cycle, state.passer, state.lockout_until,
            player, self._offset[0], self._offset[1], cfg.field_size,
        )
        return _GO_TO_BALL if skill == GO_TO_BALL else Command(_MOVE_TO, (x, y))


@compiled
def support_target(pos, holder, cycle, passer, lockout_until, player, offset_x, offset_y, size):
    """The support behaviour's ``(skill, x, y)`` for attacker ``player`` of one drill:
    ``GO_TO_BALL`` for a loose ball it is no farther from than its mate (or its mate may
    not take yet), else ``MOVE_TO`` its support spot moved by the offset."""
    if holder < 0:
        mate = player ^ 1
        mate_locked = passer == mate and cycle < lockout_until
        bx, by = pos[4, 0], pos[4, 1]
        if mate_locked or hypot(pos[player, 0] - bx, pos[player, 1] - by) <= hypot(
            pos[mate, 0] - bx, pos[mate, 1] - by
        ):
            return GO_TO_BALL, 0.0, 0.0
    x, y = support_spot(pos, player, size)
    x, y = x + offset_x, y + offset_y
    lo, hi = 1.0, size - 1.0  # each clamp min(max(v, lo), hi), as the builtins compare
    return MOVE_TO, (lo if x < lo else hi if x > hi else x), (lo if y < lo else hi if y > hi else y)


@compiled
def support_commands_of_drills(skill, target, speed, supporting, pos, holder, cycle, passer,
                               lockout_until, offsets, size):
    """The support behaviour's commands for attacker ``k`` of drill ``i`` wherever
    ``supporting[i, k]``, written into ``skill``, ``target`` and ``speed`` (``offsets``:
    ``(n, 2, 2)``, each attacker's offset)."""
    for i in range(pos.shape[0]):
        for k in range(2):
            if supporting[i, k]:
                s, x, y = support_target(pos[i], holder[i], cycle[i], passer[i],
                                         lockout_until[i], k, offsets[i, k, 0],
                                         offsets[i, k, 1], size)
                skill[i, k] = s
                target[i, k, 0] = x
                target[i, k, 1] = y
                speed[i, k] = 1.0
