"""Bad input gets a clear error saying what was wrong and what is allowed."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import soccer_drill
from soccer_drill import TeamError
from soccer_drill.commands import Command, Skill
from soccer_drill.config import DrillConfig
from soccer_drill.vector import HolderVectorEnv


def _first_turn(opponent="chasers", illegal_action="raise"):
    env = soccer_drill.env(opponent=opponent, illegal_action=illegal_action)
    env.reset(seed=0)
    agent = env.agent_selection
    mask = env.observe(agent)["action_mask"]
    return env, agent, mask


def test_masked_action_names_agent_action_and_legal_ones():
    env, agent, mask = _first_turn()
    masked = int(np.flatnonzero(mask == 0)[0])
    with pytest.raises(ValueError, match=rf"action {masked} \(\w+\) is masked for '{agent}'") as err:
        env.step(masked)
    for legal in np.flatnonzero(mask):
        assert f"{legal}=" in str(err.value)
    assert "illegal_action='default'" in str(err.value)  # the error names the option


@pytest.mark.parametrize("shared_spaces", [False, True])
def test_masked_defender_action_with_shared_spaces_names_the_padding(shared_spaces):
    env = soccer_drill.parallel_env(illegal_action="raise", shared_spaces=shared_spaces)
    obs, _ = env.reset(seed=0)
    actions = {a: int(np.flatnonzero(obs[a]["action_mask"])[0]) for a in env.agents}
    if shared_spaces:
        with pytest.raises(ValueError, match=r"action 4 \(padding\) is masked for 'defender_0'"):
            env.step({**actions, "defender_0": 4})
    else:
        with pytest.raises(ValueError, match=r"action 4 for 'defender_0' is out of range; allowed: 0\.\.2"):
            env.step({**actions, "defender_0": 4})


def test_masked_action_is_replaced_by_default_and_reported_in_infos():
    env = soccer_drill.env(opponent="chasers")  # the default: illegal_action="default"
    env.reset(seed=0)
    agent = env.agent_selection
    holder = env.drill_state.holder == env.possible_agents.index(agent)
    masked = int(np.flatnonzero(env.observe(agent)["action_mask"] == 0)[0])
    env.step(masked)
    taken = 0 if holder else 3  # HOLD for the holder, GET_OPEN off the ball
    assert env.infos[agent] == {"illegal_action": masked, "action_taken": taken}
    env.step(None if env.terminations[env.agent_selection] else
             int(np.flatnonzero(env.observe(env.agent_selection)["action_mask"])[0]))
    assert env.agent_selection == agent
    assert env.last()[4] == {"illegal_action": masked, "action_taken": taken}  # seen at its turn
    env.step(int(np.flatnonzero(env.observe(agent)["action_mask"])[0]))  # a legal action
    assert env.infos[agent] == {}  # the report is gone

    par = soccer_drill.parallel_env(opponent="chasers")
    obs, infos = par.reset(seed=0)
    assert infos == {a: {} for a in par.agents}
    actions = {a: int(np.flatnonzero(obs[a]["action_mask"] == 0)[0]) for a in par.agents}
    _, _, _, _, infos = par.step(actions)
    for a in par.agents:
        assert infos[a]["illegal_action"] == actions[a]
        assert infos[a]["action_taken"] in (0, 3)
    legal = {a: int(np.flatnonzero(o["action_mask"])[0]) for a, o in par.reset(seed=0)[0].items()}
    assert par.step(legal)[4] == {a: {} for a in par.agents}


@pytest.mark.parametrize("action", [5, -1, 99])
def test_out_of_range_action(action):
    env, agent, _ = _first_turn()
    with pytest.raises(ValueError, match=rf"action {action} for '{agent}' is out of range; allowed: 0..4"):
        env.step(action)


@pytest.mark.parametrize("action", [1.5, "1", [1], True])
def test_wrong_action_type(action):
    env, agent, _ = _first_turn()
    with pytest.raises(TypeError, match=f"action for '{agent}' must be an integer"):
        env.step(action)


def test_numpy_integer_actions_are_accepted():
    env, agent, mask = _first_turn()
    legal = int(np.flatnonzero(mask)[0])
    env.step(np.int64(legal))
    plain, _, _ = _first_turn()
    plain.step(legal)
    # The NumPy integer is taken as the plain one: the same next turn, the same observation.
    assert env.agent_selection == plain.agent_selection != agent
    np.testing.assert_array_equal(env.observe(env.agent_selection)["observation"],
                                  plain.observe(plain.agent_selection)["observation"])


def test_parallel_missing_or_extra_agents():
    env = soccer_drill.parallel_env(opponent="chasers")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="one action per live agent"):
        env.step({"attacker_0": 0})
    with pytest.raises(ValueError, match="one action per live agent"):
        env.step({"attacker_0": 0, "attacker_1": 3, "defender_0": 0})


def test_step_before_reset():
    with pytest.raises(RuntimeError, match="before reset"):
        soccer_drill.env().step(0)
    with pytest.raises(RuntimeError, match="before reset"):
        soccer_drill.parallel_env().step({})


def test_the_turns_of_an_environment_never_reset_are_refused_not_empty():
    # A loop over agent_iter() before reset() did nothing, silently; PettingZoo's
    # OrderEnforcingWrapper, which the drill's checks stand in for, refuses it.
    env = soccer_drill.env(opponent="chasers")
    with pytest.raises(RuntimeError, match=r"agent_iter\(\) called before reset\(\)"):
        env.agent_iter()
    env.reset(seed=0)
    turns = []
    for agent in env.agent_iter(3):
        turns.append(agent)
        env.step(3)  # GET_OPEN, or HOLD replacing it for the holder
    assert turns == ["attacker_0", "attacker_1", "attacker_0"]


def test_the_batched_masks_of_drills_never_reset_are_refused():
    # They were the masks of a drill whose ball nobody holds, as if it were under way.
    from soccer_drill.vector import ParallelVectorEnv

    env = ParallelVectorEnv(num_envs=2)
    with pytest.raises(RuntimeError, match=r"action_masks\(\) called before reset\(\)"):
        env.action_masks()
    observations, _ = env.reset(seed=0)
    masks = env.action_masks()
    for agent, mask in masks.items():
        np.testing.assert_array_equal(mask, observations[agent]["action_mask"])


def test_unknown_team_lists_known_ones():
    with pytest.raises(ValueError, match=r"unknown team 'nobody'; known teams: \[.*'chasers'"):
        soccer_drill.env(opponent="nobody")


def test_bad_team_parameters():
    with pytest.raises(ValueError, match=r"bad parameters .* for team 'chasers'"):
        soccer_drill.env(opponent="chasers", opponent_params={"colour": "red"})


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("field_size", -1.0, r"field_size must be a finite number in \[10, 1000\], got -1.0"),
        ("max_cycles", 0, r"max_cycles must be an integer in \[1, 1,000,000\], got 0"),
        ("substeps", 2.5, r"substeps must be an integer in \[1, 1,000\], got 2.5"),
        ("ball_damping", 1.5, r"ball_damping must be a finite number in \[0, 1\]"),
        ("tackle_probability", -0.1, r"tackle_probability must be a finite number in \[0, 1\]"),
        ("attacker_speed", math.nan, r"attacker_speed must be a finite number in \(0, 100\], got nan"),
        ("ball_offset", 2.0, r"ball_offset must be a finite number in \[0, 0.95\), got 2.0 "
                             r"\(smaller than control_radius - 0.05"),
        ("attacker_starts", ((1.0, 1.0), (50.0, 1.0)), r"attacker_starts must be a list of 2 "
                                                       r"values, each a list of 2 values"),
    ],
)
def test_invalid_configuration(field, value, message):
    with pytest.raises(ValueError, match=message):
        DrillConfig(**{field: value})


def test_unknown_configuration_key_and_keyword():
    with pytest.raises(ValueError, match=r"unknown DrillConfig field\(s\) \['speed'\]"):
        soccer_drill.env(config={"speed": 3})
    with pytest.raises(TypeError, match="unexpected keyword"):
        soccer_drill.env(colour="red")


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"obs_type": "pixels"}, "obs_type must be one of 'features', 'kinematic' or 'full'"),
        ({"render_mode": "ansi"}, "render_mode must be None or one of"),
        ({"illegal_action": "ignore"}, "illegal_action must be 'raise' or 'default'"),
        ({"max_cycles": 0}, r"max_cycles must be an integer in \[1, 1,000,000\]"),
    ],
)
def test_invalid_environment_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        soccer_drill.env(**kwargs)


def test_holder_env_rejects_bad_actions():
    env = soccer_drill.HolderEnv(opponent="chasers")
    env.reset(seed=0)
    for bad in (3, -1, 0.5, None):
        with pytest.raises(ValueError, match=r"integer in \[0, 2\] \(0=HOLD, 1=PASS, 2=DRIBBLE\)"):
            env.step(bad)


class _Team:
    """A configurable misbehaving team."""

    def __init__(self, act):
        self._act = act

    def reset(self, view, rng):
        self.players = view.players

    def act(self, view):
        return self._act(self.players)


def _boom(players):
    raise KeyError("lost my tactics board")


@pytest.mark.parametrize(
    ("act", "message"),
    [
        (_boom, r"team '_Team' raised in act\(\) at cycle 0: KeyError"),
        (lambda p: {"attacker_0": Command(Skill.INTERCEPT)},
         r"exactly the players it drives \['defender_0', 'defender_1'\], got \['attacker_0'\]"),
        (lambda p: dict.fromkeys(p, Command(Skill.MOVE_TO, (math.nan, 1.0))),
         "MOVE_TO needs a finite"),
        (lambda p: dict.fromkeys(p, Command(Skill.DRIBBLE)), "not allowed for a scripted defender"),
        (lambda p: dict.fromkeys(p, "run"), "expected a Command, got 'run'"),
        (lambda p: dict.fromkeys(p, Command(Skill.MARK, speed=2.0)), r"speed must be in \(0, 1\]"),
        # None for the first player: refused, not read as "the previous player's command"
        # (there is none: its row was memory never written)
        (lambda p: {p[0]: None, p[1]: Command(Skill.MARK)},
         "player 'defender_0', cycle 0: expected a Command, got None"),
        (lambda p: dict.fromkeys(p), "player 'defender_0', cycle 0: expected a Command, got None"),
        # a set has no order to read x and y by ({30.0, 2.0} iterates as 2.0, 30.0)
        (lambda p: dict.fromkeys(p, Command(Skill.MOVE_TO, {30.0, 2.0})),
         r"not a set or a dict.*got \{2\.0, 30\.0\}"),
        (lambda p: dict.fromkeys(p, Command(Skill.MOVE_TO, {"x": 3.0, "y": 4.0})),
         "not a set or a dict"),
    ],
)
def test_misbehaving_team_is_named(act, message):
    team = _Team(act)
    env = soccer_drill.HolderEnv(opponent=team)
    env.reset(seed=0)
    with pytest.raises(TeamError, match=message):
        env.step(0)
    # The same environment stays usable: once its team behaves, its next reset gives the
    # episode a fresh environment gives against a well-behaved team.
    def marking(players):
        return dict.fromkeys(players, Command(Skill.MARK))

    team._act = marking  # the team mends its ways
    fresh = soccer_drill.HolderEnv(opponent=_Team(marking))
    for e in (env, fresh):
        e.reset(seed=0)
    for _ in range(3):
        a, b = env.step(0), fresh.step(0)
        np.testing.assert_array_equal(a[0], b[0])
        assert a[1:4] == b[1:4]


@pytest.mark.parametrize("make", [
    lambda **kw: soccer_drill.HolderEnv(**kw),
    lambda **kw: HolderVectorEnv(num_envs=2, **kw),
])
def test_decision_cycles_may_be_a_numpy_integer_but_not_a_bool(make):
    assert make(decision_cycles=np.int64(3)).decision_cycles == 3
    with pytest.raises(ValueError, match=r"decision_cycles must be an integer in \[1, 50\], got True"):
        make(decision_cycles=True)


@pytest.mark.parametrize("make", [soccer_drill.env, soccer_drill.parallel_env])
def test_shared_spaces_may_be_a_numpy_bool(make):
    env = make(shared_spaces=np.True_)
    env.reset(seed=0)
    assert env.observation_space("attacker_0") == env.observation_space("defender_0")


def test_a_commands_plain_integer_skill_is_named_as_not_a_skill_member():
    # Command(6) is refused (a Command names a Skill member): the error must not read as
    # if MARK=6 were refused while listing MARK=6 as allowed.
    env = soccer_drill.HolderEnv(opponent=_Team(lambda p: dict.fromkeys(p, Command(6))))
    env.reset(seed=0)
    with pytest.raises(TeamError, match=r"not its integer \(Skill\(6\) is Skill\.MARK\)"):
        env.step(0)


@pytest.mark.parametrize("make", [soccer_drill.env, soccer_drill.parallel_env])
@pytest.mark.parametrize("seed", [-1, 3.0, "3", True, [1, 2], np.array([4])])
def test_players_reset_refuses_a_seed_that_is_not_a_non_negative_integer(make, seed):
    env = make(opponent="chasers")
    env.reset(seed=5)
    before = env.state()
    with pytest.raises(ValueError, match=r"seed must be None or an integer >= 0, got "):
        env.reset(seed=seed)
    assert np.array_equal(env.state(), before)  # refused before anything changed
    env.reset(seed=np.int64(7))  # a NumPy integer is a seed like any other
    fresh = make(opponent="chasers")
    fresh.reset(seed=7)
    assert np.array_equal(env.state(), fresh.state())


def test_holder_reset_takes_a_numpy_integer_seed_as_the_other_environments_do():
    # The players' and the batched environments take NumPy integers (seeds drawn from an
    # np.arange or a Generator); Gymnasium's own check refused them here.
    env = soccer_drill.HolderEnv(opponent="chasers")
    obs, _ = env.reset(seed=np.int64(7))
    fresh, _ = soccer_drill.HolderEnv(opponent="chasers").reset(seed=7)
    np.testing.assert_array_equal(obs, fresh)
    for seed in (-1, 3.0, True, [1, 2]):
        with pytest.raises(ValueError, match=r"seed must be None or an integer >= 0, got "):
            env.reset(seed=seed)


@pytest.mark.parametrize("make", [soccer_drill.env, soccer_drill.parallel_env])
@pytest.mark.parametrize("opponent", [None, "chasers"])
def test_an_unknown_agent_is_named_with_the_environments_agents(make, opponent):
    """A per-agent call with a name that is not an agent (a defender when the defenders
    are a scripted team, a typo, an unhashable value) says so and lists the agents,
    still as a ``KeyError``, as a mapping's lookup would be."""
    env = make(opponent=opponent)
    env.reset(seed=0)
    unknown = ["attacker_9", "goalkeeper", ["attacker_0"]]
    if opponent is not None:
        unknown.append("defender_0")
    calls = [env.observation_space, env.action_space, env.action_mask]
    if hasattr(env, "observe"):
        calls.append(env.observe)
    agents = re.escape(str(list(env.possible_agents)))
    for call in calls:
        for agent in unknown:
            with pytest.raises(KeyError, match="is not an agent of this environment; "
                                               f"its agents are {agents}"):
                call(agent)


