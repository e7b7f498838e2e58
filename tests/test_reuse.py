"""Ways of reusing past policies on synthetic SMDPs: fine-tuning starts as the source
policy, options valued from their own policies, given regions, the choosing episodes
charged to the budget, and a composition target where fragments of two policies are
better than either."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from synthetic_smdp import FAST, FATAL, SLOW, ZoneCorridor, zone

from ilpss.kernels import RegionKernels
from ilpss.lifelong import LifelongConfig, LifelongLearner
from ilpss.metrics import t_interval
from ilpss.options import OptionLibrary
from ilpss.policy import FrozenPolicy
from ilpss.reuse import REUSES, BestOfPast, GivenRegions, LatestPast, Reuse, learn_with
from ilpss.smdp import LearnerConfig, SmdpLearner
from ilpss.tiles import TileCoder


class MappedCorridor(ZoneCorridor):
    """The corridor with another fast action per zone (``fast``: zone -> action); the
    slow and the fatal actions follow it round the three."""

    def __init__(self, fast: dict[int, int], **kwargs) -> None:
        super().__init__(**kwargs)
        self.fast = fast

    def step(self, action: int):
        z = zone(self.x)
        kind = (int(action) - self.fast[z]) % 3  # 0 fast, 1 slow, 2 fatal
        return super().step((FAST, SLOW, FATAL)[kind][z])


X = {0: 0, 1: 1, 2: 2}
"""A source: the corridor as it is."""
Y = {0: 1, 1: 2, 2: 0}
"""Another source: every zone's fast action shifted."""
COMPOSED = {0: 0, 1: 1, 2: 0}
"""The target: X's zones A and B, Y's zone C (X's action there is fatal, Y's slow in A
and B)."""
LC = LearnerConfig(tile_widths=(1.0,), n_tilings=8, gamma=0.95)


def _coder() -> TileCoder:
    return LC.tile_coder(MappedCorridor(X).observation_space)


def _zone_policy(fast: dict[int, int]) -> FrozenPolicy:
    coder = _coder()
    w = np.zeros((3, coder.n_weights))
    for x in np.arange(0.05, 9.0, 0.1):
        w[fast[zone(x)], coder.active(np.array([x]))] = 1.0 / coder.n_active
    return FrozenPolicy(coder, 3, (), w)


def _mean_reward(act, fast, n=200, seed=0) -> np.ndarray:
    env = MappedCorridor(fast, cost=0.02)
    out = []
    for i in range(n):
        obs, _ = env.reset(seed=seed + i)
        total, done = 0.0, False
        while not done:
            obs, r, term, trunc, _ = env.step(act(obs))
            total += r
            done = term or trunc
        out.append(total)
    return np.array(out)


def test_a_composition_where_the_composed_policy_beats_each_source():
    composed = _mean_reward(lambda o: COMPOSED[zone(o[0])], COMPOSED)
    for source in (X, Y):
        alone = _mean_reward(lambda o, s=source: s[zone(o[0])], COMPOSED)
        value, low, _ = t_interval(composed - alone)  # paired by episode seed
        assert low > 0, (source, value)


def test_fine_tuning_starts_as_the_source_policy_at_the_first_decision():
    source = _zone_policy(Y)
    learner = SmdpLearner(3, _coder(), None, LC, seed=0)
    LatestPast().start(learner, [_zone_policy(X), source], MappedCorridor(COMPOSED), seed=0)
    _assert_acts_as(learner, source, learner_seed=0)


def _assert_acts_as(learner: SmdpLearner, policy: FrozenPolicy, learner_seed: int) -> None:
    """``learner`` holds ``policy``'s values and plays its first episode on the target
    exactly as ``policy`` does."""
    for x in np.arange(0.25, 9.0, 0.5):
        s = np.array([x])
        np.testing.assert_array_equal(learner.q.q_values(s), policy.q_values(s))
    first = learner.run_episode(MappedCorridor(COMPOSED), learn=False, seed=3)
    replay = SmdpLearner.from_policy(policy, None, LC, seed=learner_seed).run_episode(
        MappedCorridor(COMPOSED), learn=False, seed=3)
    assert first.choices == replay.choices


