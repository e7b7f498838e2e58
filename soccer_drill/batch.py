"""Many drills stepped together: the rules of :class:`~soccer_drill.drill.Drill` on arrays.

:class:`BatchDrill` holds ``N`` drills' states as arrays and advances any subset of
them by one cycle: the players' commands become velocities (the skills' rules of
:mod:`soccer_drill.motion`, the single drill's, run drill by drill), the holder keeps
or kicks the ball, the physics runs (:class:`~soccer_drill.batch_physics.BatchPhysics`),
then possession, tackles and the outcome are decided, with the formulas of
:class:`~soccer_drill.drill.Drill` in the same order. The random draws of drill ``i`` come from its own generator, in the
order the single drill makes them (the start, then per cycle the pass's two normals and
the tackles' uniforms), so drill ``i`` reset with the generator of ``reset(seed=s)``
starts exactly where a single drill does.
"""

from __future__ import annotations

import math

import numpy as np

from soccer_drill.batch_physics import DRILLS_PER_SPACE, BatchPhysics
from soccer_drill.config import DrillConfig
from soccer_drill.drill import OUTCOMES
from soccer_drill.motion import (
    CONTROL,
    KICK,
    NO_BALL,
    PASS,
    motions_of_drills,
    roll_table,
    rule_parameters,
)
from soccer_drill.state import DrillState

RUNNING = 0
"""``BatchDrill.outcome`` of a drill whose episode runs; ``k + 1`` is ``OUTCOMES[k]``."""
OUTCOME_NAMES: tuple[str | None, ...] = (None, *OUTCOMES)
"""Outcome names by code: ``OUTCOME_NAMES[BatchDrill.outcome[i]]``."""
_SUCCESS, _INTERCEPTION, _OUT, _TIMEOUT = 1, 2, 3, 4
_PLAYERS = np.arange(4)
_IS_DEFENDER = _PLAYERS >= 2


