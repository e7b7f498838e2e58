"""The drill's cycle, written once: :class:`BatchDrill` runs it for ``n`` drills on arrays,
and :class:`Drill` is one of them (``n = 1``) in a pymunk space of its own.

Each cycle every player's command becomes a desired velocity by the skills' rules
(:mod:`soccer_drill.rules.motion`), reached under the acceleration cap; the holder keeps
the ball at a control point just ahead of it with a small kick per cycle, or kicks it
away; the physics runs ``substeps`` fixed steps (:mod:`soccer_drill.drill.spaces`:
players collide with each other and with walls just outside the field; the ball meets
nothing and rolls with damping, so leaving the field ends the episode); then possession,
tackles and the outcome are decided (:mod:`soccer_drill.rules.cycle`). The rules run in
compiled loops over the drills; the random draws stay here, each drill's from its own
generator in one order: the start, then per cycle the pass's two normals and the
tackles' uniforms.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np

from soccer_drill.config import DrillConfig
from soccer_drill.constraints import Integer, checked
from soccer_drill.drill.spaces import DRILLS_PER_SPACE, BatchPhysics, DrillSpace
from soccer_drill.rules.cycle import (
    ORDER,
    PASSING,
    RUNNING,
    SCRATCH,
    TACKLERS,
    after_physics_of_drills,
    before_physics_of_drills,
    draw_start,
    outcome,
    reward,
    tackle,
)
from soccer_drill.rules.motion import roll_table, rule_parameters
from soccer_drill.skills import Command
from soccer_drill.state import DrillState

Outcome = Literal["success", "interception", "out", "timeout"]
OUTCOMES: tuple[Outcome, ...] = ("success", "interception", "out", "timeout")
OUTCOME_NAMES: tuple[str | None, ...] = (None, *OUTCOMES)
"""Outcome names by code: ``OUTCOME_NAMES[BatchDrill.outcome[i]]``."""


class BatchDrill:
    """``n`` drills without any API around them: physics, possession and outcomes on arrays.

    Parameters
    ----------
    n
        Number of drills.
    config
        Their parameters (one for all).
    drills_per_space
        Drills sharing one pymunk space (:class:`BatchPhysics`).
    physics
        The pymunk side instead (:class:`DrillSpace` for one drill).

    Attributes (``i`` indexes drills):
        pos, vel: ``(n, 5, 2)`` float64, the four players then the ball.
        holder: ``(n,)`` the player in possession, -1 for a loose ball.
        cycle, passer, lockout_until: ``(n,)`` as in :class:`~soccer_drill.state.DrillState`.
        outcome: ``(n,)`` int8, :data:`RUNNING` or ``1 + OUTCOMES.index(name)``.
        attacker_reward: ``(n,)`` the attackers' reward once the episode has ended.

    Drill ``i`` reset with the generator of ``reset(seed=s)`` starts where a single
    drill does, and with one drill per space plays its episodes up to the order in
    which chipmunk meets simultaneous contacts (:mod:`soccer_drill.drill.spaces`).
    """

    def __init__(
        self,
        n: int,
        config: DrillConfig | None = None,
        drills_per_space: int = DRILLS_PER_SPACE,
        physics: BatchPhysics | DrillSpace | None = None,
    ) -> None:
        self.n = n = checked("the number of drills", n, Integer(1))
        self.config = cfg = config or DrillConfig()
        self.physics = physics if physics is not None else BatchPhysics(n, cfg, drills_per_space)
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
        self._noise = np.zeros((n, 2))  # the two normals of each drill's pass
        self._motions = np.zeros((n, 4, 5))  # each player's motion (skills' rules)
        self._new_vel = np.zeros((n, 5, 2))  # the velocities set before the physics
        self._scratch = np.zeros((n, SCRATCH), dtype=np.int64)  # see rules.cycle.SCRATCH
        self._numbers()

    def _numbers(self) -> None:
        """What the rules read every cycle after its commands: the state's arrays, the
        scratch, the configuration's numbers (its arrays the shared read-only ones the rules
        are compiled for), in one tuple per call."""
        cfg = self.config
        self._params, self._table = rule_parameters(cfg), roll_table(cfg)
        self._before_rest = (
            self.outcome, self.pos, self.vel, self.holder, self._noise, self._new_vel,
            self._scratch, self._motions, self._params, self._table,
            cfg.player_acceleration * cfg.cycle_seconds, cfg.cycle_seconds, cfg.ball_offset,
            cfg.ball_damping**cfg.cycle_seconds, cfg.ball_max_speed)
        self._after_rest = (
            self.pos, self.vel, self.holder, self.cycle, self.passer, self.lockout_until,
            self.outcome, self._scratch, self._new_vel, cfg.substeps,
            cfg.cycle_seconds / cfg.substeps, cfg.pass_lockout_cycles, self._params,
            cfg.control_radius, cfg.control_speed, cfg.field_size, cfg.max_cycles)

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._numbers()  # a copy's arrays are writable: the shared read-only ones again

    # ------------------------------------------------------------------ reset
    def reset(self, drills: np.ndarray, rngs: Sequence[np.random.Generator]) -> None:
        """Start a new episode in each of ``drills``, drawing from its generator in ``rngs``:
        the start jitter, then the attacker given the ball. The physics of those drills
        is built anew where it holds no other drill (``physics.renew``)."""
        cfg = self.config
        for i, rng in zip(drills.tolist(), rngs, strict=True):
            self.pos[i], self.holder[i] = draw_start(rng, cfg)
        self.physics.renew(drills, self.pos)
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
        rngs: Sequence[np.random.Generator],
    ) -> None:
        """Advance the drills where ``active`` (``(n,)`` bool) by one cycle.

        ``skill`` (``(n, 4)`` int), ``target`` (``(n, 4, 2)``) and ``speed`` (``(n, 4)``)
        are every player's command (rows of inactive drills are ignored); ``rngs[i]`` is
        drill ``i``'s generator. Inactive drills stand still and keep their state.
        """
        ended, passes, n_active = before_physics_of_drills(active, True, skill, target, speed,
                                                           *self._before_rest)
        if ended >= 0:
            raise RuntimeError(f"drill {ended}: the episode has ended; reset it first")
        if passes:  # the pass's two draws, then its drill's rules
            noise = self._noise
            for i in np.flatnonzero(self._scratch[:, PASSING]).tolist():
                noise[i] = rngs[i].normal(size=2)
            before_physics_of_drills(active, False, skill, target, speed, *self._before_rest)
        players = self.physics.cycle(self.pos, self._new_vel, active if n_active < self.n else None)
        tackling, ended = after_physics_of_drills(active, players, *self._after_rest)
        self.cycles_run += n_active
        if tackling:
            self._tackle(rngs)
        if tackling or ended:
            self._rewards(active)

    def _tackle(self, rngs: Sequence[np.random.Generator]) -> None:
        """The tackles (:func:`~soccer_drill.rules.cycle.tackle`) where opponents may
        tackle, and the outcome again where one took the ball."""
        cfg = self.config
        scratch = self._scratch
        for i in np.flatnonzero(scratch[:, TACKLERS]).tolist():
            taken = tackle(scratch[i, ORDER:TACKLERS], int(scratch[i, TACKLERS]), rngs[i],
                           cfg.tackle_probability)
            if taken >= 0:
                self.holder[i] = taken
                self.outcome[i] = outcome(self.pos[i], taken, self.cycle[i], cfg.field_size,
                                          cfg.max_cycles)

    def _rewards(self, active: np.ndarray) -> None:
        """The attackers' reward in the active drills whose episode has ended."""
        cfg, bx = self.config, self.pos[:, 4, 0]
        for i in np.flatnonzero(active & (self.outcome != RUNNING)).tolist():
            self.attacker_reward[i] = reward(int(self.outcome[i]), float(bx[i]), cfg)

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