def test_start_from_refuses_a_policy_of_another_state_space():
    learner = SmdpLearner(3, _coder(), None, LC)
    other = FrozenPolicy(TileCoder([0.0], [1.0], [0.5]), 3)
    with pytest.raises(ValueError, match="cannot start from a policy"):
        learner.start_from(other)


def test_the_best_past_policy_is_chosen_on_charged_episodes():
    env = MappedCorridor(Y, cost=0.02)
    learner = SmdpLearner(3, _coder(), None, LC, seed=0)
    policies = [_zone_policy(Y), _zone_policy(X)]  # the latest is the worse one here
    spent = BestOfPast(episodes=5).start(learner, policies, env, seed=11)
    assert len(spent) == 10  # 5 greedy episodes of each, charged to the budget
    np.testing.assert_array_equal(learner.q.weights, policies[0].weights)
    curve = learn_with(BestOfPast(episodes=5), SmdpLearner(3, _coder(), None, LC, seed=0),
                       policies, env, 30, seed=4, choice_seed=11)
    assert len(curve) == 30
    assert [r.total_reward for r in curve[:10]] == [r.total_reward for r in spent]
    # The learning episodes are those a learner from the same start plays, unmoved by
    # the choosing episodes before them.
    again = SmdpLearner(3, _coder(), None, LC, seed=0)
    again.start_from(policies[0])
    tail = again.train(env, 20, seed=4)
    assert [r.total_reward for r in curve[10:]] == [r.total_reward for r in tail]


def test_options_valued_from_their_policies_start_above_the_policys_own_value():
    policies = [_zone_policy(X), _zone_policy(Y)]
    regions = RegionKernels(1, [0, 0], [6.0, 6.0], [True, False])
    library = OptionLibrary(regions, policies)
    learner = SmdpLearner(3, _coder(), library, replace(LC, option_values="policy"), seed=0)
    for x in np.arange(0.25, 9.0, 0.5):
        s = np.array([x])
        q = learner.q.q_values(s)
        for j, oid in enumerate(learner.option_ids):
            own = policies[library.policy_of(oid)].q_values(s).max()
            assert q[3 + j] >= own - 1e-12
    constant = SmdpLearner(3, _coder(), library, replace(LC, option_initial_value=0.25))
    assert constant.q.q_values(np.array([1.0]))[3:] == pytest.approx(0.25)


def test_given_regions_are_options_inside_them_and_nowhere_else():
    regions = RegionKernels(1, [0, 0], [6.0, 6.0], [True, False])
    assert regions.membership(np.array([[5.5], [6.0], [6.5]])).tolist() == [
        [1.0, 0.0], [1.0, 0.0], [0.0, 1.0]]
    library = OptionLibrary(regions, [_zone_policy(X)])
    rng = np.random.default_rng(0)
    for x, inside in ((2.0, 0), (8.0, 1)):
        avail = library.available(np.array([x]), rng)
        kernels = [library.registry[int(o)][0] for o in library.option_ids]
        assert [bool(a) for a in avail] == [k == inside for k in kernels]


def test_given_regions_round_trip_in_a_checkpoint(tmp_path):
    REUSES.register("test_given", Reuse("test_given", GivenRegions(((0, 6.0, True),
                                                                   (0, 6.0, False))),
                                        LatestPast()), overwrite=True)
    try:
        cfg = LifelongConfig(n_kernels=2, train_episodes=15, rollout_episodes=3,
                             options="test_given", learner=replace(LC, option_values="policy"))
        learner = LifelongLearner(cfg, MappedCorridor(X).observation_space, 3, seed=2)
        for fast in (X, Y):
            learner.run_trial(MappedCorridor(fast, cost=0.02), str(fast))
        learner.save(tmp_path)
        loaded = LifelongLearner.load(tmp_path, MappedCorridor(X).observation_space)
        assert isinstance(loaded.kernel_model, RegionKernels)
        assert loaded.records == learner.records
        np.testing.assert_array_equal(loaded.kernel_model.thresholds, [6.0, 6.0])
    finally:
        REUSES.unregister("test_given")


