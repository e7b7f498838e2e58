"""The simplest team: both defenders chase the ball."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from soccer_drill.skills import Command, Skill
from soccer_drill.state import DrillView
from soccer_drill.teams.batch import SameCommands


class Chasers:
    """Both defenders chase the ball (at speed 1, the same as interceptors_press).

    Parameters
    ----------
    speed
        Fraction of the defenders' top speed, in (0, 1].
    """

    def __init__(self, speed: float = 1.0) -> None:
        if not 0.0 < speed <= 1.0:
            raise ValueError(f"speed must be in (0, 1], got {speed!r}")
        self.speed = speed
        self._players: tuple[str, ...] = ()
        self._command = self.command()

    def command(self) -> Command:
        """The command of both defenders: INTERCEPT at :attr:`speed`."""
        return Command(Skill.INTERCEPT, speed=self.speed)

    def reset(self, view: DrillView, rng: np.random.Generator) -> None:
        """Remember the players to drive and the command for them."""
        self._players = view.players
        # Made once per episode (a Command is immutable): making one costs about a
        # microsecond, over 1% of the drill's cycle.
        self._command = self.command()

    def act(self, view: DrillView) -> Mapping[str, Command]:
        """INTERCEPT for both defenders."""
        return dict.fromkeys(self._players, self._command)

    def batch(self, n: int) -> SameCommands:
        """This team for ``n`` drills at once (``soccer_drill.teams.batch``): its one command."""
        return SameCommands(self.command)
