"""warm_up() compiles every rule with the types the environments pass: after it, episodes
through every environment compile nothing new (a compile there would fall inside a team's
time-bounded call, or in the middle of a timed run).

Run in a fresh interpreter: in the test process, earlier tests have already compiled
whatever they ran.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from soccer_drill.rules.compiled import COMPILED

_EPISODES = r"""
import json, sys
import gymnasium as gym
import numpy as np
from numba.core.registry import CPUDispatcher

import soccer_drill
from soccer_drill import policies
from soccer_drill.rules.first_use import warm_up
from soccer_drill.vector import ParallelVectorEnv, play_episodes


def signatures():
    return {f"{name}.{key}": sorted(map(str, value.signatures))
            for name, module in list(sys.modules.items())
            if name.startswith(("soccer_drill", "opponents")) and module is not None
            for key, value in vars(module).items() if isinstance(value, CPUDispatcher)}


def pick(rng, mask):
    return int(rng.choice(np.flatnonzero(mask)))


TEAMS = ("chasers", "goal_guards", "parametric")
for team in TEAMS:  # a team's module, imported, registers its own warmer
    soccer_drill.make_team(team)
warm_up()
before = signatures()
rng = np.random.default_rng(0)
for team in TEAMS:
    for obs_type in ("features", "kinematic", "full"):
        aec = soccer_drill.env(opponent=team, obs_type=obs_type)
        aec.reset(seed=1)
        for agent in aec.agent_iter(600):
            obs, _, term, trunc, info = aec.last()
            aec.step(None if term or trunc else pick(rng, obs["action_mask"]))
            aec.state()
        vec = ParallelVectorEnv(num_envs=3, opponent=team, obs_type=obs_type)
        obs, _ = vec.reset(seed=2)
        for _ in range(150):
            obs, *_ = vec.step({a: np.array([pick(rng, m) for m in o["action_mask"]])
                                for a, o in obs.items()})
            vec.state()
    par = soccer_drill.parallel_env(opponent=team)
    obs, _ = par.reset(seed=3)
    while par.agents:
        obs, *_ = par.step({a: pick(rng, o["action_mask"]) for a, o in obs.items()})
    holder = gym.make("soccer_drill/Holder-v0", opponent=team)
    for seed in range(4, 8):
        holder.reset(seed=seed)
        done = False
        while not done:
            _, _, term, trunc, _ = holder.step(int(rng.integers(3)))
            done = term or trunc
    for n in (1, 3):
        holders = gym.make_vec("soccer_drill/Holder-v0", num_envs=n, opponent=team)
        holders.reset(seed=8)
        for _ in range(100):
            holders.step(rng.integers(3, size=n))
        play_episodes(holders, policies.random_policy, range(10, 16))
        holders.close()
for n in (1, 3):  # scripted attacks: the holder loop in the multi-agent drill
    vec = ParallelVectorEnv(num_envs=n, attack="mixed_rules", obs_type="full")
    obs, _ = vec.reset(seed=9)
    for _ in range(150):
        obs, *_ = vec.step({a: np.array([pick(rng, m) for m in o["action_mask"]])
                            for a, o in obs.items()})
after = signatures()
print(json.dumps({k: sorted(set(v) - set(before.get(k, ()))) for k, v in after.items()
                  if set(v) - set(before.get(k, ()))}))
"""


@pytest.mark.skipif(not COMPILED, reason="the rules run as plain Python")
def test_episodes_after_warm_up_compile_nothing_new():
    done = subprocess.run([sys.executable, "-c", _EPISODES], capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout.strip().splitlines()[-1]) == {}


_EDGES = r"""
import sys
import numpy as np
import soccer_drill
from soccer_drill.vector import HolderVectorEnv, ParallelVectorEnv

config = {"max_cycles": 1} if sys.argv[1] == "one cycle" else {"task": "keepaway", "attackers": 1}
team = {} if sys.argv[1] == "one cycle" else {"opponent": "keepaway_takers"}
for size in ({}, {"attackers": 3}) if sys.argv[1] == "one cycle" else ({},):
    cfg = {**config, **size}  # the first environment of its size in this process
    holder = soccer_drill.HolderEnv(config=cfg, **team)
    holder.reset(seed=0)
    holder.step(0)
    par = soccer_drill.parallel_env(config=cfg, **team)
    obs, _ = par.reset(seed=1)
    while par.agents:
        obs, *_ = par.step({a: int(np.flatnonzero(o["action_mask"])[0]) for a, o in obs.items()})
    for vec in (HolderVectorEnv(num_envs=2, config=cfg, **team),
                ParallelVectorEnv(num_envs=2, config=cfg, **team)):
        vec.reset(seed=2)
print("played")
"""


@pytest.mark.parametrize("case", ["one cycle", "one keeper"])
def test_the_first_environment_of_an_edge_configuration_is_made_and_plays(case):
    """A process's first environment of a size warms the rules up with its configuration:
    with ``max_cycles=1`` the warm-up's two steps used to run past the episode's end
    (``RuntimeError``), and keepaway with one keeper warmed the state of a taker as if a
    keeper, writing past the end of its row (the process aborted)."""
    done = subprocess.run([sys.executable, "-c", _EDGES, case], capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().endswith("played")


@pytest.mark.skipif(not COMPILED, reason="warm-ups run only with the compiled rules")
@pytest.mark.parametrize("module, raised", [("my_plugin.teams", False), ("opponents.mine", True)])
def test_a_plugins_failing_warm_up_is_its_own_failure(module, raised):
    # before, one plugin's failing @warms function made every environment of the process
    # fail (chasers' too) with the plugin's raw exception
    from soccer_drill.envs.holder import HolderEnv
    from soccer_drill.registry import PluginWarning
    from soccer_drill.rules import compiled

    def broken(config):
        raise IndexError("a typo in a warm-up")

    broken.__module__ = module
    compiled.warms(broken)
    try:
        if raised:  # this project's own warm-up failing is a defect, raised
            with pytest.raises(IndexError, match="a typo"):
                HolderEnv(opponent="chasers")
        else:
            with pytest.warns(PluginWarning, match=rf"warm-up {module}:.*broken .*failed and "
                                                   r"is skipped: IndexError"):
                env = HolderEnv(opponent="chasers")
            env.reset(seed=0)
            env.step(0)
    finally:
        compiled._warmers.remove(broken)
