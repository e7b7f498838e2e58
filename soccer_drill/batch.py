"""Many drills stepped together: the rules of :class:`~soccer_drill.drill.Drill` on arrays.

:class:`BatchDrill` holds ``N`` drills' states as arrays and advances any subset of
them by one cycle: the players' commands become velocities (the batched skills of
:mod:`soccer_drill.batch_skills`), the holder keeps or kicks the ball, the physics runs
(:class:`~soccer_drill.batch_physics.BatchPhysics`), then possession, tackles and the
outcome are decided, all with the formulas of :class:`~soccer_drill.drill.Drill` in
the same order. The random draws of drill ``i`` come from its own generator, in the
order the single drill makes them (the start, then per cycle the pass's two normals and
the tackles' uniforms), so drill ``i`` reset with the generator of ``reset(seed=s)``
starts exactly where a single drill does.
"""

from __future__ import annotations

import numpy as np

from soccer_drill.batch_physics import DRILLS_PER_SPACE, BatchPhysics
from soccer_drill.batch_skills import (
    CONTROL,
    KICK,
    holder_motion,
    off_ball_targets,
    toward,
    turn_toward,
)
from soccer_drill.config import DrillConfig
from soccer_drill.drill import OUTCOMES
from soccer_drill.skills import BALL_SKILLS, Skill
from soccer_drill.state import DrillState

