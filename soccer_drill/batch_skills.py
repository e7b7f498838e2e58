"""The skills of :mod:`soccer_drill.skills` for many drills at once, on arrays.

Every function here computes, for ``N`` drills at once, what the function of the same
name in :mod:`soccer_drill.skills` (or :class:`~soccer_drill.support.SupportPlayer`)
computes for one: the same formulas in the same order of operations, so that from the
same state they give the same numbers (``tests/test_batch.py`` checks them against
the single drill's functions on states of real episodes). Where the single code stops
a search early (the interception point, the dribbling heading) the batched code scans
every candidate: the single code's early stop is proven to find the same point.

Arrays: ``pos`` and ``vel`` are ``(N, 5, 2)`` float64 (the four players then the ball,
as :attr:`DrillState.pos`), ``holder`` is ``(N,)`` int (-1: a loose ball).
"""

from __future__ import annotations

import math

import numpy as np

from soccer_drill.config import DrillConfig
from soccer_drill.skills import (
    _ARRIVE_SECONDS,
    _HEADINGS,
    _HOLD_EDGE,
    _LEAD_SECONDS,
    GUARD_DEPTH,
    Skill,
    _roll_table,
)

NO_BALL, CONTROL, KICK = 0, 1, 2
_OPPONENTS = np.array([[2, 3], [2, 3], [0, 1], [0, 1]])  # per player index
_HX = np.array([h[0] for h in _HEADINGS])
_HY = np.array([h[1] for h in _HEADINGS])
_HSCORE = np.array([h[2] for h in _HEADINGS])
_MAX_TURN = math.radians(40.0)


