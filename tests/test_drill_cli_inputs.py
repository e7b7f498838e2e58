"""The drill's commands (soccer-drill-gif, soccer-drill-calibrate): bad input and a failing
team said in one line, with exit 2 or 1."""

from __future__ import annotations

import pytest

from ilpss.experiments import calibrate
from soccer_drill import Command, Skill
from soccer_drill.rendering import gif


class Flaky:
    """Plays, then raises at cycle 3."""

    def reset(self, view, rng):
        self.players = view.players

    def act(self, view):
        if view.cycle >= 3:
            raise RuntimeError("flaky at cycle 3")
        return {p: Command(Skill.INTERCEPT) for p in self.players}


@pytest.fixture
def flaky(team_registry):
    team_registry.register("flaky_cli", Flaky)
    return "flaky_cli"


def test_soccer_drill_gif_says_a_failing_team_in_one_line(flaky, tmp_path, capsys):
    assert gif.main(["--team", flaky, "--policy", "hold", "-o", str(tmp_path / "e.gif")]) == 1
    err = capsys.readouterr().err
    assert err.startswith("soccer-drill-gif: error: team 'flaky_cli' raised in act() at cycle 3")
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "e.gif").exists()


@pytest.mark.parametrize("workers", ["1", "2"])
def test_soccer_drill_calibrate_says_a_failing_team_in_one_line(flaky, tmp_path, capsys, workers):
    code = calibrate.main(["--teams", flaky, "--episodes", "2", "--no-gifs", "--workers", workers,
                           "--out", str(tmp_path / "cal")])
    assert code == 1
    err = capsys.readouterr().err
    assert err.startswith("soccer-drill-calibrate: error: team 'flaky_cli'")
    assert "flaky at cycle 3" in err and "Traceback" not in err
    assert not (tmp_path / "cal" / "opponents.md").exists()


def test_soccer_drill_gif_refuses_an_output_that_is_not_a_gif(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_:
        gif.main(["-o", str(tmp_path / "episode.png")])
    assert exit_.value.code == 2
    assert "-o/--output must name a .gif file" in capsys.readouterr().err
    assert not (tmp_path / "episode.png").exists()


def test_soccer_drill_calibrate_refuses_no_workers(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_:
        calibrate.main(["--workers", "0", "--episodes", "2", "--out", str(tmp_path / "cal")])
    assert exit_.value.code == 2
    assert "--workers must be >= 1 (1: in this process), got 0" in capsys.readouterr().err