def _valued_policy(fast: dict[int, int], gamma: float = 0.95, cost: float = 0.02):
    """A policy whose values are what it learnt on its own task: the optimal return on
    its fast action, -1 (the fatal reward) on the others."""
    from synthetic_smdp import optimal_value

    coder = _coder()
    total, count = np.zeros((3, coder.n_weights)), np.zeros((3, coder.n_weights))
    for x in np.arange(0.05, 9.0, 0.05):
        active = coder.active(np.array([x]))
        for a in range(3):
            value = optimal_value(x, gamma, cost) if a == fast[zone(x)] else -1.0
            total[a, active] += value / coder.n_active
            count[a, active] += 1
    return FrozenPolicy(coder, 3, (), np.where(count > 0, total / np.maximum(count, 1), 0.0))


@pytest.mark.slow
def test_a_fine_tuned_learner_takes_another_policys_option_only_where_it_is_better():
    """ILPSS-FT's mechanism on the composition: the learner starts from the latest
    policy (Y), with X and Y as options in the two regions, valued from their policies
    and handed back by value. Where X is better (zone A) X's option takes over; where X
    is fatal (beyond 6) its option is never the learner's choice; and the hand-over
    costs no collapse of the seed-mean curve."""
    from ilpss.metrics import largest_dip

    policies = [_valued_policy(X), _valued_policy(Y)]
    library = OptionLibrary(RegionKernels(1, [0, 0], [6.0, 6.0], [True, False]), policies)
    config = replace(LC, option_values="policy", interruption=True,
                     intra_option_primitives=True, epsilon=0.05)
    fatal = next(3 + j for j, o in enumerate(library.option_ids)
                 if library.registry[int(o)] == (1, 0))  # X's option beyond 6
    curves, zone_a = [], []
    for seed in range(12):
        learner = SmdpLearner(3, _coder(), library, config, seed=seed)
        learner.start_from(policies[1])
        results = learner.train(MappedCorridor(COMPOSED, cost=0.02), 150, seed=seed)
        curves.append([r.total_reward for r in results])
        choices = {}
        for x in np.arange(0.25, 9.0, 0.5):
            s = np.array([x])
            allowed = np.r_[np.ones(3, bool),
                            library.memberships(library.membership(s))[learner._lib_pos] > 0]
            choices[x] = int(np.argmax(np.where(allowed, learner.q.q_values(s), -np.inf)))
        assert all(c != fatal for x, c in choices.items() if x > 6.0), choices
        zone_a.append(sum(library.registry[int(learner.option_ids[c - 3])] == (0, 0)
                          for x, c in choices.items() if x < 3.0 and c >= 3))
    assert min(zone_a) >= 1, zone_a  # X's option is chosen in zone A on every seed
    assert float(largest_dip(np.mean(curves, axis=0), 20)) <= 0.2


