"""ilpss-holder-learning's comparison: learning seeds are the unit, paired by episode seed."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from ilpss.experiments.holder_learning import compare_to_rule


def test_episodes_are_not_replicates_of_the_learnt_policy():
    rng = np.random.default_rng(0)
    rule = rng.normal(0.4, 0.6, size=500)
    # 3 learning seeds whose policies differ: one clearly worse than the rule, two better
    learnt = rule + np.array([[-0.1], [0.35], [0.4]]) + rng.normal(0, 0.3, size=(3, 500))
    c = compare_to_rule(learnt, rule)
    # pooling the 1,500 episodes as if independent claims a tiny p-value ...
    assert stats.ttest_ind(learnt.ravel(), rule, equal_var=False).pvalue < 0.01
    # ... while over the 3 seeds the difference is not shown
    low, high = c["diff_ci"][1:]
    assert low < 0 < high and c["p"] > 0.2
    assert c["improvement"].better == 2 and c["improvement"].worse == 1
    # more evaluation episodes of the same policies do not add replicates
    twice = compare_to_rule(np.tile(learnt, 2), np.tile(rule, 2))
    assert twice["diff_ci"] == pytest.approx(c["diff_ci"])


def test_pairing_by_episode_seed_removes_the_episodes_difficulty():
    rng = np.random.default_rng(1)
    difficulty = rng.normal(0, 0.8, size=200)  # shared by the rule and every policy
    rule = 0.3 + difficulty
    learnt = 0.4 + difficulty + rng.normal(0, 0.02, size=(10, 200))
    c = compare_to_rule(learnt, rule)
    assert c["diff_ci"][0] == pytest.approx(0.1, abs=0.01)
    assert c["diff_ci"][2] - c["diff_ci"][1] < 0.01  # the difficulty cancels in the pairs
    assert c["p"] < 1e-6
    with pytest.raises(ValueError, match="n_seeds >= 2"):
        compare_to_rule(learnt[:1], rule)
    with pytest.raises(ValueError, match="n_episodes"):
        compare_to_rule(learnt, rule[:-1])
