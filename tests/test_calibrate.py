"""Plugin authors calibrate their own teams: ``--teams``, ``--out``, and the plugin page."""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

import soccer_drill
from ilpss.experiments.calibrate import Cell, criteria, main
from soccer_drill import Command, Skill
from soccer_drill.teams.registry import TEAMS

ROOT = Path(__file__).resolve().parents[1]


class Statues:
    """Defenders that stand still where they start."""

    def reset(self, view, rng):
        self.home = {p: tuple(view.positions[2 + k]) for k, p in enumerate(view.players)}

    def act(self, view):
        return {p: Command(Skill.MOVE_TO, target) for p, target in self.home.items()}


@pytest.fixture
def statues():
    soccer_drill.register("statues", Statues, overwrite=True)
    yield "statues"
    TEAMS.unregister("statues")


def test_teams_and_default_out_never_touch_docs(statues, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "opponents.md").write_text("committed page\n")
    assert main(["--teams", statues, "interceptors_press", "--episodes", "2",
                 "--workers", "1"]) == 0
    assert (docs / "opponents.md").read_text() == "committed page\n"
    assert sorted(p.name for p in docs.iterdir()) == ["opponents.md"]
    out = tmp_path / "results" / "calibration"
    text = (out / "opponents.md").read_text()
    assert sorted(p.name for p in (out / "gifs").iterdir()) == [
        "interceptors_press.gif", "statues.gif"
    ]
    assert "(gifs/statues.gif)" in text
    assert "| `statues` | Defenders that stand still where they start. |" in text
    assert "soccer-drill-calibrate --teams statues interceptors_press --episodes 2" in text
    teams_in_tables = set(re.findall(r"^\| (\w+) \| random \| \d", text, flags=re.M))
    assert teams_in_tables == {"statues", "interceptors_press"}  # only the teams given
    printed = capsys.readouterr().out
    for page in (text, printed):
        assert "each of the 2 teams (statues, interceptors_press)" in page
        assert "against both teams" in page
        assert "paper team" not in page and "all four" not in page


