"""Region teams and rules: the switch at the boundary, seeding, the batched drill, the targets."""

from __future__ import annotations

import re
import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import soccer_drill
from ilpss.experiments import region_check
from ilpss.experiments.region_check import CANDIDATES, t_interval
from opponents.region_stream import (
    LEFT,
    NEAR,
    SHARP_SOURCES,
    SHARP_TARGETS,
    SOURCES,
    TARGETS,
)
from opponents.regions import Region, RegionRule, RegionTeam, composition
from soccer_drill import teams
from soccer_drill.commands import Skill
from soccer_drill.config import DrillConfig
from soccer_drill.drill.drills import BatchDrill
from soccer_drill.envs.core import observation
from soccer_drill.envs.holder import HolderEnv
from soccer_drill.policies import HOLDER_POLICIES
from soccer_drill.skills import state_record
from soccer_drill.state import DrillState
from soccer_drill.teams.kit import BatchRandom, BatchView
from soccer_drill.vector import HolderVectorEnv, play_episodes

DEFENDERS = ("defender_0", "defender_1")
GUARDS = {"roles": ["guard", "guard"]}  # no sorties: MOVE_TO their spots on the line
ONE = np.zeros(1, dtype=np.int64)


def _view(holder_xy, ball_xy, holder=0):
    """A drill standing still: attacker ``holder`` at ``holder_xy``."""
    pos = [(5.0, 30.0), (30.0, 30.0), (13.0, 9.0), (22.0, 9.0), ball_xy]
    if holder >= 0:
        pos[holder] = holder_xy
    return DrillState(tuple(pos), ((0.0, 0.0),) * 5, holder, 0)


class _One:
    """A team's batched form in one drill, put in given states."""

    def __init__(self, team, state, seed=0):
        self.batched = team.batch(1)
        self.drill = BatchDrill(1, DrillConfig())
        self.view = BatchView(self.drill, DEFENDERS)
        rng = BatchRandom(1)
        rng.seed(ONE, [seed])
        self.drill.set_state(0, state)
        self.batched.reset(self.view, ONE, rng)

    def act(self, state):
        self.drill.set_state(0, state)
        return self.batched.act(self.view, ONE)

    def below(self, state):
        self.drill.set_state(0, state)
        return bool(self.batched.below(self.view, ONE)[0])


def _skills(team, state):
    return tuple(Skill(int(s)) for s in team.act(state).skill[0])


# ------------------------------------------------------------------ the region test
def test_region_refuses_what_it_cannot_test_and_says_what_is_allowed():
    with pytest.raises(ValueError, match=r"feature must be 'dist_goal' or 'lateral'"):
        Region("pass_angle", 10.0)
    with pytest.raises(ValueError, match=r"threshold for 'dist_goal' must be a finite number in \[0, 36\]"):
        Region("dist_goal", 40.0)
    with pytest.raises(ValueError, match=r"in \[-18.5, 18.5\], got True"):
        Region("lateral", True)
    with pytest.raises(ValueError, match="got nan"):
        Region("lateral", float("nan"))
    with pytest.raises(ValueError, match="unknown holder rule 'passy'"):
        RegionRule("passy", "lane", NEAR)


def test_the_region_is_the_observed_feature_rounded_to_float32():
    assert (NEAR.index, LEFT.index) == (5, 6)
    assert NEAR.below(12.0) and not NEAR.below(12.000002)
    assert NEAR.below(12.0000001)  # rounds to 12.0 in float32, as the observation does
    obs = np.zeros(9, dtype=np.float32)
    obs[5], obs[6] = 12.0, 0.5
    assert NEAR.observed_below(obs) and not LEFT.observed_below(obs)
    # The holder's feature at a state is exactly the team's test there.
    features = observation("features", DrillConfig())
    for y in (11.9999999, 12.0, 12.0000001, 12.00001):
        state = _view((20.0, y), (20.0, y - 0.75))
        team = _One(RegionTeam("chasers", "parametric", NEAR, below_params=GUARDS), state)
        obs = features(state_record(state), ONE, ONE)[0]
        assert team.below(state) == NEAR.observed_below(obs)


