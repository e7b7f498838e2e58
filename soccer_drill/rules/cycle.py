"""The rules of one cycle around the physics, and of an episode's start, written once for
one drill.

Before the physics (:func:`before_physics`), the players' motions
(:mod:`soccer_drill.rules.motion`) become velocities under the acceleration cap, and the
holder's ball action becomes the ball's velocity: a kick, a small kick that keeps the
ball at the control point, or none (it rolls on, damped). After it
(:func:`after_physics`), the ball moves on arrays as pymunk moves a free body, a velocity
a collision pushed past its cap is capped, possession is decided (who controls the ball,
and which opponents may tackle), then the outcome.

The functions read one drill's records (:data:`~soccer_drill.rules.arrays.STATE` and
:data:`~soccer_drill.rules.arrays.CYCLE`) and the rule parameters by name, and are
compiled per drill (:mod:`soccer_drill.rules.compiled`);
:class:`~soccer_drill.drill.drills.BatchDrill` runs them through the loops at the end of
the module, for one drill (the single environments) or many. The random draws stay with
the caller, each drill's from its own generator in the same order: the pass's two
normals, the tackles' uniforms (:func:`tackle`).
"""

from __future__ import annotations

import math

import numpy as np

from soccer_drill.commands import Skill
from soccer_drill.config import DrillConfig
from soccer_drill.rules.arrays import Outcome
from soccer_drill.rules.compiled import compiled, hypot
from soccer_drill.rules.motion import BallAction, motions_into
from soccer_drill.tasks import TASKS

_RUNNING, _SUCCESS, _INTERCEPTION, _OUT, _TIMEOUT = (int(o) for o in Outcome)  # as stored
_NO_BALL, _CONTROL, _KICK = (int(a) for a in BallAction)  # as the motions hold them
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
def velocities_into(state, cycle, params):
    """The velocities set before the physics, into ``cycle.new_vel``: each player's
    desired velocity (``cycle.motions``) reached within the acceleration cap, the ball's
    from the holder's ball action. Returns the player who kicked the ball, or -1."""
    pos, vel, holder, motions, out = state.pos, state.vel, state.holder, cycle.motions, cycle.new_vel
    p = params[0]
    accel, dt, ball_offset = p.acceleration, p.cycle_seconds, p.ball_offset
    kicker = -1
    ball = pos.shape[0] - 1
    bvx, bvy = vel[ball, 0] * p.roll, vel[ball, 1] * p.roll  # rolling freely, unless acted on
    for i in range(ball):
        vx0, vy0 = vel[i, 0], vel[i, 1]
        dvx, dvy = motions[i, 0] - vx0, motions[i, 1] - vy0
        dv = hypot(dvx, dvy)
        if dv > accel:
            dvx, dvy = dvx * accel / dv, dvy * accel / dv
        vx, vy = vx0 + dvx, vy0 + dvy
        out[i, 0] = vx
        out[i, 1] = vy
        action = motions[i, 2]
        if action == _NO_BALL or i != holder:  # only the holder's ball skills move it
            continue
        if action == _KICK:
            bvx, bvy = motions[i, 3], motions[i, 4]
            kicker = i
        elif action == _CONTROL:
            # A small kick that puts the ball at the control point after this cycle,
            # turning it round the player by at most 40 degrees so it stays controlled.
            px, py = pos[i, 0], pos[i, 1]
            bx, by = pos[ball, 0], pos[ball, 1]
            ux, uy = turn_toward(bx - px, by - py, motions[i, 3], motions[i, 4])
            cx = px + vx * dt + ux * ball_offset
            cy = py + vy * dt + uy * ball_offset
            bvx, bvy = (cx - bx) / dt, (cy - by) / dt
    out[ball, 0], out[ball, 1] = capped(bvx, bvy, p.ball_max_speed)
    return kicker


