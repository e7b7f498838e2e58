"""Each scripted team does what its docstring claims (fixed seeds), and the family samples."""

from __future__ import annotations

import math

import numpy as np
import pytest

import soccer_drill
from ilpss.experiments.calibrate import (
    Cell,
    calibrate,
    calibrate_family,
    criteria,
    wilson_interval,
    write_markdown,
    write_team_gif,
)
from ilpss.experiments.calibrate import main as calibrate_main
from opponents import PAPER_TEAMS, ParametricTeam, sample_opponents
from opponents.cli import main as list_teams
from soccer_drill import make_team
from soccer_drill.commands import Skill
from soccer_drill.envs.holder import HolderEnv
from soccer_drill.policies import HOLDER_POLICIES
from soccer_drill.skills import ball_interception_point
from soccer_drill.state import BALL
from soccer_drill.teams import BatchRandom


def _cycles(team: str, action: int, episodes: int = 8, **params):
    """Drill states after every decision of a fixed holder action."""
    env = HolderEnv(opponent=team, opponent_params=params or None)
    states = []
    for seed in range(episodes):
        env.reset(seed=seed)
        states.append(env.drill_state)
        done = False
        while not done:
            _, _, term, trunc, _ = env.step(action)
            states.append(env.drill_state)
            done = term or trunc
    return states


def test_goal_guards_stay_near_the_line():
    states = _cycles("goal_guards", action=0)  # HOLD far up the field
    near = [s.pos[d][1] < 8.0 for s in states[1:] for d in (2, 3)]
    assert np.mean(near) > 0.75  # sorties (2% per cycle, 10 cycles each) take the rest


def test_interceptors_close_on_the_ball():
    env = HolderEnv(opponent="interceptors_press")
    closer = 0
    for seed in range(10):
        env.reset(seed=seed)
        before = [env.drill_state.distance(d, BALL) for d in (2, 3)]
        for _ in range(5):  # 20 cycles of HOLD: the holder backs away at 1.5 m/s
            env.step(0)
        after = [env.drill_state.distance(d, BALL) for d in (2, 3)]
        closer += all(a < b - 3.0 for a, b in zip(after, before, strict=True))
    assert closer >= 9


def test_interceptor_guard_splits_the_roles():
    states = _cycles("interceptor_guard", action=0)
    guard_near_line = np.mean([s.pos[3][1] < 6.0 for s in states[1:]])
    interceptor_near_line = np.mean([s.pos[2][1] < 6.0 for s in states[1:]])
    assert guard_near_line > 0.8 and interceptor_near_line < 0.3


def test_the_two_interceptor_teams_differ():
    def farther_defender_distance(team):
        return np.mean([max(s.distance(2, BALL), s.distance(3, BALL))
                        for s in _cycles(team, action=0)[1:]])

    press, cover = farther_defender_distance("interceptors_press"), farther_defender_distance(
        "interceptors_cover")
    assert cover > press + 2.0  # in "cover" one defender stays in the passing lane


def test_sampler_gives_distinct_reproducible_runnable_opponents():
    a, b = sample_opponents(25, seed=3), sample_opponents(25, seed=3)
    assert a == b and len({repr(sorted(p.items())) for p in a}) == 25
    assert a != sample_opponents(25, seed=4)
    compositions = {tuple(p["roles"]) for p in a}
    assert len(compositions) == 3
    for params in a[:5]:
        env = HolderEnv(opponent="parametric", opponent_params=params)
        env.reset(seed=0)
        _, reward, *_ = env.step(2)
        assert math.isfinite(reward)
    with pytest.raises(ValueError, match="n must be an integer >= 0"):
        sample_opponents(-1, seed=0)


def test_cli_lists_every_team(capsys):
    assert list_teams([]) == 0
    out = capsys.readouterr().out
    for team in (*PAPER_TEAMS, "chasers", "parametric", "keepaway_takers"):
        assert team in out
    assert list_teams(["--task", "keepaway"]) == 0
    assert capsys.readouterr().out.split()[0] == "keepaway_takers"
    with pytest.raises(SystemExit) as refused:
        list_teams(["--task", "kept"])
    assert refused.value.code == 2
    assert "task must be 'drill' or 'keepaway', got 'kept'" in capsys.readouterr().err


