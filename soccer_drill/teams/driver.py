"""The one team driver: a scripted team in ``n`` drills, within its CPU-time bound, every
command it returns checked (:func:`check_commands`) before it reaches the drill.

A team with a batched form (``team.batch(n)``, :mod:`soccer_drill.teams.kit`) is called
once per cycle for every drill acting; one without runs as one copy per drill (the team
itself in the first drill, ``copy.deepcopy`` of an instance or its factory's new ones in
the others), each copy's call held to ``team_timeout`` on its own, its commands read once
into the same arrays. The single environment is a batch of one drill, its errors naming
no drill; a batch's name the drills of a batched call, or the copy's drill.

After a team's error the drills that acted are part-way through a cycle: the driver
refuses to act again until every drill is reset.
"""

from __future__ import annotations

import copy
import gc
import itertools
import math
import pickle
import time
import weakref
from collections.abc import Callable, Mapping, Set
from typing import Any

import numpy as np

from soccer_drill.commands import BALL_SKILLS, SCRIPTED_SKILLS, Command, Skill
from soccer_drill.config import DrillConfig
from soccer_drill.constraints import Integer, ListOf, checked, is_int, is_real
from soccer_drill.interruptions import MAX_ITEMS, delivered_by_signal, short_repr
from soccer_drill.rules.arrays import immutable
from soccer_drill.rules.compiled import compiled, typed, warms
from soccer_drill.rules.first_use import warm_up
from soccer_drill.teams.kit import BatchCommands, BatchRandom, BatchTeam, BatchView
from soccer_drill.teams.registry import (
    DEFAULT_TEAM_TIMEOUT,
    Team,
    TeamError,
    _what_happened,
    check_team_timeout,
    is_team,
    make_team,
    team_parameters,
)
from soccer_drill.teams.time_bound import Overrun, call_within, counted_cpu, restart_count

_ALLOWED = np.zeros(len(Skill), dtype=bool)  # by skill value: may a scripted defender use it
_ALLOWED[[int(s) for s in SCRIPTED_SKILLS]] = True
_ALLOWED.flags.writeable = False
_SKILL, _SPEED, _TARGET = 1, 2, 3  # what was refused first
_DEFENDER_COUNTS = ListOf(Integer(1, 4), min_len=1, kinds=(list, tuple, set, frozenset, range))
"""What a team's ``defender_counts`` may be: the numbers of defenders it plays."""


def skill_refused(skill: object) -> str:
    """Why a scripted team's command of ``skill`` is refused."""
    allowed = [f"{s.name}={int(s)}" for s in SCRIPTED_SKILLS]
    shown = f"{skill.name}={int(skill)}" if isinstance(skill, Skill) else short_repr(skill)
    why = f"skill {shown} is not allowed for a scripted defender; allowed: {allowed}"
    if is_int(skill) and not isinstance(skill, Skill) and 0 <= skill < len(Skill):  # type: ignore[operator]
        # A Command's plain integer, whose value may be an allowed skill's: say why it is not.
        member = Skill(int(skill))  # type: ignore[call-overload]
        why += (f"; a Command's skill is a soccer_drill.Skill member, not its integer "
                f"(Skill({int(skill)}) is Skill.{member.name})")  # type: ignore[call-overload]
    return why


def _speed_refused(speed: object) -> str:
    if not is_real(speed):  # a bool, a string, an array: say the type, not the range
        return (f"speed must be a real number in (0, 1] (not a bool, a string or an "
                f"array), got {short_repr(speed)} of type {type(speed).__name__}")
    return f"speed must be in (0, 1], got {short_repr(speed)}"


def _target_refused(target: object) -> str:
    return (f"MOVE_TO needs a finite (x, y) target: a pair such as a tuple, list or array "
            f"(not a set or a dict, which have no x and y), got {short_repr(target)}")


# Each array of BatchCommands: its name, shape for m drills, dtype kinds, their words, and
# the dtype the drill keeps.
_COMMAND_ARRAYS = (
    ("skill", lambda m, d: (m, d), "iu", "integers (Skill values)", np.dtype(np.int64)),
    ("target", lambda m, d: (m, d, 2), "iuf", "numbers", np.dtype(np.float64)),
    ("speed", lambda m, d: (m, d), "iuf", "numbers", np.dtype(np.float64)),
)
_shapes: dict[tuple[int, int], tuple[tuple[int, ...], ...]] = {}  # by (m, d): the arrays' shapes


def _command_shapes(m: int, d: int) -> tuple[tuple[int, ...], ...]:
    """The shapes of the three arrays of the commands of ``d`` players in ``m`` drills."""
    shapes = _shapes.get((m, d))
    if shapes is None:
        shapes = _shapes[m, d] = tuple(shape(m, d) for _, shape, *_ in _COMMAND_ARRAYS)
    return shapes