def test_out_folder_and_errors(statues, tmp_path, capsys):
    out = tmp_path / "mine"
    assert main(["--teams", statues, "--episodes", "2", "--workers", "1", "--no-gifs",
                 "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["opponents.md"]
    text = (out / "opponents.md").read_text()
    assert "against statues:" in text
    assert "not judged, it needs at least two teams" in text
    with pytest.raises(SystemExit):
        main(["--teams", "no_such_team", "--episodes", "2"])
    assert "unknown team(s) ['no_such_team']; installed teams:" in capsys.readouterr().err
    (tmp_path / "a_file").write_text("")
    with pytest.raises(SystemExit):
        main(["--teams", statues, "--out", str(tmp_path / "a_file"), "--episodes", "2"])
    assert "--out must name a folder" in capsys.readouterr().err


@pytest.mark.parametrize("out, said", [
    ("a_file/calibration", "'{tmp}/a_file' is a file, not a folder"),
    ("taken", "the output must name a file, got the folder '{tmp}/taken/opponents.md'"),
    ("gifs_a_file", "'{tmp}/gifs_a_file/gifs' is a file, not a folder"),
])
def test_outputs_are_checked_before_any_episode(statues, tmp_path, capsys, monkeypatch, out,
                                                 said):
    from ilpss.experiments import calibrate

    monkeypatch.setattr(calibrate, "calibrate", lambda *a, **k: pytest.fail("it calibrated"))
    (tmp_path / "a_file").write_text("")
    (tmp_path / "taken" / "opponents.md").mkdir(parents=True)  # a folder where the page goes
    (tmp_path / "gifs_a_file").mkdir()
    (tmp_path / "gifs_a_file" / "gifs").write_text("")
    with pytest.raises(SystemExit) as exit_:
        main(["--teams", statues, "--episodes", "2", "--out", str(tmp_path / out)])
    assert exit_.value.code == 2
    assert said.format(tmp=tmp_path) in capsys.readouterr().err


def _cell(team, rule, successes, reward, n=100):
    return Cell(team, rule, successes, n, reward, reward - 0.1, reward + 0.1)


def test_criteria_wording_follows_the_teams_given():
    teams = ("a_team", "b_team", "c_team")
    cells = {}
    for k, team in enumerate(teams):
        cells[(team, "random")] = _cell(team, "random", 5, -0.9)
        cells[(team, "x")] = _cell(team, "x", 60, 0.2 if k else -0.5)
        cells[(team, "y")] = _cell(team, "y", 40, -0.5 if k else 0.2)
    lines = criteria(cells, teams)
    assert "each of the 3 teams (a_team, b_team, c_team)" in lines[0]
    assert "against all 3:" in lines[1]
    assert "against all 3 teams" in lines[2] and "**met**" in lines[2]
    assert not any("paper" in line or "four" in line for line in lines)


def _fenced_blocks(text: str, language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", text, flags=re.S)


def test_plugin_page_example_builds_installs_and_is_discovered(tmp_path):
    """The plugin page's example, as written, is a package pip installs; its team is found."""
    page = (ROOT / "docs" / "plugins.md").read_text()
    (pyproject,) = _fenced_blocks(page, "toml")
    meta = tomllib.loads(pyproject)
    assert meta["build-system"]["build-backend"] == "setuptools.build_meta"
    assert any(r.startswith("setuptools") for r in meta["build-system"]["requires"])
    module = next(b for b in _fenced_blocks(page, "python") if "class Zonal" in b)
    project = tmp_path / "my-teams"
    (project / "my_teams").mkdir(parents=True)
    (project / "pyproject.toml").write_text(pyproject)
    (project / "my_teams" / "__init__.py").write_text(module)
    target = tmp_path / "site"
    # No build isolation and no dependencies: the test needs no network, and the
    # project's own setuptools builds it.
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
         "--no-build-isolation", "--target", str(target), str(project)],
        check=True, capture_output=True, timeout=300,
    )
    check = (
        "import soccer_drill, sys\n"
        "teams = soccer_drill.available_teams()\n"
        "print(teams['zonal'])\n"
        "env = soccer_drill.HolderEnv(opponent='zonal', opponent_params={'depth': 4.0})\n"
        "env.reset(seed=0)\n"
        "print(env.step(2)[4]['duration'])\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", check], capture_output=True, text=True, timeout=120,
        env={"PYTHONPATH": str(target), "PATH": "/usr/bin:/bin"},
    )
    assert done.returncode == 0, done.stderr
    first, duration = done.stdout.splitlines()
    assert first == "Each defender guards one half of the field and presses the ball when it enters it."
    assert int(duration) >= 1


@pytest.mark.parametrize(("arguments", "said"), [
    (("chasers", "earlypass", 5), r"rules must be a list of at least 1 values, each one of .*"
                                  r"'early_pass'.*got \['earlypass'\]"),
    (("chasers", "early_pass", -5), r"episodes must be an integer >= 1, got -5"),
    (("chasers", "early_pass", 0), r"episodes must be an integer >= 1, got 0"),
    (("chasers", "early_pass", 5, -1), r"first_seed must be an integer in \[0, .*got -1"),
    (("chasers", "early_pass", 5, 0, None, None, 0), r"drills must be an integer >= 1, got 0"),
])
def test_one_cell_refuses_a_rule_or_a_count_it_cannot_play_naming_it(arguments, said):
    """``evaluate`` (the plugin page's one cell in Python) raised a bare ``KeyError`` for a
    mistyped rule and, for -5 episodes, an error about ``num_envs``, which the caller never
    gave."""
    from ilpss.experiments.calibrate import evaluate

    with pytest.raises(ValueError, match=said):
        evaluate(*arguments)
