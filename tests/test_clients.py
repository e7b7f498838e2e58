"""The four-player drill with its default arguments in the clients that need every agent
to have the same spaces (SuperSuit's vector environments here; Tianshou and RLlib in
docs/integrations.md's recipes), and the per-role spaces one argument away."""

from __future__ import annotations

import numpy as np
import pytest
import supersuit as ss

import soccer_drill


@pytest.mark.parametrize("make", [soccer_drill.env, soccer_drill.parallel_env])
def test_with_no_opponent_every_agent_has_the_same_spaces_by_default(make):
    env = make()
    agents = env.possible_agents
    assert len(agents) == 4
    for agent in agents:
        assert env.observation_space(agent) == env.observation_space(agents[0])
        assert env.action_space(agent) == env.action_space(agents[0])
    assert env.action_space("defender_0").n == 5
    per_role = make(shared_spaces=False)
    assert per_role.action_space("defender_0").n == 3
    assert per_role.observation_space("defender_0") != per_role.observation_space("attacker_0")


def test_with_an_opponent_the_default_spaces_are_the_attackers_own():
    env = soccer_drill.parallel_env(opponent="chasers")
    plain = soccer_drill.parallel_env(opponent="chasers", shared_spaces=False)
    for agent in env.possible_agents:
        assert env.observation_space(agent) == plain.observation_space(agent)  # no role flag
    obs, _ = env.reset(seed=0)
    expected, _ = plain.reset(seed=0)
    for agent in env.agents:
        np.testing.assert_array_equal(obs[agent]["observation"], expected[agent]["observation"])


@pytest.mark.parametrize("obs_format", ["dict", "flat"])
def test_supersuit_vector_envs_take_the_four_player_drill_with_defaults(obs_format):
    env = soccer_drill.parallel_env(obs_format=obs_format)
    vec = ss.concat_vec_envs_v1(ss.pettingzoo_env_to_vec_env_v1(env), 2, num_cpus=1,
                                base_class="gymnasium")
    vec.action_space.seed(0)
    vec.reset(seed=0)
    ended = 0
    for _ in range(150):
        actions = np.array([vec.action_space.sample() for _ in range(vec.num_envs)])
        _, _, terms, truncs, _ = vec.step(actions)
        ended += int(np.sum(terms | truncs))
    vec.close()
    assert vec.num_envs == 8 and ended > 0
