"""The players of many drills in a few pymunk spaces, moved by batched reads and writes.

Each drill's four players and its four walls sit in a space of their own region, the
regions ``spacing`` metres apart so that no two drills' shapes ever meet, and each
space holds up to ``drills_per_space`` drills (``benchmarks/bench_vector.py`` measures
the layouts: one space per 64 drills costs least per drill at every batch size tried).
The ball touches nothing, so it is not a pymunk body: its sub-steps are the same
additions pymunk makes (``p + v * dt``, ``substeps`` times), on arrays.

One cycle is one batched write of every player's position and velocity per space
(``pymunk.batch.set_space_bodies``), ``substeps`` calls of ``Space.step`` per space, and
one batched read back. Writing the positions too lets a drill stand still (a drill
waiting for its holder's decision, or one just reset): it is written where it stood
with no velocity before every cycle, and after it. A space none of whose drills moves
is not stepped at all, and a space all of whose drills start a new episode is built
anew (:meth:`BatchPhysics.renew`), so that with one drill per space a drill's physics
is the single drill's, waits and resets included (see ``HolderVectorEnv``).

The sub-steps call chipmunk's ``cpSpaceStep`` directly when this pymunk has it, as the
single drill does (:func:`~soccer_drill.drill.space_step`); else ``Space.step``.
"""

from __future__ import annotations

import math

import numpy as np
import pymunk
import pymunk.batch as pmb

from soccer_drill.config import DrillConfig, is_integer
from soccer_drill.drill import _PLAYER_MASS, space_step
from soccer_drill.interruptions import CtrlCDeferred

_FIELDS = pmb.BodyFields.POSITION | pmb.BodyFields.VELOCITY
DRILLS_PER_SPACE = 64
"""The default number of drills sharing one pymunk space."""


def check_drills_per_space(drills_per_space: object) -> int:
    """``drills_per_space`` as an int, or ``ValueError`` saying what is allowed."""
    if not is_integer(drills_per_space) or drills_per_space < 1:  # type: ignore[operator]
        raise ValueError(f"drills_per_space must be an integer >= 1, got {drills_per_space!r}")
    return int(drills_per_space)  # type: ignore[call-overload]


