"""What a scripted team returned, checked, and :class:`TeamDriver`, which runs a team within
its CPU-time bound and reports what it raises; the words of each refusal, which the
batched check (:mod:`soccer_drill.teams.batch`) says too.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from soccer_drill.constraints import is_real
from soccer_drill.interruptions import MAX_ITEMS, delivered_by_signal, short_repr
from soccer_drill.rules.compiled import compiled
from soccer_drill.rules.first_use import warm_up
from soccer_drill.skills import BALL_SKILLS, Command, Skill
from soccer_drill.state import PLAYER_NAMES, DrillView
from soccer_drill.teams.registry import (
    DEFAULT_TEAM_TIMEOUT,
    Team,
    TeamError,
    _what_happened,
    check_team_timeout,
    make_team,
    team_parameters,
)
from soccer_drill.teams.time_bound import Overrun, call_within

_MOVE_TO = Skill.MOVE_TO  # read once: an enum member lookup costs ~0.2 us
_UNSET = object()  # no command seen yet (``None`` is a command to refuse)


SCRIPTED_SKILLS: tuple[Skill, ...] = tuple(s for s in Skill if s not in BALL_SKILLS)
"""The skills a scripted team may command: any but the holder's ball skills."""


def skill_refused(skill: object) -> str:
    """Why a scripted team's command of ``skill`` is refused (the checks of a team's
    commands in the single and the batched drill alike)."""
    allowed = [f"{s.name}={int(s)}" for s in SCRIPTED_SKILLS]
    shown = f"{skill.name}={int(skill)}" if isinstance(skill, Skill) else short_repr(skill)
    return f"skill {shown} is not allowed for a scripted defender; allowed: {allowed}"


def speed_allowed(speed: Any) -> bool:
    """Whether a command's ``speed`` lies in (0, 1] (NaN does not); the batched check runs
    it compiled (:data:`speed_allowed_compiled`)."""
    return speed > 0.0 and speed <= 1.0


speed_allowed_compiled = compiled(speed_allowed)


def speed_refused(speed: object) -> str:
    """Why a command of ``speed`` is refused."""
    return f"speed must be in (0, 1], got {short_repr(speed)}"


def target_refused(target: object) -> str:
    """Why a ``MOVE_TO`` to ``target`` is refused."""
    return f"MOVE_TO needs a finite (x, y) target, got {short_repr(target)}"


class _PlayerSet:
    """The players a team drives, as :func:`check_commands` compares and indexes them."""

    __slots__ = ("indices", "names", "set")

    def __init__(self, players: tuple[str, ...]) -> None:
        for player in players:
            if player not in PLAYER_NAMES:
                raise ValueError(f"unknown player {player!r}; players are {list(PLAYER_NAMES)}")
        self.names, self.set = players, frozenset(players)
        self.indices = tuple(PLAYER_NAMES.index(p) for p in players)


_player_sets: dict[tuple[str, ...], _PlayerSet] = {}


def check_commands(
    commands: object, players: tuple[str, ...], team: str, cycle: int, drill: int | None = None
) -> list[tuple[int, Command]]:
    """What a team's ``act()`` returned, checked: ``(player index, Command)`` pairs of
    plain values (a ``Command`` of a ``Skill``, a ``float`` speed in (0, 1], a tuple of
    two finite floats as a ``MOVE_TO`` target), one per player in ``players``.

    Anything else raises :class:`TeamError` naming ``team``, the player and ``cycle`` (and
    ``drill``, for a copy of the team in one drill of a batch):
    not a mapping with exactly those players (its size is read before its keys, so a
    huge mapping is refused at once), not a ``Command``, a ball skill, a speed outside
    (0, 1], a target that is not a finite ``(x, y)`` pair, or a mapping or value that
    raises when read. Each value is read once, and what is returned is what was checked.
    Messages are short whatever the team gave (:func:`~soccer_drill.interruptions.short_repr`).

    This runs the team's own objects (a ``Mapping``'s ``__len__``, ``__iter__`` and
    ``__getitem__``, a speed's ``__float__``, ``__repr__`` in a message): call it inside
    the team's time bound, as :class:`TeamDriver` does, so that none of it escapes the
    bound.
    """
    known = _player_sets.get(players)
    if known is None:
        known = _player_sets[players] = _PlayerSet(tuple(players))
    try:
        return _checked(commands, known, team, cycle, drill)
    except (TeamError, Overrun):
        raise
    except BaseException as exc:  # the team's own Mapping or Command type misbehaved
        if delivered_by_signal(exc):
            raise
        raise TeamError(
            f"{_named(team, drill)} returned commands that could not be checked at cycle "
            f"{cycle}: {_what_happened(exc)}"
        ) from exc


