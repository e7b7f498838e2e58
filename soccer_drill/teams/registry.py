"""Scripted teams: the protocol, the registry and plugin discovery.

A team drives some players (today: the two defenders). It is reset with a
read-only :class:`~soccer_drill.state.DrillView` and a random generator it must
draw all its randomness from, and each cycle returns one
:class:`~soccer_drill.commands.Command` per player it drives; or it offers its batched form,
``batch(n)``, which plays one drill or many (:mod:`soccer_drill.teams.kit`).

Teams are found by id in :data:`TEAMS`, a :class:`~soccer_drill.registry.Registry`:
first among in-process registrations (:func:`register`), then among the entry points
of the group ``soccer_drill.opponents``; the entry point's name is the id and its
value a factory taking keyword parameters::

    [project.entry-points."soccer_drill.opponents"]
    my_team = "my_package.teams:MyTeam"

An entry point is imported on first use. One that fails to import (or is not
callable) only breaks its own team: building it raises :class:`TeamError` naming it
and the error, :func:`available_teams` leaves it out with a :class:`PluginWarning`,
and :func:`broken_teams` lists it. A declared id that is not valid (an id is at most 64
ASCII letters, digits, ``_`` or ``-``: :class:`~soccer_drill.constraints.Name`), or that
looks like another team's (the same but for case, or ``-`` against ``_``), is refused the
same way; an id declared by two distributions warns, naming both, and the first one
found on ``sys.path`` is used (this project's own team, if it is one of them). Teams may
be looked up and built from several threads at once.

Every call of a team's ``reset`` and ``act`` is bounded in CPU time (``team_timeout``,
1 s by default; see :class:`~soccer_drill.teams.driver.TeamDriver`).
"""

from __future__ import annotations

import hashlib
import inspect
import re
import sys
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from soccer_drill.commands import Command
from soccer_drill.constraints import Name, NoneOr, OneOf, Real, checked
from soccer_drill.interruptions import delivered_by_signal, short_repr
from soccer_drill.registry import PROJECT_DISTRIBUTION, PluginWarning, Registry
from soccer_drill.state import DrillView

ENTRY_POINT_GROUP = "soccer_drill.opponents"
KEEPAWAY_ENTRY_POINT_GROUP = "soccer_drill.keepaway_teams"
DEFAULT_TEAM_TIMEOUT = 1.0
"""Seconds of CPU time a team's ``reset`` or ``act`` may take before it is stopped."""
TEAM_TIMEOUT_RANGE = (0.001, 86_400.0)
"""Allowed ``team_timeout`` values, in seconds (``None`` means no bound). Far inside
what ``setitimer`` takes (about 9.2e9 s, or 2**31 s with a 32-bit ``time_t``)."""
TEAM_TIMEOUT = NoneOr(Real(*TEAM_TIMEOUT_RANGE))
"""What ``team_timeout`` may be: ``None`` (no bound) or seconds in :data:`TEAM_TIMEOUT_RANGE`."""
BUILT_IN_DISTRIBUTION = PROJECT_DISTRIBUTION
"""The distribution of this project's own teams (``opponents``): they win an id that a
plugin declares too."""


@runtime_checkable
class Team(Protocol):
    """What a scripted team implements."""

    def reset(self, view: DrillView, rng: np.random.Generator) -> None:
        """Start an episode. ``view.players`` names the players this team drives."""

    def act(self, view: DrillView) -> Mapping[str, Command]:
        """One command per driven player for the coming cycle."""


def is_team(obj: object) -> bool:
    """Whether ``obj`` is a team instance: it offers ``batch(n)``, or ``reset`` and ``act``
    (reading them runs the team's code, when they are properties)."""
    if isinstance(obj, type):
        return False
    return isinstance(obj, Team) or callable(getattr(obj, "batch", None))


class TeamError(RuntimeError):
    """A scripted team misbehaved (raised, hung, or returned invalid commands), or its
    plugin cannot be used (failed to import, not callable, invalid id)."""


TEAMS = Registry(
    ENTRY_POINT_GROUP, "team", label="id", names=Name(dots=False),
    calls="a team class or factory", error=TeamError,
)
"""Every team of the drill, by id: in-process registrations (:func:`register`) and the
entry points of the group ``soccer_drill.opponents``, each imported on first use."""
KEEPAWAY_TEAMS = Registry(
    KEEPAWAY_ENTRY_POINT_GROUP, "keepaway team", label="id", names=Name(dots=False),
    calls="a team class or factory", error=TeamError,
)
"""The takers' teams of the keepaway task (:data:`~soccer_drill.tasks.TASKS`), by id: the
entry points of the group ``soccer_drill.keepaway_teams``."""
TASK_TEAMS: dict[str, Registry] = {"drill": TEAMS, "keepaway": KEEPAWAY_TEAMS}
"""Each task's teams. An id is looked up in every task's registry (the drill's first), so
any team can be named in any environment; :func:`team_ids` lists one task's."""
_TASK = OneOf(tuple(TASK_TEAMS))
"""What a ``task`` of :func:`team_ids` and :func:`available_teams` may be."""