class _Calling:
    """The drills of one call of a team, described only if an error names them.

    Parameters
    ----------
    drills
        The drills the call is for (``None``: the single environment's one drill,
        never named).
    cycles
        The batch's cycle counters (``None``: a reset, before any cycle).
    """

    def __init__(self, drills: np.ndarray | None, cycles: np.ndarray | None) -> None:
        self.drills, self.cycles = drills, cycles
        self.running: int | None = None
        """The drill whose copy was running when the call ended (copies only)."""

    def __format__(self, spec: str) -> str:
        text = ""
        if self.drills is not None:
            drills = [int(d) for d in self.drills[:6]]
            if len(self.drills) == 1:
                text = f" of drill {drills[0]}"
            else:
                listed = ", ".join(map(str, drills[:5])) + (", ..." if len(self.drills) > 5
                                                            else "")
                text = f" of drills {listed} ({len(self.drills)} in one call)"
        if self.cycles is not None:
            shown = self.cycles if self.drills is None else self.cycles[self.drills]
            low, high = int(shown.min()), int(shown.max())
            text = f" at cycle {low}" + (f"-{high}" if high > low else "") + text
        return text


def check_commands(commands: object, cycle: np.ndarray, drills: np.ndarray, cycles: np.ndarray,
                   team: str, players: tuple[str, ...], named: bool = True) -> None:
    """``commands``, one row per drill of ``drills``, checked, then written into those
    drills' :data:`~soccer_drill.rules.arrays.CYCLE` records (``cycle``) as the commands of
    the defenders, ``players`` (the last of the drill's players); else :class:`TeamError`,
    nothing written.

    Valid: a :class:`~soccer_drill.teams.kit.BatchCommands` of numeric arrays of the
    right shapes, each skill one a scripted defender may use (any but the ball skills),
    each speed in (0, 1], each ``MOVE_TO``'s target finite. The error names ``team``, the
    first bad drill (unless ``named`` is false: the single environment's one drill), its
    player and cycle, what was wrong and what is allowed. What is written is what was
    checked, in one pass (no code of the team's runs in between).
    """
    if not isinstance(commands, BatchCommands):
        raise TeamError(
            f"team {team!r}: act() must return BatchCommands(skill, target, speed), "
            f"got {type(commands).__name__}{_Calling(drills if named else None, cycles):}"
        )
    m, d = len(drills), len(players)
    arrays = []
    for (name, _, kinds, what, dtype), shape, given in zip(_COMMAND_ARRAYS, _command_shapes(m, d),
                                                          commands, strict=True):
        if (type(given) is np.ndarray and (given.dtype is dtype or given.dtype == dtype)
                and (flags := given.flags).c_contiguous and flags.writeable):
            array = given  # as the drill keeps them: read as they are
        else:
            try:
                array = np.asarray(given)
            except (TypeError, ValueError, OverflowError) as exc:
                if delivered_by_signal(exc):
                    raise
                raise TeamError(f"team {team!r}: commands' {name} is not a numeric array: "
                                f"{exc}{_Calling(drills if named else None, cycles):}") from exc
            if array.dtype.kind not in kinds:  # no strings, bools or objects
                raise TeamError(f"team {team!r}: commands' {name} must be an array of {what}, "
                                f"got dtype {array.dtype}{_Calling(drills if named else None, cycles):}")
            # As int64, a value out of the int64 range wraps to a negative one, refused
            # all the same.
            array = np.array(array, dtype=dtype)
        if array.shape != shape:
            raise TeamError(
                f"team {team!r}: commands' {name} must have shape {shape} (one row per "
                f"drill acting, one column per player), got {array.shape}{_Calling(drills if named else None, cycles):}"
            )
        arrays.append(array)
    skill, target, speed = arrays
    what, r, k = _check_of(cycle, drills)(cycle, drills, skill, target, speed, _ALLOWED)
    if what == 0:
        return
    where = (f"team {team!r}, " + (f"drill {int(drills[r])}, " if named else "")
             + f"player {players[k]!r}, cycle {int(cycles[drills[r]])}: ")
    if what == _SKILL:
        given = np.asarray(commands.skill)[r, k].item()
        named_skill = Skill(given) if is_int(given) and 0 <= given < len(Skill) else given
        raise TeamError(where + skill_refused(named_skill))
    if what == _SPEED:
        raise TeamError(where + _speed_refused(float(speed[r, k])))
    raise TeamError(where + _target_refused(tuple(target[r, k].tolist())))


_checks: dict[tuple[int, bool], tuple[np.dtype, Callable[..., Any]]] = {}


