"""What the batched environments share: the drills, their seed streams, team and support."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any, TypeVar

import numpy as np

from soccer_drill.config import DrillConfig
from soccer_drill.constraints import Integer, checked, is_int
from soccer_drill.drill import BatchDrill
from soccer_drill.rendering.batch import frame_bytes
from soccer_drill.rules.cycle import RUNNING
from soccer_drill.rules.support import OFFSET_STD, RESAMPLE_CYCLES, support_commands_of_drills
from soccer_drill.teams import Team, check_team_timeout
from soccer_drill.teams.batch import BatchRandom, BatchTeamDriver

_T = TypeVar("_T")

DRILL_BYTES = 32 * 1024
"""An upper estimate of one drill's memory in a batch (measured at 13-23 KiB a drill from
64 drills on, 42 KiB in the first small batch of a process: docs/benchmarks.md)."""


def available_memory() -> int | None:
    """Bytes this process can still take: the smaller of the system's available memory
    and what its cgroup's limit leaves (``None`` where neither can be read)."""
    found = []
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    found.append(int(line.split()[1]) * 1024)
    except (OSError, ValueError, IndexError):
        pass
    try:
        with open("/sys/fs/cgroup/memory.max") as limit, \
                open("/sys/fs/cgroup/memory.current") as current:
            text = limit.read().strip()
            if text != "max":
                found.append(max(0, int(text) - int(current.read().strip())))
    except (OSError, ValueError):
        pass
    return min(found) if found else None


def check_num_envs(num_envs: object) -> int:
    """``num_envs`` as an int, or ``ValueError`` saying what is allowed: an integer in
    [1, 1,000,000] whose drills fit in the memory available (at :data:`DRILL_BYTES` a drill;
    beyond it the process is killed, or crashes inside pymunk, while it builds them)."""
    n = checked("num_envs", num_envs, Integer(1, 1_000_000))
    available = available_memory()
    if available is not None and n * DRILL_BYTES > available:
        raise ValueError(
            f"num_envs={n} needs about {n * DRILL_BYTES / 2**20:,.0f} MiB (up to "
            f"{DRILL_BYTES // 1024} KiB a drill), more than the {available / 2**20:,.0f} MiB "
            f"of memory available; at most {available // DRILL_BYTES:,} drills fit now"
        )
    return n


