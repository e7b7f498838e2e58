"""soccer_drill: the 2v2 drill of the ILPSS paper, with PettingZoo and Gymnasium APIs.

>>> import soccer_drill
>>> aec = soccer_drill.env(opponent="chasers")          # PettingZoo AEC
>>> par = soccer_drill.parallel_env()                   # PettingZoo parallel, 4 agents
>>> import gymnasium as gym
>>> holder = gym.make("soccer_drill/Holder-v0", opponent="chasers")  # the ball holder's SMDP
"""

from __future__ import annotations

import gymnasium

from soccer_drill.commands import Command, Skill
from soccer_drill.config import DrillConfig
from soccer_drill.envs.agents import env, parallel_env, raw_env
from soccer_drill.envs.holder import HolderEnv
from soccer_drill.state import PLAYER_NAMES, DrillState, DrillView
from soccer_drill.teams.registry import Team, TeamError, available_teams, make_team, register

__all__ = [
    "PLAYER_NAMES",
    "Command",
    "DrillConfig",
    "DrillState",
    "DrillView",
    "HolderEnv",
    "Skill",
    "Team",
    "TeamError",
    "available_teams",
    "env",
    "make_team",
    "parallel_env",
    "raw_env",
    "register",
]

HOLDER_ENV_ID = "soccer_drill/Holder-v0"
if HOLDER_ENV_ID not in gymnasium.registry:
    gymnasium.register(
        id=HOLDER_ENV_ID,
        entry_point="soccer_drill.envs.holder:HolderEnv",
        vector_entry_point="soccer_drill.vector.holder:HolderVectorEnv",
    )

from soccer_drill import scenarios as _scenarios  # noqa: E402  (the named scenarios' ids)

_scenarios._register()