def _built_in(registry: Registry, team_id: object) -> bool:
    """Whether ``registry`` holds ``team_id`` as one of this project's own teams."""
    dist = getattr(registry.entry_point(team_id), "dist", None)  # type: ignore[arg-type]
    return getattr(dist, "name", None) == BUILT_IN_DISTRIBUTION


def _registry_of(team_id: object) -> Registry:
    """The registry holding ``team_id``: the one where it is this project's own team, if
    any (a plugin of another task's group cannot take a built-in id), else the first
    that holds it (the drill's if none does: its error names it)."""
    holders = [r for r in TASK_TEAMS.values() if team_id in r]
    if len(holders) > 1:
        built_in = [r for r in holders if _built_in(r, team_id)]
        if built_in:
            if team_id not in _SHADOWED:
                _SHADOWED.add(team_id)  # type: ignore[arg-type]
                warnings.warn(f"team id {team_id!r} is one of this project's own teams; a "
                              "plugin or registration that declares it for another task is "
                              "ignored for it", PluginWarning, stacklevel=3)
            return built_in[0]
    if holders:
        return holders[0]
    # none holds it: the one that refused its plugin, if any, says why
    return next((r for r in TASK_TEAMS.values() if r.refused(team_id)), TEAMS)


_SHADOWED: set[str] = set()
"""Built-in ids already warned of as declared again for another task."""


def _factory(team_id: str) -> Any:
    """The factory of team ``team_id``, from whichever task's registry holds it; an
    unknown id's ``ValueError`` lists every task's teams, since any may be named."""
    registry = _registry_of(team_id)
    try:
        return registry.get(team_id)
    except ValueError as exc:
        others = {task: r.names() for task, r in TASK_TEAMS.items() if r is not registry}
        raise ValueError(f"{exc}; and the teams of other tasks, which any environment "
                         f"takes too: {others}") from None


def check_team_timeout(team_timeout: object) -> float | None:
    """``team_timeout`` as a float, or ``None``; refuses anything outside
    :data:`TEAM_TIMEOUT_RANGE` (NaN, infinity, bools and non-numbers included)."""
    return None if team_timeout is None else checked("team_timeout", team_timeout, TEAM_TIMEOUT)


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


def refresh() -> None:
    """Look for newly installed entry points of every task's teams (keeps explicit
    registrations)."""
    for registry in TASK_TEAMS.values():
        registry.refresh()
    _SHADOWED.clear()


def register(team_id: str, factory: Callable[..., Team], *, overwrite: bool = False) -> None:
    """Register ``factory`` under ``team_id`` for this process (notebooks, tests).

    Raises
    ------
    ValueError
        ``team_id`` is not a valid id (at most 64 ASCII letters, digits, ``_`` or ``-``,
        not starting with a digit), looks like the id of another team of any task (the
        same but for case, or ``-`` against ``_``), is one of this project's own teams'
        (which keep their ids, ``overwrite`` or not), or is taken and ``overwrite`` is false.
    TypeError
        ``factory`` is not callable.
    """
    for task, registry in TASK_TEAMS.items():
        built_in = team_id in registry and _built_in(registry, team_id)
        if built_in:  # so that results labelled with a built-in id come from its team
            raise ValueError(f"team {team_id!r} is one of the {task} task's teams, and this "
                             "project's own teams keep their ids; give yours an id of its own")
        if registry is TEAMS:
            continue
        other = registry.alike(team_id)  # the drill's own registry checks its look-alikes
        if other is not None:
            raise ValueError(f"team id {team_id!r} looks like the {task} task's team {other!r} "
                             "(ids that differ only in case or in '-' against '_' are taken "
                             "for each other); give yours an id of its own")
        if team_id in registry and not overwrite:
            raise ValueError(f"team {team_id!r} is already one of the {task} task's teams; "
                             "pass overwrite=True to play yours under that id instead")
    TEAMS.register(team_id, factory, overwrite=overwrite)


