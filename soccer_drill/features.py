"""Observations: the paper's 9 features and a richer egocentric kinematic vector.

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
_hypot, _acos = math.hypot, math.acos
_FLOAT32 = np.float32  # passed by position: np.array's keyword costs ~0.2 us a call


def features(
    state: DrillState, player: int, cfg: DrillConfig, low: Bounds, high: Bounds
) -> np.ndarray:
    """The 9 features of ``player`` (see the module table), clipped to the bounds.

    ``low`` and ``high`` are :func:`feature_bounds` (arrays, or their ``tolist()``: faster).
    """
    pos = state.pos
    sx, sy = pos[player]
    mx, my = pos[player ^ 1]
    (o1x, o1y), (o2x, o2y) = (pos[2], pos[3]) if player < 2 else (pos[0], pos[1])
    ax, ay = o1x - sx, o1y - sy  # opponents relative to self
    bx, by = o2x - sx, o2y - sy
    ux, uy = mx - sx, my - sy  # mate relative to self
    da, db, dm = _hypot(ax, ay), _hypot(bx, by), _hypot(ux, uy)
    near, far = (da, db) if da <= db else (db, da)
    ma, mb = _hypot(ax - ux, ay - uy), _hypot(bx - ux, by - uy)
    mate_opp = mb if mb < ma else ma  # min(ma, mb)
    # Angles at self between the mate, or the goal direction (0, -1), and each opponent:
    # acos of the normalised dot product (clamped to [-1, 1]), 180 for a zero-length side.
    # With the goal direction that product is -y / d (exactly, but for the sign of a zero,
    # which acos ignores).
    if da < 1e-9:
        pa = ga = 180.0
    else:
        if dm < 1e-9:
            pa = 180.0
        else:
            c = (ux * ax + uy * ay) / (dm * da)
            pa = _DEGREES * _acos(-1.0 if c < -1.0 else 1.0 if c > 1.0 else c)
        c = -ay / da
        ga = _DEGREES * _acos(-1.0 if c < -1.0 else 1.0 if c > 1.0 else c)
    if db < 1e-9:
        pb = gb = 180.0
    else:
        if dm < 1e-9:
            pb = 180.0
        else:
            c = (ux * bx + uy * by) / (dm * db)
            pb = _DEGREES * _acos(-1.0 if c < -1.0 else 1.0 if c > 1.0 else c)
        c = -by / db
        gb = _DEGREES * _acos(-1.0 if c < -1.0 else 1.0 if c > 1.0 else c)
    raw = (dm, near, far, mate_opp, pb if pb < pa else pa, sy, sx - cfg.field_size / 2, my,
           gb if gb < ga else ga)
    if _inside(raw, low, high):  # the usual case: nothing to clip
        return np.array(raw, _FLOAT32)
    return _clipped(raw, low, high)


def _inside(values: Sequence[float], low: Bounds, high: Bounds) -> bool:
    """Whether each of the nine values lies strictly inside its bounds, where the clip
    keeps it as it is (the usual case: then no clip is needed).

    Written out, a third of the cost of ``all(map(operator.lt, ...))`` over the nine.
    """
    v0, v1, v2, v3, v4, v5, v6, v7, v8 = values
    l0, l1, l2, l3, l4, l5, l6, l7, l8 = low
    h0, h1, h2, h3, h4, h5, h6, h7, h8 = high
    return (l0 < v0 < h0 and l1 < v1 < h1 and l2 < v2 < h2 and l3 < v3 < h3 and l4 < v4 < h4
            and l5 < v5 < h5 and l6 < v6 < h6 and l7 < v7 < h7 and l8 < v8 < h8)


def _clipped(values: Sequence[float], low: Bounds, high: Bounds) -> np.ndarray:
    """``np.clip(np.array(values, float32), low, high)``, bit for bit, but faster.

    Clipping the float64 values before rounding them to float32 gives the same floats
    (``low`` and ``high`` are float32 and rounding is monotonic); each comparison is
    NumPy's own (``max(v, lo)`` is ``v if v > lo or v is NaN else lo``), so even the
    sign of a clipped zero is NumPy's. Bounds given as lists of floats (``low.tolist()``)
    are compared fastest. :func:`features` calls it only when :func:`_inside` is false.
    """
    return np.array(
        [  # m = max(v, lo), then min(m, hi), each as NumPy compares
            m if ((m := v if v > lo or v != v else lo) < hi or m != m) else hi
            for v, lo, hi in zip(values, low, high, strict=True)
        ],
        _FLOAT32,
    )


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
    pos, vel = state.pos, state.vel
    sx, sy = pos[player]
    svx, svy = vel[player]
    values = [sx, sy, svx, svy]
    others = (player ^ 1, *((2, 3) if player < 2 else (0, 1)), BALL)
    for j in others:
        values += [pos[j][0] - sx, pos[j][1] - sy, vel[j][0] - svx, vel[j][1] - svy]
    h = state.holder
    values += [
        float(h == player),
        float(h == player ^ 1),
        float(h >= 0 and (h >= 2) != (player >= 2)),
        float(h < 0),
        float(player < 2),
        float(state.passer == player and state.cycle < state.lockout_until),
    ]
    return _clipped(values, low, high)


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


def global_state(
    state: DrillState, cfg: DrillConfig, low: np.ndarray, high: np.ndarray
) -> np.ndarray:
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
    values: list[float] = []
    for (x, y), (vx, vy) in zip(state.pos, state.vel, strict=True):
        values += [x, y, vx, vy]
    holder, passer = state.holder, state.passer
    locked = state.cycle < state.lockout_until
    values += [float(holder == i) for i in range(4)]
    values += [float(locked and passer == i) for i in range(4)]
    values.append(state.cycle / cfg.max_cycles)
    return np.clip(np.array(values, _FLOAT32), low, high)