def test_every_tasks_teams_are_listed_and_named_when_an_id_is_unknown():
    """Keepaway's takers are teams like the drill's: listed by ``available_teams`` (every
    task's, or one task's), and named by the error for an unknown id, as any
    environment takes them."""
    every = soccer_drill.available_teams()
    assert {"keepaway_takers", "goal_guards"} <= set(every)
    assert list(soccer_drill.available_teams("keepaway")) == ["keepaway_takers"]
    assert "keepaway_takers" not in soccer_drill.available_teams("drill")
    with pytest.raises(ValueError, match=r"task must be 'drill' or 'keepaway', got 'kept'"):
        soccer_drill.available_teams("kept")
    with pytest.raises(ValueError, match=r"unknown team 'keepaway_taker'.*goal_guards.*"
                                         r"'keepaway': \['keepaway_takers'\]"):
        soccer_drill.HolderEnv(config={"task": "keepaway"}, opponent="keepaway_taker")



# ------------------------------------------------------------------ calibration
def test_calibration_table_and_criteria(tmp_path):
    cells = calibrate(episodes=3, teams=PAPER_TEAMS, workers=1)
    lines = criteria(cells)
    assert len(lines) == 3 and all(("met" in line) for line in lines)
    path = write_markdown(cells, 3, tmp_path / "opponents.md", gifs={})
    text = path.read_text()
    full_rows = [r for r in text.splitlines() if r.startswith("| interceptors_press | ")
                 and "[" in r]
    assert len(full_rows) == len(HOLDER_POLICIES)  # a row per fixed rule in the full table
    assert "## Criteria" in text and "## Success rates" in text


def _cell(team, rule, successes, reward, n=100):
    return Cell(team, rule, successes, n, reward, reward - 0.1, reward + 0.1)


def test_criteria_verdicts_follow_the_figures():
    def cells(random_wins, best_wins, same_ranking):
        out = {}
        for k, team in enumerate(PAPER_TEAMS):
            order = ("a", "b") if same_ranking or k % 2 else ("b", "a")
            out[(team, "random")] = _cell(team, "random", random_wins, -0.9)
            out[(team, order[0])] = _cell(team, order[0], best_wins, 0.2)
            out[(team, order[1])] = _cell(team, order[1], 10, -0.5)
        return out

    good = criteria(cells(random_wins=5, best_wins=60, same_ranking=False))
    assert all("**met**" in line for line in good)
    bad = criteria(cells(random_wins=30, best_wins=20, same_ranking=True))
    assert all("**NOT met**" in line for line in bad)


def test_wilson_interval_matches_scipy():
    from scipy import stats

    for k, n in ((0, 10), (3, 10), (250, 500), (500, 500)):
        ci = stats.binomtest(k, n).proportion_ci(method="wilson")
        assert wilson_interval(k, n) == pytest.approx((ci.low, ci.high), abs=1e-12)


def test_calibration_command_writes_the_page(tmp_path, capsys):
    out = tmp_path / "calibration"
    assert calibrate_main(["--episodes", "2", "--workers", "1", "--out", str(out),
                           "--no-gifs", "--sampled", "2", "--sampled-episodes", "2"]) == 0
    text = (out / "opponents.md").read_text()
    assert "soccer-drill-calibrate --episodes 2 --sampled 2" in text
    assert "## The parametric family" in text and "| p01 (" in text
    assert "met" in capsys.readouterr().out


def test_family_cells_are_labelled_and_paired():
    cells, members = calibrate_family(2, seed=0, episodes=2, workers=1, rules=["dribble"])
    assert set(members) == {"p00", "p01"}
    assert set(cells) == {("p00", "dribble"), ("p01", "dribble")}
    assert members["p00"] == sample_opponents(2, seed=0)[0]


def test_team_gif_is_small(tmp_path):
    seed, outcome = write_team_gif("interceptors_cover", "shield_pass", tmp_path / "t.gif")
    assert outcome == "success" and seed >= 1
    assert 0 < (tmp_path / "t.gif").stat().st_size < 1_500_000


