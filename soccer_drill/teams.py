"""Scripted teams: the protocol, the registry and plugin discovery.

A team drives some players (today: the two defenders). It is reset with a
read-only :class:`~soccer_drill.state.DrillView` and a random generator it must
draw all its randomness from, and each cycle returns one
:class:`~soccer_drill.skills.Command` per player it drives.

Teams are found by id: first in the in-process registry (:func:`register`), then
among the entry points of the group ``soccer_drill.opponents``; the entry point's
name is the id and its value a factory taking keyword parameters::

    [project.entry-points."soccer_drill.opponents"]
    my_team = "my_package.teams:MyTeam"

An entry point is imported on first use. One that fails to import (or is not
callable) only breaks its own team: building it raises :class:`TeamError` naming it
and the error, :func:`available_teams` leaves it out with a :class:`PluginWarning`,
and :func:`broken_teams` lists it. A declared id that is not valid is refused the
same way; an id declared by two distributions warns, naming both, and the first one
found on ``sys.path`` is used.

Every call of a team's ``reset`` and ``act`` is bounded in CPU time (``team_timeout``,
1 s by default; see :class:`TeamDriver`), so a team stuck computing fails with a
:class:`TeamError` naming it instead of freezing an experiment, and a loaded machine
never fails an honest team.
"""

from __future__ import annotations

import hashlib
import inspect
import itertools
import math
import numbers
import sys
import time
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from soccer_drill.interruptions import MAX_ITEMS, delivered_by_signal, short_repr
from soccer_drill.rules.first_use import warm_up
from soccer_drill.skills import BALL_SKILLS, Command, Skill
from soccer_drill.state import PLAYER_NAMES, DrillView
from soccer_drill.time_bound import Overrun, call_within

ENTRY_POINT_GROUP = "soccer_drill.opponents"
_MOVE_TO = Skill.MOVE_TO  # read once: an enum member lookup costs ~0.2 us
_UNSET = object()  # no command seen yet (``None`` is a command to refuse)
DEFAULT_TEAM_TIMEOUT = 1.0
"""Seconds of CPU time a team's ``reset`` or ``act`` may take before it is stopped."""
TEAM_TIMEOUT_RANGE = (0.001, 86_400.0)
"""Allowed ``team_timeout`` values, in seconds (``None`` means no bound). Far inside
what ``setitimer`` takes (about 9.2e9 s, or 2**31 s with a 32-bit ``time_t``)."""

@runtime_checkable
class Team(Protocol):
    """What a scripted team implements."""

    def reset(self, view: DrillView, rng: np.random.Generator) -> None:
        """Start an episode. ``view.players`` names the players this team drives."""

    def act(self, view: DrillView) -> Mapping[str, Command]:
        """One command per driven player for the coming cycle."""


class TeamError(RuntimeError):
    """A scripted team misbehaved (raised, hung, or returned invalid commands), or its
    plugin cannot be used (failed to import, not callable, invalid id)."""


class PluginWarning(UserWarning):
    """A team plugin is broken or ambiguous; the other teams are unaffected."""


def check_team_timeout(team_timeout: object) -> float | None:
    """``team_timeout`` as a float, or ``None``; refuses anything outside
    :data:`TEAM_TIMEOUT_RANGE` (NaN, infinity, bools and non-numbers included)."""
    if team_timeout is None:
        return None
    low, high = TEAM_TIMEOUT_RANGE
    if not (_is_real(team_timeout) and low <= team_timeout <= high):  # type: ignore[operator]
        raise ValueError(
            f"team_timeout must be None (no bound) or a number of seconds in "
            f"[{low:g}, {high:g}], got {team_timeout!r}"
        )
    return float(team_timeout)  # type: ignore[arg-type]


def team_parameters(params: object) -> dict[str, Any]:
    """``opponent_params`` as keyword parameters: ``None`` (none) or a mapping with str keys."""
    if params is None:
        return {}
    if not isinstance(params, Mapping) or not all(isinstance(k, str) for k in params):
        raise TypeError(
            "opponent_params must be None or a mapping of parameter names (str) to values, "
            f"got {params!r}"
        )
    return dict(params)


