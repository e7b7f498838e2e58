"""Scripted teams in the batched drill: a batched ``act`` for all drills, or one team per drill.

A team can offer a batched version of itself: a method ``batch(n)`` returning an
object with

| method | does |
|---|---|
| ``reset(view, drills, rng)`` | start an episode in each of ``drills`` (an int array); ``rng`` is a :class:`BatchRandom` drawing from each drill's own generator |
| ``act(view, drills)`` | a :class:`BatchCommands` with one row per drill of ``drills``, in that order: the commands of the team's two players |

``view`` is a :class:`BatchView` (read-only arrays of every drill). The paper's teams and
the parametric family (:mod:`opponents.parametric`) and ``chasers`` have one. A team
without ``batch`` runs as one copy per drill, each behind its own
:class:`~soccer_drill.teams.TeamDriver` (its checks, as in the single environment).

:class:`BatchTeamDriver` runs either kind: one CPU-time bound per cycle of the batch
(``team_timeout`` for a batched team; for the copies, one timer for the cycle whose
count starts afresh at each copy, so that each copy's call is held to ``team_timeout``
as the single environment holds its team), and the
commands checked, a bad one named by drill, player and cycle. An error
of a copy names its drill; one of a batched call names the drills it was called for (it
cannot tell which of them failed). After a team's error the drills that acted are
part-way through a cycle: the driver refuses to act again until every drill is reset.
"""

from __future__ import annotations

import contextlib
import copy
import math
from collections.abc import Callable, Iterator, Mapping
from typing import Any, NamedTuple, Protocol, runtime_checkable

import numpy as np

from soccer_drill.config import DrillConfig
from soccer_drill.drill.drills import rows
from soccer_drill.rules.compiled import compiled, warms
from soccer_drill.skills import Command, Skill
from soccer_drill.state import PLAYER_NAMES, DrillState, DrillView, ReadOnlyView
from soccer_drill.teams.driver import (
    SCRIPTED_SKILLS,
    TeamDriver,
    resolve_team,
    skill_refused,
    speed_allowed_compiled,
    speed_refused,
    target_refused,
)
from soccer_drill.teams.registry import Team, TeamError, make_team
from soccer_drill.teams.time_bound import Overrun, counted_cpu, restart_count

_MOVE_TO = int(Skill.MOVE_TO)
_IS_ALLOWED = np.zeros(len(Skill), dtype=bool)  # by skill value: may a scripted defender use it
_IS_ALLOWED[[int(s) for s in SCRIPTED_SKILLS]] = True


class BatchCommands(NamedTuple):
    """The commands of a team's two players in ``m`` drills.

    Attributes
    ----------
    skill
        ``(m, 2)`` integers, :class:`~soccer_drill.skills.Skill` values.
    target
        ``(m, 2, 2)`` floats, the ``MOVE_TO`` targets (ignored for other skills).
    speed
        ``(m, 2)`` floats in ``(0, 1]``.
    """

    skill: np.ndarray
    target: np.ndarray
    speed: np.ndarray


def _read_only(array: np.ndarray) -> np.ndarray:
    """A read-only copy: a view could be made writeable again (its ``flags``, or its
    ``base``) and write into the batch's state."""
    out = array.copy()
    out.flags.writeable = False
    return out


class BatchView(ReadOnlyView):
    """A read-only window on every drill of a batch, handed to batched teams.

    Each array is a read-only copy of the batch's state, taken when it is read (a team
    that writes to it, even after setting it writeable, changes only its copy).
    """

    __slots__ = ()

    @property
    def n(self) -> int:
        """Number of drills."""
        return self._source.n  # type: ignore[attr-defined]

    @property
    def pos(self) -> np.ndarray:
        """``(n, 5, 2)``: the four players (``PLAYER_NAMES`` order) then the ball, metres."""
        return _read_only(self._source.pos)  # type: ignore[attr-defined]

    @property
    def vel(self) -> np.ndarray:
        """``(n, 5, 2)`` velocities, m/s."""
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


