"""Tests of ilpss.smdp: SMDP Sarsa / Q-learning over primitives and kernel options."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from synthetic_smdp import (
    FunctionKernels,
    IntervalKernels,
    NoDurationEnv,
    ScriptedChain,
    ZoneCorridor,
    binomial_ok,
    constant_kernels,
    constant_policy,
    optimal_action,
    optimal_value,
)

from ilpss.episode import options_used
from ilpss.options import OptionLibrary, OptionSettings
from ilpss.smdp import KEEPAWAY, EpisodeResult, LearnerConfig, SmdpLearner
from ilpss.tiles import TileCoder

GAMMA = 0.9


def corridor_coder() -> TileCoder:
    return TileCoder([0.0], [9.0], [1.0], n_tilings=4)


def chain_coder(length: int) -> TileCoder:
    # Width 0.5 with one tiling: the integer states of a chain share no tile.
    return TileCoder([0.0], [float(length)], [0.5], n_tilings=1)


def greedy_primitive(learner: SmdpLearner, x: float, rng: np.random.Generator) -> int:
    """The primitive the greedy learner would take at ``x`` (options resolved), counting
    only options that could start there (K > 0)."""
    s = np.array([x])
    q = learner.q.q_values(s)
    mask = np.ones(learner.n_choices, dtype=bool)
    lib = learner.library
    if lib is not None and len(lib):
        mask[learner.n_primitive :] = lib.memberships(lib.membership(s)) > 0
    c = int(np.argmax(np.where(mask, q, -np.inf)))
    if c < learner.n_primitive:
        return c
    return lib.act(learner.option_ids[c - learner.n_primitive], s, rng)  # type: ignore[union-attr]


def interior_points() -> list[float]:
    return [n + f for n in range(9) for f in (0.3, 0.5, 0.7)]


def is_optimal_episode(res: EpisodeResult, cost: float = 0.05) -> bool:
    """Whether the episode's discounted return is the optimal value of its start."""
    best = optimal_value(res.trace[0, 0], GAMMA, cost)
    return bool(res.success and abs(res.discounted_return - best) < 1e-9)


def set_q(learner: SmdpLearner, x: float, choice: int, value: float) -> None:
    a = learner.tile_coder.active(np.array([x]))
    learner.q.weights[choice, a] = value / a.shape[0]


# ------------------------------------------------------------------ convergence
@pytest.mark.parametrize("method", ["sarsa", "q"])
def test_converges_to_the_optimal_policy_without_options(method: str) -> None:
    env = ZoneCorridor()
    learner = SmdpLearner(3, corridor_coder(), config=LearnerConfig(method=method, trace_decay=0.0, initial_value=1.0, gamma=GAMMA), seed=0)
    curve = learner.train(env, 2000, seed=10)
    rng = np.random.default_rng(0)
    assert all(greedy_primitive(learner, x, rng) == optimal_action(x) for x in interior_points())
    evaluation = learner.evaluate(env, 300, seed=99)
    assert np.mean([is_optimal_episode(r) for r in evaluation]) >= 0.9
    # The learnt values approach the hand-computed optimum at cell centres.
    for n in range(9):
        v = learner.q.q_values(np.array([n + 0.5])).max()
        assert v == pytest.approx(optimal_value(n + 0.5, GAMMA, 0.05), abs=0.15)
    # It learnt: late episodes succeed far more often than early ones.
    early = np.mean([r.success for r in curve[:100]])
    late = np.mean([r.success for r in curve[-200:]])
    assert late > 0.95 and late > early


