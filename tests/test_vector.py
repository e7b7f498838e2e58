"""The batched drill: Gymnasium's vector API, the single drill's rules, seeds, errors, teams."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, VectorEnv

import soccer_drill
from ilpss.experiments.agreement import agreement
from opponents.parametric import ParametricTeam, sample_opponents
from soccer_drill import TeamError
from soccer_drill.commands import Command, Skill
from soccer_drill.drill.drills import BatchDrill
from soccer_drill.envs.core import observation
from soccer_drill.envs.holder import HolderEnv
from soccer_drill.policies import HOLDER_POLICIES
from soccer_drill.rules.arrays import CYCLE, roll_table, rule_parameters
from soccer_drill.rules.cycle import before_physics_of_drills
from soccer_drill.rules.motion import interception_points, mark_targets
from soccer_drill.skills import ball_interception_point, execute, state_record
from soccer_drill.teams.kit import BatchCommands, BatchRandom, BatchView
from soccer_drill.vector import HolderVectorEnv, play_episodes
from soccer_drill.vector.agents import ParallelVectorEnv

TEAMS = ("chasers", "interceptors_press", "interceptors_cover", "interceptor_guard", "goal_guards")


def _holder_states(team: str, seeds: range) -> list:
    """Drill states met in single-env episodes (with passes, tackles, loose balls)."""
    env, states = HolderEnv(opponent=team), []
    policy, rng = HOLDER_POLICIES["random"], np.random.default_rng(0)
    for seed in seeds:
        obs, _ = env.reset(seed=seed)
        done = False
        while not done:
            states.append(env.drill_state)
            obs, _, term, trunc, _ = env.step(policy(obs, rng))
            done = term or trunc
    return states


def _arrays(states: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return (np.array([s.pos for s in states]), np.array([s.vel for s in states]),
            np.array([s.holder for s in states]))


def test_the_batched_loops_give_each_drill_what_the_rules_give_it_alone():
    """The batched forms run the one drill's rules drill by drill: each row is that
    drill's, whatever the other rows hold (real states, with passes, tackles, loose balls)."""
    states = _holder_states("interceptors_cover", range(4))
    cfg = soccer_drill.DrillConfig()
    pos, vel, holder = _arrays(states)
    n = len(states)
    rng = np.random.default_rng(3)
    vmax = np.tile([6.0, 6.0, 4.6, 4.1], (n, 1))
    points = interception_points(pos, vel, holder, vmax, cfg)
    marks = mark_targets(pos, holder, 0.4)
    attacker = np.where(holder >= 0, holder % 2, 0)
    features = observation("features", cfg)
    records = np.concatenate([state_record(s) for s in states])
    feats = features(records, np.arange(n), attacker)
    off_ball = [int(s) for s in Skill if s not in (Skill.HOLD, Skill.PASS, Skill.DRIBBLE)]
    skill = rng.choice(off_ball, size=(n, 4))
    has_ball = holder >= 0
    skill[has_ball, holder[has_ball]] = rng.choice([int(Skill.HOLD), int(Skill.DRIBBLE)],
                                                   size=np.count_nonzero(has_ball))
    target = rng.uniform(0.0, cfg.field_size, size=(n, 4, 2))
    speed = rng.uniform(0.5, 1.0, size=(n, 4))
    cycle = np.zeros(n, dtype=CYCLE)
    cycle["skill"], cycle["target"], cycle["speed"] = skill, target, speed
    before_physics_of_drills(np.ones(n, dtype=bool), True, records, cycle, rule_parameters(cfg),
                             roll_table(cfg))
    motions = cycle["motions"]
    for k, s in enumerate(states):
        for p in range(4):
            assert tuple(points[k, p]) == ball_interception_point(s, p, vmax[k, p], cfg)
            bx, by = s.pos[4]
            fx, fy = s.pos[s.free_opponent_of(p)]
            assert tuple(marks[k, p]) == (fx + 0.4 * (bx - fx), fy + 0.4 * (by - fy))
            command = Command(Skill(int(skill[k, p])), tuple(target[k, p]), float(speed[k, p]))
            assert tuple(motions[k, p]) == tuple(execute(s, p, command, cfg, None))
        alone = features(state_record(s), np.zeros(1, dtype=np.int64), attacker[k:k + 1])[0]
        np.testing.assert_array_equal(feats[k], alone)