def _check_of(cycle: np.ndarray, drills: np.ndarray) -> Callable[..., Any]:
    """:func:`_checked_into` for these arrays: its machine code for their types
    (:func:`~soccer_drill.rules.compiled.typed`: the commands' three arrays are by now
    C-ordered, writeable, of the drill's dtypes and shapes), found once per records' dtype
    and kind of ``drills``; else (an array of other types) the compiled rule, which types
    its arguments."""
    if not (type(cycle) is np.ndarray and type(drills) is np.ndarray and drills.ndim == 1
            and drills.dtype is _INT64 and (flags := drills.flags).c_contiguous
            and cycle.ndim == 1 and cycle.flags.c_contiguous):
        return _checked_into
    dtype, writeable = cycle.dtype, flags.writeable
    known = _checks.get((id(dtype), writeable))
    if known is None or known[0] is not dtype:  # kept: its id is not another's meanwhile
        known = _checks[id(dtype), writeable] = (dtype, typed(
            _checked_into, cycle, drills, np.zeros((1, 1), np.int64), np.zeros((1, 1, 2)),
            np.ones((1, 1)), _ALLOWED))
    return known[1]


_INT64 = np.dtype(np.int64)


@compiled
def _checked_into(cycle, drills, skill, target, speed, allowed):
    """The first command refused, as ``(what, row, player)``: every skill checked first
    (one a scripted defender may use), then every speed (in (0, 1], not NaN), then every
    ``MOVE_TO``'s target (finite), rows in order. If none is (``(0, -1, -1)``), each row
    is written into drill ``drills[r]``'s record as the commands of its last
    ``skill.shape[1]`` players (the defenders)."""
    defenders = skill.shape[1]
    for what in range(_SKILL, _TARGET + 1):
        for r in range(skill.shape[0]):
            for k in range(defenders):
                s = skill[r, k]
                if what == _SKILL:
                    bad = s < 0 or s >= allowed.shape[0] or not allowed[s]
                elif what == _SPEED:
                    bad = not (speed[r, k] > 0.0 and speed[r, k] <= 1.0)
                else:
                    bad = s == Skill.MOVE_TO and not (math.isfinite(target[r, k, 0])
                                                      and math.isfinite(target[r, k, 1]))
                if bad:
                    return what, r, k
    for r in range(drills.shape[0]):
        c = cycle[drills[r]]
        first = c.skill.shape[0] - defenders
        for k in range(defenders):
            c.skill[first + k] = skill[r, k]
            c.target[first + k, 0] = target[r, k, 0]
            c.target[first + k, 1] = target[r, k, 1]
            c.speed[first + k] = speed[r, k]
    return 0, -1, -1


@warms
def _compile_checks(config: DrillConfig | None) -> None:
    """The check, with its callers' types, before a team's bounded call."""
    from soccer_drill.rules.arrays import cycle_record

    cfg = config or DrillConfig()
    d = cfg.defenders
    skill, target, speed = np.zeros((1, d), np.int64), np.zeros((1, d, 2)), np.ones((1, d))
    shown = np.zeros(1, dtype=np.int64)
    shown.flags.writeable = False  # as a batch of one drill, or every drill, passes them
    for drills in (np.zeros(1, dtype=np.int64), shown):
        _checked_into(np.zeros(1, cycle_record(cfg.players)), drills, skill, target, speed,
                      _ALLOWED)


# ---------------------------------------------------------------- one drill's teams
def _read(commands: object, players: tuple[str, ...]) -> BatchCommands:
    """What one drill's team returned (``act(view)``), read once into one row: the
    :class:`Command` of each of ``players``, its target a ``(float, float)`` pair, its
    speed a float; ``TeamError`` (naming the team, and ``(player)`` where it is one
    player's) for anything else. Values are checked afterwards, by :func:`check_commands`.
    """
    known = frozenset(players)
    if not ((type(commands) is dict and commands.keys() == known) or (
            isinstance(commands, Mapping) and len(commands) == len(known)
            and set(commands) == known)):
        if isinstance(commands, Mapping):
            size = len(commands)
            keys = sorted(short_repr(k) for k in itertools.islice(commands, MAX_ITEMS))
            got = f"[{', '.join(keys)}]" if size <= MAX_ITEMS else (
                f"{size:,} keys, the first {len(keys)} [{', '.join(keys)}, ...]")
        else:
            got = type(commands).__name__
        raise _Refused(f"must return a mapping with exactly the players it drives "
                       f"{sorted(players)}, got {got}")
    skill = np.empty((1, len(players)), dtype=np.int64)
    target = np.zeros((1, len(players), 2))
    speed = np.empty((1, len(players)))
    previous: object = _NOTHING_READ  # not None: a None is refused, never copied
    for k, player in enumerate(players):
        command = commands[player]
        if command is previous:  # one object for both players: read once, as it was
            skill[0, k], target[0, k], speed[0, k] = skill[0, k - 1], target[0, k - 1], speed[0, k - 1]
            continue
        previous = command
        if not isinstance(command, Command):
            raise _Refused(f"expected a Command, got {short_repr(command)}", player)
        skill_k, target_k, speed_k = command.skill, command.target, command.speed
        if not isinstance(skill_k, Skill) or skill_k in BALL_SKILLS:
            raise _Refused(skill_refused(skill_k), player)
        if not is_real(speed_k):
            raise _Refused(_speed_refused(speed_k), player)
        skill[0, k], speed[0, k] = skill_k, float(speed_k)  # type: ignore[arg-type]
        if skill_k is Skill.MOVE_TO:
            point = _point(target_k)
            if point is None:
                raise _Refused(_target_refused(target_k), player)
            target[0, k] = point
    return BatchCommands(skill, target, speed)