def test_durations_are_discounted_per_cycle() -> None:
    """With no per-cycle cost only gamma ** duration separates fast from slow actions.

    Q-learning is used here because its targets do not depend on exploration, so with
    the small margins of this variant it settles reliably (checked over 16 seeds: >= 84 %
    optimal episodes with durations, <= 59 % without); the duration arithmetic itself
    is shared by both methods and checked exactly in the tests below.
    """
    env = ZoneCorridor(cost=0.0)
    learner = SmdpLearner(3, corridor_coder(), config=LearnerConfig(method="q", trace_decay=0.0, initial_value=1.0, gamma=GAMMA), seed=1)
    learner.train(env, 2000, seed=4)
    rng = np.random.default_rng(0)
    # In the last cell both reach the goal within the step, whose reward is not
    # discounted by its own duration: a true tie when cost = 0, so it is left out.
    points = [x for x in interior_points() if x < 8]
    assert all(greedy_primitive(learner, x, rng) == optimal_action(x) for x in points)
    env_eval = ZoneCorridor(cost=0.0)
    evaluation = learner.evaluate(env_eval, 300, seed=9)
    assert np.mean([is_optimal_episode(r, cost=0.0) for r in evaluation]) >= 0.8
    # Blind to durations (no "duration" in info: 1 cycle assumed), slow steps look as
    # good as fast ones, and the learnt policy wastes cycles.
    blind = SmdpLearner(3, corridor_coder(), config=LearnerConfig(method="q", trace_decay=0.0, initial_value=1.0, gamma=GAMMA), seed=1)
    blind.train(NoDurationEnv(ZoneCorridor(cost=0.0)), 2000, seed=4)
    evaluation = blind.evaluate(env_eval, 300, seed=9)
    assert np.mean([is_optimal_episode(r, cost=0.0) for r in evaluation]) < 0.7


@pytest.mark.parametrize("intra_option", [False, True])
def test_converges_with_options(intra_option: bool) -> None:
    coder = corridor_coder()
    good = constant_policy(1, coder=coder)  # the fast action of zone B
    bad = constant_policy(0, coder=coder)  # the fatal action of zone B
    lib = OptionLibrary(IntervalKernels([(3, 6)], inside=0.9), [good, bad])
    env = ZoneCorridor()
    learner = SmdpLearner(3, coder, lib, config=LearnerConfig(method="sarsa", trace_decay=0.0, initial_value=1.0, gamma=GAMMA, intra_option=intra_option), seed=0)
    assert learner.option_ids == (0, 1)
    learner.train(env, 2000, seed=4)
    rng = np.random.default_rng(0)
    assert all(greedy_primitive(learner, x, rng) == optimal_action(x) for x in interior_points())
    evaluation = learner.evaluate(env, 300, seed=99)
    assert np.mean([is_optimal_episode(r) for r in evaluation]) >= 0.9
    # The bad option is never used by the learnt policy.
    assert 1 not in options_used(evaluation)
    # Options only start inside their kernel (K = 0 outside [3, 6)).
    for res in evaluation:
        for run in res.option_runs:
            assert 3 <= res.trace[run.start_decision, 0] < 6
    assert lib.options()[0].uses + lib.options()[1].uses > 0


def test_converges_with_options_on_the_real_kernel_model() -> None:
    kernels = pytest.importorskip("ilpss.kernels")
    rng = np.random.default_rng(0)
    bag = rng.uniform(3.0, 6.0, size=(300, 1))  # successful states in zone B
    model = kernels.SharedKernelModel(n_components=1, random_state=0).fit([bag])
    coder = corridor_coder()
    lib = OptionLibrary(model, [constant_policy(1, coder=coder)])
    m = [lib.membership(np.array([x]))[0] for x in (1.0, 4.5, 8.0)]
    assert m[1] > 0.8 and m[0] < 0.01 and m[2] < 0.01
    learner = SmdpLearner(3, coder, lib, config=LearnerConfig(method="sarsa", trace_decay=0.0, initial_value=1.0, gamma=GAMMA), seed=0)
    learner.train(ZoneCorridor(), 2000, seed=6)
    evaluation = learner.evaluate(ZoneCorridor(), 300, seed=99)
    assert np.mean([is_optimal_episode(r) for r in evaluation]) >= 0.9


def test_good_option_is_used_and_discounting_follows() -> None:
    coder = corridor_coder()
    good = constant_policy(1, coder=coder)
    bad = constant_policy(0, coder=coder)
    lib = OptionLibrary(IntervalKernels([(3, 6)], inside=0.9), [good, bad])
    # Prefer options a priori (as after a transfer) so that the greedy policy keeps them.
    learner = SmdpLearner(3, coder, lib, config=LearnerConfig(method="q", trace_decay=0.0, initial_value=0.0, gamma=GAMMA), seed=2)
    learner.q.weights[3:] += 1.0 / coder.n_active
    learner.train(ZoneCorridor(), 1500, seed=5)
    used = options_used(learner.evaluate(ZoneCorridor(), 200, seed=7))
    assert used == {0}
    report = lib.end_trial(used)
    assert report.discounted == (1,) and lib.scale(0) == 1.0 and lib.scale(1) == 0.5