def check_frames_fit(n: int, config: DrillConfig) -> None:
    """``ValueError`` if ``n`` drills and their frames do not fit in the memory available
    (:func:`available_memory`): ``render()`` returns ``n`` frames at once, and draws each
    through one more (so ``n + 1``), besides the drills themselves (:data:`DRILL_BYTES`
    each). Nothing is checked where the memory available cannot be read (imports pygame,
    for the frames' size)."""
    available = available_memory()
    if available is None:
        return
    each, (width, height) = frame_bytes(config)
    drill = DRILL_BYTES
    needed = n * drill + (n + 1) * each
    if needed > available:
        fit = max(0, (available - each) // (drill + each))
        raise ValueError(
            f"num_envs={n} with render_mode='rgb_array' needs about {needed / 2**20:,.0f} MiB: "
            f"{n} drills (up to {drill // 1024} KiB each) and their frames ({n + 1} of {width} "
            f"x {height} pixels, {each / 2**20:.2f} MiB each, render() returns them together), "
            f"more than the {available / 2**20:,.0f} MiB of memory available; at most {fit:,} "
            "drills fit now with their frames (or draw fewer: a HolderEnv draws one drill, "
            "also as a video)"
        )


def check_frames_memory(n: int, config: DrillConfig) -> None:
    """``RuntimeError`` if ``render()``'s ``n`` frames (returned at once, and one more while
    drawing) do not fit in the memory available now: the check that
    :class:`~soccer_drill.rendering.batch.BatchRenderer` makes before it draws."""
    available = available_memory()
    if available is not None:
        each, (width, height) = frame_bytes(config)
        if (n + 1) * each > available:
            raise RuntimeError(
                f"render() of {n} drills needs about {(n + 1) * each / 2**20:,.1f} MiB for "
                f"their frames ({n + 1} of {width} x {height} pixels, {each / 2**20:.2f} MiB "
                f"each), more than the {available / 2**20:,.1f} MiB of memory available "
                f"now; at most {max(0, available // each - 1):,} frames fit"
            )


def check_seed(seed: object, n: int) -> list[int | None] | None:
    """A batched ``reset``'s ``seed`` as one seed (``None``: keep the stream) per drill.

    ``None`` stays ``None``; an integer ``s`` gives drill ``i`` the seed ``s + i``; a
    sequence must hold exactly ``n`` entries, each ``None`` or an integer. Integers are
    Python or NumPy ones (not bools), ``>= 0``. Anything else: ``ValueError`` saying what
    was given and what is allowed, before any drill is touched.
    """
    if seed is None:
        return None
    allowed = (
        f"seed must be None, an integer >= 0 (drill i gets seed + i) or a sequence of {n} "
        "seeds, one per drill, each None or an integer >= 0"
    )
    if is_int(seed):
        if seed < 0:
            raise ValueError(f"{allowed}; got {seed!r}")
        return [int(seed) + i for i in range(n)]
    if isinstance(seed, np.ndarray) and seed.ndim != 1:
        raise ValueError(f"{allowed}; got an array of shape {seed.shape}")
    if isinstance(seed, str | bytes) or not isinstance(seed, Sequence | np.ndarray):
        raise ValueError(f"{allowed}; got {seed!r} of type {type(seed).__name__}")
    seeds = list(seed)
    if len(seeds) != n:
        raise ValueError(f"{allowed}; got a sequence of {len(seeds)}")
    for i, s in enumerate(seeds):
        if s is not None and not (is_int(s) and s >= 0):
            raise ValueError(f"{allowed}; got seed[{i}] = {s!r} of type {type(s).__name__}")
    return [None if s is None else int(s) for s in seeds]


class BatchCore:
    """``n`` drills with their generators, scripted team and support players.

    Parameters
    ----------
    n
        Number of drills.
    opponent
        Team id, ``Team`` instance, or ``None`` (no scripted team).
    opponent_params
        Keyword parameters of the team factory.
    config
        The drills' parameters.
    team_timeout
        CPU-time bound of one batched team call, or of each drill's copy's
        (``None``: no bound).
    support
        The attackers not given a command are driven by the support behaviour.
    drills_per_space
        Drills sharing one pymunk space.

    Seeding: drill ``i`` has its own generator, the stream that a single environment's
    ``reset(seed=s_i)`` starts (``np.random.default_rng(s_i)``); at each of its episode's
    starts it draws the start as :meth:`Drill.reset` does, then the seeds of its support
    player's and its team's own generators, as :class:`~soccer_drill.envs.core.DrillCore` does.
    """

    def __init__(
        self,
        n: int,
        opponent: str | Team | None,
        opponent_params: Mapping[str, Any] | None,
        config: DrillConfig,
        team_timeout: float | None,
        support: bool,
        drills_per_space: int,
    ) -> None:
        team_timeout = check_team_timeout(team_timeout)
        self.n, self.config = n, config
        self.batch = BatchDrill(n, config, drills_per_space)
        self.generators = [np.random.default_rng(s) for s in np.random.SeedSequence().spawn(n)]
        if opponent is None:
            if opponent_params:
                raise ValueError("opponent_params given but opponent is None")
            self.team = None
        else:
            self.team = BatchTeamDriver(opponent, opponent_params, self.batch, team_timeout)
        self.support = support
        self.support_rng = BatchRandom(n, normal=True)
        self.support_offset = np.zeros((n, 2))
        self.skill = np.zeros((n, 4), dtype=np.int64)
        self.target = np.zeros((n, 4, 2))
        self.speed = np.ones((n, 4))
        self.interrupted: str | None = None
        """The call of the environment that stopped part-way (see :meth:`changing`), until
        every drill is reset."""
        self.attack: Any = None
        """A scripted attack driving both attackers (:mod:`soccer_drill.vector.attack`),
        set by the environment that plays one; seeded with the team's seeds (no team then)."""

    def changing(self, call: str, work: Callable[[], _T], every_drill: bool = False) -> _T:
        """``work()``, a call of the environment that changes its drills (``call`` names
        it in errors), made all or nothing as far as the caller can tell.

        Every check of the call's arguments comes before it, so that a refused call
        changes nothing. If ``work`` stops part-way -- a Ctrl-C, a team's error, anything
        raised -- drills may be part-way through a cycle or a reset (a cycle is not undone:
        it would mean copying every drill's physics and generators before each one), so
        :attr:`interrupted` stays set and :meth:`check_usable` refuses every later step
        until a reset of every drill (``every_drill``) has ended. A reset of some drills
        keeps an earlier interruption. The flag is set before ``work`` starts and cleared
        after its result is complete, so an interruption at any point in between is seen.
        """
        before = self.interrupted
        self.interrupted = call if every_drill or before is None else before
        try:
            out = work()
        except BaseException as exc:
            if every_drill or before is None:
                self.interrupted = f"{call} (stopped by {type(exc).__name__})"
            raise
        self.interrupted = None if every_drill else before
        return out

    def check_usable(self) -> None:
        """The team's error (:meth:`check_team`), or ``RuntimeError`` if a call stopped
        part-way (:meth:`changing`) and the drills were not all reset since."""
        self.check_team()
        if self.interrupted is not None:
            raise RuntimeError(
                f"{self.interrupted} stopped part-way, which may leave drills part-way "
                "through a cycle or a reset; call reset() (of every drill: no reset_mask) to "
                "start every drill again"
            )

    def seed(self, seeds: list[int | None] | None) -> None:
        """Reseed the drills: ``seeds`` is :func:`check_seed`'s, one seed (or ``None``:
        keep) per drill; ``None`` keeps every stream."""
        if seeds is None:
            return
        for i, s in enumerate(seeds):
            if s is not None:
                self.generators[i] = np.random.default_rng(s)
        # The physics is fresh after the reset of every drill that follows (each space
        # built anew, BatchDrill.reset): the run then depends on the seeds alone.

    def reset(self, drills: np.ndarray) -> None:
        """Start a new episode in each of ``drills``."""
        if not len(drills):
            return
        gens = [self.generators[i] for i in drills.tolist()]
        self.batch.reset(drills, gens)
        # The seeds of the support player's and the team's generators, as DrillCore draws them.
        support_seeds, team_seeds = zip(*(g.integers(2**63, size=2).tolist() for g in gens), strict=True)
        if self.support:
            self.support_rng.seed(drills, list(support_seeds))
            self.support_offset[drills] = 0.0
        if self.team is not None:
            self.team.reset(drills, list(team_seeds))
        if self.attack is not None:
            self.attack.reset(drills, list(team_seeds))

    def support_commands(self, supporting: np.ndarray) -> None:
        """The support behaviour's commands for attacker ``k`` in the drills where
        ``supporting[:, k]`` (``(n, 2)`` bool; attacker 0 first, as the single drill asks,
        since both draw from the drill's one support generator)."""
        b = self.batch
        resample = b.cycle % RESAMPLE_CYCLES == 0
        # The offsets each attacker's spot uses: attacker 0's after its draws, attacker
        # 1's after its own (drawn after attacker 0's, from the same generator).
        offsets = np.empty((self.n, 2, 2))
        for k in (0, 1):
            draw = np.nonzero(supporting[:, k] & resample)[0]
            if len(draw):
                dx = self.support_rng.random(draw)
                dy = self.support_rng.random(draw)
                self.support_offset[draw, 0] = OFFSET_STD * dx
                self.support_offset[draw, 1] = OFFSET_STD * dy
            offsets[:, k] = self.support_offset
        support_commands_of_drills(self.skill, self.target, self.speed, supporting, b.pos,
                                   b.holder, b.cycle, b.passer, b.lockout_until, offsets,
                                   self.config.field_size)

    def check_team(self) -> None:
        """:class:`~soccer_drill.teams.TeamError` if the team failed and the drills were
        not all reset since (see :class:`~soccer_drill.teams.batch.BatchTeamDriver`)."""
        if self.team is not None:
            self.team.check_usable()

    def advance(self, active: np.ndarray) -> None:
        """One cycle of the drills where ``active``, with the commands set in the arrays
        (the team's written here)."""
        drills = np.nonzero(active)[0]
        if self.team is not None:
            self.team.act(drills, self.skill, self.target, self.speed)
        b, attack = self.batch, self.attack
        if attack is not None:
            supporting = np.zeros((self.n, 2), dtype=bool)
            attack.before_cycle(b.pos, b.holder, active, self.skill, self.speed, supporting)
            self.support_commands(supporting)
        self.batch.step(active, self.skill, self.target, self.speed, self.generators)
        if attack is not None:
            attack.after_cycle(b.holder, b.outcome != RUNNING, active)

    @property
    def ended(self) -> np.ndarray:
        """``(n,)`` bool: the drills whose episode has an outcome."""
        return self.batch.outcome != RUNNING