@dataclass
class _Entry:
    factory: Callable[..., Team] | None
    entry_point: Any = None  # importlib.metadata.EntryPoint, loaded on first use
    # Loading an entry point imports and parses each time (and importlib.metadata keeps
    # a little memory per call): every environment makes its team, so load once; a
    # failure is kept too, so a broken plugin is not re-imported by every lookup.
    loaded: Callable[..., Team] | None = field(default=None, repr=False, compare=False)
    failure: str | None = field(default=None, repr=False, compare=False)
    cause: BaseException | None = field(default=None, repr=False, compare=False)

    def load(self, team_id: str) -> Callable[..., Team]:
        """The team factory (importing the entry point on first use)."""
        if self.factory is not None:
            return self.factory
        if self.loaded is None and self.failure is None:
            where = f"the entry point of team {team_id!r} ({self.entry_point.value})"
            try:
                loaded = self.entry_point.load()
            # SystemExit too: a plugin calling sys.exit() at import must not end the host.
            except (Exception, SystemExit) as exc:
                self.failure, self.cause = f"{where} failed to load: {exc!r}", exc
            else:
                if callable(loaded):
                    self.loaded = loaded
                else:
                    self.failure = (
                        f"{where} is not callable: it names a {type(loaded).__name__} "
                        f"({loaded!r}); it must name a team class or factory"
                    )
        if self.failure is not None:
            raise TeamError(self.failure) from self.cause
        return self.loaded  # type: ignore[return-value]


_registry: dict[str, _Entry] = {}
_refused: dict[str, str] = {}  # declared ids that are not valid: id -> why
_discovered = False


def _id_problem(team_id: object) -> str | None:
    """Why ``team_id`` is not a valid team id, or ``None``."""
    if isinstance(team_id, str) and team_id and team_id.replace("-", "_").isidentifier():
        return None
    return (
        "a team id must be a non-empty identifier (letters, digits, '_' or '-', not "
        f"starting with a digit), got {team_id!r}"
    )


def _origin(ep: Any) -> str:
    """The distribution that declares entry point ``ep``, for messages."""
    name = getattr(getattr(ep, "dist", None), "name", None)
    return f"distribution {name!r} ({ep.value})" if name else f"an entry point ({ep.value})"


BUILT_IN_DISTRIBUTION = "soccer-drill-ilpss"
"""The distribution of this project's own teams (``opponents``): they win an id that a
plugin declares too."""


def _is_built_in(ep: Any) -> bool:
    name = getattr(getattr(ep, "dist", None), "name", None) or ""
    return name.lower().replace("_", "-").replace(".", "-") == BUILT_IN_DISTRIBUTION


def _discover() -> None:
    global _discovered
    if _discovered:
        return
    _discovered = True
    try:
        found = list(entry_points(group=ENTRY_POINT_GROUP))
    except Exception as exc:  # unreadable metadata of some installed distribution
        warnings.warn(
            f"could not read the {ENTRY_POINT_GROUP!r} entry points: {exc!r}",
            PluginWarning, stacklevel=3,
        )
        return
    first: dict[str, Any] = {}
    # This project's own teams first: a plugin declaring one of their ids cannot replace
    # it (results labelled "chasers" are always this project's chasers).
    found.sort(key=lambda ep: not _is_built_in(ep))
    for ep in found:
        problem = _id_problem(ep.name)
        if problem is not None:
            _refused[ep.name] = f"team {ep.name!r} of {_origin(ep)} is refused: {problem}"
            warnings.warn(_refused[ep.name], PluginWarning, stacklevel=3)
        elif ep.name in first:
            kept = "this project's own team" if _is_built_in(first[ep.name]) else "the first"
            warnings.warn(
                f"team id {ep.name!r} is declared twice, by {_origin(first[ep.name])} and "
                f"by {_origin(ep)}; using {kept} (give the other team an id of its own)",
                PluginWarning, stacklevel=3,
            )
        else:
            first[ep.name] = ep
            _registry.setdefault(ep.name, _Entry(None, ep))  # a register()ed team wins


def refresh() -> None:
    """Look for newly installed entry points (keeps explicit registrations)."""
    global _discovered
    for team_id in [k for k, e in _registry.items() if e.factory is None]:
        del _registry[team_id]
    _refused.clear()
    _discovered = False
    _discover()


