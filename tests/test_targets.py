"""Protocol A with several targets: the sources learnt once per seed and method, every
target from the same state after them, results and reports per target, and resume."""

from __future__ import annotations

import json
import re
import shlex
import shutil
from dataclasses import replace

import pytest

from ilpss.experiments.cli import build_config, parser
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.methods import METHODS, LifelongMethod
from ilpss.experiments.report import write_report
from ilpss.experiments.results_doc import main as results_main
from ilpss.experiments.results_doc import parser as results_parser
from ilpss.experiments.results_doc import protocol_config
from ilpss.experiments.run import JobError, run_experiment
from ilpss.experiments.seed_data import SeedData
from ilpss.lifelong import LifelongLearner

SOURCES = ("interceptors_press", "interceptor_guard")
TARGETS = ("goal_guards", "chasers")
TINY = ["--seeds-a", "2", "--episodes", "8", "--rollouts", "3"]


def _several() -> ExperimentConfig:
    """Exactly the configuration ``ilpss-results`` builds for protocol A with these flags."""
    args = results_parser().parse_args([*TINY, "--teams", *SOURCES, "--targets", *TARGETS])
    return protocol_config("A", args).with_overrides(workers=1)


def _count_trials(monkeypatch) -> list[str]:
    """Record the task name of every trial the lifelong learners run in this process."""
    names: list[str] = []
    real = LifelongLearner.run_trial

    def run_trial(self, env, name, callback=None):
        names.append(name)
        return real(self, env, name, callback)

    monkeypatch.setattr(LifelongLearner, "run_trial", run_trial)
    return names


def test_targets_are_protocol_a_sources_only_distinct_and_not_elsewhere():
    cfg = ExperimentConfig(teams=SOURCES, targets=TARGETS)
    (stream,) = cfg.streams(0)
    assert [t.name for t in stream.tasks] == [*SOURCES, *TARGETS]
    assert stream.first_target == 2 and stream.shared_start
    assert stream.name == "held_out=goal_guards+chasers"
    # The default: the last team is the one target, as before.
    (default,) = ExperimentConfig().streams(0)
    assert default.first_target == 3 and default.name == "held_out=goal_guards"
    assert "targets" not in ExperimentConfig().results_record()
    assert cfg.results_record()["targets"] == list(TARGETS)
    with pytest.raises(ValueError, match=r"targets: \['goal_guards'\] are also sources; .*"
                                         r"--teams interceptors_press interceptors_cover "
                                         r"interceptor_guard --targets goal_guards chasers"):
        ExperimentConfig(targets=TARGETS)
    with pytest.raises(ValueError, match="targets must not repeat a team"):
        ExperimentConfig(teams=SOURCES, targets=("chasers", "chasers"))
    with pytest.raises(ValueError, match="protocol B takes no targets"):
        ExperimentConfig(protocol="B", targets=("chasers",))
    with pytest.raises(ValueError, match=r"ExperimentConfig\.targets must be a list"):
        ExperimentConfig(teams=SOURCES, targets=("chasers", ""))
    args = parser().parse_args(["--teams", *SOURCES, "--targets", *TARGETS, "--out", "x"])
    assert build_config(args).streams(0) == cfg.streams(0)
    assert ExperimentConfig.from_dict(json.loads(cfg.to_json())) == cfg


@pytest.mark.slow
def test_several_targets_learn_the_sources_once_and_equal_one_run_per_target(
    tmp_path, monkeypatch
):
    cfg = _several()
    trials = _count_trials(monkeypatch)
    several = run_experiment(cfg, tmp_path / "several", progress=False)
    lifelong = [m for m in cfg.methods if isinstance(METHODS.get(m), LifelongMethod)]
    # Per seed and lifelong method: each source once, each target once.
    for name in (*SOURCES, *TARGETS):
        assert trials.count(name) == cfg.n_seeds * len(lifelong), name
    for target_index, target in enumerate(TARGETS, start=len(SOURCES)):
        alone = cfg.with_overrides(teams=(*SOURCES, target), targets=())
        single = run_experiment(alone, tmp_path / target, progress=False)
        for mine, theirs in zip(several, single, strict=True):
            for method in cfg.methods:
                curve = mine["methods"][method]["curves"][str(target_index)]
                assert curve == theirs["methods"][method]["curves"][str(len(SOURCES))]
                if method in lifelong:  # the series at the sources and at this target
                    for key, values in theirs["methods"][method].items():
                        if key != "curves":
                            got = mine["methods"][method][key]
                            assert [*got[:len(SOURCES)], got[target_index]] == values, key
    # Not a vacuous equality: the targets' curves differ, and some episode succeeds.
    curves = several[0]["methods"]["ilpss"]["curves"]
    assert curves["2"] != curves["3"]
    assert max(max(r["methods"]["scratch"]["curves"]["3"]) for r in several) > 0


