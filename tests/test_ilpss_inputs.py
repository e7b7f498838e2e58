"""Bad input to ilpss's commands and classes: refused before any work, with a message that
says what was wrong and what is allowed; references and recorded commands that hold."""

from __future__ import annotations

import json
import shlex

import numpy as np
import pytest
from gymnasium import spaces

from ilpss.experiments.config import ExperimentConfig

TWO_TEAMS = ("chasers", "goal_guards")


def _fail_if_run(monkeypatch) -> None:
    from ilpss.experiments.executor import LocalExecutor

    monkeypatch.setattr(LocalExecutor, "map", lambda *a, **k: pytest.fail("it ran jobs"))


def _experiment(argv, capsys) -> tuple[int, str]:
    from ilpss.experiments import cli

    with pytest.raises(SystemExit) as exit_info:
        cli.main([*argv, "--quiet"])
    return exit_info.value.code, capsys.readouterr().err


def _holder(argv, capsys) -> tuple[int, str]:
    from ilpss.experiments import holder_learning

    with pytest.raises(SystemExit) as exit_info:
        holder_learning.main(argv)
    return exit_info.value.code, capsys.readouterr().err


# ------------------------------------------------------------ fields a protocol does not use
@pytest.mark.parametrize("fields, said", [
    ({"protocol": "C", "teams": TWO_TEAMS}, "ExperimentConfig.teams: protocol C does not use it"),
    ({"protocol": "R", "teams": TWO_TEAMS}, "ExperimentConfig.teams: protocol R does not use it"),
    ({"protocol": "A", "stream_length": 5},
     "ExperimentConfig.stream_length: protocol A does not use it (it reads teams and targets), "
     "got 5; leave it at its default 20"),
    ({"protocol": "B", "stream_length": 5}, "ExperimentConfig.stream_length: protocol B"),
    ({"protocol": "A", "n_shuffles": 3}, "ExperimentConfig.n_shuffles: protocol A"),
    ({"protocol": "B", "sampler_team": "chasers"}, "ExperimentConfig.sampler_team: protocol B"),
    ({"protocol": "S", "stream_length": 5}, "ExperimentConfig.stream_length: protocol S"),
    ({"protocol": "L", "n_shuffles": 3}, "ExperimentConfig.n_shuffles: protocol L"),
])
def test_a_protocol_refuses_a_field_it_does_not_use(fields, said):
    with pytest.raises(ValueError, match=None) as info:
        ExperimentConfig(**fields)
    assert said in str(info.value)


def test_a_protocol_accepts_the_fields_it_uses_and_defaults_of_the_others():
    ExperimentConfig(protocol="C", stream_length=3, sampler_team="parametric")
    ExperimentConfig(protocol="R")
    ExperimentConfig(protocol="R", teams=TWO_TEAMS, targets=("interceptors_press",))
    ExperimentConfig(protocol="B", teams=TWO_TEAMS, n_shuffles=0)
    ExperimentConfig(protocol="A", teams=TWO_TEAMS, stream_length=20)
    ExperimentConfig(protocol="S")
    ExperimentConfig(protocol="L", stream_length=3)


def test_the_sharp_tests_streams_hold_its_sources_then_its_targets_from_the_same_state():
    """S: the paper's teams and the contain, then each target after them; L: the same
    after a prefix drawn by protocol C's sampler (the same draw as C's stream)."""
    from ilpss.experiments import drill_facts

    (s,) = ExperimentConfig(protocol="S").streams(3)
    assert [t.name for t in s.tasks] == [*drill_facts.SHARP_SOURCES, *drill_facts.SHARP_TARGETS]
    assert s.first_target == len(drill_facts.SHARP_SOURCES) and s.shared_start
    (long,) = ExperimentConfig(protocol="L", stream_length=4).streams(3)
    (c,) = ExperimentConfig(protocol="C", stream_length=4).streams(3)
    assert long.tasks[:4] == c.tasks
    assert long.tasks[4:] == s.tasks and long.first_target == 4 + s.first_target
    with pytest.raises(ValueError, match="are also sources"):
        ExperimentConfig(protocol="L", teams=TWO_TEAMS, targets=TWO_TEAMS[:1])