RUNNING = 0
"""``BatchDrill.outcome`` of a drill whose episode runs; ``k + 1`` is ``OUTCOMES[k]``."""
OUTCOME_NAMES: tuple[str | None, ...] = (None, *OUTCOMES)
"""Outcome names by code: ``OUTCOME_NAMES[BatchDrill.outcome[i]]``."""
_SUCCESS, _INTERCEPTION, _OUT, _TIMEOUT = 1, 2, 3, 4
_BALL_SKILL_CODES = np.array(sorted(int(s) for s in BALL_SKILLS))


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
        self._top = np.array([cfg.attacker_speed] * 2 + [cfg.defender_speed] * 2)
        self._caps = np.array([*self._top, cfg.ball_max_speed])
        self._starts = np.array([*cfg.attacker_starts, *cfg.defender_starts])

    # ------------------------------------------------------------------ reset
    def rebuild(self) -> None:
        """New physics spaces and bodies, as if the batch were new (see ``reset(seed=...)``)."""
        self.physics.build()

    def reset(self, drills: np.ndarray, rngs: list[np.random.Generator]) -> None:
        """Start a new episode in each of ``drills``, drawing from its generator in ``rngs``.

        The draws are those of :meth:`Drill.reset`: the start jitter, then the attacker
        given the ball.
        """
        cfg = self.config
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
        rows = np.arange(n)
        if (self.outcome[active] != RUNNING).any():
            ended = np.flatnonzero(active & (self.outcome != RUNNING))
            raise RuntimeError(
                f"drill {int(ended[0])}: the episode has ended; reset it first"
            )
        # The holder's ball skill (the holder's command must be one; others never are).
        held = (holder >= 0) & active
        h = np.where(holder >= 0, holder, 0)
        hskill = np.where(held, skill[rows, h], -1)
        passing = np.flatnonzero(hskill == int(Skill.PASS))
        noise = np.zeros((n, 2))
        for i in passing.tolist():
            noise[i] = rngs[i].normal(size=2)  # the two draws of pass_velocity, in order
        vmax = self._top * speed
        ball_skill = np.isin(skill, _BALL_SKILL_CODES)
        tgt = off_ball_targets(pos, vel, holder, skill, target, vmax, cfg)
        desired = toward(pos[:, :4], tgt, vmax)
        mv, ball_action, bvec = holder_motion(pos, vel, h, hskill, speed[rows, h], noise, cfg)
        desired = np.where(ball_skill[..., None], 0.0, desired)
        ball_held = held & ball_skill[rows, h]
        desired[ball_held, h[ball_held]] = mv[ball_held]
        # The acceleration cap.
        accel = cfg.player_acceleration * dt
        old = vel[:, :4]
        d = desired - old
        dv = np.hypot(d[..., 0], d[..., 1])
        over = dv > accel
        safe = np.where(over, dv, 1.0)  # dvx * accel / dv, as the single code computes it
        dx = np.where(over, d[..., 0] * accel / safe, d[..., 0])
        dy = np.where(over, d[..., 1] * accel / safe, d[..., 1])
        new_vel = np.stack((old[..., 0] + dx, old[..., 1] + dy), axis=-1)
        # The ball: kicked, kept at the control point, or rolling.
        kicked = held & (ball_action == KICK)
        control = held & (ball_action == CONTROL)
        ball_vel = vel[:, 4] * self._roll
        if kicked.any():
            ball_vel[kicked] = bvec[kicked]
        if control.any():
            c = np.flatnonzero(control)
            hc = h[c]
            p = pos[c, hc]
            b = pos[c, 4]
            ux, uy = turn_toward(b[:, 0] - p[:, 0], b[:, 1] - p[:, 1], bvec[c, 0], bvec[c, 1])
            hv = new_vel[c, hc]
            cx = p[:, 0] + hv[:, 0] * dt + ux * cfg.ball_offset
            cy = p[:, 1] + hv[:, 1] * dt + uy * cfg.ball_offset
            ball_vel[c, 0] = (cx - b[:, 0]) / dt
            ball_vel[c, 1] = (cy - b[:, 1]) / dt
        ball_vel = _capped(ball_vel, cfg.ball_max_speed)
        # Inactive drills stand still.
        still = ~active
        new_vel[still] = 0.0
        new_pos, out_vel = self.physics.cycle(pos[:, :4], new_vel)
        ball = pos[:, 4].copy()
        sub_dt = cfg.cycle_seconds / cfg.substeps
        step = ball_vel * sub_dt
        for _ in range(cfg.substeps):  # pymunk's own position update, p + v * dt
            ball += step
        # A collision can push a player past its top speed: capped (the ball is already).
        out_vel = _capped(out_vel, self._caps[:4], squared=True)
        ball_vel = _capped(ball_vel, cfg.ball_max_speed, squared=True)
        a = np.flatnonzero(active)
        pos[a, :4] = new_pos[a]
        pos[a, 4] = ball[a]
        vel[a, :4] = out_vel[a]
        vel[a, 4] = ball_vel[a]
        before = np.where(kicked, -1, holder)
        self.passer[kicked] = h[kicked]
        self.lockout_until[kicked] = self.cycle[kicked] + 1 + cfg.pass_lockout_cycles
        self.cycle[a] += 1
        self.cycles_run += len(a)
        self._possession(a, before, rngs)
        self._judge(a)

    def _possession(self, a: np.ndarray, before: np.ndarray, rngs: list) -> None:
        """``Drill._holder_after`` for the drills ``a`` (``before``: who held it before)."""
        cfg = self.config
        pos, vel = self.pos[a], self.vel[a]
        ball, bvel = pos[:, 4:5], vel[:, 4:5]
        dist = np.hypot(pos[:, :4, 0] - ball[..., 0], pos[:, :4, 1] - ball[..., 1])
        rel = np.hypot(bvel[..., 0] - vel[:, :4, 0], bvel[..., 1] - vel[:, :4, 1])
        locked_out = np.where(self.cycle[a] < self.lockout_until[a], self.passer[a], -1)
        ok = (dist <= cfg.control_radius) & (np.arange(4) != locked_out[:, None])
        ok &= rel <= cfg.control_speed
        rows = np.arange(len(a))
        held = before[a]
        hh = np.where(held >= 0, held, 0)
        keeps = (held >= 0) & ok[rows, hh]
        new = np.where(keeps, held, -1)
        # A loose ball goes to the nearest player in control (the lower index if equal).
        masked = np.where(ok, dist, np.inf)
        nearest = masked.argmin(axis=1)
        loose = ~keeps & ok.any(axis=1)
        new = np.where(loose, nearest, new)
        # Tackles: each opponent in control, nearest first, takes it with probability p.
        opponents = ok & ((np.arange(4) >= 2) != (hh >= 2)[:, None]) & keeps[:, None]
        for r in np.flatnonzero(opponents.any(axis=1)).tolist():
            rng = rngs[int(a[r])]
            for i in sorted(np.flatnonzero(opponents[r]).tolist(), key=lambda i: (dist[r, i], i)):
                if rng.random() < cfg.tackle_probability:
                    new[r] = i
                    break
        self.holder[a] = new

    def _judge(self, a: np.ndarray) -> None:
        cfg = self.config
        bx, by = self.pos[a, 4, 0], self.pos[a, 4, 1]
        h = self.holder[a]
        inside_x = (bx >= 0.0) & (bx <= cfg.field_size)
        inside = inside_x & (by >= 0.0) & (by <= cfg.field_size)
        interception = h >= 2
        success = ~interception & (h >= 0) & (by <= 0.0) & inside_x
        out = ~interception & ~success & ~inside
        timeout = ~interception & ~success & ~out & (self.cycle[a] >= cfg.max_cycles)
        code = np.select([interception, success, out, timeout], [2, 1, 3, 4], 0).astype(np.int8)
        half = cfg.field_size / 2
        off_centre = np.minimum(np.abs(bx - half) / half, 1.0)
        success_reward = cfg.reward_success_centre + (
            cfg.reward_success_edge - cfg.reward_success_centre
        ) * off_centre
        reward = np.select(
            [success, interception | out, timeout],
            [success_reward, cfg.reward_failure, cfg.reward_timeout],
            0.0,
        )
        self.outcome[a] = code
        self.attacker_reward[a] = reward

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


def _capped(v: np.ndarray, cap: np.ndarray | float, squared: bool = False) -> np.ndarray:
    """``drill._capped`` on arrays: a velocity above its cap scaled down to it.

    ``squared``: the drill's test after the physics (``vx * vx + vy * vy > cap * cap``).
    """
    speed = np.hypot(v[..., 0], v[..., 1])
    cap_b = np.broadcast_to(cap, speed.shape)
    if squared:
        over = v[..., 0] * v[..., 0] + v[..., 1] * v[..., 1] > cap_b * cap_b
        over &= speed > cap_b  # drill._capped keeps a speed at most the cap as it is
    else:
        over = speed > cap_b
    if not over.any():
        return v
    safe = np.where(over, speed, 1.0)
    return np.where(
        over[..., None],
        np.stack((v[..., 0] * cap_b / safe, v[..., 1] * cap_b / safe), axis=-1),
        v,
    )