_NOTHING_READ = object()


class _Refused(Exception):
    """What one drill's team returned is not commands: why, and for which player."""

    def __init__(self, why: str, player: str | None = None) -> None:
        super().__init__(why)
        self.why, self.player = why, player


def _point(target: object) -> tuple[float, float] | None:
    """``target`` read once into a finite ``(x, y)`` pair of floats, or ``None`` (also
    for a set or a mapping, whose two items have no order to read x and y by)."""
    if isinstance(target, Set | Mapping):
        return None
    try:
        x, y = target  # type: ignore[misc]
    except (TypeError, ValueError):  # not iterable, or not exactly two items
        return None
    if not (is_real(x) and is_real(y)):
        return None
    point = (float(x), float(y))
    return point if math.isfinite(point[0]) and math.isfinite(point[1]) else None


class _Copies:
    """A team of one drill (``reset(view, rng)``, ``act(view)``) run in ``n`` drills as the
    batched protocol asks: one copy per drill, called in turn, each copy's CPU time
    counted afresh (:func:`~soccer_drill.teams.time_bound.restart_count`) so that each is
    held to the bound on its own, with one timer armed for all of them."""

    def __init__(self, teams: list[Team], driver: TeamDriver) -> None:
        self.teams, self.driver = teams, driver
        self.running: int | None = None
        """The drill whose copy is (or was last) being called."""

    def reset(self, view: BatchView, drills: np.ndarray, rng: BatchRandom) -> None:
        for i in drills.tolist():
            self._each(i, "reset()", "", self.teams[i].reset, view.drill(i), rng.generator(i))

    def act(self, view: BatchView, drills: np.ndarray) -> BatchCommands:
        players = self.driver.view.players
        rows = []
        for i in drills.tolist():
            one = view.drill(i)
            when = f" at cycle {one.cycle}"
            got = self._each(i, "act()", when, self.teams[i].act, one)
            try:
                rows.append(_read(got, players))
            except _Refused as refused:
                raise self.driver.copy_refused(i, refused, one.cycle) from None
            except (Overrun, TeamError):
                raise
            except BaseException as exc:  # the team's own Mapping or Command misbehaved
                if delivered_by_signal(exc):
                    raise
                raise self.driver.copy_unreadable(i, one.cycle, exc) from exc
        if len(rows) == 1:
            return rows[0]
        return BatchCommands(*(np.concatenate(parts) for parts in zip(*rows, strict=True)))

    def _each(self, i: int, call: str, when: str, method: Callable[..., Any], *args: Any) -> Any:
        """``method(*args)`` of drill ``i``'s copy: its exceptions its error, its CPU time
        its own."""
        self.running = i
        start = restart_count()
        try:
            out = method(*args)
        except (Overrun, TeamError):
            raise
        except BaseException as exc:
            if delivered_by_signal(exc):
                raise
            raise self.driver.copy_raised(i, call, when, exc) from exc
        timeout = self.driver.team_timeout
        spent = counted_cpu() - start
        if timeout is not None and spent > timeout:  # where the timer cannot interrupt
            raise Overrun(spent)
        return out


_COMPILING = ("; a team whose call compiles code (numba's, at its first call) registers "
              "that compile with soccer_drill.teams.warms, which runs it before any bounded "
              "call")
"""The end of a time bound's error: the usual reason a team that runs fast is stopped."""


