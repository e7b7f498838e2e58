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

**Any size.** With ``m`` teammates and ``d`` opponents the features are keepaway's
(Stone, Sutton and Kuhlmann 2005: teammates and opponents ordered by distance, a
passing-lane angle per teammate) with the drill's goal line added, ``4 m + d + 3`` of
them, the 9 above at ``m = 1, d = 2``:

| indices | feature |
|---------|---------|
| ``0 .. m-1`` | distance self to each teammate, nearest first (``dist_mate_k``) |
| ``m .. m+d-1`` | distance self to each opponent, nearest first (``dist_opp_k``) |
| ``m+d .. 2m+d-1`` | each teammate's distance to its nearest opponent, teammates in that order |
| ``2m+d .. 3m+d-1`` | each teammate's passing-lane angle (min over opponents of angle(mate, self, opponent)) |
| ``3m+d``, ``3m+d+1`` | self's distance to the goal line, its lateral offset |
| ``3m+d+2 .. 4m+d+1`` | each teammate's distance to the goal line |
| ``4m+d+2`` | the dribbling-lane angle |

The ball holder's features (``HolderEnv``) have its own team's numbers (``m =
attackers - 1``, ``d = defenders``: 13 at 3v2, 4 at 1v1); the multi-agent ones room for
the larger team on both sides (``m = max - 1``, ``d = max``), so that every player's
have one length, a slot with nobody in it reading 0 (:func:`feature_slots`).

Every kind of observation is one entry of :data:`OBSERVATION_TYPES`, read by the
single and the batched environments alike (``obs_type``): its size, its bounds for a
configuration and its compiled rule over drills. A new kind is a rule of one drill, its
loop over drills and one entry there.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from soccer_drill.config import DrillConfig
from soccer_drill.rules.compiled import compiled, hypot
from soccer_drill.rules.motion import teammates_by_distance

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
"""The 9 features' names in the paper's 2v2 drill (:func:`feature_names` for any size)."""


def feature_names(mates: int, opponents: int) -> tuple[str, ...]:
    """The features' names with ``mates`` teammates and ``opponents`` opponents (the
    module's table): ``FEATURE_NAMES`` for one teammate and two opponents."""
    if (mates, opponents) == (1, 2):
        return FEATURE_NAMES
    return _slot_names(mates, opponents)


def _slot_names(mates: int, opponents: int) -> tuple[str, ...]:
    """The features' names by slot, whatever the size (the paper's 9 named as any other)."""
    ranks = range(1, mates + 1)
    return (*(f"dist_mate_{k}" for k in ranks),
            *(f"dist_opp_{k}" for k in range(1, opponents + 1)),
            *(f"mate_{k}_dist_opp" for k in ranks),
            *(f"pass_angle_{k}" for k in ranks),
            "dist_goal", "lateral",
            *(f"mate_{k}_dist_goal" for k in ranks),
            "dribble_angle")


def feature_slots(cfg: DrillConfig, holder: bool = False) -> tuple[int, int]:
    """``(teammates, opponents)`` the features of ``cfg``'s drill have room for: the
    attackers' own numbers for the ball holder (``holder``), else room for the larger
    team, so that every player's features have one length (a smaller team's missing
    players read 0)."""
    if holder:
        return cfg.attackers - 1, cfg.defenders
    most = max(cfg.attackers, cfg.defenders)
    return most - 1, most


def holder_feature_indices(cfg: DrillConfig) -> np.ndarray:
    """Where the ball holder's features (:func:`feature_slots` with ``holder``) sit in a
    player's multi-agent features of ``cfg``'s drill, which have room for the larger team:
    ``agent_features[holder_feature_indices(cfg)]`` is the holder's view (the identity
    when the attackers are the larger team, as in the 2v2 drill)."""
    agent = _slot_names(*feature_slots(cfg))  # by slot: the paper's names are for 2v2 only
    return np.array([agent.index(name) for name in _slot_names(*feature_slots(cfg, True))],
                    dtype=np.int64)


