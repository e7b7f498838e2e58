"""Observations: the paper's 9 features, a richer egocentric kinematic vector, and the
full observation (both, and the time left) for multi-agent learners.

The 9 features are keepaway-style distances and angles seen from one player
("self"), its teammate ("mate") and its two opponents. For the ball holder they
are the ILPSS state.

| index | feature | unit | range |
|-------|---------|------|-------|
| 0 | distance self to mate | m | [0, 55] |
| 1 | distance self to the nearer opponent | m | [0, 55] |
| 2 | distance self to the other opponent | m | [0, 55] |
| 3 | distance mate to its nearest opponent | m | [0, 55] |
| 4 | passing-lane angle: min over opponents of angle(mate, self, opponent) | deg | [0, 180] |
| 5 | distance self to the goal line (``y``) | m | [0, 37] |
| 6 | signed lateral offset of self from the line centre (``x - size/2``) | m | [-18.5, 18.5] |
| 7 | distance mate to the goal line | m | [0, 37] |
| 8 | dribbling-lane angle: min over opponents of angle(goal direction, self->opponent) | deg | [0, 180] |

Ranges follow from the region (35 m) plus the wall margin (1 m) players cannot
pass; values are clipped into them so observations always lie in the space.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from soccer_drill.config import DrillConfig
from soccer_drill.rules.compiled import compiled, hypot
from soccer_drill.state import BALL, DrillState

Bounds = np.ndarray | Sequence[float]
"""Observation bounds: a float32 array, or its values as Python floats."""

FEATURE_NAMES: tuple[str, ...] = (
    "dist_mate",
    "dist_opp_near",
    "dist_opp_far",
    "mate_dist_opp",
    "pass_angle",
    "dist_goal",
    "lateral",
    "mate_dist_goal",
    "dribble_angle",
)


def feature_bounds(cfg: DrillConfig) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds of the 9 features (float32)."""
    span = cfg.field_size + 2 * cfg.wall_margin
    diag = math.ceil(span * math.sqrt(2))
    half = cfg.field_size / 2 + cfg.wall_margin
    top = cfg.field_size + cfg.wall_margin
    low = np.array([0, 0, 0, 0, 0, 0, -half, 0, 0], dtype=np.float32)
    high = np.array([diag, diag, diag, diag, 180, top, half, top, 180], dtype=np.float32)
    return low, high


_DEGREES = 180.0 / math.pi
_FLOAT32 = np.float32


def _as_bounds(bounds: Bounds) -> np.ndarray:
    """Bounds as the float64 array the compiled rules read (the same values)."""
    if type(bounds) is np.ndarray and bounds.dtype == np.float64:
        return bounds
    return np.asarray(bounds, dtype=np.float64)


def features(
    state: DrillState, player: int, cfg: DrillConfig, low: Bounds, high: Bounds
) -> np.ndarray:
    """The 9 features of ``player`` (see the module table), clipped to the bounds.

    ``low`` and ``high`` are :func:`feature_bounds` (float64 arrays of them: fastest).
    """
    pos = state.pos
    (sx, sy), (mx, my) = pos[player], pos[player ^ 1]
    (o1x, o1y), (o2x, o2y) = (pos[2], pos[3]) if player < 2 else (pos[0], pos[1])
    out = np.empty(9, _FLOAT32)
    _features_into(out, sx, sy, mx, my, o1x, o1y, o2x, o2y, cfg.field_size / 2,
                   _as_bounds(low), _as_bounds(high))
    return out


def batch_features(
    pos: np.ndarray, player: np.ndarray, cfg: DrillConfig, low: Bounds, high: Bounds
) -> np.ndarray:
    """The 9 features of ``player[i]`` in drill ``i`` of ``pos`` (``(N, 5, 2)``):
    ``(N, 9)`` float32, :func:`features` of each drill."""
    out = np.empty((len(pos), 9), _FLOAT32)
    _features_of_drills(out, np.ascontiguousarray(pos, dtype=np.float64),
                        np.ascontiguousarray(player, dtype=np.int64), cfg.field_size / 2,
                        _as_bounds(low), _as_bounds(high))
    return out


def players_features(
    pos: np.ndarray, players: tuple[int, ...], cfg: DrillConfig, low: Bounds, high: Bounds
) -> np.ndarray:
    """The 9 features of each of ``players`` in every drill: ``(N, len(players), 9)``."""
    n, k = len(pos), len(players)
    each = np.broadcast_to(np.asarray(players, dtype=np.int64), (n, k)).reshape(-1)
    drills = np.repeat(np.ascontiguousarray(pos, dtype=np.float64), k, axis=0)
    return batch_features(drills, each, cfg, low, high).reshape(n, k, 9)


