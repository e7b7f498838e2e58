"""The batched environments' rendering, shared spaces and global state, their teams'
failures, seeded team streams and several rules in one batch."""

from __future__ import annotations

import signal
import sys

import numpy as np
import pytest

import soccer_drill
from ilpss.experiments.calibrate import evaluate_rules
from soccer_drill import TeamError
from soccer_drill.commands import Command, Skill
from soccer_drill.envs.holder import HolderEnv
from soccer_drill.policies import HOLDER_POLICIES
from soccer_drill.teams.kit import BatchCommands, BatchRandom
from soccer_drill.vector import HolderVectorEnv, play_episodes
from soccer_drill.vector.agents import ParallelVectorEnv


def test_the_holder_batch_renders_one_frame_per_drill_as_the_single_env_draws_it():
    venv = HolderVectorEnv(num_envs=3, opponent="goal_guards", render_mode="rgb_array")
    venv.reset(seed=4)
    venv.step(np.array([2, 0, 1]))
    frames = venv.render()
    assert isinstance(frames, tuple) and len(frames) == 3
    env = HolderEnv(opponent="goal_guards", render_mode="rgb_array")
    env.reset(seed=4)
    single = env.render()
    assert frames[0].shape == single.shape and frames[0].dtype == np.uint8
    venv.reset(seed=4)
    np.testing.assert_array_equal(venv.render()[0], single)  # drill 0 starts as reset(seed=4)
    assert not np.array_equal(venv.render()[0], venv.render()[1])
    venv.close()
    assert HolderVectorEnv(num_envs=2).render() is None
    with pytest.raises(ValueError, match="render_mode must be None or 'rgb_array', got"):
        HolderVectorEnv(num_envs=2, render_mode="human")


def test_the_multi_agent_batch_renders_too():
    venv = ParallelVectorEnv(num_envs=2, opponent="chasers", render_mode="rgb_array")
    with pytest.raises(RuntimeError, match="before reset"):
        venv.render()
    venv.reset(seed=0)
    frames = venv.render()
    assert len(frames) == 2 and frames[1].ndim == 3


def _random_legal(masks, rng):
    return {a: (rng.random(m.shape) * m).argmax(axis=1) for a, m in masks.items()}


@pytest.mark.parametrize("obs_type", ["features", "kinematic"])
def test_shared_spaces_and_state_equal_the_single_parallel_env_with_one_drill(obs_type):
    """With one drill per space the physics is the single drill's: spaces, observations,
    masks, rewards and ``state()`` equal ``parallel_env(shared_spaces=True)``'s."""
    venv = ParallelVectorEnv(num_envs=1, opponent=None, shared_spaces=True, obs_type=obs_type)
    env = soccer_drill.parallel_env(opponent=None, shared_spaces=True, obs_type=obs_type)
    for agent in env.possible_agents:
        assert venv.action_space(agent) == env.action_space(agent)
        assert venv.observation_space(agent) == env.observation_space(agent)
    assert venv.state_space == env.state_space
    obs, _ = venv.reset(seed=9)
    single, _ = env.reset(seed=9)
    rng = np.random.default_rng(0)
    for _ in range(60):
        for agent in env.agents:
            np.testing.assert_array_equal(obs[agent]["observation"][0], single[agent]["observation"])
            np.testing.assert_array_equal(obs[agent]["action_mask"][0], single[agent]["action_mask"])
        np.testing.assert_array_equal(venv.state()[0], env.state())
        actions = _random_legal({a: o["action_mask"] for a, o in obs.items()}, rng)
        obs, rewards, term, trunc, _ = venv.step(actions)
        single, r, t, tr, _ = env.step({a: int(v[0]) for a, v in actions.items()})
        assert {a: float(v[0]) for a, v in rewards.items()} == r
        if any(t.values()) or any(tr.values()):
            break


def test_shared_spaces_mask_a_defenders_last_two_actions_and_replace_them():
    venv = ParallelVectorEnv(num_envs=4, opponent=None, shared_spaces=True)
    obs, _ = venv.reset(seed=1)
    assert obs["defender_0"]["observation"].shape == (4, 10)
    np.testing.assert_array_equal(obs["defender_0"]["observation"][:, -1], 0.0)
    np.testing.assert_array_equal(obs["attacker_0"]["observation"][:, -1], 1.0)
    np.testing.assert_array_equal(obs["defender_1"]["action_mask"], [[1, 1, 1, 0, 0]] * 4)
    actions = {a: obs[a]["action_mask"].argmax(axis=1) for a in venv.agents}
    actions["defender_1"] = np.full(4, 4)
    _, _, _, _, infos = venv.step(actions)
    np.testing.assert_array_equal(infos["illegal_action"]["defender_1"], 4)
    np.testing.assert_array_equal(infos["action_taken"]["defender_1"], 0)  # INTERCEPT
    strict = ParallelVectorEnv(num_envs=4, opponent=None, shared_spaces=True, illegal_action="raise")
    obs, _ = strict.reset(seed=1)
    actions = {a: obs[a]["action_mask"].argmax(axis=1) for a in strict.agents}
    actions["defender_0"] = np.array([0, 0, 3, 0])
    with pytest.raises(ValueError, match=r"drill 2: action 3 \(padding\) is masked for 'defender_0'"):
        strict.step(actions)
    with pytest.raises(ValueError, match=r"shared_spaces must be None or true or false, got 1"):
        ParallelVectorEnv(num_envs=2, shared_spaces=1)
    assert ParallelVectorEnv(num_envs=2).shared_spaces  # no opponent: as parallel_env
    assert not ParallelVectorEnv(num_envs=2, opponent="chasers").shared_spaces