class BatchRandom:
    """Uniform draws from each drill's own generator, ``block`` at a time.

    ``random(drills)`` gives one uniform per drill of ``drills`` (distinct indices), each
    the next ``Generator.random()`` of that drill's generator: the same numbers, in the
    same order, as calling each generator one draw at a time. A drill given a seed
    rather than a generator gets ``np.random.default_rng(seed)`` at its first draw (most
    teams never draw, and making a generator costs as much as a dozen array operations).
    """

    def __init__(self, n: int, block: int = 64, normal: bool = False) -> None:
        self._generators: list[np.random.Generator | int | None] = [None] * n
        self._block = block
        self._buffer = np.empty((n, block))
        self._next = np.full(n, block)
        self._normal = normal

    def seed(self, drills: np.ndarray, generators: list[np.random.Generator | int]) -> None:
        """Draw from now on from ``generators`` (or generators of these seeds) for ``drills``."""
        for i, g in zip(drills.tolist(), generators, strict=True):
            self._generators[i] = g
        self._next[drills] = self._block

    def random(self, drills: np.ndarray) -> np.ndarray:
        """The next draw of each drill in ``drills`` (standard normals if ``normal``):
        a 1-D array of distinct drill indices, anything else ``ValueError``."""
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
                g = self._generators[i]
                if g is None:
                    raise RuntimeError(f"drill {i}: no generator; reset the drill first")
                if not isinstance(g, np.random.Generator):
                    g = self._generators[i] = np.random.default_rng(g)
                if self._normal:
                    g.standard_normal(out=self._buffer[i])
                else:
                    g.random(out=self._buffer[i])
            k[empty] = 0
        self._next[drills] = k + 1
        return self._buffer[drills, k]


def every_drill(drills: np.ndarray, n: int) -> bool:
    """Whether ``drills`` is ``0, 1, ..., n - 1`` in order (then a team may read the
    batch's arrays as they are rather than gather its rows)."""
    return len(drills) == n and not np.count_nonzero(drills - rows(n))


class SameCommands:
    """The batched form of a team whose players all get one command, the same in every
    drill and every cycle of an episode: ``command()``, the team's own rule, made again at
    each reset (as the single team makes it at its own).
    """

    def __init__(self, command: Callable[[], Command]) -> None:
        self._command = command
        self._row = (0, (0.0, 0.0), 1.0)

    def reset(self, view: BatchView, drills: np.ndarray, rng: BatchRandom) -> None:
        """Make the command for the episodes starting."""
        command = self._command()
        self._row = (int(command.skill), command.target or (0.0, 0.0), command.speed)

    def act(self, view: BatchView, drills: np.ndarray) -> BatchCommands:
        """The command for both players of each of ``drills``."""
        m = len(drills)
        skill, target, speed = self._row
        return BatchCommands(np.full((m, 2), skill), np.full((m, 2, 2), target),
                             np.full((m, 2), speed))


@runtime_checkable
class BatchTeam(Protocol):
    """What a team's ``batch(n)`` returns (see the module docstring)."""

    def reset(self, view: BatchView, drills: np.ndarray, rng: BatchRandom) -> None: ...

    def act(self, view: BatchView, drills: np.ndarray) -> BatchCommands: ...


class _Slot:
    """What a :class:`DrillView` reads for one drill of a batch: its state and config."""

    __slots__ = ("config", "state")

    def __init__(self, config: DrillConfig) -> None:
        self.config = config
        self.state: DrillState


class _Calling:
    """The drills of one call of a team, described only if an error names them: its
    ``when`` in a :class:`~soccer_drill.teams.TeamDriver` message (``act()`` + this).

    Parameters
    ----------
    drills
        The drills the call is for.
    cycles
        The batch's cycle counters (``None``: a reset, before any cycle).
    each
        The CPU-time bound of each drill's copy, when the call runs copies one
        after another under one bound of ``each`` times their number (then
        :attr:`running` is the copy that was running when it ended).
    """

    def __init__(self, drills: np.ndarray, cycles: np.ndarray | None, each: float | None = None) -> None:
        self.drills, self.cycles, self.each = drills, cycles, each
        self.running: int | None = None

    def __format__(self, spec: str) -> str:
        drills = [int(d) for d in self.drills[:6]]
        if len(self.drills) == 1:
            text = f" of drill {drills[0]}"
        else:
            listed = ", ".join(map(str, drills[:5])) + (", ..." if len(self.drills) > 5 else "")
            text = f" of drills {listed} ({len(self.drills)} in one call)"
        if self.cycles is not None:
            cycles = self.cycles[self.drills]
            low, high = int(cycles.min()), int(cycles.max())
            text = f" at cycle {low}" + (f"-{high}" if high > low else "") + text
        if self.each is not None:
            text += f", each drill's copy bounded by {self.each:g} s"
            if self.running is not None:
                text += f", stopped in drill {self.running}"
        return text


