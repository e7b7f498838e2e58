"""Scripted teams and their driver: the protocol, the registry, the checks and time bound.

| module | holds |
|---|---|
| :mod:`~soccer_drill.teams.registry` | the :class:`Team` protocol, :data:`TEAMS` (a :class:`~soccer_drill.registry.Registry`), :func:`register`, :func:`make_team`, :func:`team_code` |
| :mod:`~soccer_drill.teams.driver` | :func:`check_commands` (what a team returned, checked; the words of each refusal) and :class:`TeamDriver` (a team within its CPU-time bound) |
| :mod:`~soccer_drill.teams.batch` | the batched protocol (:class:`~soccer_drill.teams.batch.BatchView`, ``BatchCommands``, ``BatchRandom``, ``SameCommands``) and ``BatchTeamDriver`` (a team's ``batch(n)``, or one copy per drill) |
| :mod:`~soccer_drill.teams.time_bound` | the CPU-time bound of one call (which exceptions a signal delivered: :mod:`soccer_drill.interruptions`) |

The names below are this package's: what plugins and users import from
``soccer_drill.teams``.
"""

from __future__ import annotations

from soccer_drill.teams.driver import (
    SCRIPTED_SKILLS,
    TeamDriver,
    check_commands,
    resolve_team,
    skill_refused,
    speed_allowed,
    speed_refused,
    target_refused,
)
from soccer_drill.teams.registry import (
    BUILT_IN_DISTRIBUTION,
    DEFAULT_TEAM_TIMEOUT,
    ENTRY_POINT_GROUP,
    TEAM_TIMEOUT_RANGE,
    TEAMS,
    PluginWarning,
    Team,
    TeamError,
    available_teams,
    broken_teams,
    check_team_timeout,
    describe,
    make_team,
    refresh,
    register,
    team_code,
    team_ids,
    team_parameters,
)

__all__ = [
    "BUILT_IN_DISTRIBUTION",
    "DEFAULT_TEAM_TIMEOUT",
    "ENTRY_POINT_GROUP",
    "SCRIPTED_SKILLS",
    "TEAMS",
    "TEAM_TIMEOUT_RANGE",
    "PluginWarning",
    "Team",
    "TeamDriver",
    "TeamError",
    "available_teams",
    "broken_teams",
    "check_commands",
    "check_team_timeout",
    "describe",
    "make_team",
    "refresh",
    "register",
    "resolve_team",
    "skill_refused",
    "speed_allowed",
    "speed_refused",
    "target_refused",
    "team_code",
    "team_ids",
    "team_parameters",
]