def _highest_primitive_values(**settings) -> list[float]:
    """Per seed, the largest primitive value over the corridor after 60 learning episodes
    with X's option in [0, 6), valued 1.5 where it is taken (and corrected) and 5 on the
    tiles no state of its region uses (never taken there: never corrected)."""
    coder = _coder()
    inside, outside = set(), set()
    for x in np.arange(0.0, 6.0, 0.01):
        inside.update(coder.active(np.array([x])).tolist())
    for x in np.arange(6.0, 9.0, 0.01):
        outside.update(coder.active(np.array([x])).tolist())
    far = np.array(sorted(outside - inside))
    assert len(far) > 0
    library = OptionLibrary(RegionKernels(1, [0], [6.0], [True]), [_zone_policy(X)])
    config = replace(LC, intra_option_primitives=True, interruption=True, **settings)
    highest = []
    for seed in range(5):
        learner = SmdpLearner(3, coder, library, config, seed=seed)
        learner.q.weights[3, sorted(inside)] = 1.5 / coder.n_active
        learner.q.weights[3, far] = 5.0 / coder.n_active
        learner.train(MappedCorridor(X, cost=0.02), 60, seed=seed)
        highest.append(max(learner.q.q_values(np.array([x]))[:3].max()
                           for x in np.arange(0.05, 9.0, 0.1)))
    return highest


def test_steps_inside_an_option_bootstrap_only_from_choices_available_there():
    """An option's values outside its region are never corrected (it is never taken
    there). Bootstrapping the steps inside an option from every choice carries them into
    the primitives, above any return the corridor pays (at most 1); bootstrapping from
    the choices available at the next state, as a choice point does, does not."""
    every = _highest_primitive_values(step_targets="every_choice")
    available = _highest_primitive_values(step_targets="available_choices")
    primitives = _highest_primitive_values(step_targets="primitive_choices")
    assert min(every) > 1.15, every
    assert max(available) < 1.1, available
    assert max(primitives) < 1.1, primitives


def test_options_valued_from_their_policies_primitives_do_not_inherit_its_options_values():
    """A past policy that chose options holds their values too: a tile-wise maximum over
    all its values starts its option at least at the largest of them, so each start's
    excess passes to the next; over its primitive actions only, it does not."""
    coder = _coder()
    sources = [_zone_policy(X)]
    first = OptionLibrary(RegionKernels(1, [0], [6.0], [True]), sources)
    learner = SmdpLearner(3, coder, first, replace(LC, option_values="policy"), seed=0)
    learner.q.weights[3:] = 5.0 / coder.n_active  # an option it valued far above any return
    chained = learner.freeze()
    library = OptionLibrary(RegionKernels(1, [0], [6.0], [True]), [*sources, chained])
    option = next(3 + j for j, o in enumerate(library.option_ids)
                  if library.policy_of(o) == 1)
    s = np.array([2.0])
    inherited = SmdpLearner(3, coder, library, replace(LC, option_values="policy"))
    assert inherited.q.q_values(s)[option] == pytest.approx(5.0)
    fresh = SmdpLearner(3, coder, library, replace(LC, option_values="policy_primitives"))
    assert fresh.q.q_values(s)[option] == pytest.approx(chained.q_values(s)[:3].max(), abs=0.2)
    assert fresh.q.q_values(s)[option] < 1.5


def test_targets_clipped_to_the_returns_keep_never_corrected_option_values_out():
    """The same never-corrected option values, bootstrapped from every choice: with the
    targets clipped to the range of the corridor's returns (at most 1), the primitives
    stay within it, where without the clip they rise above it."""
    free = _highest_primitive_values(step_targets="every_choice")
    bounded = _highest_primitive_values(step_targets="every_choice", value_bounds=(-1.0, 1.0))
    assert min(free) > 1.15, free
    assert max(bounded) < 1.1, bounded


def test_value_bounds_are_a_range_low_below_high():
    assert LearnerConfig(value_bounds=[-1, 1]).value_bounds == (-1.0, 1.0)
    for bad in ((1.0, -1.0), (0.0, 0.0), (0.0,), "ab"):
        with pytest.raises(ValueError, match="value_bounds"):
            LearnerConfig(value_bounds=bad)


