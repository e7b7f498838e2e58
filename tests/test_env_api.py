"""The drill passes PettingZoo's and Gymnasium's own API checkers."""

from __future__ import annotations

import copy
import types
import warnings
from functools import partial

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import (
    api_test,
    max_cycles_test,
    parallel_api_test,
    parallel_seed_test,
    performance_benchmark,
    render_test,
    seed_test,
    state_test,
)
from pettingzoo.test import test_save_obs as save_obs_test  # not collected as a test

import soccer_drill

OPPONENTS = [None, "chasers"]
CONFIGURATIONS = [(o, t) for o in OPPONENTS for t in ("features", "kinematic", "full")]


def _module(**kwargs):
    """What ``max_cycles_test`` takes: a module with ``env`` and ``parallel_env``."""
    return types.SimpleNamespace(
        env=partial(soccer_drill.env, **kwargs),
        parallel_env=partial(soccer_drill.parallel_env, **kwargs),
    )


# Every function of pettingzoo.test, unmodified and with its default arguments, on the
# environments' default arguments (only the opponent and the observation type vary).
@pytest.mark.parametrize(("opponent", "obs_type"), CONFIGURATIONS)
def test_pettingzoo_aec_tests(opponent, obs_type):
    make = partial(soccer_drill.env, opponent=opponent, obs_type=obs_type)
    api_test(make())
    seed_test(make)
    render_test(make)
    state_test(make(), partial(soccer_drill.parallel_env, opponent=opponent, obs_type=obs_type)())


@pytest.mark.parametrize(("opponent", "obs_type"), CONFIGURATIONS)
def test_pettingzoo_parallel_tests(opponent, obs_type):
    make = partial(soccer_drill.parallel_env, opponent=opponent, obs_type=obs_type)
    parallel_api_test(make())
    parallel_seed_test(make)
    max_cycles_test(_module(opponent=opponent, obs_type=obs_type))