class BatchDrill:
    """``n`` drills without any API around them: physics, possession and outcomes on arrays.

    Args:
        n: number of drills.
        config: their parameters (one for all).
        drills_per_space: drills sharing one pymunk space.

    Attributes (``i`` indexes drills):
        pos, vel: ``(n, 5, 2)`` float64, the four players then the ball.
        holder: ``(n,)`` the player in possession, -1 for a loose ball.
        cycle, passer, lockout_until: ``(n,)`` as in :class:`~soccer_drill.state.DrillState`.
        outcome: ``(n,)`` int8, :data:`RUNNING` or ``1 + OUTCOMES.index(name)``.
        attacker_reward: ``(n,)`` the attackers' reward once the episode has ended.
    """

    def __init__(
        self, n: int, config: DrillConfig | None = None, drills_per_space: int = DRILLS_PER_SPACE
    ) -> None:
        if not isinstance(n, int) or isinstance(n, bool) or n < 1:
            raise ValueError(f"the number of drills must be an integer >= 1, got {n!r}")
        self.n = n
        self.config = cfg = config or DrillConfig()
        self.physics = BatchPhysics(n, cfg, drills_per_space)
        self.pos = np.zeros((n, 5, 2))
        self.vel = np.zeros((n, 5, 2))
        self.holder = np.full(n, -1, dtype=np.int64)
        self.cycle = np.zeros(n, dtype=np.int64)
        self.passer = np.full(n, -1, dtype=np.int64)
        self.lockout_until = np.zeros(n, dtype=np.int64)
        self.outcome = np.zeros(n, dtype=np.int8)
        self.attacker_reward = np.zeros(n)
        self.cycles_run = 0
        """Drill-cycles advanced since construction (for benchmarks)."""
        self._roll = cfg.ball_damping**cfg.cycle_seconds
        self._sub_dt = cfg.cycle_seconds / cfg.substeps
        self._top = np.array([cfg.attacker_speed] * 2 + [cfg.defender_speed] * 2)
        self._caps = np.array([*self._top, cfg.ball_max_speed])
        self._starts = np.array([*cfg.attacker_starts, *cfg.defender_starts])
        self._params, self._table = rule_parameters(cfg), roll_table(cfg)
        self._noise = np.zeros((n, 2))  # the two normals of each drill's pass
        self._motions = np.zeros((n, 4, 5))  # each player's motion (skills' rules)

    # ------------------------------------------------------------------ reset
    def reset(self, drills: np.ndarray, rngs: list[np.random.Generator]) -> None:
        """Start a new episode in each of ``drills``, drawing from its generator in ``rngs``.

        The draws are those of :meth:`Drill.reset`: the start jitter, then the attacker
        given the ball. The physics of the spaces holding only drills of ``drills`` is
        built anew, as :meth:`Drill.reset` builds its own (``BatchPhysics.renew``).
        """
        cfg = self.config
        self.physics.renew(drills)
        for i, rng in zip(drills.tolist(), rngs, strict=True):
            jitter = rng.uniform(-cfg.start_jitter, cfg.start_jitter, size=(4, 2))
            self.pos[i, :4] = self._starts + jitter
            holder = int(rng.integers(2))
            self.pos[i, 4] = (self.pos[i, holder, 0], self.pos[i, holder, 1] - cfg.ball_offset)
            self.holder[i] = holder
        self.vel[drills] = 0.0
        self.cycle[drills] = 0
        self.passer[drills] = -1
        self.lockout_until[drills] = 0
        self.outcome[drills] = RUNNING
        self.attacker_reward[drills] = 0.0

    # ------------------------------------------------------------------- step
    def step(
        self,
        active: np.ndarray,
        skill: np.ndarray,
        target: np.ndarray,
        speed: np.ndarray,
        rngs: list[np.random.Generator],
    ) -> None:
        """Advance the drills where ``active`` (``(n,)`` bool) by one cycle.

        ``skill`` (``(n, 4)`` int), ``target`` (``(n, 4, 2)``) and ``speed`` (``(n, 4)``)
        are every player's command (rows of inactive drills are ignored); ``rngs[i]`` is
        drill ``i``'s generator. Inactive drills stand still and keep their state.
        """
        cfg, dt = self.config, self.config.cycle_seconds
        pos, vel, holder = self.pos, self.vel, self.holder
        n = self.n
        r = rows(n)
        if np.count_nonzero(self.outcome[active]):
            ended = np.nonzero(active & (self.outcome != RUNNING))[0]
            raise RuntimeError(
                f"drill {int(ended[0])}: the episode has ended; reset it first"
            )
        # Each player's motion, by the skills' rules; the holder's pass draws two normals.
        held = (holder >= 0) & active
        hskill = np.where(held, skill[r, holder], -1)  # holder -1: any column, unused
        passing = hskill == PASS
        noise = self._noise
        if np.count_nonzero(passing):
            for i in np.nonzero(passing)[0].tolist():
                noise[i] = rngs[i].normal(size=2)  # the two draws of pass_velocity, in order
        motions = self._motions
        motions_of_drills(motions, active, pos, vel, holder, skill, target, speed, noise,
                          self._params, self._table)
        desired = motions[..., 0:2].copy()
        ball_action = np.where(held, motions[r, holder, 2], NO_BALL)
        bvec = motions[r, holder, 3:5]
        # The acceleration cap.
        accel = cfg.player_acceleration * dt
        old = z(vel)[:, :4]
        dz = z(desired) - old
        d = xy(dz)
        dv = np.hypot(d[..., 0], d[..., 1])
        over = dv > accel
        if np.count_nonzero(over):  # dvx * accel / dv, as the single code computes it
            dz = np.where(over, z(d * accel / np.where(over, dv, 1.0)[..., None]), dz)
        dz += old
        new_vel = xy(dz)
        # The ball: kicked, kept at the control point, or rolling.
        kicked = held & (ball_action == KICK)
        control = held & (ball_action == CONTROL)
        ball_vel = vel[:, 4] * self._roll
        any_kicked = np.count_nonzero(kicked)
        if any_kicked:
            np.copyto(z(ball_vel), z(bvec), where=kicked)
        if np.count_nonzero(control):
            pz = z(pos)
            p = pz[r, holder]
            f = xy(pz[:, 4] - p)
            ux, uy = turn_toward(f[:, 0], f[:, 1], bvec[:, 0], bvec[:, 1])
            c = new_vel[r, holder] * dt
            cz = z(c)
            cz += p
            c[:, 0] += ux * cfg.ball_offset
            c[:, 1] += uy * cfg.ball_offset
            cz -= pz[:, 4]
            c /= dt
            np.copyto(z(ball_vel), cz, where=control)
        ball_vel = _capped(ball_vel, cfg.ball_max_speed)
        # Inactive drills stand still.
        n_active = np.count_nonzero(active)
        if n_active < n:
            new_vel[~active] = 0.0
        new_pos, out_vel = self.physics.cycle(pos[:, :4], new_vel, active if n_active < n else None)
        ball = pos[:, 4].copy()
        step = ball_vel * self._sub_dt
        for _ in range(cfg.substeps):  # pymunk's own position update, p + v * dt
            ball += step
        # A collision can push a player past its top speed: capped (the ball is already).
        out_vel = _capped(out_vel, self._caps[:4], squared=True)
        ball_vel = _capped(ball_vel, cfg.ball_max_speed, squared=True)
        if n_active == n:  # the usual case: every drill moved
            pos[:, :4] = new_pos
            vel[:, :4] = out_vel
            pos[:, 4] = ball
            vel[:, 4] = ball_vel
        else:
            where = active[:, None, None]
            np.copyto(pos[:, :4], new_pos, where=where)
            np.copyto(vel[:, :4], out_vel, where=where)
            np.copyto(pos[:, 4], ball, where=active[:, None])
            np.copyto(vel[:, 4], ball_vel, where=active[:, None])
        before = np.where(kicked, -1, holder) if any_kicked else holder
        if any_kicked:
            self.passer[kicked] = holder[kicked]
            self.lockout_until[kicked] = self.cycle[kicked] + 1 + cfg.pass_lockout_cycles
        self.cycle += active
        self.cycles_run += n_active
        self._possession(active, before, rngs)
        self._judge(active)

    def _possession(self, active: np.ndarray, before: np.ndarray, rngs: list) -> None:
        """``Drill._holder_after`` for the ``active`` drills (``before``: who held it before)."""
        cfg = self.config
        pos, vel = self.pos, self.vel
        d = xy(z(pos)[:, :4] - z(pos)[:, 4:5])
        dist = np.hypot(d[..., 0], d[..., 1])
        v = xy(z(vel)[:, 4:5] - z(vel)[:, :4])
        rel = np.hypot(v[..., 0], v[..., 1])
        locked_out = np.where(self.cycle < self.lockout_until, self.passer, -1)
        ok = dist <= cfg.control_radius
        ok &= _PLAYERS != locked_out[:, None]
        ok &= rel <= cfg.control_speed
        keeps = (before >= 0) & ok[rows(self.n), before]  # before -1: any column, unused
        # A loose ball goes to the nearest player in control (the lower index if equal).
        nearest = np.where(ok, dist, np.inf).argmin(axis=1)
        new = np.where(keeps, before, np.where(ok.any(axis=1), nearest, -1))
        # Tackles: each opponent in control, nearest first, takes it with probability p.
        opponents = ok & (_IS_DEFENDER != (before >= 2)[:, None]) & (keeps & active)[:, None]
        if np.count_nonzero(opponents):
            for r in np.nonzero(opponents.any(axis=1))[0].tolist():
                rng = rngs[r]
                for i in sorted(np.nonzero(opponents[r])[0].tolist(), key=lambda i: (dist[r, i], i)):
                    if rng.random() < cfg.tackle_probability:
                        new[r] = i
                        break
        np.copyto(self.holder, new, where=active)

    def none_can_end(self) -> bool:
        """Whether no drill's episode can end now: every ball strictly inside the field, no
        defender holding it, no drill at its last cycle (one test, before any detail: most
        cycles end no episode)."""
        cfg, ball = self.config, self.pos[:, 4]
        return (
            np.count_nonzero((ball > 0.0) & (ball <= cfg.field_size)) == 2 * self.n
            and not np.count_nonzero(self.holder >= 2)
            and not np.count_nonzero(self.cycle >= cfg.max_cycles)
        )

    def end_codes(self, active: np.ndarray) -> np.ndarray:
        """``(n,)`` ints: the outcome code each of the ``active`` drills' state gives now
        (``Drill._outcome``), :data:`RUNNING` where none or where not active."""
        cfg = self.config
        bx, by = self.pos[:, 4, 0], self.pos[:, 4, 1]
        h = self.holder
        inside_x = (bx >= 0.0) & (bx <= cfg.field_size)
        inside = inside_x & (by >= 0.0) & (by <= cfg.field_size)
        code = np.where(
            h >= 2, _INTERCEPTION,
            np.where((h >= 0) & (by <= 0.0) & inside_x, _SUCCESS,
                     np.where(inside, np.where(self.cycle >= cfg.max_cycles, _TIMEOUT, RUNNING),
                              _OUT)))
        code &= -active.view(np.int8)  # inactive drills: RUNNING
        return code

    def _judge(self, active: np.ndarray) -> None:
        if self.none_can_end():
            return
        cfg = self.config
        code = self.end_codes(active)
        if not np.count_nonzero(code):
            return
        bx = self.pos[:, 4, 0]
        for i in np.nonzero(code)[0].tolist():  # the drills whose episode ends now
            c = int(code[i])
            self.outcome[i] = c
            self.attacker_reward[i] = (
                cfg.success_reward(float(bx[i])) if c == _SUCCESS
                else cfg.reward_timeout if c == _TIMEOUT else cfg.reward_failure
            )

    # ---------------------------------------------------------------- views
    def state_of(self, i: int) -> DrillState:
        """Drill ``i``'s current :class:`DrillState` (for per-drill teams and checks)."""
        p = self.pos[i].tolist()
        v = self.vel[i].tolist()
        return DrillState(
            tuple(map(tuple, p)), tuple(map(tuple, v)), int(self.holder[i]), int(self.cycle[i]),
            int(self.passer[i]), int(self.lockout_until[i]),
        )

    def set_state(self, i: int, state: DrillState) -> None:
        """Put drill ``i`` in ``state`` (tests check the rules from the single drill's states)."""
        self.pos[i] = state.pos
        self.vel[i] = state.vel
        self.holder[i], self.cycle[i] = state.holder, state.cycle
        self.passer[i], self.lockout_until[i] = state.passer, state.lockout_until
        self.outcome[i] = RUNNING


