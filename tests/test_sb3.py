"""``soccer_drill.vector.sb3.HolderSB3VecEnv`` against SB3's own ``DummyVecEnv`` of ``HolderEnv``:
the same observations, rewards, dones and infos, step for step, across autoresets.

SB3 needs torch, so these run with ``pytest -m integrations`` (``pip install -e
".[integrations]"``)."""

from __future__ import annotations

import numpy as np
import pytest

pytestmark = pytest.mark.integrations
pytest.importorskip("stable_baselines3")

from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor  # noqa: E402

from soccer_drill import HolderEnv  # noqa: E402
from soccer_drill.vector.sb3 import HolderSB3VecEnv  # noqa: E402

N = 6
TEAM = "interceptors_cover"
# The batch computes a length with NumPy's hypot where HolderEnv uses math.hypot: the two
# may differ in the last bit (HolderVectorEnv's docstring), so floats agree to float32's
# precision rather than bit for bit.
CLOSE = dict(rtol=1e-5, atol=1e-5)


def _pair(seed):
    batched = HolderSB3VecEnv(N, opponent=TEAM, drills_per_space=1)
    single = DummyVecEnv([lambda: HolderEnv(opponent=TEAM) for _ in range(N)])
    for env in (batched, single):
        env.seed(seed)
    return batched, single


def test_it_steps_as_dummy_vec_env_of_holder_env_across_autoresets():
    batched, single = _pair(3)
    np.testing.assert_allclose(batched.reset(), single.reset(), **CLOSE)
    assert batched.reset_infos == single.reset_infos
    rng = np.random.default_rng(0)
    ends = 0
    for _ in range(150):
        actions = rng.integers(3, size=N)
        obs, rewards, dones, infos = batched.step(actions)
        obs1, rewards1, dones1, infos1 = single.step(actions)
        np.testing.assert_allclose(obs, obs1, **CLOSE)
        assert obs.dtype == obs1.dtype and rewards.dtype == rewards1.dtype
        np.testing.assert_array_equal(rewards, rewards1)
        np.testing.assert_array_equal(dones, dones1)
        for info, info1 in zip(infos, infos1, strict=True):
            final, final1 = info.pop("terminal_observation", None), info1.pop("terminal_observation", None)
            assert info == info1
            assert (final is None) == (final1 is None)
            if final is not None:
                ends += 1
                np.testing.assert_allclose(final, final1, **CLOSE)
        assert batched.reset_infos == single.reset_infos
    assert ends > 20  # the autoresets were exercised, timeouts among them or not


def test_a_seed_applies_at_the_next_reset_only_and_repeats_the_episodes():
    env = HolderSB3VecEnv(N, opponent=TEAM)
    env.seed(7)
    first = env.reset()
    again = env.reset()  # no seed now: each drill's stream goes on
    env.seed(7)
    np.testing.assert_array_equal(env.reset(), first)
    assert not np.array_equal(again, first)


def test_the_attributes_methods_and_masks_sb3_asks_for():
    env = HolderSB3VecEnv(4, opponent=TEAM)
    assert env.get_attr("num_envs", [1, 2]) == [4, 4]
    assert env.env_is_wrapped(VecMonitor) == [False] * 4
    masks = env.env_method("action_masks", indices=[0, 3])
    assert len(masks) == 2 and all(m.shape == (3,) and m.all() for m in masks)
    assert env.has_attr("action_masks")
    env.set_attr("decision_cycles", 4)
    with pytest.raises(ValueError, match="set for every drill"):
        env.set_attr("decision_cycles", 4, indices=[0])


@pytest.mark.parametrize("given", ["autoreset_mode", "batch_size"])
def test_what_sb3_fixes_cannot_be_given(given):
    with pytest.raises(ValueError, match=f"HolderSB3VecEnv sets {given} itself"):
        HolderSB3VecEnv(4, **{given: None})


def test_different_options_per_drill_are_refused_at_the_reset():
    env = HolderSB3VecEnv(2, opponent=TEAM)
    env.set_options([{"a": 1}, {"a": 2}])
    with pytest.raises(ValueError, match="take one options dict"):
        env.reset()


def test_a_reset_mask_in_the_options_is_refused_since_sb3_resets_every_drill():
    # before, reset() reset the masked drills only, and VecMonitor counted the others' new
    env = HolderSB3VecEnv(4, opponent=TEAM)
    env.reset()
    env.set_options({"reset_mask": np.array([True, False, False, False])})
    with pytest.raises(ValueError, match="its options take no reset_mask"):
        env.reset()


