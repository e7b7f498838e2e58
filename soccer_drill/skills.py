"""The skills vocabulary shared by agents' actions, the support player and scripted teams.

A player is driven each cycle by one :class:`Command`. The drill turns it into a
desired velocity and, for the ball holder, a ball action (keep the ball at a
control point, or kick it). The functions here are pure: they read a
:class:`~soccer_drill.state.DrillState` and return a :class:`Motion`.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from enum import IntEnum
from typing import TYPE_CHECKING, NamedTuple

if TYPE_CHECKING:
    import numpy as np

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

GUARD_DEPTH = 2.5
"""Distance from the goal line at which ``GUARD_LINE`` stands, in metres."""


@dataclass(frozen=True, slots=True)
class Command:
    """What one player does for one cycle.

    Args:
        skill: the skill to execute.
        target: ``(x, y)`` in metres; required for ``MOVE_TO``, ignored otherwise.
        speed: fraction of the player's top speed to use, in ``(0, 1]``.
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


NO_BALL, CONTROL, KICK = 0, 1, 2
_sqrt, _ceil = math.sqrt, math.ceil
_ARRIVE_SECONDS = 0.3  # slow down this long before a target, so players do not orbit it
_HOLD_EDGE = 3.0  # a shielding holder stops backing away this close to a touchline
_LEAD_SECONDS = 1.5  # how far ahead a defender aims at a dribbling holder


def _unit(x: float, y: float) -> tuple[float, float]:
    n = math.hypot(x, y)
    return (x / n, y / n) if n > 1e-9 else (0.0, -1.0)


def ball_interception_point(
    state: DrillState, player: int, vmax: float, cfg: DrillConfig
) -> tuple[float, float]:
    """Earliest point of the rolling ball's path that ``player`` can reach in time."""
    bx, by = state.pos[4]
    bvx, bvy = state.vel[4]
    px, py = state.pos[player]
    if state.holder >= 0 and state.holder != player:
        # Aim where a carried ball will be when we get there, so chasers do not trail.
        hvx, hvy = state.vel[state.holder]
        lead = math.hypot(bx - px, by - py) / vmax if vmax > 0 else 0.0
        if _LEAD_SECONDS < lead:  # min(lead, _LEAD_SECONDS), as min() compares
            lead = _LEAD_SECONDS
        return bx + hvx * lead, by + hvy * lead
    ball_speed = math.hypot(bvx, bvy)
    if ball_speed < 1.0 or state.holder >= 0:
        return bx, by
    times, travels, slowing, spacing = _roll_table(cfg.ball_damping, cfg.cycle_seconds)
    reach, last = cfg.control_radius, len(times) - 1
    # The first point of the table within reach, as a scan of every point finds it, but
    # skipping points that cannot be: after a point the gap (the distance to the ball's
    # point less the reach) shrinks per second by at most vmax plus the ball's speed
    # there (it only slows down), and by vmax alone once the ball rolls away from the
    # player. The bound is widened far beyond rounding errors.
    vmax_step = vmax * spacing * (1.0 + 1e-9)
    speed_bound = ball_speed * (1.0 + 1e-9)
    k = 0
    while True:
        travelled = travels[k]
        x, y = bx + bvx * travelled, by + bvy * travelled
        dx, dy = x - px, y - py
        r = vmax * times[k] + reach
        d2 = dx * dx + dy * dy
        if d2 <= r * r or k == last:
            return x, y
        gap = _sqrt(d2) - r - 1e-9 * (r + 1.0)
        if dx * bvx + dy * bvy >= 0.0:  # rolling away: no nearer from here on
            closing = vmax_step
        else:
            closing = speed_bound * slowing[k] + vmax_step
        if gap <= closing:
            k += 1
        elif gap >= closing * (last - k):  # none left can be reached: the last point
            k = last
        else:
            k += _ceil(gap / closing)


@functools.lru_cache(maxsize=64)
def _roll_table(
    damping: float, cycle: float
) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...], float]:
    """A rolling ball every 2 cycles for 3 s: the times; per unit of initial speed, the
    distance travelled by then and the most it travels to the next point; the time
    between two points."""
    k = -math.log(max(damping, 1e-6))
    times = tuple(step * cycle for step in range(1, round(3.0 / cycle) + 1, 2))
    travels = tuple((1.0 - math.exp(-k * t)) / k if k > 0 else t for t in times)
    spacing = 2 * cycle
    slowing = tuple(math.exp(-k * t) * spacing for t in times)  # speed there x spacing
    return times, travels, slowing, spacing


