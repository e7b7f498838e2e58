"""DrillConfig: every number checked the same way, NumPy or not, and kept in a sane range."""

from __future__ import annotations

import json
import math
from dataclasses import fields

import numpy as np
import pytest

import soccer_drill
from soccer_drill.commands import Command, Skill
from soccer_drill.config import COLLISION_BIAS, DrillConfig, fewest_substeps
from soccer_drill.constraints import Integer, checked

NUMERIC = [f.name for f in fields(DrillConfig) if f.type in ("float", "int")]
INTEGERS = [f.name for f in fields(DrillConfig) if f.type == "int"]


def test_every_number_declares_its_limits_and_the_defaults_lie_inside():
    defaults = DrillConfig()
    for f in fields(DrillConfig):
        if f.name in NUMERIC:
            limits = f.metadata["constraint"]
            assert isinstance(limits, Integer) == (f.name in INTEGERS)
            assert checked(f.name, getattr(defaults, f.name), limits) == getattr(defaults, f.name)
        else:
            assert "constraint" not in f.metadata


@pytest.mark.parametrize("name", NUMERIC)
@pytest.mark.parametrize(
    "bad",
    [np.float32("nan"), np.float64("inf"), -np.inf, math.nan, True, np.bool_(True), "1", None,
     np.array([1.0])],
    ids=repr,
)
def test_non_finite_and_non_numbers_are_refused_naming_the_field_and_range(name, bad):
    kind = "an integer" if name in INTEGERS else "a finite number"
    with pytest.raises(ValueError, match=rf"^DrillConfig\.{name} must be {kind} in [\[(]\S+, \S+\], got "):
        DrillConfig(**{name: bad})


@pytest.mark.parametrize(
    ("name", "value", "message"),
    [
        # Absurd values that used to be accepted, and then hung or broke the drill.
        ("cycle_seconds", 1e-9, r"cycle_seconds must be a finite number in \[0.001, 1\], got 1e-09"),
        ("substeps", 10**9, r"substeps must be an integer in \[1, 1,000\], got 1000000000"),
        ("field_size", 1e300, r"field_size must be a finite number in \[10, 1000\], got 1e\+300"),
        ("attacker_speed", 1e200, r"attacker_speed must be a finite number in \(0, 100\]"),
        ("ball_max_speed", 1e308, r"ball_max_speed must be a finite number in \(0, 1000\]"),
        ("kick_angle_noise", 1e9, r"kick_angle_noise must be a finite number in \[0, 180\]"),
        ("reward_failure", -1e300, r"reward_failure must be a finite number in \[-1000, 1000\]"),
        ("max_cycles", 10**12, r"max_cycles must be an integer in \[1, 1,000,000\]"),
        ("field_size", 10**400, r"field_size must be a finite number in \[10, 1000\], got 1000"),
        ("defender_speed", 0.0, r"defender_speed must be a finite number in \(0, 100\], got 0.0"),
    ],
)
def test_absurd_values_are_refused_up_front_with_the_allowed_range(name, value, message):
    with pytest.raises(ValueError, match=message):
        DrillConfig(**{name: value})


def test_numpy_numbers_are_accepted_and_stored_as_python_numbers():
    config = DrillConfig(
        max_cycles=np.int64(50), substeps=np.uint8(8), pass_lockout_cycles=np.int32(3),
        attacker_speed=np.float32(5.5), tackle_probability=np.float64(0.25), field_size=40,
        attacker_starts=np.array([[4.0, 31.0], [31.0, 31.0]]),
    )
    assert config == DrillConfig(
        max_cycles=50, substeps=8, pass_lockout_cycles=3, attacker_speed=5.5,
        tackle_probability=0.25, field_size=40.0,
    )
    for f in fields(DrillConfig):
        value = getattr(config, f.name)
        if f.name in NUMERIC:
            assert type(value) is (int if f.name in INTEGERS else float), f.name
    assert config.attacker_starts == ((4.0, 31.0), (31.0, 31.0))
    assert all(type(c) is float for p in config.attacker_starts for c in p)
    assert DrillConfig.from_dict(json.loads(json.dumps(config.to_dict()))) == config
    env = soccer_drill.HolderEnv(opponent="chasers", config=config)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)