def test_decision_cycles_set_through_set_attr_changes_the_decisions():
    # before, the attribute was set and the loop kept its own value: no effect, no error
    env = HolderSB3VecEnv(4, opponent=TEAM)
    env.set_attr("decision_cycles", 1)
    env.seed(0)
    env.reset()
    _, _, _, infos = env.step(np.zeros(4, dtype=np.int64))  # HOLD
    assert env.get_attr("decision_cycles") == [1] * 4
    assert [info["duration"] for info in infos] == [1] * 4


def test_step_wait_without_step_async_is_refused():
    env = HolderSB3VecEnv(2, opponent=TEAM)
    env.reset()
    with pytest.raises(RuntimeError, match="without step_async"):
        env.step_wait()


def test_indices_are_checked_and_what_the_batch_cannot_do_per_drill_is_refused():
    env = HolderSB3VecEnv(3, opponent=TEAM)
    env.reset()
    for bad in ([5], "a", -1, 3.0):
        with pytest.raises((TypeError, ValueError), match="indices must be"):
            env.get_attr("num_envs", indices=bad)
        with pytest.raises((TypeError, ValueError), match="indices must be"):
            env.env_method("action_masks", indices=bad)
    assert env.get_attr("num_envs", indices=[2]) == [3]
    with pytest.raises(ValueError, match=r"env_method\('reset'\).*every drill"):
        env.env_method("reset", indices=[1])
    with pytest.raises(ValueError, match=r"env_method\('close'\).*every drill"):
        env.env_method("close", indices=[0, 1])
    assert env.env_method("close", indices=[]) == []  # no drill: nothing called, as DummyVecEnv
    env.step(np.zeros(3, dtype=np.int64))  # not closed
    with pytest.raises(ValueError, match=r"set_attr\('autoreset_mode'\).*HolderSB3VecEnv sets it"):
        env.set_attr("autoreset_mode", "NextStep")
    env.step(np.zeros(3, dtype=np.int64))


def _played(env, seed, steps=12):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(steps):
        obs, rewards, dones, infos = env.step(rng.integers(3, size=N))
        out.append((obs.tobytes(), rewards.tobytes(), dones.tobytes(), repr(infos)))
    return out


@pytest.mark.parametrize("how", ["copy", "deepcopy", "pickle"])
def test_a_copy_is_independent_and_continues_every_drill_bit_for_bit(how):
    """copy.copy gave an alias: the copy's steps moved the original's drills."""
    import copy
    import pickle

    original = HolderSB3VecEnv(N, opponent=TEAM)
    original.seed(3)
    original.reset()
    _played(original, 1, steps=3)
    duplicate = {"copy": copy.copy, "deepcopy": copy.deepcopy,
                 "pickle": lambda env: pickle.loads(pickle.dumps(env))}[how](original)
    assert duplicate.venv is not original.venv
    copied = _played(duplicate, 2)
    assert _played(original, 2) == copied  # not moved by the copy's steps


def test_timeout_terminal_reports_the_drills_timeout_as_an_end_not_a_cut():
    # before, the adapter always reported the timeout (which pays -1) as a truncation,
    # which SB3 bootstraps, and had no way to say otherwise
    def timeouts(**kwargs):
        venv = HolderSB3VecEnv(num_envs=4, opponent="goal_guards", **kwargs)
        venv.seed(0)
        venv.reset()
        seen = []
        for _ in range(300):  # always HOLD: the episodes time out
            _, rewards, dones, infos = venv.step(np.zeros(4, dtype=np.int64))
            seen += [(float(rewards[i]), infos[i]["outcome"], infos[i]["TimeLimit.truncated"])
                     for i in np.flatnonzero(dones)]
        return [s for s in seen if s[1] == "timeout"]

    assert timeouts() and all(cut for _, _, cut in timeouts())
    ended = timeouts(timeout_terminal=True)
    assert ended and all(r == -1.0 and not cut for r, _, cut in ended)
    cut = HolderSB3VecEnv(num_envs=2, opponent="goal_guards", timeout_terminal=True,
                          max_episode_steps=2)
    cut.reset()
    _, _, dones, infos = cut.step(np.zeros(2, dtype=np.int64))
    _, _, dones, infos = cut.step(np.zeros(2, dtype=np.int64))
    assert dones.all() and all(i["TimeLimit.truncated"] for i in infos)  # a cut stays one
    with pytest.raises(ValueError, match="timeout_terminal"):
        HolderSB3VecEnv(num_envs=2, timeout_terminal="yes")