# Each array of BatchCommands: its name, shape for m drills, dtype kinds and their words.
_COMMAND_ARRAYS = (
    ("skill", lambda m: (m, 2), "iu", "integers (Skill values)"),
    ("target", lambda m: (m, 2, 2), "iuf", "numbers"),
    ("speed", lambda m: (m, 2), "iuf", "numbers"),
)


class BatchTeamDriver:
    """The scripted team of ``n`` drills: batched if the team offers it, else one per drill.

    Parameters
    ----------
    opponent
        A team id or a :class:`~soccer_drill.teams.Team` instance (copied
        with ``copy.deepcopy`` for each drill when it has no batched version).
    opponent_params
        Keyword parameters of the team factory (with an id).
    n
        Number of drills.
    config
        The drills' configuration.
    team_timeout
        The CPU-time bound of one batched call, or of each copy's call
        (see the module docstring).
    """

    def __init__(
        self,
        opponent: str | Team,
        opponent_params: Mapping[str, Any] | None,
        batch: Any,
        team_timeout: float | None,
    ) -> None:
        players = PLAYER_NAMES[2:]
        team, self.name, params = resolve_team(opponent, opponent_params, team_timeout)
        n = batch.n
        self._batch = batch
        self.view = BatchView(batch, players)
        self._bound = TeamDriver(team, self.name, players, team_timeout)
        # Every attribute of the team is read inside its bound and error wrapping (a
        # property runs the team's code), as its methods are called.
        self.batched: BatchTeam | None = self._bound.call("batch()", "", self._make_batch, team, n)
        if self.batched is not None:
            self.rng = BatchRandom(n)
            self._drivers: list[TeamDriver] = []
        else:
            copies = [team] + [self._copy(opponent, team, params, i) for i in range(1, n)]
            self._drivers = [TeamDriver(t, self.name, players, None, drill=i)
                             for i, t in enumerate(copies)]
            # One bound around the calls of all drills acting in a cycle, counted afresh
            # for each drill's copy (time_bound.restart_count): each copy is held to
            # team_timeout, with one timer armed per cycle (the copies' drivers: none).
            self._each_bound = TeamDriver(team, self.name, players, team_timeout)
            self._part = counted_cpu if team_timeout is None else restart_count
            self._slots = [_Slot(batch.config) for _ in range(n)]
            self._views = [DrillView(slot, players) for slot in self._slots]
        self._timeout = team_timeout
        self.failure: str | None = None
        """The error of the team's last failed call, until every drill is reset."""

    def _make_batch(self, team: Team, n: int) -> BatchTeam | None:
        """The team's batched form (``team.batch(n)``, checked), or ``None`` if it has none."""
        make_batch = getattr(team, "batch", None)
        if not callable(make_batch):
            return None
        batched = make_batch(n)
        if not isinstance(batched, BatchTeam) or not (
            callable(batched.reset) and callable(batched.act)
        ):
            raise TeamError(
                f"team {self.name!r}: batch({n}) returned {type(batched).__name__}, "
                "which lacks reset(view, drills, rng) and act(view, drills)"
            )
        return batched

    def _copy(self, opponent: str | Team, team: Team, params: dict[str, Any], drill: int) -> Team:
        """One more copy of the team, for drill ``drill`` (``copy.deepcopy`` runs inside
        the team's bound: a ``__deepcopy__`` is the team's code)."""
        if isinstance(opponent, str):
            return make_team(opponent, **params)
        failed: list[tuple[str, Exception]] = []

        def copying() -> Team | None:
            try:
                return copy.deepcopy(team)
            except Exception as exc:  # not copyable: said below, with what to do
                text = str(exc)  # the team's code too (an exception of its own)
                text = text if len(text) <= 400 else text[:400] + "..."
                failed.append((f"{type(exc).__name__}: {text}", exc))
                return None

        copied = self._bound.call("copy.deepcopy()", f" for drill {drill}", copying)
        if failed:
            raise TypeError(
                f"team {self.name!r}: the batched drill runs a team without batch(n) as one "
                f"copy per drill, made by copy.deepcopy, and copying it failed "
                f"({failed[0][0]}); make it copyable, give it a batch(n) "
                "method, or register its factory and pass its id"
            ) from failed[0][1]
        return copied  # type: ignore[return-value]

    def _refresh(self, drills: np.ndarray) -> None:
        for i in drills.tolist():
            self._slots[i].state = self._batch.state_of(i)

    def reset(self, drills: np.ndarray, seeds: list[int]) -> None:
        """Start an episode in each of ``drills``; ``seeds`` seed their teams' streams
        (``np.random.default_rng(seed)``, made when a batched team first draws)."""
        with self._failing():
            if self.batched is not None:
                self.rng.seed(drills, seeds)
                self._bound.call("reset()", _Calling(drills, None), self._batched_reset, drills)
            else:
                self._refresh(drills)
                calling = _Calling(drills, None, self._timeout)
                self._each_bound.call("reset()", calling, self._each_reset, drills, seeds, calling)
        if len(drills) == len(self._batch.cycle):
            self.failure = None

    def _each_reset(self, drills: np.ndarray, seeds: list[int], calling: _Calling) -> None:
        for i, s in zip(drills.tolist(), seeds, strict=True):
            calling.running = i
            start = self._part()
            try:
                self._drivers[i].reset(self._views[i], np.random.default_rng(s))
            except Overrun as exc:
                if self._timeout is None:  # an enclosing bound's, not this driver's
                    raise
                raise self._past_copy_bound(i, "reset()", "", exc) from None
            self._check_copy_time(i, "reset()", "", start)

    def act(self, drills: np.ndarray, skill: np.ndarray, target: np.ndarray, speed: np.ndarray) -> None:
        """Write the team's commands for ``drills`` into columns 2 and 3 of the arrays."""
        self.check_usable()
        if not len(drills):
            return
        with self._failing():
            if self.batched is not None:
                calling = _Calling(drills, self._batch.cycle)
                commands = self._bound.call("act()", calling, self._checked_act, drills)
            else:
                self._refresh(drills)
                calling = _Calling(drills, self._batch.cycle, self._timeout)
                commands = self._each_bound.call("act()", calling, self._each_act, drills, calling)
        sk, tg, sp = commands
        rows = slice(None) if len(drills) == len(skill) else drills  # all drills: no gather
        skill[rows, 2:] = sk
        target[rows, 2:] = tg
        speed[rows, 2:] = sp

    def check_usable(self) -> None:
        """:class:`TeamError` if the team failed and not every drill was reset since."""
        if self.failure is not None:
            raise TeamError(
                f"the team failed earlier ({self.failure}), leaving the drills that acted "
                "part-way through that cycle; call reset() before stepping again"
            )

    @contextlib.contextmanager
    def _failing(self) -> Iterator[None]:
        """Keeps the error of a failing call (see :attr:`failure`)."""
        try:
            yield
        except TeamError as exc:
            self.failure = str(exc)
            raise

    def _each_act(self, drills: np.ndarray, calling: _Calling) -> BatchCommands:
        m = len(drills)
        skill = np.empty((m, 2), dtype=np.int64)
        target = np.zeros((m, 2, 2))
        speed = np.empty((m, 2))
        for r, i in enumerate(drills.tolist()):
            calling.running = i
            start = self._part()
            try:
                acted = self._drivers[i].act(self._views[i])
            except Overrun as exc:
                if self._timeout is None:  # an enclosing bound's, not this driver's
                    raise
                raise self._past_copy_bound(i, "act()", f" at cycle {int(self._batch.cycle[i])}",
                                            exc) from None
            self._check_copy_time(i, "act()", f" at cycle {int(self._batch.cycle[i])}", start)
            for index, command in acted:
                k = index - 2
                skill[r, k] = int(command.skill)
                speed[r, k] = command.speed
                if command.target is not None:
                    target[r, k] = command.target
        return BatchCommands(skill, target, speed)

    def _check_copy_time(self, drill: int, call: str, when: str, start: float) -> None:
        """A copy whose call took more than ``team_timeout`` of CPU time is an overrun,
        as in the single drill, also where the bound cannot interrupt it (off the main
        thread, without ``setitimer``): then it is said when the call returns."""
        spent = counted_cpu() - start
        if self._timeout is not None and spent > self._timeout:
            raise self._past_copy_bound(drill, call, when, spent)

    def _past_copy_bound(self, drill: int, call: str, when: str,
                         past: float | Overrun) -> TeamError:
        """The error of drill ``drill``'s copy past its bound: ``past`` is the CPU time it
        took, or the :class:`Overrun` that stopped it."""
        took = f"took {past:.2f}" if isinstance(past, float) else f"stopped after {past.cpu:.2f}"
        return TeamError(
            f"team {self.name!r} (drill {drill}) exceeded its time bound of {self._timeout:g} s "
            f"of CPU time in {call}{when} ({took} s of CPU time); fix the team or pass a larger "
            "team_timeout"
        )

    def _batched_reset(self, drills: np.ndarray) -> None:
        assert self.batched is not None
        self.batched.reset(self.view, _read_only(drills), self.rng)  # its attribute read here

    def _checked_act(self, drills: np.ndarray) -> BatchCommands:
        assert self.batched is not None
        out = self.batched.act(self.view, _read_only(drills))  # its own: ours index the commands
        return check_commands(out, drills, self._batch.cycle, self.name, self.view.players)


