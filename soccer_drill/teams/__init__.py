"""The kit of a team's author: everything a scripted team needs from the drill, in one place.

| need | names |
|---|---|
| the protocol and the registry | ``Team`` (one drill: ``reset(view, rng)``, ``act(view)``), ``register``, ``make_team``, ``available_teams`` and ``TeamError``; ``team_ids``, ``describe``; plugins: ``refresh``, ``broken_teams``, ``PluginWarning``, ``team_code`` |
| what a team is told and says | ``Command``, ``Skill``, ``DrillView`` and ``DrillState`` (one drill), ``PLAYER_NAMES`` and ``DrillConfig`` (its ``attackers``, ``defenders`` and ``player_names``); ``FEATURE_NAMES`` |
| many drills at once (``batch(n)``, one drill too) | ``BatchView`` (read-only arrays of every drill, the rule parameters by name), ``BatchCommands``, ``BatchRandom`` (each drill's draws), ``BatchTeam``, ``SameCommands``, ``every_drill``, ``STATE`` (a drill's record; ``state_record(players)`` for any size) |
| the skills' rules | ``rule_parameters`` and ``roll_table`` (what the rules read of a configuration, by name), ``interception_point`` and ``mark_target`` (one drill, compiled: call them in a loop over ``every_drill``), ``GUARD_DEPTH`` |
| compiled team code | ``compiled`` (numba, or plain Python with the same floats), ``hypot``, ``warms`` (compile before the team's first time-bounded call) |

Every name is importable from here (``from soccer_drill.teams import Command, Skill``); the
protocol's and the commands' are ``soccer_drill``'s own, declared public there.

A team written once in batched form (``batch(n)``) plays one drill (the single
environments) as it plays many; ``docs/plugins.md`` has a short example, and
``opponents/parametric.py`` a full one. The modules: :mod:`~soccer_drill.teams.registry`
(the protocol, :data:`~soccer_drill.teams.registry.TEAMS`), :mod:`~soccer_drill.teams.kit`
(the batched protocol), :mod:`~soccer_drill.teams.driver` (the one driver: time bound and
command checks), :mod:`~soccer_drill.teams.time_bound`.
"""

# soccer_drill's own public names, importable from the kit too (not declared again here)
from soccer_drill.commands import Command as Command
from soccer_drill.commands import Skill as Skill
from soccer_drill.config import DrillConfig as DrillConfig
from soccer_drill.rules.arrays import STATE, roll_table, rule_parameters, state_record
from soccer_drill.rules.compiled import compiled, hypot, warms
from soccer_drill.rules.features import FEATURE_NAMES
from soccer_drill.rules.motion import (
    GUARD_DEPTH,
    in_cone,  # noqa: F401  (keepaway's pass cone, for the takers)
    interception_point,
    mark_target,
)
from soccer_drill.state import BALL  # noqa: F401  (the 2v2 drill's ball index, kept importable)
from soccer_drill.state import PLAYER_NAMES as PLAYER_NAMES
from soccer_drill.state import DrillState as DrillState
from soccer_drill.state import DrillView as DrillView
from soccer_drill.teams.kit import (
    BatchCommands,
    BatchRandom,
    BatchTeam,
    BatchView,
    SameCommands,
    every_drill,
)
from soccer_drill.teams.registry import (
    PluginWarning,
    broken_teams,
    describe,
    refresh,
    team_code,
    team_ids,
)
from soccer_drill.teams.registry import Team as Team
from soccer_drill.teams.registry import TeamError as TeamError
from soccer_drill.teams.registry import available_teams as available_teams
from soccer_drill.teams.registry import make_team as make_team
from soccer_drill.teams.registry import register as register

__all__ = [
    "FEATURE_NAMES",
    "GUARD_DEPTH",
    "STATE",
    "BatchCommands",
    "BatchRandom",
    "BatchTeam",
    "BatchView",
    "PluginWarning",
    "SameCommands",
    "broken_teams",
    "compiled",
    "describe",
    "every_drill",
    "hypot",
    "interception_point",
    "mark_target",
    "refresh",
    "roll_table",
    "rule_parameters",
    "state_record",
    "team_code",
    "team_ids",
    "warms",
]