# ------------------------------------------------------------------ exact update
@pytest.mark.parametrize("method", ["sarsa", "q"])
def test_option_update_spans_start_to_termination(method: str) -> None:
    rewards = [0.5, -0.2, 1.0, 0.3, 0.0, 2.0]
    durations = [2, 1, 3, 1, 1, 1]
    env = ScriptedChain(rewards, durations)
    coder = chain_coder(len(rewards))
    # Kernel: K = 1 for x < 3, 0 from x = 3: the option runs at x = 0, 1, 2 and stops at 3.
    model = FunctionKernels([lambda s: 1.0 if s[0] < 3 else 0.0], [[1.0]], [[[1.0]]])
    lib = OptionLibrary(model, [constant_policy(2, coder=coder)])
    alpha, gamma = 0.5, 0.8
    learner = SmdpLearner(3, coder, lib, config=LearnerConfig(method=method, trace_decay=0.0, initial_value=0.0, alpha=alpha, epsilon=0.0, gamma=gamma), seed=0)
    set_q(learner, 0.0, 3, 5.0)  # the option is the greedy choice at x = 0
    set_q(learner, 3.0, 1, 0.7)  # the best choice at x = 3 (where the option is unavailable)
    set_q(learner, 3.0, 0, 0.2)
    res = learner.run_episode(env, learn=True)
    assert env.actions[:3] == [2, 2, 2]  # the option's policy acted
    assert res.options_chosen == [0]
    run = res.option_runs[0]
    assert (run.start_decision, run.n_decisions, run.cycles) == (0, 3, 6)
    assert not run.ended_by_episode and not run.explored
    R = 0.5 + gamma**2 * -0.2 + gamma**3 * 1.0
    D = 2 + 1 + 3
    target = R + gamma**D * 0.7
    q0 = learner.q.q_values(np.array([0.0]))[3]
    assert q0 == pytest.approx(5.0 + alpha * (target - 5.0), abs=1e-12)
    # The states inside the option got no update of their own.
    for x in (1.0, 2.0):
        np.testing.assert_array_equal(learner.q.q_values(np.array([x])), 0.0)
    assert res.cycles == sum(durations) and res.decisions == 6
    assert res.total_reward == pytest.approx(sum(rewards))
    elapsed = np.concatenate(([0], np.cumsum(durations)[:-1]))
    assert res.discounted_return == pytest.approx(float(np.sum(gamma**elapsed * rewards)))
    np.testing.assert_array_equal(res.trace[:, 0], np.arange(6.0))


def test_primitive_updates_and_terminal_target() -> None:
    rewards = [1.0, 2.0]
    durations = [3, 2]
    env = ScriptedChain(rewards, durations)
    coder = chain_coder(2)
    alpha, gamma = 0.25, 0.5
    learner = SmdpLearner(3, coder, config=replace(KEEPAWAY, alpha=alpha, epsilon=0.0, gamma=gamma), seed=0)
    set_q(learner, 0.0, 1, 1.0)
    set_q(learner, 1.0, 2, 4.0)
    learner.run_episode(env)
    assert env.actions == [1, 2]
    # Sarsa: Q(0, 1) <- 1 + a (1 + g^3 * 4 - 1); the last update's target is the reward.
    assert learner.q.q_values(np.array([0.0]))[1] == pytest.approx(1 + alpha * gamma**3 * 4.0)
    assert learner.q.q_values(np.array([1.0]))[2] == pytest.approx(4 + alpha * (2.0 - 4.0))