@pytest.mark.parametrize("argv, said", [
    (["--protocol", "C", "--teams", *TWO_TEAMS, "--stream-length", "3"],
     "ExperimentConfig.teams: protocol C does not use it"),
    (["--protocol", "R", "--teams", *TWO_TEAMS], "ExperimentConfig.teams: protocol R"),
    (["--protocol", "A", "--stream-length", "5"], "ExperimentConfig.stream_length: protocol A"),
])
def test_the_command_refuses_flags_its_protocol_ignores(tmp_path, monkeypatch, capsys, argv,
                                                         said):
    _fail_if_run(monkeypatch)
    code, err = _experiment([*argv, "--seeds", "1", "--out", str(tmp_path / "run")], capsys)
    assert code == 2 and said in err
    assert not (tmp_path / "run" / "config.json").exists()


def test_a_config_file_with_a_field_its_protocol_ignores_is_refused(tmp_path, monkeypatch,
                                                                    capsys):
    _fail_if_run(monkeypatch)
    config = tmp_path / "c.json"
    config.write_text(json.dumps({"protocol": "C", "teams": list(TWO_TEAMS)}))
    code, err = _experiment(["--config", str(config), "--out", str(tmp_path / "run")], capsys)
    assert code == 2 and f"--config {config}: ExperimentConfig.teams: protocol C" in err


# ------------------------------------------------------------ an experiment learns
def test_an_experiment_without_learning_episodes_is_refused_before_any_job(
    tmp_path, monkeypatch, capsys
):
    from ilpss.experiments import demo
    from ilpss.lifelong import LifelongConfig

    said = "ExperimentConfig.lifelong.train_episodes must be an integer in [1, 1,000,000], got 0"
    with pytest.raises(ValueError) as info:
        ExperimentConfig().with_overrides(lifelong={"train_episodes": 0})
    assert str(info.value) == said
    assert LifelongConfig(train_episodes=0).train_episodes == 0  # the Python API keeps 0

    _fail_if_run(monkeypatch)
    out = tmp_path / "run"
    code, err = _experiment(["--seeds", "1", "--methods", "scratch", "--episodes", "0",
                             "--out", str(out)], capsys)
    flag = "--episodes must be an integer in [1, 1,000,000], got 0"  # said as the flag
    assert code == 2 and flag in err and not (out / "config.json").exists()
    config = tmp_path / "c.json"
    config.write_text(json.dumps({"methods": ["scratch"], "lifelong": {"train_episodes": 0}}))
    code, err = _experiment(["--config", str(config), "--out", str(out)], capsys)
    assert code == 2 and said in err and not (out / "config.json").exists()
    with pytest.raises(SystemExit) as exit_info:
        demo.main(["--episodes", "0", "--out", str(out)])
    assert exit_info.value.code == 2 and flag in capsys.readouterr().err
    assert not (out / "config.json").exists()


def test_a_run_wide_way_of_reusing_past_policies_is_refused_naming_the_methods(
    tmp_path, monkeypatch, capsys
):
    """``--set options=whole_policies`` made the methods that take the default reuse
    (``ilpss`` and its variants) run whole past policies under ILPSS's name, silently;
    the reuse is each method's own."""
    said = ("ExperimentConfig.lifelong.options: each method sets its own way of reusing past "
            "policies, so the run's must stay 'kernels'")
    with pytest.raises(ValueError, match=said + r".*got 'whole_policies'; choose a method "
                       r"that reuses them so .*\['whole_policies', 'whole_policies_plus'\]"):
        ExperimentConfig().with_overrides(lifelong={"options": "whole_policies"})
    assert ExperimentConfig().with_overrides(lifelong={"options": "kernels"}).lifelong.options \
        == "kernels"

    _fail_if_run(monkeypatch)
    out = tmp_path / "run"
    code, err = _experiment(["--seeds", "1", "--methods", "scratch", "ilpss", "--set",
                             "options=whole_policies", "--out", str(out)], capsys)
    assert code == 2 and said in err and not (out / "config.json").exists()


