"""What the batched environments refuse: unknown reset options, what a rule returns in
``play_episodes``, non-string agent keys and ``HolderSB3VecEnv``'s drill indices."""

from __future__ import annotations

import numpy as np
import pytest

import soccer_drill
from soccer_drill.policies import HOLDER_POLICIES
from soccer_drill.vector import HolderVectorEnv, play_episodes
from soccer_drill.vector.agents import ParallelVectorEnv


def test_reset_refuses_unknown_options_and_options_that_are_not_a_dict():
    venv = HolderVectorEnv(num_envs=3, opponent="goal_guards")
    venv.reset(seed=0)
    mask = np.array([True, False, False])
    with pytest.raises(ValueError, match=r"HolderVectorEnv.reset's options: unknown field\(s\) "
                                         r"\['reset_masks'\]; allowed: \['reset_mask'\]"):
        venv.reset(options={"reset_masks": mask})
    with pytest.raises(TypeError, match=r"options must be None or a dict.*got list"):
        venv.reset(options=[1])
    with pytest.raises(ValueError, match=r"unknown field\(s\) \[1\]"):
        venv.reset(options={1: 2})
    venv.reset(options={})  # an empty dict: every drill, as None
    venv.reset(options={"reset_mask": mask})


@pytest.mark.parametrize("make", [
    lambda: soccer_drill.HolderEnv(), lambda: soccer_drill.parallel_env(),
    lambda: soccer_drill.env(), lambda: HolderVectorEnv(num_envs=2),
    lambda: ParallelVectorEnv(num_envs=2)], ids=["holder", "parallel", "aec", "holder vector",
                                                 "parallel vector"])
def test_every_environment_checks_reset_options_alike(make):
    """``options`` is ``None`` or a dict in every environment: of the keys it takes in the
    Gymnasium ones and the batched agents (``HolderEnv`` and ``ParallelVectorEnv`` take
    none), any keys in PettingZoo's, whose API test passes some; an empty dict always
    passes. Anything else is refused with what was given and what is allowed."""
    env = make()
    with pytest.raises(TypeError, match=r"'s options must be None or a dict \(keys: .*\), got str"):
        env.reset(seed=0, options="not a dict")
    if isinstance(env, soccer_drill.HolderEnv | HolderVectorEnv | ParallelVectorEnv):
        with pytest.raises(ValueError, match=r"'s options: unknown field\(s\) \['colour'\]"):
            env.reset(seed=0, options={"colour": "red"})
    else:  # PettingZoo's API test resets its environments with options={"options": 1}
        env.reset(seed=0, options={"colour": "red"})
    env.reset(seed=0, options={})
    env.reset(seed=0, options=None)


def _returning(value):
    return lambda obs, rng: value


@pytest.mark.parametrize("value", [-1, -2, -3, 3, 7, 1.9, True, np.True_, "1", None, np.float64(1.0)])
def test_play_episodes_refuses_what_a_rule_returns_that_is_not_an_action(value):
    venv = HolderVectorEnv(num_envs=2, opponent="goal_guards")
    with pytest.raises(ValueError, match=r"drill \d+ \(seed \d+\): the rule returned .*action must "
                                         r"be an integer in \[0, 2\] \(0=HOLD, 1=PASS, 2=DRIBBLE\)"):
        play_episodes(venv, _returning(value), [4, 5])


def test_play_episodes_takes_numpy_integer_actions_and_refuses_seeds_that_are_not_integers():
    venv = HolderVectorEnv(num_envs=2, opponent="goal_guards")
    assert len(play_episodes(venv, _returning(np.int64(0)), [1, np.int32(2)])) == 2
    for seeds in ([1.5], [True], ["3"], [-1]):
        with pytest.raises((TypeError, ValueError), match=r"seeds\[0\] \(a seed of HolderEnv\.reset\) "
                                                           r"must be an integer >= 0"):
            play_episodes(venv, HOLDER_POLICIES["hold"], seeds)