@pytest.mark.parametrize("lam", [0.0, 0.7])
def test_eligibility_traces_carry_later_errors_back(lam: float) -> None:
    env = ScriptedChain([1.0, 2.0], [3, 2])
    alpha, gamma = 0.25, 0.5
    learner = SmdpLearner(3, chain_coder(2), config=LearnerConfig(method="sarsa", trace_decay=lam, initial_value=0.0, alpha=alpha, epsilon=0.0, gamma=gamma), seed=0)
    set_q(learner, 0.0, 1, 1.0)
    set_q(learner, 1.0, 2, 4.0)
    learner.run_episode(env)
    # delta_1 = 1 + g^3 * 4 - 1; the terminal delta_2 = 2 - 4 also reaches Q(0, 1)
    # with eligibility g^3 * lambda (zero when lambda = 0).
    expected = 1 + alpha * gamma**3 * 4.0 + alpha * (2.0 - 4.0) * gamma**3 * lam
    assert learner.q.q_values(np.array([0.0]))[1] == pytest.approx(expected)
    assert learner.q.q_values(np.array([1.0]))[2] == pytest.approx(4 + alpha * (2.0 - 4.0))


def test_traces_replace_rather_than_accumulate_on_shared_tiles() -> None:
    """Two successive states in one tile: its eligibility is reset to 1, not 1 + g^3 lambda."""
    env = ScriptedChain([1.0, 2.0], [3, 2])
    alpha, gamma, lam = 0.25, 0.5, 0.7
    coder = TileCoder([0.0], [2.0], [10.0], n_tilings=1)  # states 0 and 1 share the tile
    learner = SmdpLearner(3, coder, config=LearnerConfig(method="sarsa", trace_decay=lam, initial_value=0.0, alpha=alpha, epsilon=0.0, gamma=gamma), seed=0)
    learner.q.weights[1] = 1.0  # action 1 is greedy everywhere
    learner.run_episode(env)
    assert env.actions == [1, 1]
    after_first = 1 + alpha * gamma**3  # delta_1 = 1 + g^3 * 1 - 1
    expected = after_first + alpha * (2.0 - after_first)  # eligibility 1 at the end
    assert learner.q.q_values(np.array([0.0]))[1] == pytest.approx(expected)


def test_watkins_traces_are_cut_by_exploratory_choices() -> None:
    """With epsilon = 1 every choice explores, so Q(lambda) equals one-step Q-learning."""
    weights = []
    for lam in (0.0, 0.9):
        learner = SmdpLearner(3, corridor_coder(), config=LearnerConfig(method="q", trace_decay=lam, initial_value=0.0, epsilon=1.0), seed=3)
        learner.train(ZoneCorridor(), 30, seed=1)
        weights.append(learner.q.weights.copy())
    np.testing.assert_array_equal(weights[0], weights[1])
    sarsa = SmdpLearner(3, corridor_coder(), config=LearnerConfig(method="sarsa", trace_decay=0.9, initial_value=0.0, epsilon=1.0), seed=3)
    sarsa.train(ZoneCorridor(), 30, seed=1)
    assert not np.array_equal(sarsa.q.weights, weights[0])  # Sarsa(lambda) keeps its traces


@pytest.mark.parametrize("method", ["sarsa", "q"])
def test_converges_with_eligibility_traces(method: str) -> None:
    learner = SmdpLearner(3, corridor_coder(), config=LearnerConfig(method=method, trace_decay=0.8, initial_value=1.0, gamma=GAMMA), seed=0)
    learner.train(ZoneCorridor(), 2000, seed=10)
    rng = np.random.default_rng(0)
    assert all(greedy_primitive(learner, x, rng) == optimal_action(x) for x in interior_points())
    assert np.mean([is_optimal_episode(r) for r in learner.evaluate(ZoneCorridor(), 300, seed=99)]) >= 0.9


def test_trace_decay_outside_unit_interval_is_refused() -> None:
    with pytest.raises(ValueError, match="trace_decay"):
        SmdpLearner(3, corridor_coder(), config=LearnerConfig(method="sarsa", trace_decay=1.5, initial_value=0.0))


