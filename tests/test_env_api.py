"""The drill passes PettingZoo's and Gymnasium's own API checkers."""

from __future__ import annotations

import types
import warnings
from functools import partial

import gymnasium as gym
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import (
    api_test,
    max_cycles_test,
    parallel_api_test,
    parallel_seed_test,
    render_test,
    seed_test,
)

import soccer_drill

OPPONENTS = [None, "chasers"]


@pytest.mark.parametrize("opponent", OPPONENTS)
@pytest.mark.parametrize("obs_type", ["features", "kinematic"])
def test_api(opponent, obs_type):
    api_test(soccer_drill.env(opponent=opponent, obs_type=obs_type), num_cycles=400)


@pytest.mark.parametrize("opponent", OPPONENTS)
def test_parallel_api(opponent):
    parallel_api_test(soccer_drill.parallel_env(opponent=opponent), num_cycles=400)


@pytest.mark.parametrize("opponent", OPPONENTS)
def test_seed(opponent):
    seed_test(partial(soccer_drill.env, opponent=opponent), num_cycles=300)


@pytest.mark.parametrize("opponent", OPPONENTS)
def test_parallel_seed(opponent):
    # parallel_seed_test samples without masks: see test_max_cycles. (It also stops after one
    # step; tests/test_determinism.py checks whole episodes.)
    parallel_seed_test(
        partial(soccer_drill.parallel_env, opponent=opponent, illegal_action="default"),
        num_cycles=300,
    )


@pytest.mark.parametrize("opponent", OPPONENTS)
def test_render(opponent):
    render_test(partial(soccer_drill.env, opponent=opponent))


@pytest.mark.parametrize("opponent", OPPONENTS)
def test_max_cycles(opponent):
    # max_cycles_test samples actions without their masks, so it runs with the documented
    # illegal_action="default" (a masked action becomes the role's default action).
    module = types.SimpleNamespace(
        env=partial(soccer_drill.env, opponent=opponent, illegal_action="default"),
        parallel_env=partial(
            soccer_drill.parallel_env, opponent=opponent, illegal_action="default"
        ),
    )
    max_cycles_test(module)


def test_metadata_and_spaces_are_stable():
    env = soccer_drill.env()
    assert env.metadata["is_parallelizable"] is True
    assert env.metadata["name"] == "soccer_drill_v0"
    assert env.metadata["render_fps"] > 0
    assert set(env.metadata["render_modes"]) == {"human", "rgb_array"}
    assert env.possible_agents == ["attacker_0", "attacker_1", "defender_0", "defender_1"]
    for agent in env.possible_agents:
        assert env.observation_space(agent) is env.observation_space(agent)
        assert env.action_space(agent) is env.action_space(agent)
    assert soccer_drill.env(opponent="chasers").possible_agents == ["attacker_0", "attacker_1"]


def test_agents_empty_at_episode_end():
    env = soccer_drill.env(opponent="chasers", max_cycles=30)
    env.reset(seed=3)
    for agent in env.agent_iter():
        obs, _, term, trunc, _ = env.last()
        env.step(None if term or trunc else env.action_space(agent).sample(obs["action_mask"]))
    assert env.agents == []
    with pytest.raises(RuntimeError, match="episode ended"):
        env.step(0)


def test_holder_env_check_env():
    env = gym.make("soccer_drill/Holder-v0", opponent="chasers")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any checker warning fails the test
        check_env(env.unwrapped, skip_render_check=False)
    check_env(gym.make("soccer_drill/Holder-v0", render_mode="rgb_array").unwrapped)


def test_holder_env_info_and_duration():
    env = gym.make("soccer_drill/Holder-v0", opponent="chasers")
    obs, info = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    total, outcome = 0, None
    for _ in range(500):
        obs, reward, term, trunc, info = env.step(1)  # always pass: multi-cycle steps
        assert info["duration"] >= 1
        total += info["duration"]
        assert info["cycles"] == total
        if term or trunc:
            outcome = info["outcome"]
            break
    assert outcome in {"success", "interception", "out", "timeout"}
    assert trunc == (outcome == "timeout")


def test_holder_decision_cycles():
    for cycles in (1, 4):
        env = soccer_drill.HolderEnv(opponent="chasers", decision_cycles=cycles)
        env.reset(seed=0)
        durations = []
        for _ in range(30):
            _, _, term, trunc, info = env.step(0)  # HOLD
            durations.append(info["duration"])
            if term or trunc:
                break
        assert max(durations) <= cycles
        assert durations[0] == cycles  # nobody reaches the holder in the first cycles
    for bad in (0, 51, 2.5, True):
        with pytest.raises(ValueError, match=r"decision_cycles must be an integer in 1\.\.50"):
            soccer_drill.HolderEnv(opponent="chasers", decision_cycles=bad)