# ------------------------------------------------------------------ the team switches
def test_the_team_plays_the_behaviour_of_the_carriers_region():
    team = _One(RegionTeam("chasers", "parametric", NEAR, below_params=GUARDS),
                _view((20.0, 20.0), (20.0, 19.25)))
    intercept, move = (Skill.INTERCEPT,) * 2, (Skill.MOVE_TO,) * 2
    assert _skills(team, _view((20.0, 12.01), (20.0, 11.26))) == intercept  # above
    assert _skills(team, _view((20.0, 12.0), (20.0, 11.25))) == move  # at the threshold: below
    # Held, the ball's carrier decides (its ball is already below); loose, the ball.
    assert _skills(team, _view((20.0, 12.5), (20.0, 11.75))) == intercept
    assert _skills(team, _view(None, (20.0, 11.9), holder=-1)) == move
    assert _skills(team, _view(None, (20.0, 12.1), holder=-1)) == intercept
    # The commands below are those of the guards themselves, reset with the same state.
    state = _view((9.0, 6.0), (9.0, 5.25), holder=1)
    guards = _One(soccer_drill.make_team("parametric", **GUARDS), state, seed=1)
    for mine, theirs in zip(team.act(state), guards.act(state), strict=True):
        np.testing.assert_array_equal(mine, theirs)


def test_the_team_decides_each_drills_region_at_its_carrier():
    cases = [((20.0, 12.01), (20.0, 11.26), 0), ((20.0, 12.0), (20.0, 11.25), 1),
             ((20.0, 12.5), (20.0, 11.75), 0), (None, (20.0, 11.9), -1),
             (None, (20.0, 12.1), -1), ((17.5, 11.0), (17.6, 12.5), 1)]
    states = [_view(*case) for case in cases]
    batch = SimpleNamespace(
        n=len(states), config=DrillConfig(),
        pos=np.array([s.pos for s in states]), holder=np.array([s.holder for s in states]))
    carriers = [s.pos[s.holder if s.holder >= 0 else 4] for s in states]
    expected = {NEAR: [np.float32(y) <= np.float32(12.0) for _, y in carriers],
                LEFT: [np.float32(x - 17.5) <= np.float32(0.0) for x, _ in carriers]}
    assert expected[NEAR] == [False, True, False, True, False, True]
    for region in (NEAR, LEFT):
        team = RegionTeam("chasers", "parametric", region, below_params=GUARDS)
        batched = team.batch(len(states)).below(BatchView(batch, DEFENDERS), np.arange(len(states)))
        assert batched.tolist() == expected[region]
        assert [_One(team, s).below(s) for s in states] == expected[region]


def test_the_lateral_region_splits_left_from_right():
    team = _One(RegionTeam("chasers", "parametric", LEFT, below_params=GUARDS),
                _view((20.0, 20.0), (20.0, 19.25)))
    assert _skills(team, _view((17.5, 20.0), (17.6, 19.25))) == (Skill.MOVE_TO,) * 2
    assert _skills(team, _view((17.6, 20.0), (17.4, 19.25))) == (Skill.INTERCEPT,) * 2


def test_each_team_gets_its_own_stream_derived_from_the_one_given():
    def sorties(seed):
        state = _view((20.0, 30.0), (20.0, 29.25))
        team = _One(RegionTeam("goal_guards", "goal_guards", NEAR), state, seed=seed)
        for _ in range(200):
            team.act(state)
        return tuple(int(t.memory["sorties"][0]) for t in team.batched.teams)

    counts = [sorties(seed) for seed in range(6)]
    assert counts == [sorties(seed) for seed in range(6)]  # reproducible
    assert len(set(counts)) > 1  # another seed, other draws
    # The two teams see the same view; with one stream they would sortie alike.
    assert any(a != b for a, b in counts)