# ------------------------------------------------------------ option statistics
def _forced_option_runs(k: float, c_scale_trials: int, n_episodes: int, seed: int):
    coder = chain_coder(400)
    lib = OptionLibrary(constant_kernels([k]), [constant_policy(0, coder=coder)])
    for _ in range(c_scale_trials):
        lib.end_trial(used=[])  # scale 0.5 ** trials
    env = ScriptedChain([0.0] * 400, [1] * 400)
    learner = SmdpLearner(3, coder, lib, config=replace(KEEPAWAY, epsilon=0.0), seed=seed)
    learner.q.weights[3] = 1.0  # the option is preferred whenever it is available
    return lib, [learner.run_episode(env, learn=False) for _ in range(n_episodes)]


def test_option_termination_and_initiation_frequencies_in_episodes() -> None:
    k = 0.7
    lib, results = _forced_option_runs(k, c_scale_trials=1, n_episodes=20, seed=3)
    runs = [r for res in results for r in res.option_runs if not r.ended_by_episode]
    lengths = np.array([r.n_decisions for r in runs])
    # Run length is geometric: P(length = 1) = 1 - K; mean 1 / (1 - K).
    assert binomial_ok(int((lengths == 1).sum()), lengths.size, 1 - k)
    assert lengths.mean() == pytest.approx(1 / (1 - k), rel=0.1)
    # At each choice point the option starts with probability c * K = 0.5 * 0.7.
    n_choices = sum(len(res.choices) for res in results)
    n_starts = sum(len(res.options_chosen) for res in results)
    assert binomial_ok(n_starts, n_choices, 0.5 * k)


def test_pruned_option_is_never_offered_again() -> None:
    lib, _ = _forced_option_runs(0.9, c_scale_trials=0, n_episodes=0, seed=0)
    coder = lib.policies[0].tile_coder
    learner = SmdpLearner(3, coder, lib, config=replace(KEEPAWAY, epsilon=0.0), seed=0)
    learner.q.weights[3] = 1.0
    for _ in range(4):
        lib.end_trial(used=[])
    assert len(lib) == 0
    res = learner.run_episode(ScriptedChain([0.0] * 50, [1] * 50), learn=False)
    assert res.options_chosen == []


# ------------------------------------------------------------------ reproducibility
def _curve(seed: int, with_options: bool) -> tuple[list[float], list[int], np.ndarray]:
    coder = corridor_coder()
    lib = None
    if with_options:
        lib = OptionLibrary(
            IntervalKernels([(3, 6)], inside=0.9), [constant_policy(1, coder=coder)]
        )
    learner = SmdpLearner(3, coder, lib, config=replace(KEEPAWAY, gamma=GAMMA, epsilon=0.1), seed=seed)
    results = learner.train(ZoneCorridor(), 150, seed=21)
    return (
        [r.total_reward for r in results],
        [r.decisions for r in results],
        learner.q.weights.copy(),
    )


@pytest.mark.parametrize("with_options", [True])
def test_same_seed_same_learning_curve(with_options: bool) -> None:
    r1, d1, w1 = _curve(7, with_options)
    r2, d2, w2 = _curve(7, with_options)
    assert r1 == r2 and d1 == d2
    np.testing.assert_array_equal(w1, w2)
    r3, d3, _ = _curve(8, with_options)
    assert (r3, d3) != (r1, d1)


def _pruned_run(method: str, every_value: bool, monkeypatch: pytest.MonkeyPatch):
    """200 episodes with 9 options, a third of them pruned half-way."""
    if every_value:  # the plain path: every choice's value at every choice point
        monkeypatch.setattr(SmdpLearner, "_choice_values",
                            lambda self, active, mask: self.q.q_from_tiles(active))
    coder = corridor_coder()
    model = IntervalKernels([(0, 4), (2, 7), (5, 9)], inside=[0.5, 0.3, 0.6], outside=0.05)
    lib = OptionLibrary(model, [constant_policy(a, coder=coder) for a in (0, 1, 2)],
                        OptionSettings(discount=0.25))
    learner = SmdpLearner(3, coder, lib, config=LearnerConfig(method=method, trace_decay=0.9, initial_value=1.0, gamma=GAMMA, epsilon=0.1), seed=3)
    results = learner.train(ZoneCorridor(), 100, seed=1)
    for _ in range(2):
        lib.end_trial(used=[int(o) for o in lib.option_ids if o % 3])
    assert len(lib) == 6
    results += learner.train(ZoneCorridor(), 100, seed=2)
    return ([(r.total_reward, r.decisions, [(o.option_id, o.n_decisions) for o in r.option_runs])
             for r in results], learner.q.weights.copy())