def test_options_valued_from_their_policies_start_within_the_value_bounds():
    """A past policy valued far above any return (5 where the corridor pays at most 1)
    starts its option at 5 without bounds, and within them with bounds, where it can
    send no excess back along the traces."""
    coder = _coder()
    valued = FrozenPolicy(coder, 3, (), np.full((3, coder.n_weights), 5.0 / coder.n_active))
    library = OptionLibrary(RegionKernels(1, [0], [6.0], [True]), [valued])
    s = np.array([2.0])
    free = SmdpLearner(3, coder, library, replace(LC, option_values="policy"))
    assert free.q.q_values(s)[3] == pytest.approx(5.0)
    bounded = SmdpLearner(3, coder, library, replace(LC, option_values="policy",
                                                     value_bounds=(-1.0, 1.0)))
    assert bounded.q.q_values(s)[3] == pytest.approx(1.0)


@pytest.mark.parametrize("option_traces", ["kept", "cut"])
def test_an_options_error_reaches_the_choices_before_it_only_with_kept_traces(option_traces):
    """X's option, offered from x = 3 on and valued 5 where the corridor pays at most 1,
    is chosen after the primitives of zone A. The large errors of correcting its value
    reach those primitives along the traces when they are kept, and never when they are
    cut before an option is chosen."""
    coder = _coder()
    library = OptionLibrary(RegionKernels(1, [0], [3.0], [False]), [_zone_policy(X)])
    config = replace(LC, option_traces=option_traces, epsilon=0.0)
    reached = 0
    for seed in range(5):
        learner = SmdpLearner(3, coder, library, config, seed=seed)
        learner.q.weights[3:] = 5.0 / coder.n_active
        update = learner._td_update

        def traced(traces, active, choice, *args, learner=learner, update=update):
            nonlocal reached
            before = learner.q.weights[:3].copy()
            update(traces, active, choice, *args)
            if choice >= 3:  # the option's own update: did it move a primitive?
                reached += not np.array_equal(before, learner.q.weights[:3])

        learner._td_update = traced
        learner.train(MappedCorridor(X, cost=0.02, start_high=0.5), 5, seed=seed)
    assert (reached > 0) == (option_traces == "kept"), reached


# ------------------------------------------------------------------ the controls
def test_the_best_of_the_recent_sources_tries_only_those_and_costs_no_more():
    env = MappedCorridor(Y, cost=0.02)
    # The best source is the oldest: a choice among the 2 latest does not see it.
    policies = [_zone_policy(Y), _zone_policy(X), _zone_policy(X)]
    every = SmdpLearner(3, _coder(), None, LC, seed=0)
    all_spent = BestOfPast(episodes=5).start(every, policies, env, seed=11)
    recent = SmdpLearner(3, _coder(), None, LC, seed=0)
    spent = BestOfPast(episodes=5, recent=2).start(recent, policies, env, seed=11)
    assert len(all_spent) == 15 and len(spent) == 10
    np.testing.assert_array_equal(every.q.weights, policies[0].weights)
    np.testing.assert_array_equal(recent.q.weights, policies[2].weights)
    # each tried source plays the episodes it plays when all are tried
    assert [e.total_reward for e in spent] == [e.total_reward for e in all_spent[5:]]
    with pytest.raises(ValueError, match=r"BestOfPast\.recent"):
        BestOfPast(recent=0)


def test_the_bounded_fine_tuning_control_clips_every_target_into_the_bounds(monkeypatch):
    """The control of the bounded methods is fine-tuning with their base learner: from a
    source valued at 5 where the corridor pays at most 1, every target it learns towards
    lies within the bounds, where fine-tuning without them learns towards values above."""
    from types import SimpleNamespace

    from ilpss.experiments.config import ExperimentConfig
    from ilpss.experiments.methods import METHODS, FineTuneMethod

    coder = _coder()
    valued = FrozenPolicy(coder, 3, (), np.full((3, coder.n_weights), 5.0 / coder.n_active))
    scratch = SimpleNamespace(n_primitive=3, tile_coder=coder, policies=[valued])
    cfg = ExperimentConfig().with_overrides(lifelong={"train_episodes": 10,
                                                      "learner": LC.__dict__})
    targets = []
    update = SmdpLearner._td_update

    def spied(self, traces, active, choice, target, *args):
        targets.append(target)
        return update(self, traces, active, choice, target, *args)

    monkeypatch.setattr(SmdpLearner, "_td_update", spied)
    highest = {}
    for name in ("finetune", "finetune_bounded"):
        targets.clear()
        method = METHODS.get(name)
        assert isinstance(method, FineTuneMethod)
        method.learn_target(cfg, 0, scratch, 1, MappedCorridor(X, cost=0.02))
        highest[name] = max(targets)
    assert highest["finetune"] > 1.5 and highest["finetune_bounded"] <= 1.0
    candidate = METHODS.get("whole_policies_ft_bounded_cut").config(cfg.lifelong).learner
    assert METHODS.get("finetune_bounded").value_bounds == candidate.value_bounds