class _Exits:
    """A batched team whose act calls sys.exit() (or raises what ``error`` makes)."""

    def __init__(self, error):
        self.error = error

    def reset(self, view, drills, rng):
        pass

    def act(self, view, drills):
        raise self.error()


class _Team:
    def __init__(self, error, batched=True):
        self.error, self.batched = error, batched

    def reset(self, view, rng):
        pass

    def act(self, view):
        raise self.error()

    def __getattr__(self, name):
        if name == "batch" and self.__dict__["batched"]:
            return lambda n: _Exits(self.error)
        raise AttributeError(name)


@pytest.mark.parametrize("batched", [True, False])
@pytest.mark.parametrize(("error", "message"), [
    (lambda: SystemExit(3), r"raised in act\(\).*sys\.exit\(3\) \(SystemExit\)"),
    (lambda: KeyboardInterrupt("mine"), r"raised in act\(\).*KeyboardInterrupt itself"),
    (lambda: ValueError("bad"), r"raised in act\(\).*ValueError\('bad'\)"),
])
def test_whatever_a_team_raises_in_the_batch_is_a_team_error_naming_it(batched, error, message):
    venv = HolderVectorEnv(num_envs=3, opponent=_Team(error, batched))
    venv.reset(seed=0)
    # A copy per drill names the drill that failed; a batched call the drills it was for.
    where = r" at cycle 0 of drills 0, 1, 2 \(3 in one call\)" if batched else " at cycle 0"
    named = "team '_Team' " if batched else r"team '_Team' \(drill 0\) "
    with pytest.raises(TeamError, match=named + message.replace(r"act\(\)", r"act\(\)" + where)):
        venv.step(np.zeros(3, dtype=int))


@pytest.mark.skipif(sys.platform == "win32", reason="raise_signal(SIGINT) ends the process")
def test_a_ctrl_c_during_a_batched_act_still_stops_the_program():
    class CtrlC(_Exits):
        def act(self, view, drills):
            signal.raise_signal(signal.SIGINT)  # as the user's Ctrl-C arrives
            for _ in range(1000):
                pass
            raise AssertionError("not interrupted")

    class Team(_Team):
        def __getattr__(self, name):
            if name == "batch":
                return lambda n: CtrlC(None)
            raise AttributeError(name)

    venv = HolderVectorEnv(num_envs=2, opponent=Team(None))
    venv.reset(seed=0)
    with pytest.raises(KeyboardInterrupt):
        venv.step(np.zeros(2, dtype=int))


def test_a_seeded_batch_random_draws_what_the_seeds_generators_would():
    rng = BatchRandom(3, block=4)
    rng.seed(np.arange(3), [11, 12, np.random.default_rng(13)])
    draws = np.array([rng.random(np.array([0, 2])) for _ in range(9)])
    for column, seed in ((0, 11), (1, 13)):
        np.testing.assert_array_equal(draws[:, column], np.random.default_rng(seed).random(9))
    with pytest.raises(RuntimeError, match="drill 1: no generator"):
        BatchRandom(2).random(np.array([1]))


class _Hesitant:
    """A team of one drill that draws: each cycle, each defender intercepts with
    probability 0.3, else marks."""

    def reset(self, view, rng):
        self.rng, self.players = rng, view.players

    def act(self, view):
        return {p: Command(Skill.INTERCEPT if self.rng.random() < 0.3 else Skill.MARK)
                for p in self.players}


class _HesitantBatch:
    """The same, written in batched form: each drill's draws from its own stream."""

    def batch(self, n):
        return self

    def reset(self, view, drills, rng):
        self.rng = rng

    def act(self, view, drills):
        draws = np.stack([self.rng.random(drills), self.rng.random(drills)], axis=1)
        skill = np.where(draws < 0.3, int(Skill.INTERCEPT), int(Skill.MARK))
        m = len(drills)
        return BatchCommands(skill, np.zeros((m, 2, 2)), np.ones((m, 2)))


