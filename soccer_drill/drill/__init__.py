"""The drill without any API around it: one cycle of physics and rules, for one drill or many.

| module | holds |
|---|---|
| :mod:`~soccer_drill.drill.drills` | :class:`BatchDrill` (the cycle, written once, for ``n`` drills on arrays) and :class:`Drill` (one of them in a space of its own) |
| :mod:`~soccer_drill.drill.spaces` | the pymunk side: :class:`DrillSpace` (one drill, the ball a body too) and :class:`BatchPhysics` (the players of many drills in shared spaces) |
"""

from __future__ import annotations

from soccer_drill.drill.drills import OUTCOME_NAMES, OUTCOMES, BatchDrill, Drill, Outcome
from soccer_drill.drill.spaces import (
    DRILLS_PER_SPACE,
    BatchPhysics,
    DrillSpace,
    check_batch_order,
    check_drills_per_space,
    space_step,
)

__all__ = [
    "DRILLS_PER_SPACE",
    "OUTCOMES",
    "OUTCOME_NAMES",
    "BatchDrill",
    "BatchPhysics",
    "Drill",
    "DrillSpace",
    "Outcome",
    "check_batch_order",
    "check_drills_per_space",
    "space_step",
]
