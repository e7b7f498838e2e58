"""Edges of the ilpss API: arguments checked before any work, a trial closed all or
nothing, start rules held to their budget, pruning at a zero threshold, exact statistics
on equal values, and the kernel model's far states, small bags and documentation."""

from __future__ import annotations

import re

import numpy as np
import pytest
from synthetic_smdp import ZoneCorridor, constant_kernels, constant_policy

from ilpss import baselines, metrics
from ilpss.kernels import SharedKernelModel, select_n_components
from ilpss.lifelong import LearnerConfig, LifelongConfig, LifelongLearner
from ilpss.options import OptionLibrary, OptionSettings
from ilpss.policy import FrozenPolicy
from ilpss.reuse import BestOfPast, Fresh, learn_with
from ilpss.smdp import SmdpLearner


class Counting(ZoneCorridor):
    """The corridor, counting its resets (episodes played)."""

    def __init__(self, **kw) -> None:
        super().__init__(**kw)
        self.resets = 0

    def reset(self, *, seed=None, options=None):
        self.resets += 1
        return super().reset(seed=seed, options=options)


def _config(**kw) -> LifelongConfig:
    base = {"n_kernels": 2, "train_episodes": 30, "rollout_episodes": 8,
            "learner": LearnerConfig(initial_value=1.0, tile_widths=(1.0, 0.5), n_tilings=4)}
    return LifelongConfig(**{**base, **kw})


def _corridor(t: int) -> Counting:
    return Counting(cost=(0.02, 0.05, 0.1)[t], n_features=2)


def _learner(config: LifelongConfig, n_trials: int, seed: int = 3) -> LifelongLearner:
    ll = LifelongLearner(config, _corridor(0).observation_space, 3, seed=seed)
    for t in range(n_trials):
        ll.run_trial(_corridor(t), f"corridor_{t}")
    return ll


def _state(ll: LifelongLearner):
    """Everything a checkpoint holds, and the library's counts."""
    lib = ll.library
    return (
        list(ll.records),
        [(p.weights.tobytes(), p.option_ids) for p in ll.policies],
        [b.tobytes() for b in ll.bags],
        None if lib is None else (
            lib.option_ids.tolist(), lib.scales.tolist(), lib.uses.tolist(),
            lib.trial_uses.tolist(), sorted(lib.pruned), sorted(lib.registry.items()),
            lib.kernel_ids.tolist(), len(lib.policies)),
        None if ll.kernel_model is None else ll.kernel_model.means_.tobytes(),
    )


# ----------------------------------------------------------------- names and seeds
@pytest.mark.parametrize("name", ["", "   ", 7, None])
def test_a_trial_name_a_checkpoint_could_not_hold_is_refused_before_any_episode(name):
    ll = LifelongLearner(_config(), _corridor(0).observation_space, 3, seed=0)
    env = _corridor(0)
    with pytest.raises(ValueError, match="trial name must be a non-empty string"):
        ll.run_trial(env, name)
    assert env.resets == 0 and ll.n_trials == 0
    learner, results = ll.learn(env)
    with pytest.raises(ValueError, match="trial name must be a non-empty string"):
        ll.extract(env, name, learner, results)
    assert ll.n_trials == 0 and ll.policies == [] and ll.bags == []


@pytest.mark.parametrize("seed", [-1, 1.7, "3", True, None])
def test_a_seed_that_is_not_a_non_negative_integer_is_refused_at_once(seed):
    with pytest.raises(ValueError, match=r"seed must be an integer >= 0, got"):
        LifelongLearner(_config(), _corridor(0).observation_space, 3, seed=seed)


def test_numpy_integer_seeds_are_taken():
    assert LifelongLearner(_config(), _corridor(0).observation_space, 3,
                           seed=np.int64(5)).seed == 5


