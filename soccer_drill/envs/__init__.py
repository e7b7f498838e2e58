"""The single environments: PettingZoo's AEC and parallel drill, and the Gymnasium ball holder.

| module | holds |
|---|---|
| :mod:`~soccer_drill.envs.agents` | ``raw_env`` / ``env`` (AEC) and ``parallel_env``; their docstring is the reference of spaces, rewards and arguments |
| :mod:`~soccer_drill.envs.holder` | :class:`~soccer_drill.envs.holder.HolderEnv`, registered as ``soccer_drill/Holder-v0`` |
| :mod:`~soccer_drill.envs.core` | :class:`~soccer_drill.envs.core.DrillCore`: what the three share (team, seeding, spaces, masks, one cycle); the masks and the words of a refused action, which the batched environments share too |
"""