class _LookAhead(_Team):
    """A team that plays a drill of its own inside its act() (a look-ahead), against a
    team of its own that may fail there."""

    def __init__(self, inner):
        super().__init__(lambda players: dict.fromkeys(players, Command(Skill.MARK)))
        self.inner = inner

    def reset(self, view, rng):
        super().reset(view, rng)
        self.sim = soccer_drill.HolderEnv(opponent=self.inner)

    def act(self, view):
        self.sim.reset(seed=0)
        self.sim.step(0)
        return super().act(view)


def test_a_team_whose_own_inner_drill_fails_is_the_team_named():
    """The error of an environment a team runs inside its act() is the team's failure:
    named after the outer team and its call, the inner error said after it (and chained),
    not passed on as if the inner team were the environment's."""
    # No time bound on the outer team: its first call may compile the inner drill's rules.
    env = soccer_drill.HolderEnv(opponent=_LookAhead(_Team(_boom)), team_timeout=None)
    env.reset(seed=0)
    with pytest.raises(TeamError, match=r"^team '_LookAhead' raised in act\(\) at cycle 0: "
                                        r".*team '_Team' raised in act\(\) at cycle 0: KeyError"
                       ) as raised:
        env.step(0)
    assert isinstance(raised.value.__cause__, TeamError)
    with pytest.raises(TeamError, match=r"the team failed earlier \(team '_LookAhead' raised"):
        env.step(0)  # the outer environment's own refusal names its own team
    # A look-ahead whose inner team behaves plays on.
    fine = soccer_drill.HolderEnv(opponent=_LookAhead("chasers"), team_timeout=None)
    fine.reset(seed=0)
    fine.step(0)
