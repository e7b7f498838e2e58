"""Flat observations, shared spaces, the global state and errors before reset."""

from __future__ import annotations

import numpy as np
import pytest

import soccer_drill
from soccer_drill.rules.features import STATE_SIZE


def _legal(mask: np.ndarray, rng: np.random.Generator) -> int:
    return int(rng.choice(np.flatnonzero(mask)))


@pytest.mark.parametrize("opponent", [None, "chasers"])
def test_flat_aec_observation_is_the_box_and_the_mask_is_in_infos(opponent):
    flat = soccer_drill.env(opponent=opponent, obs_format="flat")
    nested = soccer_drill.env(opponent=opponent)
    for agent in flat.possible_agents:
        assert flat.observation_space(agent) == nested.observation_space(agent)["observation"]
    flat.reset(seed=3)
    nested.reset(seed=3)
    rng = np.random.default_rng(0)
    turns = 0
    for agent in flat.agent_iter():
        obs, reward, term, trunc, info = flat.last()
        expected, *_ = nested.last()
        np.testing.assert_array_equal(obs, expected["observation"])
        assert flat.observation_space(agent).contains(obs)
        np.testing.assert_array_equal(info["action_mask"], expected["action_mask"])
        np.testing.assert_array_equal(flat.action_mask(), expected["action_mask"])
        np.testing.assert_array_equal(flat.action_mask(agent), expected["action_mask"])
        action = None if term or trunc else _legal(info["action_mask"], rng)
        flat.step(action)
        nested.step(action)
        turns += 1
    assert turns > 20 and info["outcome"] in {"success", "interception", "out", "timeout"}


@pytest.mark.parametrize("scenario", ["drill_1v1", "drill_2v2"])
def test_flat_aec_masks_in_the_last_infos_are_those_after_the_last_cycle(scenario):
    """The cycle that ends an episode may move the ball (an interception, a tackle): the
    infos' masks then are the new holder's, as ``action_mask`` and ``parallel_env`` say,
    so PettingZoo's conversion of the AEC form gives the parallel form's infos."""
    from pettingzoo.utils.conversions import aec_to_parallel

    from soccer_drill import scenarios

    native = scenarios.parallel_env(scenario, obs_format="flat", opponent="chasers")
    converted = aec_to_parallel(scenarios.env(scenario, obs_format="flat", opponent="chasers"))
    rng = np.random.default_rng(1)
    moved = 0
    for episode in range(30):
        _, infos = native.reset(seed=episode)
        converted.reset(seed=episode)
        while native.agents:
            before = {a: infos[a]["action_mask"] for a in native.agents}
            actions = {a: _legal(before[a], rng) for a in native.agents}
            _, _, _, _, infos = native.step(actions)
            _, _, _, _, converted_infos = converted.step(actions)
            for a in actions:
                np.testing.assert_array_equal(converted_infos[a]["action_mask"],
                                              infos[a]["action_mask"])
        moved += any(not np.array_equal(before[a], infos[a]["action_mask"]) for a in before)
    assert moved  # some episode's last cycle moved the ball


def test_flat_parallel_masks_follow_possession():
    flat = soccer_drill.parallel_env(obs_format="flat")
    nested = soccer_drill.parallel_env()
    obs, infos = flat.reset(seed=5)
    expected, _ = nested.reset(seed=5)
    rng = np.random.default_rng(1)
    masks_seen = set()
    while flat.agents:
        for a in flat.agents:
            np.testing.assert_array_equal(obs[a], expected[a]["observation"])
            np.testing.assert_array_equal(infos[a]["action_mask"], expected[a]["action_mask"])
            np.testing.assert_array_equal(flat.action_mask(a), expected[a]["action_mask"])
            masks_seen.add((a, infos[a]["action_mask"].tobytes()))
        actions = {a: _legal(infos[a]["action_mask"], rng) for a in flat.agents}
        obs, _, _, _, infos = flat.step(actions)
        expected, *_ = nested.step(actions)
    assert len({m for a, m in masks_seen if a == "attacker_0"}) == 2  # holder and off the ball


