"""The rules of one cycle around the physics, and of an episode's start, written once for
one drill.

Before the physics (:func:`before_physics`), the players' motions
(:mod:`soccer_drill.rules.motion`) become velocities under the acceleration cap, and the
holder's ball action becomes the ball's velocity: a kick, a small kick that keeps the
ball at the control point, or none (it rolls on, damped). After it
(:func:`after_physics`), the ball moves on arrays as pymunk moves a free body, a velocity
a collision pushed past its cap is capped, possession is decided (who controls the ball,
and which opponents may tackle), then the outcome.

The functions read one drill's arrays (``pos`` and ``vel``: ``(5, 2)`` float64, the
four players then the ball) and are compiled per drill (:mod:`soccer_drill.rules.compiled`);
:class:`~soccer_drill.drill.BatchDrill` runs them through the loops at the end of the
module, for one drill (the single environments) or many. The random draws stay with the
caller, each drill's from its own generator in the same order: the pass's two normals,
the tackles' uniforms (:func:`tackle`).
"""

from __future__ import annotations

import math

import numpy as np

from soccer_drill.config import DrillConfig
from soccer_drill.rules.compiled import compiled, hypot
from soccer_drill.rules.motion import (
    ATTACKER_SPEED,
    BALL_MAX_SPEED,
    CONTROL,
    DEFENDER_SPEED,
    KICK,
    NO_BALL,
    PASS,
    motions_into,
)

RUNNING, SUCCESS, INTERCEPTION, OUT, TIMEOUT = range(5)
"""Outcome codes: an episode still running, then ``1 + OUTCOMES.index(name)``."""
_MAX_TURN = math.radians(40.0)  # the ball's turn round its holder per cycle
_TWO_PI = 2 * math.pi


@compiled
def capped(vx, vy, cap):
    """``(vx, vy)`` scaled down to speed ``cap`` if it is faster."""
    speed = hypot(vx, vy)
    if speed <= cap:
        return vx, vy
    return vx * cap / speed, vy * cap / speed


@compiled
def turn_toward(fx, fy, tx, ty):
    """Unit vector from direction f toward direction t, rotated by at most 40 degrees."""
    b = math.atan2(ty, tx)
    a = math.atan2(fy, fx) if (fx != 0.0 or fy != 0.0) else b
    delta = (b - a + math.pi) % _TWO_PI - math.pi
    turn = delta if delta < _MAX_TURN else _MAX_TURN  # max(-t, min(t, delta)), as compared
    a += turn if turn > -_MAX_TURN else -_MAX_TURN
    return math.cos(a), math.sin(a)


@compiled
def velocities_into(out, pos, vel, holder, motions, accel, dt, ball_offset, roll, ball_max):
    """The velocities set before the physics, into ``out`` (``(5, 2)``): each player's
    desired velocity reached within ``accel`` (m/s per cycle), the ball's from the
    holder's ball action. Returns the player who kicked the ball, or -1."""
    kicker = -1
    bvx, bvy = vel[4, 0] * roll, vel[4, 1] * roll  # rolling freely, unless acted on
    for i in range(4):
        vx0, vy0 = vel[i, 0], vel[i, 1]
        dvx, dvy = motions[i, 0] - vx0, motions[i, 1] - vy0
        dv = hypot(dvx, dvy)
        if dv > accel:
            dvx, dvy = dvx * accel / dv, dvy * accel / dv
        vx, vy = vx0 + dvx, vy0 + dvy
        out[i, 0] = vx
        out[i, 1] = vy
        action = motions[i, 2]
        if action == NO_BALL or i != holder:  # only the holder's ball skills move the ball
            continue
        if action == KICK:
            bvx, bvy = motions[i, 3], motions[i, 4]
            kicker = i
        elif action == CONTROL:
            # A small kick that puts the ball at the control point after this cycle,
            # turning it round the player by at most 40 degrees so it stays controlled.
            px, py = pos[i, 0], pos[i, 1]
            bx, by = pos[4, 0], pos[4, 1]
            ux, uy = turn_toward(bx - px, by - py, motions[i, 3], motions[i, 4])
            cx = px + vx * dt + ux * ball_offset
            cy = py + vy * dt + uy * ball_offset
            bvx, bvy = (cx - bx) / dt, (cy - by) / dt
    out[4, 0], out[4, 1] = capped(bvx, bvy, ball_max)
    return kicker


@compiled
def recap(vel, params):
    """Cap each body's velocity in ``vel`` at its top speed (a collision can push a
    player past it); the usual case, under the cap, costs no square root."""
    for i in range(5):
        if i < 2:
            cap = params[ATTACKER_SPEED]
        elif i < 4:
            cap = params[DEFENDER_SPEED]
        else:
            cap = params[BALL_MAX_SPEED]
        vx, vy = vel[i, 0], vel[i, 1]
        if vx * vx + vy * vy > cap * cap:
            vel[i, 0], vel[i, 1] = capped(vx, vy, cap)