@pytest.mark.parametrize("team", TEAMS)
def test_one_drill_plays_the_single_environments_episodes_step_by_step(team):
    """With one drill per space the physics is the single drill's: every observation,
    reward and info equals the single environment's, decision by decision."""
    venv = HolderVectorEnv(num_envs=1, opponent=team)
    env = HolderEnv(opponent=team)
    policy = HOLDER_POLICIES["pass_first"]
    for seed in (3, 11):
        obs, info = venv.reset(seed=seed)
        single, _ = env.reset(seed=seed)
        np.testing.assert_array_equal(obs[0], single)
        done = False
        while not done:
            action = policy(single, None)
            obs, reward, term, trunc, info = venv.step(np.array([action]))
            single, r, t, tr, i = env.step(action)
            np.testing.assert_array_equal(obs[0], single)
            assert (reward[0], term[0], trunc[0]) == (r, t, tr)
            assert {k: info[k][0] for k in i} == i
            done = t or tr
        venv.step(np.array([0]))  # NEXT_STEP autoreset


def test_a_batch_of_one_drill_is_the_single_drill_bit_for_bit():
    """A batch of one drill is in the single drill's own space (the ball a body too,
    velocities alone written): its episodes are ``HolderEnv``'s to the last bit, also
    those with simultaneous contacts, where a space of the batch's kind differs."""
    venv = HolderVectorEnv(num_envs=1, opponent="interceptors_cover")
    env = HolderEnv(opponent="interceptors_cover")
    rng = np.random.default_rng(5)
    for seed in range(60):
        obs, _ = venv.reset(seed=seed)
        single, _ = env.reset(seed=seed)
        done = False
        while not done:
            action = int(rng.integers(3))
            obs, reward, term, trunc, info = venv.step(np.array([action]))
            single, r, t, tr, i = env.step(action)
            assert obs[0].tobytes() == single.tobytes(), f"seed {seed}, cycle {i['cycles']}"
            assert (reward[0], term[0], trunc[0]) == (r, t, tr)
            done = t or tr


def test_make_vec_gives_the_batched_env_with_gymnasiums_spaces_and_first_observations():
    venv = gym.make_vec("soccer_drill/Holder-v0", num_envs=5, vectorization_mode="vector_entry_point",
                        opponent="goal_guards")
    assert isinstance(venv, VectorEnv) and isinstance(venv.unwrapped, HolderVectorEnv)
    sync = gym.make_vec("soccer_drill/Holder-v0", num_envs=5, vectorization_mode="sync",
                        opponent="goal_guards")
    assert venv.single_observation_space == sync.single_observation_space
    assert venv.action_space == sync.action_space and venv.observation_space == sync.observation_space
    obs, info = venv.reset(seed=42)
    sync_obs, sync_info = sync.reset(seed=42)
    np.testing.assert_array_equal(obs, sync_obs)  # drill i starts as env i of reset(seed=42 + i)
    assert set(info) == set(sync_info)
    for key in info:
        assert list(info[key]) == list(sync_info[key])
    assert obs in venv.observation_space
    obs, rewards, term, trunc, info = venv.step(venv.action_space.sample())
    assert obs in venv.observation_space and rewards.shape == (5,) and term.dtype == bool
    assert set(info) == set(sync_info)


def _run(venv, seed, steps, policy_seed=0):
    out = []
    obs, _ = venv.reset(seed=seed)
    rng = np.random.default_rng(policy_seed)
    for _ in range(steps):
        obs, r, te, tr, info = venv.step(rng.integers(3, size=venv.num_envs))
        out.append((obs.copy(), r.copy(), te.copy(), tr.copy(), info["cycles"].copy()))
    return out


def test_the_same_seed_gives_the_same_batch_also_after_earlier_episodes():
    venv = HolderVectorEnv(num_envs=12, opponent="goal_guards", drills_per_space=5)
    first = _run(venv, 7, 40)
    _run(venv, 8, 25)
    again = _run(venv, 7, 40)
    fresh = _run(HolderVectorEnv(num_envs=12, opponent="goal_guards", drills_per_space=5), 7, 40)
    for a, b, c in zip(first, again, fresh, strict=True):
        for x, y, z in zip(a, b, c, strict=True):
            np.testing.assert_array_equal(x, y)
            np.testing.assert_array_equal(x, z)
    other = _run(HolderVectorEnv(num_envs=12, opponent="goal_guards"), 9, 5)
    assert not np.array_equal(other[0][0], first[0][0])


