"""Scripted defending teams for soccer_drill, registered as ``soccer_drill.opponents`` plugins.

| id | team |
|----|------|
| ``interceptors_press`` | paper team 1: two interceptors, both press the ball |
| ``interceptors_cover`` | paper team 2: one presses, the other marks the passing lane |
| ``interceptor_guard`` | paper team 3: one interceptor, one goal-line guard |
| ``goal_guards`` | paper team 4: two guards who seldom leave the line |
| ``chasers`` | both defenders chase the ball (the simplest team) |
| ``parametric`` | the family the paper teams belong to (keyword parameters) |

:func:`sample_opponents` draws distinct members of the family for long streams.
"""

from opponents.chasers import Chasers
from opponents.paper import GoalGuards, InterceptorGuard, InterceptorsCover, InterceptorsPress
from opponents.parametric import ParametricTeam, sample_opponents, spec_label

PAPER_TEAMS: tuple[str, str, str, str] = (
    "interceptors_press",
    "interceptors_cover",
    "interceptor_guard",
    "goal_guards",
)
"""Ids of the paper's four teams, in the paper's order (team 1 to team 4)."""

__all__ = [
    "PAPER_TEAMS",
    "Chasers",
    "GoalGuards",
    "InterceptorGuard",
    "InterceptorsCover",
    "InterceptorsPress",
    "ParametricTeam",
    "sample_opponents",
    "spec_label",
]