@compiled
def _features_of_drills(out, pos, players, half_size, low, high):
    for i in range(pos.shape[0]):
        p = players[i]
        m = p ^ 1
        o = 2 if p < 2 else 0
        _features_into(out[i], pos[i, p, 0], pos[i, p, 1], pos[i, m, 0], pos[i, m, 1],
                       pos[i, o, 0], pos[i, o, 1], pos[i, o + 1, 0], pos[i, o + 1, 1],
                       half_size, low, high)


@compiled
def _features_into(out, sx, sy, mx, my, o1x, o1y, o2x, o2y, half_size, low, high):
    """The 9 features of a player at ``(sx, sy)``, with its mate at ``(mx, my)`` and its
    opponents at ``(o1x, o1y)`` and ``(o2x, o2y)``, clipped into ``out`` (float32)."""
    ax, ay = o1x - sx, o1y - sy  # opponents relative to self
    bx, by = o2x - sx, o2y - sy
    ux, uy = mx - sx, my - sy  # mate relative to self
    da, db, dm = hypot(ax, ay), hypot(bx, by), hypot(ux, uy)
    near, far = (da, db) if da <= db else (db, da)
    ma, mb = hypot(ax - ux, ay - uy), hypot(bx - ux, by - uy)
    mate_opp = mb if mb < ma else ma  # min(ma, mb)
    # Angles at self between the mate, or the goal direction (0, -1), and each opponent:
    # acos of the normalised dot product (clamped to [-1, 1]), 180 for a zero-length side.
    # With the goal direction that product is -y / d (exactly, but for the sign of a zero,
    # which acos ignores).
    pa = pb = ga = gb = 180.0
    if da >= 1e-9:
        if dm >= 1e-9:
            pa = _angle((ux * ax + uy * ay) / (dm * da))
        ga = _angle(-ay / da)
    if db >= 1e-9:
        if dm >= 1e-9:
            pb = _angle((ux * bx + uy * by) / (dm * db))
        gb = _angle(-by / db)
    _clip_into(out, 0, dm, low, high)
    _clip_into(out, 1, near, low, high)
    _clip_into(out, 2, far, low, high)
    _clip_into(out, 3, mate_opp, low, high)
    _clip_into(out, 4, pb if pb < pa else pa, low, high)
    _clip_into(out, 5, sy, low, high)
    _clip_into(out, 6, sx - half_size, low, high)
    _clip_into(out, 7, my, low, high)
    _clip_into(out, 8, gb if gb < ga else ga, low, high)


@compiled
def _angle(cosine):
    """The angle of ``cosine`` (clamped to [-1, 1]) in degrees."""
    return _DEGREES * math.acos(-1.0 if cosine < -1.0 else 1.0 if cosine > 1.0 else cosine)


@compiled
def _clip_into(out, k, value, low, high):
    """``out[k]`` = ``value`` clipped into ``[low[k], high[k]]``, as ``np.clip`` of the
    float32 value: bounds are float32 values and rounding is monotonic, so clipping
    first gives the same float; each comparison is NumPy's (``max(v, lo)`` is
    ``v if v > lo or v is NaN else lo``), so even the sign of a clipped zero is NumPy's."""
    lo, hi = low[k], high[k]
    m = value if value > lo or value != value else lo
    out[k] = m if m < hi or m != m else hi


KINEMATIC_SIZE = 26


