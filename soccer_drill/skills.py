"""The skills vocabulary shared by agents' actions, the support player and scripted teams.

A player is driven each cycle by one :class:`Command`. The drill turns it into a
desired velocity and, for the ball holder, a ball action (keep the ball at a
control point, or kick it). The rules are :mod:`soccer_drill.rules.motion`'s, written once
for one drill's arrays; the functions here offer them on a
:class:`~soccer_drill.state.DrillState` (for teams and tests).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from soccer_drill.rules import motion as rules

if TYPE_CHECKING:
    from soccer_drill.config import DrillConfig
    from soccer_drill.state import DrillState


class Skill(IntEnum):
    """Every skill a player can be commanded to execute for one cycle."""

    HOLD = 0
    """Holder: shield the ball, keeping the body between it and the nearest defender."""
    PASS = 1
    """Holder: kick the ball to the teammate (noisy, aimed to arrive slowly)."""
    DRIBBLE = 2
    """Holder: run toward the goal line with the ball, steering around defenders."""
    GET_OPEN = 3
    """Off-ball: move to a support spot beside and ahead of the ball, away from defenders."""
    GO_TO_BALL = 4
    """Off-ball: run to the earliest reachable point on the ball's path."""
    INTERCEPT = 5
    """Defender: run to the ball (or to where a rolling ball can be reached first)."""
    MARK = 6
    """Defender: stand in the passing lane between the ball and the free attacker."""
    GUARD_LINE = 7
    """Defender: guard the goal line, level with the ball, ``GUARD_DEPTH`` metres up."""
    MOVE_TO = 8
    """Anyone: run to ``Command.target``."""


BALL_SKILLS = frozenset({Skill.HOLD, Skill.PASS, Skill.DRIBBLE})
"""Skills only the attacker holding the ball may use."""

ATTACKER_ACTIONS: tuple[Skill, ...] = (
    Skill.HOLD, Skill.PASS, Skill.DRIBBLE, Skill.GET_OPEN, Skill.GO_TO_BALL,
)
"""An attacker agent's discrete actions, in index order."""

DEFENDER_ACTIONS: tuple[Skill, ...] = (Skill.INTERCEPT, Skill.MARK, Skill.GUARD_LINE)
"""A defender agent's discrete actions, in index order."""

HOLDER_ACTIONS: tuple[Skill, ...] = (Skill.HOLD, Skill.PASS, Skill.DRIBBLE)
"""The ball holder's actions: the paper's three basic options."""

@dataclass(frozen=True, slots=True)
class Command:
    """What one player does for one cycle.

    Parameters
    ----------
    skill
        The skill to execute.
    target
        ``(x, y)`` in metres; required for ``MOVE_TO``, ignored otherwise.
    speed
        Fraction of the player's top speed to use, in ``(0, 1]``.
    """

    skill: Skill
    target: tuple[float, float] | None = None
    speed: float = 1.0


class Motion(NamedTuple):
    """A skill's output: the desired velocity and what happens to the ball."""

    vx: float
    vy: float
    ball: int
    """``NO_BALL``, ``CONTROL`` (keep it ``ball_offset`` ahead along (bx, by)) or ``KICK``."""
    bx: float = 0.0
    by: float = 0.0


def _arrays(state: DrillState) -> tuple[np.ndarray, np.ndarray]:
    return np.array(state.pos), np.array(state.vel)


def ball_interception_point(
    state: DrillState, player: int, vmax: float, cfg: DrillConfig
) -> tuple[float, float]:
    """Earliest point of the rolling ball's path that ``player`` can reach in time."""
    pos, vel = _arrays(state)
    params = rules.rule_parameters(cfg)
    return rules.interception_point(pos, vel, state.holder, player, float(vmax),
                                    params[rules.CONTROL_RADIUS], rules.roll_table(cfg),
                                    params[rules.SPACING])


def support_spot(state: DrillState, player: int, cfg: DrillConfig) -> tuple[float, float]:
    """Where an off-ball attacker gets open: wide of the ball and a little ahead of it."""
    return rules.support_spot(np.array(state.pos), player, cfg.field_size)


def dribble_heading(state: DrillState, player: int, cfg: DrillConfig) -> tuple[float, float]:
    """Unit heading toward the goal line that keeps clear of defenders and touchlines."""
    return rules.dribble_heading(np.array(state.pos), player, cfg.field_size)


def shield_direction(state: DrillState, player: int) -> tuple[float, float]:
    """Unit direction away from the nearest opponent: where a shielded ball is kept."""
    return rules.shield_direction(np.array(state.pos), player)


def pass_velocity(
    state: DrillState, player: int, cfg: DrillConfig, rng: np.random.Generator
) -> tuple[float, float]:
    """Noisy kick velocity that brings the ball to the teammate at about arrival speed
    (two standard normals drawn from ``rng``: the direction's, then the speed's)."""
    pos, vel = _arrays(state)
    angle_normal, speed_normal = rng.normal(size=2).tolist()
    return rules.pass_velocity(pos, vel, player, angle_normal, speed_normal,
                               rules.rule_parameters(cfg))


def execute(
    state: DrillState,
    player: int,
    command: Command,
    cfg: DrillConfig,
    rng: np.random.Generator,
) -> Motion:
    """Turn ``command`` for ``player`` into a :class:`Motion` for this cycle (a pass of
    the holder draws its two normals from ``rng``)."""
    pos, vel = _arrays(state)
    noise = (0.0, 0.0)
    if command.skill is Skill.PASS and player == state.holder:
        noise = tuple(rng.normal(size=2).tolist())
    tx, ty = command.target if command.target is not None else (0.0, 0.0)
    return Motion(*rules.motion(pos, vel, state.holder, player, int(command.skill), float(tx),
                                float(ty), float(command.speed), *noise,
                                rules.rule_parameters(cfg), rules.roll_table(cfg)))
