"""The parametric team's parameters: bools refused as numbers, NumPy numbers taken as
Python ones, and a reaction delay longer than an episode costs the batched team no more
memory than one of ``max_cycles`` while acting as the single team does."""

from __future__ import annotations

import numpy as np
import pytest

from opponents.parametric import ParametricTeam, sample_opponents
from soccer_drill.envs.holder import HolderEnv
from soccer_drill.vector import HolderVectorEnv


@pytest.mark.parametrize("params, said", [
    ({"speed": True}, r"speed must be a finite number in \(0, 1\] or a list of 1 to 4 values, each a finite number in \(0, 1\], got True"),
    ({"speed": [1.0, True]}, r"speed must be a finite number in \(0, 1\] or a list of 1 to 4 values, each a finite number in \(0, 1\], got \[1.0, True\]"),
    ({"speed": None}, r"speed must be a finite number in \(0, 1\] or a list of 1 to 4 values, each a finite number in \(0, 1\], got None"),
    ({"reaction_delay": True}, "reaction_delay must be an integer >= 0, got True"),
    ({"sortie_cycles": True}, "sortie_cycles must be an integer >= 1, got True"),
    ({"mark_fraction": True}, r"mark_fraction must be a finite number in \[0, 1\], got True"),
    ({"guard_track": False}, r"guard_track must be a finite number in \[0, 1\], got False"),
    ({"press_probability": np.True_}, r"press_probability must be a finite number in \[0, 1\], got np.True_"),
])
def test_bools_are_refused_for_numbers_in_the_single_and_the_batched_drill(params, said):
    with pytest.raises(ValueError, match=said):
        ParametricTeam(**params)
    with pytest.raises(ValueError, match=said):
        HolderEnv(opponent="parametric", opponent_params=params)
    with pytest.raises(ValueError, match=said):
        HolderVectorEnv(num_envs=2, opponent="parametric", opponent_params=params)


def test_sample_opponents_refuses_a_bool_count():
    with pytest.raises(ValueError, match="n must be an integer >= 0, got True"):
        sample_opponents(True, seed=0)


def test_numpy_numbers_are_the_python_ones():
    team = ParametricTeam(speed=np.float32(0.5), reaction_delay=np.int64(2), mark_fraction=np.float32(0.25),
                          sortie_cycles=np.int32(3))
    assert team.params() == ParametricTeam(speed=0.5, reaction_delay=2, mark_fraction=0.25,
                                           sortie_cycles=3).params()


def _batched_run(delay: int, steps: int) -> list:
    venv = HolderVectorEnv(num_envs=3, opponent="parametric", max_cycles=40, drills_per_space=1,
                           opponent_params={"reaction_delay": delay})
    out = [venv.reset(seed=3)[0]]
    for t in range(steps):
        out.append(venv.step(np.full(3, t % 3))[:4])
    return out


def test_a_delay_longer_than_an_episode_acts_as_the_single_team_at_the_memory_of_max_cycles():
    huge = 10**9  # a buffer of this many states per drill would not fit in memory
    long_run = _batched_run(huge, 30)
    # Past max_cycles (40) a delay changes nothing: the team sees the episode's first state.
    for got, want in zip(long_run, _batched_run(40, 30), strict=True):
        for a, b in zip(got, want, strict=True):
            np.testing.assert_array_equal(a, b)
    # Each drill's first episode is the single environment's with the same delay.
    for i in range(3):
        single = HolderEnv(opponent="parametric", max_cycles=40,
                           opponent_params={"reaction_delay": huge})
        np.testing.assert_allclose(single.reset(seed=3 + i)[0], long_run[0][i], atol=1e-5)
        for t, (obs, reward, term, trunc) in enumerate(long_run[1:]):
            s_obs, s_reward, s_term, s_trunc, _ = single.step(t % 3)
            np.testing.assert_allclose(s_obs, obs[i], atol=1e-5)
            assert (s_reward, s_term, s_trunc) == (reward[i], term[i], trunc[i])
            if s_term or s_trunc:
                break
        else:
            pytest.fail(f"drill {i}: the episode did not end in 30 steps")