def kinematic_bounds(cfg: DrillConfig) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of the egocentric kinematic observation (see :func:`kinematics`)."""
    span = cfg.field_size + 2 * cfg.wall_margin
    top_speed = max(cfg.attacker_speed, cfg.defender_speed)
    pos_hi, vel_hi = span, max(cfg.ball_max_speed, top_speed)
    high = np.array(
        [span, span, top_speed, top_speed] + [pos_hi, pos_hi, vel_hi, vel_hi] * 4 + [1.0] * 6,
        dtype=np.float32,
    )
    low = -high
    low[:2] = -cfg.wall_margin
    low[-6:] = 0.0
    return low, high


def kinematics(state: DrillState, player: int, low: Bounds, high: Bounds) -> np.ndarray:
    """Egocentric kinematic observation of ``player`` (26 values).

    ``[x, y, vx, vy]`` of self, then for mate, opponent 0, opponent 1 and ball
    their position and velocity relative to self (metres, m/s), then six flags:
    self holds, mate holds, an opponent holds, ball loose, self is an attacker,
    the passer lock-out applies to self.
    """
    out = np.empty(KINEMATIC_SIZE, _FLOAT32)
    _kinematics_into(out, np.array(state.pos), np.array(state.vel), state.holder,
                     state.passer if state.cycle < state.lockout_until else -1, player,
                     _as_bounds(low), _as_bounds(high))
    return out


def batch_kinematics(
    pos: np.ndarray, vel: np.ndarray, holder: np.ndarray, passer_locked: np.ndarray,
    player: int, low: Bounds, high: Bounds,
) -> np.ndarray:
    """:func:`kinematics` of ``player`` in every drill (``passer_locked``: the passer
    who cannot regain the ball yet, -1 for none): ``(N, 26)`` float32."""
    out = np.empty((len(pos), KINEMATIC_SIZE), _FLOAT32)
    _kinematics_of_drills(out, np.ascontiguousarray(pos, dtype=np.float64),
                          np.ascontiguousarray(vel, dtype=np.float64),
                          np.ascontiguousarray(holder, dtype=np.int64),
                          np.ascontiguousarray(passer_locked, dtype=np.int64), player,
                          _as_bounds(low), _as_bounds(high))
    return out


@compiled
def _kinematics_of_drills(out, pos, vel, holder, passer_locked, player, low, high):
    for i in range(pos.shape[0]):
        _kinematics_into(out[i], pos[i], vel[i], holder[i], passer_locked[i], player, low, high)


@compiled
def _kinematics_into(out, pos, vel, holder, passer_locked, player, low, high):
    """:func:`kinematics` of one drill (``pos``, ``vel``: ``(5, 2)``) into ``out``."""
    sx, sy = pos[player, 0], pos[player, 1]
    svx, svy = vel[player, 0], vel[player, 1]
    _clip_into(out, 0, sx, low, high)
    _clip_into(out, 1, sy, low, high)
    _clip_into(out, 2, svx, low, high)
    _clip_into(out, 3, svy, low, high)
    o = 2 if player < 2 else 0
    k = 4
    for j in (player ^ 1, o, o + 1, 4):  # mate, opponents, ball
        _clip_into(out, k, pos[j, 0] - sx, low, high)
        _clip_into(out, k + 1, pos[j, 1] - sy, low, high)
        _clip_into(out, k + 2, vel[j, 0] - svx, low, high)
        _clip_into(out, k + 3, vel[j, 1] - svy, low, high)
        k += 4
    opponent_holds = holder >= 0 and (holder >= 2) != (player >= 2)
    flags = (holder == player, holder == player ^ 1, opponent_holds, holder < 0, player < 2,
             passer_locked == player)
    for flag in flags:
        _clip_into(out, k, 1.0 if flag else 0.0, low, high)
        k += 1


FULL_SIZE = KINEMATIC_SIZE + 9 + 1
"""Length of the full observation (:func:`full_observation`)."""


def full_bounds(cfg: DrillConfig) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of :func:`full_observation`: the kinematic bounds, the 9 features', then [0, 1]."""
    (klo, khi), (flo, fhi) = kinematic_bounds(cfg), feature_bounds(cfg)
    low = np.concatenate((klo, flo, [0.0])).astype(np.float32)
    high = np.concatenate((khi, fhi, [1.0])).astype(np.float32)
    return low, high


def full_observation(state: DrillState, player: int, cfg: DrillConfig, low: Bounds,
                     high: Bounds) -> np.ndarray:
    """The full observation of ``player`` (36 values): :func:`kinematics` (26: self,
    mate, opponents and ball, possession flags, role), the paper's 9 :func:`features`
    (passing and dribbling lanes), then the time left, ``1 - cycle / max_cycles``."""
    out = np.empty(FULL_SIZE, _FLOAT32)
    _full_into(out, np.array(state.pos), np.array(state.vel), state.holder,
               state.passer if state.cycle < state.lockout_until else -1, player,
               1.0 - state.cycle / cfg.max_cycles, cfg.field_size / 2, _as_bounds(low),
               _as_bounds(high))
    return out


def batch_full(
    pos: np.ndarray, vel: np.ndarray, holder: np.ndarray, passer_locked: np.ndarray,
    cycle: np.ndarray, player: int, cfg: DrillConfig, low: Bounds, high: Bounds,
) -> np.ndarray:
    """:func:`full_observation` of ``player`` in every drill: ``(N, 36)`` float32."""
    out = np.empty((len(pos), FULL_SIZE), _FLOAT32)
    _full_of_drills(out, np.ascontiguousarray(pos, dtype=np.float64),
                    np.ascontiguousarray(vel, dtype=np.float64),
                    np.ascontiguousarray(holder, dtype=np.int64),
                    np.ascontiguousarray(passer_locked, dtype=np.int64), player,
                    1.0 - np.asarray(cycle, dtype=np.float64) / cfg.max_cycles,
                    cfg.field_size / 2, _as_bounds(low), _as_bounds(high))
    return out


@compiled
def _full_of_drills(out, pos, vel, holder, passer_locked, player, time_left, half_size, low,
                    high):
    for i in range(pos.shape[0]):
        _full_into(out[i], pos[i], vel[i], holder[i], passer_locked[i], player, time_left[i],
                   half_size, low, high)