@pytest.mark.parametrize(
    "starts",
    [((1.0, 1.0), (math.nan, 1.0)), ((1.0, 1.0), (np.float32("inf"), 1.0)),
     ((1.0, 1.0), (True, 1.0)), ((1.0, 1.0),), ((1.0, 1.0), (1.0, 1.0, 1.0)), 5.0, "ab"],
    ids=repr,
)
def test_start_points_must_be_two_finite_points_inside_the_field(starts):
    with pytest.raises(ValueError, match=r"attacker_starts must be a list of 2 values, each a "
                                         r"list of 2 values, each a finite number in \[0, 35\], "
                                         r"got .* \(two \(x, y\) points inside the field, one per "
                                         r"attacker\)"):
        DrillConfig(attacker_starts=starts)


def test_default_starts_that_do_not_fit_the_field_say_they_were_not_given():
    """Two players of a side keep the paper's points in a field of any size: a smaller
    field that leaves them outside says the starts were the defaults, and what to give;
    starts that were given get no such note."""
    with pytest.raises(ValueError, match=r"field_size 20 is too small for the drill's "
                                         r"default starts \(attacker_starts and "
                                         r"defender_starts not given\).* give a larger "
                                         r"field_size, or attacker_starts and defender_starts "
                                         r"that fit\. The check said: DrillConfig\."
                                         r"attacker_starts must be .* in \[0, 20\]"):
        DrillConfig(field_size=20)
    with pytest.raises(ValueError) as given:
        DrillConfig(field_size=20, attacker_starts=((4.0, 31.0), (5.0, 5.0)),
                    defender_starts=((5.0, 9.0), (10.0, 9.0)))
    assert "not given" not in str(given.value)
    config = DrillConfig(field_size=20, attacker_starts=((4.0, 16.0), (16.0, 16.0)),
                         defender_starts=((7.0, 5.0), (13.0, 5.0)))
    assert config.attacker_starts == ((4.0, 16.0), (16.0, 16.0))


@pytest.mark.parametrize("starts", [((5.0, 5.0), (10.0, 10.0)),  # two for three keepers
                                    ((25.0, 5.0), (10.0, 10.0), (5.0, 5.0))])  # one outside
def test_starts_given_wrong_beside_default_ones_are_named_not_the_field(starts):
    """Before, the error opened with the field being too small for the default starts
    of the other side, and named the starts given only at its end."""
    with pytest.raises(ValueError) as refused:
        DrillConfig(task="keepaway", attackers=3, defenders=2, field_size=20,
                    attacker_starts=starts)
    said = str(refused.value)
    assert said.startswith("DrillConfig.attacker_starts must be a list of 3 values")
    assert "too small" not in said and "default starts" not in said


@pytest.mark.parametrize(("values", "message"), [
    ({"start_jitter": 10.0}, r"start_jitter 10 can put the player starting at \(4, 31\) "
                             r"\(attacker_starts\) outside the walls"),
    ({"start_jitter": 0.0, "attacker_starts": ((17.5, 0.5), (17.0, 20.0))},  # ball at y < 0
     r"can put the ball of the attacker starting at \(17.5, 0.5\).*on the goal line"),
    ({"start_jitter": 0.3, "attacker_starts": ((34.9, 17.0), (30.0, 20.0))},
     r"can put the ball of the attacker starting at \(34.9, 17\).*outside the field"),
])
def test_a_start_that_is_out_of_play_before_the_first_cycle_is_refused(values, message):
    with pytest.raises(ValueError, match=message):
        DrillConfig(**values)


def test_a_start_near_the_field_s_edge_within_the_walls_is_taken():
    config = DrillConfig(defender_starts=((1.0, 2.0), (34.0, 2.0)))  # jitter 1.5: x >= -0.5
    assert config.defender_starts == ((1.0, 2.0), (34.0, 2.0))


class _RunRight:
    """A team whose defenders run to (900, 17.5), far beyond the field's right wall."""

    def reset(self, view, rng):
        self.players = view.players

    def act(self, view):
        return dict.fromkeys(self.players, Command(Skill.MOVE_TO, (900.0, 17.5)))


