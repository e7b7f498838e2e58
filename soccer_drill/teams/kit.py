"""What a team is given and returns for many drills at once: the batched team protocol.

A team plays one drill or many through the same code: the drill asks it for its batched
form, ``team.batch(n)``, an object with

| method | does |
|---|---|
| ``reset(view, drills, rng)`` | start an episode in each of ``drills`` (an int array); ``rng`` is a :class:`BatchRandom` drawing from each drill's own generator |
| ``act(view, drills)`` | a :class:`BatchCommands` with one row per drill of ``drills``, in that order: the commands of the team's two players |

``view`` is a :class:`BatchView` (read-only copies of every drill's arrays, the rule
parameters by name, and a :class:`~soccer_drill.state.DrillView` of each drill). The
single environment is a batch of one drill (``n = 1``). A team without ``batch`` (only
``reset(view, rng)`` and ``act(view)`` of one drill) runs as one copy per drill
(:class:`~soccer_drill.teams.driver.TeamDriver`), each copy's commands checked and its
time bounded as a batched team's.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple, Protocol, runtime_checkable

import numpy as np

from soccer_drill.commands import Command, Skill
from soccer_drill.config import DrillConfig
from soccer_drill.drill.drills import rows
from soccer_drill.state import DrillState, DrillView, ReadOnlyView


class BatchCommands(NamedTuple):
    """The commands of a team's ``d`` players (``view.players``: two in the 2v2 drill) in
    ``m`` drills.

    Attributes
    ----------
    skill
        ``(m, d)`` integers, :class:`~soccer_drill.commands.Skill` values.
    target
        ``(m, d, 2)`` floats, the ``MOVE_TO`` targets (ignored for other skills).
    speed
        ``(m, d)`` floats in ``(0, 1]``.
    """

    skill: np.ndarray
    target: np.ndarray
    speed: np.ndarray


def _read_only(array: np.ndarray) -> np.ndarray:
    """A read-only copy: a view could be made writeable again (its ``flags``, or its
    ``base``) and write into the batch's state."""
    if array.dtype.names is None:
        out = array.copy()
    else:  # records: their bytes copied whole (``copy`` goes field by field, 5x slower)
        out = np.ndarray(array.shape, array.dtype, bytearray(array.tobytes()))
    out.flags.writeable = False
    return out


class _DrillOfBatch:
    """What a :class:`DrillView` reads of drill ``i`` of a batch: its state and its
    configuration."""

    __slots__ = ("batch", "i")

    def __init__(self, batch: Any, i: int) -> None:
        self.batch, self.i = batch, i

    @property
    def config(self) -> DrillConfig:
        return self.batch.config

    @property
    def state(self) -> DrillState:
        return self.batch.state_of(self.i)


class BatchView(ReadOnlyView):
    """A read-only window on every drill of a batch, handed to teams.

    Each array of the batch's state is a read-only copy, taken when it is read (a team
    that writes to it, even after setting it writeable, changes only its copy); the
    arrays every drill shares (:attr:`params`, :attr:`table`) cannot be made writeable
    (:func:`~soccer_drill.rules.arrays.immutable`).
    :meth:`drill` is one drill's :class:`~soccer_drill.state.DrillView`.
    """

    __slots__ = ("_drills",)

    def __init__(self, source: object, players: tuple[str, ...]) -> None:
        super().__init__(source, players)
        object.__setattr__(self, "_drills", {})

    @property
    def n(self) -> int:
        """Number of drills."""
        return self._source.n  # type: ignore[attr-defined]

    @property
    def state(self) -> np.ndarray:
        """``(n,)`` :data:`~soccer_drill.rules.arrays.STATE` records: every field below in
        one copy (compiled team code reads ``state[i].pos``, ``state[i].holder``, ...)."""
        return _read_only(self._source.state)  # type: ignore[attr-defined]

    @property
    def pos(self) -> np.ndarray:
        """``(n, players + 1, 2)``: the players (``config.player_names`` order: ``(n, 5,
        2)`` in the 2v2 drill) then the ball, metres."""
        return _read_only(self._source.pos)  # type: ignore[attr-defined]

    @property
    def vel(self) -> np.ndarray:
        """``(n, players + 1, 2)`` velocities, m/s."""
        return _read_only(self._source.vel)  # type: ignore[attr-defined]

    @property
    def holder(self) -> np.ndarray:
        """``(n,)`` index of the player in possession, -1 for a loose ball."""
        return _read_only(self._source.holder)  # type: ignore[attr-defined]

    @property
    def cycle(self) -> np.ndarray:
        """``(n,)`` cycles since each drill's reset."""
        return _read_only(self._source.cycle)  # type: ignore[attr-defined]

    @property
    def passer(self) -> np.ndarray:
        """``(n,)`` the last player who passed, or -1."""
        return _read_only(self._source.passer)  # type: ignore[attr-defined]

    @property
    def lockout_until(self) -> np.ndarray:
        """``(n,)`` the passer cannot regain the ball before this cycle."""
        return _read_only(self._source.lockout_until)  # type: ignore[attr-defined]

    @property
    def params(self) -> np.ndarray:
        """The rule parameters, by name (:func:`~soccer_drill.rules.arrays.rule_parameters`:
        ``view.params[0]["control_radius"]``; compiled code takes the array)."""
        return self._source.params  # type: ignore[attr-defined]

    @property
    def table(self) -> np.ndarray:
        """The rolling ball's table (:func:`~soccer_drill.rules.arrays.roll_table`)."""
        return self._source.table  # type: ignore[attr-defined]

    def drill(self, i: int) -> DrillView:
        """Drill ``i`` as one drill's team sees it (its ``state`` a
        :class:`~soccer_drill.state.DrillState`)."""
        views: dict[int, DrillView] = self._drills
        view = views.get(i)
        if view is None:
            view = views[i] = DrillView(_DrillOfBatch(self._source, i), self._players)
        return view

    def __reduce__(self) -> tuple[type, tuple[object, tuple[str, ...]]]:
        return type(self), (self._source, self._players)


