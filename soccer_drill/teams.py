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
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import Any, Protocol, runtime_checkable

import numpy as np

from soccer_drill.skills import BALL_SKILLS, Command, Skill
from soccer_drill.state import PLAYER_NAMES, DrillView

ENTRY_POINT_GROUP = "soccer_drill.opponents"


@runtime_checkable
class Team(Protocol):
    """What a scripted team implements."""

    def reset(self, view: DrillView, rng: np.random.Generator) -> None:
        """Start an episode. ``view.players`` names the players this team drives."""

    def act(self, view: DrillView) -> Mapping[str, Command]:
        """One command per driven player for the coming cycle."""


class TeamError(RuntimeError):
    """A scripted team misbehaved (raised, or returned invalid commands)."""


@dataclass(frozen=True)
class _Entry:
    factory: Callable[..., Team] | None
    entry_point: Any = None  # importlib.metadata.EntryPoint, loaded on first use

    def load(self, team_id: str) -> Callable[..., Team]:
        """The team factory (importing the entry point on first use)."""
        if self.factory is not None:
            return self.factory
        try:
            return self.entry_point.load()
        except Exception as exc:
            raise TeamError(
                f"the entry point of team {team_id!r} ({self.entry_point.value}) "
                f"failed to load: {exc!r}"
            ) from exc


_registry: dict[str, _Entry] = {}
_discovered = False


def _discover() -> None:
    global _discovered
    if _discovered:
        return
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        _registry.setdefault(ep.name, _Entry(None, ep))
    _discovered = True


def refresh() -> None:
    """Look for newly installed entry points (keeps explicit registrations)."""
    global _discovered
    for team_id in [k for k, e in _registry.items() if e.factory is None]:
        del _registry[team_id]
    _discovered = False
    _discover()


def register(team_id: str, factory: Callable[..., Team], *, overwrite: bool = False) -> None:
    """Register ``factory`` under ``team_id`` for this process (notebooks, tests).

    Raises:
        ValueError: ``team_id`` is not a non-empty identifier-like string, or is
            taken and ``overwrite`` is false.
    """
    if not isinstance(team_id, str) or not team_id or not team_id.replace("-", "_").isidentifier():
        raise ValueError(
            f"team id must be a non-empty identifier (letters, digits, '_' or '-'), "
            f"got {team_id!r}"
        )
    if not callable(factory):
        raise TypeError(f"factory for team {team_id!r} must be callable, got {factory!r}")
    _discover()
    if team_id in _registry and not overwrite:
        raise ValueError(f"team id {team_id!r} is already registered; pass overwrite=True")
    _registry[team_id] = _Entry(factory)


def team_ids() -> list[str]:
    """Ids of every known team, sorted."""
    _discover()
    return sorted(_registry)


def describe(team_id: str) -> str:
    """First line of the team factory's docstring."""
    factory = _lookup(team_id)
    doc = (getattr(factory, "__doc__", None) or "").strip()
    return doc.splitlines()[0] if doc else ""


def available_teams() -> dict[str, str]:
    """``{team id: one-line description}`` for every known team."""
    return {team_id: describe(team_id) for team_id in team_ids()}


def _lookup(team_id: str) -> Callable[..., Team]:
    _discover()
    entry = _registry.get(team_id)
    if entry is None:
        raise ValueError(f"unknown opponent team {team_id!r}; known teams: {team_ids()}")
    return entry.load(team_id)


def make_team(team_id: str, **params: Any) -> Team:
    """Instantiate the team registered as ``team_id`` with keyword ``params``."""
    factory = _lookup(team_id)
    try:
        team = factory(**params)
    except TypeError as exc:
        raise ValueError(f"bad parameters {params!r} for team {team_id!r}: {exc}") from exc
    if not isinstance(team, Team):
        raise TeamError(
            f"team {team_id!r}: factory returned {type(team).__name__}, which lacks "
            "reset(view, rng) and act(view)"
        )
    return team


class TeamDriver:
    """Runs a team inside the drill and checks everything it returns."""

    def __init__(self, team: Team, name: str, players: tuple[str, ...]) -> None:
        self.team, self.name, self.players = team, name, players
        self._indices = tuple(PLAYER_NAMES.index(p) for p in players)

    def reset(self, view: DrillView, rng: np.random.Generator) -> None:
        """Reset the team, naming it in any error it raises."""
        try:
            self.team.reset(view, rng)
        except Exception as exc:
            raise TeamError(f"team {self.name!r} raised in reset(): {exc!r}") from exc

    def act(self, view: DrillView) -> list[tuple[int, Command]]:
        """Commands as ``(player index, command)`` pairs, validated."""
        try:
            commands = self.team.act(view)
        except Exception as exc:
            raise TeamError(
                f"team {self.name!r} raised in act() at cycle {view.cycle}: {exc!r}"
            ) from exc
        if not isinstance(commands, Mapping) or set(commands) != set(self.players):
            got = sorted(commands) if isinstance(commands, Mapping) else type(commands).__name__
            raise TeamError(
                f"team {self.name!r} must return a mapping with exactly the players it "
                f"drives {sorted(self.players)}, got {got} at cycle {view.cycle}"
            )
        out = []
        for player, index in zip(self.players, self._indices, strict=True):
            out.append((index, self._check(player, commands[player], view.cycle)))
        return out

    def _check(self, player: str, command: object, cycle: int) -> Command:
        where = f"team {self.name!r}, player {player!r}, cycle {cycle}"
        if not isinstance(command, Command):
            raise TeamError(f"{where}: expected a Command, got {command!r}")
        if not isinstance(command.skill, Skill) or command.skill in BALL_SKILLS:
            raise TeamError(
                f"{where}: skill {command.skill!r} is not allowed for a scripted defender; "
                f"allowed: {[s.name for s in Skill if s not in BALL_SKILLS]}"
            )
        if not (isinstance(command.speed, float | int) and 0.0 < command.speed <= 1.0):
            raise TeamError(f"{where}: speed must be in (0, 1], got {command.speed!r}")
        if command.skill is Skill.MOVE_TO:
            t = command.target
            if t is None or len(t) != 2 or not all(math.isfinite(float(c)) for c in t):
                raise TeamError(f"{where}: MOVE_TO needs a finite (x, y) target, got {t!r}")
        return command
