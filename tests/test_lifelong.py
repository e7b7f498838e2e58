"""The lifelong loop (Algorithm 1): end to end, checkpoints, resume, ablations."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest
from synthetic_smdp import ZoneCorridor

from ilpss.kernels import SharedKernelModel, UniformKernel
from ilpss.lifelong import LearnerConfig, LifelongConfig, LifelongLearner

DRILL = "soccer_drill:soccer_drill/Holder-v0"
DRILL_WIDTHS = (3.0, 3.0, 3.0, 3.0, 10.0, 3.0, 3.0, 3.0, 10.0)


def _corridors():
    # Three task instances that differ in their step cost (dynamics of the reward).
    return [ZoneCorridor(cost=c, n_features=2) for c in (0.02, 0.05, 0.1)]


def _config(**kw):
    base = {"n_kernels": 2, "train_episodes": 40, "rollout_episodes": 10,
            "learner": LearnerConfig(initial_value=1.0, tile_widths=(1.0, 0.5), n_tilings=8)}
    return LifelongConfig(**{**base, **kw})


def _run(n_trials, config, seed=3, checkpoint_dir=None):
    envs = _corridors()
    ll = LifelongLearner(config, envs[0].observation_space, 3, seed=seed)
    for t in range(n_trials):
        ll.run_trial(envs[t], f"corridor_{t}")
        if checkpoint_dir is not None:
            ll.save(checkpoint_dir)
    return ll


def _fingerprint(ll: LifelongLearner):
    lib = ll.library
    return (
        [r for r in ll.records],
        [p.weights.tobytes() for p in ll.policies],
        [b.tobytes() for b in ll.bags],
        None if lib is None else (lib.option_ids.tolist(), lib.scales.tolist(),
                                  lib.kernel_ids.tolist(), sorted(lib.registry.items())),
        None if ll.kernel_model is None else ll.kernel_model.means_.tobytes(),
    )


def test_loop_builds_bags_kernels_and_options():
    ll = _run(3, _config())
    assert ll.n_trials == 3 and len(ll.policies) == 3 and len(ll.bags) == 3
    assert isinstance(ll.kernel_model, SharedKernelModel)
    assert ll.kernel_model.weights_.shape == (3, 2)  # one weight vector per instance
    for record, bag in zip(ll.records, ll.bags, strict=True):
        assert record.bag_size == len(bag)
        assert len(record.rewards) == 40
    # Trial 1 learns without options; later trials are offered K x (policies so far).
    assert ll.records[0].options_offered == 0
    assert ll.records[1].options_offered == 2 * 1
    assert ll.records[2].options_offered <= 2 * 2
    assert len(ll.library.policies) == 3
    assert ll.records[-1].library_size == len(ll.library)


def test_same_seed_same_run_and_different_seed_differs():
    a, b = _run(2, _config(), seed=5), _run(2, _config(), seed=5)
    assert _fingerprint(a) == _fingerprint(b)
    assert _fingerprint(a) != _fingerprint(_run(2, _config(), seed=6))


def test_resume_from_checkpoint_ends_identical(tmp_path):
    straight = _run(3, _config())
    _run(2, _config(), checkpoint_dir=tmp_path)  # "interrupted" after trial 2
    resumed = LifelongLearner.load(tmp_path, _corridors()[0].observation_space)
    assert resumed.n_trials == 2
    resumed.run_trial(_corridors()[2], "corridor_2")
    assert _fingerprint(resumed) == _fingerprint(straight)


def test_checkpoint_survives_a_half_written_successor(tmp_path):
    ll = _run(1, _config(), checkpoint_dir=tmp_path)
    (tmp_path / ".building_0002").mkdir()  # a crash while building the next checkpoint
    (tmp_path / ".building_0002" / "state.json").write_text("{trunc")
    restored = LifelongLearner.load(tmp_path, _corridors()[0].observation_space)
    assert _fingerprint(restored) == _fingerprint(ll)


def test_corrupt_checkpoint_is_refused(tmp_path):
    _run(1, _config(), checkpoint_dir=tmp_path)
    state = tmp_path / "trial_0001" / "state.json"
    record = json.loads(state.read_text())
    state.write_text(json.dumps({**record, "schema": "ilpss.lifelong/0"}))
    with pytest.raises(ValueError, match=r"schema 'ilpss\.lifelong/0'"):
        LifelongLearner.load(tmp_path, _corridors()[0].observation_space)
    with pytest.raises(FileNotFoundError, match="no checkpoint"):
        LifelongLearner.load(tmp_path / "elsewhere", _corridors()[0].observation_space)


def test_whole_policy_ablation_and_learning_anew():
    whole = _run(2, _config(options="whole_policies"))
    assert isinstance(whole.kernel_model, UniformKernel)
    assert len(whole.library.policies) == 2
    state = np.array([4.0, 0.5])
    assert whole.library.continuation_probability(whole.library.option_ids[0], state) == 1.0
    anew = _run(2, _config(options="none"))
    assert anew.library is None and all(r.options_offered == 0 for r in anew.records)


def test_config_round_trip_and_validation():
    cfg = _config(options="whole_policies")
    assert LifelongConfig.from_dict(json.loads(json.dumps(cfg.to_dict()))) == cfg
    with pytest.raises(ValueError, match=r"unknown LifelongConfig field\(s\) \['kernels'\]"):
        LifelongConfig.from_dict({"kernels": 5})
    with pytest.raises(ValueError, match=r"LifelongConfig.options must name a registered reuse "
                       r".*got 'all'; registered: \[.*'finetune_best', 'finetune_latest', 'kernels'"):
        LifelongConfig(options="all")
    with pytest.raises(ValueError, match=r"OptionSettings.discount must be a finite number in "
                       r"\(0, 1\], got 1.5"):
        LifelongConfig.from_dict({"library": {"discount": 1.5}})
    with pytest.raises(ValueError, match=r"LifelongConfig.library: unknown OptionSettings "
                       r"field\(s\) \['discout'\]"):
        LifelongConfig.from_dict({"library": {"discout": 0.5}})


@pytest.mark.slow
def test_tiny_loop_on_the_drill():
    """Three opponents then a held-out one, with and without options, on a tiny budget."""
    cfg = LifelongConfig(n_kernels=3, train_episodes=15, rollout_episodes=10,
                         learner=LearnerConfig(tile_widths=DRILL_WIDTHS))
    envs = [gym.make(DRILL, opponent=t) for t in ("chasers", "interceptors_cover", "goal_guards")]
    ll = LifelongLearner(cfg, envs[0].observation_space, 3, seed=0)
    for env, name in zip(envs, ("chasers", "interceptors_cover", "goal_guards"), strict=True):
        record = ll.run_trial(env, name)
        assert len(record.rewards) == 15
        assert all(-1.0 <= r <= 1.0 for r in record.rewards)
    held_out = gym.make(DRILL, opponent="interceptor_guard")
    _, with_options = ll.learn(held_out, with_options=True)
    _, anew = ll.learn(held_out, with_options=False)
    assert len(with_options) == len(anew) == 15


def test_every_learner_setting_reaches_the_smdp_learner() -> None:
    """A new LearnerConfig field must be wired to SmdpLearner (or be a tile setting)."""

    from ilpss.lifelong import LearnerConfig
    from ilpss.smdp import SmdpLearner
    from ilpss.tiles import TileCoder

    lc = LearnerConfig(alpha=0.05, method="sarsa", trace_decay=0.5, initial_value=0.5,
                       option_initial_value=0.25)
    learner = SmdpLearner(3, TileCoder([0.0], [1.0], [0.5]), None, lc)
    assert learner.config is lc
    assert learner.q.q_values([0.3])[0] == pytest.approx(0.5)