def register(team_id: str, factory: Callable[..., Team], *, overwrite: bool = False) -> None:
    """Register ``factory`` under ``team_id`` for this process (notebooks, tests).

    Raises:
        ValueError: ``team_id`` is not a non-empty identifier-like string, or is
            taken and ``overwrite`` is false.
    """
    problem = _id_problem(team_id)
    if problem is not None:
        raise ValueError(problem)
    if not callable(factory):
        raise TypeError(f"factory for team {team_id!r} must be callable, got {factory!r}")
    _discover()
    if team_id in _registry and not overwrite:
        raise ValueError(f"team id {team_id!r} is already registered; pass overwrite=True")
    _registry[team_id] = _Entry(factory)


def team_ids() -> list[str]:
    """Ids of every known team, sorted (without importing any plugin)."""
    _discover()
    return sorted(_registry)


def describe(team_id: str) -> str:
    """First line of the team factory's docstring."""
    factory = _lookup(team_id)
    doc = (getattr(factory, "__doc__", None) or "").strip()
    return doc.splitlines()[0] if doc else ""


def available_teams() -> dict[str, str]:
    """``{team id: one-line description}`` of every team that can be built.

    A team whose plugin fails to load is left out with a :class:`PluginWarning`
    naming it and the error (:func:`broken_teams` lists them).
    """
    teams = {}
    for team_id in team_ids():
        try:
            teams[team_id] = describe(team_id)
        except TeamError as exc:
            warnings.warn(str(exc), PluginWarning, stacklevel=2)
    return teams


def broken_teams() -> dict[str, str]:
    """``{team id: what is wrong}`` for every declared team that cannot be built.

    Imports every plugin not imported yet.
    """
    _discover()
    broken = dict(_refused)
    for team_id in team_ids():
        try:
            _lookup(team_id)
        except TeamError as exc:
            broken[team_id] = str(exc)
    return dict(sorted(broken.items()))


def _lookup(team_id: str) -> Callable[..., Team]:
    _discover()
    entry = _registry.get(team_id)
    if entry is None:
        if team_id in _refused:
            raise TeamError(_refused[team_id])
        raise ValueError(f"unknown opponent team {team_id!r}; known teams: {team_ids()}")
    return entry.load(team_id)


def team_code(team_id: str) -> dict[str, str]:
    """What identifies the code of team ``team_id``, so that a result kept between runs
    is not taken for the team's after its code changed.

    ``factory``: the factory's module and name; ``distribution``: the name and version of
    the distribution that declares it (an entry point's); ``source_sha256``: the SHA-256
    of the source of the package the factory is in (every ``.py`` file under its
    top-level package, by relative path; the file alone for a single-module plugin).
    A key is left out when it cannot be known (a factory made at run time).
    """
    factory = _lookup(team_id)
    out = {"factory": f"{getattr(factory, '__module__', '?')}:{getattr(factory, '__qualname__', '?')}"}
    entry_point = _registry[team_id].entry_point
    dist = getattr(entry_point, "dist", None)
    if dist is not None:
        out["distribution"] = f"{dist.name} {dist.version}"
    digest = _package_digest(getattr(factory, "__module__", None))
    if digest is not None:
        out["source_sha256"] = digest
    return out


def _package_digest(module_name: str | None) -> str | None:
    """SHA-256 of the ``.py`` files of ``module_name``'s top-level package (or module)."""
    top = sys.modules.get((module_name or "").partition(".")[0])
    origin = getattr(top, "__file__", None)
    if origin is None:
        return None
    path = Path(origin)
    files = sorted(path.parent.rglob("*.py")) if path.name == "__init__.py" else [path]
    digest = hashlib.sha256()
    for file in files:
        digest.update(str(file.relative_to(path.parent)).encode())
        digest.update(b"\0" + file.read_bytes() + b"\0")
    return digest.hexdigest()