# ----------------------------------------------------------------- all or nothing
@pytest.mark.parametrize("where", ["kernel fit", "library refit"])
def test_a_trial_that_fails_in_its_close_leaves_the_learner_as_it_was(where, monkeypatch,
                                                                      tmp_path):
    ll = _learner(_config(), 2)
    ll.save(tmp_path)
    before = _state(ll)
    discounted = []
    end_trial = OptionLibrary.end_trial

    def spy(self, used, offered=None):
        report = end_trial(self, used, offered)
        discounted.extend(report.discounted)
        return report

    def fail(*args, **kwargs):
        raise ValueError("covariance of component 0 is not positive definite")

    monkeypatch.setattr(OptionLibrary, "end_trial", spy)
    monkeypatch.setattr(*((SharedKernelModel, "fit") if where == "kernel fit"
                          else (OptionLibrary, "refit")), fail)
    with pytest.raises(ValueError, match="not positive definite"):
        ll.run_trial(_corridor(2), "corridor_2")
    assert discounted  # the close had discounted options before it failed
    assert _state(ll) == before
    # A save now writes the last complete trial, which loads.
    ll.save(tmp_path)
    assert _state(LifelongLearner.load(tmp_path, _corridor(0).observation_space))[:3] == \
        before[:3]
    # A retry runs as the first try of an uninterrupted run.
    monkeypatch.undo()
    ll.run_trial(_corridor(2), "corridor_2")
    assert _state(ll) == _state(_learner(_config(), 3))