def test_teams_that_draw_get_their_streams_from_the_seeds():
    """A team's draws come from each drill's team stream: batched and one copy per drill
    (generators made at once) give the same episodes."""
    results = []
    for team in (_HesitantBatch(), _Hesitant()):
        venv = HolderVectorEnv(num_envs=5, opponent=team)
        venv.reset(seed=3)
        results.append([venv.step(np.full(5, 2))[0] for _ in range(12)])
    np.testing.assert_array_equal(np.array(results[0]), np.array(results[1]))


@pytest.mark.parametrize(("skill", "speed", "target", "message"), [
    (1, 1.0, 0.0, r"drill 4, player 'defender_0', cycle 0: skill PASS=1 is not allowed"),
    (9, 1.0, 0.0, r"drill 4, player 'defender_0', cycle 0: skill 9 is not allowed"),
    (8, 1.0, np.nan, r"drill 4, player 'defender_0', cycle 0: MOVE_TO needs a finite"),
    (8, 0.0, 1.0, r"drill 4, player 'defender_0', cycle 0: speed must be in \(0, 1\]"),
])
def test_a_bad_batched_command_is_named_by_drill_player_and_what_is_wrong(skill, speed, target, message):
    class Bad(_Exits):
        def act(self, view, drills):
            m = len(drills)
            sk, sp, tg = np.full((m, 2), 5), np.ones((m, 2)), np.ones((m, 2, 2))
            bad = drills == 4
            sk[bad, 0], sp[bad, 0], tg[bad, 0] = skill, speed, target
            return BatchCommands(sk, tg, sp)

    class Team(_Team):
        def __getattr__(self, name):
            if name == "batch":
                return lambda n: Bad(None)
            raise AttributeError(name)

    venv = HolderVectorEnv(num_envs=6, opponent=Team(None))
    venv.reset(seed=0)
    with pytest.raises(TeamError, match=message):
        venv.step(np.zeros(6, dtype=int))


def test_play_episodes_takes_one_rule_per_seed():
    venv = HolderVectorEnv(num_envs=8, opponent="interceptors_press")
    seeds = list(range(12))
    played = play_episodes(
        venv, [HOLDER_POLICIES["hold"]] * 12 + [HOLDER_POLICIES["dribble"]] * 12, seeds * 2)
    assert len(played) == 24
    assert all(outcome != "success" for _, outcome in played[:12])  # holding never scores
    with pytest.raises(ValueError, match="a sequence of 12 rules"):
        play_episodes(venv, [HOLDER_POLICIES["hold"]] * 11, seeds)


def test_calibration_plays_every_rule_of_a_team_in_one_batch():
    rules = ["hold", "dribble", "pass_first"]
    batched = evaluate_rules("interceptor_guard", rules, 30, drills=64)
    single = evaluate_rules("interceptor_guard", rules, 30, drills=1)
    assert [c.rule for c in batched] == rules == [c.rule for c in single]
    assert batched[0].successes == 0 == single[0].successes
    for b, s in zip(batched, single, strict=True):
        assert b.episodes == s.episodes == 30
        assert abs(b.success_rate - s.success_rate) <= 0.3  # the same drill, in distribution


def test_with_a_space_per_drill_every_drill_is_the_single_parallel_env_across_autoresets():
    """Each drill of ``drills_per_space=1`` plays ``parallel_env``'s episodes from seed
    ``s + i``, the episodes after an autoreset included (a reset builds the drill's space
    anew, as the single drill's reset does): equal bit for bit until the first last-bit
    difference (NumPy's ``hypot`` or ``arctan2`` against ``math``'s, or pymunk's contact
    solving; see ``HolderVectorEnv``), which here comes only after several episodes, and
    then only in the last bits."""
    n = 3
    venv = ParallelVectorEnv(num_envs=n, opponent="interceptors_cover", drills_per_space=1)
    singles = [soccer_drill.parallel_env(opponent="interceptors_cover") for _ in range(n)]
    obs, _ = venv.reset(seed=4)
    single_obs = [env.reset(seed=4 + i)[0] for i, env in enumerate(singles)]
    rng = np.random.default_rng(1)
    ended = np.zeros(n, dtype=bool)
    episodes = np.zeros(n, dtype=int)  # ended so far, while the drill still equals its env
    same = np.ones(n, dtype=bool)
    for _ in range(300):
        for i, env in enumerate(singles):
            for agent in env.agents if same[i] else ():
                diff = np.abs(obs[agent]["observation"][i] - single_obs[i][agent]["observation"])
                if diff.max() > 0:
                    assert diff.max() < 1e-5, (i, agent, diff.max())
                    same[i] = False
        actions = _random_legal({a: o["action_mask"] for a, o in obs.items()}, rng)
        obs, rewards, term, trunc, _ = venv.step(actions)
        for i, env in enumerate(singles):
            if ended[i]:  # the autoreset: the next episode of the drill's stream
                single_obs[i], _ = env.reset()
                ended[i] = False
                continue
            single_obs[i], r, te, tr, _ = env.step({a: int(v[i]) for a, v in actions.items()})
            if same[i]:
                assert {a: float(v[i]) for a, v in rewards.items()} == r
            ended[i] = any(te.values()) or any(tr.values())
            episodes[i] += ended[i] and same[i]
    assert (episodes >= 3).all(), episodes