class TeamDriver:
    """The scripted team of ``n`` drills: batched if the team offers it, else one copy per
    drill (see the module docstring).

    Parameters
    ----------
    opponent
        A team id or a team instance (copied with ``copy.deepcopy`` for each further
        drill when it has no batched form).
    opponent_params
        Keyword parameters of the team factory (with an id).
    batch
        The drills (a :class:`~soccer_drill.drill.drills.BatchDrill`).
    team_timeout
        Seconds of CPU time each call of the team may take (a copy's: each drill's), in
        ``TEAM_TIMEOUT_RANGE`` (1 ms to one day), or ``None`` for no bound.
    single
        The single environment's one drill: errors name no drill.

    What the bound counts is the CPU time of the thread running the team during the call
    (``time.thread_time``), less garbage collections (see
    :mod:`soccer_drill.teams.time_bound`):

    | the team's call | counted | stopped |
    |---|---|---|
    | computing (Python code, NumPy, any C code) | yes | on the main thread of a Unix process: interrupted inside the call once past the bound, also in a pure-Python infinite loop and after swallowing the first interruption (the timer re-fires); elsewhere: when the call returns |
    | checking what ``act()`` returned (the team's ``Mapping`` methods, a speed's ``__float__``, the ``__repr__`` of anything named in an error) and describing an exception it raised | yes: inside the same bound | as computing |
    | stuck inside one C call that never returns | yes | no (Python cannot interrupt C code) |
    | waiting: descheduled on a loaded machine, ``time.sleep``, I/O, a lock, a debugger's pause | no | no: a call blocked forever hangs the drill |
    | garbage collections it triggers (and the finalisers they run) | no | - |
    | threads it starts | no (their own CPU time) | - |

    A loaded machine therefore never turns an honest team into a :class:`TeamError`.
    Interruption uses ``setitimer(ITIMER_PROF)``/``SIGPROF``; the previous ``SIGPROF``
    handler is restored after every call, also when the call or the arming of the timer
    fails. Off the main thread, on platforms without ``setitimer`` (Windows), or when
    another ``ITIMER_PROF`` timer is already armed (a profiler's; it is put back at once),
    the call's CPU time is measured and the error raised *after* it returns.

    Whatever the team raises is reported as a :class:`TeamError` naming it, the call and
    the cycle: any exception, ``SystemExit`` (``sys.exit()``) and a ``KeyboardInterrupt``
    its code raises included. A Ctrl-C (``SIGINT``) arriving during the call, and an
    exception that a signal handler of the program raises then, pass through unchanged,
    so Ctrl-C still stops the program (how the two are told apart:
    :mod:`soccer_drill.interruptions`). After the error the environment stays usable: its
    next ``reset()`` of every drill resets the team.
    """

    def __init__(
        self,
        opponent: str | Team,
        opponent_params: Mapping[str, Any] | None,
        batch: Any,
        team_timeout: float | None = DEFAULT_TEAM_TIMEOUT,
        single: bool = False,
    ) -> None:
        self.team_timeout = check_team_timeout(team_timeout)
        warm_up(batch.config)  # the rules a team may call, compiled before any bounded call
        self.single = single
        self._batch = batch
        self.view = BatchView(batch, batch.config.player_names[batch.config.attackers:])
        team, self.name, params = resolve_team(opponent, opponent_params, self.team_timeout)
        warm_up(batch.config)  # and those the team's own module registered when imported
        self.team = team
        # Every attribute of the team is read inside its bound and error wrapping (a
        # property runs the team's code), as its methods are called.
        self._check_size(self.call("defender_counts", "", getattr, team, "defender_counts",
                                   None))
        # An instance another environment plays (given again, or a factory's one instance)
        # is copied before batch(), since a batched form may keep its state in the team.
        if _played_elsewhere(team):
            team = self.team = self.call("copy.deepcopy()", "", self._own_copy)
        batched = self.call("batch()", "", self._batched)
        if batched is not None and _played_elsewhere(batched):  # batch() gave it again
            batched = self.call("copy.deepcopy()", "", self._own_copy, batched)
        self.batched: BatchTeam | _Copies = batched if batched is not None else _Copies(
            self._per_drill(opponent, params), self)
        self.rng = BatchRandom(batch.n)
        self.failure: str | None = None
        """The error of the team's last failed call, until every drill is reset."""
        self._every = immutable(np.arange(batch.n))  # handed to the team every cycle
        _DRIVERS.add(self)

    def __deepcopy__(self, memo: dict[int, Any]) -> TeamDriver:
        """A copy of the driver and its team (an environment's ``copy.deepcopy``); a team
        that cannot be copied is named, with what to do, instead of a bare error of
        ``copy`` about one of its attributes."""
        copied = type(self).__new__(type(self))
        memo[id(self)] = copied
        try:
            state = copy.deepcopy(self.__dict__, memo)
        except Exception as exc:
            if delivered_by_signal(exc):
                raise
            raise TypeError(
                f"team {self.name!r} cannot be copied, so neither can the environment it "
                f"plays in: {short_repr(exc)}; give the team what "
                "copy.deepcopy can copy (or __deepcopy__), or make a new environment") from exc
        copied.__setstate__(state)
        return copied

    def __getstate__(self) -> dict[str, Any]:
        """The driver's state for ``pickle``: a team that pickle cannot store is named,
        with what to do, instead of a bare error of ``pickle`` about one of its attributes
        (the team is pickled once more here to find out)."""
        batched = self.batched
        played = batched.teams if isinstance(batched, _Copies) else [batched]
        try:
            pickle.dumps((self.team, *played))  # not the copies' driver: this one
        except Exception as exc:
            if delivered_by_signal(exc):
                raise
            raise TypeError(
                f"team {self.name!r} cannot be pickled, so neither can the environment it "
                f"plays in: {short_repr(exc)}; give the team what pickle can store (or "
                "__getstate__), or make a new environment") from exc
        return self.__dict__

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        # Read-only again, as the original's (copy.deepcopy and pickle make arrays
        # writable): a writable array is another type to a compiled team, which would be
        # compiled anew inside the copy's first time-bounded call.
        self._every = immutable(self._every)
        # A copy loaded in another process (a worker, a resumed checkpoint) compiles, or
        # loads, the rules and the team's registered warm-ups now, as a new driver does,
        # not inside the team's first bounded call (the team's module is imported by now).
        warm_up(self._batch.config)

    def _check_size(self, counts: object) -> None:
        """The drill's number of defenders, among those the team says it plays (its
        ``defender_counts``, a collection of integers; none said: any); else
        :class:`TeamError` naming the team, the size asked and the sizes it plays."""
        if counts is None:
            return
        defenders = self._batch.config.defenders
        try:
            plays = sorted(set(checked("defender_counts", counts, _DEFENDER_COUNTS)))
        except ValueError as exc:
            raise TeamError(f"team {self.name!r}: {exc}") from exc
        if defenders not in plays:
            raise TeamError(
                f"team {self.name!r} plays {', '.join(map(str, plays))} defender(s), and this "
                f"drill has {defenders} (DrillConfig.defenders={defenders}); make the drill "
                f"with defenders in {plays}, or choose a team that plays {defenders}")

    def _batched(self) -> BatchTeam | None:
        """The team's batched form (``team.batch(n)``, checked), or ``None`` if it has none."""
        team, n = self.team, self._batch.n
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

    def _per_drill(self, opponent: str | Team, params: dict[str, Any]) -> list[Team]:
        """One team instance per drill: the team, then :meth:`_copy`'s; an instance that
        another drill or environment plays already (a factory that returns one instance
        every time) copied, so that no two drills share one."""
        teams, taken = [self.team], {id(self.team)}
        for i in range(1, self._batch.n):
            made = self._copy(opponent, params, i)
            in_use = id(made) in taken  # the instances kept in teams: their ids stay theirs
            if in_use or _played_elsewhere(made):
                made = self.call("copy.deepcopy()", f" for drill {i}", self._own_copy, made,
                                 in_use)
            teams.append(made)
            taken.add(id(made))
        return teams

    def _copy(self, opponent: str | Team, params: dict[str, Any], drill: int) -> Team:
        """One more copy of the team, for drill ``drill``: its factory's for an id (not
        bounded, as building the team never is: a team may load what it needs when made),
        else ``copy.deepcopy``, the team's code, inside its bound."""
        if isinstance(opponent, str):
            return make_team(opponent, **params)
        return self.call("copy.deepcopy()", f" for drill {drill}", self._deepcopy)

    def _deepcopy(self) -> Team:
        try:
            return copy.deepcopy(self.team)
        except Exception as exc:  # not copyable: said, with what to do
            if delivered_by_signal(exc):
                raise
            text = str(exc)  # the team's code too (an exception of its own)
            text = text if len(text) <= 400 else text[:400] + "..."
            raise _NotCopied(
                f"team {self.name!r}: the batched drill runs a team without batch(n) as one "
                f"copy per drill, made by copy.deepcopy, and copying it failed "
                f"({type(exc).__name__}: {text}); make it copyable, give it a batch(n) "
                "method, or register its factory and pass its id"
            ) from exc

    def _own_copy(self, shared: object = None, in_use: bool = False) -> Any:
        """A copy of the team instance, or of ``shared`` (its batched form, or a per-drill
        instance its factory gave again), which another live environment or drill plays
        already (the object itself if that environment was only waiting to be collected;
        never if another drill of this one plays it: ``in_use``)."""
        played = self.team if shared is None else shared
        try:
            return copy.deepcopy(played)
        except Exception as exc:  # not copyable: said, with what to do
            if delivered_by_signal(exc):
                raise
            gc.collect()  # an environment dropped in a reference cycle plays nothing
            if not (in_use or _played_elsewhere(played)):
                return played
            raise _NotCopied(
                f"team {self.name!r}: this instance is played by another environment (or "
                "drill) already, "
                f"and copying it for this one failed ({type(exc).__name__}: "
                f"{short_repr(str(exc))}); pass each environment an instance of its own, or "
                "register its factory and pass its id"
            ) from exc

    # -------------------------------------------------------------- the calls
    def reset(self, drills: np.ndarray, seeds: list[int]) -> None:
        """Start an episode in each of ``drills``; ``seeds`` seed their teams' streams
        (``np.random.default_rng(seed)``, made when the team first draws)."""
        self.rng.seed(drills, seeds)
        try:
            self.call("reset()", _Calling(None if self.single else drills, None), self._reset,
                      drills)
        except TeamError as exc:
            self.failure = str(exc)
            raise
        if len(drills) == self._batch.n:
            self.failure = None

    def _reset(self, drills: np.ndarray) -> None:
        self.batched.reset(self.view, self._shown(drills), self.rng)  # its attribute read here

    def act(self, drills: np.ndarray) -> None:
        """The team's commands for ``drills`` (ascending), checked, into the drills'
        commands of players 2 and 3."""
        if self.failure is not None:
            self.check_usable()
        if not len(drills):
            return
        try:
            self.call("act()", drills, self._act, drills)
        except TeamError as exc:
            self.failure = str(exc)
            raise

    def _act(self, drills: np.ndarray) -> None:
        batch = self._batch
        out = self.batched.act(self.view, self._shown(drills))
        check_commands(out, batch.commands, drills, batch.cycle, self.name, self.view.players,
                       not self.single)

    def _shown(self, drills: np.ndarray) -> np.ndarray:
        """``drills`` as the team is handed them: read-only, and never the driver's own
        (every drill's is :func:`immutable`, the others a copy)."""
        if len(drills) == self._batch.n:
            return self._every
        shown = drills.copy()
        shown.flags.writeable = False
        return shown

    def check_usable(self) -> None:
        """:class:`TeamError` if the team failed and not every drill was reset since."""
        if self.failure is not None:
            raise _raised_by(self, TeamError(
                f"the team failed earlier ({self.failure}), leaving the drills that acted "
                "part-way through that cycle; call reset() before stepping again"
            ))

    def call(self, call: str, when: object, method: Callable[..., Any], *args: Any) -> Any:
        """``method(*args)`` within the team's time bound; any failure a :class:`TeamError`
        naming the call (``call``, and ``when``: ``" at cycle 3"``, or the drills acting,
        said with their cycles)."""
        start = time.perf_counter()
        try:
            if self.team_timeout is None:
                return self._guarded(call, when, method, args)
            return call_within(self.team_timeout, self._guarded, call, when, method, args)
        except Overrun as exc:
            raise _raised_by(self, self._past_bound(call, self._when(when), exc, start)) from None
        except _NotCopied as exc:
            raise TypeError(str(exc)) from exc.__cause__
        except TeamError as exc:
            _raised_by(self, exc)
            raise
        except TypeError:
            raise
        except Exception as exc:  # the bound itself failed (arming its timer)
            if delivered_by_signal(exc):  # the program's own, landing while the bound is set
                raise
            raise TeamError(f"{self._who()}: its time bound could not be set for "
                            f"{call}{self._when(when)}: {short_repr(exc)}") from exc

    def _guarded(self, call: str, when: object, method: Callable[..., Any],
                 args: tuple) -> Any:
        """``method(*args)``, whatever it raises a :class:`TeamError` (a Ctrl-C apart)."""
        try:
            return method(*args)
        except (Overrun, _NotCopied):
            raise
        except TeamError as exc:
            if getattr(exc, _RAISED_BY, self) is self:  # this driver's own check
                raise
            # Another driver's: an environment the team runs inside its own call failed.
            raise TeamError(f"{self._who()} raised in {call}{self._when(when)}: "
                            f"{_what_happened(exc)}") from exc
        except BaseException as exc:
            if delivered_by_signal(exc):
                raise
            raise TeamError(f"{self._who()} raised in {call}{self._when(when)}: "
                            f"{_what_happened(exc)}{self._protocol_hint(call, exc)}") from exc

    def _protocol_hint(self, call: str, exc: BaseException) -> str:
        """For a batched form's ``reset``/``act`` called with arguments it does not take:
        which protocol ``batch(n)`` chose (a team of one drill that also has a ``batch``
        method is called as a batched team)."""
        if (call not in ("reset()", "act()") or not isinstance(exc, TypeError)
                or "argument" not in str(exc) or isinstance(getattr(self, "batched", None),
                                                            _Copies | type(None))):
            return ""
        return ("; a team with batch(n) is played through what batch(n) returns, called as "
                "reset(view, drills, rng) and act(view, drills) (a team of one drill, "
                "reset(view, rng) and act(view), has no batch method)")

    def _when(self, when: object) -> object:
        """``when`` as words: the drills of an ``act()`` (an array) with their cycles."""
        if isinstance(when, np.ndarray):
            return _Calling(None if self.single else when, self._batch.cycle)
        return when

    # ------------------------------------------------------------- the words
    def _who(self, drill: int | None = None) -> str:
        """How errors name the team (and the drill of its copy in a batch)."""
        return f"team {self.name!r}" + ("" if drill is None or self.single else
                                        f" (drill {drill})")

    def _past_bound(self, call: str, when: object, exc: Overrun, start: float) -> TeamError:
        """The error of a call stopped by the time bound (a copy's: naming its drill)."""
        batched = getattr(self, "batched", None)  # None while the copies are being made
        copy_drill = batched.running if isinstance(batched, _Copies) else None
        if copy_drill is not None and not self.single:
            when = f" at cycle {int(self._batch.cycle[copy_drill])}" if call == "act()" else ""
            return TeamError(
                f"{self._who(copy_drill)} exceeded its time bound of {self.team_timeout:g} s "
                f"of CPU time in {call}{when} (stopped after {exc.cpu:.2f} s of CPU time); "
                f"fix the team or pass a larger team_timeout{_COMPILING}")
        return TeamError(
            f"{self._who()} exceeded its time bound of {self.team_timeout:g} s of "
            f"CPU time in {call}{when} (stopped after {exc.cpu:.2f} s of CPU time, "
            f"{time.perf_counter() - start:.2f} s in all); fix the team or pass a larger "
            f"team_timeout{_COMPILING}"
        )

    def copy_raised(self, drill: int, call: str, when: str, exc: BaseException) -> TeamError:
        """The error of drill ``drill``'s copy raising ``exc``."""
        return TeamError(f"{self._who(drill)} raised in {call}{when}: {_what_happened(exc)}")

    def _named(self, drill: int) -> str:
        """How the errors of a copy's commands name the team (and the drill)."""
        return f"team {self.name!r}" + ("" if self.single else f", drill {drill}")

    def copy_unreadable(self, drill: int, cycle: int, exc: BaseException) -> TeamError:
        """The error of drill ``drill``'s copy returning what raises when read."""
        return TeamError(f"{self._named(drill)} returned commands that could not be checked "
                         f"at cycle {cycle}: {_what_happened(exc)}")

    def copy_refused(self, drill: int, refused: _Refused, cycle: int) -> TeamError:
        """The error of drill ``drill``'s copy returning what is not commands."""
        named = self._named(drill)
        if refused.player is None:
            return TeamError(f"{named} {refused.why} at cycle {cycle}")
        return TeamError(f"{named}, player {refused.player!r}, cycle {cycle}: {refused.why}")


