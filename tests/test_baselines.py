"""Tests of ilpss.baselines: PRQ-learning with pi-reuse (Fernández and Veloso 2006)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np
import pytest
from synthetic_smdp import (
    FAST,
    FATAL,
    ScriptedChain,
    ZoneCorridor,
    binomial_ok,
    constant_policy,
    optimal_action,
    optimal_value,
    zone,
)

from ilpss.baselines import PrqConfig, PrqLearner
from ilpss.policy import FrozenPolicy
from ilpss.smdp import EpisodeResult, LearnerConfig
from ilpss.tiles import TileCoder

GAMMA = 0.9
Z999 = 3.29

ONE_STEP = LearnerConfig(trace_decay=0.0, initial_value=0.0)
"""The paper's PRQ base learner: one-step Q-learning from values 0."""


def cell_coder() -> TileCoder:
    """One tiling of width 1: one tile per corridor cell, aligned with the zones, so a
    zone-dependent policy can be written exactly."""
    return TileCoder([0.0], [9.0], [1.0], n_tilings=1)


def corridor_coder() -> TileCoder:
    return TileCoder([0.0], [9.0], [1.0], n_tilings=4)


def chain_coder(length: int) -> TileCoder:
    # Width 0.5 with one tiling: the integer states of a chain share no tile.
    return TileCoder([0.0], [float(length)], [0.5], n_tilings=1)


def zone_policy(action_of_zone: Mapping[int, int], coder: TileCoder | None = None) -> FrozenPolicy:
    """A past policy whose greedy action in zone z is ``action_of_zone[z]`` (Q = 1 for it,
    0 for the others)."""
    coder = coder or cell_coder()
    w = np.zeros((3, coder.n_weights))
    for cell in range(9):
        w[action_of_zone[zone(cell + 0.5)], coder.active([cell + 0.5])] = 1.0
    return FrozenPolicy(coder, 3, (), w)


def interior_points() -> list[float]:
    return [n + f for n in range(9) for f in (0.3, 0.5, 0.7)]


def is_optimal_episode(res: EpisodeResult, cost: float = 0.05) -> bool:
    best = optimal_value(res.trace[0, 0], GAMMA, cost)
    return bool(res.success and abs(res.discounted_return - best) < 1e-9)


def mean_reward(results: list[EpisodeResult]) -> float:
    return float(np.mean([r.total_reward for r in results]))


def test_zone_policy_helper_is_what_it_says() -> None:
    rng = np.random.default_rng(0)
    good, bad = zone_policy(FAST), zone_policy(FATAL)
    for x in interior_points():
        assert good.greedy(np.array([x]), rng) == optimal_action(x)
        assert bad.greedy(np.array([x]), rng) == FATAL[zone(x)]


# ------------------------------------------------------------------ reuse works
def test_optimal_past_policy_is_reused_and_speeds_up_learning() -> None:
    """Across seeds, reusing an optimal past policy beats learning from scratch early on
    (checked on 40 seeds: the first-50 mean is higher on every one, by 0.15 +- 0.06)."""
    seeds = range(6)
    n_early = 50
    diffs = []
    for seed in seeds:
        prq = PrqLearner(3, cell_coder(), [zone_policy(FAST)], config=LearnerConfig(trace_decay=0.0, initial_value=1.0, gamma=GAMMA), seed=seed)
        p0 = prq.selection_probabilities()
        np.testing.assert_allclose(p0, [0.5, 0.5])  # tau0 = 0: uniform at first
        curve = prq.train(ZoneCorridor(), 300, seed=100 + seed)
        scratch = PrqLearner(3, cell_coder(), [], config=LearnerConfig(trace_decay=0.0, initial_value=1.0, gamma=GAMMA), seed=seed)
        base = scratch.train(ZoneCorridor(), n_early, seed=100 + seed)
        diffs.append(mean_reward(curve[:n_early]) - mean_reward(base))
        # Its gain exceeds that of the new policy, so its probability grows to ~1.
        assert prq.reuse_gains[0] > prq.reuse_gains[-1]
        p = prq.selection_probabilities()
        assert p[0] > 0.99 and p.sum() == pytest.approx(1.0)
        reused = np.array(prq.reused)
        assert (reused[-100:] == 0).mean() > (reused[:n_early] == 0).mean()
        assert prq.reuse_counts.sum() == 300 and prq.tau == pytest.approx(300 * 0.05)
    assert np.mean(diffs) > 0.05
    assert sum(d > 0 for d in diffs) >= 5