@pytest.mark.parametrize("obs_type", ["features", "kinematic"])
def test_shared_spaces_give_every_agent_the_same_spaces_and_a_role_flag(obs_type):
    env = soccer_drill.parallel_env(obs_type=obs_type, shared_spaces=True)
    plain = soccer_drill.parallel_env(obs_type=obs_type, shared_spaces=False)
    agents = env.possible_agents
    assert len({repr(env.observation_space(a)) for a in agents}) == 1
    assert all(env.observation_space(a) == env.observation_space(agents[0]) for a in agents)
    assert all(env.action_space(a) == env.action_space(agents[0]) for a in agents)
    assert env.action_space("defender_0").n == 5
    size = plain.observation_space("attacker_0")["observation"].shape[0]
    assert env.observation_space("defender_1")["observation"].shape == (size + 1,)
    obs, _ = env.reset(seed=2)
    reference, _ = plain.reset(seed=2)
    for a in agents:
        np.testing.assert_array_equal(obs[a]["observation"][:-1], reference[a]["observation"])
        assert obs[a]["observation"][-1] == (1.0 if a.startswith("attacker") else 0.0)
    np.testing.assert_array_equal(obs["defender_0"]["action_mask"], [1, 1, 1, 0, 0])
    actions = {a: int(np.flatnonzero(obs[a]["action_mask"])[0]) for a in agents}
    # A defender's padding action is masked: replaced by INTERCEPT and reported.
    _, _, _, _, infos = env.step({**actions, "defender_0": 3, "defender_1": 0})
    assert infos["defender_0"] == {"illegal_action": 3, "action_taken": 0}
    assert infos["defender_1"] == {}
    # The replacement plays exactly as the action it became.
    plain.step({**actions, "defender_0": 0, "defender_1": 0})
    np.testing.assert_array_equal(env.state(), plain.state())


def test_global_state_layout():
    env = soccer_drill.env(opponent="chasers", max_cycles=60)
    env.reset(seed=4)
    rng = np.random.default_rng(4)
    assert env.state_space.shape == (STATE_SIZE,)
    seen_holders, seen_lockout = set(), False
    for _agent in env.agent_iter():
        obs, _, term, trunc, _ = env.last()
        state = env.state()
        s = env.drill_state
        assert env.state_space.contains(state)
        for body in range(5):
            np.testing.assert_allclose(state[4 * body: 4 * body + 2], s.pos[body], rtol=1e-6, atol=1e-5)
            np.testing.assert_allclose(state[4 * body + 2: 4 * body + 4], s.vel[body], rtol=1e-6, atol=1e-5)
        np.testing.assert_array_equal(state[20:24], [float(s.holder == i) for i in range(4)])
        locked = [float(s.passer == i and s.cycle < s.lockout_until) for i in range(4)]
        np.testing.assert_array_equal(state[24:28], locked)
        assert state[28] == pytest.approx(s.cycle / 60)
        seen_holders.add(s.holder)
        seen_lockout |= any(locked)
        env.step(None if term or trunc else _legal(obs["action_mask"], rng))
    assert len(seen_holders) >= 2 and seen_lockout  # the flags were exercised
    par = soccer_drill.parallel_env(opponent="chasers")
    par.reset(seed=4)
    env.reset(seed=4)
    np.testing.assert_array_equal(par.state(), env.state())


@pytest.mark.parametrize(
    "call",
    [
        lambda: soccer_drill.env(render_mode="rgb_array").render(),
        lambda: soccer_drill.env().last(),
        lambda: soccer_drill.env().observe("attacker_0"),
        lambda: soccer_drill.env().state(),
        lambda: soccer_drill.env().action_mask("attacker_0"),
        lambda: soccer_drill.env().step(0),
        lambda: soccer_drill.parallel_env(render_mode="rgb_array").render(),
        lambda: soccer_drill.parallel_env().state(),
        lambda: soccer_drill.parallel_env().drill_state,
        lambda: soccer_drill.HolderEnv(render_mode="rgb_array").render(),
        lambda: soccer_drill.HolderEnv().step(0),
        lambda: soccer_drill.HolderEnv().drill_state,
    ],
)
def test_calls_before_reset_say_so(call):
    with pytest.raises(RuntimeError, match=r"called before reset\(\); call reset\(\) first"):
        call()


def test_bad_option_values_are_refused():
    with pytest.raises(ValueError, match="obs_format must be 'dict' or 'flat', got 'box'"):
        soccer_drill.env(obs_format="box")
    with pytest.raises(ValueError, match=r"shared_spaces must be None or true or false, got 1"):
        soccer_drill.parallel_env(shared_spaces=1)


def test_holder_rgb_array_list_gives_one_frame_per_cycle():
    import gymnasium as gym

    env = gym.make("soccer_drill/Holder-v0", opponent="chasers", render_mode="rgb_array_list")
    assert env.unwrapped.render_mode == "rgb_array_list"  # native, not Gymnasium's collector
    reference = soccer_drill.HolderEnv(opponent="chasers", render_mode="rgb_array")
    drawn: list = []
    env.reset(seed=0)
    reference.reset(seed=0)
    reference.record_frames(drawn)  # one frame now, then one per cycle
    frames = env.render()
    assert len(frames) == 1 and frames[0].shape[2] == 3 and frames[0].dtype == np.uint8
    assert env.render() == []  # frames are handed over once
    done = False
    while not done:
        _, _, term, trunc, info = env.step(1)
        reference.step(1)
        new = env.render()
        assert len(new) == info["duration"]  # one frame per 0.1 s cycle
        frames += new
        done = term or trunc
    assert len(frames) == info["cycles"] + 1 == len(drawn)
    for a, b in zip(frames, drawn, strict=True):
        np.testing.assert_array_equal(a, b)
    env.reset(seed=1)
    assert len(env.render()) == 1  # reset starts a new list
