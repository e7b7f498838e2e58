"""The simplest team: both defenders chase the ball."""

from __future__ import annotations

from soccer_drill import Command, Skill
from soccer_drill.constraints import Real, checked
from soccer_drill.teams import SameCommands

SPEED = Real(0.0, 1.0, low_open=True)
"""What ``speed`` may be: a fraction of the defenders' top speed in (0, 1]."""


class Chasers:
    """Both defenders chase the ball (at speed 1, the same as interceptors_press).

    Its batched form is its one command (``SameCommands``), for one drill as for many.

    Parameters
    ----------
    speed
        Fraction of the defenders' top speed, in (0, 1].
    """

    def __init__(self, speed: float = 1.0) -> None:
        self.speed = checked("speed", speed, SPEED)

    def command(self) -> Command:
        """The command of both defenders: INTERCEPT at :attr:`speed`."""
        return Command(Skill.INTERCEPT, speed=self.speed)

    def batch(self, n: int) -> SameCommands:
        """This team for ``n`` drills at once: its one command."""
        return SameCommands(self.command)
