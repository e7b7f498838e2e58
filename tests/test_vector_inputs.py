"""The batched environments' input checks: seeds (every reset path alike), counts given
as NumPy integers, and actions of a non-integer dtype, each refused with an error that
says what was given and what is allowed, as the single environments refuse them."""

from __future__ import annotations

import numpy as np
import pytest

import soccer_drill
from soccer_drill.envs.holder import HolderEnv
from soccer_drill.vector import HolderVectorEnv
from soccer_drill.vector.agents import ParallelVectorEnv

ALLOWED = r"seed must be None, an integer >= 0 \(drill i gets seed \+ i\) or a sequence of 4 seeds"
MASK = np.array([True, False, False, True])

BAD_SEEDS = [
    ([1], "got a sequence of 1"),
    ([1, 2, 3, 4, 5, 6], "got a sequence of 6"),
    (True, "got True of type bool"),
    (1.5, "got 1.5 of type float"),
    ("a", "got 'a' of type str"),
    (-1, "got -1"),
    ([0, 1, 2.0, 3], r"got seed\[2\] = 2.0 of type float"),
    ([0, 1, -2, 3], r"got seed\[2\] = -2"),
    ([0, False, 2, 3], r"got seed\[1\] = False of type bool"),
    (np.zeros((2, 2), dtype=int), r"got an array of shape \(2, 2\)"),
]


def _holder() -> HolderVectorEnv:
    venv = HolderVectorEnv(num_envs=4, opponent="chasers")
    venv.reset(seed=0)
    return venv


@pytest.mark.parametrize("seed, said", BAD_SEEDS)
@pytest.mark.parametrize("call", [
    lambda v, s: v.reset(seed=s),
    lambda v, s: v.reset(seed=s, options={"reset_mask": MASK}),
    lambda v, s: v.async_reset(seed=s),
    lambda v, s: v.async_reset(seed=s, options={"reset_mask": MASK}),
], ids=["reset", "masked reset", "async_reset", "masked async_reset"])
def test_every_reset_path_refuses_a_bad_seed_alike_and_changes_nothing(call, seed, said):
    venv = _holder()
    venv.step(np.full(4, 2))
    before = venv._core.batch.pos.copy(), [g.bit_generator.state for g in venv._core.generators]
    with pytest.raises(ValueError, match=f"{ALLOWED}.*; {said}"):
        call(venv, seed)
    np.testing.assert_array_equal(venv._core.batch.pos, before[0])
    assert [g.bit_generator.state for g in venv._core.generators] == before[1]


@pytest.mark.parametrize("seed, said", BAD_SEEDS)
def test_the_batched_agents_refuse_a_bad_seed_as_the_batched_holder(seed, said):
    with pytest.raises(ValueError, match=f"{ALLOWED}.*; {said}"):
        ParallelVectorEnv(num_envs=4, opponent="chasers").reset(seed=seed)


def test_numpy_integer_seeds_are_the_python_ones():
    venv = HolderVectorEnv(num_envs=4, opponent="chasers")
    want = venv.reset(seed=7)[0]
    for seed in (np.int64(7), np.uint32(7), [7, 8, 9, 10], (np.int64(7), 8, np.int32(9), 10),
                 np.arange(7, 11)):
        np.testing.assert_array_equal(venv.reset(seed=seed)[0], want)
    agents = ParallelVectorEnv(num_envs=4, opponent="chasers")
    agents.reset(seed=7)
    state = agents.state()
    agents.reset(seed=np.int64(7))
    np.testing.assert_array_equal(agents.state(), state)


def test_a_masked_reset_seeds_its_drills_as_a_full_reset_and_ignores_the_others_entries():
    venv = HolderVectorEnv(num_envs=4, opponent="chasers", drills_per_space=1)
    full = HolderVectorEnv(num_envs=4, opponent="chasers", drills_per_space=1).reset(seed=5)[0]
    venv.reset(seed=0)
    for _ in range(3):
        cycles = venv.step(np.full(4, 2))[4]["cycles"]
    obs, info = venv.reset(seed=np.int64(5), options={"reset_mask": MASK})
    np.testing.assert_array_equal(obs[MASK], full[MASK])
    # the infos are the reset drills' only, as Gymnasium's SyncVectorEnv gives them (before,
    # every drill's was marked, the others' with their running counts)
    for key in ("cycles", "duration", "outcome", "holder"):
        np.testing.assert_array_equal(info[f"_{key}"], MASK)
    np.testing.assert_array_equal(info["cycles"], 0)
    assert list(info["holder"][~MASK]) == [None, None]
    after = venv.step(np.full(4, 2))[4]["cycles"]  # the others went on
    np.testing.assert_array_equal(after[~MASK], cycles[~MASK] + 4)
    # A list has one entry per drill; those of the drills not reset may be anything valid.
    obs, _ = venv.reset(seed=[5, 99, None, 8], options={"reset_mask": MASK})
    np.testing.assert_array_equal(obs[MASK], full[MASK])