def test_the_same_seed_gives_the_same_episode_also_after_others():
    def episode(env, seed):
        obs, _ = env.reset(seed=seed)
        trace, done = [obs], False
        while not done:
            obs, reward, term, trunc, _ = env.step(HOLDER_POLICIES["late_pass"](obs, None))
            trace += [obs, reward]
            done = term or trunc
        return trace

    used = HolderEnv(opponent="press_far_contain_near")
    for seed in (5, 6):
        episode(used, seed)
    fresh = episode(HolderEnv(opponent="press_far_contain_near"), 3)
    again = episode(used, 3)
    assert len(fresh) == len(again)
    for x, y in zip(fresh, again, strict=True):
        np.testing.assert_array_equal(x, y)


# ------------------------------------------------------------------ the batched drill
def test_the_team_is_one_batched_team_whatever_the_number_of_drills():
    params = {"above": "goal_guards", "below": "contain_cover", "region": LEFT}
    rule = RegionRule("early_pass", "lane", LEFT)
    batched = play_episodes(HolderVectorEnv(num_envs=6, opponent=RegionTeam(**params),
                                            drills_per_space=1), rule, range(6))
    singles = []
    for seed in range(6):
        env, total = HolderEnv(opponent=RegionTeam(**params)), 0.0
        obs, _ = env.reset(seed=seed)
        rng, done = np.random.default_rng(seed), False
        while not done:
            obs, reward, term, trunc, info = env.step(rule(obs, rng))
            total, done = total + reward, term or trunc
        singles.append((total, info["outcome"]))
    assert len(batched) == len(singles) == 6
    assert sum(b == s for b, s in zip(batched, singles, strict=True)) >= 4  # up to contacts


@pytest.mark.parametrize("target", TARGETS)
def test_the_batched_drill_plays_the_single_environments_episodes_step_by_step(target):
    """One drill: every observation, reward and info equals the single environment's."""
    rule = RegionRule("late_pass", "lane", soccer_drill.make_team(target).region)
    venv, env = HolderVectorEnv(num_envs=1, opponent=target), HolderEnv(opponent=target)
    for seed in (2, 9):
        obs, _ = venv.reset(seed=seed)
        single, _ = env.reset(seed=seed)
        np.testing.assert_array_equal(obs[0], single)
        done = False
        while not done:
            action = rule(single, None)
            obs, reward, term, trunc, info = venv.step(np.array([action]))
            single, r, t, tr, i = env.step(action)
            np.testing.assert_array_equal(obs[0], single)
            assert (reward[0], term[0], trunc[0]) == (r, t, tr)
            assert {k: info[k][0] for k in i} == i
            done = t or tr
        venv.step(np.array([0]))  # NEXT_STEP autoreset


def test_a_team_without_a_batched_form_cannot_be_composed():
    class Plain:
        def reset(self, view, rng):
            pass

        def act(self, view):
            return dict.fromkeys(view.players, soccer_drill.Command(Skill.INTERCEPT))

    soccer_drill.register("plain_for_regions", Plain, overwrite=True)
    with pytest.raises(soccer_drill.TeamError, match=r"RegionTeam composes teams with a batched form "
                                              r"\(batch\(n\)\); team 'plain_for_regions' has "
                                              r"none"):
        RegionTeam("plain_for_regions", "contain_cover", NEAR)


# ------------------------------------------------------------------ the registered teams
def test_the_stream_teams_are_installed_and_are_what_the_pre_check_judges():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        teams.refresh()
        listed = soccer_drill.available_teams()
        assert teams.broken_teams() == {}
    assert set(SOURCES) | set(TARGETS) <= set(listed)
    for c in CANDIDATES:
        assert c.team().region == c.region  # a registered id is checked to be its composition
    assert {c.label for c in CANDIDATES if c.registered} == set(TARGETS) | set(SHARP_TARGETS)
    assert set(SHARP_SOURCES) | set(SHARP_TARGETS) <= set(listed)
    press_far = soccer_drill.make_team("press_far_contain_near")
    assert (press_far.above_id, press_far.below_id, press_far.region) == (
        "interceptors_press", "contain_cover", NEAR)
    assert soccer_drill.make_team("press_far_contain_near", region={"feature": "dist_goal",
                                                             "threshold": 9.0}).region.threshold == 9
    with pytest.raises(ValueError, match=r"RegionTeam above \(a team id\) must be a non-empty "
                                         r"identifier"):
        RegionTeam(soccer_drill.make_team("chasers"), "chasers", NEAR)