def test_a_bad_agent_key_is_named_without_failing_to_sort_the_keys():
    env = ParallelVectorEnv(num_envs=2)
    env.reset(seed=0)
    actions = {a: np.zeros(2, dtype=np.int64) for a in env.agents}
    actions[3] = np.zeros(2, dtype=np.int64)
    with pytest.raises(ValueError, match=r"actions must be a mapping of every agent .*got keys .*3"):
        env.step(actions)


def test_drill_indices_are_checked_as_sb3_reads_them():
    from soccer_drill.vector.holder import check_drill_indices

    assert check_drill_indices(None, 3) == [0, 1, 2]
    assert check_drill_indices(2, 3) == [2]
    assert check_drill_indices(np.int64(1), 3) == [1]
    assert check_drill_indices([0, 2], 3) == [0, 2]
    assert check_drill_indices(np.array([1]), 3) == [1]
    assert check_drill_indices([], 3) == []
    for bad in (5, -1, [5], [0, 3], "a", 1.0, True, [True], [0.0], {"a": 1}):
        with pytest.raises(ValueError, match=r"indices must be a list of values, each an integer "
                                             r"in \[0, 2\], got"):
            check_drill_indices(bad, 3)


def test_num_envs_beyond_the_memory_available_is_refused_with_the_estimate(monkeypatch):
    """Up to 1,000,000 drills were accepted whatever the memory (about 20 MB per 1,000),
    and under a memory limit 200,000 crashed inside pymunk: the estimate is checked
    against what is available before any drill is built."""
    from soccer_drill.vector import HolderVectorEnv
    from soccer_drill.vector import memory as batch_core

    assert batch_core.available_memory() is None or batch_core.available_memory() > 0
    monkeypatch.setattr(batch_core, "available_memory", lambda: 10 * 2**20)  # 10 MiB
    with pytest.raises(ValueError, match=r"num_envs=1000 needs about 31 MiB \(up to 32 KiB a "
                                         r"drill\), more than the 10 MiB of memory available; "
                                         r"at most 320 drills fit now"):
        HolderVectorEnv(1000, opponent="chasers")
    env = HolderVectorEnv(8, opponent="chasers")  # 256 KiB: fits
    env.close()


@pytest.mark.parametrize("kind", ["holder", "agents"])
def test_frames_of_every_drill_beyond_the_memory_available_are_refused_with_the_estimate(
    kind, monkeypatch
):
    """render() returns a frame of every drill at once (1.31 MiB each, 640 pixels wide
    whatever the field): with rgb_array, num_envs is checked with its frames, and
    render() checks them against what is available when it is called."""
    from soccer_drill.vector import HolderVectorEnv
    from soccer_drill.vector import memory as batch_core
    from soccer_drill.vector.agents import ParallelVectorEnv

    make = HolderVectorEnv if kind == "holder" else ParallelVectorEnv
    monkeypatch.setattr(batch_core, "available_memory", lambda: 100 * 2**20)  # 100 MiB
    with pytest.raises(ValueError, match=r"num_envs=200 with render_mode='rgb_array' needs about "
                                         r"269 MiB: 200 drills \(up to 32 KiB each\) and their "
                                         r"frames \(201 of 640 x 714 pixels, 1\.31 MiB each, "
                                         r"render\(\) returns them together\), more than the "
                                         r"100 MiB of memory available; at most 73 drills fit "
                                         r"now with their frames"):
        make(200, opponent="chasers", render_mode="rgb_array")
    make(200, opponent="chasers").close()  # without frames: 6 MiB
    env = make(8, opponent="chasers", render_mode="rgb_array")
    env.reset(seed=0)
    assert len(env.render()) == 8
    monkeypatch.setattr(batch_core, "available_memory", lambda: 2 * 2**20)  # less, since
    with pytest.raises(RuntimeError, match=r"render\(\) of 8 drills needs about 11\.8 MiB for "
                                           r"their frames \(9 of 640 x 714 pixels, 1\.31 MiB "
                                           r"each\), more than the 2\.0 MiB of memory available "
                                           r"now; at most 0 frames fit"):
        env.render()
    monkeypatch.setattr(batch_core, "available_memory", lambda: None)  # unknown: not checked
    assert len(env.render()) == 8
    env.close()