def support_spot(state: DrillState, player: int, cfg: DrillConfig) -> tuple[float, float]:
    """Where an off-ball attacker gets open: wide of the ball and a little ahead of it."""
    size = cfg.field_size
    pos = state.pos
    bx, by = pos[4]
    side = 1.0 if pos[player][0] >= bx else -1.0
    if not 3.0 <= bx + side * 11.0 <= size - 3.0:
        side = -side
    # Each clamp is min(max(v, lo), hi) written out (the same floats, NaN included, for
    # lo < hi): the two builtin calls cost more than the rest of the line.
    lo, hi = 2.0, size - 2.0
    tx, ty = bx + side * 11.0, by - 3.0
    tx = lo if tx < lo else hi if tx > hi else tx
    ty = lo if ty < lo else hi if ty > hi else ty
    # Step away from a defender standing on the spot.
    for d in (2, 3) if player < 2 else (0, 1):  # the opponents
        dx, dy = tx - pos[d][0], ty - pos[d][1]
        dist = math.hypot(dx, dy)
        if dist < 5.0:
            ux, uy = _unit(dx, dy)
            tx += ux * (5.0 - dist)
            ty += uy * (5.0 - dist)
    lo, hi = 1.0, size - 1.0
    return (lo if tx < lo else hi if tx > hi else tx), (lo if ty < lo else hi if ty > hi else ty)


def dribble_heading(state: DrillState, player: int, cfg: DrillConfig) -> tuple[float, float]:
    """Unit heading toward the goal line that keeps clear of defenders and touchlines.

    The candidate with the highest score wins, the first in ``_HEADINGS``' order among
    equals. A candidate's score is its initial score less penalties, so candidates are
    tried from the highest initial score down, and the search stops once no candidate
    left could reach the best score found.
    """
    px, py = state.pos[player]
    size = cfg.field_size
    best, best_score, best_order = (0.0, -1.0), -math.inf, len(_HEADINGS)
    d1, d2 = state.opponents_of(player)
    r1x, r1y = state.pos[d1][0] - px, state.pos[d1][1] - py
    r2x, r2y = state.pos[d2][0] - px, state.pos[d2][1] - py
    for order, hx, hy, score in _HEADINGS_BY_SCORE:
        if score < best_score:
            break
        # Each opponent ahead within 12 m costs more the closer it is to the heading line.
        ahead = r1x * hx + r1y * hy
        if 0.0 < ahead < 12.0:
            free = 1.0 - abs(r1x * hy - r1y * hx) / 4.0
            score -= 2.0 * (free if free > 0.0 else 0.0) * (1.0 - ahead / 12.0)
        ahead = r2x * hx + r2y * hy
        if 0.0 < ahead < 12.0:
            free = 1.0 - abs(r2x * hy - r2y * hx) / 4.0
            score -= 2.0 * (free if free > 0.0 else 0.0) * (1.0 - ahead / 12.0)
        ex = px + hx * 4.0
        if not 1.0 <= ex <= size - 1.0:
            score -= 3.0
        if score > best_score or (score == best_score and order < best_order):
            best, best_score, best_order = (hx, hy), score, order
    return best


def _heading(deg: int) -> tuple[float, float, float]:
    """Unit heading ``deg`` degrees off straight down the field, and its initial score."""
    a = math.radians(deg)
    return math.sin(a), -math.cos(a), math.cos(a)


_HEADINGS = tuple(_heading(deg) for deg in range(-70, 71, 10))  # the candidates, in order
# (position in _HEADINGS, hx, hy, initial score), highest initial score first.
_HEADINGS_BY_SCORE = tuple(sorted(
    ((order, *heading) for order, heading in enumerate(_HEADINGS)),
    key=lambda item: (-item[3], item[0]),
))


def shield_direction(state: DrillState, player: int) -> tuple[float, float]:
    """Unit direction away from the nearest opponent: where a shielded ball is kept."""
    px, py = state.pos[player]
    d1, d2 = state.opponents_of(player)
    x1, y1 = state.pos[d1]
    x2, y2 = state.pos[d2]
    if math.hypot(x2 - px, y2 - py) < math.hypot(x1 - px, y1 - py):  # the first if equal
        x1, y1 = x2, y2
    return _unit(px - x1, py - y1)