@compiled
def possession(order, dist, pos, vel, holder, cycle, passer, lockout_until, radius, speed):
    """Who holds the ball after this cycle's physics, before any tackle: ``(holder,
    tacklers)``, with the opponents who may tackle, nearest first, in ``order[:tacklers]``.

    ``holder`` is who held it before the physics (-1: loose, or just kicked). A player
    controls the ball within ``radius`` of it at a relative speed of at most ``speed``,
    unless it passed it and is locked out. The holder keeps it while it controls it (then
    each opponent in control may tackle); a loose ball goes to the nearest player in
    control (the lower index if equal). ``order`` and ``dist`` (4 entries) are scratch.
    """
    bx, by = pos[4, 0], pos[4, 1]
    bvx, bvy = vel[4, 0], vel[4, 1]
    locked_out = passer if cycle < lockout_until else -1
    count = 0
    for i in range(4):  # in control, sorted by (distance, index) as they come
        d = hypot(pos[i, 0] - bx, pos[i, 1] - by)
        if d <= radius and i != locked_out and hypot(bvx - vel[i, 0], bvy - vel[i, 1]) <= speed:
            k = count
            while k > 0 and dist[k - 1] > d:
                order[k], dist[k] = order[k - 1], dist[k - 1]
                k -= 1
            order[k], dist[k] = i, d
            count += 1
    keeps = False
    for k in range(count):
        if order[k] == holder:
            keeps = True
    if not keeps:
        return (order[0] if count > 0 else -1), 0
    tacklers = 0
    for k in range(count):
        i = order[k]
        if (i >= 2) != (holder >= 2):
            order[tacklers] = i
            tacklers += 1
    return holder, tacklers


def tackle(order: np.ndarray, tacklers: int, rng: np.random.Generator, probability: float) -> int:
    """The first of ``order[:tacklers]`` whose uniform draw from ``rng`` is below
    ``probability`` (one draw per opponent tried), or -1: no tackle."""
    for k in range(tacklers):
        if rng.random() < probability:
            return int(order[k])
    return -1


@compiled
def outcome(pos, holder, cycle, size, max_cycles):
    """The outcome code of one drill's state: an interception (a defender holds the
    ball), a success (an attacker holds it on or past the goal line, between the posts
    of the field's width), out (the ball left the field), a timeout, else ``RUNNING``."""
    bx, by = pos[4, 0], pos[4, 1]
    if holder >= 2:
        return INTERCEPTION
    if holder >= 0 and by <= 0.0 and 0.0 <= bx <= size:
        return SUCCESS
    if not (0.0 <= bx <= size and 0.0 <= by <= size):
        return OUT
    if cycle >= max_cycles:
        return TIMEOUT
    return RUNNING


def reward(code: int, ball_x: float, cfg: DrillConfig) -> float:
    """The attackers' reward for an episode ending with outcome ``code``."""
    if code == SUCCESS:
        return cfg.success_reward(ball_x)
    return cfg.reward_timeout if code == TIMEOUT else cfg.reward_failure


def draw_start(rng: np.random.Generator, cfg: DrillConfig) -> tuple[np.ndarray, int]:
    """An episode's start, drawn from ``rng``: each player's nominal start plus a uniform
    jitter (the four players' draws first), then the attacker given the ball, which
    starts ``ball_offset`` below it. Returns the positions (``(5, 2)``) and the holder."""
    jitter = rng.uniform(-cfg.start_jitter, cfg.start_jitter, size=(4, 2))
    pos = np.empty((5, 2))
    pos[:4] = np.array([*cfg.attacker_starts, *cfg.defender_starts]) + jitter
    holder = int(rng.integers(2))
    pos[4] = pos[holder, 0], pos[holder, 1] - cfg.ball_offset
    return pos, holder


# ------------------------------------------------------------------ one cycle
@compiled
def before_physics(out, motions, pos, vel, holder, skill, target, speed, noise, params, table,
                   accel, dt, ball_offset, roll, ball_max):
    """One drill's velocities set before the physics, into ``out`` (``(5, 2)``): every
    player's motion by the skills' rules (:func:`~soccer_drill.rules.motion.motions_into`,
    into ``motions``), then :func:`velocities_into`. Returns the player who kicked the
    ball, or -1."""
    motions_into(motions, pos, vel, holder, skill, target, speed, noise, params, table)
    return velocities_into(out, pos, vel, holder, motions, accel, dt, ball_offset, roll,
                           ball_max)


