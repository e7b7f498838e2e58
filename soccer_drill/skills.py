"""The skills' rules offered on a :class:`~soccer_drill.state.DrillState`, for teams and tests.

A player is driven each cycle by one :class:`~soccer_drill.commands.Command`. The drill
turns it into a desired velocity and, for the ball holder, a ball action (keep the ball
at a control point, or kick it). The rules are :mod:`soccer_drill.rules.motion`'s,
written once for one drill's arrays; the functions here run them on a snapshot.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from soccer_drill.commands import Command, Skill
from soccer_drill.rules import arrays
from soccer_drill.rules import motion as rules
from soccer_drill.rules.arrays import roll_table, rule_parameters

if TYPE_CHECKING:
    from soccer_drill.config import DrillConfig
    from soccer_drill.state import DrillState


class Motion(NamedTuple):
    """A skill's output: the desired velocity and what happens to the ball."""

    vx: float
    vy: float
    ball: int
    """A :class:`~soccer_drill.rules.motion.BallAction`: none, ``CONTROL`` (keep it
    ``ball_offset`` ahead along (bx, by)) or ``KICK``."""
    bx: float = 0.0
    by: float = 0.0


def state_record(state: DrillState) -> np.ndarray:
    """``state`` as one :data:`~soccer_drill.rules.arrays.STATE` record (a ``(1,)`` array;
    of as many players as ``state`` holds)."""
    record = np.zeros(1, dtype=arrays.state_record(len(state.pos) - 1))
    record["pos"][0], record["vel"][0] = state.pos, state.vel
    record["holder"], record["cycle"] = state.holder, state.cycle
    record["passer"], record["lockout_until"] = state.passer, state.lockout_until
    return record


def ball_interception_point(
    state: DrillState, player: int, vmax: float, cfg: DrillConfig
) -> tuple[float, float]:
    """Earliest point of the rolling ball's path that ``player`` can reach in time."""
    return rules.interception_point(np.array(state.pos), np.array(state.vel), state.holder,
                                    player, float(vmax), rule_parameters(cfg), roll_table(cfg))


def support_spot(state: DrillState, player: int, cfg: DrillConfig) -> tuple[float, float]:
    """Where an off-ball attacker gets open: wide of the ball and a little ahead of it."""
    return rules.support_spot(np.array(state.pos), player, cfg.field_size, cfg.attackers)


def dribble_heading(state: DrillState, player: int, cfg: DrillConfig) -> tuple[float, float]:
    """Unit heading toward the goal line that keeps clear of defenders and touchlines."""
    return rules.dribble_heading(np.array(state.pos), player, cfg.field_size, cfg.attackers)


def shield_direction(state: DrillState, player: int,
                     cfg: DrillConfig | None = None) -> tuple[float, float]:
    """Unit direction away from the nearest opponent: where a shielded ball is kept
    (``cfg``: the drill's, for its number of attackers; ``None``: two)."""
    return rules.shield_direction(np.array(state.pos), player, 2 if cfg is None else cfg.attackers)


def pass_velocity(
    state: DrillState, player: int, cfg: DrillConfig, rng: np.random.Generator,
    mate: int | None = None,
) -> tuple[float, float]:
    """Noisy kick velocity that brings the ball to teammate ``mate`` (``None``: the
    nearest) at about arrival speed (two standard normals drawn from ``rng``: the
    direction's, then the speed's)."""
    pos = np.array(state.pos)
    if mate is None:
        mate = rules.nearest_teammate(pos, player, cfg.attackers)
    angle_normal, speed_normal = rng.normal(size=2).tolist()
    return rules.pass_velocity(pos, np.array(state.vel), player, mate, angle_normal,
                               speed_normal, rule_parameters(cfg))


def execute(
    state: DrillState,
    player: int,
    command: Command,
    cfg: DrillConfig,
    rng: np.random.Generator,
) -> Motion:
    """Turn ``command`` for ``player`` into a :class:`Motion` for this cycle (a pass of
    the holder draws its two normals from ``rng``)."""
    cycle = np.zeros(1, dtype=arrays.cycle_record(cfg.players))
    cycle["receiver"] = -1
    if command.skill is Skill.PASS and player == state.holder:
        cycle["noise"][0] = rng.normal(size=2)
    cycle["skill"][0, player] = int(command.skill)
    cycle["speed"][0, player] = float(command.speed)
    if command.target is not None:
        cycle["target"][0, player] = command.target
    return Motion(*rules.motion(state_record(state)[0], cycle[0], player, rule_parameters(cfg),
                                roll_table(cfg)))