class BatchPhysics:
    """The pymunk side of ``n`` drills: players and walls, stepped one cycle at a time.

    Args:
        n: number of drills.
        config: the drills' parameters (one for all).
        drills_per_space: drills sharing one space (the last space may hold fewer).
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
        self._bodies: list[np.ndarray] = [None] * k  # type: ignore[list-item]  # (count, 4, 4) views
        self._steps: list = [None] * k
        self._fresh = np.ones(k, dtype=bool)  # built and not stepped since: nothing to forget
        self._get_buffer = pmb.Buffer()
        self.offsets = np.zeros((self.n, 2))  # (n, 2): where each drill's region starts in its space
        self._offsets = self.offsets[:, None, :]
        for space in range(k):
            self._build_space(space)
        self._out_pos = np.empty((self.n, 4, 2))
        self._out_vel = np.empty((self.n, 4, 2))

    def renew(self, drills: np.ndarray) -> None:
        """New spaces and bodies for the spaces all of whose drills are in ``drills``
        (drills starting a new episode): their contact caches and bias velocities are
        forgotten, as the single drill's ``reset`` forgets its own. A space shared with a
        drill that goes on is kept, and so is one not stepped since it was built (it has
        nothing to forget)."""
        resetting = np.zeros(self.n, dtype=bool)
        resetting[drills] = True
        for k, sl in enumerate(self._slices):
            if not self._fresh[k] and resetting[sl].all():
                self._build_space(k)

    def _build_space(self, k: int) -> None:
        """Space ``k``: its drills' players and walls, each drill in its own region (a
        Ctrl-C meanwhile waits for the end: :class:`~soccer_drill.interruptions.CtrlCDeferred`)."""
        self._fresh[k] = False  # until built: a build cut short is built again
        with CtrlCDeferred():
            self._build_space_now(k)

    def _build_space_now(self, k: int) -> None:
        cfg, sl = self.config, self._slices[k]
        count = sl.stop - sl.start
        cols = max(1, math.ceil(math.sqrt(self.drills_per_space)))
        space = pymunk.Space()
        objects: list = []
        for j in range(count):
            ox, oy = (j % cols) * self.spacing, (j // cols) * self.spacing
            self.offsets[sl.start + j] = (ox, oy)
            for _ in range(4):
                body = pymunk.Body(_PLAYER_MASS, math.inf)
                body.position = (ox, oy)
                objects += [body, pymunk.Circle(body, cfg.player_radius)]
            lo, hi = -cfg.wall_margin, cfg.field_size + cfg.wall_margin
            corners = [(ox + a, oy + b) for a, b in ((lo, lo), (hi, lo), (hi, hi), (lo, hi))]
            for a, b in zip(corners, corners[1:] + corners[:1], strict=True):
                objects.append(pymunk.Segment(space.static_body, a, b, 0.1))
        space.add(*objects)
        space.step(0.0)  # Space.step's checks of the new bodies, once; nothing moves
        self._check_order(space, count)
        array = np.zeros((4 * count + 1, 4))  # x, y, vx, vy per body, then the static body
        self._get_buffer.clear()
        pmb.get_space_bodies(space, _FIELDS, self._get_buffer)
        array[:] = np.frombuffer(self._get_buffer.float_buf(), dtype=np.float64).reshape(-1, 4)
        self.spaces[k] = space
        self._arrays[k] = array
        self._attach(k)
        self._fresh[k] = True

    def _attach(self, k: int) -> None:
        """What space ``k`` is written and stepped through: a batch buffer sharing its
        array's memory (written in place), the players' view of that array, its step."""
        space, array = self.spaces[k], self._arrays[k]
        buffer = pmb.Buffer()
        buffer.set_float_buf(array)
        self._set_buffers[k] = buffer
        self._bodies[k] = array[:-1].reshape(-1, 4, 4)
        self._steps[k] = space_step(space)

    def __getstate__(self) -> dict:
        """Everything but the C handles and the views, which a copy makes anew; pymunk's
        spaces copy themselves, their contacts included."""
        state = self.__dict__.copy()
        for name in ("_set_buffers", "_get_buffer", "_steps", "_bodies", "_offsets"):
            del state[name]
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        k = len(self.spaces)
        self._set_buffers, self._bodies, self._steps = [None] * k, [None] * k, [None] * k
        self._get_buffer = pmb.Buffer()
        self._offsets = self.offsets[:, None, :]
        for space in range(k):
            self._attach(space)

    def _check_order(self, space: pymunk.Space, count: int) -> None:
        """The batched reads list the players first, in the order added (as the drill checks)."""
        buffer = pmb.Buffer()
        pmb.get_space_bodies(space, pmb.BodyFields.BODY_ID, buffer)
        ids = memoryview(buffer.int_buf()).cast("P").tolist()
        bodies = [b.id for b in space.bodies if b.body_type == pymunk.Body.DYNAMIC]
        if ids[: 4 * count] != bodies:
            raise RuntimeError(
                f"pymunk {pymunk.version}'s batch API lists the space's bodies in an "
                "unexpected order; this pymunk version is not supported by soccer_drill"
            )

    def cycle(self, pos: np.ndarray, vel: np.ndarray,
              active: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """One cycle of the players from ``pos``/``vel`` (``(n, 4, 2)``, field coordinates).

        ``active`` (``(n,)`` bool, ``None``: every drill) names the drills that move; a
        space none of whose drills moves is not stepped, so its contacts are kept as they
        were rather than solved again for players standing still (with one drill per
        space, a drill that waits then moves on exactly as if it had not waited).

        Returns the players' positions and velocities after the ``substeps`` steps (arrays
        of this object, overwritten by the next cycle; a space not stepped gives back
        ``pos`` and ``vel``).
        """
        offsets = self._offsets
        sub_dt, substeps = self._sub_dt, self.config.substeps
        out_pos, out_vel = self._out_pos, self._out_vel
        stepped = []
        for k, (sl, bodies, buffer, space, step) in enumerate(zip(
            self._slices, self._bodies, self._set_buffers, self.spaces, self._steps, strict=True
        )):
            if active is not None and not np.count_nonzero(active[sl]):
                out_pos[sl], out_vel[sl] = pos[sl], vel[sl]
                continue
            self._fresh[k] = False
            np.add(pos[sl], offsets[sl], out=bodies[..., 0:2])
            bodies[..., 2:4] = vel[sl]
            pmb.set_space_bodies(space, _FIELDS, buffer)
            stepped.append((sl, space, step))
        for _, _, step in stepped:
            for _ in range(substeps):
                step(sub_dt)
        get, buffer = pmb.get_space_bodies, self._get_buffer
        for sl, space, _ in stepped:
            buffer.clear()
            get(space, _FIELDS, buffer)
            rows = np.frombuffer(buffer.float_buf(), dtype=np.float64)[:-4].reshape(-1, 4, 4)
            np.subtract(rows[..., 0:2], offsets[sl], out=out_pos[sl])
            out_vel[sl] = rows[..., 2:4]
        return out_pos, out_vel
