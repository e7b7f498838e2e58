"""The drill's physics and rules: one call to :meth:`Drill.step` is one cycle.

Players and ball are pymunk bodies. Each cycle every player's :class:`Command`
becomes a desired velocity (acceleration- and speed-capped); the holder keeps
the ball at a control point just ahead of it with a small kick per cycle, or
kicks it away; then the world advances ``substeps`` fixed physics steps. Players
collide with each other and with walls just outside the region; the ball
collides with nothing and rolls with damping, so leaving the region ends the
episode. Possession, tackles and the outcome are decided after the physics.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from typing import Literal

import numpy as np
import pymunk
import pymunk.batch
from pymunk.batch import get_space_bodies

from soccer_drill.config import DrillConfig
from soccer_drill.interruptions import CtrlCDeferred
from soccer_drill.rules.cycle import (
    RUNNING,
    draw_start,
    outcome,
    possession,
    recap,
    reward,
    tackle,
    velocities_into,
)
from soccer_drill.rules.motion import motions_into, roll_table, rule_parameters
from soccer_drill.skills import Command, Skill
from soccer_drill.state import DrillState

Outcome = Literal["success", "interception", "out", "timeout"]
OUTCOMES: tuple[Outcome, ...] = ("success", "interception", "out", "timeout")

_PLAYER_MASS = 75.0
_BALL_MASS, _BALL_RADIUS = 0.45, 0.11
_BALL_MOMENT = pymunk.moment_for_circle(_BALL_MASS, 0.0, _BALL_RADIUS)
_BALL_FILTER = pymunk.ShapeFilter(categories=0, mask=0)  # the ball's shape meets nothing
# pymunk's property setters called directly: the same code as ``body.velocity = v``
# without pymunk's generic ``__setattr__`` wrapper, which costs as much again.
_set_velocity = pymunk.Body.velocity.fset
_set_position = pymunk.Body.position.fset
_set_filter = pymunk.Shape.filter.fset
try:  # chipmunk's own step, behind Space.step
    from pymunk._chipmunk import lib as _chipmunk

    _SPACE_STEP = _chipmunk.cpSpaceStep
except (ImportError, AttributeError):  # pragma: no cover - another pymunk build
    _SPACE_STEP = None
_POSITION_VELOCITY = pymunk.batch.BodyFields.POSITION | pymunk.batch.BodyFields.VELOCITY
_new_state = tuple.__new__  # DrillState's fields in order, without its __new__'s defaults
_PASS = Skill.PASS
_NO_NOISE = np.zeros(2)
_NO_NOISE.flags.writeable = False


class Drill:
    """The 2v2 drill without any API around it: physics, possession and outcome.

    Args:
        config: the drill's parameters.

    After :meth:`reset`, :attr:`state` is the current :class:`DrillState`;
    :attr:`outcome` becomes one of :data:`OUTCOMES` when the episode ends, and
    :attr:`attacker_reward` is then the attackers' reward.
    """

    def __init__(self, config: DrillConfig | None = None) -> None:
        self.config = config or DrillConfig()
        cfg = self.config
        self._dt = cfg.cycle_seconds
        self._sub_dt = cfg.cycle_seconds / cfg.substeps
        self._roll = cfg.ball_damping**cfg.cycle_seconds  # speed kept per cycle
        self._buffer = pymunk.batch.Buffer()  # reused: one batched read per cycle
        self._params, self._table = rule_parameters(cfg), roll_table(cfg)
        # The players' commands as the compiled rules read them, and their motions.
        self._skill = np.zeros(4, dtype=np.int64)
        self._target = np.zeros((4, 2))
        self._speed = np.ones(4)
        self._motions = np.zeros((4, 5))
        # The state as arrays (the rules read them), the velocities set before the physics,
        # and scratch of the possession rule.
        self._pos, self._vel, self._new_vel = np.zeros((5, 2)), np.zeros((5, 2)), np.zeros((5, 2))
        self._arrays_of: DrillState | None = None
        self._order, self._dist = np.zeros(4, dtype=np.int64), np.zeros(4)
        self._accel = cfg.player_acceleration * cfg.cycle_seconds
        self._build_space()
        _check_batch_order(self._space, self._bodies, self._buffer)  # every space alike
        self.state: DrillState
        self.outcome: Outcome | None = None
        self.attacker_reward = 0.0

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        del state["_buffer"], state["_space_step"]  # C handles, not picklable: a copy makes its own
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._buffer = pymunk.batch.Buffer()
        self._space_step = space_step(self._space)

    # ------------------------------------------------------------------ reset
    def _build_space(self) -> None:
        """:meth:`_build_space_now`, a Ctrl-C meanwhile waiting for its end (the old space
        is freed there: :class:`~soccer_drill.interruptions.CtrlCDeferred`)."""
        with CtrlCDeferred():
            self._build_space_now()

    def _build_space_now(self) -> None:
        """A new pymunk space with the four players, the ball and the walls.

        Built anew on every :meth:`reset`: a space keeps contact caches and other
        internal state from earlier episodes that change later collisions, so reusing
        one would make an episode depend on what ran before it, not only on its seed.
        The bodies are new too: a body keeps the bias velocity of the last step's
        contacts (pymunk does not expose it), which would move it in the next episode's
        first step. Everything is added in one call (bodies first, then shapes, in order),
        and shapes keep pymunk's default elasticity and friction (0), which the drill
        wants: setting them costs more than the rest of a shape's creation.
        """
        cfg = self.config
        space = pymunk.Space()
        self._players = [pymunk.Body(_PLAYER_MASS, math.inf) for _ in range(4)]  # no spin
        self._ball = pymunk.Body(_BALL_MASS, _BALL_MOMENT)
        # Players and walls keep pymunk's default filter (every shape meets every other),
        # which gives the drill's collisions: player with player, player with wall (two
        # static walls never meet). Setting a filter costs about 1 us a shape.
        shapes = [pymunk.Circle(body, cfg.player_radius) for body in self._players]
        ball_shape = pymunk.Circle(self._ball, _BALL_RADIUS)
        _set_filter(ball_shape, _BALL_FILTER)  # touches nothing
        shapes.append(ball_shape)
        lo, hi = -cfg.wall_margin, cfg.field_size + cfg.wall_margin
        corners = [(lo, lo), (hi, lo), (hi, hi), (lo, hi)]
        for a, b in zip(corners, corners[1:] + corners[:1], strict=True):
            shapes.append(pymunk.Segment(space.static_body, a, b, 0.1))
        self._bodies = (*self._players, self._ball)
        space.add(*self._bodies, *shapes)
        self._space = space
        self._space_step = space_step(space)

    def reset(self, rng: np.random.Generator) -> DrillState:
        """Place the players with seeded jitter and give the ball to a random attacker.

        The physics space is rebuilt, so the episode depends only on ``rng``'s state.
        """
        cfg = self.config
        self._build_space()
        start, holder = draw_start(rng, cfg)
        pos = tuple(map(tuple, start.tolist()))
        for body, p in zip(self._bodies, pos, strict=True):
            _set_position(body, p)  # new bodies are at rest
        self.outcome = None
        self.attacker_reward = 0.0
        self.state = self._arrays_of = DrillState(pos, ((0.0, 0.0),) * 5, holder, 0)
        self._pos[:], self._vel[:] = self.state.pos, 0.0
        return self.state

    # ------------------------------------------------------------------- step
    def step(self, commands: Sequence[Command], rng: np.random.Generator) -> DrillState:
        """Advance one cycle with one command per player (index order)."""
        if self.outcome is not None:
            raise RuntimeError("the episode has ended; call reset() first")
        if len(commands) != 4:
            raise ValueError(f"Drill.step needs one command per player (4), got {len(commands)}")
        cfg, state = self.config, self.state
        holder, passer, lockout_until = state.holder, state.passer, state.lockout_until
        skill, target, speed = self._skill, self._target, self._speed
        for i, command in enumerate(commands):
            skill[i] = command.skill
            speed[i] = command.speed
            if command.target is not None:  # MOVE_TO's: the others' targets are not read
                target[i] = command.target
        noise = _NO_NOISE
        if holder >= 0 and commands[holder].skill is _PASS:  # the kick's two normals
            noise = rng.normal(size=2)
        if self._arrays_of is not state:  # the state was set from outside
            self._pos[:], self._vel[:] = state.pos, state.vel
        pos, vel, params, motions = self._pos, self._vel, self._params, self._motions
        motions_into(motions, pos, vel, holder, skill, target, speed, noise, params, self._table)
        new_vel = self._new_vel
        kicker = velocities_into(new_vel, pos, vel, holder, motions, self._accel, self._dt,
                                 cfg.ball_offset, self._roll, cfg.ball_max_speed)
        for body, (vx, vy) in zip(self._bodies, new_vel.tolist(), strict=True):
            _set_velocity(body, (vx, vy))
        if kicker >= 0:
            holder, passer, lockout_until = -1, kicker, state.cycle + 1 + cfg.pass_lockout_cycles

        step, sub_dt = self._space_step, self._sub_dt
        for _ in range(cfg.substeps):
            step(sub_dt)

        # One batched read of every body's position and velocity: x, y, vx, vy per body,
        # in the order checked by _check_batch_order (then the space's static body).
        buffer = self._buffer
        buffer.clear()
        get_space_bodies(self._space, _POSITION_VELOCITY, buffer)
        bodies = np.frombuffer(buffer.float_buf(), dtype=np.float64)[:20].reshape(5, 4)
        pos[:] = bodies[:, :2]
        vel[:] = bodies[:, 2:]
        recap(vel, params)  # a collision can push a body past its top speed
        cycle = state.cycle + 1
        holder, tacklers = possession(self._order, self._dist, pos, vel, holder, cycle, passer,
                                      lockout_until, cfg.control_radius, cfg.control_speed)
        if tacklers:
            taken = tackle(self._order, tacklers, rng, cfg.tackle_probability)
            holder = taken if taken >= 0 else holder
        p, v = pos.tolist(), vel.tolist()
        new = _new_state(DrillState, (
            (tuple(p[0]), tuple(p[1]), tuple(p[2]), tuple(p[3]), tuple(p[4])),
            (tuple(v[0]), tuple(v[1]), tuple(v[2]), tuple(v[3]), tuple(v[4])),
            holder, cycle, passer, lockout_until,
        ))
        self.state = self._arrays_of = new
        code = outcome(pos, holder, cycle, cfg.field_size, cfg.max_cycles)
        if code != RUNNING:
            self.outcome = OUTCOMES[code - 1]
            self.attacker_reward = reward(code, p[4][0], cfg)
        return new


def space_step(space: pymunk.Space) -> Callable[[float], object]:
    """``space.step``, or chipmunk's ``cpSpaceStep`` on the space when this pymunk has it:
    ``Space.step`` is that call plus bookkeeping for callbacks and for bodies added or
    removed during a step, none of which the drill uses (the same computation, without
    about a microsecond of Python per sub-step)."""
    if _SPACE_STEP is not None and hasattr(space, "_space"):
        return functools.partial(_SPACE_STEP, space._space)
    return space.step


def _check_batch_order(
    space: pymunk.Space, bodies: tuple[pymunk.Body, ...], buffer: pymunk.batch.Buffer
) -> None:
    """Check that pymunk's batched reads list ``bodies`` first, in their order.

    :meth:`Drill.step` reads every body at once through ``pymunk.batch`` (an API pymunk
    calls experimental) and relies on that order; a pymunk release that changed it would
    otherwise mix the bodies up silently.
    """
    buffer.clear()
    get_space_bodies(space, pymunk.batch.BodyFields.BODY_ID, buffer)
    ids = memoryview(buffer.int_buf()).cast("P").tolist()
    if ids[: len(bodies)] != [body.id for body in bodies]:
        raise RuntimeError(
            f"pymunk {pymunk.version}'s batch API lists the space's bodies in an "
            "unexpected order; this pymunk version is not supported by soccer_drill"
        )