def check_commands(
    commands: object, drills: np.ndarray, cycles: np.ndarray, team: str, players: tuple[str, ...]
) -> BatchCommands:
    """``commands`` as plain arrays if they are valid for ``drills``, else :class:`TeamError`.

    The error names the first bad drill, its player and cycle, what was wrong and what is
    allowed. The arrays returned are copies, so the team cannot change them afterwards.
    """
    m = len(drills)
    if not isinstance(commands, BatchCommands):
        raise TeamError(
            f"team {team!r}: a batched act() must return BatchCommands(skill, target, speed), "
            f"got {type(commands).__name__}"
        )
    try:
        given = [np.asarray(commands.skill), np.asarray(commands.target), np.asarray(commands.speed)]
    except (TypeError, ValueError, OverflowError) as exc:
        raise TeamError(f"team {team!r}: batched commands are not numeric arrays: {exc}") from exc
    for (name, shape, kinds, what), array in zip(_COMMAND_ARRAYS, given, strict=True):
        if array.dtype.kind not in kinds:  # no strings, bools or objects, as a Command refuses
            raise TeamError(
                f"team {team!r}: batched commands' {name} must be an array of {what}, got "
                f"dtype {array.dtype}"
            )
        shape = shape(m)
        if array.shape != shape:
            raise TeamError(
                f"team {team!r}: batched commands' {name} must have shape {shape} (one row per "
                f"drill acting, one column per player), got {array.shape}"
                f"{_Calling(drills, cycles):}"
            )
    raw_skill = given[0]
    # As int64, a value out of the int64 range wraps to a negative one, refused all the same.
    skill = raw_skill.astype(np.int64)
    target = np.array(given[1], dtype=np.float64)
    speed = np.array(given[2], dtype=np.float64)
    what, r, k = _first_refused(skill, target, speed, _IS_ALLOWED, _MOVE_TO)
    if what == _NONE:
        return BatchCommands(skill, target, speed)
    where = (f"team {team!r}, drill {int(drills[r])}, player {players[k]!r}, cycle "
             f"{int(cycles[drills[r]])}: ")
    if what == _SKILL:
        raise TeamError(where + skill_refused(raw_skill[r, k].item()))
    if what == _SPEED:
        raise TeamError(where + speed_refused(float(speed[r, k])))
    raise TeamError(where + target_refused(tuple(target[r, k].tolist())))


_NONE, _SKILL, _SPEED, _TARGET = range(4)


@compiled
def _first_refused(skill, target, speed, allowed, move_to):
    """The first command refused, as ``(what, row, player)``: every skill checked first
    (one a scripted defender may use), then every speed (in (0, 1], not NaN), then every
    ``MOVE_TO``'s target (finite), rows in order; ``(_NONE, -1, -1)`` if none is."""
    for what in range(_SKILL, _TARGET + 1):
        for r in range(skill.shape[0]):
            for k in range(2):
                s = skill[r, k]
                if what == _SKILL:
                    bad = s < 0 or s >= allowed.shape[0] or not allowed[s]
                elif what == _SPEED:
                    bad = not speed_allowed_compiled(speed[r, k])
                else:
                    bad = s == move_to and not (math.isfinite(target[r, k, 0])
                                                and math.isfinite(target[r, k, 1]))
                if bad:
                    return what, r, k
    return _NONE, -1, -1


@warms
def _compile_check() -> None:
    """:func:`_first_refused` with its caller's types, before a team's bounded call."""
    _first_refused(np.zeros((1, 2), dtype=np.int64), np.zeros((1, 2, 2)), np.ones((1, 2)),
                   _IS_ALLOWED, _MOVE_TO)
