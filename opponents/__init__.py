"""Scripted defending teams for soccer_drill, registered as ``soccer_drill.opponents`` plugins.

| id | team |
|----|------|
| ``interceptors_press`` | paper team 1: two interceptors, both press the ball |
| ``interceptors_cover`` | paper team 2: one presses, the other marks the passing lane |
| ``interceptor_guard`` | paper team 3: one interceptor, one goal-line guard |
| ``goal_guards`` | paper team 4: two guards who seldom leave the line |
| ``chasers`` | both defenders chase the ball (the simplest team) |
| ``parametric`` | the family the paper teams belong to (keyword parameters) |
| ``contain_cover`` | a slow presser that waits in the holder's path and a close marker |
| ``press_far_contain_near`` | ``interceptors_press`` beyond 12 m of the goal line, ``contain_cover`` within it |
| ``contain_left_press_right`` | ``contain_cover`` in the left half, ``interceptors_press`` in the right |
| ``press_left_contain_right`` | ``interceptors_press`` in the left half, ``contain_cover`` in the right |

:class:`RegionTeam` plays one team on each side of a :class:`Region`;
:class:`RegionRule` plays one fixed holder rule on each side (``docs/regions.md``).

:func:`sample_opponents` draws distinct members of the family for long streams.
"""

from opponents.parametric import ParametricTeam, sample_opponents, spec_label
from opponents.regions import Region, RegionRule, RegionTeam

PAPER_TEAMS: tuple[str, str, str, str] = (
    "interceptors_press",
    "interceptors_cover",
    "interceptor_guard",
    "goal_guards",
)
"""Ids of the paper's four teams, in the paper's order (team 1 to team 4)."""

__all__ = [
    "PAPER_TEAMS",
    "ParametricTeam",
    "Region",
    "RegionRule",
    "RegionTeam",
    "sample_opponents",
    "spec_label",
]
