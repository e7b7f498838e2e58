"""The SMDP episode seam (ilpss.episode), and the tests every learner standing on it shares.

Each shared test runs over ``LEARNERS``: SMDP Q-learning, PRQ-learning with no past
policy (then Q-learning too) and PRQ-learning reusing a past policy.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from synthetic_smdp import FAST, NoDurationEnv, ZoneCorridor, zone

from ilpss.baselines import PrqConfig, PrqLearner
from ilpss.episode import EpisodeLog, EpisodicLearner, check_env, observation, step_duration
from ilpss.policy import FrozenPolicy
from ilpss.smdp import LearnerConfig, SmdpLearner
from ilpss.tiles import TileCoder

GAMMA = 0.9


def coder() -> TileCoder:
    return TileCoder([0.0], [9.0], [1.0], n_tilings=4)


def fast_policy() -> FrozenPolicy:
    """Greedy on the fast action of every zone."""
    c = coder()
    w = np.zeros((3, c.n_weights))
    for x in np.arange(0.5, 9.0, 1.0):
        w[FAST[zone(x)], c.active(np.array([x]))] = 1.0
    return FrozenPolicy(c, 3, (), w)


def _config(settings: dict) -> LearnerConfig:
    """One-step Q-learning from values 0, with ``settings`` changed."""
    return LearnerConfig(**{"method": "q", "trace_decay": 0.0, "initial_value": 0.0, **settings})


LEARNERS = {
    "smdp": lambda seed=None, **kw: SmdpLearner(3, coder(), None, _config(kw), seed=seed),
    "prq": lambda seed=None, **kw: PrqLearner(3, coder(), [], _config(kw), seed=seed),
    "prq_reusing": lambda seed=None, **kw: PrqLearner(3, coder(), [fast_policy()], _config(kw),
                                                      PrqConfig(psi=0.9), seed=seed),
}
learners = pytest.mark.parametrize("kind", sorted(LEARNERS))


def make(kind: str, **kw) -> EpisodicLearner:
    return LEARNERS[kind](**{"gamma": GAMMA, **kw})


# ------------------------------------------------------------- the environment contract
def test_the_contract_functions() -> None:
    env = ZoneCorridor()
    check_env(env, 3, 1)
    with pytest.raises(ValueError, match=r"is not Discrete\(4\)"):
        check_env(env, 4, 1)
    with pytest.raises(ValueError, match=r"observations have shape \(1,\), the tile coder expects"):
        check_env(env, 3, 2)
    buffer = np.array([1.5], dtype=np.float32)
    x = observation(buffer, 1)
    buffer[0] = 7.0
    assert x.dtype == np.float64 and x[0] == 1.5  # a copy
    for bad, match in (([1.0, 2.0], "shape"), ([np.nan], "NaN"), ([np.inf], "NaN")):
        with pytest.raises(ValueError, match=match):
            observation(bad, 1)
    assert step_duration({}) == 1 and step_duration({"duration": np.int64(4)}) == 4
    for bad in (0, 1.5, "2", True, None):
        with pytest.raises(ValueError, match=r"info\['duration'\] must be an int >= 1"):
            step_duration({"duration": bad})


def test_a_result_before_any_step_is_refused_also_under_python_o() -> None:
    """Before, an assert: python -O dropped it, and the caller got an unrelated TypeError."""
    import subprocess
    import sys

    with pytest.raises(RuntimeError, match="an episode has at least one step"):
        EpisodeLog(0.9, 9, 10).result()
    done = subprocess.run([sys.executable, "-O", "-c", "from ilpss.episode import EpisodeLog\n"
                           "EpisodeLog(0.9, 9, 10).result()"], capture_output=True, text=True,
                          timeout=300, check=False)
    assert "RuntimeError: an episode has at least one step" in done.stderr


def test_the_log_makes_the_episode_result() -> None:
    log = EpisodeLog(gamma=0.5, n_features=1, max_decisions=2)
    for s, r, d in ((0.0, 1.0, 2), (1.0, -0.5, 1)):
        log.visit(np.array([s]))
        log.choose(0, explored=False)
        log.step(np.array([s + 1]), r, d, terminated=s == 1.0, truncated=False, info={})
    res = log.result()
    assert res.total_reward == 0.5 and res.discounted_return == 1.0 - 0.25 * 0.5
    assert res.cycles == 3 and res.decisions == 2 and res.trace.shape == (2, 1)
    assert res.success is False and res.outcome is None  # last reward not positive
    assert res.final_observation.tolist() == [2.0]
    with pytest.raises(RuntimeError, match="max_decisions=2"):
        log.visit(np.array([2.0]))
    won = EpisodeLog(1.0, 1, 10)
    won.visit(np.array([0.0]))
    won.step(np.array([1.0]), 1.0, 1, True, False, {"outcome": "interception"})
    assert won.result().success is False  # a reported outcome decides


# --------------------------------------------------------------- shared learner tests
@learners
def test_works_without_duration_or_outcome_in_info(kind) -> None:
    for res in make(kind, seed=0).train(NoDurationEnv(ZoneCorridor()), 20, seed=0):
        assert res.cycles == res.decisions and res.outcome is None
        # Success is inferred from a positive final reward at termination.
        assert res.success == bool(res.final_observation[0] >= 9)


@learners
def test_a_truncation_is_terminal_unless_bootstrapped(kind) -> None:
    env = ZoneCorridor(start_high=0.5, max_cycles=3)
    for flag, expected in [(False, -1.0 - 0.15), (True, -1.0 - 0.15 + GAMMA**3 * 2.0)]:
        learner = make(kind, alpha=1.0, epsilon=0.0, bootstrap_on_truncation=flag, seed=0)
        if kind == "prq_reusing":
            learner.psi = 0.0  # no reuse: the slow action below is the greedy one
        learner.q.weights[1] = 2.0 / coder().n_active  # Q(., slow) = 2 everywhere
        res = learner.run_episode(env, seed=0)
        assert res.truncated and res.decisions == 1 and res.outcome == "timeout"
        assert learner.q.q_values(res.trace[0])[1] == pytest.approx(expected)


@learners
def test_same_seed_same_learning_curve(kind) -> None:
    def curve(seed: int) -> tuple[list[float], list[list[int]], np.ndarray]:
        learner = make(kind, epsilon=0.1, seed=seed)
        results = learner.train(ZoneCorridor(), 100, seed=21)
        return [r.total_reward for r in results], [r.choices for r in results], \
            learner.q.weights.copy()

    (r1, c1, w1), (r2, c2, w2), (r3, c3, _) = curve(7), curve(7), curve(8)
    assert r1 == r2 and c1 == c2
    np.testing.assert_array_equal(w1, w2)
    assert (r3, c3) != (r1, c1)


@learners
def test_evaluation_is_greedy_and_changes_nothing(kind) -> None:
    learner = make(kind, epsilon=0.5, seed=0)
    calls: list[int] = []
    learner.train(ZoneCorridor(), 30, seed=1, callback=lambda i, res: calls.append(i))
    assert calls == list(range(30))
    weights = learner.q.weights.copy()
    results = learner.evaluate(ZoneCorridor(), 20, seed=2)
    assert len(results) == 20
    np.testing.assert_array_equal(learner.q.weights, weights)
    for res in results:
        assert not any(res.explored)
        for s, a in zip(res.trace, res.choices, strict=True):
            q = learner.q.q_values(s)
            assert q[a] == q.max()


@learners
def test_an_episode_records_what_happened(kind) -> None:
    learner = make(kind, epsilon=0.0, seed=0)
    if kind == "prq_reusing":
        learner.psi = 0.0
    env = ZoneCorridor(start_high=0.5, max_cycles=6)
    # Always the slow action of zone A: 3 cycles per step -> timeout after 2 steps.
    learner.q.weights[1] = 1.0
    res = learner.run_episode(env, seed=0)
    assert res.truncated and not res.terminated
    assert res.outcome == "timeout" and not res.success
    assert res.decisions == 2 and res.cycles == 6
    assert res.trace.shape == (2, 1) and res.trace[1, 0] == pytest.approx(res.trace[0, 0] + 1)
    assert res.final_observation[0] == pytest.approx(res.trace[0, 0] + 2)
    assert res.choices == [1, 1] and res.explored == [False, False]
    assert res.option_runs == [] and res.options_chosen == []


class NanEnv(ZoneCorridor):
    def step(self, action: int):
        obs, r, term, trunc, info = super().step(action)
        return np.full_like(obs, np.nan), r, term, trunc, info


class BadDurationEnv(ZoneCorridor):
    def __init__(self, duration: object) -> None:
        super().__init__()
        self.duration = duration

    def step(self, action: int):
        obs, r, term, trunc, info = super().step(action)
        return obs, r, term, trunc, {**info, "duration": self.duration}


@learners
def test_bad_environments_and_arguments_are_refused(kind) -> None:
    learner = make(kind, epsilon=0.0, seed=0)
    if kind == "prq_reusing":
        learner.psi = 0.0
    learner.q.weights[0] = 1.0  # the fast action of zone A: the episode goes on
    wrong_actions = ZoneCorridor()
    wrong_actions.action_space = gym.spaces.Discrete(4)
    for learn in (True, False):
        with pytest.raises(ValueError, match="Discrete"):
            learner.run_episode(wrong_actions, learn)
        with pytest.raises(ValueError, match="shape"):
            learner.run_episode(ZoneCorridor(n_features=2), learn)
        with pytest.raises(ValueError, match="NaN"):
            learner.run_episode(NanEnv(start_high=0.5), learn, seed=0)
        for bad in (0, 1.5, "2", True):
            with pytest.raises(ValueError, match="duration"):
                learner.run_episode(BadDurationEnv(bad), learn, seed=0)
    with pytest.raises(ValueError, match="n_episodes"):
        learner.train(ZoneCorridor(), -1)
    with pytest.raises(ValueError, match="n_episodes"):
        learner.evaluate(ZoneCorridor(), -1)
    capped = make(kind, epsilon=0.0, max_decisions=3, seed=0)
    if kind == "prq_reusing":
        capped.psi = 0.0
    capped.q.weights[0] = 1.0  # the fast action of zone A: more than 3 steps to the goal
    for learn in (True, False):
        with pytest.raises(RuntimeError, match="max_decisions=3"):
            capped.run_episode(ZoneCorridor(start_high=0.5), learn, seed=0)
    for name, value in (("alpha", 0.0), ("epsilon", 2.0), ("gamma", 1.5),
                        ("max_decisions", 0), ("initial_value", np.nan)):
        with pytest.raises(ValueError, match=rf"LearnerConfig.{name} must be"):
            make(kind, **{name: value})


def test_prq_learning_without_past_policies_is_smdp_q_learning() -> None:
    """Same draws and updates as SmdpLearner(method="q") (shared tiles: 4 tilings)."""
    kw = {"epsilon": 0.1, "initial_value": 1.0, "seed": 4}
    prq, smdp = make("prq", **kw), make("smdp", **kw)
    a = prq.train(ZoneCorridor(), 300, seed=8)
    b = smdp.train(ZoneCorridor(), 300, seed=8)
    assert [r.choices for r in a] == [r.choices for r in b]
    assert [r.total_reward for r in a] == [r.total_reward for r in b]
    np.testing.assert_array_equal(prq.q.weights, smdp.q.weights)
    assert prq.reused == [-1] * 300 and prq.reuse_counts.tolist() == [300]
    assert [r.choices for r in prq.evaluate(ZoneCorridor(), 5, seed=3)] == \
        [r.choices for r in smdp.evaluate(ZoneCorridor(), 5, seed=3)]