@pytest.mark.parametrize("method", ["sarsa", "q"])
def test_choice_points_reading_only_allowed_values_change_nothing(
    method: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    runs, weights = _pruned_run(method, False, monkeypatch)
    assert sum(len(r[2]) for r in runs[100:]) > 0  # options still ran after the pruning
    plain_runs, plain_weights = _pruned_run(method, True, monkeypatch)
    assert runs == plain_runs and weights.tobytes() == plain_weights.tobytes()


def test_from_policy_rolls_out_identically() -> None:
    coder = corridor_coder()
    lib = OptionLibrary(IntervalKernels([(3, 6)], inside=0.9), [constant_policy(1, coder=coder)])
    learner = SmdpLearner(3, coder, lib, config=replace(KEEPAWAY, gamma=GAMMA), seed=0)
    learner.train(ZoneCorridor(), 200, seed=1)
    frozen = learner.freeze()
    a = SmdpLearner.from_policy(frozen, lib, config=KEEPAWAY, seed=5).evaluate(ZoneCorridor(), 30, seed=2)
    b = SmdpLearner.from_policy(frozen, lib, config=KEEPAWAY, seed=5).evaluate(ZoneCorridor(), 30, seed=2)
    assert [r.choices for r in a] == [r.choices for r in b]
    with pytest.raises(ValueError, match="library"):
        SmdpLearner.from_policy(frozen, None, config=KEEPAWAY)
    other = OptionLibrary(IntervalKernels([(0, 1)]), [])
    with pytest.raises(KeyError, match="unknown option id"):
        SmdpLearner.from_policy(frozen, other, config=KEEPAWAY)


# ------------------------------------------------------------------ intra-option
def test_intra_option_updates_consistent_options_only() -> None:
    env = ScriptedChain([1.0, 0.0], [1, 1])
    coder = chain_coder(2)
    model = constant_kernels([0.5])
    lib = OptionLibrary(model, [constant_policy(1, coder=coder), constant_policy(0, coder=coder)])
    learner = SmdpLearner(3, coder, lib, config=LearnerConfig(method="q", trace_decay=0.0, initial_value=0.0, alpha=1.0, epsilon=0.0, gamma=1.0, intra_option=True), seed=0)
    set_q(learner, 0.0, 1, 0.1)  # primitive 1 is the greedy choice at x = 0 (options: 0)
    learner.run_episode(env)
    q0 = learner.q.q_values(np.array([0.0]))
    # Option 0 (policy takes 1) is consistent with the primitive taken: updated to
    # r + K Q(s', o) + (1 - K) max Q(s') = 1 + 0 (all values at x = 1 are 0 then).
    assert q0[3] == pytest.approx(1.0)
    assert q0[4] == 0.0  # option 1's policy would take 0: not updated
    assert q0[1] == pytest.approx(1.0)  # the primitive's own SMDP update


# ------------------------------------------------------------------ bad inputs
def test_bad_inputs_give_clear_errors() -> None:
    coder = corridor_coder()
    with pytest.raises(ValueError, match=r"LearnerConfig\.method must be 'sarsa' or 'q', got 'td'"):
        SmdpLearner(3, coder, config=LearnerConfig(method="td", trace_decay=0.0, initial_value=0.0))
    with pytest.raises(TypeError, match="TileCoder"):
        SmdpLearner(3, None, config=KEEPAWAY)  # type: ignore[arg-type]
    lib2 = OptionLibrary(
        IntervalKernels([(0, 3)], n_features=2),
        [constant_policy(0, coder=TileCoder([0, 0], [9, 1], [1, 1], 2))],
    )
    with pytest.raises(ValueError, match="features"):
        SmdpLearner(3, coder, lib2, config=KEEPAWAY)
    lib4 = OptionLibrary(IntervalKernels([(0, 3)]), [constant_policy(0, n_primitive=4)])
    with pytest.raises(ValueError, match="primitive"):
        SmdpLearner(3, coder, lib4, config=KEEPAWAY)

    # Bad environments and the shared settings: tests/test_episode.py, for every learner.
