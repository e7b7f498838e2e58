"""Reference deep-RL results for the drill: PPO and masked PPO beside the fixed rules and
the tile-coded learners, by one command (``soccer-drill-reference``).

Needs torch, Stable-Baselines3 and sb3-contrib (``pip install 'soccer-drill-ilpss[integrations]'``);
nothing else in the project imports this package. Its modules, one concern each:

==========================  =========================================================
module                      concern
==========================  =========================================================
:mod:`.settings`            the settings of every run, frozen dataclasses (no torch)
:mod:`.holder`              SB3 PPO and MaskablePPO on the holder, the transfer row
:mod:`.marl_ppo`            MAPPO and IPPO on ``ParallelVectorEnv``, self-play with a pool
:mod:`.jobs`                the jobs, their keys and checks (kept, resumable)
:mod:`.page`                the results page and its figures
:mod:`.cli`                 the command line
==========================  =========================================================
"""