class BatchRandom:
    """Uniform draws from each drill's own generator, ``block`` at a time.

    ``random(drills)`` gives one uniform per drill of ``drills`` (distinct indices), each
    the next ``Generator.random()`` of that drill's generator: the same numbers, in the
    same order, as calling each generator one draw at a time. A drill given a seed
    rather than a generator gets ``np.random.default_rng(seed)`` at its first draw (most
    teams never draw, and making a generator costs as much as a dozen array operations);
    :meth:`generator` hands it out whole.
    """

    def __init__(self, n: int, block: int = 64) -> None:
        self._generators: list[np.random.Generator | int | None] = [None] * n
        self._block = block
        self._buffer = np.empty((n, block))
        self._next = np.full(n, block)

    def seed(self, drills: np.ndarray, generators: list[np.random.Generator | int]) -> None:
        """Draw from now on from ``generators`` (or generators of these seeds) for ``drills``."""
        for i, g in zip(drills.tolist(), generators, strict=True):
            self._generators[i] = g
        self._next[drills] = self._block

    def generator(self, i: int) -> np.random.Generator:
        """Drill ``i``'s generator itself (for a team that draws its own way; then draw
        from it only)."""
        g = self._generators[i]
        if g is None:
            raise RuntimeError(f"drill {i}: no generator; reset the drill first")
        if not isinstance(g, np.random.Generator):
            g = self._generators[i] = np.random.default_rng(g)
        return g

    def random(self, drills: np.ndarray) -> np.ndarray:
        """The next uniform of each drill in ``drills``: a 1-D array of distinct drill
        indices, anything else ``ValueError``."""
        drills = np.asarray(drills)
        n = len(self._generators)
        if drills.ndim != 1 or drills.dtype.kind not in "iu":
            raise ValueError(
                "BatchRandom.random takes a 1-D integer array of distinct drill indices (one "
                f"draw each), got {drills.dtype} of shape {drills.shape}"
            )
        if len(drills):
            # Ascending indices (how the drill passes them) are distinct, and their ends
            # bound them: one comparison instead of a sort.
            ascending = len(drills) == 1 or bool((drills[1:] > drills[:-1]).all())
            low, high = (drills[0], drills[-1]) if ascending else (drills.min(), drills.max())
            if low < 0 or high >= n:
                raise ValueError(f"BatchRandom.random: drill indices must lie in 0..{n - 1}, "
                                 f"got {low}..{high}")
            if not ascending and len(np.unique(drills)) != len(drills):  # one draw per drill
                raise ValueError("BatchRandom.random: the drill indices must be distinct (one "
                                 "draw per drill per call; call again for a second draw)")
        k = self._next[drills]
        empty = k >= self._block
        if np.count_nonzero(empty):
            for i in drills[empty].tolist():
                self.generator(i).random(out=self._buffer[i])
            k[empty] = 0
        self._next[drills] = k + 1
        return self._buffer[drills, k]


def every_drill(drills: np.ndarray, n: int) -> bool:
    """Whether ``drills`` is ``0, 1, ..., n - 1`` in order (then a team may read the
    batch's arrays as they are rather than gather its rows)."""
    if len(drills) != n:
        return False
    return bool(drills[0] == 0) if n == 1 else not np.count_nonzero(drills - rows(n))


@runtime_checkable
class BatchTeam(Protocol):
    """What a team's ``batch(n)`` returns (see the module docstring)."""

    def reset(self, view: BatchView, drills: np.ndarray, rng: BatchRandom) -> None: ...

    def act(self, view: BatchView, drills: np.ndarray) -> BatchCommands: ...


class SameCommands:
    """The batched form of a team whose players all get one command, the same in every
    drill and every cycle of an episode: ``command()``, the team's own rule, made again at
    each reset (as the single team makes it at its own).

    ``act`` hands out the same arrays while the rows asked for are as many (the drill
    copies what it is given).
    """

    def __init__(self, command: Callable[[], Command]) -> None:
        self._command = command
        self._row = (int(Skill.INTERCEPT), (0.0, 0.0), 1.0)
        self._made: dict[int, BatchCommands] = {}

    def reset(self, view: BatchView, drills: np.ndarray, rng: BatchRandom) -> None:
        """Make the command for the episodes starting."""
        command = self._command()
        row = (int(command.skill), command.target or (0.0, 0.0), float(command.speed))
        if row != self._row:
            self._row, self._made = row, {}

    def act(self, view: BatchView, drills: np.ndarray) -> BatchCommands:
        """The command for every player of each of ``drills``."""
        m, d = len(drills), len(view.players)
        made = self._made.get(m)
        if made is None or made.skill.shape[1] != d:
            skill, target, speed = self._row
            made = self._made[m] = BatchCommands(
                np.full((m, d), skill, dtype=np.int64), np.full((m, d, 2), target),
                np.full((m, d), speed))
        return made