def test_autoreset_next_step_and_same_step():
    for mode in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
        venv = HolderVectorEnv(num_envs=8, opponent="chasers", autoreset_mode=mode)
        obs, _ = venv.reset(seed=0)
        seen_end = False
        for _ in range(60):
            obs, r, te, tr, info = venv.step(np.full(8, 2))  # always dribble: episodes end
            ended = te | tr
            if mode == AutoresetMode.SAME_STEP and ended.any():
                i = int(np.flatnonzero(ended)[0])
                assert info["_final_obs"][i] and info["final_obs"][i].shape == (9,)
                assert info["final_info"]["outcome"][i] is not None
                assert info["cycles"][i] == 0 and info["outcome"][i] is None  # already reset
                seen_end = True
            if mode == AutoresetMode.NEXT_STEP and ended.any():
                i = int(np.flatnonzero(ended)[0])
                assert info["outcome"][i] is not None
                obs, r, te, tr, info = venv.step(np.full(8, 2))
                assert info["cycles"][i] == 0 and r[i] == 0.0 and not (te[i] or tr[i])
                seen_end = True
        assert seen_end


def test_a_bad_action_in_drill_17_names_it_and_leaves_every_drill_as_it_was():
    venv = HolderVectorEnv(num_envs=32, opponent="interceptors_cover")
    venv.reset(seed=5)
    venv.step(np.zeros(32, dtype=int))
    b = venv._core.batch
    before = (b.pos.copy(), b.vel.copy(), b.holder.copy(), b.cycle.copy())
    actions = np.ones(32, dtype=int)
    actions[17] = 5
    with pytest.raises(ValueError, match=r"drill 17: action must be an integer in \[0, 2\]"):
        venv.step(actions)
    for x, y in zip(before, (b.pos, b.vel, b.holder, b.cycle), strict=True):
        np.testing.assert_array_equal(x, y)
    with pytest.raises(ValueError, match=r"shape \(32,\)"):
        venv.step(np.ones(31, dtype=int))
    venv.step(np.ones(32, dtype=int))  # still usable


class _NoBatch:
    """The parametric team as a team of one drill (``reset(view, rng)``, ``act(view)``): its
    batched form run on a drill of its own, put in the state it is shown. The batched
    drill runs it as one copy per drill, checked by the team driver."""

    def __init__(self, **params):
        self.inner = ParametricTeam(**params)

    def reset(self, view, rng):
        one = np.zeros(1, dtype=np.int64)
        self.drill = BatchDrill(1, view.config)
        self.drill.set_state(0, view.state)
        self.view, self.batched = BatchView(self.drill, view.players), self.inner.batch(1)
        draws = BatchRandom(1)
        draws.seed(one, [rng])
        self.batched.reset(self.view, one, draws)

    def act(self, view):
        self.drill.set_state(0, view.state)
        c = self.batched.act(self.view, np.zeros(1, dtype=np.int64))
        return {p: Command(Skill(int(c.skill[0, k])), tuple(c.target[0, k].tolist())
                           if c.skill[0, k] == Skill.MOVE_TO else None, float(c.speed[0, k]))
                for k, p in enumerate(view.players)}


@pytest.mark.parametrize("params", [
    {"roles": ("guard", "guard"), "press_probability": 0.05, "guard_track": 0.8},
    *sample_opponents(3, seed=1),
])
def test_a_batched_team_plays_as_one_team_per_drill(params):
    """The batched parametric team and one copy per drill give identical batches."""
    batched = _run(HolderVectorEnv(num_envs=9, opponent=ParametricTeam(**params)), 2, 30)
    copies = _run(HolderVectorEnv(num_envs=9, opponent=_NoBatch(**params)), 2, 30)
    for a, b in zip(batched, copies, strict=True):
        for x, y in zip(a, b, strict=True):
            np.testing.assert_array_equal(x, y)


class _BadBatch:
    """Batched chasers whose drill 3 gets a speed of 1.5."""

    def reset(self, view, drills, rng):
        pass

    def act(self, view, drills):
        speed = np.ones((len(drills), 2))
        speed[drills == 3, 1] = 1.5
        return BatchCommands(np.full((len(drills), 2), 5), np.zeros((len(drills), 2, 2)), speed)


class _Team:
    def reset(self, view, rng):
        pass

    def act(self, view):
        return {}

    def batch(self, n):
        return _BadBatch()


def test_a_bad_batched_command_names_the_team_drill_player_and_cycle():
    venv = HolderVectorEnv(num_envs=6, opponent=_Team())
    venv.reset(seed=0)
    with pytest.raises(TeamError, match=r"drill 3, player 'defender_1', cycle 0: speed must be in \(0, 1\]"):
        venv.step(np.zeros(6, dtype=int))


