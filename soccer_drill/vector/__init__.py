"""The vector environments: many drills stepped together, behind Gymnasium's and PettingZoo's
conventions with a leading batch axis.

| module | holds |
|---|---|
| :mod:`~soccer_drill.vector.holder` | :class:`HolderVectorEnv`, the vector entry point of ``soccer_drill/Holder-v0`` (``gym.make_vec``), and :func:`play_episodes` |
| :mod:`~soccer_drill.vector.agents` | :class:`ParallelVectorEnv`: the parallel environment with a leading batch axis |
| :mod:`~soccer_drill.vector.core` | :class:`~soccer_drill.vector.core.BatchCore`: what both share (drills, seed streams, team, support players) |
| :mod:`~soccer_drill.vector.sb3` | ``HolderSB3VecEnv``: the batched holder behind Stable-Baselines3's ``VecEnv`` (needs SB3; not imported here) |
"""

from __future__ import annotations

from soccer_drill.vector.agents import ParallelVectorEnv
from soccer_drill.vector.holder import (
    RESET_OPTIONS,
    HolderVectorEnv,
    check_drill_indices,
    check_reset_options,
    first_non_integer,
    play_episodes,
)

__all__ = [
    "RESET_OPTIONS",
    "HolderVectorEnv",
    "ParallelVectorEnv",
    "check_drill_indices",
    "check_reset_options",
    "first_non_integer",
    "play_episodes",
]
