"""The environments' one stack, and the single environments on it.

| module | holds |
|---|---|
| :mod:`~soccer_drill.envs.core` | :class:`~soccer_drill.envs.core.BatchCore`: the episodes of ``n`` drills (generators, team, support players) under every environment; the observations offered, the masks and the words of a refused action |
| :mod:`~soccer_drill.envs.holder` | :class:`~soccer_drill.envs.holder.HolderLoop`, the holder's SMDP over a core's drills, and :class:`~soccer_drill.envs.holder.HolderEnv` (one drill of it), registered as ``soccer_drill/Holder-v0`` |
| :mod:`~soccer_drill.envs.agents` | ``raw_env`` / ``env`` (AEC) and ``parallel_env``, one drill of a core; their docstring is the reference of spaces, rewards and arguments |
| :mod:`~soccer_drill.envs.pickling` | copies and pickles (for the code that made them), the thread lock |
"""
