"""The vector environments: many drills stepped together, behind Gymnasium's and PettingZoo's
conventions with a leading batch axis, over the episodes of the single environments
(:class:`~soccer_drill.envs.core.BatchCore`).

| module | holds |
|---|---|
| :mod:`~soccer_drill.vector.holder` | :class:`HolderVectorEnv`, the vector entry point of ``soccer_drill/Holder-v0`` (``gym.make_vec``), and :func:`play_episodes` |
| :mod:`~soccer_drill.vector.agents` | :class:`ParallelVectorEnv`: the parallel environment with a leading batch axis |
| :mod:`~soccer_drill.vector.memory` | how many drills, and frames of them, fit in the memory available |
| :mod:`~soccer_drill.vector.sb3` | ``HolderSB3VecEnv``: the batched holder behind Stable-Baselines3's ``VecEnv`` (needs SB3; not imported here) |
"""

from soccer_drill.vector.agents import ParallelVectorEnv
from soccer_drill.vector.holder import HolderVectorEnv, play_episodes

__all__ = ["HolderVectorEnv", "ParallelVectorEnv", "play_episodes"]
