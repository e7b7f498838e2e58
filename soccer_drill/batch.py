"""Many drills stepped together: the rules of :class:`~soccer_drill.drill.Drill` on arrays.

:class:`BatchDrill` holds ``N`` drills' states as arrays and advances any subset of
them by one cycle: the players' commands become velocities (the skills' rules of
:mod:`soccer_drill.rules.motion`, the single drill's, run drill by drill), the holder keeps
or kicks the ball, the physics runs (:class:`~soccer_drill.batch_physics.BatchPhysics`),
then possession, tackles and the outcome are decided, with the formulas of
:class:`~soccer_drill.drill.Drill` in the same order. The random draws of drill ``i`` come from its own generator, in the
order the single drill makes them (the start, then per cycle the pass's two normals and
the tackles' uniforms), so drill ``i`` reset with the generator of ``reset(seed=s)``
starts exactly where a single drill does.
"""

from __future__ import annotations

import numpy as np

from soccer_drill.batch_physics import DRILLS_PER_SPACE, BatchPhysics
from soccer_drill.config import DrillConfig
from soccer_drill.drill import OUTCOMES
from soccer_drill.rules.cycle import (
    RUNNING,
    after_physics_of_drills,
    draw_start,
    outcomes_of_drills,
    possession_of_drills,
    reward,
    tackle,
    velocities_of_drills,
)
from soccer_drill.rules.motion import (
    PASS,
    motions_of_drills,
    roll_table,
    rule_parameters,
)
from soccer_drill.state import DrillState

OUTCOME_NAMES: tuple[str | None, ...] = (None, *OUTCOMES)
"""Outcome names by code: ``OUTCOME_NAMES[BatchDrill.outcome[i]]``."""


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
        self._params, self._table = rule_parameters(cfg), roll_table(cfg)
        self._noise = np.zeros((n, 2))  # the two normals of each drill's pass
        self._motions = np.zeros((n, 4, 5))  # each player's motion (skills' rules)
        self._new_vel = np.zeros((n, 5, 2))  # the velocities set before the physics
        self._kicker = np.full(n, -1, dtype=np.int64)
        self._before = np.full(n, -1, dtype=np.int64)  # who held the ball before the physics
        self._accel = cfg.player_acceleration * cfg.cycle_seconds
        self._order = np.zeros((n, 4), dtype=np.int64)  # the possession rule's tacklers
        self._tacklers = np.zeros(n, dtype=np.int64)
        self._codes = np.zeros(n, dtype=np.int64)

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
            self.pos[i], self.holder[i] = draw_start(rng, cfg)
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
        # The velocities set before the physics (inactive drills stand still).
        new_vel, kicker = self._new_vel, self._kicker
        velocities_of_drills(new_vel, kicker, active, pos, vel, holder, motions,
                             self._accel, dt, cfg.ball_offset, self._roll, cfg.ball_max_speed)
        n_active = np.count_nonzero(active)
        new_pos, out_vel = self.physics.cycle(pos[:, :4], new_vel[:, :4],
                                              active if n_active < n else None)
        before = self._before
        before[:] = holder
        after_physics_of_drills(pos, vel, before, self.passer, self.lockout_until, self.cycle,
                                active, kicker, new_pos, out_vel, new_vel, cfg.substeps,
                                self._sub_dt, cfg.pass_lockout_cycles, self._params)
        self.cycles_run += n_active
        self._possession(active, before, rngs)
        self._judge(active)

    def _possession(self, active: np.ndarray, before: np.ndarray, rngs: list) -> None:
        """Possession and tackles (:func:`~soccer_drill.rules.cycle.possession`) in the
        ``active`` drills (``before``: who held the ball before the physics)."""
        cfg = self.config
        order, tacklers = self._order, self._tacklers
        possession_of_drills(self.holder, tacklers, order, active, self.pos, self.vel, before,
                             self.cycle, self.passer, self.lockout_until, cfg.control_radius,
                             cfg.control_speed)
        if np.count_nonzero(tacklers[active]):
            for i in np.nonzero(active & (tacklers > 0))[0].tolist():
                taken = tackle(order[i], int(tacklers[i]), rngs[i], cfg.tackle_probability)
                if taken >= 0:
                    self.holder[i] = taken

    def _judge(self, active: np.ndarray) -> None:
        """The outcome (:func:`~soccer_drill.rules.cycle.outcome`) of the ``active`` drills."""
        cfg, code = self.config, self._codes
        outcomes_of_drills(code, active, self.pos, self.holder, self.cycle, cfg.field_size,
                           cfg.max_cycles)
        if not np.count_nonzero(code):
            return
        bx = self.pos[:, 4, 0]
        for i in np.nonzero(code)[0].tolist():  # the drills whose episode ends now
            c = int(code[i])
            self.outcome[i] = c
            self.attacker_reward[i] = reward(c, float(bx[i]), cfg)

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


def rows(n: int) -> np.ndarray:
    """``np.arange(n)``, made once per ``n`` (read-only)."""
    r = _rows_cache.get(n)
    if r is None:
        r = _rows_cache[n] = np.arange(n)
        r.flags.writeable = False
    return r