# ------------------------------------------------------------- the family itself
def _trajectory(opponent, params=None, seed=0, action=2):
    env = HolderEnv(opponent=opponent, opponent_params=params)
    env.reset(seed=seed)
    states, done = [], False
    while not done:
        _, _, term, trunc, _ = env.step(action)
        states.append(env.drill_state.pos)
        done = term or trunc
    return states


@pytest.mark.parametrize("team", PAPER_TEAMS)
def test_paper_teams_are_settings_of_the_family(team):
    instance = make_team(team)
    assert isinstance(instance, ParametricTeam)
    params = instance.params()
    for seed in (0, 1):  # the same behaviour, cycle for cycle, through the family's id
        assert _trajectory(team, seed=seed) == _trajectory("parametric", params, seed=seed)


def test_goal_guards_are_seeded_and_sortie_at_the_stated_rate():
    assert _trajectory("goal_guards", seed=5, action=0) == _trajectory(
        "goal_guards", seed=5, action=0)
    # One-cycle sorties, no reach: the number of sorties is Binomial(cycles on the line, p).
    env = HolderEnv(opponent="parametric", opponent_params={
        "roles": ["guard", "guard"], "press_probability": 0.1, "sortie_cycles": 1,
        "guard_reach": 0.0})
    team = env.loop.core.team.team
    sorties = trials = 0
    for seed in range(10):
        env.reset(seed=seed)
        done = False
        while not done:
            _, _, term, trunc, info = env.step(0)
            done = term or trunc
        sorties += team.sorties
        trials += 2 * info["cycles"] - team.sorties  # guard-cycles spent on the line
    rate = sorties / trials
    assert abs(rate - 0.1) < 3 * math.sqrt(0.1 * 0.9 / trials)


def test_reaction_delay_acts_on_the_state_of_cycles_ago():
    env = HolderEnv(opponent="chasers", decision_cycles=1)  # one cycle per DRIBBLE step
    env.reset(seed=0)
    view, cfg, one = env.loop.core.team.view, env.config, np.zeros(1, dtype=np.int64)
    late = ParametricTeam(reaction_delay=3).batch(1)
    rng = BatchRandom(1)
    rng.seed(one, [0])
    late.reset(view, one, rng)
    seen = []
    for t in range(25):
        seen.append(env.drill_state)
        commands = late.act(view, one)
        assert commands.skill[0, 0] == Skill.MOVE_TO
        old = seen[max(t - 3, 0)]
        assert tuple(commands.target[0, 0]) == ball_interception_point(old, 2, cfg.defender_speed,
                                                                       cfg)
        _, _, term, trunc, info = env.step(2)
        assert info["duration"] == 1 and not (term or trunc)


def test_family_rejects_bad_parameters_by_name():
    for bad, message in (
        ({"roles": ["keeper", "guard"]}, "roles must be a list of 1 to 4 values"),
        ({"coordination": "zonal"}, "coordination must be one of"),
        ({"speed": 1.5}, "speed must be a finite number in"),
        ({"reaction_delay": -1}, "reaction_delay must be an integer"),
        ({"press_probability": 2.0}, "press_probability must be a finite number in"),
    ):
        with pytest.raises(ValueError, match=message):
            HolderEnv(opponent="parametric", opponent_params=bad)


def test_press_team_matches_the_independent_chasers():
    for seed in (0, 3):
        assert _trajectory("interceptors_press", seed=seed) == _trajectory("chasers", seed=seed)


@pytest.mark.parametrize("n", [1, 3])
def test_chasers_give_one_command_per_episode_at_the_speed_set_then(n):
    from opponents.chasers import Chasers
    from soccer_drill.vector import HolderVectorEnv

    team = Chasers(speed=0.5)
    env = HolderEnv(opponent=team) if n == 1 else HolderVectorEnv(num_envs=n, opponent=team)
    env.reset(seed=0)
    driver, batch = env.loop.core.team, env.loop.core.batch
    driver.act(np.arange(n))
    assert (batch.skill[:, 2:] == int(Skill.INTERCEPT)).all() and (batch.speed[:, 2:] == 0.5).all()
    team.speed = 1.0  # the team's own rule, made again at each episode's start
    driver.act(np.arange(n))
    assert (batch.speed[:, 2:] == 0.5).all()
    env.reset(seed=0)
    driver.act(np.arange(n))
    assert (batch.speed[:, 2:] == 1.0).all()
