"""The fixed stochastic support behaviour of an attacker that is not an agent."""

from __future__ import annotations

import numpy as np

from soccer_drill.config import DrillConfig
from soccer_drill.skills import Command, Skill, support_spot
from soccer_drill.state import BALL, DrillState

_RESAMPLE_CYCLES = 10  # how often the support spot's random offset changes
_OFFSET_STD = 2.0  # metres
_GO_TO_BALL = Command(Skill.GO_TO_BALL)  # immutable, so one serves every cycle
_MOVE_TO = Skill.MOVE_TO  # read once: an enum member lookup costs ~0.2 us


class SupportPlayer:
    """Chases a loose ball it is nearer to, otherwise gets open with a random offset.

    The offset (normal, ``_OFFSET_STD`` m per axis) is redrawn every
    ``_RESAMPLE_CYCLES`` cycles from the generator given at :meth:`reset`, so the
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
        if state.cycle % _RESAMPLE_CYCLES == 0:
            dx, dy = self._rng.normal(0.0, _OFFSET_STD, size=2)
            self._offset = (float(dx), float(dy))
        if state.holder < 0:
            mate = player ^ 1
            mate_locked = state.passer == mate and state.cycle < state.lockout_until
            if mate_locked or state.distance(player, BALL) <= state.distance(mate, BALL):
                return _GO_TO_BALL
        x, y = support_spot(state, player, cfg)
        x, y = x + self._offset[0], y + self._offset[1]
        lo, hi = 1.0, cfg.field_size - 1.0  # each clamp min(max(v, lo), hi), written out
        return Command(_MOVE_TO, (lo if x < lo else hi if x > hi else x,
                                  lo if y < lo else hi if y > hi else y))
