"""The hot path's shortcuts give what the plain code gives, bit for bit, or fail loudly."""

from __future__ import annotations

import numpy as np
import pytest

import soccer_drill
from soccer_drill import drill as drill_module
from soccer_drill.config import DrillConfig
from soccer_drill.features import (
    _clipped,
    feature_bounds,
    features,
    kinematic_bounds,
    kinematics,
)


def test_the_clip_is_numpys_bit_for_bit_with_nan_signed_zeros_and_equal_bounds():
    rng = np.random.default_rng(0)
    for _ in range(3000):
        values = rng.normal(size=9) * rng.choice([1e-40, 1e-3, 1.0, 1e3])
        values[rng.random(9) < 0.1] = 0.0
        values[rng.random(9) < 0.1] *= -0.0
        values[rng.random(9) < 0.05] = np.nan
        low = rng.normal(size=9).astype(np.float32)
        high = (low + np.abs(rng.normal(size=9))).astype(np.float32)
        low[rng.random(9) < 0.2] = 0.0
        same = rng.random(9) < 0.1
        high[same] = low[same]
        expected = np.clip(np.array(values, dtype=np.float32), low, high)
        got = _clipped(values.tolist(), low.tolist(), high.tolist())
        assert got.dtype == np.float32 and got.tobytes() == expected.tobytes()


def test_observations_are_the_same_with_array_and_float_bounds():
    cfg = DrillConfig()
    env = soccer_drill.env(opponent="chasers")
    env.reset(seed=4)
    for _ in range(40):
        if not env.agents:
            env.reset()
        obs, _, term, trunc, _ = env.last()
        env.step(None if term or trunc else int(np.flatnonzero(obs["action_mask"])[-1]))
        state = env.drill_state
        for player in range(4):
            low, high = feature_bounds(cfg)
            assert (features(state, player, cfg, low, high).tobytes()
                    == features(state, player, cfg, low.tolist(), high.tolist()).tobytes())
            low, high = kinematic_bounds(cfg)
            assert (kinematics(state, player, low, high).tobytes()
                    == kinematics(state, player, low.tolist(), high.tolist()).tobytes())


def test_a_batched_read_in_another_order_is_refused_by_name():
    drill = drill_module.Drill()
    drill_module._check_batch_order(drill._space, drill._bodies, drill._buffer)  # as built
    with pytest.raises(RuntimeError, match=r"pymunk .*batch API lists the space's bodies in "
                       r"an unexpected order; this pymunk version is not supported"):
        drill_module._check_batch_order(drill._space, drill._bodies[::-1], drill._buffer)


def test_a_drill_with_its_batch_buffer_pickles_and_continues_identically():
    import pickle

    from soccer_drill.skills import Command, Skill

    drill, rng = drill_module.Drill(), np.random.default_rng(0)
    drill.reset(rng)
    copy, copy_rng = pickle.loads(pickle.dumps((drill, rng)))
    commands = [Command(Skill.GET_OPEN)] * 2 + [Command(Skill.INTERCEPT)] * 2
    for _ in range(30):
        if drill.outcome is not None:
            break
        assert drill.step(commands, rng) == copy.step(commands, copy_rng)