@compiled
def after_physics(pos, vel, players, set_vel, order, dist, holder, kicker, cycle, passer,
                  lockout_until, substeps, sub_dt, lockout_cycles, params, radius,
                  control_speed, size, max_cycles):
    """One drill's state after the physics, written into ``pos`` and ``vel``: the
    players as the physics left them (``players``: ``(4, 4)``, ``x, y, vx, vy``), the
    ball moved by its velocity in ``set_vel``, every velocity capped (:func:`recap`).

    The ball meets nothing, so it moves as pymunk moves a free body with no gravity and
    a damping of 1, on arrays: ``p + (v + 0) * dt`` each of the ``substeps`` sub-steps,
    keeping ``v + 0`` (the addition of pymunk's zero force and bias velocity, which turns
    a -0.0 into 0.0). Then a kick's passer and lock-out, the cycle counted, possession
    (:func:`possession`, before any tackle) and the outcome.

    Returns ``(holder, tacklers, cycle, passer, lockout_until, code)``, the opponents
    who may tackle in ``order[:tacklers]`` (``order`` and ``dist``: scratch of 4).
    """
    for k in range(4):
        pos[k, 0], pos[k, 1] = players[k, 0], players[k, 1]
        vel[k, 0], vel[k, 1] = players[k, 2], players[k, 3]
    bvx, bvy = set_vel[4, 0] + 0.0, set_vel[4, 1] + 0.0
    step_x, step_y = bvx * sub_dt, bvy * sub_dt
    bx, by = pos[4, 0], pos[4, 1]
    for _ in range(substeps):
        bx += step_x
        by += step_y
    pos[4, 0], pos[4, 1] = bx, by
    vel[4, 0], vel[4, 1] = bvx, bvy
    recap(vel, params)  # a collision can push a body past its top speed
    if kicker >= 0:
        holder, passer, lockout_until = -1, kicker, cycle + 1 + lockout_cycles
    cycle += 1
    holder, tacklers = possession(order, dist, pos, vel, holder, cycle, passer, lockout_until,
                                  radius, control_speed)
    return (holder, tacklers, cycle, passer, lockout_until,
            outcome(pos, holder, cycle, size, max_cycles))


# ------------------------------------------------------------------ many drills
# Each drill's scratch of a cycle, one int64 row: who may tackle (4), their number, the
# kicker, whether its holder passes (in one array: every array handed to compiled code
# costs its dispatch about 50 ns, as much as the rules of a step of some skills).
ORDER, TACKLERS, KICKER, PASSING, SCRATCH = 0, 4, 5, 6, 7


@compiled
def before_physics_of_drills(active, first, skill, target, speed, code, pos, vel, holder, noise,
                             out, scratch, motions, params, table, accel, dt, ball_offset, roll,
                             ball_max):
    """:func:`before_physics` of the drills, the kicker into ``scratch[i, KICKER]``.

    With ``first`` true: of every active drill whose holder does not pass (the others are
    marked in ``scratch[i, PASSING]``: their two normals are drawn before their rules
    run); an inactive drill's bodies stand still (velocity 0). Returns ``(ended, passes,
    active)``: the first active drill whose episode has ended (-1: none), the passes,
    the active drills. With ``first`` false: of the drills marked, their ``noise`` drawn.
    """
    ended, passes, count = -1, 0, 0
    for i in range(pos.shape[0]):
        if not first:
            if scratch[i, PASSING] == 0:
                continue
        elif not active[i]:
            out[i] = 0.0
            scratch[i, KICKER] = -1
            scratch[i, PASSING] = 0
            continue
        else:
            count += 1
            if code[i] != RUNNING and ended < 0:
                ended = i
            h = holder[i]
            scratch[i, PASSING] = 0
            if h >= 0 and skill[i, h] == PASS:
                scratch[i, PASSING] = 1
                passes += 1
                continue
        scratch[i, KICKER] = before_physics(out[i], motions[i], pos[i], vel[i], holder[i],
                                            skill[i], target[i], speed[i], noise[i], params,
                                            table, accel, dt, ball_offset, roll, ball_max)
    return ended, passes, count


@compiled
def after_physics_of_drills(active, players, pos, vel, holder, cycle, passer, lockout_until, code,
                            scratch, set_vel, substeps, sub_dt, lockout_cycles, params, radius,
                            control_speed, size, max_cycles):
    """:func:`after_physics` of each active drill, into its rows of the state's arrays,
    ``code`` (the outcome before any tackle) and ``scratch`` (the opponents who may tackle
    and their number, 0 in inactive drills). Returns the number of active drills with a
    tackle to draw, and of those ended."""
    dist = np.empty(4)
    tackling = ended = 0
    for i in range(pos.shape[0]):
        if not active[i]:
            scratch[i, TACKLERS] = 0
            continue
        h, t, c, p, lock, result = after_physics(
            pos[i], vel[i], players[i], set_vel[i], scratch[i, ORDER:TACKLERS], dist, holder[i],
            scratch[i, KICKER], cycle[i], passer[i], lockout_until[i], substeps, sub_dt,
            lockout_cycles, params, radius, control_speed, size, max_cycles)
        holder[i], scratch[i, TACKLERS], cycle[i], passer[i], lockout_until[i], code[i] = (
            h, t, c, p, lock, result)
        if t > 0:
            tackling += 1
        if result != RUNNING:
            ended += 1
    return tackling, ended