def test_bad_past_policy_is_abandoned_and_the_optimum_learnt() -> None:
    for seed in range(3):
        prq = PrqLearner(3, cell_coder(), [zone_policy(FATAL)], config=LearnerConfig(trace_decay=0.0, initial_value=1.0, gamma=GAMMA), seed=seed)
        curve = prq.train(ZoneCorridor(), 1500, seed=200 + seed)
        reused = np.array(prq.reused)
        # psi_0 = 1: every reuse episode starts with the fatal action.
        assert prq.reuse_gains[0] == -1.0
        for res, k in zip(curve, reused, strict=True):
            if k == 0:
                assert res.decisions == 1 and res.outcome == "interception"
        share_early = (reused[:50] == 0).mean()
        share_late = (reused[-500:] == 0).mean()
        assert share_early > 0.1 and share_late < 0.01 and share_late < share_early
        assert prq.selection_probabilities()[0] < 1e-6
        # The new policy is optimal in every zone, and its values near the optimum.
        rng = np.random.default_rng(0)
        for x in interior_points():
            assert prq.q.greedy(np.array([x]), rng) == optimal_action(x)
        for n in range(9):
            v = prq.q.q_values(np.array([n + 0.5])).max()
            assert v == pytest.approx(optimal_value(n + 0.5, GAMMA, 0.05), abs=0.15)
        evaluation = prq.evaluate(ZoneCorridor(), 200, seed=99)
        assert np.mean([is_optimal_episode(r) for r in evaluation]) >= 0.9


# ------------------------------------------------------------------ pi-reuse
def test_pi_reuse_follows_the_past_policy_with_decaying_probability() -> None:
    """In reuse episodes, decision h follows the past policy with probability
    psi * upsilon ** h.

    Chain with unique states, reward 1 only at the end and gamma = 1: every Q-learning
    target is 1, so the new Q stays greedy for action 1 (Q = 1 exactly) while the past
    policy always takes 2 (epsilon = 0): the action tells who chose it.
    """
    H, psi, upsilon = 30, 0.8, 0.9
    coder = chain_coder(H)
    env = ScriptedChain([0.0] * (H - 1) + [1.0], [1] * H)
    prq = PrqLearner(3, coder, [constant_policy(2, coder=coder)], config=replace(ONE_STEP, alpha=0.01, epsilon=0.0), reuse=PrqConfig(psi=psi, upsilon=upsilon, delta_tau=0.0), seed=5)
    prq.q.weights[1] = 1.0 / coder.n_active
    hits = np.zeros(H, dtype=np.int64)
    n_reuse = 0
    for _ in range(1000):
        prq.run_episode(env)
        actions = np.array(env.actions)
        followed = np.array(prq.followed_past)
        np.testing.assert_array_equal(followed, actions == 2)
        assert set(actions) <= {1, 2}
        if prq.reused[-1] == 0:
            n_reuse += 1
            hits += followed
        else:
            assert not followed.any()  # Pi_Omega episodes never follow the past policy
    assert binomial_ok(n_reuse, 1000, 0.5)
    p = psi * upsilon ** np.arange(H)
    for h in range(H):
        assert binomial_ok(int(hits[h]), n_reuse, float(p[h])), h
    # Pooled: the number of steps that followed the past policy.
    sd = np.sqrt(np.sum(n_reuse * p * (1 - p)))
    assert abs(hits.sum() - n_reuse * p.sum()) < Z999 * sd
    # The decay rate estimated from the counts is upsilon.
    slope = np.polyfit(np.arange(12), np.log(hits[:12] / n_reuse), 1)[0]
    assert np.exp(slope) == pytest.approx(upsilon, abs=0.02)


