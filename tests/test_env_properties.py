"""Property-based tests of the AEC, parallel and holder environments (hypothesis)."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import soccer_drill
from soccer_drill.config import SPEEDS, DrillConfig, fewest_substeps

OUTCOMES = {"success", "interception", "out", "timeout"}

configs = st.fixed_dictionaries(
    {},
    optional={
        "max_cycles": st.integers(1, 120),
        "substeps": st.integers(1, 12),
        "tackle_probability": st.floats(0.0, 1.0),
        "ball_damping": st.floats(0.05, 1.0),
        "kick_angle_noise": st.floats(0.0, 30.0),
        "defender_speed": st.floats(1.0, 9.0),
        "attacker_speed": st.floats(1.0, 9.0),
        "control_speed": st.floats(0.5, 20.0),
        "start_jitter": st.floats(0.0, 3.0),
    },
)


def _enough_substeps(config: dict) -> dict:
    """Sub-steps raised where the speeds drawn need more (``DrillConfig`` refuses fewer)."""
    full = {**DrillConfig().to_dict(), **config}
    fewest = fewest_substeps(max(full[name] for name in SPEEDS), full["cycle_seconds"],
                             full["player_radius"])
    return config if full["substeps"] >= fewest else {**config, "substeps": fewest}


configs = configs.map(_enough_substeps)
SETTINGS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@SETTINGS
@given(config=configs, seed=st.integers(0, 2**31 - 1), opponent=st.sampled_from([None, "chasers"]),
       obs_type=st.sampled_from(["features", "kinematic"]), reset_at=st.integers(0, 60))
def test_aec_invariants(config, seed, opponent, obs_type, reset_at):
    env = soccer_drill.env(opponent=opponent, obs_type=obs_type, config=config)
    cfg = DrillConfig.from_dict(config)
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    turns, ended = 0, 0
    for agent in env.agent_iter(max_iter=4 * (cfg.max_cycles + 2) * 2):
        obs, reward, term, trunc, info = env.last()
        assert env.observation_space(agent).contains(obs)
        assert np.isfinite(obs["observation"]).all()
        assert set(env.rewards) == set(env.terminations) == set(env.agents)
        if term or trunc:
            assert info["outcome"] in OUTCOMES
            assert trunc == (info["outcome"] == "timeout")
            ended += 1
            env.step(None)
            continue
        turns += 1
        if turns == reset_at:  # a reset in the middle of an episode starts cleanly
            env.reset(seed=seed + 1)
            continue
        legal = np.flatnonzero(obs["action_mask"])
        assert legal.size > 0
        env.step(int(rng.choice(legal)))
        state = env.drill_state
        if agent == env.possible_agents[-1] or env.outcome is not None:
            assert state.holder in (-1, 0, 1, 2, 3)
            assert state.cycle <= cfg.max_cycles
    assert env.agents == []
    assert ended == len(env.possible_agents)  # everyone told once that the episode ended


@SETTINGS
@given(config=configs, seed=st.integers(0, 2**31 - 1), opponent=st.sampled_from([None, "chasers"]))
def test_parallel_invariants(config, seed, opponent):
    env = soccer_drill.parallel_env(opponent=opponent, config=config)
    cfg = DrillConfig.from_dict(config)
    rng = np.random.default_rng(seed)
    obs, infos = env.reset(seed=seed)
    steps = 0
    while env.agents:
        actions = {a: int(rng.choice(np.flatnonzero(o["action_mask"]))) for a, o in obs.items()}
        obs, rewards, term, trunc, infos = env.step(actions)
        steps += 1
        for agent, o in obs.items():
            assert env.observation_space(agent).contains(o)
        if env.outcome is None:
            assert all(r == 0.0 for r in rewards.values())
        else:
            assert env.agents == []
            paid = rewards[next(iter(rewards))]
            assert paid != 0.0 or cfg.reward_failure == 0.0
            assert all(i["outcome"] == env.outcome for i in infos.values())
    assert steps <= cfg.max_cycles


@SETTINGS
@given(config=configs, seed=st.integers(0, 2**31 - 1),
       actions=st.lists(st.integers(0, 2), min_size=1, max_size=200))
def test_holder_invariants(config, seed, actions):
    env = soccer_drill.HolderEnv(opponent="chasers", config=config)
    cfg = DrillConfig.from_dict(config)
    obs, info = env.reset(seed=seed)
    total = 0
    for action in actions:
        assert env.observation_space.contains(obs)
        obs, reward, term, trunc, info = env.step(action)
        assert info["duration"] >= 1
        total += info["duration"]
        assert info["cycles"] == total <= cfg.max_cycles
        if term or trunc:
            assert info["outcome"] in OUTCOMES
            if info["outcome"] == "success":
                assert cfg.reward_success_edge <= reward <= cfg.reward_success_centre
            elif info["outcome"] == "timeout":
                assert (trunc, reward) == (True, cfg.reward_timeout)
            else:
                assert (term, reward) == (True, cfg.reward_failure)
            break
        assert reward == 0.0 and info["outcome"] is None