def test_a_close_that_fails_on_its_own_is_undone_too(monkeypatch):
    ll = _learner(_config(), 2)
    learner, results = ll.learn(_corridor(2))
    before = _state(ll)

    def fail(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(OptionLibrary, "refit", fail)
    with pytest.raises(KeyboardInterrupt):
        ll.extract(_corridor(2), "corridor_2", learner, results)
    assert _state(ll) == before


# ----------------------------------------------------------------- the choosing budget
def _three_policies() -> list[FrozenPolicy]:
    coder = LearnerConfig().tile_coder(ZoneCorridor().observation_space)
    return [constant_policy(a, coder=coder) for a in (1, 2, 0)]


def _new_learner() -> SmdpLearner:
    coder = LearnerConfig().tile_coder(ZoneCorridor().observation_space)
    return SmdpLearner(3, coder, None, LearnerConfig(), seed=0)


@pytest.mark.parametrize("budget", [0, 4, 5, 12, 14, 15, 40])
def test_choosing_the_best_past_policy_never_plays_beyond_the_budget(budget):
    policies = _three_policies()
    full = _new_learner()
    all_tried = BestOfPast(episodes=5).start(full, policies, ZoneCorridor(), seed=11)
    env = Counting()
    learner = _new_learner()
    curve = learn_with(BestOfPast(episodes=5), learner, policies, env, budget, seed=4,
                       choice_seed=11)
    assert env.resets == len(curve) == budget
    tried = min(3, budget // 5)
    # The latest policies that fit are tried, on the episodes they get when all are.
    assert [r.total_reward for r in curve[:5 * tried]] == \
        [r.total_reward for r in all_tried[5 * (3 - tried):]]
    if tried == 0:
        chosen = 2  # nothing tried: the latest, as fine-tuning
    else:
        means = {k: np.mean([r.total_reward for r in all_tried[5 * k:5 * k + 5]])
                 for k in range(3 - tried, 3)}
        chosen = max(means, key=lambda k: (means[k], k))
    starting = _new_learner()
    starting.start_from(policies[chosen])
    if tried == 3:  # the default case: the choice fits, as it always did
        np.testing.assert_array_equal(starting.q.weights, full.q.weights)
    # The learner went on from the chosen policy's values.
    rest = starting.train(ZoneCorridor(), budget - len(curve[:5 * tried]), seed=4)
    assert [r.total_reward for r in curve[5 * tried:]] == [r.total_reward for r in rest]


def test_finetune_best_plays_on_the_task_exactly_the_episodes_it_charges():
    ll = _learner(_config(options="finetune_best", train_episodes=12), 3)
    env = _corridor(0)
    _, results = ll.learn(env)
    assert env.resets == len(results) == 12


class _Overspending:
    def start(self, learner, policies, env, seed, *, budget=None):
        return learn_with(Fresh(), learner, [], env, 3, seed=seed, choice_seed=0)


class _Older:
    """A start rule written before start rules were given their budget."""

    def start(self, learner, policies, env, seed):
        return []


def test_a_start_rule_that_plays_beyond_the_budget_is_refused_and_older_rules_still_run():
    with pytest.raises(ValueError, match="played 3 episodes choosing, more than the budget "
                                         "of 2"):
        learn_with(_Overspending(), _new_learner(), [], ZoneCorridor(), 2, seed=0,
                   choice_seed=0)
    assert len(learn_with(_Older(), _new_learner(), [], ZoneCorridor(), 2, seed=0,
                          choice_seed=0)) == 2


# ----------------------------------------------------------------- pruning at zero
def test_a_scale_discounted_to_zero_is_pruned_even_with_a_zero_threshold():
    model = constant_kernels([0.5, 0.5])
    lib = OptionLibrary(model, [constant_policy(0)],
                        OptionSettings(discount=1e-200, prune_threshold=0.0))
    report = lib.end_trial(used=[0])
    assert report.pruned == () and lib.scale(1) == 1e-200  # above 0: kept, as before
    report = lib.end_trial(used=[0])  # 1e-200 * 1e-200 underflows to 0
    assert report.pruned == (1,) and list(lib.option_ids) == [0]
    refit = lib.refit(model)  # the library's own state is accepted again
    assert list(refit.option_ids) == [0]


def test_a_lifelong_run_with_a_zero_prune_threshold_goes_on():
    config = _config(library=OptionSettings(prune_threshold=0.0, discount=1e-200),
                     train_episodes=10, rollout_episodes=4)
    ll = LifelongLearner(config, _corridor(0).observation_space, 3, seed=1)
    for t in (0, 1, 2, 0, 1):
        ll.run_trial(_corridor(t), f"corridor_{t}")
    assert ll.n_trials == 5 and (ll.library.scales > 0).all()


# ----------------------------------------------------------------- exact statistics
@pytest.mark.parametrize("v", [0.1, 0.3, 0.7, 1 / 3, -2.2])
def test_equal_values_give_their_exact_interval_and_p_value(v):
    x = [v] * 3
    assert metrics.t_interval(x) == (v, v, v)
    assert metrics.t_test_pvalue(x, null=v) == 1.0
    assert metrics.t_test_pvalue(x, null=v + 1.0) == 0.0
    assert metrics.t_test_pvalue([v] * 10, null=v) == 1.0
    rows = np.array([[v] * 4, [0.0, 1.0, 2.0, 3.0]])
    mean, low, high = metrics.t_interval(rows)
    assert (mean[0], low[0], high[0]) == (v, v, v)
    assert low[1] < mean[1] == 1.5 < high[1]
    np.testing.assert_array_equal(metrics.t_test_pvalue(rows, null=v)[:1], [1.0])


def test_smoothing_is_exact_on_equal_values_and_a_window_of_one_copies():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(3, 200))
    out = metrics.smooth(x, 1)
    np.testing.assert_array_equal(out, x)
    assert out is not x
    for edges in ("expanding", "valid"):
        assert (metrics.smooth(np.full(10_000, 0.1), 7, edges=edges) == 0.1).all()
    assert metrics.largest_dip(np.full(50, 0.3), 5) == 0.0
    # Windows that are not constant are the running sums' means, as before.
    zeros = np.zeros((3, 1))
    csum = np.concatenate([zeros, np.cumsum(x, axis=-1)], axis=-1)
    np.testing.assert_array_equal(metrics.smooth(x, 9, edges="valid"),
                                  (csum[:, 9:] - csum[:, :-9]) / 9)


def test_comparing_constant_curves_finds_no_spurious_difference_in_dips():
    estimates = metrics.compare(np.full((4, 50), 0.3), np.full((4, 50), 0.2), first=5, last=5,
                                threshold=None, window=5)
    dip = estimates["largest_dip_gain"]
    assert (dip.value, dip.low, dip.high, dip.p_value) == (0.0, 0.0, 0.0, 1.0)


# ----------------------------------------------------------------- kernels
def _bags(seed: int, sizes=(40, 40), d: int = 2) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.normal(rng.normal(0, 3, d), 1.0, (n, d)) for n in sizes]


