"""What each task's players do, and what its ball holder sees and may do: one entry per
task of :data:`~soccer_drill.tasks.TASKS`.

| task | holder's observation | holder's actions | keepers/attackers off the ball |
|---|---|---|---|
| ``drill`` | :data:`~soccer_drill.rules.features.HOLDER_FEATURES` (the paper's 9 at 2v2) | ``HOLD``, a pass per teammate, ``DRIBBLE`` | :class:`~soccer_drill.rules.support.SupportDraws` (a support spot, moved at random) |
| ``keepaway`` | :data:`KEEPAWAY_STATE` (keepaway's 13 at 3v2, 19 at 4v3) | ``HOLD``, a pass per teammate (keepaway has no dribble) | :class:`~soccer_drill.rules.keepaway.GetOpen` (keepaway's ``GetOpen``) |

The environments read this table (the holder's SMDP, the episodes' core); the rules stay
written once for one drill's records.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from soccer_drill.commands import holder_action_names
from soccer_drill.config import DrillConfig
from soccer_drill.drill.drills import BatchDrill
from soccer_drill.rules.arrays import rule_parameters
from soccer_drill.rules.compiled import warms
from soccer_drill.rules.features import HOLDER_FEATURES, ObservationType
from soccer_drill.rules.keepaway import GetOpen, keepaway_bounds, keepaway_states_of_drills
from soccer_drill.rules.support import SupportDraws
from soccer_drill.tasks import TASKS


def keepaway_action_names(attackers: int) -> tuple[str, ...]:
    """The keeper with the ball's actions: ``HOLD``, then a pass to each other keeper,
    nearest first (``PASS_1``, ``PASS_2``, ...): keepaway's, without a dribble."""
    return ("HOLD", *(f"PASS_{k}" for k in range(1, attackers)))


KEEPAWAY_STATE = ObservationType(
    13, keepaway_bounds, keepaway_states_of_drills,
    "keepaway's state variables of the keeper with the ball (13 at 3v2, 19 at 4v3: "
    "soccer_drill.rules.keepaway)")
"""The keeper with the ball's observation: keepaway's state variables."""


@dataclass(frozen=True)
class TaskRules:
    """What one task's ball holder sees and may do, and who drives its other attackers."""

    holder_observation: ObservationType
    """The holder's observation (``HolderEnv``'s ``Box``)."""
    holder_actions: Callable[[int], tuple[str, ...]]
    """``holder_actions(attackers)``: the names of the holder's actions, in index order
    (action 0 is ``HOLD``, then the passes, nearest teammate first; ``DRIBBLE`` last
    where the task has it)."""
    support: Callable[[int, DrillConfig], Any]
    """``support(n, config)``: the behaviour of the attackers no agent controls in ``n``
    drills (``seed(drills, seeds)``, ``commands(state, cycle, supporting, size)``)."""


TASK_RULES: dict[str, TaskRules] = {
    "drill": TaskRules(HOLDER_FEATURES, holder_action_names,
                       lambda n, config: SupportDraws(n)),
    "keepaway": TaskRules(KEEPAWAY_STATE, keepaway_action_names, GetOpen),
}
"""Each task's rules, by name (``DrillConfig.task``)."""


def task_rules(config: DrillConfig) -> TaskRules:
    """The rules of ``config``'s task."""
    return TASK_RULES[config.task]


@functools.lru_cache(maxsize=64)
def cycle_reward(config: DrillConfig) -> float:
    """What the attackers are paid per cycle the episode runs (0 in the drill; keepaway:
    ``cycle_seconds``)."""
    return TASKS[config.task].reward_per_second * config.cycle_seconds


@warms
def _keepaway_rules(config: DrillConfig | None) -> None:
    """Keepaway's compiled rules with their callers' arrays (a keepaway configuration's
    only): the state variables of the single and the batched environments, the keepers
    off the ball."""
    if config is None or config.task != "keepaway":
        return
    n = 2
    batch = BatchDrill(n, config)
    every = np.arange(n)
    batch.reset(every, [np.random.default_rng(k) for k in range(n)])
    params = rule_parameters(config)
    low, high = (b.astype(np.float64) for b in keepaway_bounds(config))
    out = np.empty((n, len(low)), np.float32)
    fixed = every.copy()
    fixed.flags.writeable = False
    # the state is a keeper's: with one keeper, the second drill's is keeper 0 too
    keepers = every % config.attackers
    fixed_keepers = keepers.copy()
    fixed_keepers.flags.writeable = False
    for rows, players in ((fixed, fixed_keepers), (every, keepers), (fixed, keepers)):
        keepaway_states_of_drills(out, batch.state, rows, players, params, low, high)
    steps_supporting = np.zeros(n, dtype=[("s", np.int8, (config.attackers,))])["s"]
    for supporting in (steps_supporting, np.ones((n, config.attackers), dtype=np.int8)):
        supporting[:] = 1
        GetOpen(n, config).commands(batch.state, batch.commands, supporting, config.field_size)