def pass_velocity(
    state: DrillState, player: int, cfg: DrillConfig, rng: np.random.Generator
) -> tuple[float, float]:
    """Noisy kick velocity that brings the ball to the teammate at about arrival speed."""
    bx, by = state.pos[4]
    mate = state.teammate_of(player)
    mx, my = state.pos[mate]
    mvx, mvy = state.vel[mate]
    k = -math.log(max(cfg.ball_damping, 1e-6))
    dist = math.hypot(mx - bx, my - by)
    lead = dist / max(cfg.pass_arrival_speed + k * dist, 1e-6)  # rough travel time
    tx, ty = mx + mvx * lead, my + mvy * lead
    dist = math.hypot(tx - bx, ty - by)
    speed = min(cfg.pass_arrival_speed + k * dist, cfg.ball_max_speed)
    angle = math.atan2(ty - by, tx - bx) + math.radians(cfg.kick_angle_noise) * rng.normal()
    speed = min(max(speed * (1.0 + cfg.kick_speed_noise * rng.normal()), 0.0), cfg.ball_max_speed)
    return speed * math.cos(angle), speed * math.sin(angle)


# The members as module constants: reading ``Skill.HOLD`` costs ~0.2 us (an enum
# class attribute), and execute() runs for every player every cycle.
_HOLD, _PASS, _DRIBBLE = Skill.HOLD, Skill.PASS, Skill.DRIBBLE
_GET_OPEN, _MARK, _GUARD_LINE = Skill.GET_OPEN, Skill.MARK, Skill.GUARD_LINE
_TO_BALL = (Skill.GO_TO_BALL, Skill.INTERCEPT)
_motion = tuple.__new__  # a Motion from all five fields, without its __new__'s defaults


def execute(
    state: DrillState,
    player: int,
    command: Command,
    cfg: DrillConfig,
    rng: np.random.Generator,
) -> Motion:
    """Turn ``command`` for ``player`` into a :class:`Motion` for this cycle."""
    skill = command.skill
    px, py = state.pos[player]
    is_attacker = player < 2
    top = cfg.attacker_speed if is_attacker else cfg.defender_speed
    vmax = top * command.speed
    if skill is _DRIBBLE:
        hx, hy = dribble_heading(state, player, cfg)
        v = cfg.dribble_speed * command.speed
        return _motion(Motion, (hx * v, hy * v, CONTROL, hx, hy))
    if skill is _HOLD:
        sx, sy = shield_direction(state, player)
        v = cfg.hold_speed * command.speed
        vx, vy = sx * v, sy * v
        # Shielding backs away from pressure, but never over a touchline.
        lo, hi = _HOLD_EDGE, cfg.field_size - _HOLD_EDGE
        if (px < lo and vx < 0) or (px > hi and vx > 0):
            vx = 0.0
        if (py < lo and vy < 0) or (py > hi and vy > 0):
            vy = 0.0
        # Nor is the ball kept over a touchline or the far end: near one, it is kept along
        # the line instead (else a pressing defender simply pushes it out of the region).
        if (px < lo and sx < 0) or (px > hi and sx > 0):
            sx, sy = 0.0, (1.0 if sy > 0 else -1.0)
        if py > hi and sy > 0:
            sx, sy = (1.0 if sx > 0 else -1.0), 0.0
        return _motion(Motion, (vx, vy, CONTROL, sx, sy))
    if skill is _PASS:
        kx, ky = pass_velocity(state, player, cfg, rng)
        return _motion(Motion, (0.0, 0.0, KICK, kx, ky))
    if skill is _GET_OPEN:
        tx, ty = support_spot(state, player, cfg)
    elif skill in _TO_BALL:
        tx, ty = ball_interception_point(state, player, vmax, cfg)
    elif skill is _MARK:
        bx, by = state.pos[4]
        free = state.free_opponent_of(player)
        fx, fy = state.pos[free]
        tx, ty = fx + 0.35 * (bx - fx), fy + 0.35 * (by - fy)
    elif skill is _GUARD_LINE:
        tx = min(max(state.pos[4][0], 4.0), cfg.field_size - 4.0)
        ty = GUARD_DEPTH
    else:  # MOVE_TO
        assert command.target is not None
        tx, ty = command.target
    # Toward the target at most vmax, slowing on arrival (written here rather than in a
    # function of its own: it runs for most players every cycle, about 4 calls saved).
    dx, dy = tx - px, ty - py
    dist = math.hypot(dx, dy)
    if dist < 1e-6:
        return _motion(Motion, (0.0, 0.0, NO_BALL, 0.0, 0.0))
    speed = dist / _ARRIVE_SECONDS
    if not speed < vmax:  # min(vmax, speed), as min() compares
        speed = vmax
    return _motion(Motion, (dx / dist * speed, dy / dist * speed, NO_BALL, 0.0, 0.0))