def _crashed(tmp_path, monkeypatch, crash):
    """A one-seed run of ILPSS and learning anew killed at the first trial for which
    ``crash(learner, task_name)`` holds; the configuration, the uninterrupted run's
    result, the crashed run's folder and its job folder."""
    cfg = _several().with_overrides(methods=("ilpss", "scratch"), n_seeds=1)
    straight = run_experiment(cfg, tmp_path / "straight", progress=False)
    real = LifelongLearner.run_trial

    def crashing(self, env, name, callback=None):
        if crash(self, name):
            raise KeyboardInterrupt("killed")
        return real(self, env, name, callback)

    monkeypatch.setattr(LifelongLearner, "run_trial", crashing)
    out = tmp_path / "crashed"
    with pytest.raises(KeyboardInterrupt):
        run_experiment(cfg, out, progress=False)
    monkeypatch.setattr(LifelongLearner, "run_trial", real)
    return cfg, straight, out, out / "seed_000" / "stream_00"


def _resumed(cfg, out, monkeypatch):
    """The crashed run run again: the trials it ran, its job's record and its result."""
    trials = _count_trials(monkeypatch)
    done = []
    resumed = run_experiment(cfg, out, progress=False, on_done=lambda s, d: done.append(d))
    return trials, done[0], resumed


@pytest.mark.slow
def test_a_crash_after_the_first_target_resumes_without_relearning_the_sources(
    tmp_path, monkeypatch
):
    cfg, straight, out, job = _crashed(tmp_path, monkeypatch,
                                       lambda learner, name: name == TARGETS[1])
    assert (job / "ilpss" / "target_02" / "LATEST").exists()
    assert not (job / "ilpss" / "target_03").exists() and not (job / "result.json").exists()

    trials, done, resumed = _resumed(cfg, out, monkeypatch)
    # ILPSS resumes: no source, no finished target again; learning anew had not started.
    assert trials == [TARGETS[1], *SOURCES, *TARGETS]
    assert done.resumed == {"ilpss": len(SOURCES) + 1, "scratch": 0}
    assert resumed == straight
    assert (job / "result.json").read_bytes() == (
        tmp_path / "straight" / "seed_000" / "stream_00" / "result.json").read_bytes()
    # A target's checkpoint moved to another target's folder is refused, by name.
    (job / "result.json").unlink()
    branch = job / "ilpss" / "target_03"
    shutil.rmtree(branch)
    shutil.copytree(job / "ilpss" / "target_02", branch)
    with pytest.raises(JobError, match=r"CheckpointRefused: .*target_03: the checkpoint comes from another run "
                                         r"\(target: 2 saved, 3 here\)"):
        run_experiment(cfg, out, progress=False)


@pytest.mark.slow
def test_a_crash_after_every_target_resumes_them_all_from_their_checkpoints(
    tmp_path, monkeypatch
):
    # Killed in the next method, once every target of the first has its checkpoint: the
    # resumed job takes each finished target from its own checkpoint, the second as well
    # as the first (each compared with the state after the sources only).
    cfg, straight, out, job = _crashed(
        tmp_path, monkeypatch, lambda learner, name: learner.provenance["method"] == "scratch")
    for index in range(len(SOURCES), len(SOURCES) + len(TARGETS)):
        assert (job / "ilpss" / f"target_{index:02d}" / "LATEST").exists()

    trials, done, resumed = _resumed(cfg, out, monkeypatch)
    assert trials == [*SOURCES, *TARGETS]  # learning anew only
    assert done.resumed == {"ilpss": len(SOURCES) + len(TARGETS), "scratch": 0}
    assert resumed == straight


