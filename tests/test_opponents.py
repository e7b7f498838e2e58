"""Each scripted team does what its docstring claims (fixed seeds), and the family samples."""

from __future__ import annotations

import math

import numpy as np
import pytest

from opponents import PAPER_TEAMS, sample_opponents
from opponents.calibrate import calibrate, criteria, write_markdown
from opponents.cli import main as list_teams
from soccer_drill.holder import HolderEnv
from soccer_drill.policies import HOLDER_POLICIES
from soccer_drill.state import BALL


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
    for team in (*PAPER_TEAMS, "chasers", "parametric"):
        assert team in out


def test_calibration_table_and_criteria(tmp_path):
    cells = calibrate(episodes=3, teams=PAPER_TEAMS, workers=1)
    lines = criteria(cells)
    assert len(lines) == 3 and all(("met" in line) for line in lines)
    path = write_markdown(cells, 3, tmp_path / "opponents.md", gifs={})
    text = path.read_text()
    assert text.count("| interceptors_press |") == len(HOLDER_POLICIES)  # a row per fixed rule
