"""The one-file MAPPO/IPPO (``ilpss/reference/marl_ppo.py``): its advantages are CleanRL's
GAE when every cycle is a decision, and pay a longer decision the rewards of its cycles;
the decision schedule; the reward option's total over an episode. Needs torch."""

from __future__ import annotations

import numpy as np
import pytest

from ilpss.reference.settings import PPOConfig

pytestmark = pytest.mark.integrations


@pytest.fixture(name="marl")
def _marl():
    """The module, imported only when a test runs (the default suite imports no torch)."""
    return pytest.importorskip("ilpss.reference.marl_ppo", exc_type=ImportError)


def _rollout(marl, t: int, rows: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    b = marl._Rollout.empty(t, rows, 3, 5, 3)
    b.rew[:] = rng.normal(size=(t, rows))
    b.val[:] = rng.normal(size=(t, rows))
    b.done[:] = rng.random((t, rows)) < 0.1
    b.valid[:] = True
    b.valid[1:][b.done[:-1] > 0] = False  # the step after an end only resets the drill
    b.rew[~b.valid] = 0.0
    return b


def test_with_a_decision_every_cycle_the_advantages_are_cleanrls_gae(marl):
    cfg = PPOConfig(gamma=1.0, gae_lambda=0.95)
    b = _rollout(marl, 60, 5)
    following = np.random.default_rng(1).normal(size=5).astype(np.float32)
    adv, _ = marl._advantages(b, following, cfg)
    expected, last = np.zeros_like(b.rew), np.zeros(5)
    for t in reversed(range(60)):
        nxt = following if t == 59 else b.val[t + 1]
        going_on = 1.0 - b.done[t]
        last = b.rew[t] + nxt * going_on - b.val[t] + 0.95 * going_on * last
        expected[t] = last
    np.testing.assert_allclose(adv[b.valid], expected[b.valid], atol=1e-5)


def test_a_decision_is_paid_the_rewards_of_its_cycles(marl):
    cfg = PPOConfig(gamma=1.0, gae_lambda=1.0)
    b = marl._Rollout.empty(6, 1, 3, 5, 3)
    b.valid[:, 0] = [True, False, False, True, False, False]
    b.rew[:, 0] = [0.1, 0.2, 0.3, 0.0, 0.0, -1.0]
    b.done[5, 0] = 1.0
    b.val[:, 0] = [0.5, 9, 9, -0.2, 9, 9]  # values off the decisions are never read
    adv, ret = marl._advantages(b, np.array([7.0], np.float32), cfg)
    assert ret[3, 0] == pytest.approx(-1.0)  # the episode's end: no bootstrap
    assert ret[0, 0] == pytest.approx(0.6 - 1.0)  # its cycles' rewards, then the next's return
    assert adv[1, 0] == adv[2, 0] == 0.0


def test_decisions_come_every_k_cycles_and_when_the_ball_changes_hands(marl):
    d = marl.Decisions(1, 3)
    none = np.zeros(1, bool)
    held = [d.deciding(np.array([h]), none)[0] for h in (0, 0, 0, 0, 1, 1, -1, -1, -1, -1)]
    assert held == [True, False, False, True, True, False, True, False, False, True]
    every = marl.Decisions(1, 1)
    assert all(every.deciding(np.array([0]), none)[0] for _ in range(4))


def test_the_reward_options_total_is_the_drills_reward_minus_the_starts_potential(marl):
    field, shaping = 35.0, 1.0
    ys = np.array([30.0, 25.0, 27.0, 12.0, 3.0])  # the ball's distance to the line
    states = np.zeros((len(ys), 29))
    states[:, marl.BALL_Y] = ys
    phi = marl.potential(states, shaping, field)
    terms = [phi[k + 1] - phi[k] for k in range(len(ys) - 2)] + [0.0 - phi[-2]]
    assert sum(terms) == pytest.approx(-phi[0])  # whatever happened in between