def test_agents_that_ignore_the_masks_play_on_through_autoresets():
    env = ParallelVectorEnv(num_envs=8)  # no opponent: shared spaces, Discrete(5) for everyone
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    resets = 0
    for _ in range(200):  # random actions, masked ones included, also while drills reset
        _, rewards, terms, truncs, _ = env.step({a: rng.integers(5, size=8) for a in env.agents})
        resets += int(np.count_nonzero(terms["attacker_0"] | truncs["attacker_0"]))
    assert resets > 0
    assert rewards["attacker_0"] is not rewards["attacker_1"]  # each agent's own array


def test_the_batched_agents_spaces_options_and_flags_as_parallel_env():
    with pytest.raises(KeyError, match="unknown agent 'bogus'"):
        ParallelVectorEnv(num_envs=2).observation_space("bogus")
    with pytest.raises(ValueError, match=r"ParallelVectorEnv\.reset's options: unknown field"):
        ParallelVectorEnv(num_envs=2).reset(options={"reset_mask": np.ones(2, dtype=bool)})
    env = ParallelVectorEnv(num_envs=2, shared_spaces=np.True_)
    assert env.action_space("defender_0") == env.action_space("attacker_0")
    _, infos = env.reset(seed=0)
    illegal = infos["illegal_action"]
    assert illegal["attacker_0"] is not illegal["attacker_1"]


def test_the_single_and_the_batched_multi_agent_env_refuse_an_action_in_the_same_words():
    single = soccer_drill.parallel_env(opponent=None, illegal_action="raise")
    single.reset(seed=4)
    batched = ParallelVectorEnv(num_envs=1, opponent=None, illegal_action="raise")
    batched.reset(seed=4)  # drill 0 starts as the single env's reset(seed=4)
    holds = single.drill_state.holder == 0
    for bad in (7, 3 if holds else 0):  # out of range; masked for attacker_0 now
        actions = {a: 0 for a in single.agents}
        actions["attacker_0"] = bad
        with pytest.raises(ValueError) as said_single:
            single.step(actions)
        with pytest.raises(ValueError) as said_batched:
            batched.step({a: np.array([x]) for a, x in actions.items()})
        assert str(said_batched.value) == f"drill 0: {said_single.value}"


def test_the_batched_view_is_read_only_as_the_single_view_is():
    import pickle

    from soccer_drill.teams.kit import BatchView

    venv = HolderVectorEnv(num_envs=2, opponent="chasers")
    venv.reset(seed=0)
    views = (BatchView(venv._core.batch, ("defender_0", "defender_1")),
             soccer_drill.HolderEnv(opponent="chasers").loop.core.team.view.drill(0))
    for view in views:
        name = type(view).__name__
        with pytest.raises(AttributeError, match=f"{name} is read-only: cannot set 'players'"):
            view.players = ()
        with pytest.raises(AttributeError, match=f"{name} is read-only: cannot delete '_source'"):
            del view._source
        assert type(pickle.loads(pickle.dumps(view))) is type(view)
    assert views[0].pos.shape == (2, 5, 2) and not views[0].pos.flags.writeable


def test_every_drills_observation_lies_in_its_observation_space():
    """The spaces say what the observations are: each drill's row of an agent's
    observation is an element of ``observation_space(agent)``, a dict as
    ``parallel_env``'s, for teams and for four learning players."""
    for opponent in ("chasers", None):
        venv = ParallelVectorEnv(num_envs=3, opponent=opponent)
        obs, _ = venv.reset(seed=2)
        for agent, value in obs.items():
            space = venv.observation_space(agent)
            for row in range(3):
                one = {key: array[row] for key, array in value.items()}
                assert space.contains(one), (agent, one)


def test_the_batched_agents_count_their_agents_as_parallel_env_does():
    # before, ParallelVectorEnv had none of PettingZoo's num_agents and max_num_agents
    batched, single = ParallelVectorEnv(2), soccer_drill.parallel_env()
    single.reset(seed=0)
    batched.reset(seed=0)
    assert (batched.num_agents, batched.max_num_agents) == (single.num_agents,
                                                            single.max_num_agents) == (4, 4)