@pytest.mark.slow
def test_the_report_and_the_results_page_are_per_target_and_pooled(tmp_path):
    runs, docs = tmp_path / "runs", tmp_path / "docs"
    argv = ["--runs", str(runs), "--docs", str(docs), "--protocols", "A", *TINY,
            "--teams", *SOURCES, "--targets", *TARGETS, "--workers", "1", "--quiet"]
    assert results_main(argv) == 0
    report = (runs / "protocol_a" / "report.md").read_text()
    assert report.count("## Pooled over the targets (primary)") == 1
    assert "Holm's adjustment" in report and "2 looks after one history" in report
    for target, index in zip(TARGETS, (2, 3), strict=True):
        assert f"## Target `{target}`" in report
        assert f"| `{target}` |" in report  # its descriptive row in every method's table
        assert (runs / "protocol_a" / f"curves_00_{index:02d}.png").stat().st_size > 0
        assert "Descriptive (one target, unadjusted)" in report
    page = (docs / "results.md").read_text()
    assert "each of the held-out teams `goal_guards`, `chasers`" in page
    assert "### Verdicts" in page and "per target (descriptive)" in page
    assert "options offered / used / active at `chasers`" in page
    for name in re.findall(r"\]\((figures/[^)]+)\)", page):
        assert (docs / name).stat().st_size > 0
    assert "figures/protocol_a_curves_03.png" in page
    assert "figures/ilpss_vs_goal_guards.gif" in page  # the first target's agent
    # The page's command names the targets and regenerates the page without running again.
    (command,) = re.findall(r"Regenerate the whole page .*?: `([^`]+)`", page)
    assert "--targets goal_guards chasers" in command
    results = sorted(runs.glob("protocol_a/seed_*/stream_*/result.json"))
    mtimes = [f.stat().st_mtime_ns for f in results]
    assert results_main([*shlex.split(command)[1:], "--workers", "1", "--quiet"]) == 0
    assert [f.stat().st_mtime_ns for f in results] == mtimes
    # The report is computed from the numbers kept beside the page: the finished jobs read
    # back, rounded as the data keeps them, and written again give the same report.
    cfg = _several()
    again = run_experiment(cfg, runs / "protocol_a", progress=False)
    kept = SeedData.read(docs / "data" / "results")
    for job, read in zip(kept.results("A"), again, strict=True):
        assert list(job["methods"]) == list(read["methods"])  # in the run's order
        for name, entry in read["methods"].items():
            for target, curve in entry["curves"].items():
                assert job["methods"][name]["curves"][target] == pytest.approx(curve, abs=1e-4)
    (tmp_path / "report").mkdir()
    write_report(cfg, kept.results("A"), tmp_path / "report", command="x")
    assert (tmp_path / "report" / "report.md").read_text().split("## Pooled")[1] == \
        report.split("## Pooled")[1]


@pytest.mark.slow
def test_a_finished_job_with_targets_past_index_nine_is_read_back(tmp_path):
    cfg = ExperimentConfig(protocol="C", stream_length=11, n_seeds=1, workers=1,
                           methods=("scratch",)).with_overrides(
        lifelong={"train_episodes": 2, "rollout_episodes": 1})
    first = run_experiment(cfg, tmp_path, progress=False)
    assert sorted(first[0]["methods"]["scratch"]["curves"], key=int) == [
        str(t) for t in range(1, 11)]
    assert run_experiment(cfg, tmp_path, progress=False) == first  # read back, checked


@pytest.mark.parametrize(("name", "default", "value"), [
    ("step_targets", "every_choice", "available_choices"),
    ("value_bounds", None, (-1.0, 1.0)),
    ("option_traces", "kept", "cut"),
])
def test_a_learner_setting_added_later_is_recorded_only_when_set(name, default, value):
    # Runs made before the setting existed computed what its default computes: their
    # records stay the records of the same configuration, so they resume and report.
    base = ExperimentConfig()
    assert name not in base.results_record()["lifelong"]["learner"]
    learner = replace(base.lifelong.learner, **{name: value})
    changed = replace(base, lifelong=replace(base.lifelong, learner=learner))
    recorded = changed.results_record()["lifelong"]["learner"][name]
    assert recorded == (list(value) if isinstance(value, tuple) else value)
    assert base.to_dict()["lifelong"]["learner"][name] == default