@compiled
def _full_into(out, pos, vel, holder, passer_locked, player, time_left, half_size, low, high):
    """:func:`full_observation` of one drill into ``out``."""
    k = KINEMATIC_SIZE
    _kinematics_into(out[:k], pos, vel, holder, passer_locked, player, low[:k], high[:k])
    m = player ^ 1
    o = 2 if player < 2 else 0
    _features_into(out[k:k + 9], pos[player, 0], pos[player, 1], pos[m, 0], pos[m, 1],
                   pos[o, 0], pos[o, 1], pos[o + 1, 0], pos[o + 1, 1], half_size,
                   low[k:k + 9], high[k:k + 9])
    _clip_into(out, k + 9, time_left, low, high)


STATE_SIZE = 29
"""Length of the global state vector (:func:`global_state`)."""


def state_bounds(cfg: DrillConfig) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of :func:`global_state` (float32).

    Players are held inside the walls (``wall_margin`` outside the region); the ball
    touches nothing, and one cycle after it leaves the region (which ends the episode)
    it is at most ``ball_max_speed * cycle_seconds`` further out.
    """
    player_lo, player_hi = -cfg.wall_margin, cfg.field_size + cfg.wall_margin
    reach = cfg.wall_margin + cfg.ball_max_speed * cfg.cycle_seconds
    ball_lo, ball_hi = -reach, cfg.field_size + reach
    low, high = [], []
    speeds = (cfg.attacker_speed, cfg.attacker_speed, cfg.defender_speed, cfg.defender_speed,
              cfg.ball_max_speed)
    for body, speed in enumerate(speeds):
        lo, hi = (ball_lo, ball_hi) if body == BALL else (player_lo, player_hi)
        low += [lo, lo, -speed, -speed]
        high += [hi, hi, speed, speed]
    low += [0.0] * 9
    high += [1.0] * 9
    return np.array(low, dtype=np.float32), np.array(high, dtype=np.float32)


def global_state(state: DrillState, cfg: DrillConfig, low: Bounds, high: Bounds) -> np.ndarray:
    """The whole drill in a fixed layout (29 float32 values), for centralised critics.

    | index | value |
    |-------|-------|
    | 0-3 | ``x, y, vx, vy`` of ``attacker_0`` (field coordinates, m and m/s) |
    | 4-7 | the same for ``attacker_1`` |
    | 8-11 | the same for ``defender_0`` |
    | 12-15 | the same for ``defender_1`` |
    | 16-19 | the same for the ball |
    | 20-23 | 1 for the player holding the ball (all 0: a loose ball), in player order |
    | 24-27 | 1 for the player who passed and cannot regain the ball yet, in player order |
    | 28 | cycles elapsed / ``max_cycles`` |

    Values are clipped into :func:`state_bounds`.
    """
    out = np.empty(STATE_SIZE, _FLOAT32)
    _state_into(out, np.array(state.pos), np.array(state.vel), state.holder,
                state.passer if state.cycle < state.lockout_until else -1,
                state.cycle / cfg.max_cycles, _as_bounds(low), _as_bounds(high))
    return out


def batch_global_state(
    pos: np.ndarray, vel: np.ndarray, holder: np.ndarray, passer_locked: np.ndarray,
    cycle: np.ndarray, cfg: DrillConfig, low: Bounds, high: Bounds,
) -> np.ndarray:
    """:func:`global_state` of every drill: ``(N, 29)`` float32."""
    out = np.empty((len(pos), STATE_SIZE), _FLOAT32)
    _states_of_drills(out, np.ascontiguousarray(pos, dtype=np.float64),
                      np.ascontiguousarray(vel, dtype=np.float64),
                      np.ascontiguousarray(holder, dtype=np.int64),
                      np.ascontiguousarray(passer_locked, dtype=np.int64),
                      cycle / cfg.max_cycles, _as_bounds(low), _as_bounds(high))
    return out


@compiled
def _states_of_drills(out, pos, vel, holder, passer_locked, progress, low, high):
    for i in range(pos.shape[0]):
        _state_into(out[i], pos[i], vel[i], holder[i], passer_locked[i], progress[i], low, high)


@compiled
def _state_into(out, pos, vel, holder, passer_locked, progress, low, high):
    """:func:`global_state` of one drill into ``out``."""
    for body in range(5):
        _clip_into(out, 4 * body, pos[body, 0], low, high)
        _clip_into(out, 4 * body + 1, pos[body, 1], low, high)
        _clip_into(out, 4 * body + 2, vel[body, 0], low, high)
        _clip_into(out, 4 * body + 3, vel[body, 1], low, high)
    for i in range(4):
        _clip_into(out, 20 + i, 1.0 if holder == i else 0.0, low, high)
        _clip_into(out, 24 + i, 1.0 if passer_locked == i else 0.0, low, high)
    _clip_into(out, 28, progress, low, high)