_new_state = tuple.__new__  # DrillState's fields in order, without its __new__'s defaults
_ONE = np.zeros(1, dtype=np.int64)
_ONE.flags.writeable = False


class Drill:
    """The 2v2 drill without any API around it: physics, possession and outcome.

    Parameters
    ----------
    config
        The drill's parameters.

    A :class:`BatchDrill` of one drill in a :class:`~soccer_drill.drill.spaces.DrillSpace`
    of its own. After :meth:`reset`, :attr:`state` is the current :class:`DrillState`;
    :attr:`outcome` becomes one of :data:`OUTCOMES` when the episode ends, and
    :attr:`attacker_reward` is then the attackers' reward. A :attr:`state` set from
    outside is what the next cycle's rules read; the bodies stay where the physics
    left them.
    """

    def __init__(self, config: DrillConfig | None = None) -> None:
        self.config = config or DrillConfig()
        self.drills = BatchDrill(1, self.config, physics=DrillSpace(self.config))
        # The players' commands as the rules read them.
        self._skill = np.zeros((1, 4), dtype=np.int64)
        self._target = np.zeros((1, 4, 2))
        self._speed = np.ones((1, 4))
        self._views()
        self._active = np.ones(1, dtype=bool)
        self._arrays_of: DrillState | None = None  # the state the arrays hold
        self.state: DrillState
        self.outcome: Outcome | None = None
        self.attacker_reward = 0.0

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        del state["_rows"], state["_state"]  # views: a copy's own are taken anew
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._views()

    def _views(self) -> None:
        """The rows of the one drill that a cycle writes and reads (views, which a copy
        takes anew)."""
        drills = self.drills
        self._rows = (self._skill[0], self._target[0], self._speed[0])
        self._state = (drills.pos[0], drills.vel[0], drills.holder, drills.cycle, drills.passer,
                       drills.lockout_until, drills.outcome)

    @property
    def physics(self) -> DrillSpace:
        """The drill's pymunk space and bodies."""
        return self.drills.physics  # type: ignore[return-value]

    def reset(self, rng: np.random.Generator) -> DrillState:
        """Place the players with seeded jitter and give the ball to a random attacker.

        The physics space is rebuilt, so the episode depends only on ``rng``'s state.
        """
        drills = self.drills
        drills.reset(_ONE, (rng,))
        self.outcome = None
        self.attacker_reward = 0.0
        pos = tuple(map(tuple, drills.pos[0].tolist()))
        self.state = self._arrays_of = DrillState(pos, ((0.0, 0.0),) * 5, int(drills.holder[0]), 0)
        return self.state

    def step(self, commands: Sequence[Command], rng: np.random.Generator) -> DrillState:
        """Advance one cycle with one command per player (index order)."""
        if self.outcome is not None:
            raise RuntimeError("the episode has ended; call reset() first")
        if len(commands) != 4:
            raise ValueError(f"Drill.step needs one command per player (4), got {len(commands)}")
        drills = self.drills
        skill, target, speed = self._rows
        for i, command in enumerate(commands):
            skill[i] = command.skill
            speed[i] = command.speed
            if command.target is not None:  # MOVE_TO's: the others' targets are not read
                target[i] = command.target
        if self._arrays_of is not self.state:  # the state was set from outside
            drills.set_state(0, self.state)
        drills.step(self._active, self._skill, self._target, self._speed, (rng,))
        pos, vel, holder, cycle, passer, lockout_until, outcome = self._state
        p, v = pos.tolist(), vel.tolist()
        new = _new_state(DrillState, (
            (tuple(p[0]), tuple(p[1]), tuple(p[2]), tuple(p[3]), tuple(p[4])),
            (tuple(v[0]), tuple(v[1]), tuple(v[2]), tuple(v[3]), tuple(v[4])),
            holder.item(), cycle.item(), passer.item(), lockout_until.item(),
        ))
        self.state = self._arrays_of = new
        code = outcome.item()
        if code != RUNNING:
            self.outcome = OUTCOMES[code - 1]
            self.attacker_reward = drills.attacker_reward.item()
        return new


_rows_cache: dict[int, np.ndarray] = {}


def rows(n: int) -> np.ndarray:
    """``np.arange(n)``, made once per ``n`` (read-only)."""
    r = _rows_cache.get(n)
    if r is None:
        r = _rows_cache[n] = np.arange(n)
        r.flags.writeable = False
    return r