@pytest.mark.filterwarnings("ignore")
def test_the_trace_is_documented_as_able_to_fall_with_reg_covar():
    doc = SharedKernelModel.__doc__
    text = " ".join(doc[doc.index("log_likelihood_trace_ :"):].split())
    assert "may decrease" in text and "reg_covar=0" in text
    # With a large reg_covar the regularised M-step lowers the likelihood ...
    rng = np.random.default_rng(0)
    bags = [rng.normal(rng.normal(0, 3, 1), rng.uniform(0.1, 2), (30, 1)) for _ in range(3)]
    trace = SharedKernelModel(4, reg_covar=1.0, n_init=1, random_state=0).fit(
        bags).log_likelihood_trace_
    assert np.diff(trace).min() < -1e-3
    # ... while with a tiny one any step down is of the order of rounding.
    for s in range(5):
        trace = SharedKernelModel(4, reg_covar=1e-9, n_init=1, random_state=s).fit(
            bags).log_likelihood_trace_
        assert np.diff(trace).min() >= -1e-6


def test_select_n_components_skips_counts_a_small_bag_cannot_fit():
    bags = [np.random.default_rng(0).normal(size=(5, 2))]
    best, bics = select_n_components(bags, random_state=0)
    assert set(bics) == {1, 2, 3, 4, 5} and best in bics
    with pytest.raises(ValueError, match=re.escape(
            "no candidate can be fitted to 5 states: the numbers of components must be at "
            "most the number of states (1 to 5), got [6, 7]")):
        select_n_components(bags, candidates=[7, 6])
    with pytest.raises(ValueError, match="select_n_components candidate must be an integer in"):
        select_n_components(bags, candidates=[0, 1])


@pytest.mark.filterwarnings("ignore")
def test_responsibilities_of_a_far_state_are_finite_and_sum_to_one():
    model = SharedKernelModel(3, random_state=0).fit(_bags(1, (60, 60)))
    rng = np.random.default_rng(2)
    for _ in range(10):
        u = rng.normal(size=2)
        far = model.responsibilities(u * 1e200)
        assert np.isfinite(far).all() and far.sum() == pytest.approx(1.0, abs=1e-12)
        # The limit along the direction: the kernel that wins well before overflow.
        assert np.argmax(far) == np.argmax(model.responsibilities(u * 1e6))
    both = model.responsibilities(np.array([[1e300, -1e300], [0.0, 0.0]]))
    np.testing.assert_allclose(both.sum(axis=1), 1.0)
    np.testing.assert_array_equal(both[1], model.responsibilities([0.0, 0.0]))


# ----------------------------------------------------------------- PRQ's example
def test_the_prq_learner_example_runs():
    doc = baselines.PrqLearner.__doc__
    lines = [line.strip()[4:] for line in doc.splitlines()
             if line.strip().startswith((">>> ", "... "))]
    code = "\n".join(re.sub(r"\s*# doctest: \+SKIP$", "", line) for line in lines)
    env = ZoneCorridor()
    coder = LearnerConfig(gamma=0.9).tile_coder(env.observation_space)
    namespace = {**vars(baselines), "env": env,
                 "old_policy": constant_policy(0, coder=coder)}
    exec(compile(code, "PrqLearner example", "exec"), namespace)
    probabilities = namespace["learner"].selection_probabilities()
    assert probabilities.shape == (2,) and probabilities.sum() == pytest.approx(1.0)


@pytest.mark.parametrize(("call", "error", "message"), [
    (lambda ll: ll.learn(_corridor(0), trial=-1), ValueError,
     r"^trial must be an integer >= 0, got -1$"),
    (lambda ll: ll.learn(_corridor(0), trial=1.5), ValueError,
     r"^trial must be an integer >= 0, got 1\.5$"),
    (lambda ll: ll.run_trial("chasers", "chasers"), ValueError,
     r"the environment has no action_space: give a Gymnasium environment \(action_space "
     r"Discrete\(3\), reset and step\), not str 'chasers'"),
], ids=["negative trial", "fractional trial", "a team id for the environment"])
def test_a_learners_arguments_are_named_when_refused(call, error, message):
    """Before, NumPy's seeding said "expected non-negative integer" or "seed must be
    integer", and a string for the environment was "action space None"."""
    ll = _learner(_config(), 0)
    with pytest.raises(error, match=message):
        call(ll)
    assert ll.n_trials == 0


