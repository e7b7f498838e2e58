"""Keepaway's rules on the drill's physics (Stone, Sutton and Kuhlmann 2005): the keeper
with the ball's state variables, and the keepers' behaviour off the ball.

**State variables.** With ``k`` keepers and ``t`` takers, seen from the keeper with the
ball ``K1``, the other keepers ``K2 .. Kk`` ordered by their distance to ``K1`` and the
takers ``T1 .. Tt`` by theirs, ``C`` the region's centre: ``4 k + 2 t - 3`` values (13 at
3v2, 19 at 4v3), in keepaway's order:

| indices | variable | unit |
|---|---|---|
| ``0`` | ``dist(K1, C)`` | m |
| ``1 .. k-1`` | ``dist(K1, Ki)``, ``i = 2 .. k`` | m |
| ``k .. k+t-1`` | ``dist(K1, Tj)``, ``j = 1 .. t`` | m |
| ``k+t .. 2k+t-2`` | ``dist(Ki, C)`` | m |
| ``2k+t-1 .. 2k+2t-2`` | ``dist(Tj, C)`` | m |
| ``2k+2t-1 .. 3k+2t-3`` | ``min_j dist(Ki, Tj)``: each keeper's nearest taker | m |
| ``3k+2t-2 .. 4k+2t-4`` | ``min_j ang(Ki, K1, Tj)``: each keeper's passing lane | deg |

Ties in distance keep the lower index first; an angle with a zero-length side reads 180.
Values are clipped into their bounds (:func:`keepaway_bounds`).

**Off the ball** (:class:`GetOpen`, the keepers the holder's SMDP does not control): a
keeper goes to a loose ball if it can reach it first among the keepers that may take it
(keepaway's "fastest to the ball intercepts"); otherwise it gets open (keepaway's
hand-coded ``GetOpen``): of a 5 x 5 grid of points over the region (a tenth of its side
in from each edge), the least congested (the sum of ``1 / distance`` to every other
player) among those open for a pass from where the ball will be played (no taker in the
cone of half-width ``0.3`` per metre from there to the point), else the least congested.
It is deterministic: keepaway's keepers draw nothing.
"""

from __future__ import annotations

import math

import numpy as np

from soccer_drill.commands import Skill
from soccer_drill.config import DrillConfig
from soccer_drill.rules.arrays import roll_table, rule_parameters
from soccer_drill.rules.compiled import compiled, hypot
from soccer_drill.rules.motion import in_cone, interception_point, players_by_distance

GRID = 5
"""Points per side of the grid a keeper gets open on."""
CONE = 0.3
"""Half-width per metre of the cone a taker blocks a pass in (about 16.7 degrees)."""
_GO_TO_BALL, _MOVE_TO = int(Skill.GO_TO_BALL), int(Skill.MOVE_TO)
_DEGREES = 180.0 / math.pi


def state_size(keepers: int, takers: int) -> int:
    """How many state variables keepaway has with ``keepers`` and ``takers``."""
    return 4 * keepers + 2 * takers - 3


def state_names(keepers: int, takers: int) -> tuple[str, ...]:
    """The state variables' names, in order (the module's table)."""
    others = range(2, keepers + 1)
    return ("dist_k1_c", *(f"dist_k1_k{i}" for i in others),
            *(f"dist_k1_t{j}" for j in range(1, takers + 1)),
            *(f"dist_k{i}_c" for i in others), *(f"dist_t{j}_c" for j in range(1, takers + 1)),
            *(f"min_dist_k{i}_t" for i in others), *(f"min_ang_k{i}_k1_t" for i in others))