# ------------------------------------------------------------ ilpss-holder-learning
def test_the_holder_learning_page_records_a_command_that_reruns_it():
    from ilpss.experiments.holder_learning import command, parser

    p = parser()
    args = p.parse_args(["--teams", "chasers", "goal_guards", "--rules", "my.rules:RULES",
                         "--episodes", "7", "--workers", "3", "--alpha", "0.123456789",
                         "--out", "page.md", "--keep", "kept"])
    line = command(p, args)
    argv = shlex.split(line)
    assert argv[0] == "ilpss-holder-learning"
    assert p.parse_args(argv[1:]) == args
    assert "--teams chasers goal_guards" in line and "--rules my.rules:RULES" in line
    assert "--alpha 0.123456789" in line  # not rounded to 0.123457
    # The flags left at their defaults: the settings that define the page, nothing else.
    assert command(p, p.parse_args([])) == (
        "ilpss-holder-learning --episodes 1000 --eval 500 --seeds 10 --method q "
        "--trace-decay 0.9 --initial-value 1 --alpha 0.125")


@pytest.mark.parametrize("argv, said", [
    (["--teams", "chasers", "chasers"],
     "--teams must be a list of at least 1 distinct values, each a non-empty string, got "
     "['chasers', 'chasers']"),
    (["--episodes", "100000000"], "--episodes must be an integer in [1, 1,000,000], got 100000000"),
    (["--eval", "0"], "--eval must be an integer in [1, 100,000], got 0"),
    (["--seeds", "1"], "--seeds must be an integer in [2, 100,000], got 1"),
    (["--workers", "0"], "--workers must be an integer in [1, 1,024], got 0"),
])
def test_holder_learning_refuses_repeated_teams_and_counts_out_of_range(
    tmp_path, monkeypatch, capsys, argv, said
):
    _fail_if_run(monkeypatch)
    code, err = _holder([*argv, "--out", str(tmp_path / "page.md"), "--keep",
                         str(tmp_path / "keep")], capsys)
    assert code == 2 and said in err
    assert not (tmp_path / "keep").exists()


def test_holder_learning_writes_its_page_under_results_by_default():
    from ilpss.experiments import holder_learning

    assert holder_learning.parser().get_default("out") == "results/holder_learning.md"
    # The documented full-size run still writes the tracked page.
    assert "--out docs/learning.md" in holder_learning.__doc__.splitlines()[2]


# ------------------------------------------------------------ a team that fails
@pytest.fixture
def broken_team(team_registry):
    def factory(**params):
        raise RuntimeError("planted failure")

    team_registry.register("broken_for_ilpss", factory)
    return "broken_for_ilpss"


def test_a_team_that_fails_ends_the_commands_with_one_line(tmp_path, monkeypatch, capsys,
                                                           broken_team):
    _fail_if_run(monkeypatch)
    out = tmp_path / "run"
    code, err = _experiment(["--seeds", "1", "--methods", "scratch", "--teams", "chasers",
                             broken_team, "--out", str(out)], capsys)
    assert code == 1 and "Traceback" not in err
    assert err.startswith(f"ilpss-experiment: error: team {broken_team!r} failed while being "
                          "built") and "planted failure" in err
    assert not (out / "config.json").exists()
    code, err = _holder(["--teams", "chasers", broken_team, "--out", str(tmp_path / "p.md"),
                         "--keep", str(tmp_path / "keep")], capsys)
    assert code == 2 and "Traceback" not in err
    assert f"ilpss-holder-learning: error: team {broken_team!r} failed while being built" in err