def resolve_team(
    opponent: object, opponent_params: object, team_timeout: float | None = DEFAULT_TEAM_TIMEOUT
) -> tuple[Team, str, dict[str, Any]]:
    """The team an environment's ``opponent`` and ``opponent_params`` name, its name in
    errors, and the parameters it was built with.

    ``opponent`` is a registered team id (built by :func:`make_team` with
    ``opponent_params``) or a :class:`Team` instance (then ``opponent_params`` must be
    empty: the instance is already built). A class is refused: its methods would be
    called without an instance. Whether an instance is a team is read from its ``reset``
    and ``act`` (a property there is the team's code), within ``team_timeout`` and
    :class:`TeamDriver`'s error wrapping.
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
    driver = TeamDriver(opponent, name, (), team_timeout)  # type: ignore[arg-type]
    if driver.call("reading its reset and act", "", isinstance, opponent, Team):
        if opponent_params:
            raise ValueError(
                f"opponent_params given with a Team instance ({type(opponent).__name__}): an "
                "instance is already built, so give its parameters to its constructor, or pass "
                "a registered team id with opponent_params"
            )
        return opponent, type(opponent).__name__, {}
    raise TypeError(f"opponent must be a team id or a Team instance, got {short_repr(opponent)}")


def _named(team: str, drill: int | None) -> str:
    """How the errors of the command checks name the team (and the drill of a copy)."""
    return f"team {team!r}" if drill is None else f"team {team!r}, drill {drill}"


def _checked(commands: object, known: _PlayerSet, team: str, cycle: int,
             drill: int | None) -> list:
    # The common case first (a dict; its keys compared as a set, without copying; a set
    # comparison looks at the sizes first).
    if not (
        (type(commands) is dict and commands.keys() == known.set)
        or (
            isinstance(commands, Mapping)
            and len(commands) == len(known.set)
            and set(commands) == known.set
        )
    ):
        if isinstance(commands, Mapping):
            size = len(commands)
            keys = sorted(short_repr(k) for k in itertools.islice(commands, MAX_ITEMS))
            got = f"[{', '.join(keys)}]" if size <= MAX_ITEMS else (
                f"{size:,} keys, the first {len(keys)} [{', '.join(keys)}, ...]"
            )
        else:
            got = type(commands).__name__
        raise TeamError(
            f"{_named(team, drill)} must return a mapping with exactly the players it drives "
            f"{sorted(known.names)}, got {got} at cycle {cycle}"
        )
    out = []
    given = checked = _UNSET
    for player, index in zip(known.names, known.indices, strict=True):
        command = commands[player]
        if command is not given:  # one object for several players is checked once
            given, checked = command, _check(team, player, command, cycle, drill)
        out.append((index, checked))
    return out


def _check(team: str, player: str, command: object, cycle: int, drill: int | None) -> Command:
    """``command`` if it is valid and plain, else a plain copy of it.

    Each field is read once and the copy holds what was checked: a ``MOVE_TO``
    target becomes a ``(float, float)`` tuple, so an object that yields other
    numbers when read again (or a ``Command`` subclass computing its fields)
    cannot slip a NaN past the check.
    """
    if not isinstance(command, Command):
        raise _invalid(team, drill, player, cycle, f"expected a Command, got {short_repr(command)}")
    skill, target, speed = command.skill, command.target, command.speed
    if not isinstance(skill, Skill) or skill in BALL_SKILLS:
        raise _invalid(team, drill, player, cycle, skill_refused(skill))
    plain = type(command) is Command and (type(speed) is float or type(speed) is int)
    if not (plain and speed_allowed(speed)):  # else the general check, and a copy
        checked = float(speed) if not plain and is_real(speed) else speed  # type: ignore[arg-type]
        if not (is_real(checked) and speed_allowed(checked)):
            raise _invalid(team, drill, player, cycle, speed_refused(speed))
        speed = checked
    if skill is not _MOVE_TO:
        return command if plain else Command(skill, None, speed)  # type: ignore[arg-type]
    if not (  # the common case, already immutable and plain: no copy needed
        type(target) is tuple
        and len(target) == 2
        and type(target[0]) is float
        and type(target[1]) is float
        and math.isfinite(target[0])
        and math.isfinite(target[1])
    ):
        point = _point(target)
        if point is None:
            raise _invalid(team, drill, player, cycle, target_refused(target))
        target, plain = point, False
    return command if plain else Command(skill, target, speed)  # type: ignore[arg-type]


def _invalid(team: str, drill: int | None, player: str, cycle: int, what: str) -> TeamError:
    return TeamError(f"{_named(team, drill)}, player {player!r}, cycle {cycle}: {what}")


class TeamDriver:
    """Runs a team inside the drill, bounds the CPU time of each call, checks every command.

    Parameters
    ----------
    team
        The team.
    name
        Its id, named in every error.
    players
        The players it drives.
    team_timeout
        Seconds of CPU time each ``reset`` or ``act`` call may take, in
        :data:`TEAM_TIMEOUT_RANGE` (1 ms to one day), or ``None`` for no bound. A
        call that exceeds it raises :class:`TeamError`.
    drill
        The drill of a batch this copy of the team plays in (named in its errors),
        or ``None``.

    What the bound counts is the CPU time of the thread running the team during the call
    (``time.thread_time``), less garbage collections (see
    :mod:`soccer_drill.teams.time_bound`):

    | the team's call | counted | stopped |
    |---|---|---|
    | computing (Python code, NumPy, any C code) | yes | on the main thread of a Unix process: interrupted inside the call once past the bound, also in a pure-Python infinite loop and after swallowing the first interruption (the timer re-fires); elsewhere: when the call returns |
    | checking what ``act()`` returned (:func:`check_commands`: the team's ``Mapping`` methods, a speed's ``__float__``, the ``__repr__`` of anything named in an error) and describing an exception it raised | yes: inside the same bound | as computing |
    | stuck inside one C call that never returns | yes | no (Python cannot interrupt C code) |
    | waiting: descheduled on a loaded machine, ``time.sleep``, I/O, a lock, a debugger's pause | no | no: a call blocked forever hangs the drill |
    | garbage collections it triggers (and the finalisers they run) | no | - |
    | threads it starts | no (their own CPU time) | - |

    A loaded machine therefore never turns an honest team into a :class:`TeamError`.
    Interruption uses ``setitimer(ITIMER_PROF)``/``SIGPROF``; the previous ``SIGPROF``
    handler is restored after every call, also when the call or the arming of the
    timer fails. Off the main thread, on platforms without ``setitimer`` (Windows), or
    when another ``ITIMER_PROF`` timer is already armed (a profiler's; it is put back
    at once), the call's CPU time is measured and the error raised *after* it returns.
    Pass ``team_timeout=None`` for no bound at all.

    Whatever the team raises is reported as a :class:`TeamError` naming it, the call and
    the cycle: any exception, ``SystemExit`` (``sys.exit()``) and a ``KeyboardInterrupt``
    its code raises included. A Ctrl-C (``SIGINT``) arriving during the call, and an
    exception that a signal handler of the program raises then, pass through unchanged,
    so Ctrl-C still stops the program (how the two are told apart:
    :mod:`soccer_drill.interruptions`).

    After the error the environment stays usable: its next ``reset()`` resets the team.
    """

    def __init__(
        self,
        team: Team,
        name: str,
        players: tuple[str, ...],
        team_timeout: float | None = DEFAULT_TEAM_TIMEOUT,
        drill: int | None = None,
    ) -> None:
        self.team, self.name, self.players = team, name, tuple(players)
        self.team_timeout = check_team_timeout(team_timeout)
        warm_up()  # the rules a team may call, compiled before any bounded call
        self.drill = drill
        # How its errors name the team: with the drill of a batch it plays in, if any.
        self._who = f"team {name!r}" if drill is None else f"team {name!r} (drill {drill})"

    def reset(self, view: DrillView, rng: np.random.Generator) -> None:
        """Reset the team, naming it in any error it raises."""
        start = time.perf_counter()
        try:
            self._call(self._bounded_reset, view, rng)
        except Overrun as exc:
            raise self._past_bound("reset()", "", exc, start) from None
        except TeamError:
            raise
        except Exception as exc:  # the bound itself failed (arming its timer)
            raise self._unbounded("reset()", "", exc) from exc

    def act(self, view: DrillView) -> list[tuple[int, Command]]:
        """Commands as ``(player index, command)`` pairs, checked (within the bound)."""
        start = time.perf_counter()
        try:
            return self._call(self._bounded_act, view)
        except Overrun as exc:
            raise self._past_bound("act()", f" at cycle {view.cycle}", exc, start) from None
        except TeamError:
            raise
        except Exception as exc:  # the bound itself failed (arming its timer)
            raise self._unbounded("act()", f" at cycle {view.cycle}", exc) from exc

    def _bounded_reset(self, view: DrillView, rng: np.random.Generator) -> None:
        try:
            self.team.reset(view, rng)
        except Overrun:
            raise
        except BaseException as exc:
            if delivered_by_signal(exc):
                raise
            raise self._raised("reset()", "", exc) from exc

    def _bounded_act(self, view: DrillView) -> list[tuple[int, Command]]:
        try:
            commands = self.team.act(view)
        except Overrun:
            raise
        except BaseException as exc:
            if delivered_by_signal(exc):
                raise
            raise self._raised("act()", f" at cycle {view.cycle}", exc) from exc
        return check_commands(commands, self.players, self.name, view.cycle, self.drill)

    def call(self, call: str, when: object, method: Callable[..., Any], *args: Any) -> Any:
        """``method(*args)`` within this driver's time bound; any failure a :class:`TeamError`.

        For drivers that run a team another way than :meth:`act` (the batched drill's
        batched ``act``, whose commands are checked inside ``method``, so the bound covers
        the check). ``call`` and ``when`` name the call in the error (``"act()"``,
        ``" at cycle 3"``).
        """
        start = time.perf_counter()

        def bounded(*inner: Any) -> Any:
            try:
                return method(*inner)
            except (Overrun, TeamError):
                raise
            except BaseException as exc:
                if delivered_by_signal(exc):
                    raise
                raise self._raised(call, when, exc) from exc

        try:
            return self._call(bounded, *args)
        except Overrun as exc:
            raise self._past_bound(call, when, exc, start) from None
        except TeamError:
            raise
        except Exception as exc:  # the bound itself failed (arming its timer)
            raise self._unbounded(call, when, exc) from exc

    def _call(self, method: Callable[..., Any], *args: Any) -> Any:
        """``method(*args)`` within the CPU-time bound; raises :class:`Overrun` past it."""
        timeout = self.team_timeout
        if timeout is None:
            return method(*args)
        return call_within(timeout, method, *args)

    def _raised(self, call: str, when: object, exc: BaseException) -> TeamError:
        return TeamError(f"{self._who} raised in {call}{when}: {_what_happened(exc)}")

    def _unbounded(self, call: str, when: object, exc: Exception) -> TeamError:
        return TeamError(
            f"{self._who}: its time bound could not be set for {call}{when}: "
            f"{short_repr(exc)}"
        )

    def _past_bound(self, call: str, when: object, exc: Overrun, start: float) -> BaseException:
        """The error of a call stopped by a time bound: this driver's, or, if it has none,
        ``exc`` unchanged, for the outer bound that stopped it (the batched drill runs
        one copy of a team per drill under one bound for all of them)."""
        if self.team_timeout is None:
            return exc
        return TeamError(
            f"{self._who} exceeded its time bound of {self.team_timeout:g} s of "
            f"CPU time in {call}{when} (stopped after {exc.cpu:.2f} s of CPU time, "
            f"{time.perf_counter() - start:.2f} s in all); fix the team or pass a larger "
            "team_timeout"
        )


def _point(target: object) -> tuple[float, float] | None:
    """``target`` read once into a finite ``(x, y)`` pair of floats, or ``None``."""
    try:
        x, y = target  # type: ignore[misc]
    except (TypeError, ValueError):  # not iterable, or not exactly two items
        return None
    if not (is_real(x) and is_real(y)):
        return None
    point = (float(x), float(y))
    return point if math.isfinite(point[0]) and math.isfinite(point[1]) else None