def keepaway_bounds(cfg: DrillConfig) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds of the state variables (float32): distances up to the
    diagonal of the walls' square, distances to the centre up to half of it, angles up
    to 180 degrees."""
    k, t = cfg.attackers, cfg.defenders
    span = cfg.field_size + 2 * cfg.wall_margin
    diag = math.ceil(span * math.sqrt(2))
    half = math.ceil(span * math.sqrt(2) / 2)
    high = [half] + [diag] * (k - 1 + t) + [half] * (k - 1 + t) + [diag] * (k - 1) + [180] * (k - 1)
    return np.zeros(len(high), dtype=np.float32), np.array(high, dtype=np.float32)


@compiled
def _clip(out, k, value, low, high):
    """``out[k]`` = ``value`` clipped into ``[low[k], high[k]]`` (as ``np.clip``)."""
    lo, hi = low[k], high[k]
    m = value if value > lo or value != value else lo
    out[k] = m if m < hi or m != m else hi


@compiled
def keepaway_state_into(out, pos, player, params, low, high):
    """The state variables of keeper ``player`` (``K1``) in one drill (``pos``: ``(players
    + 1, 2)``, the first ``params[0].attackers`` of them keepers) into ``out`` (float32),
    each clipped into ``[low, high]`` (the module's table)."""
    keepers = params[0].attackers
    players = pos.shape[0] - 1
    takers = players - keepers
    c = params[0].field_size / 2
    sx, sy = pos[player, 0], pos[player, 1]
    mates = np.empty(4, np.int64)
    mdist = np.empty(4)
    opps = np.empty(4, np.int64)
    odist = np.empty(4)
    m = players_by_distance(pos, 0, keepers, player, sx, sy, mates, mdist)
    t = players_by_distance(pos, keepers, players, -1, sx, sy, opps, odist)
    _clip(out, 0, hypot(sx - c, sy - c), low, high)
    for i in range(m):
        _clip(out, 1 + i, mdist[i], low, high)
        q = mates[i]
        _clip(out, keepers + takers + i, hypot(pos[q, 0] - c, pos[q, 1] - c), low, high)
        ux, uy = pos[q, 0] - sx, pos[q, 1] - sy
        near, lane = 0.0, 180.0
        for j in range(t):
            o = opps[j]
            d = hypot(pos[o, 0] - pos[q, 0], pos[o, 1] - pos[q, 1])
            ax, ay = pos[o, 0] - sx, pos[o, 1] - sy
            a = 180.0
            if mdist[i] >= 1e-9 and odist[j] >= 1e-9:
                cosine = (ux * ax + uy * ay) / (mdist[i] * odist[j])
                cosine = -1.0 if cosine < -1.0 else 1.0 if cosine > 1.0 else cosine
                a = _DEGREES * math.acos(cosine)
            if j == 0 or d < near:
                near = d
            if j == 0 or a < lane:
                lane = a
        _clip(out, 2 * keepers + 2 * takers - 1 + i, near, low, high)
        _clip(out, 3 * keepers + 2 * takers - 2 + i, lane, low, high)
    for j in range(t):
        o = opps[j]
        _clip(out, keepers + j, odist[j], low, high)
        _clip(out, 2 * keepers + takers - 1 + j, hypot(pos[o, 0] - c, pos[o, 1] - c), low, high)


@compiled
def keepaway_states_of_drills(out, state, rows, players, params, low, high):
    """:func:`keepaway_state_into` of keeper ``players[r]`` in drill ``rows[r]``, into ``out[r]``."""
    for r in range(rows.shape[0]):
        keepaway_state_into(out[r], state[rows[r]].pos, players[r], params, low, high)


# ------------------------------------------------------------------ off the ball
@compiled
def get_open_point(pos, player, fx, fy, size, keepers):
    """Where keeper ``player`` gets open for a pass from ``(fx, fy)`` (the module's
    docstring): ``(x, y)``."""
    players = pos.shape[0] - 1
    buffer = size / 10.0
    mesh = (size - 2.0 * buffer) / (GRID - 1)
    best_open, best_any = math.inf, math.inf
    ox, oy, ax, ay = 0.0, 0.0, 0.0, 0.0
    for i in range(GRID):
        for j in range(GRID):
            x, y = buffer + i * mesh, buffer + j * mesh
            congestion = 0.0
            for q in range(players):
                if q != player:
                    d = hypot(pos[q, 0] - x, pos[q, 1] - y)
                    congestion += 1.0 / (d if d > 0.1 else 0.1)
            blocked = False
            for o in range(keepers, players):
                if in_cone(fx, fy, x, y, pos[o, 0], pos[o, 1], CONE):
                    blocked = True
            if congestion < best_any:
                best_any, ax, ay = congestion, x, y
            if not blocked and congestion < best_open:
                best_open, ox, oy = congestion, x, y
    if best_open < math.inf:
        return ox, oy
    return ax, ay


@compiled
def get_open_commands(state, cycle, supporting, params, table):
    """Keepaway's keepers off the ball, for keeper ``k`` of drill ``i`` wherever
    ``supporting[i, k]``, into ``cycle[i]``'s command of ``k`` (the module's docstring)."""
    keepers = supporting.shape[1]
    p = params[0]
    vmax = p.attacker_speed
    size = p.field_size
    for i in range(state.shape[0]):
        s, c = state[i], cycle[i]
        pos, vel = s.pos, s.vel
        ball = pos.shape[0] - 1
        # Who plays the ball next: its holder, or the keeper that reaches it first.
        fastest, soonest = -1, math.inf
        if s.holder < 0:
            for k in range(keepers):
                if s.passer == k and s.cycle < s.lockout_until:
                    continue
                x, y = interception_point(pos, vel, s.holder, k, vmax, params, table)
                when = hypot(x - pos[k, 0], y - pos[k, 1]) / vmax
                if when < soonest:
                    fastest, soonest = k, when
        if fastest >= 0:
            fx, fy = interception_point(pos, vel, s.holder, fastest, vmax, params, table)
        else:
            fx, fy = pos[ball, 0], pos[ball, 1]
        for k in range(keepers):
            if not supporting[i, k]:
                continue
            c.speed[k] = 1.0
            if k == fastest:
                c.skill[k] = _GO_TO_BALL
                continue
            x, y = get_open_point(pos, k, fx, fy, size, keepers)
            c.skill[k] = _MOVE_TO
            c.target[k, 0] = x
            c.target[k, 1] = y


class GetOpen:
    """Keepaway's keepers off the ball in ``n`` drills (the module's docstring): the
    support behaviour of the keepaway task (:data:`~soccer_drill.rules.task_rules.TASK_RULES`),
    with the interface of :class:`~soccer_drill.rules.support.SupportDraws`. It draws
    nothing, so :meth:`seed` keeps nothing."""

    def __init__(self, n: int, config: DrillConfig) -> None:
        self.n = n
        self._config = config
        self._params, self._table = rule_parameters(config), roll_table(config)

    def __getstate__(self) -> dict:
        return {"n": self.n, "_config": self._config}

    def __setstate__(self, state: dict) -> None:
        self.__init__(state["n"], state["_config"])  # the configuration's read-only arrays

    def seed(self, drills: np.ndarray, seeds: list[int]) -> None:
        """A new episode in ``drills``: nothing to draw."""

    def commands(self, state: np.ndarray, cycle: np.ndarray, supporting: np.ndarray,
                 size: float) -> None:
        """:func:`get_open_commands` of every drill."""
        get_open_commands(state, cycle, supporting, self._params, self._table)
