"""The skills of :mod:`soccer_drill.skills` for many drills at once, on arrays.

Every function here computes, for ``N`` drills at once, what the function of the same
name in :mod:`soccer_drill.skills` (or :class:`~soccer_drill.support.SupportPlayer`)
computes for one: the same formulas in the same order of operations, so that from the
same state they give the same numbers (``tests/test_vector.py`` checks them against
the single drill's functions on states of real episodes). Where the single code stops
a search early (the interception point, the dribbling heading) the batched code scans
every candidate: the single code's early stop is proven to find the same point.

The cost of a call is mostly NumPy's fixed cost per operation (about 1 us, whatever
``N``), so the formulas work on ``(..., 2)`` vectors where the single code repeats a
line for x and y (one operation instead of two, the same floats), compute a skill for
every player at once rather than gathering the players that use it, and pick results
with lookup tables rather than ``np.isin`` or ``np.select``. Where vectors are only
selected, added or subtracted they are viewed as one complex number each (:func:`z`,
:func:`xy`): NumPy then runs one loop over the vectors instead of one per pair of
floats, about twice as fast on ``(N, 4, 2)`` arrays, with the same floats. Skills that
only some players or drills use are computed on those: the support spots of the
attackers, the marks of the defenders, the holder's dribble and hold on the rows of the
drills where the holder does that.

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
_FIRST_OPPONENT, _SECOND_OPPONENT = _OPPONENTS[:, 0], _OPPONENTS[:, 1]
_PLAYERS = np.arange(4)
_HX = np.array([h[0] for h in _HEADINGS])
_HY = np.array([h[1] for h in _HEADINGS])
_HSCORE = np.array([h[2] for h in _HEADINGS])
_MAX_TURN = math.radians(40.0)
_DOWN = np.array([0.0, -1.0])  # skills._unit of a tiny vector
_DOWN_Z = complex(0.0, -1.0)
_ALL, _ATTACKERS, _DEFENDERS = slice(0, 4), slice(0, 2), slice(2, 4)
_rows_cache: dict[int, np.ndarray] = {}


def z(a: np.ndarray) -> np.ndarray:
    """The ``(..., 2)`` float64 vectors ``a`` as one complex128 each, a view (its last axis
    must be contiguous): selections (``np.where``, ``np.copyto``), additions and
    subtractions of whole vectors in one pass over the vectors rather than over pairs of
    floats, with the same floats (a complex sum is the sums of the two parts)."""
    return a.view(np.complex128)[..., 0]


def xy(a: np.ndarray) -> np.ndarray:
    """The complex128 array ``a`` as ``(..., 2)`` float64 vectors, a view (:func:`z`'s inverse)."""
    return a[..., None].view(np.float64)


def rows(n: int) -> np.ndarray:
    """``np.arange(n)``, made once per ``n`` (read-only)."""
    r = _rows_cache.get(n)
    if r is None:
        r = _rows_cache[n] = np.arange(n)
        r.flags.writeable = False
    return r


def _units(v: np.ndarray, norm: np.ndarray) -> np.ndarray:
    """``skills._unit`` of the vectors ``v`` (``(..., 2)``) of length ``norm``."""
    ok = norm > 1e-9
    return xy(np.where(ok, z(v / np.where(ok, norm, 1.0)[..., None]), _DOWN_Z))


def interception_points(
    pos: np.ndarray, vel: np.ndarray, holder: np.ndarray, vmax: np.ndarray, cfg: DrillConfig
) -> np.ndarray:
    """``ball_interception_point`` of each of the four players: ``(N, 4, 2)``.

    ``vmax`` is ``(N, 4)``: each player's top speed times its command's speed (> 0, as
    every speed of the drill is).
    """
    ball = z(pos)[:, 4:5]  # (N, 1)
    d = xy(ball - z(pos)[:, :4])
    lead = np.hypot(d[..., 0], d[..., 1])
    lead /= vmax
    np.minimum(lead, _LEAD_SECONDS, out=lead)  # min(lead, _LEAD_SECONDS), NaN kept
    carried = vel[rows(len(pos)), holder][:, None, :] * lead[..., None]  # holder -1: unused
    other_holds = (holder[:, None] >= 0) & (holder[:, None] != _PLAYERS)
    out = xy(np.where(other_holds, z(carried) + ball, ball))
    bvel = vel[:, 4]
    rolling = (holder < 0) & (np.hypot(bvel[:, 0], bvel[:, 1]) >= 1.0)
    if np.count_nonzero(rolling):
        r = np.nonzero(rolling)[0]
        times_a, travels_a = _roll_arrays(cfg.ball_damping, cfg.cycle_seconds)
        x = pos[r, 4, 0:1] + vel[r, 4, 0:1] * travels_a  # (R, K)
        y = pos[r, 4, 1:2] + vel[r, 4, 1:2] * travels_a
        dx = x[:, None, :] - pos[r, :4, 0][:, :, None]  # (R, 4, K)
        dy = y[:, None, :] - pos[r, :4, 1][:, :, None]
        reach = vmax[r][:, :, None] * times_a + cfg.control_radius
        within = dx * dx + dy * dy <= reach * reach
        within[:, :, -1] = True  # none within reach: the last point
        k = within.argmax(axis=2)  # the first point within reach, (R, 4)
        rr = rows(len(r))[:, None]
        out[r, :, 0] = x[rr, k]
        out[r, :, 1] = y[rr, k]
    return out


_roll_cache: dict[tuple[float, float], tuple[np.ndarray, np.ndarray]] = {}


def _roll_arrays(damping: float, cycle: float) -> tuple[np.ndarray, np.ndarray]:
    """``_roll_table``'s times and travels as arrays, made once per ``(damping, cycle)``."""
    key = (damping, cycle)
    arrays = _roll_cache.get(key)
    if arrays is None:
        times, travels, _, _ = _roll_table(damping, cycle)
        arrays = _roll_cache[key] = (np.array(times), np.array(travels))
        for a in arrays:
            a.flags.writeable = False
    return arrays


def support_spots(pos: np.ndarray, cfg: DrillConfig, players: slice = _ALL) -> np.ndarray:
    """``support_spot`` of each of the four players, or of ``players`` (a slice of
    them): ``(N, 4, 2)`` (``(N, k, 2)`` for ``k`` players)."""
    size = cfg.field_size
    bx = pos[:, 4, 0:1]
    side = np.where(pos[:, players, 0] >= bx, 11.0, -11.0)  # side * 11.0, exactly
    spot = bx + side
    side = np.where((spot >= 3.0) & (spot <= size - 3.0), side, -side)
    t = np.empty((len(pos), side.shape[1], 2))
    tx = np.add(bx, side, out=t[..., 0])
    np.minimum(np.maximum(tx, 2.0, out=tx), size - 2.0, out=tx)
    t[..., 1] = pos[:, 4, 1:2] - 3.0
    np.minimum(np.maximum(t[..., 1], 2.0, out=t[..., 1]), size - 2.0, out=t[..., 1])
    tz, pz = z(t), z(pos)
    for opponents in (_FIRST_OPPONENT[players], _SECOND_OPPONENT[players]):  # in order
        d = xy(tz - pz[:, opponents])
        dist = np.hypot(d[..., 0], d[..., 1])
        near = dist < 5.0
        if not np.count_nonzero(near):  # no spot moves away from this opponent
            continue
        step = _units(d, dist) * (5.0 - dist)[..., None]
        tz = np.where(near, tz + z(step), tz)
    t = xy(tz)
    return np.minimum(np.maximum(t, 1.0, out=t), size - 1.0, out=t)


def dribble_headings(pos: np.ndarray, player: np.ndarray, cfg: DrillConfig) -> np.ndarray:
    """``dribble_heading`` of attacker ``player[i]`` in drill ``i``: ``(N, 2)``."""
    p = pos[rows(len(pos)), player]
    px, py = p[:, 0:1], p[:, 1:2]
    score = _HSCORE
    for d in (2, 3):
        rx, ry = pos[:, d, 0:1] - px, pos[:, d, 1:2] - py
        ahead = rx * _HX + ry * _HY
        free = 1.0 - np.abs(rx * _HY - ry * _HX) / 4.0
        penalty = 2.0 * np.where(free > 0.0, free, 0.0) * (1.0 - ahead / 12.0)
        score = score - np.where((ahead > 0.0) & (ahead < 12.0), penalty, 0.0)
    ex = px + _HX * 4.0
    score = score - np.where((ex >= 1.0) & (ex <= cfg.field_size - 1.0), 0.0, 3.0)
    best = score.argmax(axis=1)  # the first of equal scores in _HEADINGS order
    return _HEADING_VECTORS[best]


_HEADING_VECTORS = np.stack((_HX, _HY), axis=1)


def shield_directions(pos: np.ndarray, player: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``shield_direction`` of ``player[i]`` in drill ``i``."""
    r = rows(len(pos))
    p = pos[r, player]
    o1, o2 = pos[r, _FIRST_OPPONENT[player]], pos[r, _SECOND_OPPONENT[player]]
    d1 = np.hypot(o1[:, 0] - p[:, 0], o1[:, 1] - p[:, 1])
    d2 = np.hypot(o2[:, 0] - p[:, 0], o2[:, 1] - p[:, 1])
    away = p - np.where((d2 < d1)[:, None], o2, o1)
    u = _units(away, np.hypot(away[:, 0], away[:, 1]))
    return u[:, 0], u[:, 1]


def pass_velocities(
    pos: np.ndarray, vel: np.ndarray, player: np.ndarray, noise: np.ndarray, cfg: DrillConfig
) -> np.ndarray:
    """``pass_velocity`` of ``player[i]``, with ``noise[i]`` its two standard normals."""
    r = rows(len(pos))
    bx, by = pos[:, 4, 0], pos[:, 4, 1]
    mate = player ^ 1
    mx, my = pos[r, mate, 0], pos[r, mate, 1]
    mvx, mvy = vel[r, mate, 0], vel[r, mate, 1]
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


def mark_targets(
    pos: np.ndarray, holder: np.ndarray, fraction: float = 0.35, players: slice = _ALL
) -> np.ndarray:
    """Where each of the four players (or of ``players``, a slice of them) marks
    (``MARK``): ``fraction`` of the way from its free opponent to the ball. ``(N, 4, 2)``."""
    pz = z(pos)
    f = pz[rows(len(pos))[:, None], free_opponents(pos, holder)[:, players]]  # (N, k)
    return xy(f + z(fraction * xy(pz[:, 4:5] - f)))


def free_opponents(pos: np.ndarray, holder: np.ndarray) -> np.ndarray:
    """``DrillState.free_opponent_of`` for each of the four players: ``(N, 4)`` indices."""
    d = xy(z(pos)[:, :4] - z(pos)[:, 4:5])
    dist = np.hypot(d[..., 0], d[..., 1])  # (N, 4): each player's distance to the ball
    a, b = _FIRST_OPPONENT, _SECOND_OPPONENT
    h = holder[:, None]
    return np.where(h == a, b, np.where(h == b, a, np.where(dist[:, a] > dist[:, b], a, b)))


def guard_targets(pos: np.ndarray, cfg: DrillConfig) -> np.ndarray:
    """``GUARD_LINE``'s spot (level with the ball, ``GUARD_DEPTH`` up): ``(N, 2)``."""
    out = np.full((len(pos), 2), GUARD_DEPTH)
    np.minimum(np.maximum(pos[:, 4, 0], 4.0), cfg.field_size - 4.0, out=out[:, 0])
    return out


def toward(pos: np.ndarray, target: np.ndarray, vmax: np.ndarray) -> np.ndarray:
    """The run of ``execute`` toward ``target`` at most ``vmax``, slowing on arrival."""
    d = target - pos
    dist = np.hypot(d[..., 0], d[..., 1])
    speed = dist / _ARRIVE_SECONDS
    speed = np.where(speed < vmax, speed, vmax)
    moving = dist >= 1e-6
    d /= np.where(moving, dist, 1.0)[..., None]  # dx / dist * speed, as the single code
    d *= speed[..., None]
    return xy(np.where(moving, z(d), 0j))


_TO_BALL_SKILLS = (int(Skill.GO_TO_BALL), int(Skill.INTERCEPT))
_SKILL_TARGET = np.zeros(len(Skill), dtype=np.int8)  # which rule gives a skill's target
_BY_INTERCEPTION, _BY_SUPPORT, _BY_MARK, _BY_GUARD = 1, 2, 3, 4
_SKILL_TARGET[list(_TO_BALL_SKILLS)] = _BY_INTERCEPTION
_SKILL_TARGET[int(Skill.GET_OPEN)] = _BY_SUPPORT
_SKILL_TARGET[int(Skill.MARK)] = _BY_MARK
_SKILL_TARGET[int(Skill.GUARD_LINE)] = _BY_GUARD


def off_ball_targets(
    pos: np.ndarray,
    vel: np.ndarray,
    holder: np.ndarray,
    skill: np.ndarray,
    target: np.ndarray,
    vmax: np.ndarray,
    cfg: DrillConfig,
) -> np.ndarray:
    """The target of each player's off-ball skill (``(N, 4, 2)``; ball skills: any value).

    ``target`` (the ``MOVE_TO`` targets) is not changed.
    """
    rule = _SKILL_TARGET[skill]
    used = np.bincount(rule.ravel(), minlength=5)  # one call tells which rules are needed
    if used[0] == rule.size:  # MOVE_TO and ball skills only
        return target
    out = z(target).copy()
    if used[_BY_INTERCEPTION]:
        np.copyto(out, z(interception_points(pos, vel, holder, vmax, cfg)),
                  where=rule == _BY_INTERCEPTION)
    if used[_BY_SUPPORT]:  # usually the attackers' rule only: the spots of those used
        mask = rule == _BY_SUPPORT
        players = _players_using(mask, used[_BY_SUPPORT])
        np.copyto(out[:, players], z(support_spots(pos, cfg, players)), where=mask[:, players])
    if used[_BY_MARK]:  # usually the defenders' rule only
        mask = rule == _BY_MARK
        players = _players_using(mask, used[_BY_MARK])
        np.copyto(out[:, players], z(mark_targets(pos, holder, players=players)),
                  where=mask[:, players])
    if used[_BY_GUARD]:
        np.copyto(out, z(guard_targets(pos, cfg))[:, None], where=rule == _BY_GUARD)
    return xy(out)


def _players_using(mask: np.ndarray, count: int) -> slice:
    """The players (columns of ``mask``, ``count`` of whose entries are set) that use a
    rule: the attackers, the defenders or all four."""
    attackers = np.count_nonzero(mask[:, :2])
    return _ATTACKERS if attackers == count else _DEFENDERS if attackers == 0 else _ALL


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

    ``skill`` and ``speed`` are the holder's command (any other skill: no ball action);
    ``holder`` must be an attacker's index where ``skill`` is a ball skill (any valid
    index elsewhere); ``noise`` the ``(N, 2)`` standard normals of the drills that pass
    (any values elsewhere). Returns the desired velocity ``(N, 2)``, the ball action
    ``(N,)`` and the ball vector ``(N, 2)``.
    """
    n = len(pos)
    mv = np.zeros((n, 2))
    bvec = np.zeros((n, 2))
    action = _BALL_ACTION[np.where((skill >= 0) & (skill < len(_BALL_ACTION)), skill, 3)]
    used = np.bincount(action, minlength=3)
    if used[CONTROL]:  # each skill computed on the rows of the drills that use it
        dribble = skill == int(Skill.DRIBBLE)
        hold = skill == int(Skill.HOLD)
        if np.count_nonzero(dribble):
            r = np.nonzero(dribble)[0]
            h = dribble_headings(pos[r], holder[r], cfg)
            mv[r] = h * (cfg.dribble_speed * speed[r])[:, None]
            bvec[r] = h
        if np.count_nonzero(hold):
            r = np.nonzero(hold)[0]
            pr, hr = pos[r], holder[r]
            s = np.stack(shield_directions(pr, hr), axis=1)  # (R, 2)
            v = s * (cfg.hold_speed * speed[r])[:, None]
            p = pr[rows(len(r)), hr]
            lo, hi = _HOLD_EDGE, cfg.field_size - _HOLD_EDGE
            below, above = p < lo, p > hi
            v[(below & (v < 0)) | (above & (v > 0))] = 0.0
            sx, sy = s[:, 0], s[:, 1]
            side = (below[:, 0] & (sx < 0)) | (above[:, 0] & (sx > 0))
            sx, sy = np.where(side, 0.0, sx), np.where(side, np.where(sy > 0, 1.0, -1.0), sy)
            far = above[:, 1] & (sy > 0)
            sx, sy = np.where(far, np.where(sx > 0, 1.0, -1.0), sx), np.where(far, 0.0, sy)
            mv[r] = v
            bvec[r, 0] = sx
            bvec[r, 1] = sy
    if used[KICK]:
        r = np.nonzero(action == KICK)[0]
        assert noise is not None
        bvec[r] = pass_velocities(pos[r], vel[r], holder[r], noise[r], cfg)
    return mv, action, bvec


_BALL_ACTION = np.zeros(len(Skill), dtype=np.int64)  # a skill's ball action
_BALL_ACTION[[int(Skill.HOLD), int(Skill.DRIBBLE)]] = CONTROL
_BALL_ACTION[int(Skill.PASS)] = KICK


def turn_toward(
    fx: np.ndarray, fy: np.ndarray, tx: np.ndarray, ty: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``drill._turn_toward`` on arrays: from direction f toward t by at most 40 degrees."""
    b = np.arctan2(ty, tx)
    a = np.where((fx != 0) | (fy != 0), np.arctan2(fy, fx), b)
    delta = np.remainder(b - a + math.pi, 2 * math.pi) - math.pi
    a = a + np.maximum(-_MAX_TURN, np.minimum(_MAX_TURN, delta))
    return np.cos(a), np.sin(a)