@compiled
def recap(vel, params):
    """Cap each body's velocity in ``vel`` at its top speed (a collision can push a
    player past it); the usual case, under the cap, costs no square root."""
    p = params[0]
    ball = vel.shape[0] - 1
    for i in range(ball + 1):
        if i < p.attackers:
            cap = p.attacker_speed
        elif i < ball:
            cap = p.defender_speed
        else:
            cap = p.ball_max_speed
        vx, vy = vel[i, 0], vel[i, 1]
        if vx * vx + vy * vy > cap * cap:
            vel[i, 0], vel[i, 1] = capped(vx, vy, cap)


@compiled
def possession(state, order, dist, params):
    """Who holds the ball after this cycle's physics, before any tackle: ``(holder,
    tacklers)``, with the opponents who may tackle, nearest first, in ``order[:tacklers]``.

    ``state.holder`` is who held it before the physics (-1: loose, or just kicked). A
    player controls the ball within the control radius of it at a relative speed of at
    most the control speed, unless it passed it and is locked out. The holder keeps it
    while it controls it (then each opponent in control may tackle); a loose ball goes to
    the nearest player in control (the lower index if equal). ``order`` and ``dist`` (one
    entry per player) are scratch.
    """
    pos, vel, holder = state.pos, state.vel, state.holder
    radius, speed = params[0].control_radius, params[0].control_speed
    attackers, ball = params[0].attackers, pos.shape[0] - 1
    bx, by = pos[ball, 0], pos[ball, 1]
    bvx, bvy = vel[ball, 0], vel[ball, 1]
    locked_out = state.passer if state.cycle < state.lockout_until else -1
    count = 0
    for i in range(ball):  # in control, sorted by (distance, index) as they come
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
        if (i >= attackers) != (holder >= attackers):
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
def outcome(pos, holder, cycle, size, max_cycles, attackers, goal_line):
    """The outcome code of one drill's state: an interception (a defender, a player from
    ``attackers`` on, holds the ball), a success (with ``goal_line``, an attacker holds it
    on or past the goal line, between the posts of the field's width), out (the ball left
    the field), a timeout, else ``RUNNING``."""
    ball = pos.shape[0] - 1
    bx, by = pos[ball, 0], pos[ball, 1]
    if holder >= attackers:
        return _INTERCEPTION
    if goal_line and holder >= 0 and by <= 0.0 and 0.0 <= bx <= size:
        return _SUCCESS
    if not (0.0 <= bx <= size and 0.0 <= by <= size):
        return _OUT
    if cycle >= max_cycles:
        return _TIMEOUT
    return _RUNNING


def reward(code: int, ball_x: float, cfg: DrillConfig) -> float:
    """The attackers' reward for an episode ending with outcome ``code`` (nothing where the
    task pays no outcome: keepaway pays the time, :data:`~soccer_drill.tasks.TASKS`)."""
    if not TASKS[cfg.task].outcome_rewards:
        return 0.0
    if code == Outcome.SUCCESS:
        return cfg.success_reward(ball_x)
    return cfg.reward_timeout if code == Outcome.TIMEOUT else cfg.reward_failure


def draw_start(rng: np.random.Generator, cfg: DrillConfig) -> tuple[np.ndarray, int]:
    """An episode's start, drawn from ``rng``: each player's nominal start plus a uniform
    jitter (the players' draws first), then the attacker given the ball, which starts
    ``ball_offset`` below it. Returns the positions (``(players + 1, 2)``) and the holder."""
    players = cfg.players
    jitter = rng.uniform(-cfg.start_jitter, cfg.start_jitter, size=(players, 2))
    pos = np.empty((players + 1, 2))
    pos[:players] = np.array([*cfg.attacker_starts, *cfg.defender_starts]) + jitter
    holder = int(rng.integers(cfg.attackers))
    pos[players] = pos[holder, 0], pos[holder, 1] - cfg.ball_offset
    return pos, holder


# ------------------------------------------------------------------ one cycle
@compiled
def before_physics(state, cycle, params, table):
    """One drill's velocities set before the physics, into ``cycle.new_vel``: every
    player's motion by the skills' rules (:func:`~soccer_drill.rules.motion.motions_into`,
    into ``cycle.motions``), then :func:`velocities_into`. Returns the player who kicked
    the ball, or -1."""
    motions_into(state, cycle, params, table)
    return velocities_into(state, cycle, params)