def test_a_team_failing_in_a_job_is_not_advised_to_run_the_same_command_again(
    tmp_path, capsys, team_registry
):
    """A team plays the same given its seeds, so the same command failed the same way, and
    once the team was fixed the run folder refused its changed code: the advice to run the
    same command again helped in neither case."""
    from soccer_drill import Command, Skill

    class FailsAtCycle3:
        def reset(self, view, rng):
            self.players = view.players

        def act(self, view):
            if view.cycle == 3:
                raise RuntimeError("planted failure")
            return {p: Command(Skill.INTERCEPT) for p in self.players}

    team_registry.register("fails_at_cycle_3", FailsAtCycle3)
    out = tmp_path / "run"
    argv = ["--seeds", "1", "--episodes", "2", "--rollouts", "1", "--workers", "1",
            "--methods", "scratch", "--teams", "chasers", "fails_at_cycle_3", "--no-report",
            "--quiet", "--out", str(out)]
    code, err = _experiment(argv, capsys)
    assert code == 1 and "Traceback" not in err
    assert "TeamError: team 'fails_at_cycle_3' raised in act() at cycle 3" in err
    assert "fix the team, then run the command with a new run folder" in err
    assert "run the same command again" not in err


def test_the_drill_exception_is_caught_without_importing_the_drill():
    from ilpss.experiments.drill_facts import TEAM_ERROR, drill_exception
    from soccer_drill import TeamError

    assert drill_exception(TEAM_ERROR) is TeamError
    never = drill_exception("a_module_nobody_imported:Error")
    assert issubclass(never, Exception) and not issubclass(TeamError, never)


# ------------------------------------------------------------ another environment
def test_an_environment_that_does_not_take_the_tasks_is_refused_first(tmp_path, monkeypatch,
                                                                      capsys):
    from ilpss.experiments.run import run_experiment

    _fail_if_run(monkeypatch)
    cfg = ExperimentConfig(n_seeds=1, env_id="CartPole-v1", methods=("scratch",))
    with pytest.raises(ValueError, match=r"^ExperimentConfig.env_id 'CartPole-v1': the "
                                         r"environment of task 'interceptors_press' cannot be "
                                         r"made with the protocol's arguments \{'opponent'"):
        run_experiment(cfg, tmp_path / "run", progress=False)
    config = tmp_path / "c.json"
    config.write_text(json.dumps({"env_id": "CartPole-v1", "methods": ["scratch"]}))
    code, err = _experiment(["--config", str(config), "--out", str(tmp_path / "run"),
                             "--no-report"], capsys)  # (another environment: no report)
    assert code == 1 and "ExperimentConfig.env_id 'CartPole-v1'" in err
    assert "Traceback" not in err and not (tmp_path / "run" / "config.json").exists()


# ------------------------------------------------------------ the Python API's messages
class _Tiny:
    """Five steps of random 2-feature observations, two actions."""

    observation_space = spaces.Box(0.0, 1.0, (2,), np.float64)
    action_space = spaces.Discrete(2)

    def reset(self, seed=None, options=None):
        self.rng, self.t = np.random.default_rng(seed), 0
        return self.rng.random(2), {}

    def step(self, action):
        self.t += 1
        return self.rng.random(2), float(self.rng.random() < 0.3), self.t >= 5, False, {}


@pytest.mark.parametrize("space", [
    spaces.Dict({"a": spaces.Box(0.0, 1.0, (2,))}),
    spaces.Discrete(5),
    spaces.Box(-np.inf, np.inf, (2,)),
    spaces.Box(0.0, 1.0, (2, 2)),
])
def test_a_space_tile_coding_cannot_use_is_named_not_blamed_on_the_settings(space):
    from ilpss.lifelong import LifelongConfig, LifelongLearner
    from ilpss.tiles import TileCoder

    for make in (lambda: LifelongLearner(LifelongConfig(), space, 2),
                 lambda: TileCoder.from_space(space)):
        with pytest.raises(ValueError) as info:
            make()
        assert str(info.value).startswith(f"the observation space is {space!r}; tile coding "
                                          "needs a 1-D Box with finite low and high")
        assert "LearnerConfig" not in str(info.value)


