"""Drills of any size: attackers and defenders from 1 to 4, the holder's SMDP at each."""

from __future__ import annotations

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from soccer_drill import DrillConfig, HolderEnv
from soccer_drill.rules.features import feature_names
from soccer_drill.vector import HolderVectorEnv


def test_the_paper_drill_keeps_its_starts_and_its_holder() -> None:
    cfg = DrillConfig()
    assert cfg.size == (2, 2)
    assert cfg.attacker_starts == ((4.0, 31.0), (31.0, 31.0))
    assert cfg.defender_starts == ((13.0, 9.0), (22.0, 9.0))
    assert cfg.player_names == ("attacker_0", "attacker_1", "defender_0", "defender_1")
    env = HolderEnv()
    assert env.observation_space.shape == (9,)
    assert env.action_names == ("HOLD", "PASS", "DRIBBLE")
    assert feature_names(1, 2)[4] == "pass_angle"


@pytest.mark.parametrize("field", ["attacker_starts", "defender_starts"])
def test_starts_must_be_one_point_per_player(field: str) -> None:
    with pytest.raises(ValueError, match=rf"DrillConfig.{field} must be a list of 3 values.*"
                                         r"three \(x, y\) points inside the field"):
        DrillConfig(attackers=3, defenders=3, **{field: ((4.0, 31.0), (31.0, 31.0))})


@pytest.mark.parametrize("count", [0, 5, 2.0, True])
def test_team_sizes_are_one_to_four(count: object) -> None:
    with pytest.raises(ValueError, match=r"DrillConfig.attackers must be an integer in \[1, 4\]"):
        DrillConfig(attackers=count)


@pytest.mark.parametrize(("attackers", "defenders"), [(1, 1), (3, 2), (3, 3), (4, 4)])
def test_the_holder_plays_every_size(attackers: int, defenders: int) -> None:
    cfg = DrillConfig(attackers=attackers, defenders=defenders, max_cycles=60)
    env = HolderEnv(config=cfg)
    m = attackers - 1
    assert env.observation_space.shape == (4 * m + defenders + 3,)
    assert env.action_space.n == attackers + 1
    assert env.action_names[0] == "HOLD" and env.action_names[-1] == "DRIBBLE"
    check_env(env, skip_render_check=True)
    rng = np.random.default_rng(0)
    outcomes = set()
    for seed in range(3):
        obs, info = env.reset(seed=seed)
        assert info["holder"] in cfg.player_names[:attackers]
        done = False
        while not done:
            obs, reward, terminated, truncated, info = env.step(int(rng.integers(attackers + 1)))
            assert env.observation_space.contains(obs)
            done = terminated or truncated
        outcomes.add(info["outcome"])
    assert outcomes <= {"success", "interception", "out", "timeout"}


def test_teammates_are_ranked_by_distance_and_a_pass_goes_to_its_rank() -> None:
    """At 3v2 the holder's first two features are its teammates' distances, nearest
    first; PASS_2 kicks the ball toward the farther teammate."""
    env = HolderEnv(config=DrillConfig(attackers=3, defenders=2))
    for seed in range(5):
        obs, _ = env.reset(seed=seed)
        assert obs[0] <= obs[1]
        state = env.drill_state
        holder = env.loop.core.batch.holder[0]
        pos = np.array(state.pos)
        mates = [k for k in range(3) if k != holder]
        far = max(mates, key=lambda k: np.hypot(*(pos[k] - pos[holder])))
        env.step(2)  # PASS_2: the second nearest
        ball = np.array(env.drill_state.pos[-1])
        to_far = pos[far] - pos[-1]
        moved = ball - pos[-1]
        cosine = moved @ to_far / (np.linalg.norm(moved) * np.linalg.norm(to_far))
        assert cosine > 0.8, (seed, cosine)


def test_the_batched_holder_plays_a_larger_drill_as_the_single_one() -> None:
    cfg = DrillConfig(attackers=3, defenders=3)
    single = HolderEnv(config=cfg)
    vector = HolderVectorEnv(num_envs=2, config=cfg, drills_per_space=1)
    assert vector.single_action_space.n == 4
    obs, _ = vector.reset(seed=[7, 8])
    first, _ = single.reset(seed=7)
    assert np.array_equal(obs[0], first)
    for action in (3, 1, 0, 3, 2):
        obs, reward, terminated, truncated, _ = vector.step(np.array([action, 0]))
        step = single.step(action)
        if terminated[0] or truncated[0]:
            assert reward[0] == step[1]
            break
        assert np.array_equal(obs[0], step[0])