def test_chained_fine_tuning_starts_each_task_from_its_own_latest_policy():
    """``finetune_chained`` is the lifelong loop with the ``finetune_latest`` reuse: the
    learner of each task starts from the policy it learnt on the task before (itself
    fine-tuned), and acts at its first decision exactly as that policy."""
    from ilpss.experiments.config import ExperimentConfig
    from ilpss.experiments.methods import METHODS

    base = ExperimentConfig().lifelong
    config = METHODS.get("finetune_chained").config(base)
    assert config.options == "finetune_latest" and not config.reuse.offers_options
    bounded = METHODS.get("finetune_chained_bounded").config(base)
    assert bounded.learner.value_bounds is not None

    small = replace(config, train_episodes=15, rollout_episodes=2, learner=LC)
    lifelong = LifelongLearner(small, MappedCorridor(X).observation_space, 3, seed=0)
    lifelong.run_trial(MappedCorridor(X, cost=0.02), "x")
    lifelong.run_trial(MappedCorridor(Y, cost=0.02), "y")  # starts from the policy on x
    previous = lifelong.policies[-1]
    learner = lifelong.make_learner(5)
    small.reuse.start.start(learner, lifelong.policies, MappedCorridor(COMPOSED), seed=0)
    _assert_acts_as(learner, previous, learner_seed=5)


def corridor_composition(task: str) -> tuple[int, float, str, str] | None:
    """The oracles' knowledge of the corridor's tasks: ``COMPOSED`` plays X below x = 6
    (zones A and B) and Y above it; the sources are not composed."""
    return (0, 6.0, "X", "Y") if task == "COMPOSED" else None


def _oracle_learner(assigned: bool) -> LifelongLearner:
    from ilpss.experiments.oracles import TrueRegions

    REUSES.register("test_oracle", Reuse(
        "test_oracle", GivenRegions(((0, 1e9, True), (0, 6.0, True), (0, 6.0, False),
                                     (0, 3.0, True), (0, 3.0, False))), LatestPast(),
        TrueRegions(assigned, composition=f"{__name__}:corridor_composition")),
        overwrite=True)
    cfg = LifelongConfig(n_kernels=4, train_episodes=10, rollout_episodes=3,
                         options="test_oracle", learner=replace(LC, option_values="policy"))
    learner = LifelongLearner(cfg, MappedCorridor(X).observation_space, 3, seed=4)
    for name, fast in (("X", X), ("Y", Y)):
        learner.run_trial(MappedCorridor(fast, cost=0.02), name)
    return learner