@pytest.mark.parametrize(("call", "message"), [
    (lambda: metrics.holm([0.01, None]), r"p_values holds object values \(\[0\.01, None\]\); "
                                         r"give numbers"),
    (lambda: metrics.t_interval(["1", "2"]), r"values holds <U1 values"),
    (lambda: metrics.compare([[0, 1], [0]], [[0, 1], [1, 0]], first=1, last=1,
                             threshold=None, window=1),
     r"transfer_curves: rows of different lengths"),
    (lambda: metrics.compare(np.zeros((1, 20)), np.zeros((1, 20)), first=5, last=5,
                             threshold=None, window=5),
     r"^intervals over seeds need at least 2 seeds, got 1$"),
], ids=["None among p-values", "text for values", "ragged curves", "one seed"])
def test_the_statistics_refuse_what_is_not_numbers_naming_it(call, message):
    """Before, ``None`` became a test left out of the family, text was parsed as numbers,
    ragged curves gave NumPy's "inhomogeneous shape", and one seed under the t interval
    was said to be too few for a bootstrap."""
    with pytest.raises(ValueError, match=message):
        call()
    assert np.isnan(metrics.holm([0.01, float("nan")])[1])  # NaN still means "not made"


def test_a_trial_on_an_environment_with_other_observation_bounds_is_refused():
    # before, a learner made on the 2v2 drill's space ran on a 60 m field's drill (same
    # shape, bounds 88 against 53) and its tile coder clipped the observations silently
    from soccer_drill import DrillConfig, HolderEnv

    env = HolderEnv(opponent="chasers")
    learner = LifelongLearner(LifelongConfig(train_episodes=1, rollout_episodes=1),
                              env.observation_space, 3, seed=0)
    wider = HolderEnv(opponent="chasers", config=DrillConfig(field_size=60))
    with pytest.raises(ValueError, match=r"observation bounds differ from those the learner's "
                                         r"tile coder was made for \(7 feature\(s\); feature 0"):
        learner.run_trial(wider, "chasers")
    assert learner.n_trials == 0
    learner.run_trial(env, "chasers")


@pytest.mark.parametrize("reward", [float("nan"), float("inf"), None, "1", np.array([1.0])])
def test_a_reward_that_is_not_a_finite_number_is_refused_naming_it(reward):
    # before, NaN and inf surfaced as a diverged TD target blamed on the step size, None and
    # an array of one as float()'s bare TypeError, and the string "1" was taken as 1.0
    class Paying(ZoneCorridor):
        def step(self, action):
            obs, _, terminated, truncated, info = super().step(action)
            return obs, reward, terminated, truncated, info

    env = Paying()
    cfg = LearnerConfig(tile_widths=(0.5,))
    learner = SmdpLearner(3, cfg.tile_coder(env.observation_space), config=cfg, seed=0)
    with pytest.raises(ValueError, match=r"the reward the environment's step returned must "
                                         r"be a finite number, got "):
        learner.train(env, 1, seed=0)


def test_numpy_and_zero_dimensional_rewards_are_taken_as_floats():
    class Paying(ZoneCorridor):
        def step(self, action):
            obs, reward, terminated, truncated, info = super().step(action)
            return obs, np.array(reward), terminated, truncated, info

    cfg = LearnerConfig(tile_widths=(0.5,))
    plain, wrapped = ZoneCorridor(), Paying()
    curves = [SmdpLearner(3, cfg.tile_coder(e.observation_space), config=cfg, seed=0)
              .train(e, 5, seed=0) for e in (plain, wrapped)]
    assert [r.total_reward for r in curves[0]] == [r.total_reward for r in curves[1]]
