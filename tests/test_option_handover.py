"""The switches that let options hand control back to the primitives.

Each is off by default (the paper's method); these tests show on small SMDPs with known
answers that each does what its docstring claims.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from synthetic_smdp import (
    FunctionKernels,
    ScriptedChain,
    ZoneCorridor,
    constant_kernels,
    constant_policy,
)

from ilpss.baselines import PrqLearner
from ilpss.episode import EpisodeResult, OptionRun, options_used
from ilpss.options import OptionLibrary
from ilpss.smdp import KEEPAWAY, LearnerConfig, SmdpLearner
from ilpss.tiles import TileCoder


def chain_coder(length: int) -> TileCoder:
    return TileCoder([0.0], [float(length)], [0.5], n_tilings=1)  # one tile per state


def set_q(learner: SmdpLearner, x: float, choice: int, value: float) -> None:
    a = learner.tile_coder.active(np.array([x]))
    learner.q.weights[choice, a] = value / a.shape[0]


def q_at(learner: SmdpLearner, x: float) -> np.ndarray:
    return learner.q.q_values(np.array([x]))


def _everywhere_option(length: int, action: int = 2):
    """A library with one option that may start and continue everywhere (K = 1)."""
    coder = chain_coder(length)
    lib = OptionLibrary(constant_kernels([1.0]), [constant_policy(action, coder=coder)])
    return coder, lib


# ---------------------------------------------------------------- interruption
@pytest.mark.parametrize("interruption", [False, True])
def test_interruption_stops_an_option_where_a_primitive_is_worth_more(interruption: bool):
    length = 6
    coder, lib = _everywhere_option(length)
    learner = SmdpLearner(3, coder, lib, config=replace(KEEPAWAY, epsilon=0.0, interruption=interruption), seed=0)
    for x in range(length):
        set_q(learner, x, 3, 1.0)  # the option is worth 1 everywhere ...
    set_q(learner, 3.0, 0, 2.0)  # ... but HOLD is worth more at x = 3
    env = ScriptedChain([0.0] * length, [1] * length)
    res = learner.run_episode(env, learn=False)
    first = res.option_runs[0]
    if interruption:
        assert (first.n_decisions, first.interrupted) == (3, True)
        assert env.actions[:4] == [2, 2, 2, 0]  # control went to the primitive at x = 3
    else:
        assert (first.n_decisions, first.interrupted) == (length, False)
        assert env.actions == [2] * length


# ----------------------------------------------------- intra-option primitives
def test_primitives_learn_from_the_steps_of_a_running_option():
    length, alpha = 4, 0.5
    coder, lib = _everywhere_option(length, action=2)
    rewards = [0.0, 0.0, 0.0, 1.0]
    plain = SmdpLearner(3, coder, lib, config=replace(KEEPAWAY, alpha=alpha, epsilon=0.0), seed=0)
    learner = SmdpLearner(3, coder, lib, config=replace(KEEPAWAY, alpha=alpha, epsilon=0.0, intra_option_primitives=True), seed=0)
    for lrn in (plain, learner):
        set_q(lrn, 0.0, 3, 1.0)  # the option is chosen at the start and runs to the end
        lrn.run_episode(ScriptedChain(rewards, [1] * length))
    # The primitive the option took (DRIBBLE = 2) got one-step Q-learning updates at
    # every state the option passed; the last one toward the terminal reward.
    assert q_at(learner, 3.0)[2] == pytest.approx(alpha * 1.0)
    assert q_at(plain, 3.0)[2] == 0.0
    for x in (1.0, 2.0, 3.0):
        # Nothing else changed at the states inside the option: the other primitives,
        # and the option itself (its SMDP update is at the start state only).
        np.testing.assert_array_equal(q_at(learner, x)[[0, 1, 3]], q_at(plain, x)[[0, 1, 3]])
    np.testing.assert_array_equal(q_at(learner, 0.0)[3], q_at(plain, 0.0)[3])


# --------------------------------------------------------------- option bonus
def test_option_bonus_fades_linearly_over_the_learning_episodes():
    _, lib = _everywhere_option(3)
    learner = SmdpLearner(3, chain_coder(3), lib, config=replace(KEEPAWAY, option_bonus=1.5, option_bonus_episodes=4))
    assert [learner.option_bonus_at(e) for e in range(6)] == [1.5, 1.125, 0.75, 0.375, 0.0, 0.0]
    without_options = SmdpLearner(3, chain_coder(3), config=replace(KEEPAWAY, option_bonus=1.5, option_bonus_episodes=4))
    assert without_options.option_bonus_at(0) == 0.0


def test_option_bonus_makes_the_learner_follow_options_first_then_hand_back():
    length = 3
    coder, lib = _everywhere_option(length, action=2)
    learner = SmdpLearner(3, coder, lib, config=replace(KEEPAWAY, epsilon=0.0, alpha=1e-9, option_bonus=1.0, option_bonus_episodes=2), seed=0)
    for x in range(length):
        set_q(learner, x, 0, 0.8)  # HOLD is worth more than the option ...
        set_q(learner, x, 3, 0.5)  # ... but by less than the bonus
    first = learner.run_episode(ScriptedChain([0.0] * length, [1] * length))
    assert first.options_chosen == [0]
    learner.run_episode(ScriptedChain([0.0] * length, [1] * length))  # bonus 0.5 > 0.3
    third = learner.run_episode(ScriptedChain([0.0] * length, [1] * length))  # bonus 0
    assert third.options_chosen == [] and third.choices == [0] * length
    rollout = SmdpLearner(3, coder, lib, config=replace(KEEPAWAY, epsilon=0.0, option_bonus=1.0, option_bonus_episodes=10), seed=0)
    rollout.q.weights[:] = learner.q.weights
    assert rollout.run_episode(ScriptedChain([0.0] * length, [1] * length),
                               learn=False).options_chosen == []  # no bonus when not learning


def test_with_a_bonus_the_target_is_the_value_of_the_bonus_greedy_choice():
    """Q(0, HOLD) bootstraps from the option at x = 1 (chosen thanks to the bonus),
    not from the larger raw value of DRIBBLE there."""
    coder = chain_coder(2)
    # The option may start only at x = 1.
    model = FunctionKernels([lambda s: 1.0 if s[0] >= 1 else 0.0], [[1.0]], [[[1.0]]])
    lib = OptionLibrary(model, [constant_policy(2, coder=coder)])
    alpha = 0.5
    learner = SmdpLearner(3, coder, lib, config=LearnerConfig(method="q", trace_decay=0.0, initial_value=0.0, alpha=alpha, epsilon=0.0, option_bonus=1.0, option_bonus_episodes=100), seed=0)
    set_q(learner, 0.0, 0, 0.1)  # HOLD is greedy at x = 0 (the option cannot start there)
    set_q(learner, 1.0, 2, 0.6)  # raw values at x = 1: DRIBBLE 0.6, the option 0.2
    set_q(learner, 1.0, 3, 0.2)  # with the bonus the option is chosen (1.2 > 0.6)
    learner.run_episode(ScriptedChain([0.0, 0.0], [1, 1]))
    assert q_at(learner, 0.0)[0] == pytest.approx(0.1 + alpha * (0.2 - 0.1))


# -------------------------------------------------------------------- usage
def _result_with_runs(runs: list[OptionRun]) -> EpisodeResult:
    return EpisodeResult(0.0, 0.0, 1, 1, None, False, True, False, np.zeros((1, 1)),
                         np.zeros(1), option_runs=runs)


def test_usage_counts_the_decisions_an_option_ran():
    results = [
        _result_with_runs([OptionRun(5, 0, 1, 1, False, False), OptionRun(6, 1, 4, 4, False, False)]),
        _result_with_runs([OptionRun(5, 0, 2, 2, False, False), OptionRun(7, 0, 9, 9, False, True)]),
    ]
    assert options_used(results) == {5, 6}  # the paper: any greedy start
    assert options_used(results, min_decisions=3) == {5, 6}  # 5 ran 1 + 2 decisions
    assert options_used(results, min_decisions=4) == {6}
    assert options_used(results, greedy_only=False, min_decisions=5) == {7}


# ------------------------------------------------------- PRQ's base learner
def _corridor_coder() -> TileCoder:
    return TileCoder([0.0], [9.0], [1.0], n_tilings=4)


def test_prq_with_traces_on_an_empty_library_is_watkins_q_lambda():
    lc = LearnerConfig(gamma=0.9, epsilon=0.1, initial_value=1.0, trace_decay=0.8)
    prq = PrqLearner(3, _corridor_coder(), [], lc, seed=4)
    smdp = SmdpLearner(3, _corridor_coder(), None, lc, seed=4)
    a = prq.train(ZoneCorridor(), 200, seed=8)
    b = smdp.train(ZoneCorridor(), 200, seed=8)
    assert [r.choices for r in a] == [r.choices for r in b]
    np.testing.assert_array_equal(prq.q.weights, smdp.q.weights)
    one_step = PrqLearner(3, _corridor_coder(), [], replace(lc, trace_decay=0.0), seed=4)
    one_step.train(ZoneCorridor(), 200, seed=8)
    assert not np.array_equal(one_step.q.weights, prq.q.weights)
