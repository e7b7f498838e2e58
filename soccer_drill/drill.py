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

import math
from collections.abc import Sequence
from typing import Literal

import numpy as np
import pymunk
import pymunk.batch
from pymunk.batch import get_space_bodies

from soccer_drill.config import DrillConfig
from soccer_drill.motion import CONTROL, KICK, NO_BALL, motions_into, roll_table, rule_parameters
from soccer_drill.skills import Command, Skill
from soccer_drill.state import BALL, DrillState

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
        self._top_speed = (
            cfg.attacker_speed, cfg.attacker_speed, cfg.defender_speed, cfg.defender_speed,
        )
        self._caps = (*self._top_speed, cfg.ball_max_speed)
        self._caps2 = tuple(cap * cap for cap in self._caps)
        self._buffer = pymunk.batch.Buffer()  # reused: one batched read per cycle
        self._params, self._table = rule_parameters(cfg), roll_table(cfg)
        # The players' commands as the compiled rules read them, and their motions.
        self._skill = np.zeros(4, dtype=np.int64)
        self._target = np.zeros((4, 2))
        self._speed = np.ones(4)
        self._motions = np.zeros((4, 5))
        self._build_space()
        _check_batch_order(self._space, self._bodies, self._buffer)  # every space alike
        self.state: DrillState
        self.outcome: Outcome | None = None
        self.attacker_reward = 0.0

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        del state["_buffer"]  # C memory, not picklable; a copy gets its own
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._buffer = pymunk.batch.Buffer()

    # ------------------------------------------------------------------ reset
    def _build_space(self) -> None:
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

    def reset(self, rng: np.random.Generator) -> DrillState:
        """Place the players with seeded jitter and give the ball to a random attacker.

        The physics space is rebuilt, so the episode depends only on ``rng``'s state.
        """
        cfg = self.config
        self._build_space()
        starts = (*cfg.attacker_starts, *cfg.defender_starts)
        jitter = rng.uniform(-cfg.start_jitter, cfg.start_jitter, size=(4, 2))
        pos = []
        for body, (x, y), (jx, jy) in zip(self._players, starts, jitter, strict=True):
            p = (float(x + jx), float(y + jy))
            _set_position(body, p)  # new bodies are at rest
            pos.append(p)
        holder = int(rng.integers(2))
        ball = (pos[holder][0], pos[holder][1] - cfg.ball_offset)
        _set_position(self._ball, ball)
        pos.append(ball)
        self.outcome = None
        self.attacker_reward = 0.0
        self.state = DrillState(tuple(pos), ((0.0, 0.0),) * 5, holder, 0)
        return self.state

    # ------------------------------------------------------------------- step
    def step(self, commands: Sequence[Command], rng: np.random.Generator) -> DrillState:
        """Advance one cycle with one command per player (index order)."""
        if self.outcome is not None:
            raise RuntimeError("the episode has ended; call reset() first")
        cfg, state, dt = self.config, self.state, self._dt
        holder, passer, lockout_until = state.holder, state.passer, state.lockout_until
        ball_velocity: tuple[float, float] | None = None
        accel = cfg.player_acceleration * dt
        if len(commands) != 4:
            raise ValueError(f"Drill.step needs one command per player (4), got {len(commands)}")
        skill, target, speed = self._skill, self._target, self._speed
        for i, command in enumerate(commands):
            skill[i] = command.skill
            speed[i] = command.speed
            if command.target is not None:  # MOVE_TO's: the others' targets are not read
                target[i] = command.target
        noise = _NO_NOISE
        if holder >= 0 and commands[holder].skill is _PASS:  # the kick's two normals
            noise = rng.normal(size=2)
        motions_into(self._motions, np.array(state.pos), np.array(state.vel), holder, skill,
                     target, speed, noise, self._params, self._table)
        set_velocity, hypot, old_vel = _set_velocity, math.hypot, state.vel
        for i, (body, (mvx, mvy, ball_action, mbx, mby)) in enumerate(
            zip(self._players, self._motions.tolist(), strict=True)
        ):
            vx0, vy0 = old_vel[i]
            dvx, dvy = mvx - vx0, mvy - vy0
            dv = hypot(dvx, dvy)
            if dv > accel:
                dvx, dvy = dvx * accel / dv, dvy * accel / dv
            vx, vy = vx0 + dvx, vy0 + dvy
            set_velocity(body, (vx, vy))
            if ball_action == NO_BALL or i != holder:  # only the ball skills move the ball
                continue
            if ball_action == KICK:
                ball_velocity = (mbx, mby)
                holder, passer, lockout_until = -1, i, state.cycle + 1 + cfg.pass_lockout_cycles
            elif ball_action == CONTROL:
                # A small kick that puts the ball at the control point after this cycle,
                # turning it round the player by at most _MAX_TURN so it stays controlled.
                px, py = state.pos[i]
                bx, by = state.pos[BALL]
                ux, uy = _turn_toward(bx - px, by - py, mbx, mby)
                cx = px + vx * dt + ux * cfg.ball_offset
                cy = py + vy * dt + uy * cfg.ball_offset
                ball_velocity = ((cx - bx) / dt, (cy - by) / dt)
        if ball_velocity is None:  # rolling freely
            bvx, bvy = state.vel[BALL]
            ball_velocity = (bvx * self._roll, bvy * self._roll)
        set_velocity(self._ball, _capped(ball_velocity, cfg.ball_max_speed))

        step, sub_dt = self._space.step, self._sub_dt
        for _ in range(cfg.substeps):
            step(sub_dt)

        # One batched read of every body's position and velocity: x, y, vx, vy per body,
        # in the order checked by _check_batch_order (then the space's static body).
        buffer = self._buffer
        buffer.clear()
        get_space_bodies(self._space, _POSITION_VELOCITY, buffer)
        (x0, y0, vx0, vy0, x1, y1, vx1, vy1, x2, y2, vx2, vy2, x3, y3, vx3, vy3,
         x4, y4, vx4, vy4, *_) = memoryview(buffer.float_buf()).cast("d").tolist()
        # A collision can push a body past its speed cap: capped, and set back on it.
        c0, c1, c2, c3, c4 = self._caps2
        if vx0 * vx0 + vy0 * vy0 > c0:
            vx0, vy0 = self._recap(0, vx0, vy0)
        if vx1 * vx1 + vy1 * vy1 > c1:
            vx1, vy1 = self._recap(1, vx1, vy1)
        if vx2 * vx2 + vy2 * vy2 > c2:
            vx2, vy2 = self._recap(2, vx2, vy2)
        if vx3 * vx3 + vy3 * vy3 > c3:
            vx3, vy3 = self._recap(3, vx3, vy3)
        if vx4 * vx4 + vy4 * vy4 > c4:
            vx4, vy4 = self._recap(4, vx4, vy4)
        positions = ((x0, y0), (x1, y1), (x2, y2), (x3, y3), (x4, y4))
        velocities = ((vx0, vy0), (vx1, vy1), (vx2, vy2), (vx3, vy3), (vx4, vy4))
        cycle = state.cycle + 1
        holder = self._holder_after(positions, velocities, holder, cycle, passer, lockout_until, rng)
        new = _new_state(DrillState, (positions, velocities, holder, cycle, passer, lockout_until))
        self.state = new
        self._judge(new)
        return new

    def _recap(self, body: int, vx: float, vy: float) -> tuple[float, float]:
        """Body ``body``'s velocity capped at its top speed, and set on it."""
        v = _capped((vx, vy), self._caps[body])
        _set_velocity(self._bodies[body], v)
        return v

    def _holder_after(
        self,
        pos: tuple[tuple[float, float], ...],
        vel: tuple[tuple[float, float], ...],
        holder: int,
        cycle: int,
        passer: int,
        lockout_until: int,
        rng: np.random.Generator,
    ) -> int:
        """Who holds the ball after this cycle's physics (at most one player).

        ``holder`` is who held it before; the other arguments are the new state's.
        """
        cfg = self.config
        bx, by = pos[BALL]
        bvx, bvy = vel[BALL]
        radius, speed, hypot = cfg.control_radius, cfg.control_speed, math.hypot
        locked_out = passer if cycle < lockout_until else -1
        in_control = []
        for i in range(4):
            px, py = pos[i]
            dist = hypot(px - bx, py - by)
            if dist <= radius and i != locked_out:
                vx, vy = vel[i]
                if hypot(bvx - vx, bvy - vy) <= speed:
                    in_control.append((dist, i))
        in_control.sort()
        if holder >= 0:
            for _, i in in_control:
                if i == holder:
                    break
            else:
                holder = -1  # the holder lost touch with the ball
        if holder >= 0:
            for _, i in in_control:
                if (i >= 2) != (holder >= 2) and rng.random() < cfg.tackle_probability:
                    return i  # a tackle
            return holder
        return in_control[0][1] if in_control else -1

    def _judge(self, s: DrillState) -> None:
        cfg = self.config
        bx, by = s.pos[BALL]
        if s.holder >= 2:
            self.outcome, self.attacker_reward = "interception", cfg.reward_failure
        elif s.holder >= 0 and by <= 0.0 and 0.0 <= bx <= cfg.field_size:
            self.outcome, self.attacker_reward = "success", cfg.success_reward(bx)
        elif not (0.0 <= bx <= cfg.field_size and 0.0 <= by <= cfg.field_size):
            self.outcome, self.attacker_reward = "out", cfg.reward_failure
        elif s.cycle >= cfg.max_cycles:
            self.outcome, self.attacker_reward = "timeout", cfg.reward_timeout


_MAX_TURN = math.radians(40.0)  # the ball's turn round its holder per cycle


def _turn_toward(fx: float, fy: float, tx: float, ty: float) -> tuple[float, float]:
    """Unit vector from direction f toward direction t, rotated by at most _MAX_TURN."""
    a = math.atan2(fy, fx) if (fx or fy) else math.atan2(ty, tx)
    b = math.atan2(ty, tx)
    delta = (b - a + math.pi) % (2 * math.pi) - math.pi
    a += max(-_MAX_TURN, min(_MAX_TURN, delta))
    return math.cos(a), math.sin(a)


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


def _capped(v: tuple[float, float], cap: float) -> tuple[float, float]:
    speed = math.hypot(v[0], v[1])
    if speed <= cap:
        return v
    return v[0] * cap / speed, v[1] * cap / speed
