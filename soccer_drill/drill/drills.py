"""The drill's cycle, written once: :class:`BatchDrill` runs it for ``n`` drills on arrays,
one drill in a pymunk space of its own (:class:`~soccer_drill.drill.spaces.DrillSpace`: the
single environments) or many in shared spaces.

Each cycle every player's command becomes a desired velocity by the skills' rules
(:mod:`soccer_drill.rules.motion`), reached under the acceleration cap; the holder keeps
the ball at a control point just ahead of it with a small kick per cycle, or kicks it
away; the physics runs ``substeps`` fixed steps (:mod:`soccer_drill.drill.spaces`:
players collide with each other and with walls just outside the field; the ball meets
nothing and rolls with damping, so leaving the field ends the episode); then possession,
tackles and the outcome are decided (:mod:`soccer_drill.rules.cycle`). The rules run in
compiled loops over the drills' records (:mod:`soccer_drill.rules.arrays`); the random
draws stay here, each drill's from its own generator in one order: the start, then per
cycle the pass's two normals and the tackles' uniforms.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from soccer_drill.config import DrillConfig
from soccer_drill.constraints import Integer, checked
from soccer_drill.drill.spaces import DRILLS_PER_SPACE, BatchPhysics, DrillSpace
from soccer_drill.rules.arrays import (
    Outcome,
    cycle_record,
    roll_table,
    rule_parameters,
    state_record,
)
from soccer_drill.rules.compiled import bind
from soccer_drill.rules.cycle import (
    after_physics_of_drills,
    before_physics_of_drills,
    draw_start,
    outcome,
    reward,
    tackle,
)
from soccer_drill.state import DrillState


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

    Attributes
    ----------
    state
        ``(n,)`` :data:`~soccer_drill.rules.arrays.STATE` records (of
        ``config.players`` players: :func:`~soccer_drill.rules.arrays.state_record`);
        ``pos``, ``vel`` (``(n, players + 1, 2)``: the players then the ball), ``holder`` (-1: a loose ball),
        ``cycle``, ``passer``, ``lockout_until`` and ``outcome`` (an
        :class:`~soccer_drill.rules.arrays.Outcome` code) are views of its fields.
    commands
        ``(n,)`` :data:`~soccer_drill.rules.arrays.CYCLE` records; ``skill`` (``(n,
        players)``), ``target`` (``(n, players, 2)``), ``speed`` and ``receiver`` (``(n,
        players)``; -1: a pass goes to the nearest teammate), views of their fields, are
        every player's command for the next cycle (rows of inactive drills ignored).
    attacker_reward
        ``(n,)`` the attackers' reward once a drill's episode has ended.
    params, table
        The rule parameters (:func:`~soccer_drill.rules.arrays.rule_parameters`) and the
        rolling ball's table of ``config``.

    Drill ``i`` reset with the generator of ``reset(seed=s)`` starts where the single
    environment does; with one drill per space it plays its episodes up to the order in
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
        self.players = cfg.players
        self.state = np.zeros(n, dtype=state_record(cfg.players))
        self.state["holder"] = -1
        self.state["passer"] = -1
        self.commands = np.zeros(n, dtype=cycle_record(cfg.players))
        self.commands["speed"] = 1.0
        self.commands["receiver"] = -1
        self.attacker_reward = np.zeros(n)
        self._active = np.zeros(n, dtype=bool)  # the drills a cycle moves, as the rules read them
        self.cycles_run = 0
        """Drill-cycles advanced since construction (for benchmarks)."""
        self.steps = 0
        """Cycles, resets and states set since construction: when a drill's state changes."""
        self._states: dict[int, tuple[int, DrillState]] = {}  # state_of's, by drill
        self._views()

    def _views(self) -> None:
        """The fields as arrays (views, which a copy takes anew) and the configuration's
        read-only arrays the rules are compiled for."""
        for name in self.state.dtype.names:
            setattr(self, name, self.state[name])
        for name in _COMMANDS:
            setattr(self, name, self.commands[name])
        self._new_vel = self.commands["new_vel"]  # what the physics is given each cycle
        self.params, self.table = rule_parameters(self.config), roll_table(self.config)
        # The cycle's rules bound to these arrays (rules.compiled.bind), made at the first
        # cycle; the rules after the physics also to the physics' array of players.
        self._before: tuple | None = None
        self._after: tuple = (None, None)

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        for name in (*self.state.dtype.names, *_COMMANDS, "_new_vel", "params", "table",
                     "_before", "_after"):
            del state[name]
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._views()

    # ------------------------------------------------------------------ reset
    def reset(self, drills: np.ndarray, rngs: Sequence[np.random.Generator]) -> None:
        """Start a new episode in each of ``drills``, drawing from its generator in ``rngs``:
        the start jitter, then the attacker given the ball. The physics of those drills
        is built anew where it holds no other drill (``physics.renew``)."""
        cfg, pos = self.config, self.pos
        for i, rng in zip(drills.tolist(), rngs, strict=True):
            pos[i], self.holder[i] = draw_start(rng, cfg)
        self.physics.renew(drills, pos)
        state = self.state
        state["vel"][drills] = 0.0
        for name, value in (("cycle", 0), ("passer", -1), ("lockout_until", 0),
                            ("outcome", Outcome.RUNNING)):
            state[name][drills] = value
        self.attacker_reward[drills] = 0.0
        self.steps += 1

    # ------------------------------------------------------------------- step
    def step(self, active: np.ndarray, rngs: Sequence[np.random.Generator]) -> None:
        """Advance the drills where ``active`` (``(n,)`` bool) by one cycle, with the
        commands in :attr:`commands`; ``rngs[i]`` is drill ``i``'s generator. Inactive
        drills stand still and keep their state."""
        state, cycle, params = self.state, self.commands, self.params
        before = self._before
        if before is None:
            before = self._before = tuple(
                bind(before_physics_of_drills, self._active, first, state, cycle, params,
                     self.table) for first in (True, False))
        np.copyto(self._active, active)
        ended, passes, n_active = before[0]()
        if ended >= 0:
            raise RuntimeError(f"drill {ended}: the episode has ended; reset it first")
        if passes:  # the pass's two draws, then its drill's rules
            noise = cycle["noise"]
            for i in np.flatnonzero(cycle["passing"]).tolist():
                noise[i] = rngs[i].normal(size=2)
            before[1]()
        players = self.physics.cycle(self.pos, self._new_vel,
                                     active if n_active < self.n else None)
        bound_to, after = self._after
        if players is not bound_to:  # the physics' array is new: bound once more
            after = bind(after_physics_of_drills, self._active, players, state, cycle, params)
            self._after = (players, after)
        tackling, ended = after()
        self.cycles_run += n_active
        self.steps += 1
        if tackling:
            self._tackle(rngs)
        if tackling or ended:
            self._rewards(active)

    def _tackle(self, rngs: Sequence[np.random.Generator]) -> None:
        """The tackles (:func:`~soccer_drill.rules.cycle.tackle`) where opponents may
        tackle, and the outcome again where one took the ball."""
        cfg, cycle = self.config, self.commands
        for i in np.flatnonzero(cycle["tacklers"]).tolist():
            taken = tackle(cycle["order"][i], int(cycle["tacklers"][i]), rngs[i],
                           cfg.tackle_probability)
            if taken >= 0:
                self.holder[i] = taken
                self.outcome[i] = outcome(self.pos[i], taken, self.cycle[i], cfg.field_size,
                                          cfg.max_cycles, cfg.attackers,
                                          self.params[0]["goal_line"])

    def _rewards(self, active: np.ndarray) -> None:
        """The attackers' reward in the active drills whose episode has ended."""
        cfg, bx = self.config, self.pos[:, -1, 0]
        for i in np.flatnonzero(active & (self.outcome != Outcome.RUNNING)).tolist():
            self.attacker_reward[i] = reward(int(self.outcome[i]), float(bx[i]), cfg)

    # ---------------------------------------------------------------- views
    def state_of(self, i: int) -> DrillState:
        """Drill ``i``'s current :class:`DrillState` (one object until its next cycle or
        reset)."""
        made = self._states.get(i)
        if made is not None and made[0] == self.steps:
            return made[1]
        p = self.pos[i].tolist()
        v = self.vel[i].tolist()
        state = DrillState(
            tuple(map(tuple, p)), tuple(map(tuple, v)), int(self.holder[i]), int(self.cycle[i]),
            int(self.passer[i]), int(self.lockout_until[i]),
        )
        self._states[i] = (self.steps, state)
        return state

    def set_state(self, i: int, state: DrillState) -> None:
        """Put drill ``i`` in ``state`` (tests check the rules from given states); its
        bodies stay where the physics left them."""
        self.pos[i] = state.pos
        self.vel[i] = state.vel
        self.holder[i], self.cycle[i] = state.holder, state.cycle
        self.passer[i], self.lockout_until[i] = state.passer, state.lockout_until
        self.outcome[i] = Outcome.RUNNING
        self.steps += 1


_COMMANDS = ("skill", "target", "speed", "receiver")  # the commands' fields, as arrays
_rows_cache: dict[int, np.ndarray] = {}


def rows(n: int) -> np.ndarray:
    """``np.arange(n)``, made once per ``n`` (read-only)."""
    r = _rows_cache.get(n)
    if r is None:
        r = _rows_cache[n] = np.arange(n)
        r.flags.writeable = False
    return r
