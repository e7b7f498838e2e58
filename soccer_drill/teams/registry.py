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
1 s by default; see :class:`~soccer_drill.teams.driver.TeamDriver`).
"""

from __future__ import annotations

import hashlib
import inspect
import numbers
import sys
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from soccer_drill.interruptions import delivered_by_signal, short_repr
from soccer_drill.skills import Command
from soccer_drill.state import DrillView

ENTRY_POINT_GROUP = "soccer_drill.opponents"
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


def _is_real(value: object) -> bool:
    """A real number but not a bool (``float`` and ``int`` first: the common, fast case)."""
    if isinstance(value, bool):
        return False
    return isinstance(value, float | int) or isinstance(value, numbers.Real)
