"""The one-file MAPPO/IPPO (``ilpss/reference/marl_ppo.py``): its advantages are CleanRL's
GAE when every cycle is a decision, and pay a longer decision the rewards of its cycles;
the decision schedule; the reward option's total over an episode. Needs torch."""

from __future__ import annotations

import numpy as np
import pytest

from ilpss.reference.settings import PPOConfig, SelfPlaySetting

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


def test_pfsp_draws_the_opponents_a_side_beats_some_of_the_time(marl):
    """Prioritised fictitious self-play: an opponent the learning side beats about half
    the time is drawn far more often than one it always beats or never beats (they give
    no signal), none is left out, and a new checkpoint starts at q = 1/2, before the
    current networks."""
    setting = SelfPlaySetting(opponents="pfsp", pfsp_floor=0.02, pfsp_decay=0.9)
    pool = ["even", "always beaten"]
    drills = np.arange(4, 10)
    opp = marl.opponents_for(setting, drills, pool, ["current"], np.random.default_rng(0))
    assert opp.weights() == pytest.approx(np.full(3, 1 / 3))  # every q starts at 1/2
    games, wins = np.zeros(12), np.zeros(12)
    games[drills] = 4
    opp.drawn = np.array([0, 0, 1, 1, 2, 2])  # the candidates of the six drills
    wins[drills] = [2, 2, 4, 4, 0, 0]  # the attackers' successes: q = 1/2, 1, 0
    for _ in range(30):
        opp.record(games, wins)
    w = opp.weights()
    assert w[0] > 5 * w[1] and w[0] > 5 * w[2] and w.min() > 0.0
    assert w.sum() == pytest.approx(1.0)
    pool.append("new")
    w = opp.weights()
    assert len(w) == 4 and w[2] == pytest.approx(w.max())  # the new one, at q = 1/2
    drawn = np.bincount(np.random.default_rng(1).choice(4, 20_000, p=w), minlength=4)
    assert drawn.min() > 0


def test_uniform_opponents_draw_the_same_whatever_they_recorded(marl):
    """The uniform pool keeps no counts: the episodes it is told of change no draw."""
    def draws(record: bool) -> list[str]:
        opp = marl.opponents_for(SelfPlaySetting(), np.arange(3), ["untrained", "old"],
                                 ["current"], np.random.default_rng(0))
        out = []
        for k in range(50):
            if record:
                opp.record(np.ones(3), np.full(3, k % 2))
            out.append(opp.draw()[0][0])
        return out
    assert draws(True) == draws(False)
    assert set(draws(False)) == {"untrained", "old", "current"}


def test_every_named_way_of_drawing_opponents_has_its_kind(marl):
    """Each ``SelfPlaySetting.opponents`` name the settings accept makes its own kind
    of opponents, and no kind is left without a name."""
    from ilpss.reference.settings import OPPONENT_SAMPLING
    assert sorted(marl.OPPONENTS) == sorted(OPPONENT_SAMPLING)
    kinds = {name: type(marl.opponents_for(SelfPlaySetting(opponents=name), np.arange(2),
                                           ["untrained"], ["current"],
                                           np.random.default_rng(0)))
             for name in OPPONENT_SAMPLING}
    assert len(set(kinds.values())) == len(kinds)


def test_agent_ids_end_each_players_row(marl):
    """With ``agent_id`` each row (drill by drill, player by player) ends with the
    one-hot of the player's index in its side; the input bounds grow to match."""
    from ilpss.reference.jobs import _parallel
    from ilpss.reference.settings import MarlSetting
    env = _parallel(3, "full")
    observations, _ = env.reset(seed=0)
    plain = marl.Side(marl.DEFENDERS, env, MarlSetting())
    ided = marl.Side(marl.DEFENDERS, env, MarlSetting(agent_id=True))
    drills = np.array([0, 2])
    obs, mask = marl._rows(observations, plain, drills)
    obs_id, mask_id = marl._rows(observations, ided, drills)
    assert np.array_equal(obs_id[:, :-2], obs) and np.array_equal(mask_id, mask)
    assert obs_id[:, -2:].tolist() == [[1, 0], [0, 1], [1, 0], [0, 1]]
    assert ided.actor.low.shape[0] == plain.actor.low.shape[0] + 2
    assert ided.critic.low.shape == plain.critic.low.shape  # the critic sees state()


def test_an_exploiter_is_one_more_live_opponent(marl):
    """With an exploiter the live networks are two candidates: the uniform pool draws
    a checkpoint half the time and each live one a quarter; prioritised self-play puts
    a new checkpoint before both live ones, at q = 1/2."""
    rng = np.random.default_rng(0)
    opp = marl.opponents_for(SelfPlaySetting(), np.arange(3), ["untrained"],
                             ["current", "exploiter"], rng)
    drawn = [opp.draw()[0][0] for _ in range(4000)]
    share = {name: drawn.count(name) / len(drawn) for name in ("untrained", "current",
                                                                "exploiter")}
    assert share == pytest.approx({"untrained": 0.5, "current": 0.25, "exploiter": 0.25},
                                  abs=0.03)
    pool = ["untrained"]
    opp = marl.opponents_for(SelfPlaySetting(opponents="pfsp"), np.arange(4), pool,
                             ["current", "exploiter"], rng)
    opp.drawn = np.array([0, 1, 2, 2])
    opp.weights()
    opp.record(np.ones(4), np.array([0.0, 1.0, 1.0, 1.0]))  # the exploiter always wins
    pool.append("new")
    opp.weights()
    q = np.asarray(opp.wins) / np.asarray(opp.games)
    assert q[1] == pytest.approx(0.5) and q[3] == pytest.approx(q.max())


def test_self_play_with_exploiters_trains_and_is_deterministic(marl):
    from ilpss.reference.jobs import _parallel
    from ilpss.reference.settings import MarlSetting
    ppo = PPOConfig(steps=8 * 32 * 3, n_envs=8, n_steps=32, batch_size=128, n_epochs=1,
                    gamma=1.0)
    runs = []
    for share in (0.25, 0.25, 0.0):
        s = SelfPlaySetting(marl=MarlSetting(ppo=ppo), opponents="pfsp", snapshots=3,
                            exploiter_share=share)
        pool_a, pool_d, curve = marl.train_self_play(_parallel(8, "full"), s, 5)
        assert len(pool_a) == len(pool_d) == 3 and len(curve) == 3
        runs.append([p.detach().numpy().copy() for p in pool_a[-1].parameters()])
    assert all(np.array_equal(a, b) for a, b in zip(runs[0], runs[1], strict=True))
    assert not all(np.array_equal(a, b) for a, b in zip(runs[0], runs[2], strict=True))


@pytest.mark.parametrize(("field", "value", "message"), [
    ("opponents", "league", "'uniform' or 'pfsp'"),
    ("pfsp_floor", 0.0, "pfsp_floor"),
    ("pfsp_decay", 1.0, "pfsp_decay"),
])
def test_self_play_settings_refuse_what_they_do_not_allow(field, value, message):
    with pytest.raises(ValueError, match=message):
        SelfPlaySetting(**{field: value})