_RAISED_BY = "_soccer_drill_raised_by"
"""The attribute naming the driver a :class:`TeamError` left (its ``call`` or
``check_usable``): a team that runs an environment of its own inside its call, and that
environment's team fails, is this driver's team failing, not the inner one."""


def _raised_by(driver: TeamDriver, exc: TeamError) -> TeamError:
    """``exc``, marked as leaving ``driver`` unless an inner driver marked it first."""
    if not hasattr(exc, _RAISED_BY):
        setattr(exc, _RAISED_BY, driver)
    return exc


_DRIVERS: weakref.WeakSet[TeamDriver] = weakref.WeakSet()
"""The drivers made in this process and still alive (their environments' teams)."""


def _played_elsewhere(team: object) -> bool:
    """Whether a live driver plays ``team`` (the very instance, or a batched form): a team
    keeps its episode in its attributes, so two environments stepping one instance in turn
    would mix their episodes; the later one plays a copy instead (a ``batch(n)`` that
    returns the team itself, or any object it gave another environment, included)."""
    return any(driver.team is team or getattr(driver, "batched", None) is team
               for driver in list(_DRIVERS))


class _NotCopied(Exception):
    """A team without a batched form that ``copy.deepcopy`` cannot copy (a ``TypeError``
    to the caller, which made it)."""