_rows_cache: dict[int, np.ndarray] = {}
_MAX_TURN = math.radians(40.0)


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


def turn_toward(
    fx: np.ndarray, fy: np.ndarray, tx: np.ndarray, ty: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``drill._turn_toward`` on arrays: from direction f toward t by at most 40 degrees."""
    b = np.arctan2(ty, tx)
    a = np.where((fx != 0) | (fy != 0), np.arctan2(fy, fx), b)
    delta = np.remainder(b - a + math.pi, 2 * math.pi) - math.pi
    a = a + np.maximum(-_MAX_TURN, np.minimum(_MAX_TURN, delta))
    return np.cos(a), np.sin(a)


def _capped(v: np.ndarray, cap: np.ndarray | float, squared: bool = False) -> np.ndarray:
    """``drill._capped`` on arrays: a velocity above its cap scaled down to it.

    ``squared``: the drill's test after the physics (``vx * vx + vy * vy > cap * cap``),
    made first, so that the usual case (no velocity over its cap) costs no ``hypot``.
    """
    cap_b = np.broadcast_to(cap, v.shape[:-1])
    if squared:
        v2 = v[..., 0] * v[..., 0]
        v2 += v[..., 1] * v[..., 1]
        over = v2 > cap_b * cap_b
        if not np.count_nonzero(over):
            return v
        speed = np.hypot(v[..., 0], v[..., 1])
        over &= speed > cap_b  # drill._capped keeps a speed at most the cap as it is
    else:
        speed = np.hypot(v[..., 0], v[..., 1])
        over = speed > cap_b
    if not np.count_nonzero(over):
        return v
    safe = np.where(over, speed, 1.0)
    return xy(np.where(over, z(v * cap_b[..., None] / safe[..., None]), z(v)))
