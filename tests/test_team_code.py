"""Results kept between runs are tied to the code of the teams they played: a team whose
code changed is not taken for the old one."""

from __future__ import annotations

import importlib
import sys
import textwrap

import pytest

import soccer_drill.teams as teams
from ilpss.experiments import holder_learning
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.run import run_experiment
from ilpss.lifelong import LearnerConfig

_WALL = '''
from soccer_drill import Command, Skill


class Wall:
    """Both defenders stand on the goal line."""

    def reset(self, view, rng):
        self.players = view.players

    def act(self, view):
        return {p: Command(Skill.MOVE_TO, (10.0 + 15.0 * k, 1.0)) for k, p in enumerate(self.players)}
'''


@pytest.fixture
def wall(tmp_path, monkeypatch, team_registry):
    """A team ``tc_wall`` from a module of its own, and a way to change its source."""
    source = tmp_path / "plugin_tc_wall.py"
    source.write_text(textwrap.dedent(_WALL))
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "plugin_tc_wall", raising=False)  # this test's file
    module = importlib.import_module("plugin_tc_wall")
    team_registry.register("tc_wall", module.Wall)
    holder_learning._team_code.cache_clear()
    yield lambda: source.write_text(source.read_text() + "\n# a change\n")
    holder_learning._team_code.cache_clear()


def test_a_team_s_code_is_recorded_by_its_factory_and_source(wall):
    code = teams.team_code("tc_wall")
    assert code["factory"] == "plugin_tc_wall:Wall" and len(code["source_sha256"]) == 64
    wall()
    assert teams.team_code("tc_wall")["source_sha256"] != code["source_sha256"]


def test_holder_learning_keeps_no_result_for_a_team_whose_code_changed(wall):
    job = ("tc_wall", 0, 10, 5, LearnerConfig())
    rule = ("tc_wall", "soccer_drill.policies:HOLDER_POLICIES", "hold", 5)
    before = holder_learning.learning_key(job), holder_learning.rule_key(rule)
    wall()
    holder_learning._team_code.cache_clear()  # a new command: a new process
    after = holder_learning.learning_key(job), holder_learning.rule_key(rule)
    assert before[0] != after[0] and before[1] != after[1]
    assert before[0]["team_code"]["factory"] == "plugin_tc_wall:Wall"


def test_a_run_refuses_to_go_on_with_a_team_whose_code_changed(wall, tmp_path):
    cfg = ExperimentConfig(n_seeds=1, workers=1, methods=("scratch",),
                           teams=("tc_wall", "chasers")).with_overrides(
        lifelong={"train_episodes": 2, "rollout_episodes": 1})
    out = tmp_path / "run"
    run_experiment(cfg, out, progress=False)
    assert "tc_wall" in (out / "team_code.json").read_text()
    run_experiment(cfg, out, progress=False)  # the same code: the finished run is taken
    wall()
    with pytest.raises(ValueError, match=r"the code of tc_wall \(source_sha256: .*\) changed since "
                                         r"this run started"):
        run_experiment(cfg, out, progress=False)