@pytest.mark.parametrize(("attackers", "defenders"), [(3, 2), (1, 1)])
def test_the_multi_agent_drill_passes_pettingzoo_tests_at_other_sizes(
        attackers: int, defenders: int) -> None:
    from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test

    import soccer_drill

    cfg = DrillConfig(attackers=attackers, defenders=defenders, max_cycles=30)
    api_test(soccer_drill.env(config=cfg), num_cycles=30)
    parallel_api_test(soccer_drill.parallel_env(config=cfg), num_cycles=30)
    parallel_seed_test(lambda: soccer_drill.parallel_env(config=cfg), num_cycles=10)
    env = soccer_drill.parallel_env(config=cfg, opponent="chasers", render_mode="rgb_array")
    obs, _ = env.reset(seed=1)
    assert env.agents == list(cfg.player_names[:attackers])
    most = max(attackers, defenders)
    assert {o["observation"].shape for o in obs.values()} == {(5 * most - 1,)}
    assert env.state().shape == (6 * cfg.players + 5,)
    assert env.action_space(env.agents[0]).n == attackers + 3
    assert env.render().ndim == 3


def test_the_batched_multi_agent_drill_plays_a_larger_drill_as_the_single_one() -> None:
    import soccer_drill
    from soccer_drill.vector import ParallelVectorEnv

    cfg = DrillConfig(attackers=3, defenders=2)
    single = soccer_drill.parallel_env(config=cfg, opponent="chasers")
    vector = ParallelVectorEnv(num_envs=2, config=cfg, opponent="chasers", drills_per_space=1)
    obs, _ = vector.reset(seed=[3, 4])
    one, _ = single.reset(seed=3)
    rng = np.random.default_rng(0)
    for _ in range(40):
        for agent in single.agents:
            assert np.array_equal(obs[agent]["observation"][0], one[agent]["observation"])
        masks = {a: one[a]["action_mask"] for a in single.agents}
        actions = {a: int(rng.choice(np.flatnonzero(masks[a]))) for a in single.agents}
        one, rewards, terminated, truncated, _ = single.step(actions)
        obs, vrewards, vterm, _, _ = vector.step(
            {a: np.array([actions[a], 0]) for a in vector.agents})
        if any(terminated.values()) or any(truncated.values()):
            assert vterm["attacker_0"][0] == terminated["attacker_0"]
            break


@pytest.mark.parametrize("name", ["keepaway", "pass_first", "late_pass", "lane", "random"])
def test_the_fixed_rules_play_every_size(name: str) -> None:
    """A rule reads the features' layout from their length: its actions exist at every
    size, and at 3v2 it passes to a teammate it may pass to."""
    from soccer_drill.policies import HOLDER_POLICIES, layout

    rng = np.random.default_rng(1)
    for attackers, defenders in [(1, 1), (2, 2), (3, 2), (4, 4)]:
        env = HolderEnv(config=DrillConfig(attackers=attackers, defenders=defenders))
        obs, _ = env.reset(seed=2)
        assert layout(obs) == (attackers - 1, defenders)
        for _ in range(30):
            action = HOLDER_POLICIES[name](obs, rng)
            assert 0 <= action <= attackers
            obs, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                break


# The sizes compiled elsewhere in the tests (each new size compiles the rules anew).
@pytest.mark.parametrize("defenders", [1, 3, 4])
def test_every_built_in_team_plays_any_number_of_defenders(defenders: int) -> None:
    from soccer_drill.teams.registry import TEAMS

    cfg = DrillConfig(attackers=defenders, defenders=defenders, max_cycles=40)
    for team in TEAMS.own_names():  # a plugin installed beside may play only some sizes
        env = HolderEnv(opponent=team, config=cfg)
        obs, _ = env.reset(seed=3)
        for action in (defenders, 1, 0, defenders, defenders):  # DRIBBLE, a pass (1v1: DRIBBLE)
            obs, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                break
        skills = env.loop.core.batch.skill[0, defenders:]
        assert len(skills) == defenders, team


def test_a_team_repeats_its_roles_for_more_defenders() -> None:
    from opponents.parametric import ParametricTeam

    team = ParametricTeam(roles=("interceptor", "guard"), speed=[0.9, 0.8])
    assert team.roles_of(3) == ("interceptor", "guard", "interceptor")
    assert team.roles_of(1) == ("interceptor",)
    assert team.speeds_of(4) == (0.9, 0.8, 0.9, 0.8)
    guards = HolderEnv(opponent="goal_guards", config=DrillConfig(attackers=3, defenders=3),
                       opponent_params={"press_probability": 0.0, "guard_reach": 0.0})
    guards.reset(seed=0)
    guards.step(0)
    batch = guards.loop.core.batch
    # Three guards on the line, spread across it at their depth.
    assert np.all(batch.target[0, 3:, 1] == 2.5)
    assert np.all(np.diff(batch.target[0, 3:, 0]) > 0)


class _TwoOnly:
    """A team that says which numbers of defenders it plays."""

    defender_counts = (2,)

    def reset(self, view, rng):
        pass

    def act(self, view):
        from soccer_drill import Command, Skill

        return {p: Command(Skill.INTERCEPT) for p in view.players}


def test_a_team_that_cannot_play_the_size_says_so_when_the_drill_is_made() -> None:
    from soccer_drill import TeamError

    HolderEnv(opponent=_TwoOnly())  # the size it plays
    with pytest.raises(TeamError, match=r"team '.*' plays 2 defender\(s\), and this drill has 3 "
                                        r"\(DrillConfig.defenders=3\)"):
        HolderEnv(opponent=_TwoOnly(), config=DrillConfig(attackers=3, defenders=3))


