"""The tasks the drill's physics plays: what the attackers try to do, as data.

| task | the attackers (keepers) | episode end | reward of the attackers | starts |
|---|---|---|---|---|
| ``drill`` | carry the ball over the goal line (``y = 0``) | success, interception, out, timeout | at the end: ``DrillConfig.reward_*`` (success paid by where the line is crossed) | :func:`drill_starts` |
| ``keepaway`` | keep the ball inside the square region as long as they can (RoboCup keepaway, Stone, Sutton and Kuhlmann 2005) | a taker gains possession (interception), the ball leaves the region (out), timeout (a truncation) | the seconds the episode runs: ``cycle_seconds`` per cycle, nothing at the end | :func:`keepaway_starts` |

A :class:`Task` is pure data, read by the configuration (:class:`~soccer_drill.config.DrillConfig`
``task``: its starts), the rules (the goal line, through the rule parameters) and the
environments (the reward); what each task's players do is in
:mod:`soccer_drill.rules.task_rules`. A new task is one entry of :data:`TASKS` and one of
:data:`~soccer_drill.rules.task_rules.TASK_RULES`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

Point = tuple[float, float]

PAPER_STARTS: dict[str, tuple[Point, ...]] = {
    "attacker_starts": ((4.0, 31.0), (31.0, 31.0)),
    "defender_starts": ((13.0, 9.0), (22.0, 9.0)),
}
"""The nominal starts of the paper's drill: two attackers in the top corners, two
defenders near the goal line."""


def drill_starts(name: str, count: int, field_size: float) -> tuple[Point, ...]:
    """The drill's nominal starts of ``count`` attackers (``name`` ``"attacker_starts"``)
    or defenders (``"defender_starts"``) in a region of ``field_size``: the attackers
    spread evenly along a line ``4 / 35`` of the size below the top, from ``4 / 35`` of it
    in from each touchline (one: the centre); the defenders ``9 / 35`` of the size apart,
    centred, on a line ``9 / 35`` of it above the goal line. In the 35 m region two
    attackers start at ``(4, 31)`` and ``(31, 31)``, two defenders at ``(13, 9)`` and
    ``(22, 9)`` (the paper's drill, :data:`PAPER_STARTS`). Two attackers or two defenders
    keep these points in a region of any size, as they always have (a configuration
    written before the drill had other sizes starts where it did)."""
    if count == 2:
        return PAPER_STARTS[name]
    centre = field_size / 2
    if name == "attacker_starts":
        edge = field_size * 4.0 / 35.0
        top = field_size - edge
        if count == 1:
            return ((centre, top),)
        step = (top - edge) / (count - 1)
        return tuple((edge + k * step if k < count - 1 else top, top) for k in range(count))
    gap = field_size * 9.0 / 35.0
    return tuple((centre + (k - (count - 1) / 2) * gap, gap) for k in range(count))


KEEPAWAY_INSET = 2.5
"""How far inside the region's corners the keepaway players start, metres."""
TAKER_SPACING = 1.5
"""How far apart the takers start along the bottom edge, metres."""


def keepaway_starts(name: str, count: int, field_size: float) -> tuple[Point, ...]:
    """Keepaway's nominal starts: the keepers (attackers) spread evenly along the path from
    the bottom-right corner up to the top-right and across to the top-left (three keepers:
    one in each of those corners), the takers (defenders) together in the bottom-left
    corner, :data:`TAKER_SPACING` apart along the bottom edge, all :data:`KEEPAWAY_INSET`
    inside the region. The takers then have to run to the ball, as in keepaway."""
    lo, hi = KEEPAWAY_INSET, field_size - KEEPAWAY_INSET
    if name == "defender_starts":
        return tuple((lo + k * TAKER_SPACING, lo) for k in range(count))
    side = hi - lo
    points = []
    for k in range(count):
        along = 2.0 * side * k / (count - 1) if count > 1 else side
        if along <= side:  # up the right edge
            points.append((hi, lo + along))
        else:  # then across the top
            points.append((hi - (along - side), hi))
    return tuple(points)


@dataclass(frozen=True)
class Task:
    """What the attackers of a drill try to do, and how they are paid for it."""

    name: str
    description: str
    goal_line: bool
    """Whether holding the ball on or past ``y = 0`` is a success (else the line is the
    region's edge like the others: the ball beyond it is out)."""
    outcome_rewards: bool
    """Whether the end of an episode pays the configuration's outcome rewards
    (``reward_success_*``, ``reward_failure``, ``reward_timeout``); else nothing."""
    reward_per_second: float
    """What the attackers are paid per second the episode runs (keepaway: 1, its
    reward is the time the keepers hold the ball)."""
    starts: Callable[[str, int, float], tuple[Point, ...]]
    """``starts(name, count, field_size)``: the nominal starts when the configuration
    gives none (``name``: ``"attacker_starts"`` or ``"defender_starts"``)."""


TASKS: dict[str, Task] = {
    task.name: task for task in (
        Task("drill", "carry the ball over the goal line", goal_line=True,
             outcome_rewards=True, reward_per_second=0.0, starts=drill_starts),
        Task("keepaway", "keep the ball inside the region as long as possible (keepaway)",
             goal_line=False, outcome_rewards=False, reward_per_second=1.0,
             starts=keepaway_starts),
    )
}
"""Every task, by name (``DrillConfig.task``)."""
