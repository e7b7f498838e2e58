"""The batched holder used asynchronously (``batch_size`` < ``num_envs``, ``send`` and
``recv``, as EnvPool's): each drill plays the single environment's episodes, whatever
the others do; the results come as soon as a batch of drills is done; bad calls are
refused naming the drill, with nothing sent."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import soccer_drill  # noqa: F401  (registers soccer_drill/Holder-v0)
from soccer_drill.envs.holder import HolderEnv
from soccer_drill.policies import HOLDER_POLICIES
from soccer_drill.vector import HolderVectorEnv

POLICY = HOLDER_POLICIES["pass_first"]  # a function of the observation alone


def _results(venv: HolderVectorEnv, seed: int, steps: int) -> list[list[tuple]]:
    """Per drill, its first ``steps`` results with POLICY, as ``recv`` gives them."""
    got: list[list[tuple]] = [[] for _ in range(venv.num_envs)]
    venv.async_reset(seed=seed)
    while min(len(g) for g in got) < steps:
        obs, reward, term, trunc, info = venv.recv()
        for k, i in enumerate(info["env_id"].tolist()):
            got[i].append((obs[k], reward[k], term[k], trunc[k], info["duration"][k],
                           info["outcome"][k]))
        venv.send(np.array([POLICY(o, None) for o in obs]), info["env_id"])
    return [g[:steps] for g in got]


def test_each_drill_plays_the_same_episodes_whatever_the_batch():
    """With a space per drill, a drill's results depend on its seed and actions alone:
    the same whether the drills come back all together (``step``) or 2 of 6 at a time
    in the order they finish; and, since a reset builds the drill's space anew as
    ``HolderEnv.reset`` does, they are ``HolderEnv``'s results from its seed, bit for bit,
    the next episodes from the same stream included (over these 30 decisions a drill:
    later, a last-bit difference may part them: NumPy's ``hypot`` or ``arctan2`` against
    ``math``'s, or pymunk's contact solving, see ``HolderVectorEnv``)."""
    n, steps, team = 6, 30, "interceptors_cover"
    together = _results(HolderVectorEnv(num_envs=n, opponent=team, drills_per_space=1), 5, steps)
    venv = HolderVectorEnv(num_envs=n, batch_size=2, opponent=team, drills_per_space=1)
    in_pairs = _results(venv, 5, steps)
    for i, (a_run, b_run) in enumerate(zip(together, in_pairs, strict=True)):
        for k, (a, b) in enumerate(zip(a_run, b_run, strict=True)):
            np.testing.assert_array_equal(a[0], b[0], err_msg=f"drill {i}, result {k}")
            assert a[1:] == b[1:], (i, k)
    for i, run in enumerate(in_pairs):
        env = HolderEnv(opponent=team)
        obs, _ = env.reset(seed=5 + i)
        np.testing.assert_array_equal(run[0][0], obs)
        for k, (got, *rest) in enumerate(run[1:], start=1):
            if run[k - 1][2] or run[k - 1][3]:  # the autoreset: the next episode
                obs, info = env.reset()
                reward, term, trunc = 0.0, False, False
                info = {"duration": 0, **info}
            else:
                obs, reward, term, trunc, info = env.step(POLICY(obs, None))
            np.testing.assert_array_equal(got, obs, err_msg=f"drill {i}, result {k}")
            assert tuple(rest) == (reward, term, trunc, info["duration"], info["outcome"])
    assert sum(r[2] or r[3] for run in in_pairs for r in run) >= 6  # episodes did end


def test_the_batches_come_as_drills_finish():
    venv = HolderVectorEnv(num_envs=6, batch_size=2, opponent="chasers")
    venv.async_reset(seed=0)
    batches = []
    for _ in range(30):
        obs, *_, info = venv.recv()
        ids = info["env_id"]
        assert len(ids) == 2 and list(ids) == sorted(ids)
        batches.append(tuple(ids.tolist()))
        venv.send(np.array([POLICY(o, None) for o in obs]), ids)
    assert batches[:3] == [(0, 1), (2, 3), (4, 5)]  # after async_reset: in order
    assert len(set(batches)) > 3  # then as they finish, mixed


def test_send_and_recv_of_every_drill_is_step():
    a = HolderVectorEnv(num_envs=5, opponent="chasers")
    b = HolderVectorEnv(num_envs=5, opponent="chasers")
    obs_a, info_a = a.reset(seed=2)
    b.async_reset(seed=2)
    obs_b, reward_b, *_, info_b = b.recv()
    np.testing.assert_array_equal(obs_a, obs_b)
    assert not reward_b.any() and not info_b["duration"].any()
    assert list(info_b["env_id"]) == [0, 1, 2, 3, 4]
    rng = np.random.default_rng(0)
    for _ in range(40):
        actions = rng.integers(3, size=5)
        out_a = a.step(actions)
        b.send(actions)
        out_b = b.recv()
        for x, y in zip(out_a[:4], out_b[:4], strict=True):
            np.testing.assert_array_equal(x, y)
        env_id = out_b[4].pop("env_id")
        assert list(env_id) == [0, 1, 2, 3, 4] and out_b[4].pop("_env_id").all()
        assert out_a[4].keys() == out_b[4].keys()
        for key in out_a[4]:
            np.testing.assert_array_equal(out_a[4][key], out_b[4][key])


def test_a_smaller_batch_comes_back_sooner_and_keeps_the_drills_busy():
    """A drill that is done gets its next action at once rather than waiting for the
    slowest drill: fewer cycles of the batch for the same drill-cycles of play."""
    def cycles_run(batch_size: int) -> tuple[int, int]:
        venv = HolderVectorEnv(num_envs=16, batch_size=batch_size, opponent="interceptors_cover")
        venv.async_reset(seed=0)
        played = 0
        while played < 3000:
            obs, *_, info = venv.recv()
            played += int(info["duration"].sum())
            venv.send(np.array([POLICY(o, None) for o in obs]), info["env_id"])
        return venv.batch_cycles, played

    whole, played_whole = cycles_run(16)
    quarter, played_quarter = cycles_run(4)
    # The drill-cycles played per cycle of the batch: the share of the drills at work.
    assert played_quarter / quarter > 1.3 * played_whole / whole


def test_the_same_seed_gives_the_same_asynchronous_run():
    def run() -> list:
        venv = gym.make_vec("soccer_drill/Holder-v0", num_envs=8, vectorization_mode="vector_entry_point",
                            opponent="interceptors_press", batch_size=3)
        venv.async_reset(seed=9)
        out = []
        for _ in range(40):
            obs, reward, term, trunc, info = venv.recv()
            out.append((obs.copy(), reward.copy(), term.copy(), info["env_id"].copy()))
            venv.send(np.array([POLICY(o, None) for o in obs]), info["env_id"])
        return out

    first, second = run(), run()
    for x, y in zip(first, second, strict=True):
        for a, b in zip(x, y, strict=True):
            np.testing.assert_array_equal(a, b)


def test_same_step_autoreset_in_a_batch():
    venv = HolderVectorEnv(num_envs=6, batch_size=2, opponent="chasers", autoreset_mode="SameStep")
    venv.async_reset(seed=1)
    ended = 0
    for _ in range(200):
        obs, reward, term, trunc, info = venv.recv()
        done = term | trunc
        if done.any():
            ended += int(done.sum())
            assert (info["_final_obs"] == done).all()
            for k in np.flatnonzero(done):
                assert info["final_obs"][k].shape == (9,) and info["duration"][k] == 0
                assert info["final_info"]["outcome"][k] is not None
        venv.send(np.array([POLICY(o, None) for o in obs]), info["env_id"])
    assert ended > 3


@pytest.mark.parametrize("call, said", [
    (lambda v, ids, others: v.send(np.array([0, 0]), ids[[1, 1]]), "drill {1} is given twice"),
    (lambda v, ids, others: v.send(np.array([0]), np.array([7])), r"drill 7 is not in 0\.\.5"),
    (lambda v, ids, others: v.send(np.array([0]), np.array([0.5])),
     "env_id must be a non-empty 1-D array"),
    (lambda v, ids, others: v.send(np.array([0, 0]), np.array([ids[0], others[0]])),
     r"drill {2} is not waiting for an action \(done, its result not yet received"),
    (lambda v, ids, others: v.send(np.array([0, 9]), ids), r"drill {1}: action must be an integer in \[0, 2\]"),
    (lambda v, ids, others: v.send(np.array([0, 0, 0]), ids),
     r"shape \(2,\): one action per drill of env_id"),
    (lambda v, ids, others: v.step(np.zeros(6, dtype=int)), "use send"),
])
def test_bad_asynchronous_calls_are_refused_naming_the_drill_and_nothing_is_sent(call, said):
    venv = HolderVectorEnv(num_envs=6, batch_size=2, opponent="chasers")
    venv.async_reset(seed=0)
    obs, *_, info = venv.recv()
    ids = info["env_id"]
    others = np.array([i for i in range(6) if i not in ids])
    with pytest.raises((ValueError, RuntimeError), match=said.format(*ids, others[0])):
        call(venv, ids, others)
    assert not venv.loop.running.any()  # nothing was sent
    venv.send(np.zeros(2, dtype=int), ids)  # the right call still works
    assert venv.recv()[0].shape == (2, 9)


def test_recv_without_anything_sent_is_refused_rather_than_waiting_for_ever():
    venv = HolderVectorEnv(num_envs=4, batch_size=4, opponent="chasers")
    venv.async_reset(seed=0)
    venv.recv()
    with pytest.raises(RuntimeError, match=r"0 drills have results and none is running"):
        venv.recv()
    with pytest.raises(RuntimeError, match="before reset"):
        HolderVectorEnv(num_envs=2, opponent="chasers").recv()


@pytest.mark.parametrize("bad", [0, 7, 2.0, True])
def test_a_batch_size_outside_one_to_num_envs_is_refused(bad):
    with pytest.raises(ValueError, match=r"batch_size must be None or an integer in \[1, 6\]"):
        HolderVectorEnv(num_envs=6, batch_size=bad)


def test_step_after_a_send_without_its_recv_is_refused():
    venv = HolderVectorEnv(num_envs=3, opponent="chasers")
    venv.reset(seed=0)
    venv.send(np.zeros(3, dtype=int))
    with pytest.raises(ValueError, match=r"step\(\): drill 0 is not waiting for an action \(running its step\)"):
        venv.step(np.zeros(3, dtype=int))
    obs, *_ = venv.recv()  # the send's results are still there
    assert obs.shape == (3, 9)
    venv.step(np.zeros(3, dtype=int))


def test_recv_of_every_drill_hands_out_env_ids_of_the_callers_own():
    """With every drill's result at once, ``env_id`` is a new array each time: writing into
    it changes nothing of the environment's."""
    env = HolderVectorEnv(num_envs=3, opponent="chasers", batch_size=3)
    env.async_reset(seed=0)
    *_, info = env.recv()
    ids = info["env_id"]
    assert ids.tolist() == [0, 1, 2] and ids.flags.writeable
    ids[:] = 7
    env.send(np.zeros(3, dtype=np.int64), np.arange(3))
    *_, info = env.recv()
    assert info["env_id"].tolist() == [0, 1, 2]
