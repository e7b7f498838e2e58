"""The pymunk side of the drill: the players (and walls) of one drill or of many.

One cycle of the physics takes every body's velocity set by the rules and runs
``substeps`` steps; the players come back as one ``(n, players, 4)`` array (``x, y, vx, vy``
per player, field coordinates). The ball touches nothing, so the rules move it on arrays
(:func:`~soccer_drill.rules.cycle.after_physics`) exactly as pymunk moves a free body.

* :class:`DrillSpace`: one drill in a space of its own, the single environments' physics.
  The ball is a body of the space too (its shape meets nothing): chipmunk's spatial index
  holds every shape, and the order in which it finds contacts, hence the floats of
  simultaneous contacts, depends on all of them; the single drill's episodes are
  recorded with the ball in its space. The players stay where pymunk left them between
  cycles (nothing is written but velocities).
* :class:`BatchPhysics`: the players of ``n`` drills in spaces of up to
  ``drills_per_space`` drills, far apart, written and read through ``pymunk.batch``.

The sub-steps call chipmunk's ``cpSpaceStep`` directly when this pymunk has it
(:func:`space_step`); else ``Space.step``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence

import numpy as np
import pymunk
import pymunk.batch as pmb

from soccer_drill.config import DrillConfig
from soccer_drill.constraints import Integer, checked
from soccer_drill.drill.keeper import keep
from soccer_drill.interruptions import SignalsDeferred

PLAYER_MASS = 75.0
_BALL_MASS, _BALL_RADIUS = 0.45, 0.11
_BALL_MOMENT = pymunk.moment_for_circle(_BALL_MASS, 0.0, _BALL_RADIUS)
_BALL_FILTER = pymunk.ShapeFilter(categories=0, mask=0)  # the ball's shape meets nothing
# pymunk's property setters called directly: the same code as ``body.velocity = v``
# without pymunk's generic ``__setattr__`` wrapper, which costs as much again.
_set_velocity = pymunk.Body.velocity.fset
_set_position = pymunk.Body.position.fset
_set_filter = pymunk.Shape.filter.fset
try:  # chipmunk's own step, behind Space.step, and the C side of pymunk.batch
    from pymunk._chipmunk import ffi as _ffi
    from pymunk._chipmunk import lib as _chipmunk

    _SPACE_STEP = _chipmunk.cpSpaceStep
    _SET_VELOCITY = _chipmunk.cpBodySetVelocity
    _EACH_BODY = _chipmunk.cpSpaceEachBody
    _READ_BODY = _ffi.addressof(_chipmunk, "pmSpaceBodyGetIteratorFuncBatched")
    _WRITE_BODY = _ffi.addressof(_chipmunk, "pmSpaceBodySetIteratorFuncBatched")
    _FLOAT_BYTES = _ffi.sizeof("cpFloat")
except (ImportError, AttributeError):  # pragma: no cover - another pymunk build
    _SPACE_STEP = _SET_VELOCITY = _EACH_BODY = None
_FIELDS = pmb.BodyFields.POSITION | pmb.BodyFields.VELOCITY
_frombuffer = np.frombuffer


class BatchedBodies:
    """Every body of a space read, or written, through one ``pymunk.batch.Buffer``: its
    position and velocity (``x, y, vx, vy`` per body, in the space's order).

    What ``pymunk.batch.get_space_bodies`` and ``set_space_bodies`` do, the same C
    iteration, with its C arguments made once: those functions make them anew at each
    call (a C struct, an enum's value, a function's address), which costs about as much
    as the C call itself. With a pymunk build without these C functions (or its batch
    buffers' C arrays), through ``pymunk.batch``.
    """

    def __init__(self, buffer: pmb.Buffer) -> None:
        self.buffer = buffer
        self._data = self._floats = self._ints = None
        self._read: tuple = (None, 0, None)  # the last read's C array, its length, its view
        if _EACH_BODY is None:  # pragma: no cover - another pymunk build
            return
        try:
            floats, ints = buffer._float_arr, buffer._int_arr
            data = _ffi.new("pmBatchedData *")
            data.fields, data.floatArray, data.intArray = _FIELDS.value, floats, ints
        except (AttributeError, TypeError):  # pragma: no cover - another pymunk build
            return
        self._data, self._floats, self._ints = data, floats, ints

    def read(self, space: pymunk.Space) -> np.ndarray:
        """Every body of ``space``, flat: ``x, y, vx, vy`` each (a view of the buffer,
        overwritten by the next read; the same array as the last read's while the buffer
        keeps its memory and length)."""
        floats = self._floats
        if floats is None:  # pragma: no cover - another pymunk build
            self.buffer.clear()
            pmb.get_space_bodies(space, _FIELDS, self.buffer)
            return _frombuffer(self.buffer.float_buf(), dtype=np.float64)
        floats.num = self._ints.num = 0  # as Buffer.clear
        _EACH_BODY(space._space, _READ_BODY, self._data)
        memory, count, view = self._read
        if floats.num != count or floats.arr != memory:  # grown (moved): viewed anew
            memory, count = floats.arr, floats.num
            view = _frombuffer(_ffi.buffer(memory, _FLOAT_BYTES * count), dtype=np.float64)
            self._read = (memory, count, view)
        return view

    def write(self, space: pymunk.Space) -> None:
        """Every body of ``space`` set from the buffer (its array, ``x, y, vx, vy`` each)."""
        floats = self._floats
        if floats is None:  # pragma: no cover - another pymunk build
            pmb.set_space_bodies(space, _FIELDS, self.buffer)
            return
        count, floats.num = floats.num, 0  # read from the start, as set_space_bodies
        _EACH_BODY(space._space, _WRITE_BODY, self._data)
        floats.num = count
DRILLS_PER_SPACE = 64
"""The default number of drills sharing one pymunk space."""


def space_step(space: pymunk.Space) -> Callable[[float], object]:
    """``space.step``, or chipmunk's ``cpSpaceStep`` on the space when this pymunk has it:
    ``Space.step`` is that call plus bookkeeping for callbacks and for bodies added or
    removed during a step, none of which the drill uses (the same computation, without
    about a microsecond of Python per sub-step)."""
    if _SPACE_STEP is not None and hasattr(space, "_space"):
        return functools.partial(_SPACE_STEP, space._space)
    return space.step


def velocity_setters(bodies: Sequence[pymunk.Body]) -> list[Callable[[Sequence[float]], object]]:
    """For each body, a call setting its velocity to ``(vx, vy)``: chipmunk's
    ``cpBodySetVelocity`` on the body when this pymunk has it (what ``Body.velocity``'s
    setter calls, without its Python), else that setter."""
    if _SET_VELOCITY is not None and all(hasattr(body, "_body") for body in bodies):
        return [functools.partial(_SET_VELOCITY, body._body) for body in bodies]
    return [functools.partial(_set_velocity, body) for body in bodies]  # pragma: no cover


def check_batch_order(space: pymunk.Space, bodies: Sequence[pymunk.Body]) -> None:
    """Check that pymunk's batched reads list ``bodies`` first, in their order.

    Every cycle reads the bodies at once through ``pymunk.batch`` (an API pymunk calls
    experimental) and relies on that order; a pymunk release that changed it would
    otherwise mix the bodies up silently.
    """
    buffer = pmb.Buffer()
    pmb.get_space_bodies(space, pmb.BodyFields.BODY_ID, buffer)
    ids = memoryview(buffer.int_buf()).cast("P").tolist()
    if ids[: len(bodies)] != [body.id for body in bodies]:
        raise RuntimeError(
            f"pymunk {pymunk.version}'s batch API lists the space's bodies in an "
            "unexpected order; this pymunk version is not supported by soccer_drill"
        )


def check_drills_per_space(drills_per_space: object) -> int:
    """``drills_per_space`` as an int, or ``ValueError`` saying what is allowed."""
    return checked("drills_per_space", drills_per_space, Integer(1))


def _walls(space: pymunk.Space, cfg: DrillConfig, ox: float = 0.0, oy: float = 0.0) -> list:
    """The four walls just outside one drill's field, its region starting at ``(ox, oy)``."""
    lo, hi = -cfg.wall_margin, cfg.field_size + cfg.wall_margin
    corners = [(ox + a, oy + b) for a, b in ((lo, lo), (hi, lo), (hi, hi), (lo, hi))]
    return [pymunk.Segment(space.static_body, a, b, 0.1)
            for a, b in zip(corners, corners[1:] + corners[:1], strict=True)]


class DrillSpace:
    """One drill's pymunk space: its players, the ball and the walls.

    Parameters
    ----------
    config
        The drill's parameters.

    :meth:`renew` builds the space anew at every episode's start: a space keeps contact
    caches and other internal state from earlier episodes that change later collisions,
    so reusing one would make an episode depend on what ran before it, not only on its
    seed. The bodies are new too: a body keeps the bias velocity of the last step's
    contacts (pymunk does not expose it), which would move it in the next episode's
    first step. Everything is added in one call (bodies first, then shapes, in order),
    and shapes keep pymunk's default elasticity and friction (0), which the drill wants:
    setting them costs more than the rest of a shape's creation.

    A copy (``copy``, ``pickle``) builds its space as :meth:`renew` built this one and
    replays the velocities of every cycle since: the same calls in a new space, so the
    copy's space is this one's to the last bit, its spatial index included. pymunk's own
    copy of a space holds its bodies, shapes and contacts but builds its spatial index
    anew, from where the shapes stand: simultaneous contacts are then found, hence
    solved, in another order, and the copy's floats part from the original's at the
    first such contact. The record holds the velocities of each cycle of the episode
    (a bytes object of ``16 (players + 1)`` bytes a cycle).
    """

    n = 1

    def __init__(self, config: DrillConfig) -> None:
        self.config = config
        self._sub_dt, self._substeps = config.cycle_seconds / config.substeps, config.substeps
        self._reader = BatchedBodies(pmb.Buffer())  # reused: one batched read per cycle
        self._players: tuple = (None, None)  # the last read, and its players' view
        self.renew(np.zeros(1, dtype=np.int64), np.zeros((1, config.players + 1, 2)))
        check_batch_order(self.space, self._bodies)

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        # C handles, not picklable, and the space, which a copy builds and replays itself
        for name in ("_reader", "_step", "_velocities", "_players", "space", "_bodies"):
            del state[name]
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._reader = BatchedBodies(pmb.Buffer())
        self._players = (None, None)
        start, history = self._start, self._history
        with SignalsDeferred():
            self._renew_now(start[None])
            for velocities in history:  # the cycles since the space was built, again
                self._move(np.frombuffer(velocities).reshape(-1, 2).tolist())
        self._history = history

    def _move(self, velocities: list) -> None:
        """Set the bodies' velocities (``(vx, vy)`` each, players then ball) and run the
        cycle's sub-steps."""
        for set_velocity, v in zip(self._velocities, velocities, strict=True):
            set_velocity(v)
        step, sub_dt = self._step, self._sub_dt
        for _ in range(self._substeps):
            step(sub_dt)

    def renew(self, drills: np.ndarray, pos: np.ndarray) -> None:
        """A new space with the bodies at rest at ``pos[0]`` (the drill's start); a Ctrl-C
        meanwhile waits for its end (the old space is freed there:
        :class:`~soccer_drill.interruptions.SignalsDeferred`)."""
        with SignalsDeferred():
            self._renew_now(pos)

    def _renew_now(self, pos: np.ndarray) -> None:
        cfg = self.config
        space = pymunk.Space()
        players = [pymunk.Body(PLAYER_MASS, math.inf) for _ in range(cfg.players)]  # no spin
        ball = pymunk.Body(_BALL_MASS, _BALL_MOMENT)
        # Players and walls keep pymunk's default filter (every shape meets every other),
        # which gives the drill's collisions: player with player, player with wall (two
        # static walls never meet). Setting a filter costs about 1 us a shape.
        shapes = [pymunk.Circle(body, cfg.player_radius) for body in players]
        ball_shape = pymunk.Circle(ball, _BALL_RADIUS)
        _set_filter(ball_shape, _BALL_FILTER)  # touches nothing
        shapes.append(ball_shape)
        self._bodies = (*players, ball)
        space.add(*self._bodies, *shapes, *_walls(space, cfg))
        # Placed once in the space (as the recorded episodes were): the spatial index is
        # built from where the shapes stood when added.
        for body, p in zip(self._bodies, map(tuple, pos[0].tolist()), strict=True):
            _set_position(body, p)
        self.space = space
        self._step = space_step(space)
        self._velocities = velocity_setters(self._bodies)
        self._start = np.array(pos[0], dtype=np.float64)  # what a copy builds and replays
        self._history: list[bytes] = []  # each stepped cycle's float64 velocities
        keep(self, 0, space)  # the space replaced is freed here

    def cycle(self, pos: np.ndarray, vel: np.ndarray, active: np.ndarray | None) -> np.ndarray:
        """One cycle with the bodies' velocities ``vel[0]`` (``(1, players + 1, 2)``; the
        ball's too, so that it moves in the space as on the arrays). The players start where
        the last cycle left them (``pos`` is not read); with ``active`` false they stand
        still (the space is not stepped). Returns the players, ``(1, players, 4)``."""
        if active is None or active[0]:
            self._history.append(vel[0].tobytes())  # replayed by a copy
            self._move(vel[0].tolist())
        # One batched read of every body: x, y, vx, vy each, the players first
        # (check_batch_order), then the ball and the space's static body. The same array
        # every cycle while the read's is (the rules after the physics are bound to it).
        read = self._reader.read(self.space)
        last, players = self._players
        if read is not last:
            count = len(self._bodies) - 1
            players = read[:4 * count].reshape(1, count, 4)
            self._players = (read, players)
        return players


class BatchPhysics:
    """The players of ``n`` drills in shared pymunk spaces, moved by batched writes and reads.

    Parameters
    ----------
    n
        Number of drills.
    config
        The drills' parameters (one for all).
    drills_per_space
        Drills sharing one space (the last space may hold fewer).

    Each drill's players and its four walls sit in a region of their own, the
    regions :attr:`spacing` metres apart so that no two drills' shapes ever meet
    (``benchmarks/bench_vector.py`` measures the layouts: one space per 64 drills costs
    least per drill at every batch size tried). The ball is not a body here.

    One cycle is one batched write of every player's position and velocity per space
    (``pymunk.batch.set_space_bodies``), the sub-steps of each space, and one batched
    read back. Writing the positions too lets a drill stand still (a drill waiting for
    its holder's decision, or one just reset): it is written where it stood with no
    velocity before every cycle, and after it. A space none of whose drills moves is not
    stepped at all, and a space all of whose drills start a new episode is built anew
    (:meth:`renew`), so that with one drill per space a drill's physics depends on its
    own episode alone, waits and resets included.
    """

    def __init__(self, n: int, config: DrillConfig, drills_per_space: int = DRILLS_PER_SPACE) -> None:
        self.n, self.config = n, config
        self.drills_per_space = check_drills_per_space(drills_per_space)
        self._sub_dt = config.cycle_seconds / config.substeps
        span = config.field_size + 2 * config.wall_margin
        self.spacing = span + 4 * config.field_size  # far beyond any reach of a player
        self.build()

    def build(self) -> None:
        """New spaces and bodies (every contact cache and bias velocity forgotten)."""
        g = self.drills_per_space
        self._slices = [slice(first, min(first + g, self.n)) for first in range(0, self.n, g)]
        k = len(self._slices)
        self.spaces: list[pymunk.Space] = [None] * k  # type: ignore[list-item]
        self._arrays: list[np.ndarray] = [None] * k  # type: ignore[list-item]
        self._set_buffers: list[pmb.Buffer] = [None] * k  # type: ignore[list-item]
        self._bodies: list[np.ndarray] = [None] * k  # type: ignore[list-item]  # (count, players, 4) views
        self._steps: list = [None] * k
        self._fresh = np.ones(k, dtype=bool)  # built and not stepped since: nothing to forget
        self._reader = BatchedBodies(pmb.Buffer())
        self.offsets = np.zeros((self.n, 2))  # (n, 2): where each drill's region starts in its space
        self._offsets = self.offsets[:, None, :]
        for space in range(k):
            self._build_space(space)
        self._out = np.zeros((self.n, self.config.players, 4))

    def renew(self, drills: np.ndarray, pos: np.ndarray | None = None) -> None:
        """New spaces and bodies for the spaces all of whose drills are in ``drills``
        (drills starting a new episode): their contact caches and bias velocities are
        forgotten, as :class:`DrillSpace` forgets its own. A space shared with a drill
        that goes on is kept, and so is one not stepped since it was built (it has
        nothing to forget). The players are written where ``pos`` says at the next cycle."""
        resetting = np.zeros(self.n, dtype=bool)
        resetting[drills] = True
        for k, sl in enumerate(self._slices):
            if not self._fresh[k] and resetting[sl].all():
                self._build_space(k)

    def _build_space(self, k: int) -> None:
        """Space ``k``: its drills' players and walls, each drill in its own region (a
        Ctrl-C meanwhile waits for the end: :class:`~soccer_drill.interruptions.SignalsDeferred`)."""
        self._fresh[k] = False  # until built: a build cut short is built again
        with SignalsDeferred():
            self._build_space_now(k)

    def _build_space_now(self, k: int) -> None:
        cfg, sl = self.config, self._slices[k]
        count = sl.stop - sl.start
        cols = max(1, math.ceil(math.sqrt(self.drills_per_space)))
        space = pymunk.Space()
        objects: list = []
        bodies: list[pymunk.Body] = []
        for j in range(count):
            ox, oy = (j % cols) * self.spacing, (j // cols) * self.spacing
            self.offsets[sl.start + j] = (ox, oy)
            for _ in range(cfg.players):
                body = pymunk.Body(PLAYER_MASS, math.inf)
                body.position = (ox, oy)
                bodies.append(body)
                objects += [body, pymunk.Circle(body, cfg.player_radius)]
            objects += _walls(space, cfg, ox, oy)
        space.add(*objects)
        space.step(0.0)  # Space.step's checks of the new bodies, once; nothing moves
        check_batch_order(space, bodies)
        array = np.zeros((cfg.players * count + 1, 4))  # x, y, vx, vy per body, then the static body
        array[:] = self._reader.read(space).reshape(-1, 4)
        self.spaces[k] = space
        self._arrays[k] = array
        self._attach(k)
        keep(self, k, space)  # the space replaced is freed here
        self._fresh[k] = True

    def _attach(self, k: int) -> None:
        """What space ``k`` is written and stepped through: a batch buffer sharing its
        array's memory (written in place), the players' view of that array, its step."""
        space, array = self.spaces[k], self._arrays[k]
        buffer = pmb.Buffer()
        buffer.set_float_buf(array)
        self._set_buffers[k] = BatchedBodies(buffer)
        self._bodies[k] = array[:-1].reshape(-1, self.config.players, 4)
        self._steps[k] = space_step(space)

    def __getstate__(self) -> dict:
        """Everything but the C handles and the views, which a copy makes anew; pymunk's
        spaces copy themselves, their contacts included but not their spatial index,
        which the copy builds anew (contacts met at once may then be solved in another
        order: ``HolderVectorEnv``'s Copies)."""
        state = self.__dict__.copy()
        for name in ("_set_buffers", "_reader", "_steps", "_bodies", "_offsets"):
            del state[name]
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        k = len(self.spaces)
        self._set_buffers, self._bodies, self._steps = [None] * k, [None] * k, [None] * k
        self._reader = BatchedBodies(pmb.Buffer())
        self._offsets = self.offsets[:, None, :]
        with SignalsDeferred():
            for space in range(k):
                self._attach(space)
                keep(self, space, self.spaces[space])

    def cycle(self, pos: np.ndarray, vel: np.ndarray, active: np.ndarray | None) -> np.ndarray:
        """One cycle of the players from ``pos``/``vel`` (``(n, players + 1, 2)``, field
        coordinates; the ball's row is not read).

        ``active`` (``(n,)`` bool, ``None``: every drill) names the drills that move; a
        space none of whose drills moves is not stepped, so its contacts are kept as they
        were rather than solved again for players standing still (with one drill per
        space, a drill that waits then moves on exactly as if it had not waited).

        Returns the players after the sub-steps, ``(n, players, 4)`` (an array of this object,
        overwritten by the next cycle; the rows of drills in spaces not stepped are stale).
        """
        offsets, out = self._offsets, self._out
        sub_dt, substeps = self._sub_dt, self.config.substeps
        stepped = []
        for k, (sl, bodies, writer, space, step) in enumerate(zip(
            self._slices, self._bodies, self._set_buffers, self.spaces, self._steps, strict=True
        )):
            if active is not None and not np.count_nonzero(active[sl]):
                continue
            self._fresh[k] = False
            np.add(pos[sl, :-1], offsets[sl], out=bodies[..., 0:2])
            bodies[..., 2:4] = vel[sl, :-1]
            writer.write(space)
            stepped.append((sl, space, step))
        for _, _, step in stepped:
            for _ in range(substeps):
                step(sub_dt)
        read = self._reader.read
        for sl, space, _ in stepped:
            rows = read(space)[:-4].reshape(-1, self.config.players, 4)
            np.subtract(rows[..., 0:2], offsets[sl], out=out[sl, :, 0:2])
            out[sl, :, 2:4] = rows[..., 2:4]
        return out