def make_team(team_id: str, **params: Any) -> Team:
    """Instantiate the team registered as ``team_id`` with keyword ``params``.

    Raises:
        ValueError: ``params`` do not fit the factory's signature (the message lists
            what it takes), or the factory refused them with a ``ValueError``.
        TeamError: the factory failed otherwise (any other exception, ``SystemExit``
            and a ``KeyboardInterrupt`` it raised included; a Ctrl-C is not caught, see
            :mod:`soccer_drill.interruptions`), or built something that is not a team.
    """
    factory = _lookup(team_id)
    problem = _binding_problem(factory, params)
    if problem is not None:
        raise ValueError(f"bad parameters {short_repr(params)} for team {team_id!r}: {problem}")
    try:
        team = factory(**params)
    except ValueError as exc:  # the usual way to refuse a parameter's value
        raise ValueError(
            f"team {team_id!r} refused its parameters {short_repr(params)}: {short_repr(exc)}"
        ) from exc
    except BaseException as exc:
        if delivered_by_signal(exc):
            raise
        raise TeamError(
            f"team {team_id!r} failed while being built with parameters "
            f"{short_repr(params)}: {_what_happened(exc)}"
        ) from exc
    if isinstance(team, type) or not isinstance(team, Team):
        what = f"the class {team.__name__}" if isinstance(team, type) else type(team).__name__
        raise TeamError(
            f"team {team_id!r}: factory returned {what}, not a team instance with "
            "reset(view, rng) and act(view)"
        )
    return team


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


def _binding_problem(factory: Callable[..., Any], params: dict[str, Any]) -> str | None:
    """Why ``params`` cannot be passed to ``factory`` (``None``: they can, or the
    factory's signature cannot be read and the call will tell)."""
    try:
        signature = inspect.signature(factory)
    except (TypeError, ValueError):
        return None
    try:
        signature.bind(**params)
    except TypeError as exc:
        return f"{exc}; it takes {signature}"
    return None


def _what_happened(exc: BaseException) -> str:
    """A team's exception, said for an error message (short, whatever its repr)."""
    if isinstance(exc, SystemExit):
        return (f"it called sys.exit({short_repr(exc.code)}) (SystemExit); a team must not "
                "end the program, so it is reported as this error")
    if isinstance(exc, KeyboardInterrupt):
        return ("it raised KeyboardInterrupt itself (not a Ctrl-C, which stops the program "
                f"as usual): {short_repr(exc)}")
    return short_repr(exc)


SCRIPTED_SKILLS: tuple[Skill, ...] = tuple(s for s in Skill if s not in BALL_SKILLS)
"""The skills a scripted team may command: any but the holder's ball skills."""


def skill_refused(skill: object) -> str:
    """Why a scripted team's command of ``skill`` is refused (the checks of a team's
    commands in the single and the batched drill alike)."""
    allowed = [f"{s.name}={int(s)}" for s in SCRIPTED_SKILLS]
    shown = f"{skill.name}={int(skill)}" if isinstance(skill, Skill) else short_repr(skill)
    return f"skill {shown} is not allowed for a scripted defender; allowed: {allowed}"


def speed_allowed(speed: Any) -> Any:
    """Whether a command's ``speed`` lies in (0, 1] (NaN does not): a bool, or one per
    element of an array of speeds."""
    return (speed > 0.0) & (speed <= 1.0)


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
        checked = float(speed) if not plain and _is_real(speed) else speed  # type: ignore[arg-type]
        if not (_is_real(checked) and speed_allowed(checked)):
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

    Args:
        team: the team.
        name: its id, named in every error.
        players: the players it drives.
        team_timeout: seconds of CPU time each ``reset`` or ``act`` call may take, in
            :data:`TEAM_TIMEOUT_RANGE` (1 ms to one day), or ``None`` for no bound. A
            call that exceeds it raises :class:`TeamError`.
        drill: the drill of a batch this copy of the team plays in (named in its errors),
            or ``None``.

    What the bound counts is the CPU time of the thread running the team during the call
    (``time.thread_time``), less garbage collections (see
    :mod:`soccer_drill.time_bound`):

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


def _is_real(value: object) -> bool:
    """A real number but not a bool (``float`` and ``int`` first: the common, fast case)."""
    if isinstance(value, bool):
        return False
    return isinstance(value, float | int) or isinstance(value, numbers.Real)


def _point(target: object) -> tuple[float, float] | None:
    """``target`` read once into a finite ``(x, y)`` pair of floats, or ``None``."""
    try:
        x, y = target  # type: ignore[misc]
    except (TypeError, ValueError):  # not iterable, or not exactly two items
        return None
    if not (_is_real(x) and _is_real(y)):
        return None
    point = (float(x), float(y))
    return point if math.isfinite(point[0]) and math.isfinite(point[1]) else None