class _RaisingBatch(_BadBatch):
    def act(self, view, drills):
        raise ZeroDivisionError("division by zero in the batched act")


class _RaisingTeam(_Team):
    def batch(self, n):
        return _RaisingBatch()


def test_a_batched_team_that_raises_is_a_team_error_naming_it():
    venv = HolderVectorEnv(num_envs=4, opponent=_RaisingTeam())
    venv.reset(seed=0)
    with pytest.raises(TeamError, match=r"'_RaisingTeam' raised in act\(\).*ZeroDivisionError"
                                        r"\('division by zero in the batched act'\)"):
        venv.step(np.zeros(4, dtype=int))


def test_a_per_drill_team_error_is_a_team_error():
    class Broken(_NoBatch):
        def act(self, view):
            return {"defender_0": None}

    venv = HolderVectorEnv(num_envs=3, opponent=Broken())
    venv.reset(seed=0)
    with pytest.raises(TeamError, match="must return a mapping with exactly the players"):
        venv.step(np.zeros(3, dtype=int))


def test_play_episodes_plays_each_seed_once_and_is_deterministic():
    policy = HOLDER_POLICIES["late_pass"]
    a = play_episodes(HolderVectorEnv(num_envs=7, opponent="interceptor_guard"), policy, range(20))
    b = play_episodes(HolderVectorEnv(num_envs=7, opponent="interceptor_guard"), policy, range(20))
    assert a == b and len(a) == 20
    assert all(o in ("success", "interception", "out", "timeout") for _, o in a)


def test_batched_multi_agent_env():
    venv = ParallelVectorEnv(num_envs=16, opponent=None, illegal_action="raise", shared_spaces=False)
    obs, infos = venv.reset(seed=1)
    assert venv.agents == ["attacker_0", "attacker_1", "defender_0", "defender_1"]
    assert obs["attacker_0"]["observation"].shape == (16, 9)
    assert obs["defender_0"]["action_mask"].shape == (16, 3)
    masks = venv.action_masks()
    actions = {a: masks[a].argmax(axis=1) for a in venv.agents}
    obs, rewards, term, trunc, infos = venv.step(actions)
    np.testing.assert_array_equal(rewards["attacker_0"], -rewards["defender_0"])
    bad = dict(actions)
    bad["attacker_1"] = actions["attacker_1"].copy()
    holder = venv._core.batch.holder
    d = int(np.flatnonzero(holder == 1)[0]) if (holder == 1).any() else None
    if d is not None:
        bad["attacker_1"][d] = 4  # GO_TO_BALL is masked for the holder
        with pytest.raises(ValueError, match=rf"drill {d}: action 4 \(GO_TO_BALL\) is masked for 'attacker_1'"):
            venv.step(bad)
    lenient = ParallelVectorEnv(num_envs=4, opponent="chasers")
    lenient.reset(seed=0)
    holder = lenient._core.batch.holder
    acts = {a: np.full(4, 3) for a in lenient.agents}  # GET_OPEN: masked for the holder
    _, _, _, _, infos = lenient.step(acts)
    for a, i in (("attacker_0", 0), ("attacker_1", 1)):
        np.testing.assert_array_equal(infos["illegal_action"][a] == 3, holder == i)
        np.testing.assert_array_equal(infos["action_taken"][a][holder == i], 0)