@pytest.mark.parametrize("assigned", [False, True])
def test_the_oracles_offer_a_composed_target_the_options_of_its_own_regions(assigned):
    """On the composed target, the true-regions oracle offers both sides of its split with
    every past policy; the assignment oracle only X's policy below x = 6 and Y's above,
    which act there as X and Y do. A task that is not composed is offered the whole past
    policies (the region that holds every state), as the sources were."""
    try:
        learner = _oracle_learner(assigned)
        target = learner.make_learner(0, task="COMPOSED")
        library = target.library
        pairs = {(int(library.kernel_model.thresholds[k]), bool(library.kernel_model.below[k]),
                  int(p)) for k, p in zip(library.option_kernel, library.option_policy,
                                          strict=True)}
        if assigned:
            assert pairs == {(6, True, 0), (6, False, 1)}
            rng = np.random.default_rng(0)
            for j, oid in enumerate(library.option_ids):
                x = 2.0 if library.kernel_model.below[library.option_kernel[j]] else 8.0
                source = learner.policies[library.option_policy[j]]
                assert library.act(int(oid), np.array([x]), rng) == source.greedy(
                    np.array([x]), rng, primitive_only=True)
        else:
            assert pairs == {(6, below, p) for below in (True, False) for p in (0, 1)}
        whole = learner.make_learner(0, task="X").library
        assert whole.option_kernel.tolist() == [0, 0]
        assert whole.option_policy.tolist() == [0, 1]
        assert learner.records[1].options_offered == 1  # Y's trial: X's whole policy
        assert learner.make_learner(0).library is learner.library
    finally:
        REUSES.unregister("test_oracle")


def test_the_assignment_oracle_names_what_it_cannot_find():
    from ilpss.experiments.oracles import TrueRegions

    try:
        learner = _oracle_learner(True)
        library = learner.library
        with pytest.raises(ValueError, match="no past task is 'Y'"):
            TrueRegions(True, f"{__name__}:corridor_composition").offer(
                library, ["X", "Z"], "COMPOSED")
        with pytest.raises(ValueError, match=r"pair \(9, 0\) is not a \(kernel position"):
            library.only([(9, 0)])
    finally:
        REUSES.unregister("test_oracle")


def test_a_library_limited_to_some_pairs_offers_pruned_options_again():
    library = OptionLibrary(RegionKernels(1, [0, 0], [6.0, 6.0], [True, False]),
                            [_zone_policy(X), _zone_policy(Y)])
    first = int(library.option_ids[0])
    library.settings = replace(library.settings, prune_threshold=0.99)
    library.end_trial(used=[], offered=[first])  # discounted below the threshold: pruned
    assert first not in library
    limited = library.only([(0, 0), (1, 1)])
    assert [library.registry[int(o)] for o in limited.option_ids] == [(0, 0), (1, 1)]
    assert first in limited and limited.scales.tolist() == [1.0, 1.0]
    assert first not in library  # the library itself is unchanged


def test_who_runs_where_counts_every_decision_by_side_and_source():
    """The region-use count of a composed target: every greedy decision once, by the side
    of its split and by what acts; the assignment oracle's options are only ever the
    right source's on each side."""
    from ilpss.experiments.region_use import OWN, target_use

    try:
        learner = _oracle_learner(True)
        learner.run_trial(MappedCorridor(COMPOSED, cost=0.02), "COMPOSED")
        env = MappedCorridor(COMPOSED, cost=0.02)
        use = target_use(learner, 2, env, range(4), corridor_composition("COMPOSED"))
        assert sum(use.counts.values()) == sum(
            SmdpLearner.from_policy(learner.policies[2], use_library(learner), replace(
                learner.config.learner, epsilon=0.0), seed=s).run_episode(
                env, learn=False, seed=s).decisions for s in range(4))
        assert {actor for _, actor in use.counts} <= {OWN, "X", "Y"}
        assert use.counts.get((True, "Y"), 0) == use.counts.get((False, "X"), 0) == 0
        for below in (True, False):
            n, right, other, own = use.shares(below)
            assert n == 0 or (other == 0.0 and right + own == pytest.approx(1.0))
    finally:
        REUSES.unregister("test_oracle")


def use_library(learner: LifelongLearner) -> OptionLibrary:
    """The options the target's trial was offered (the oracle's offer, again)."""
    names = [r.name for r in learner.records]
    return learner.config.reuse.offer.offer(learner.library, names[:2], names[2])