def test_the_learner_names_a_missing_action_count_and_a_checkpoint_of_another_space(tmp_path):
    from ilpss.lifelong import LearnerConfig, LifelongConfig, LifelongLearner

    with pytest.raises(ValueError, match=r"LifelongLearner n_primitive \(the number of "
                                         r"primitive actions\) must be an integer >= 1, got None"):
        LifelongLearner(LifelongConfig(), _Tiny.observation_space, None)
    cfg = LifelongConfig(n_kernels=1, train_episodes=2, rollout_episodes=1,
                         learner=LearnerConfig(tile_widths=(0.5, 0.5), n_tilings=2))
    learner = LifelongLearner(cfg, _Tiny.observation_space, 2)
    learner.run_trial(_Tiny(), "tiny")
    learner.save(tmp_path)
    other = spaces.Box(0.0, 1.0, (9,))
    with pytest.raises(ValueError, match=r"the checkpoint was saved for a 2-feature observation "
                                         r"space .*, but the observation space given is "
                                         r"Box\(0.0, 1.0, \(9,\), float32\), with 9"):
        LifelongLearner.load(tmp_path, other)
    assert LifelongLearner.load(tmp_path, _Tiny.observation_space).n_trials == 1
    with pytest.raises(ValueError, match=r"^LearnerConfig.tile_widths / n_tilings: widths must "
                                         r"have 9 entries, one per feature of the observation "
                                         r"space Box\(0.0, 1.0, \(9,\), float32\), got 2"):
        cfg.learner.tile_coder(other)


# ------------------------------------------------------------ references in the reports
def test_a_run_folders_report_names_the_repositorys_statistics_page(tmp_path):
    from ilpss.experiments.report import write_report
    from ilpss.experiments.run import run_experiment

    cfg = ExperimentConfig(n_seeds=1, workers=1, methods=("scratch",),
                           teams=TWO_TEAMS).with_overrides(
        lifelong={"train_episodes": 2, "rollout_episodes": 1})
    results = run_experiment(cfg, tmp_path, progress=False)
    text = write_report(cfg, results, tmp_path).read_text()
    assert "`docs/statistics.md` in the repository" in text and "(statistics.md)" not in text


def test_the_results_page_links_only_pages_beside_it(tmp_path):
    from ilpss.experiments.results_doc import intro

    configs = {"A": ExperimentConfig()}
    text = "\n".join(intro(configs, "runs", str(tmp_path)))
    assert "(discussion.md)" not in text and "(statistics.md)" not in text
    assert "`docs/discussion.md` in the repository" in text
    assert "`docs/statistics.md` in the repository" in text
    for name in ("discussion.md", "statistics.md"):  # as in the repository's docs/
        (tmp_path / name).write_text("#\n")
    text = "\n".join(intro(configs, "runs", str(tmp_path)))
    assert "[`discussion.md`](discussion.md)" in text
    assert "[`statistics.md`](statistics.md)" in text


# ------------------------------------------------------------ repeated keys in JSON
def test_a_config_file_with_a_repeated_key_is_refused_naming_the_key_and_file(
    tmp_path, monkeypatch, capsys
):
    from ilpss._io import read_json

    config = tmp_path / "c.json"
    config.write_text('{"n_seeds": 1, "methods": ["scratch"], "n_seeds": 2}')
    with pytest.raises(ValueError, match=rf"^{config}: not valid JSON \(the key 'n_seeds' "
                                         r"appears more than once in one object"):
        read_json(config)
    nested = tmp_path / "nested.json"
    nested.write_text('{"lifelong": {"train_episodes": 2, "train_episodes": 3}}')
    with pytest.raises(ValueError, match="the key 'train_episodes' appears more than once"):
        read_json(nested)
    _fail_if_run(monkeypatch)
    code, err = _experiment(["--config", str(config), "--out", str(tmp_path / "run")], capsys)
    assert code == 2 and f"{config}: not valid JSON (the key 'n_seeds' appears" in err


def test_seeds_past_the_largest_and_a_setting_given_twice_are_refused(tmp_path, capsys):
    # before, --first-seed 4294967295 --seeds 2 ran a seed past the documented largest, and
    # a repeated --set kept its last value silently
    out = tmp_path / "run"
    for argv, said in ((["--first-seed", "4294967295", "--seeds", "2"],
                        "the seeds 4294967295 .. 4294967296 go past 4,294,967,295"),
                       (["--set", "n_kernels=2", "--set", "n_kernels=3"],
                        "--set n_kernels is given twice")):
        code, err = _experiment([*argv, "--out", str(out)], capsys)
        assert code == 2 and said in err and not out.exists()