@pytest.mark.parametrize("speed, substeps", [(25, 1), (25, 3), (100, 1), (100, 10)])
def test_sub_steps_through_which_a_player_could_pass_a_wall_are_refused(speed, substeps):
    config = {"defender_speed": speed, "substeps": substeps}
    # Allowed before, and the defenders ran out through the wall to x = 900.
    need = fewest_substeps(speed, 0.1, 0.5)
    with pytest.raises(ValueError, match=(
            rf"^DrillConfig: with {substeps} physics sub-step\(s\) per cycle of 0.1 s, a player at "
            rf"its top speed of {speed} m/s \(defender_speed\) moves {speed * 0.1 / substeps:.3g} "
            r"m in a sub-step, and can pass through a wall or a player: with player_radius 0.5, "
            rf"at most 0.105 m is allowed; make substeps at least {need}, or every speed at "
            "most ")):
        soccer_drill.HolderEnv(opponent=_RunRight(), config=config)
    # What the message advises keeps every player inside the walls.
    env = soccer_drill.HolderEnv(opponent=_RunRight(), config={**config, "substeps": need})
    env.reset(seed=0)
    done, wall = False, 35.0 + 1.0  # field_size + wall_margin
    while not done:
        _, _, term, trunc, _ = env.step(0)  # HOLD: the episode runs to its timeout
        assert all(-1.0 < c < wall for p in env.drill_state.pos[:4] for c in p)
        done = term or trunc
    assert max(p[0] for p in env.drill_state.pos[2:4]) > wall - 1.0  # they reached the wall


def test_players_thinner_than_pymunks_slop_are_refused():
    # Two such players pass through each other at any speed.
    with pytest.raises(ValueError, match=r"^DrillConfig: player_radius 0.05 is at most half of "
                                         r"pymunk's collision slop \(0.1 m, the overlap it "
                                         r"leaves alone\), so two players pass through each "
                                         r"other at any speed; make player_radius larger than "
                                         r"0.05$"):
        DrillConfig(player_radius=0.05)


def test_the_step_bound_leaves_the_default_drill_room():
    # pymunk's default collision bias, which the drill's spaces keep.
    assert COLLISION_BIAS == pytest.approx(0.9**60, rel=1e-5)
    # The defaults' fastest player (6 m/s) needs 6 of their 10 sub-steps.
    assert fewest_substeps(DrillConfig().attacker_speed, 0.1, 0.5) == 6


@pytest.mark.parametrize("config, speed", [
    ({"control_speed": 1000.0}, 31),  # capped by the ball's 25 m/s and a player's 6 m/s
    ({"control_speed": 25.0, "cycle_seconds": 0.1}, 25),
    ({"control_speed": 5.0, "cycle_seconds": 1.0, "substeps": 1000}, 5),
])
def test_a_ball_that_could_be_controlled_cannot_pass_a_player_between_two_cycles(config,
                                                                                   speed):
    cycle = config.get("cycle_seconds", 0.1)
    with pytest.raises(ValueError, match=(
            rf"^DrillConfig: a ball that a player can control moves up to {speed} m/s relative "
            rf"to it .*, {speed * cycle:.3g} m in a cycle of {cycle:g} s: more than the "
            r"control area's width of 2 m \(2 \* control_radius\), so it can pass through a "
            r"player who would control it; make control_speed \(or ball_max_speed plus the "
            rf"fastest player's speed\) at most {2 / cycle:.3g} m/s")):
        soccer_drill.HolderEnv(config=config)
    # At the bound, and where the ball can never be that fast relative to a player.
    DrillConfig(**{**config, "control_speed": 2 / cycle})
    if 2 / cycle > 6.0:  # the fastest player: 6 m/s
        DrillConfig(**{**config, "ball_max_speed": 2 / cycle - 6.0})


@pytest.mark.parametrize("along", np.linspace(0.0, 2.0, 9))
def test_at_the_bound_a_defender_on_the_line_of_a_pass_takes_the_ball(along):
    """A pass at control_speed (20 m/s, 2 m a cycle: the control area's width) is within
    control_radius of a defender standing on its line at the end of some cycle, wherever
    he stands. (At 1000 m/s, allowed before, a 25 m/s pass went through a defender
    standing on its line, never closer than 1.01 m at the end of a cycle.)"""
    from one_drill import OneDrill as Drill

    ball = (4.0, 30.25)  # below the first attacker, who passes to the second at (31, 31)
    t = (13.5 + along) / math.dist(ball, (31.0, 31.0))
    on_line = (ball[0] + t * 27.0, ball[1] + t * 0.75)
    cfg = DrillConfig(kick_angle_noise=0.0, kick_speed_noise=0.0, start_jitter=0.0,
                      ball_damping=1.0, pass_arrival_speed=20.0, control_speed=20.0,
                      defender_starts=(on_line, (20.0, 5.0)))
    drill, rng = Drill(cfg), np.random.default_rng(0)
    while drill.reset(rng).holder != 0:
        pass
    stay = [Command(Skill.MOVE_TO, p) for p in drill.state.pos[:4]]
    drill.step([Command(Skill.PASS), *stay[1:]], rng)
    while drill.outcome is None:
        drill.step(stay, rng)
    assert drill.outcome == "interception" and drill.state.holder == 2