def _unit(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``skills._unit`` on arrays: ``(x, y) / |(x, y)|``, or ``(0, -1)`` for a tiny vector."""
    n = np.hypot(x, y)
    ok = n > 1e-9
    safe = np.where(ok, n, 1.0)
    return np.where(ok, x / safe, 0.0), np.where(ok, y / safe, -1.0)


def interception_points(
    pos: np.ndarray, vel: np.ndarray, holder: np.ndarray, vmax: np.ndarray, cfg: DrillConfig
) -> np.ndarray:
    """``ball_interception_point`` of each of the four players: ``(N, 4, 2)``.

    ``vmax`` is ``(N, 4)``: each player's top speed times its command's speed.
    """
    n = len(pos)
    ball, bvel = pos[:, 4], vel[:, 4]
    bx, by = ball[:, 0:1], ball[:, 1:2]
    bvx, bvy = bvel[:, 0:1], bvel[:, 1:2]
    px, py = pos[:, :4, 0], pos[:, :4, 1]
    players = np.arange(4)
    held = holder >= 0
    other_holds = held[:, None] & (holder[:, None] != players)
    hvel = vel[np.arange(n), np.where(held, holder, 0)]
    safe_vmax = np.where(vmax > 0, vmax, 1.0)
    lead = np.where(vmax > 0, np.hypot(bx - px, by - py) / safe_vmax, 0.0)
    lead = np.where(_LEAD_SECONDS < lead, _LEAD_SECONDS, lead)
    out_x = np.where(other_holds, bx + hvel[:, 0:1] * lead, bx)
    out_y = np.where(other_holds, by + hvel[:, 1:2] * lead, by)
    rolling = (~held & (np.hypot(bvx, bvy)[:, 0] >= 1.0))
    if rolling.any():
        rows = np.flatnonzero(rolling)
        times, travels, _, _ = _roll_table(cfg.ball_damping, cfg.cycle_seconds)
        times_a, travels_a = np.asarray(times), np.asarray(travels)
        x = bx[rows] + bvx[rows] * travels_a  # (R, K)
        y = by[rows] + bvy[rows] * travels_a
        dx = x[:, None, :] - px[rows][:, :, None]  # (R, 4, K)
        dy = y[:, None, :] - py[rows][:, :, None]
        r = vmax[rows][:, :, None] * times_a + cfg.control_radius
        reach = dx * dx + dy * dy <= r * r
        reach[:, :, -1] = True  # none within reach: the last point
        k = reach.argmax(axis=2)  # the first point within reach
        out_x[rows] = np.take_along_axis(np.broadcast_to(x[:, None, :], reach.shape), k[..., None], 2)[..., 0]
        out_y[rows] = np.take_along_axis(np.broadcast_to(y[:, None, :], reach.shape), k[..., None], 2)[..., 0]
    return np.stack((out_x, out_y), axis=2)


def support_spots(pos: np.ndarray, cfg: DrillConfig) -> np.ndarray:
    """``support_spot`` of each of the four players: ``(N, 4, 2)``."""
    size = cfg.field_size
    bx, by = pos[:, 4, 0:1], pos[:, 4, 1:2]
    px = pos[:, :4, 0]
    side = np.where(px >= bx, 1.0, -1.0)
    spot = bx + side * 11.0
    side = np.where((spot >= 3.0) & (spot <= size - 3.0), side, -side)
    tx = np.clip(bx + side * 11.0, 2.0, size - 2.0)
    ty = np.broadcast_to(np.clip(by - 3.0, 2.0, size - 2.0), tx.shape).copy()
    for k in (0, 1):  # the two opponents in order, as the single code steps away
        opp = pos[:, _OPPONENTS[:, k]]  # (N, 4, 2)
        dx, dy = tx - opp[..., 0], ty - opp[..., 1]
        dist = np.hypot(dx, dy)
        ux, uy = _unit(dx, dy)
        near = dist < 5.0
        tx = np.where(near, tx + ux * (5.0 - dist), tx)
        ty = np.where(near, ty + uy * (5.0 - dist), ty)
    return np.stack((np.clip(tx, 1.0, size - 1.0), np.clip(ty, 1.0, size - 1.0)), axis=2)


def dribble_headings(pos: np.ndarray, player: np.ndarray, cfg: DrillConfig) -> np.ndarray:
    """``dribble_heading`` of attacker ``player[i]`` in drill ``i``: ``(N, 2)``."""
    rows = np.arange(len(pos))
    p = pos[rows, player]
    px, py = p[:, 0:1], p[:, 1:2]
    score = np.broadcast_to(_HSCORE, (len(pos), len(_HSCORE)))
    for d in (2, 3):
        rx, ry = pos[:, d, 0:1] - px, pos[:, d, 1:2] - py
        ahead = rx * _HX + ry * _HY
        free = 1.0 - np.abs(rx * _HY - ry * _HX) / 4.0
        penalty = 2.0 * np.where(free > 0.0, free, 0.0) * (1.0 - ahead / 12.0)
        score = score - np.where((ahead > 0.0) & (ahead < 12.0), penalty, 0.0)
    ex = px + _HX * 4.0
    score = score - np.where((ex >= 1.0) & (ex <= cfg.field_size - 1.0), 0.0, 3.0)
    best = score.argmax(axis=1)  # the first of equal scores in _HEADINGS order
    return np.stack((_HX[best], _HY[best]), axis=1)


def shield_directions(pos: np.ndarray, player: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``shield_direction`` of ``player[i]`` in drill ``i``."""
    rows = np.arange(len(pos))
    p = pos[rows, player]
    o1, o2 = pos[rows, _OPPONENTS[player, 0]], pos[rows, _OPPONENTS[player, 1]]
    d1 = np.hypot(o1[:, 0] - p[:, 0], o1[:, 1] - p[:, 1])
    d2 = np.hypot(o2[:, 0] - p[:, 0], o2[:, 1] - p[:, 1])
    near = np.where((d2 < d1)[:, None], o2, o1)
    return _unit(p[:, 0] - near[:, 0], p[:, 1] - near[:, 1])


def pass_velocities(
    pos: np.ndarray, vel: np.ndarray, player: np.ndarray, noise: np.ndarray, cfg: DrillConfig
) -> np.ndarray:
    """``pass_velocity`` of ``player[i]``, with ``noise[i]`` its two standard normals."""
    rows = np.arange(len(pos))
    bx, by = pos[:, 4, 0], pos[:, 4, 1]
    mate = player ^ 1
    mx, my = pos[rows, mate, 0], pos[rows, mate, 1]
    mvx, mvy = vel[rows, mate, 0], vel[rows, mate, 1]
    k = -math.log(max(cfg.ball_damping, 1e-6))
    dist = np.hypot(mx - bx, my - by)
    lead = dist / np.maximum(cfg.pass_arrival_speed + k * dist, 1e-6)
    tx, ty = mx + mvx * lead, my + mvy * lead
    dist = np.hypot(tx - bx, ty - by)
    speed = np.minimum(cfg.pass_arrival_speed + k * dist, cfg.ball_max_speed)
    angle = np.arctan2(ty - by, tx - bx) + math.radians(cfg.kick_angle_noise) * noise[:, 0]
    speed = np.minimum(
        np.maximum(speed * (1.0 + cfg.kick_speed_noise * noise[:, 1]), 0.0), cfg.ball_max_speed
    )
    return np.stack((speed * np.cos(angle), speed * np.sin(angle)), axis=1)


def mark_targets(pos: np.ndarray, holder: np.ndarray, fraction: float = 0.35) -> np.ndarray:
    """Where each of the four players marks (``MARK``): ``fraction`` of the way from its
    free opponent to the ball. ``(N, 4, 2)``."""
    free = free_opponents(pos, holder)  # (N, 4)
    rows = np.arange(len(pos))[:, None]
    f = pos[rows, free]  # (N, 4, 2)
    ball = pos[:, 4:5]
    return f + fraction * (ball - f)


def free_opponents(pos: np.ndarray, holder: np.ndarray) -> np.ndarray:
    """``DrillState.free_opponent_of`` for each of the four players: ``(N, 4)`` indices."""
    a, b = _OPPONENTS[:, 0], _OPPONENTS[:, 1]  # (4,)
    ball = pos[:, 4:5]
    da = np.hypot(pos[:, a, 0] - ball[..., 0], pos[:, a, 1] - ball[..., 1])
    db = np.hypot(pos[:, b, 0] - ball[..., 0], pos[:, b, 1] - ball[..., 1])
    h = holder[:, None]
    return np.where(h == a, b, np.where(h == b, a, np.where(da > db, a, b)))


def guard_targets(pos: np.ndarray, cfg: DrillConfig) -> np.ndarray:
    """``GUARD_LINE``'s spot (level with the ball, ``GUARD_DEPTH`` up): ``(N, 2)``."""
    x = np.minimum(np.maximum(pos[:, 4, 0], 4.0), cfg.field_size - 4.0)
    return np.stack((x, np.full_like(x, GUARD_DEPTH)), axis=1)


def toward(pos: np.ndarray, target: np.ndarray, vmax: np.ndarray) -> np.ndarray:
    """The run of ``execute`` toward ``target`` at most ``vmax``, slowing on arrival."""
    dx, dy = target[..., 0] - pos[..., 0], target[..., 1] - pos[..., 1]
    dist = np.hypot(dx, dy)
    speed = dist / _ARRIVE_SECONDS
    speed = np.where(speed < vmax, speed, vmax)
    moving = dist >= 1e-6
    safe = np.where(moving, dist, 1.0)  # dx / dist * speed, as the single code computes it
    return np.stack(
        (np.where(moving, dx / safe * speed, 0.0), np.where(moving, dy / safe * speed, 0.0)),
        axis=-1,
    )


_TO_BALL = (int(Skill.GO_TO_BALL), int(Skill.INTERCEPT))


def off_ball_targets(
    pos: np.ndarray,
    vel: np.ndarray,
    holder: np.ndarray,
    skill: np.ndarray,
    target: np.ndarray,
    vmax: np.ndarray,
    cfg: DrillConfig,
) -> np.ndarray:
    """The target of each player's off-ball skill (``(N, 4, 2)``; ball skills: any value)."""
    out = target.copy()
    to_ball = (skill == _TO_BALL[0]) | (skill == _TO_BALL[1])
    if to_ball.any():
        out = np.where(to_ball[..., None], interception_points(pos, vel, holder, vmax, cfg), out)
    get_open = skill == int(Skill.GET_OPEN)
    if get_open.any():
        out = np.where(get_open[..., None], support_spots(pos, cfg), out)
    mark = skill == int(Skill.MARK)
    if mark.any():
        out = np.where(mark[..., None], mark_targets(pos, holder), out)
    guard = skill == int(Skill.GUARD_LINE)
    if guard.any():
        out = np.where(guard[..., None], guard_targets(pos, cfg)[:, None, :], out)
    return out


def holder_motion(
    pos: np.ndarray,
    vel: np.ndarray,
    holder: np.ndarray,
    skill: np.ndarray,
    speed: np.ndarray,
    noise: np.ndarray | None,
    cfg: DrillConfig,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``execute`` of the ball skills for the holder ``holder[i]`` of each drill given.

    ``skill`` and ``speed`` are the holder's command; ``noise`` the ``(N, 2)`` standard
    normals of the drills that pass (any values elsewhere). Returns the desired velocity
    ``(N, 2)``, the ball action ``(N,)`` and the ball vector ``(N, 2)``.
    """
    n = len(pos)
    rows = np.arange(n)
    mv = np.zeros((n, 2))
    bvec = np.zeros((n, 2))
    action = np.zeros(n, dtype=np.int8)
    dribble = skill == int(Skill.DRIBBLE)
    if dribble.any():
        r = rows[dribble]
        h = dribble_headings(pos[r], holder[r], cfg)
        v = cfg.dribble_speed * speed[r]
        mv[r] = h * v[:, None]
        bvec[r] = h
        action[r] = CONTROL
    hold = skill == int(Skill.HOLD)
    if hold.any():
        r = rows[hold]
        sx, sy = shield_directions(pos[r], holder[r])
        v = cfg.hold_speed * speed[r]
        vx, vy = sx * v, sy * v
        p = pos[r, holder[r]]
        px, py = p[:, 0], p[:, 1]
        lo, hi = _HOLD_EDGE, cfg.field_size - _HOLD_EDGE
        vx = np.where(((px < lo) & (vx < 0)) | ((px > hi) & (vx > 0)), 0.0, vx)
        vy = np.where(((py < lo) & (vy < 0)) | ((py > hi) & (vy > 0)), 0.0, vy)
        side = ((px < lo) & (sx < 0)) | ((px > hi) & (sx > 0))
        sx, sy = np.where(side, 0.0, sx), np.where(side, np.where(sy > 0, 1.0, -1.0), sy)
        far = (py > hi) & (sy > 0)
        sx, sy = np.where(far, np.where(sx > 0, 1.0, -1.0), sx), np.where(far, 0.0, sy)
        mv[r] = np.stack((vx, vy), axis=1)
        bvec[r] = np.stack((sx, sy), axis=1)
        action[r] = CONTROL
    kick = skill == int(Skill.PASS)
    if kick.any():
        r = rows[kick]
        assert noise is not None
        bvec[r] = pass_velocities(pos[r], vel[r], holder[r], noise[r], cfg)
        action[r] = KICK
    return mv, action, bvec


def turn_toward(
    fx: np.ndarray, fy: np.ndarray, tx: np.ndarray, ty: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``drill._turn_toward`` on arrays: from direction f toward t by at most 40 degrees."""
    b = np.arctan2(ty, tx)
    a = np.where((fx != 0) | (fy != 0), np.arctan2(fy, fx), b)
    delta = np.remainder(b - a + math.pi, 2 * math.pi) - math.pi
    a = a + np.maximum(-_MAX_TURN, np.minimum(_MAX_TURN, delta))
    return np.cos(a), np.sin(a)