@compiled
def after_physics(state, cycle, players, dist, params):
    """One drill's state after the physics: the players as the physics left them
    (``players``: ``(players, 4)``, ``x, y, vx, vy``), the ball moved by its velocity in
    ``cycle.new_vel``, every velocity capped (:func:`recap`).

    The ball meets nothing, so it moves as pymunk moves a free body with no gravity and
    a damping of 1, on arrays: ``p + (v + 0) * dt`` each sub-step, keeping ``v + 0`` (the
    addition of pymunk's zero force and bias velocity, which turns a -0.0 into 0.0). Then
    a kick's passer and lock-out, the cycle counted, possession (:func:`possession`,
    before any tackle, the opponents who may tackle into ``cycle.order`` and
    ``cycle.tacklers``; ``dist``: scratch of one per player) and the outcome code, which
    it returns.
    """
    pos, vel = state.pos, state.vel
    p = params[0]
    ball = pos.shape[0] - 1
    for k in range(ball):
        pos[k, 0], pos[k, 1] = players[k, 0], players[k, 1]
        vel[k, 0], vel[k, 1] = players[k, 2], players[k, 3]
    bvx, bvy = cycle.new_vel[ball, 0] + 0.0, cycle.new_vel[ball, 1] + 0.0
    step_x, step_y = bvx * p.sub_dt, bvy * p.sub_dt
    bx, by = pos[ball, 0], pos[ball, 1]
    for _ in range(p.substeps):
        bx += step_x
        by += step_y
    pos[ball, 0], pos[ball, 1] = bx, by
    vel[ball, 0], vel[ball, 1] = bvx, bvy
    recap(vel, params)  # a collision can push a body past its top speed
    if cycle.kicker >= 0:
        state.holder, state.passer = -1, cycle.kicker
        state.lockout_until = state.cycle + 1 + p.lockout_cycles
    state.cycle += 1
    state.holder, cycle.tacklers = possession(state, cycle.order, dist, params)
    state.outcome = outcome(pos, state.holder, state.cycle, p.field_size, p.max_cycles,
                            p.attackers, p.goal_line)
    return state.outcome


# ------------------------------------------------------------------ many drills
@compiled
def before_physics_of_drills(active, first, state, cycle, params, table):
    """:func:`before_physics` of the drills, the kicker into ``cycle[i].kicker``.

    With ``first`` true: of every active drill whose holder does not pass (the others are
    marked in ``cycle[i].passing``: their two normals are drawn before their rules run);
    an inactive drill's bodies stand still (velocity 0). Returns ``(ended, passes,
    active)``: the first active drill whose episode has ended (-1: none), the passes,
    the active drills. With ``first`` false: of the drills marked, their ``noise`` drawn.
    """
    ended, passes, count = -1, 0, 0
    for i in range(state.shape[0]):
        s, c = state[i], cycle[i]
        if not first:
            if c.passing == 0:
                continue
        elif not active[i]:
            c.new_vel[:, :] = 0.0
            c.kicker = -1
            c.passing = 0
            continue
        else:
            count += 1
            if s.outcome != Outcome.RUNNING and ended < 0:
                ended = i
            h = s.holder
            c.passing = 0
            if h >= 0 and c.skill[h] == Skill.PASS:
                c.passing = 1
                passes += 1
                continue
        c.kicker = before_physics(s, c, params, table)
    return ended, passes, count


@compiled
def after_physics_of_drills(active, players, state, cycle, params):
    """:func:`after_physics` of each active drill (``players``: ``(n, players, 4)``, the
    physics' players), the tackles to draw in ``cycle[i].tacklers`` (0 in inactive
    drills). Returns the number of active drills with a tackle to draw, and of those
    ended."""
    dist = np.empty(players.shape[1])
    tackling = ended = 0
    for i in range(state.shape[0]):
        c = cycle[i]
        if not active[i]:
            c.tacklers = 0
            continue
        code = after_physics(state[i], c, players[i], dist, params)
        if c.tacklers > 0:
            tackling += 1
        if code != Outcome.RUNNING:
            ended += 1
    return tackling, ended