@pytest.mark.slow
def test_success_rates_agree_with_the_single_environment():
    """A small version of ``python -m ilpss.experiments.agreement`` (500 episodes, every rule and team)."""
    cells = agreement(120, ["interceptors_cover", "goal_guards"], ["pass_first", "late_pass"], drills=40)
    assert all(c.agrees for c in cells), cells


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_max_episode_steps_truncates_as_timelimit_truncates_the_single_env(mode):
    # before, gym.make_vec(..., vectorization_mode="vector_entry_point",
    # max_episode_steps=n) raised TypeError: the batched env had no step limit
    def make(how, **kwargs):
        return gym.make_vec("soccer_drill/Holder-v0", num_envs=3, vectorization_mode=how,
                            max_episode_steps=3, **kwargs)

    batched = make("vector_entry_point", autoreset_mode=mode)
    assert batched.unwrapped.max_episode_steps == 3
    sync = make("sync", vector_kwargs={"autoreset_mode": mode})
    assert np.array_equal(batched.reset(seed=5)[0], sync.reset(seed=5)[0])
    rng, cut = np.random.default_rng(0), 0
    for _ in range(60):
        actions = rng.integers(3, size=3)
        got, want = batched.step(actions), sync.step(actions)
        for mine, theirs in zip(got[:4], want[:4], strict=True):
            assert np.array_equal(mine, theirs)
        if mode == AutoresetMode.SAME_STEP and "_final_obs" in want[4]:
            assert np.array_equal(got[4]["_final_obs"], want[4]["_final_obs"])
        cut += int(np.count_nonzero(got[3] & ~got[2]))  # cut short: no timeout in 3 steps
    assert cut > 10  # the limit cut episodes short
    with pytest.raises(ValueError, match="max_episode_steps must be None or an integer >= 1"):
        HolderVectorEnv(2, max_episode_steps=0)
    with pytest.raises(ValueError, match="play_episodes plays whole episodes"):
        play_episodes(batched.unwrapped, HOLDER_POLICIES["hold"], [0])


def test_a_step_after_play_episodes_says_play_episodes_played_the_drills():
    # before, it said step() was called before reset(), after a reset had been made
    env = HolderVectorEnv(2)
    env.reset(seed=0)
    play_episodes(env, HOLDER_POLICIES["pass_first"], [1, 2])
    with pytest.raises(RuntimeError, match=r"step\(\) called after play_episodes\(\) played "
                                           r"the drills; call reset\(\) first"):
        env.step(np.zeros(2, dtype=int))
    env.reset(seed=0)
    env.step(np.zeros(2, dtype=int))


def test_the_defenders_reward_is_never_a_negative_zero():
    # before, the defenders got -0.0 on each drill's autoreset step and while it ran
    env = ParallelVectorEnv(4)  # both sides agents
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(150):
        _, rewards, *_ = env.step({a: rng.integers(5, size=4) for a in env.agents})
        for r in rewards.values():
            assert not np.any((r == 0) & np.signbit(r))


def test_reset_with_an_integer_seed_seeds_np_random_as_gymnasiums_vector_envs():
    # before, np_random was seeded at random whatever reset was given
    env = HolderVectorEnv(2)
    env.reset(seed=7)
    assert env.np_random_seed == 7
    first = env.np_random.random()
    env.async_reset(seed=7)
    assert env.np_random_seed == 7 and env.np_random.random() == first
    env.recv()
    env.reset(seed=[1, 2])  # one seed per drill: np_random goes on
    assert env.np_random_seed == 7


def test_call_get_attr_and_set_attr_give_what_sync_gives():
    # before, HolderVectorEnv had none of them: a client moving from "sync" to the batched
    # env lost set_attr("decision_cycles", ...) (a curriculum) with an AttributeError
    def make(how):
        env = gym.make_vec("soccer_drill/Holder-v0", num_envs=3, vectorization_mode=how,
                           opponent="chasers")
        env.reset(seed=4)
        return env

    batched, sync = make("vector_entry_point"), make("sync")
    for name in ("decision_cycles", "action_names", "observation_space", "action_space"):
        assert batched.get_attr(name) == sync.get_attr(name)
    assert np.array_equal(np.stack(batched.call("action_masks")), np.stack(sync.call("action_masks")))
    for env in (batched, sync):
        env.set_attr("decision_cycles", 2)
    assert batched.get_attr("decision_cycles") == (2, 2, 2)
    for _ in range(3):  # the next decisions last 2 cycles in both
        actions = np.array([0, 2, 0])
        ours, theirs = batched.step(actions), sync.step(actions)
        assert np.array_equal(ours[4]["duration"], theirs[4]["duration"])
    batched.set_attr("decision_cycles", [3, 3, 3])  # equal values, one per drill
    assert batched.unwrapped.decision_cycles == 3
    with pytest.raises(ValueError, match=r"share one environment, so they take one value"):
        batched.set_attr("decision_cycles", [2, 3, 3])
    with pytest.raises(ValueError, match=r"2 values for 3 drills"):
        batched.set_attr("decision_cycles", [2, 2])
    with pytest.raises(ValueError, match=r"set_attr\('num_envs'\): set when the environment is made"):
        batched.set_attr("num_envs", 4)
    with pytest.raises(ValueError, match=r"call\('step'\): step\(\) acts on every drill at once"):
        batched.call("step", np.zeros(3, dtype=int))
    assert batched.unwrapped.call("render") == (None, None, None)  # no render mode