def test_policy_choice_follows_the_softmax_of_the_gains() -> None:
    """With gains pinned (huge counts) and tau fixed, choices follow exp(tau W)."""
    coder = chain_coder(1)
    env = ScriptedChain([0.5], [1])
    past = [constant_policy(a, coder=coder) for a in (0, 1)]
    prq = PrqLearner(3, coder, past, config=ONE_STEP, reuse=PrqConfig(tau0=2.0, delta_tau=0.0), seed=3)
    prq.reuse_gains[:] = [0.5, -0.3, 0.1]
    prq.reuse_counts[:] = 10**12
    expected = np.exp(2.0 * prq.reuse_gains)
    expected /= expected.sum()
    np.testing.assert_allclose(prq.selection_probabilities(), expected)
    n = 3000
    prq.train(env, n)
    reused = np.array(prq.reused)
    for j, k in enumerate((0, 1, -1)):
        assert binomial_ok(int((reused == k).sum()), n, float(expected[j]))
    # Large tau * W does not overflow.
    prq.tau = 1e6
    p = prq.selection_probabilities()
    assert np.isfinite(p).all() and p[0] == pytest.approx(1.0)


def test_gains_counts_and_tau_follow_the_update_rule() -> None:
    prq = PrqLearner(3, cell_coder(), [zone_policy(FAST), zone_policy(FATAL)], config=replace(ONE_STEP, gamma=GAMMA), reuse=PrqConfig(tau0=0.5), seed=1)
    curve = prq.train(ZoneCorridor(), 200, seed=3)
    reused = np.array(prq.reused)
    rewards = np.array([r.total_reward for r in curve])
    for j, k in enumerate((0, 1, -1)):
        sel = reused == k
        assert prq.reuse_counts[j] == sel.sum() > 0
        assert prq.reuse_gains[j] == pytest.approx(rewards[sel].mean())
    assert prq.tau == pytest.approx(0.5 + 200 * 0.05)


def test_q_learning_update_with_durations_in_a_reuse_episode() -> None:
    """Every step of a reuse episode updates the new Q by SMDP Q-learning (max, not the
    action that will be taken), with gamma ** duration, and a terminal target r."""
    rewards, durations = [0.5, -0.2, 1.0], [2, 3, 1]
    env = ScriptedChain(rewards, durations)
    coder = chain_coder(3)
    alpha, gamma = 0.5, 0.8
    prq = PrqLearner(3, coder, [constant_policy(2, coder=coder)], config=replace(ONE_STEP, alpha=alpha, epsilon=0.0, gamma=gamma), reuse=PrqConfig(psi=1.0, upsilon=1.0, tau0=50.0), seed=0)
    prq.reuse_gains[0] = 1.0  # P(reuse) = 1 - 1e-22
    a1 = coder.active([1.0])
    a2 = coder.active([2.0])
    prq.q.weights[0, a1] = 0.7  # max at x = 1 is action 0 (the past policy takes 2)
    prq.q.weights[1, a2] = -0.4  # max at x = 2 is 0 (action 0 and 2 are still 0)
    res = prq.run_episode(env)
    assert prq.reused == [0] and env.actions == [2, 2, 2] and prq.followed_past == [True] * 3
    q = [prq.q.q_values(np.array([x])) for x in (0.0, 1.0, 2.0)]
    assert q[0][2] == pytest.approx(alpha * (0.5 + gamma**2 * 0.7))
    assert q[1][2] == pytest.approx(alpha * (-0.2 + gamma**3 * 0.0))
    assert q[2][2] == pytest.approx(alpha * 1.0)  # terminal: r alone
    assert q[1][0] == pytest.approx(0.7)  # actions not taken keep their values
    assert res.total_reward == pytest.approx(sum(rewards)) and res.cycles == 6
    assert res.discounted_return == pytest.approx(0.5 + gamma**2 * -0.2 + gamma**5 * 1.0)
    assert res.choices == [2, 2, 2] and res.explored == [False] * 3
    assert res.options_chosen == [] and res.option_runs == []
    np.testing.assert_array_equal(res.trace[:, 0], [0.0, 1.0, 2.0])
    assert prq.reuse_gains[0] == pytest.approx(sum(rewards)) and prq.reuse_counts[0] == 1


# ------------------------------------------------------------------ API behaviour
def _curve(seed: int) -> tuple[list[float], list[int], np.ndarray, np.ndarray]:
    prq = PrqLearner(3, cell_coder(), [zone_policy(FAST), zone_policy(FATAL)], config=replace(ONE_STEP, gamma=GAMMA, epsilon=0.1), reuse=PrqConfig(psi=0.9), seed=seed)
    results = prq.train(ZoneCorridor(), 150, seed=21)
    return [r.total_reward for r in results], prq.reused, prq.q.weights.copy(), prq.reuse_gains


