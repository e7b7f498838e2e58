"""One drill of the batched drill in a space of its own (the single environments' physics),
stepped with one ``Command`` per player: what the tests of the rules drive directly."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from soccer_drill.commands import Command
from soccer_drill.config import DrillConfig
from soccer_drill.drill.drills import BatchDrill
from soccer_drill.drill.spaces import DrillSpace
from soccer_drill.rules.arrays import OUTCOME_NAMES
from soccer_drill.state import DrillState

_ONE = np.zeros(1, dtype=np.int64)
_ACTIVE = np.ones(1, dtype=bool)


class OneDrill:
    """``reset(rng)`` and ``step(commands, rng)`` give the drill's :class:`DrillState`;
    ``outcome`` is ``None`` while the episode runs."""

    def __init__(self, config: DrillConfig | None = None) -> None:
        self.config = config or DrillConfig()
        self.batch = BatchDrill(1, self.config, physics=DrillSpace(self.config))
        self.physics = self.batch.physics

    @property
    def state(self) -> DrillState:
        return self.batch.state_of(0)

    @property
    def outcome(self) -> str | None:
        return OUTCOME_NAMES[self.batch.outcome[0]]

    @property
    def attacker_reward(self) -> float:
        return float(self.batch.attacker_reward[0])

    def reset(self, rng: np.random.Generator) -> DrillState:
        self.batch.reset(_ONE, [rng])
        return self.state

    def step(self, commands: Sequence[Command], rng: np.random.Generator) -> DrillState:
        for k, command in enumerate(commands):
            self.batch.skill[0, k] = int(command.skill)
            self.batch.speed[0, k] = float(command.speed)
            if command.target is not None:
                self.batch.target[0, k] = command.target
        self.batch.step(_ACTIVE, [rng])
        return self.state