def team_ids(task: str = "drill") -> list[str]:
    """Ids of every known team of ``task`` (the drill's by default), sorted (without
    importing any plugin)."""
    return TASK_TEAMS[checked("task", task, _TASK)].names()


def describe(team_id: str) -> str:
    """The first sentence of the team factory's docstring, as plain text (a sentence
    that goes on to the next line is not cut; Sphinx's roles and literals unmarked)."""
    factory = _factory(team_id)
    doc = inspect.cleandoc(getattr(factory, "__doc__", None) or "")
    paragraph = " ".join(doc.split("\n\n")[0].split())
    sentence = re.split(r"(?<=[.!?])\s", paragraph, maxsplit=1)[0]
    sentence = re.sub(r":\w+:`~?(?:[\w.]*\.)?([^`.]+)`", r"\1", sentence)
    return sentence.replace("``", "")


def available_teams(task: str | None = None) -> dict[str, str]:
    """``{team id: one-line description}`` of every team that can be built: of every
    task (the drill's first, then keepaway's takers: :data:`TASK_TEAMS`), or of ``task``.

    A team whose plugin fails to load is left out with a :class:`PluginWarning`
    naming it and the error (:func:`broken_teams` lists them).
    """
    teams = {}
    tasks = list(TASK_TEAMS) if task is None else [checked("task", task, _TASK)]
    for team_id in (name for t in tasks for name in team_ids(t)):
        try:
            teams[team_id] = describe(team_id)
        except TeamError as exc:
            warnings.warn(str(exc), PluginWarning, stacklevel=2)
    return teams


def broken_teams() -> dict[str, str]:
    """``{team id: what is wrong}`` for every declared team that cannot be built.

    Imports every plugin not imported yet, of every task's teams.
    """
    return {name: problem for registry in TASK_TEAMS.values()
            for name, problem in registry.broken().items()}


def team_code(team_id: str) -> dict[str, str]:
    """What identifies the code of team ``team_id``, so that a result kept between runs
    is not taken for the team's after its code changed.

    ``factory``: the factory's module and name; ``distribution``: the name and version of
    the distribution that declares it (an entry point's); ``source_sha256``: the SHA-256
    of the source of the package the factory is in (every ``.py`` file under its
    top-level package, by relative path, or below a namespace package under the first
    regular package; the file alone for a single-module plugin or a module directly in a
    namespace package).
    A key is left out when it cannot be known (a factory made at run time).
    """
    registry = _registry_of(team_id)
    factory = _factory(team_id)
    out = {"factory": f"{getattr(factory, '__module__', '?')}:{getattr(factory, '__qualname__', '?')}"}
    entry_point = registry.entry_point(team_id)
    dist = getattr(entry_point, "dist", None)
    if dist is not None:
        out["distribution"] = f"{dist.name} {dist.version}"
    digest = _package_digest(getattr(factory, "__module__", None))
    if digest is not None:
        out["source_sha256"] = digest
    return out


def _package_digest(module_name: str | None) -> str | None:
    """SHA-256 of the ``.py`` files of the outermost regular package that holds
    ``module_name`` (its top-level package or, below a namespace package, the first
    regular one), or of the module's file alone when no regular package holds it (a
    single-module plugin, or a module directly in a namespace package)."""
    parts = (module_name or "").split(".")
    for depth in range(1, len(parts) + 1):
        origin = getattr(sys.modules.get(".".join(parts[:depth])), "__file__", None)
        if origin is not None:  # a namespace package has none: look further in
            break
    else:
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

    Raises
    ------
    ValueError
        ``team_id`` is unknown, ``params`` do not fit the factory's signature (the message
        lists what it takes), or the factory refused them with a ``ValueError``.
    TeamError
        The team's plugin cannot be used, or the factory failed otherwise (any other
        exception, ``SystemExit`` and a ``KeyboardInterrupt`` it raised included; a Ctrl-C
        is not caught, see :mod:`soccer_drill.interruptions`), or built something that is
        not a team.
    """
    factory = _factory(team_id)
    problem = _binding_problem(factory, params)
    if problem is not None:
        raise ValueError(f"bad parameters {short_repr(params)} for team {team_id!r}: {problem}")
    try:
        team = factory(**params)
    except ValueError as exc:  # the usual way to refuse a parameter's value
        if delivered_by_signal(exc):
            raise
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
    if not is_team(team):
        what = f"the class {team.__name__}" if isinstance(team, type) else type(team).__name__
        raise TeamError(
            f"team {team_id!r}: factory returned {what}, not a team instance with "
            "reset(view, rng) and act(view), or batch(n)"
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