def test_the_batched_drills_render_at_other_sizes() -> None:
    """Each drill's frame draws its own players (the ball is the last body)."""
    cfg = DrillConfig(attackers=3, defenders=2)
    vector = HolderVectorEnv(num_envs=2, config=cfg, render_mode="rgb_array")
    vector.reset(seed=0)
    frames = vector.render()
    single = HolderEnv(config=cfg, render_mode="rgb_array")
    single.reset(seed=0)
    assert len(frames) == 2 and frames[0].shape == single.render().shape
    assert frames[0].dtype == np.uint8


def test_a_team_saying_its_sizes_wrongly_is_refused_in_the_vocabularys_words() -> None:
    from soccer_drill import TeamError

    team = _TwoOnly()
    team.defender_counts = (0, 2)  # type: ignore[misc]
    with pytest.raises(TeamError, match=r"defender_counts must be a list of at least 1 values, "
                                        r"each an integer in \[1, 4\], got \(0, 2\)"):
        HolderEnv(opponent=team)


@pytest.mark.parametrize(("attackers", "defenders"), [(3, 2), (4, 3)])
def test_plain_int_actions_give_the_same_episode_as_numpy_ones(attackers: int,
                                                               defenders: int) -> None:
    """A legal plain int takes the action check's shortcut, a NumPy integer its full path;
    both set the same skill and, for a pass, the same receiver by rank."""
    import soccer_drill

    cfg = DrillConfig(attackers=attackers, defenders=defenders)
    runs = []
    for kind in (int, np.int64):
        env = soccer_drill.parallel_env(config=cfg, opponent="chasers")
        rng, seen = np.random.default_rng(3), []
        for seed in range(6):
            obs, _ = env.reset(seed=seed)
            while env.agents:
                actions = {a: kind(rng.choice(np.flatnonzero(obs[a]["action_mask"])))
                           for a in env.agents}
                obs, rewards, *_ = env.step(actions)
                seen.append((tuple(env.unwrapped._batch.receiver[0].tolist()),
                             b"".join(o["observation"].tobytes() for o in obs.values()),
                             tuple(rewards.values())))
        runs.append(seen)
    assert runs[0] == runs[1]
    assert any(r >= 0 for step in runs[0] for r in step[0])  # passes to a teammate by rank


def test_the_smallest_fields_the_default_starts_fit_are_the_ones_documented():
    from soccer_drill import DrillConfig

    def fits(a, d, size):
        try:
            DrillConfig(attackers=a, defenders=d, field_size=size)
        except ValueError:
            return False
        return True

    for a in range(1, 5):
        for d in range(1, 5):
            least = 32.5 if a == 2 else 23.0 if d == 2 else 13.5 if a > 2 else 10.0
            assert fits(a, d, least) and (least == 10.0 or not fits(a, d, least - 0.5)), (a, d)


@pytest.mark.parametrize(("kwargs", "least"), [
    ({"field_size": 30.0}, "32.5"), ({"field_size": 20.0, "attackers": 3}, "23"),
    ({"field_size": 30.0, "start_jitter": 0.0}, "31")])
def test_default_starts_that_do_not_fit_say_the_smallest_field_they_fit(kwargs, least):
    # before, the error opened on attacker_starts, a field the user had not given, and
    # never said how large a field the default starts need
    from soccer_drill import DrillConfig

    with pytest.raises(ValueError) as refused:
        DrillConfig(**kwargs)
    said = str(refused.value)
    assert said.startswith(f"DrillConfig: field_size {kwargs['field_size']:g} is too small")
    assert f"they need field_size >= {least} " in said
    DrillConfig(**{**kwargs, "field_size": float(least)})
    with pytest.raises(ValueError):
        DrillConfig(**{**kwargs, "field_size": float(least) - 0.1})


def test_the_docstrings_give_the_spaces_of_every_size():
    # before, state() said "a 29-value vector", shared_spaces "5 actions" and
    # HolderVectorEnv's table Box(9,) and MultiDiscrete([3] * N), the 2v2 drill's only
    import soccer_drill

    config = DrillConfig(attackers=3, defenders=2)
    env = soccer_drill.parallel_env(config=config, shared_spaces=True)
    env.reset(seed=0)
    assert "``6 p + 5`` float32 values" in type(env).state.__doc__
    assert env.state().shape == (6 * 5 + 5,)
    assert "``A + 3`` actions (5 in the 2v2 drill)" in soccer_drill.raw_env.__doc__
    assert env.action_space("defender_0").n == 3 + 3
    vec = HolderVectorEnv(2, config=config)
    doc = HolderVectorEnv.__doc__
    assert "``Box(4 (A - 1) + D + 3,)``" in doc and "``MultiDiscrete([n] * N)``" in doc
    assert vec.single_observation_space.shape == (4 * 2 + 2 + 3,)
    assert list(vec.action_space.nvec) == [3 + 1] * 2
