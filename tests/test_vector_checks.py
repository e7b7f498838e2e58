"""The batched holder through ``gym.make_vec(..., vectorization_mode="vector_entry_point")``
against Gymnasium's checks: the single-env checker's tests that apply to a vector env
(spaces, seeding and step determinism, returned data not reused, the passive checks of
every observation) and Gymnasium's vector wrappers, which rely on the autoreset mode and
the info convention."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_space_limit
from gymnasium.utils.passive_env_checker import check_obs
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.wrappers.vector import (
    ClipReward,
    DictInfoToList,
    NormalizeObservation,
    NormalizeReward,
    RecordEpisodeStatistics,
)

import soccer_drill  # noqa: F401  (registers soccer_drill/Holder-v0)


def _make(n: int = 6) -> VectorEnv:
    return gym.make_vec("soccer_drill/Holder-v0", num_envs=n, vectorization_mode="vector_entry_point",
                        opponent="interceptors_cover")


def _rollout(env: VectorEnv, seed: int, steps: int = 25) -> list:
    out = []
    obs, info = env.reset(seed=seed)
    out.append((obs.copy(), {k: np.array(v).copy() for k, v in info.items()}))
    rng = np.random.default_rng(seed)
    for _ in range(steps):
        obs, reward, term, trunc, info = env.step(rng.integers(3, size=env.num_envs))
        out.append((obs.copy(), reward.copy(), term.copy(), trunc.copy(),
                    {k: np.array(v).copy() for k, v in info.items()}))
    return out


def _equal(a: object, b: object) -> bool:
    if isinstance(a, tuple | list):
        return len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_equal(a[k], b[k]) for k in a)
    return np.array_equal(a, b)


def test_the_batched_holder_passes_gymnasiums_checks():
    env = _make()
    assert isinstance(env, VectorEnv)
    assert env.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    for space, kind in ((env.single_observation_space, "observation"),
                        (env.single_action_space, "action")):
        check_space_limit(space, kind)
    assert env.observation_space.shape == (env.num_envs, *env.single_observation_space.shape)
    # Seeding: the same seed, the same run; another seed, another run.
    a, b, c = _rollout(env, 3), _rollout(env, 3), _rollout(env, 4)
    assert _equal(a, b) and not _equal(a, c)
    # Every observation passes the passive checks; returned arrays are not reused.
    obs, _ = env.reset(seed=0)
    first = obs.copy()
    for _ in range(30):
        for row in obs:
            check_obs(row, env.single_observation_space, "step")
        assert obs in env.observation_space
        previous, kept = obs, obs.copy()
        obs, reward, term, trunc, info = env.step(env.action_space.sample())
        assert obs is not previous and np.array_equal(previous, kept)
        assert reward.dtype == np.float64 and term.dtype == trunc.dtype == np.bool_
        assert set(info) == {"duration", "_duration", "cycles", "_cycles", "outcome", "_outcome",
                             "holder", "_holder"}
    assert not np.array_equal(first, obs)
    env.close()


def test_gymnasiums_vector_wrappers_run_on_the_batched_holder():
    env = DictInfoToList(ClipReward(NormalizeReward(NormalizeObservation(
        RecordEpisodeStatistics(_make(8)))), -1.0, 1.0))
    obs, infos = env.reset(seed=1)
    assert isinstance(infos, list) and len(infos) == 8
    episodes = 0
    for _ in range(60):
        obs, reward, term, trunc, infos = env.step(env.action_space.sample())
        assert obs.shape == (8, 9) and np.all(np.abs(reward) <= 1.0)
        episodes += sum("episode" in info for info in infos)
    assert episodes > 0  # episodes ended and were autoreset
    env.close()


def test_a_bad_agent_action_in_drill_17_names_it_and_changes_no_drill():
    from soccer_drill.vector.agents import ParallelVectorEnv

    def fresh():
        venv = ParallelVectorEnv(num_envs=32, opponent="interceptors_cover", illegal_action="raise")
        obs, _ = venv.reset(seed=5)
        return venv, obs

    def legal(obs):
        return {a: obs[a]["action_mask"].argmax(axis=1) for a in obs}

    venv, obs = fresh()
    b = venv._core.batch
    before = [x.copy() for x in (b.pos, b.vel, b.holder, b.cycle, b.outcome)]
    good = legal(obs)
    out_of_range = {a: v.copy() for a, v in good.items()}
    out_of_range["attacker_1"][17] = 7
    masked = {a: v.copy() for a, v in good.items()}
    holds = int(b.holder[17]) in (0, 1)
    agent = "attacker_0" if not holds else f"attacker_{int(b.holder[17])}"
    masked[agent][17] = 3 if holds else 0  # GET_OPEN for the holder, HOLD off the ball
    for actions, message in ((out_of_range, r"drill 17: action 7 for 'attacker_1' is out of range"),
                             (masked, rf"drill 17: action {masked[agent][17]} \(\w+\) is masked "
                                      rf"for '{agent}'")):
        with pytest.raises(ValueError, match=message):
            venv.step(actions)
        for x, y in zip(before, (b.pos, b.vel, b.holder, b.cycle, b.outcome), strict=True):
            np.testing.assert_array_equal(x, y)
    after_errors = venv.step(good)
    reference, _ = fresh()
    expected = reference.step(good)
    for agent_name in good:
        np.testing.assert_array_equal(after_errors[0][agent_name]["observation"],
                                      expected[0][agent_name]["observation"])
        np.testing.assert_array_equal(after_errors[1][agent_name], expected[1][agent_name])