@pytest.mark.parametrize("name", ["num_envs", "batch_size", "drills_per_space"])
def test_counts_may_be_numpy_integers(name):
    venv = HolderVectorEnv(**{"num_envs": 4, name: np.int64(2 if name != "num_envs" else 4)})
    obs, _ = venv.reset(seed=0)
    assert obs.shape == (4, 9)
    assert type(venv.num_envs) is int and type(venv.batch_size) is int
    agents = ParallelVectorEnv(num_envs=np.int64(3), drills_per_space=np.int32(2))
    assert agents.reset(seed=0)[0]["attacker_0"]["observation"].shape[0] == 3


@pytest.mark.parametrize("name, bad, said", [
    ("num_envs", np.bool_(True), r"num_envs must be an integer in \[1, 1,000,000\], got"),
    ("num_envs", True, r"num_envs must be an integer in \[1, 1,000,000\], got True"),
    ("batch_size", True, r"batch_size must be None or an integer in \[1, 4\], got True"),
    ("batch_size", np.int64(5), r"batch_size must be None or an integer in \[1, 4\], "
                                r"got np.int64\(5\)"),
    ("drills_per_space", True, "drills_per_space must be an integer >= 1, got True"),
    ("drills_per_space", 2.0, "drills_per_space must be an integer >= 1, got 2.0"),
    ("drills_per_space", np.int64(0), r"drills_per_space must be an integer >= 1, got np.int64\(0\)"),
])
def test_bad_counts_are_refused_saying_what_is_allowed(name, bad, said):
    with pytest.raises(ValueError, match=said):
        HolderVectorEnv(**{"num_envs": 4, name: bad})
    if name != "batch_size":
        with pytest.raises(ValueError, match=said.replace(r"\(4\)", "")):
            ParallelVectorEnv(**{"num_envs": 4, name: bad})


@pytest.mark.parametrize("actions", [
    np.full(4, 2.0), np.full(4, 2.0, dtype=np.float32), np.ones(4, dtype=bool),
])
def test_the_batched_holder_takes_integer_actions_only_as_the_single_holder(actions):
    single = HolderEnv(opponent="chasers")
    single.reset(seed=0)
    with pytest.raises(ValueError, match=r"action must be an integer in \[0, 2\]"):
        single.step(actions[0])
    venv = _holder()
    with pytest.raises(ValueError, match=rf"drill 0: action must be an integer in \[0, 2\] .*"
                                         rf"actions of dtype {actions.dtype}; an integer dtype is needed"):
        venv.step(actions)
    assert not venv.loop.running.any()  # nothing was sent
    venv.step(actions.astype(np.int64))  # the same values as integers are fine


def test_the_batched_agents_take_integer_actions_only_as_parallel_env():
    single = soccer_drill.parallel_env(opponent="chasers")
    obs, _ = single.reset(seed=0)
    good = {a: int(o["action_mask"].argmax()) for a, o in obs.items()}
    with pytest.raises(TypeError, match="action for 'attacker_0' must be an integer"):
        single.step({**good, "attacker_0": float(good["attacker_0"])})
    venv = ParallelVectorEnv(num_envs=3, opponent="chasers")
    obs, _ = venv.reset(seed=0)
    good = {a: o["action_mask"].argmax(axis=1) for a, o in obs.items()}
    cycles = venv._core.batch.cycle.copy()
    for bad in (good["attacker_1"].astype(float), good["attacker_1"] > 0):
        with pytest.raises(TypeError, match=rf"drill 0: action for 'attacker_1' must be an integer in "
                                            rf"\[0, 4\] \(0=HOLD, .*actions of dtype {bad.dtype}"):
            venv.step({**good, "attacker_1": bad})
    np.testing.assert_array_equal(venv._core.batch.cycle, cycles)  # no drill moved
    venv.step(good)


def test_a_holder_envs_decision_cycles_set_after_it_is_made_is_the_one_played():
    # before, setting the attribute changed nothing: the loop kept the value it was made with
    env = HolderEnv(opponent="chasers")
    env.decision_cycles = 2
    env.reset(seed=0)
    assert env.step(0)[4]["duration"] == 2
    with pytest.raises(ValueError, match=r"decision_cycles must be an integer in \[1, 50\]"):
        env.decision_cycles = 0
