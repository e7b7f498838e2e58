"""The teams that are settings of another team's class (the paper's teams, ``contain_cover``,
the region compositions) take that class's parameters by name: an unknown name or a
malformed region is refused before the team is built, with a ``ValueError`` saying what
they take, as for ``parametric`` itself."""

from __future__ import annotations

import inspect

import pytest

import soccer_drill
from opponents import PAPER_TEAMS
from opponents.paper import GoalGuards
from opponents.parametric import ParametricTeam
from opponents.regions import Region, RegionRule, RegionTeam

PRESETS = (*PAPER_TEAMS, "contain_cover", "press_far_contain_near", "press_far_contain_near_9",
           "contain_left_press_right")


@pytest.mark.parametrize("team_id", PRESETS)
def test_an_unknown_parameter_is_refused_with_the_names_the_team_takes(team_id):
    with pytest.raises(ValueError, match=rf"bad parameters \{{'bogus': 1\}} for team '{team_id}': "
                                         r"got an unexpected keyword argument 'bogus'; it takes \("):
        soccer_drill.make_team(team_id, bogus=1)


def test_a_preset_declares_its_class_parameters_with_its_own_defaults():
    taken = inspect.signature(GoalGuards).parameters
    assert list(taken) == list(inspect.signature(ParametricTeam).parameters)
    assert taken["roles"].default == ("guard", "guard")
    assert taken["press_probability"].default == GoalGuards.DEFAULTS["press_probability"]
    team = soccer_drill.make_team("goal_guards", press_probability=0.05)  # still a variant
    assert team.params()["press_probability"] == 0.05
    assert team.params()["roles"] == ["guard", "guard"]


@pytest.mark.parametrize("region", [
    {"feature": "dist_goal"},
    {"feature": "dist_goal", "threshold": 1.0, "extra": 1},
    ["dist_goal", 3.0],
    None,
])
def test_a_malformed_region_is_a_refused_value_naming_its_fields(region):
    said = r"region must be a Region or a mapping with exactly the keys 'feature' and 'threshold', got "
    with pytest.raises(ValueError, match=said):
        soccer_drill.make_team("press_far_contain_near", region=region)
    with pytest.raises(ValueError, match=said):
        RegionTeam("interceptors_press", "goal_guards", region)
    with pytest.raises(ValueError, match=said):
        RegionRule("late_pass", "early_pass", region)


def test_a_region_given_as_its_fields_is_the_region():
    team = soccer_drill.make_team("press_far_contain_near",
                                  region={"feature": "lateral", "threshold": 0.0})
    assert team.region == Region("lateral", 0.0)