def feature_bounds(cfg: DrillConfig, holder: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds of the features (float32; the 9 features in the 2v2 drill)."""
    m, d = feature_slots(cfg, holder)
    span = cfg.field_size + 2 * cfg.wall_margin
    diag = math.ceil(span * math.sqrt(2))
    half = cfg.field_size / 2 + cfg.wall_margin
    top = cfg.field_size + cfg.wall_margin
    low = np.array([0] * (3 * m + d) + [0, -half] + [0] * m + [0], dtype=np.float32)
    high = np.array([diag] * (2 * m + d) + [180] * m + [top, half] + [top] * m + [180],
                    dtype=np.float32)
    return low, high


_DEGREES = 180.0 / math.pi


@compiled
def features_into(out, pos, player, params, low, high, mates, opponents):
    """The features of ``player`` in one drill (``pos``: ``(players + 1, 2)``, the first
    ``params[0].attackers`` of them attackers) into ``out`` (float32), with room for ``mates``
    teammates and ``opponents`` opponents (the module's table; a slot with nobody in it
    reads 0), each clipped into ``[low, high]``. Teammates are ranked by their distance
    to ``player`` (the lower index among equals), opponents' distances ascending."""
    players, attackers = pos.shape[0] - 1, params[0].attackers
    half_size = params[0].field_size / 2
    o0, o1 = (attackers, players) if player < attackers else (0, attackers)  # opponents
    sx, sy = pos[player, 0], pos[player, 1]
    # Teammates by distance (equals in index order).
    rank = np.empty(4, np.int64)
    mdist = np.empty(4)
    count = teammates_by_distance(pos, player, attackers, rank, mdist)
    # Opponents' distances, ascending, and the dribbling lane.
    odist = np.empty(4)
    oda = np.empty(4)  # the opponents' distances in index order, read again per teammate
    n_opp = 0
    dribble = 180.0
    for j in range(o0, o1):
        ax, ay = pos[j, 0] - sx, pos[j, 1] - sy
        da = hypot(ax, ay)
        oda[j - o0] = da
        ga = _angle(-ay / da) if da >= 1e-9 else 180.0
        dribble = ga if n_opp == 0 or ga < dribble else dribble
        k = n_opp
        while k > 0 and odist[k - 1] > da:
            odist[k] = odist[k - 1]
            k -= 1
        odist[k] = da
        n_opp += 1
    m, d = mates, opponents
    for k in range(m):
        if k >= count:  # nobody in this slot
            for at in (k, m + d + k, 2 * m + d + k, 3 * m + d + 2 + k):
                _clip_into(out, at, 0.0, low, high)
            continue
        j = rank[k]
        mx, my = pos[j, 0], pos[j, 1]
        ux, uy = mx - sx, my - sy  # the teammate relative to self
        dm = mdist[k]
        # Its nearest opponent, and the passing lane: the smallest angle at self between
        # the teammate and an opponent (acos of the normalised dot product, clamped to
        # [-1, 1]; 180 for a zero-length side).
        mate_opp, lane = 0.0, 180.0
        for o in range(o0, o1):
            ax, ay = pos[o, 0] - sx, pos[o, 1] - sy
            da = oda[o - o0]
            ma = hypot(ax - ux, ay - uy)
            pa = 180.0
            if da >= 1e-9 and dm >= 1e-9:
                pa = _angle((ux * ax + uy * ay) / (dm * da))
            if o == o0:
                mate_opp, lane = ma, pa
            else:
                mate_opp = ma if ma < mate_opp else mate_opp
                lane = pa if pa < lane else lane
        _clip_into(out, k, dm, low, high)
        _clip_into(out, m + d + k, mate_opp, low, high)
        _clip_into(out, 2 * m + d + k, lane, low, high)
        _clip_into(out, 3 * m + d + 2 + k, my, low, high)
    for k in range(d):
        _clip_into(out, m + k, odist[k] if k < n_opp else 0.0, low, high)
    _clip_into(out, 3 * m + d, sy, low, high)
    _clip_into(out, 3 * m + d + 1, sx - half_size, low, high)
    _clip_into(out, 4 * m + d + 2, dribble, low, high)


@compiled
def _features_of_drills(out, state, rows, players, params, low, high):
    """The multi-agent features: room for the larger team (:func:`feature_slots`)."""
    attackers = params[0].attackers
    defenders = state[0].pos.shape[0] - 1 - attackers
    most = attackers if attackers > defenders else defenders
    for r in range(rows.shape[0]):
        features_into(out[r], state[rows[r]].pos, players[r], params, low, high, most - 1,
                      most)


@compiled
def _holder_features_of_drills(out, state, rows, players, params, low, high):
    """The ball holder's features: the attackers' own numbers (:func:`feature_slots`)."""
    attackers = params[0].attackers
    defenders = state[0].pos.shape[0] - 1 - attackers
    for r in range(rows.shape[0]):
        features_into(out[r], state[rows[r]].pos, players[r], params, low, high,
                      attackers - 1, defenders)


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
"""Length of the kinematic observation in the 2v2 drill (``4 * players + 10``)."""


def kinematic_bounds(cfg: DrillConfig) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of the egocentric kinematic observation (see :func:`kinematics_into`).

    A relative velocity's bound is the larger of the ball's top speed and a player's,
    not their sum: while the ball flies at nearly its top speed against a player running
    the other way, its velocity relative to that player is clipped (up to about 31 m/s
    read as 25 with the defaults, about 1% of the multi-agent observations of random
    play). The recorded episodes and the reference runs were made with these bounds, so
    they stay; ``state()`` holds every velocity unclipped."""
    span = cfg.field_size + 2 * cfg.wall_margin
    top_speed = max(cfg.attacker_speed, cfg.defender_speed)
    pos_hi, vel_hi = span, max(cfg.ball_max_speed, top_speed)
    others = cfg.players  # the other players and the ball
    high = np.array(
        [span, span, top_speed, top_speed] + [pos_hi, pos_hi, vel_hi, vel_hi] * others
        + [1.0] * 6,
        dtype=np.float32,
    )
    low = -high
    low[:2] = -cfg.wall_margin
    low[-6:] = 0.0
    return low, high


@compiled
def kinematics_into(out, state, player, low, high, attackers):
    """Egocentric kinematic observation of ``player`` in one drill (``4 * players + 10``
    values: 26 in the 2v2 drill) into ``out``.

    ``[x, y, vx, vy]`` of self, then for each teammate, each opponent (in index order)
    and the ball their position and velocity relative to self (metres, m/s), then six
    flags: self holds, a teammate holds, an opponent holds, ball loose, self is an
    attacker, the passer lock-out applies to self.
    """
    pos, vel, holder = state.pos, state.vel, state.holder
    players = pos.shape[0] - 1
    mine = player < attackers
    passer_locked = state.passer if state.cycle < state.lockout_until else -1
    sx, sy = pos[player, 0], pos[player, 1]
    svx, svy = vel[player, 0], vel[player, 1]
    _clip_into(out, 0, sx, low, high)
    _clip_into(out, 1, sy, low, high)
    _clip_into(out, 2, svx, low, high)
    _clip_into(out, 3, svy, low, high)
    k = 4
    for side in range(3):  # teammates, opponents, the ball
        for j in range(players + 1):
            if side == 2:
                if j != players:
                    continue
            elif j == players or j == player or (j < attackers) != (mine == (side == 0)):
                continue
            _clip_into(out, k, pos[j, 0] - sx, low, high)
            _clip_into(out, k + 1, pos[j, 1] - sy, low, high)
            _clip_into(out, k + 2, vel[j, 0] - svx, low, high)
            _clip_into(out, k + 3, vel[j, 1] - svy, low, high)
            k += 4
    held = holder >= 0
    mate_holds = held and holder != player and (holder < attackers) == mine
    opponent_holds = held and (holder < attackers) != mine
    flags = (holder == player, mate_holds, opponent_holds, holder < 0, mine,
             passer_locked == player)
    for flag in flags:
        _clip_into(out, k, 1.0 if flag else 0.0, low, high)
        k += 1


@compiled
def _kinematics_of_drills(out, state, rows, players, params, low, high):
    attackers = params[0].attackers
    for r in range(rows.shape[0]):
        kinematics_into(out[r], state[rows[r]], players[r], low, high, attackers)


FULL_SIZE = KINEMATIC_SIZE + 9 + 1
"""Length of the full observation in the 2v2 drill (:func:`full_into`)."""


def full_bounds(cfg: DrillConfig) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of the full observation: the kinematic bounds, the 9 features', then [0, 1]."""
    (klo, khi), (flo, fhi) = kinematic_bounds(cfg), feature_bounds(cfg)
    low = np.concatenate((klo, flo, [0.0])).astype(np.float32)
    high = np.concatenate((khi, fhi, [1.0])).astype(np.float32)
    return low, high


@compiled
def full_into(out, state, player, params, low, high):
    """The full observation of ``player`` in one drill (36 values in the 2v2 drill) into
    ``out``: the kinematic observation (self, teammates, opponents and ball, possession
    flags, role, :func:`kinematics_into`), the features (room for the larger team:
    passing and dribbling lanes, :func:`features_into`), then the time left, ``1 - cycle
    / max_cycles``."""
    players, attackers = state.pos.shape[0] - 1, params[0].attackers
    defenders = players - attackers
    most = attackers if attackers > defenders else defenders
    k = 4 * players + 10
    f = k + 5 * most - 1  # the features' end
    kinematics_into(out[:k], state, player, low[:k], high[:k], attackers)
    features_into(out[k:f], state.pos, player, params, low[k:f], high[k:f], most - 1, most)
    _clip_into(out, f, 1.0 - state.cycle / params[0].max_cycles, low, high)


@compiled
def _full_of_drills(out, state, rows, players, params, low, high):
    for r in range(rows.shape[0]):
        full_into(out[r], state[rows[r]], players[r], params, low, high)


STATE_SIZE = 29
"""Length of the global state vector in the 2v2 drill (``6 * players + 5``:
:func:`global_state_into`)."""


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
    speeds = ((cfg.attacker_speed,) * cfg.attackers + (cfg.defender_speed,) * cfg.defenders
              + (cfg.ball_max_speed,))
    for body, speed in enumerate(speeds):
        lo, hi = (ball_lo, ball_hi) if body == cfg.players else (player_lo, player_hi)
        low += [lo, lo, -speed, -speed]
        high += [hi, hi, speed, speed]
    low += [0.0] * (2 * cfg.players + 1)
    high += [1.0] * (2 * cfg.players + 1)
    return np.array(low, dtype=np.float32), np.array(high, dtype=np.float32)


@compiled
def global_state_into(out, state, max_cycles, low, high):
    """The whole of one drill in a fixed layout (``6 * players + 5`` values: 29 in the
    2v2 drill) into ``out``, for centralised critics; values clipped into
    :func:`state_bounds`. In the 2v2 drill:

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

    With ``P`` players: ``4 (P + 1)`` values of the players (attackers, then defenders)
    and the ball, ``P`` holder flags, ``P`` lock-out flags, the time.
    """
    pos, vel, holder = state.pos, state.vel, state.holder
    passer_locked = state.passer if state.cycle < state.lockout_until else -1
    players = pos.shape[0] - 1
    for body in range(players + 1):
        _clip_into(out, 4 * body, pos[body, 0], low, high)
        _clip_into(out, 4 * body + 1, pos[body, 1], low, high)
        _clip_into(out, 4 * body + 2, vel[body, 0], low, high)
        _clip_into(out, 4 * body + 3, vel[body, 1], low, high)
    flags = 4 * (players + 1)
    for i in range(players):
        _clip_into(out, flags + i, 1.0 if holder == i else 0.0, low, high)
        _clip_into(out, flags + players + i, 1.0 if passer_locked == i else 0.0, low, high)
    _clip_into(out, flags + 2 * players, state.cycle / max_cycles, low, high)


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
        Its length in the paper's 2v2 drill (its bounds give it for any drill).
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
    "the whole drill (29 values in the 2v2 drill; ``players`` is not read), for centralised "
    "critics")
"""The environments' ``state()``: every drill's :func:`global_state_into`."""
HOLDER_FEATURES = ObservationType(
    9, functools.partial(feature_bounds, holder=True), _holder_features_of_drills,
    "the ball holder's features: the attackers' own numbers of teammates and opponents "
    "(the paper's 9 in the 2v2 drill)")
"""The holder's observation (``HolderEnv``): :func:`features_into` with the attackers'
own numbers (:func:`feature_slots` with ``holder``)."""