def test_the_sources_best_rules_differ_as_the_pre_check_says():
    def mean(team, rule, n=48):
        venv = HolderVectorEnv(num_envs=16, opponent=team)
        return np.mean([r for r, _ in play_episodes(venv, HOLDER_POLICIES[rule], range(n))])

    assert mean("interceptors_press", "late_pass") > mean("interceptors_press", "lane") + 0.5
    assert mean("contain_cover", "lane") > mean("contain_cover", "late_pass") + 0.5


@pytest.mark.slow
def test_the_composed_rule_beats_every_single_rule_on_a_target():
    """A short version of the pre-check on ``press_far_contain_near``: ``late_pass`` far,
    ``lane`` near beats the best of the nine single rules, paired by seed."""
    episodes = 80
    singles = {r: region_check.play("t", "press_far_contain_near", r, episodes)
               for r in HOLDER_POLICIES}
    best = max(singles, key=lambda r: singles[r].rewards.mean())
    composed = region_check.play("t", "press_far_contain_near",
                                 RegionRule("late_pass", "lane", NEAR), episodes, NEAR)
    mean, low, _ = t_interval(composed.rewards - singles[best].rewards)
    assert low > 0.0, (best, mean, low)
    assert (composed.below > 0).mean() > 0.5  # most episodes reach the second region


def test_the_pre_check_page_names_its_command_and_judges_each_candidate(tmp_path, monkeypatch):
    monkeypatch.setattr(region_check, "CHECK_SOURCES", SOURCES)
    monkeypatch.setattr(region_check, "CANDIDATES", CANDIDATES[3:4])
    out = tmp_path / "regions.md"
    assert region_check.main(["--episodes", "4", "--workers", "1", "--out", str(out)]) == 0
    text = out.read_text()
    assert f"python -m ilpss.experiments.region_check --episodes 4 --out {out}" in text
    assert "### `contain_left_press_right`" in text and "`obs[6] <= 0`" in text
    assert re.search(r"`\w+\\\|lane`", text)  # the composed rule, its "|" escaped in tables
    assert "the others are the same episodes: checked" in text
    assert re.search(r"\| `\w+\\\|lane once` \|", text)  # one rule per episode, by its start
    with pytest.raises(SystemExit):
        region_check.main(["--episodes", "1"])


@pytest.mark.parametrize("out, said", [
    ("file/regions.md", "'{tmp}/file' is a file, not a folder"),
    ("folder/", "the output must name a file, got the folder '{tmp}/folder/'"),
])
def test_the_pre_check_checks_its_output_before_any_episode(tmp_path, monkeypatch, capsys, out,
                                                            said):
    monkeypatch.setattr(region_check, "judge", lambda *a, **k: pytest.fail("it played"))
    (tmp_path / "file").write_text("")
    with pytest.raises(SystemExit) as exit_:
        region_check.main(["--out", f"{tmp_path}/{out}"])
    assert exit_.value.code == 2
    assert said.format(tmp=tmp_path) in capsys.readouterr().err


def test_the_plugin_pages_region_example_runs():
    page = (Path(__file__).resolve().parents[1] / "docs" / "plugins.md").read_text()
    (block,) = [b for b in re.findall(r"```python\n(.*?)```", page, flags=re.S)
                if "RegionTeam(" in b]
    namespace = {"soccer_drill": soccer_drill}
    exec(block, namespace)
    obs, _ = namespace["env"].reset(seed=0)
    assert namespace["rule"](obs, None) in (0, 1, 2)
    assert namespace["team"].region == NEAR


def test_the_sharp_tests_names_are_the_same_on_both_sides():
    """``ilpss`` names the drill's teams without importing them: its copies must agree."""
    from ilpss.experiments import drill_facts

    assert drill_facts.SHARP_SOURCES == SHARP_SOURCES and drill_facts.SHARP_TARGETS == SHARP_TARGETS
    splits = {(c[0], c[1]) for c in map(composition, SHARP_TARGETS)}
    assert splits <= set(drill_facts.REGION_SPLITS) | set(drill_facts.SHARP_SPLITS)