@pytest.mark.parametrize("opponent", OPPONENTS)
def test_pettingzoo_benchmark_and_save_obs(opponent, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    performance_benchmark(soccer_drill.env(opponent=opponent))  # runs for 5 s
    assert "cycles per second" in capsys.readouterr().out
    save_obs_test(soccer_drill.env(opponent=opponent))
    # Not images, so nothing is saved: the function says so and returns.
    assert "did not save the observations" in capsys.readouterr().out
    assert not (tmp_path / "saved_observations").exists()


@pytest.mark.parametrize("opponent", OPPONENTS)
def test_flat_shared_spaces_pass_api_test_without_warnings(opponent):
    """The two documented api_test warnings go away with the two options."""
    kwargs = {"opponent": opponent, "obs_format": "flat", "shared_spaces": True}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        api_test(soccer_drill.env(**kwargs))
        parallel_api_test(soccer_drill.parallel_env(**kwargs))
    messages = {str(w.message) for w in caught}
    assert "Observation is not a NumPy array" not in messages
    assert "Agents have different observation space sizes" not in messages
    assert not any("probably should be gymnasium.spaces.box" in m for m in messages)
    seed_test(partial(soccer_drill.env, **kwargs))
    parallel_seed_test(partial(soccer_drill.parallel_env, **kwargs))
    max_cycles_test(_module(**kwargs))
    state_test(soccer_drill.env(**kwargs), soccer_drill.parallel_env(**kwargs))


def test_metadata_and_spaces_are_stable():
    env = soccer_drill.env()
    assert env.metadata["is_parallelizable"] is True
    assert env.metadata["name"] == "soccer_drill_v0"
    assert env.metadata["render_fps"] > 0
    assert set(env.metadata["render_modes"]) == {"human", "rgb_array", "rgb_array_list"}
    assert env.possible_agents == ["attacker_0", "attacker_1", "defender_0", "defender_1"]
    for agent in env.possible_agents:
        assert env.observation_space(agent) is env.observation_space(agent)
        assert env.action_space(agent) is env.action_space(agent)
    assert soccer_drill.env(opponent="chasers").possible_agents == ["attacker_0", "attacker_1"]


@pytest.mark.parametrize("make", [soccer_drill.env, soccer_drill.parallel_env])
def test_the_space_dicts_pettingzoo_declares_are_read_only_views_of_the_spaces(make):
    """PettingZoo's base classes declare ``observation_spaces`` and ``action_spaces``;
    before, reading them raised AttributeError (older clients, and PettingZoo's own
    conversions' deprecated attributes, read them)."""
    from pettingzoo.utils.conversions import aec_to_parallel

    env = make(opponent="goal_guards")
    for agent in env.possible_agents:
        assert env.observation_spaces[agent] is env.observation_space(agent)
        assert env.action_spaces[agent] is env.action_space(agent)
    assert set(env.observation_spaces) == set(env.possible_agents) == set(env.action_spaces)
    with pytest.raises(TypeError):
        env.action_spaces["attacker_0"] = None
    copy.deepcopy(env).reset(seed=0)
    if make is soccer_drill.env:
        with pytest.warns(UserWarning, match="deprecated"):
            converted = aec_to_parallel(env).observation_spaces
        assert converted == dict(env.observation_spaces)


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
        with pytest.raises(ValueError, match=r"decision_cycles must be an integer in \[1, 50\]"):
            soccer_drill.HolderEnv(opponent="chasers", decision_cycles=bad)


def test_supersuit_frame_skip_draws_from_the_environment_s_seeded_generator():
    ss = pytest.importorskip("supersuit")

    def play(seed):
        env = ss.frame_skip_v0(soccer_drill.parallel_env(opponent="chasers"), (1, 3))
        obs, _ = env.reset(seed=seed)
        cycles = []
        while env.agents:
            acts = {a: int(np.flatnonzero(obs[a]["action_mask"])[0]) for a in env.agents}
            obs, _, _, _, infos = env.step(acts)
            cycles.append(env.unwrapped.drill_state.cycle)
        return cycles

    assert play(0) == play(0)
    assert soccer_drill.env().np_random is not None


def test_last_after_the_episode_ended_says_so():
    env = soccer_drill.env(opponent="chasers", max_cycles=3)
    env.reset(seed=0)
    for _ in env.agent_iter():
        obs, _, terminated, truncated, _ = env.last()
        action = None if terminated or truncated else int(np.flatnonzero(obs["action_mask"])[0])
        env.step(action)
    with pytest.raises(RuntimeError, match=r"last\(\) called after the episode ended"):
        env.last()


def test_each_observation_is_a_new_array():
    """The agents' observations of one state are computed together; each agent still gets
    an array of its own, and writing into it changes no other observation."""
    env = soccer_drill.env()
    env.reset(seed=3)
    first = {a: env.observe(a)["observation"] for a in env.agents}
    again = {a: env.observe(a)["observation"] for a in env.agents}
    for agent in env.agents:
        assert first[agent] is not again[agent]
        np.testing.assert_array_equal(first[agent], again[agent])
        first[agent][:] = -1.0
    for agent in env.agents:
        np.testing.assert_array_equal(env.observe(agent)["observation"], again[agent])
    parallel = soccer_drill.parallel_env()
    obs, _ = parallel.reset(seed=3)
    rows = [obs[a]["observation"] for a in parallel.agents]
    assert not any(np.shares_memory(x, y) for x in rows for y in rows if x is not y)
    stepped, *_ = parallel.step({a: int(np.flatnonzero(obs[a]["action_mask"])[0])
                                 for a in parallel.agents})
    after = [stepped[a]["observation"] for a in parallel.agents]
    assert not any(np.shares_memory(x, y) for x in rows + after for y in rows + after
                   if x is not y)
    for row in after:
        row[:] = -1.0
    again, *_ = parallel.step({a: int(np.flatnonzero(stepped[a]["action_mask"])[0])
                               for a in parallel.agents})
    assert not any((again[a]["observation"] == -1.0).all() for a in parallel.agents)