def test_same_seed_same_learning_curve() -> None:
    r1, k1, w1, g1 = _curve(7)
    r2, k2, w2, g2 = _curve(7)
    assert r1 == r2 and k1 == k2
    np.testing.assert_array_equal(w1, w2)
    np.testing.assert_array_equal(g1, g2)
    r3, k3, _, _ = _curve(8)
    assert (r3, k3) != (r1, k1)


def test_evaluation_reuses_nothing_and_changes_no_gain() -> None:
    """(Greedy and leaving Q alone: tests/test_episode.py, for every learner.)"""
    prq = PrqLearner(3, cell_coder(), [zone_policy(FAST)], config=replace(ONE_STEP, gamma=GAMMA, epsilon=0.5), seed=0)
    prq.train(ZoneCorridor(), 30, seed=1)
    state = (prq.reuse_gains.copy(), prq.reuse_counts.copy(), prq.tau)
    results = prq.evaluate(ZoneCorridor(), 20, seed=2)
    assert len(prq.reused) == 30
    np.testing.assert_array_equal(prq.reuse_gains, state[0])
    np.testing.assert_array_equal(prq.reuse_counts, state[1])
    assert prq.tau == state[2]
    assert prq.followed_past == [False] * results[-1].decisions


def test_frozen_policy_can_join_the_next_library() -> None:
    prq = PrqLearner(3, cell_coder(), [], config=LearnerConfig(trace_decay=0.0, initial_value=1.0, gamma=GAMMA), seed=0)
    prq.train(ZoneCorridor(), 200, seed=0)
    frozen = prq.freeze()
    assert isinstance(frozen, FrozenPolicy) and frozen.option_ids == ()
    np.testing.assert_array_equal(frozen.weights, prq.q.weights)
    nxt = PrqLearner(3, cell_coder(), [frozen, prq.q], config=ONE_STEP, seed=1)  # a LinearPolicy is frozen
    assert all(isinstance(p, FrozenPolicy) for p in nxt.past_policies)
    assert nxt.reuse_gains.shape == (3,) and "n_past=2" in repr(nxt)


# ------------------------------------------------------------------ bad inputs
@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"psi": 1.2}, ValueError, "psi"),
        ({"psi": -0.1}, ValueError, "psi"),
        ({"upsilon": 1.01}, ValueError, "upsilon"),
        ({"tau0": -1.0}, ValueError, "tau0"),
        ({"tau0": float("inf")}, ValueError, "tau0"),
        ({"delta_tau": -0.05}, ValueError, "delta_tau"),
        ({"delta_tau": "0.1"}, ValueError, r"PrqConfig.delta_tau must be a finite number >= 0"),
        ({"psi": True}, ValueError, r"PrqConfig.psi must be a finite number in \[0, 1\], got True"),
    ],
)
def test_bad_hyper_parameters(kwargs: dict, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        PrqConfig(**kwargs)


def test_bad_past_policies() -> None:
    coder = cell_coder()
    with pytest.raises(TypeError, match="TileCoder"):
        PrqLearner(3, None, [], config=ONE_STEP)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="options"):
        PrqLearner(3, coder, [constant_policy(0, option_ids=(4,), coder=coder)], config=ONE_STEP)
    with pytest.raises(ValueError, match="tile coder"):
        PrqLearner(3, coder, [zone_policy(FAST), constant_policy(0, coder=corridor_coder())], config=ONE_STEP)
    with pytest.raises(ValueError, match="primitive"):
        PrqLearner(3, coder, [constant_policy(0, n_primitive=4, coder=coder)], config=ONE_STEP)
    with pytest.raises(TypeError, match="FrozenPolicy"):
        PrqLearner(3, coder, [np.zeros((3, coder.n_weights))], config=ONE_STEP)  # type: ignore[list-item]
    with pytest.raises(TypeError, match="sequence"):
        PrqLearner(3, coder, zone_policy(FAST), config=ONE_STEP)  # type: ignore[arg-type]