def resolve_team(
    opponent: object, opponent_params: object, team_timeout: float | None = DEFAULT_TEAM_TIMEOUT
) -> tuple[Team, str, dict[str, Any]]:
    """The team an environment's ``opponent`` and ``opponent_params`` name, its name in
    errors, and the parameters it was built with.

    ``opponent`` is a registered team id (built by ``make_team`` with ``opponent_params``)
    or a team instance (then ``opponent_params`` must be empty: the instance is already
    built). A class is refused: its methods would be called without an instance. Whether
    an instance is a team is read from its ``batch``, or its ``reset`` and ``act`` (a
    property there is the team's code), within ``team_timeout``.
    """
    if isinstance(opponent, str):
        params = team_parameters(opponent_params)
        return make_team(opponent, **params), opponent, params
    if isinstance(opponent, type):
        raise TypeError(
            f"opponent must be a team id or a Team instance, got the class {opponent.__name__}: "
            f"pass an instance ({opponent.__name__}(...)), or register it "
            "(soccer_drill.teams.register) and pass its id"
        )
    name = type(opponent).__name__
    if _read_within(opponent, name, team_timeout):
        if opponent_params:
            raise ValueError(
                f"opponent_params given with a Team instance ({name}): an instance is "
                "already built, so give its parameters to its constructor, or pass a "
                "registered team id with opponent_params"
            )
        return opponent, name, {}  # type: ignore[return-value]
    has = [m for m in ("reset", "act", "batch") if callable(getattr(type(opponent), m, None))]
    raise TypeError(
        f"opponent must be a team id or a Team instance, got {short_repr(opponent)}: a team "
        "instance has the methods reset(view, rng) and act(view), or batch(n) "
        f"(soccer_drill.teams.Team); its class {name} has {' and '.join(has) or 'none of them'}")


def _read_within(opponent: object, name: str, team_timeout: float | None) -> bool:
    """:func:`~soccer_drill.teams.registry.is_team` of ``opponent``, read inside its bound
    and error wrapping."""
    try:
        if team_timeout is None:
            return is_team(opponent)
        return call_within(team_timeout, is_team, opponent)
    except Overrun as exc:
        raise TeamError(f"team {name!r} exceeded its time bound of {team_timeout:g} s of CPU "
                        f"time in reading its reset and act (stopped after {exc.cpu:.2f} s of "
                        "CPU time); fix the team or pass a larger team_timeout") from None
    except BaseException as exc:
        if delivered_by_signal(exc):
            raise
        raise TeamError(f"team {name!r} raised in reading its reset and act: "
                        f"{_what_happened(exc)}") from exc
