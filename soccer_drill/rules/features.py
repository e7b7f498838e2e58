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

Every kind of observation is one entry of :data:`OBSERVATION_TYPES`, read by the
single and the batched environments alike (``obs_type``): its size, its bounds for a
configuration and its compiled rule over drills. A new kind is a rule of one drill, its
loop over drills and one entry there.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from soccer_drill.config import DrillConfig
from soccer_drill.rules.compiled import compiled, hypot
from soccer_drill.state import BALL

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


@compiled
def features_into(out, pos, player, half_size, low, high):
    """The 9 features of ``player`` in one drill (``pos``: ``(5, 2)``) into ``out``
    (float32), each clipped into ``[low, high]``."""
    sx, sy = pos[player, 0], pos[player, 1]
    mx, my = pos[player ^ 1, 0], pos[player ^ 1, 1]
    o = 2 if player < 2 else 0
    ax, ay = pos[o, 0] - sx, pos[o, 1] - sy  # opponents relative to self
    bx, by = pos[o + 1, 0] - sx, pos[o + 1, 1] - sy
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
def _features_of_drills(out, state, rows, players, params, low, high):
    half_size = params[0].field_size / 2
    for r in range(rows.shape[0]):
        features_into(out[r], state[rows[r]].pos, players[r], half_size, low, high)


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
"""Length of the kinematic observation."""


def kinematic_bounds(cfg: DrillConfig) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of the egocentric kinematic observation (see :func:`kinematics_into`)."""
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


@compiled
def kinematics_into(out, state, player, low, high):
    """Egocentric kinematic observation of ``player`` in one drill (26 values) into ``out``.

    ``[x, y, vx, vy]`` of self, then for mate, opponent 0, opponent 1 and ball
    their position and velocity relative to self (metres, m/s), then six flags:
    self holds, mate holds, an opponent holds, ball loose, self is an attacker,
    the passer lock-out applies to self.
    """
    pos, vel, holder = state.pos, state.vel, state.holder
    passer_locked = state.passer if state.cycle < state.lockout_until else -1
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


@compiled
def _kinematics_of_drills(out, state, rows, players, params, low, high):
    for r in range(rows.shape[0]):
        kinematics_into(out[r], state[rows[r]], players[r], low, high)


FULL_SIZE = KINEMATIC_SIZE + 9 + 1
"""Length of the full observation (:func:`full_into`)."""


def full_bounds(cfg: DrillConfig) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of the full observation: the kinematic bounds, the 9 features', then [0, 1]."""
    (klo, khi), (flo, fhi) = kinematic_bounds(cfg), feature_bounds(cfg)
    low = np.concatenate((klo, flo, [0.0])).astype(np.float32)
    high = np.concatenate((khi, fhi, [1.0])).astype(np.float32)
    return low, high


@compiled
def full_into(out, state, player, half_size, max_cycles, low, high):
    """The full observation of ``player`` in one drill (36 values) into ``out``: the
    kinematic observation (26: self, mate, opponents and ball, possession flags, role,
    :func:`kinematics_into`), the paper's 9 features (passing and dribbling lanes,
    :func:`features_into`), then the time left, ``1 - cycle / max_cycles``."""
    k = KINEMATIC_SIZE
    kinematics_into(out[:k], state, player, low[:k], high[:k])
    features_into(out[k:k + 9], state.pos, player, half_size, low[k:k + 9], high[k:k + 9])
    _clip_into(out, k + 9, 1.0 - state.cycle / max_cycles, low, high)


@compiled
def _full_of_drills(out, state, rows, players, params, low, high):
    half_size, max_cycles = params[0].field_size / 2, params[0].max_cycles
    for r in range(rows.shape[0]):
        full_into(out[r], state[rows[r]], players[r], half_size, max_cycles, low, high)


STATE_SIZE = 29
"""Length of the global state vector (:func:`global_state_into`)."""


def state_bounds(cfg: DrillConfig) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of the global state (float32).

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


@compiled
def global_state_into(out, state, max_cycles, low, high):
    """The whole of one drill in a fixed layout (29 values) into ``out``, for centralised
    critics; values clipped into :func:`state_bounds`.

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
    """
    pos, vel, holder = state.pos, state.vel, state.holder
    passer_locked = state.passer if state.cycle < state.lockout_until else -1
    for body in range(5):
        _clip_into(out, 4 * body, pos[body, 0], low, high)
        _clip_into(out, 4 * body + 1, pos[body, 1], low, high)
        _clip_into(out, 4 * body + 2, vel[body, 0], low, high)
        _clip_into(out, 4 * body + 3, vel[body, 1], low, high)
    for i in range(4):
        _clip_into(out, 20 + i, 1.0 if holder == i else 0.0, low, high)
        _clip_into(out, 24 + i, 1.0 if passer_locked == i else 0.0, low, high)
    _clip_into(out, 28, state.cycle / max_cycles, low, high)


@compiled
def _global_states_of_drills(out, state, rows, players, params, low, high):
    for r in range(rows.shape[0]):
        global_state_into(out[r], state[rows[r]], params[0].max_cycles, low, high)


# ------------------------------------------------------------------ the table
@dataclass(frozen=True)
class ObservationType:
    """One kind of observation of a player.

    Attributes
    ----------
    size
        Its length.
    bounds
        ``bounds(config) -> (low, high)``, float32 arrays of ``size``.
    rule
        Its compiled loop ``rule(out, state, rows, players, params, low, high)``: into
        ``out[r]`` (float32), the observation of player ``players[r]`` in drill
        ``rows[r]`` of ``state`` (:data:`~soccer_drill.rules.arrays.STATE` records), with
        the rule parameters and the bounds as float64.
    description
        What it holds, for messages and the environments' documentation.
    """

    size: int
    bounds: Callable[[DrillConfig], tuple[np.ndarray, np.ndarray]]
    rule: Callable[..., Any]
    description: str


OBSERVATION_TYPES: dict[str, ObservationType] = {
    "features": ObservationType(
        9, feature_bounds, _features_of_drills,
        "the paper's 9 features from the player's point of view (the module's table)"),
    "kinematic": ObservationType(
        KINEMATIC_SIZE, kinematic_bounds, _kinematics_of_drills,
        "26 egocentric values: positions and velocities relative to the player, "
        "possession flags"),
    "full": ObservationType(
        FULL_SIZE, full_bounds, _full_of_drills,
        "36 values: the kinematic observation, the paper's 9 features, then the time left "
        "(1 - cycle / max_cycles), for multi-agent learners"),
}
"""Every kind of observation an environment's ``obs_type`` may name, by name."""
GLOBAL_STATE = ObservationType(
    STATE_SIZE, state_bounds, _global_states_of_drills,
    "the whole drill (29 values; ``players`` is not read), for centralised critics")
"""The environments' ``state()``: every drill's :func:`global_state_into`."""
