"""The kept jobs of ``soccer-drill-reference`` are checked field by field, and name the
learners' library versions; the command's usability (``--seeds 1``, ``--help``,
``--learning-page``, its docstring's example). No torch needed."""

from __future__ import annotations

import copy
import dataclasses
import json
from pathlib import Path

import pytest

from ilpss.experiments.kept_jobs import KeptJobs
from ilpss.experiments.provenance import MixedCodeError, code_record
from ilpss.reference import cli
from ilpss.reference.jobs import (
    LIBRARIES,
    Job,
    check_result,
    job_key,
    least_exploited,
    library_versions,
)
from ilpss.reference.settings import SETTINGS, EvalSettings

EV = EvalSettings(episodes=4)


def _curve(steps: int = 8192, rows: int = 3) -> list[list]:
    return [[float(steps * (k + 1)), 10.0 * (k + 1), -0.25, 0.5, 4.0] for k in range(rows)]


def _holder_key() -> dict:
    job = Job("ppo", dataclasses.replace(SETTINGS["ppo"], ppo=dataclasses.replace(
        SETTINGS["ppo"].ppo, steps=3 * 8192)), 0, "chasers", (), EV)
    return job_key(job)


def _holder_result() -> dict:
    return {"curve": _curve(), "eval": {"chasers": [-1.0, 0.75, 1.0, 0.5]}}


def _marl_key(side: str = "attackers") -> tuple[dict, dict]:
    s = dataclasses.replace(SETTINGS["mappo" if side == "attackers" else "defenders"])
    s = dataclasses.replace(s, ppo=dataclasses.replace(s.ppo, steps=3 * 8192))
    if side == "attackers":
        job = Job("mappo", s, 0, "chasers", (), EV)
        result = {"curve": _curve(), "eval": {"chasers": [-1.0, 0.9, -1.0, 1.0]},
                  "stochastic": {"chasers": [-1.0, -1.0, 0.6, 1.0]}}
    else:
        job = Job("defenders", s, 0, None, (), EV, ("early_pass", "dribble"))
        rewards = [-1.0, 0.9, -1.0, 1.0]
        result = {"curve": _curve(),
                  "eval": {"early_pass": rewards, "dribble": rewards},
                  "stochastic": {"early_pass": rewards, "dribble": rewards}}
    return job_key(job), result


def test_a_result_the_job_returns_is_accepted():
    check_result("r", _holder_key(), _holder_result())
    for side in ("attackers", "defenders"):
        check_result("r", *_marl_key(side))


@pytest.mark.parametrize("change, message", [
    # an evaluation reward the drill never pays (-10.9 was accepted: it lay within the
    # reward option's range, although no reward option is set, and evaluations are the drill's)
    (lambda r: r["eval"]["chasers"].__setitem__(0, -10.9), "not an episode reward of the drill"),
    (lambda r: r["eval"]["chasers"].__setitem__(0, 0.2), "not an episode reward of the drill"),
    (lambda r: r["eval"]["chasers"].__setitem__(0, True), "not an episode reward of the drill"),
    # a curve's mean reward of 1e300
    (lambda r: r["curve"][1].__setitem__(2, 1e300), "is not one the drill's rewards can give"),
    (lambda r: r["curve"][1].__setitem__(2, 0.9), "is not one the drill's rewards can give"),
    # steps going backwards, or seconds
    (lambda r: r["curve"][2].__setitem__(0, 100.0), "steps must rise"),
    (lambda r: r["curve"][2].__setitem__(1, 1.0), "seconds never fall"),
    (lambda r: r["curve"][1].__setitem__(4, 2.5), "episodes must be a count"),
    (lambda r: r["curve"][1].__setitem__(4, 0.0), "null exactly when no episode ended"),
    (lambda r: r["curve"].pop(), "before the budget"),
    # unknown fields, anywhere
    (lambda r: r.__setitem__("extra", 1), "unknown: ['extra']"),
    (lambda r: r["eval"].__setitem__("goal_guards", [-1.0] * 4), "unknown: ['goal_guards']"),
    (lambda r: r.pop("eval"), "missing: ['eval']"),
])
def test_a_kept_result_its_job_cannot_have_returned_is_refused(change, message):
    result = copy.deepcopy(_holder_result())
    change(result)
    with pytest.raises(ValueError, match="r"):
        try:
            check_result("r", _holder_key(), result)
        except ValueError as exc:
            assert message in str(exc), exc
            raise


def test_self_play_crossplay_and_fields_are_checked():
    s = dataclasses.replace(SETTINGS["self_play"], crossplay_episodes=5)
    s = dataclasses.replace(s, marl=dataclasses.replace(
        s.marl, ppo=dataclasses.replace(s.marl.ppo, steps=3 * 8192)), snapshots=2)
    key = job_key(Job("self_play", s, 0, None, ("chasers",), EV, ("dribble",)))
    ev = {"chasers": [-1.0] * 4, "self_play": [1.0] * 4}
    result = {"curve": _curve(), "eval": ev, "untrained_eval": ev,
              "defence": {"dribble": [0.5] * 4}, "untrained_defence": {"dribble": [0.5] * 4},
              "crossplay": [[0, 5], [3, 1]]}
    check_result("r", key, result)
    for bad in ([[0, 6], [3, 1]], [[0, 5]], [[0, 5], [3, -1]], [[0, 5], [3, 1.5]]):
        with pytest.raises(ValueError, match="table of success counts"):
            check_result("r", key, {**result, "crossplay": bad})


@pytest.mark.parametrize("crossplay, kept", [
    # the last attackers beat the last defenders most, but an earlier pair holds up
    # best against every trained opponent: attackers 2 (fewest 6), defenders 1 (most 7)
    ([[0, 0, 0, 0], [9, 5, 7, 2], [9, 7, 6, 8], [9, 3, 9, 9]], (2, 1)),
    # ties go to the later checkpoint; the untrained row and column count for nothing
    ([[0, 0, 0], [0, 4, 4], [9, 4, 4]], (2, 2)),
    ([[9, 9, 0], [0, 1, 5], [0, 5, 1]], (2, 2)),
])
def test_least_exploited_keeps_each_sides_sturdiest_trained_checkpoint(crossplay, kept):
    assert least_exploited(crossplay) == kept


def test_a_kept_self_play_result_names_the_checkpoints_its_rule_keeps():
    s = dataclasses.replace(SETTINGS["self_play_pfsp_long_kept"], crossplay_episodes=9,
                            snapshots=3)
    s = dataclasses.replace(s, marl=dataclasses.replace(
        s.marl, ppo=dataclasses.replace(s.marl.ppo, steps=3 * 8192)))
    key = job_key(Job("self_play_pfsp_long_kept", s, 0, None, ("chasers",), EV, ("dribble",)))
    ev = {"chasers": [-1.0] * 4, "self_play": [1.0] * 4}
    result = {"curve": _curve(), "eval": ev, "untrained_eval": ev,
              "defence": {"dribble": [0.5] * 4}, "untrained_defence": {"dribble": [0.5] * 4},
              "crossplay": [[0, 0, 0], [9, 3, 8], [9, 5, 6]], "kept": [2, 1]}
    check_result("r", key, result)
    with pytest.raises(ValueError, match="not the checkpoints the 'least_exploited' rule"):
        check_result("r", key, {**result, "kept": [2, 2]})
    with pytest.raises(ValueError, match=r"missing: \['kept'\]"):
        check_result("r", key, {k: v for k, v in result.items() if k != "kept"})


def test_the_key_and_the_recorded_code_name_the_learners_library_versions(tmp_path):
    key = _holder_key()
    assert set(key["libraries"]) == set(LIBRARIES) == {"torch", "stable-baselines3",
                                                        "sb3-contrib"}
    assert key["libraries"] == library_versions()
    old = {**library_versions(), "torch": "0.0.1"}
    KeptJobs(tmp_path, libraries=old).save("reference", key, {"x": 1})
    record = json.loads(next(tmp_path.glob("reference-*.json")).read_text())
    assert record["code"]["libraries"] == dict(sorted(old.items()))
    assert record["code"]["source_digest"] == code_record()["source_digest"]
    # the same sources with another torch: other code, refused unless mixing is allowed
    with pytest.raises(MixedCodeError, match=r"torch 0\.0\.1"):
        KeptJobs(tmp_path, libraries=library_versions()).load("reference", key)
    assert KeptJobs(tmp_path, libraries=old).load("reference", key) == {"x": 1}


def test_one_seed_is_a_run(tmp_path):
    every, per = cli.parse_seeds(["1"])
    assert every == 1 and not per
    args = cli.parser().parse_args(["--seeds", "1", "--keep", str(tmp_path / "k")])
    assert cli._check_flags(args) == dict.fromkeys(SETTINGS, 1)


def test_help_says_every_default_and_the_smallest_run():
    text = cli.parser().format_help()
    options = text[text.index("options:"):]
    workers = " ".join(options[options.index("--workers WORKERS"):options.index("--out OUT")].split())
    assert "each job uses one core" in workers and "(default: 2)" in workers
    assert "--settings mappo --teams goal_guards --seeds 1" in text
    assert "(1 or more)" in " ".join(text.split())


def test_the_learning_page_is_found_from_the_source_tree_not_the_current_folder(
        tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    args = cli.parser().parse_args([])
    assert cli._learning_page(args) == Path(cli.__file__).resolve().parents[2] / "docs" / "learning.md"
    assert cli._learning_page(args).is_file()
    missing = cli.parser().parse_args(["--learning-page", "docs/learning.md"])
    with pytest.raises(ValueError, match="no such file"):
        cli._check_flags(missing)


def test_the_docstring_example_writes_no_shipped_page():
    example = next(line for line in cli.__doc__.splitlines() if "soccer-drill-reference" in line)
    assert "--out" not in example and "docs/" not in example
    assert cli.parser().get_default("out").startswith("results/")


@pytest.mark.parametrize(("n_envs", "share", "drills"), [
    (80, 0.2, 8),  # self_play_league: 8 of each half's 40
    (64, 0.0, 0),  # no exploiters, the default
    (4, 0.2, 1),  # a share rounding to none still gives the exploiter a drill
    (4, 0.45, 1),  # and the main side keeps one
])
def test_the_exploiters_drills_are_a_share_of_each_half(n_envs, share, drills):
    from ilpss.reference.settings import MarlSetting, SelfPlaySetting
    marl = MarlSetting(ppo=dataclasses.replace(MarlSetting().ppo, n_envs=n_envs,
                                               batch_size=4 * n_envs))
    assert SelfPlaySetting(marl=marl, exploiter_share=share).exploiter_drills() == drills


@pytest.mark.parametrize("share", [-0.1, 0.5, float("nan")])
def test_an_exploiter_share_outside_its_range_is_refused(share):
    from ilpss.reference.settings import SelfPlaySetting
    with pytest.raises(ValueError, match=r"exploiter_share must be .*got"):
        SelfPlaySetting(exploiter_share=share)


def test_progress_past_the_budget_leaves_no_negative_time(capsys):
    # before, a job whose last rollout passed its budget printed "about -0.0 min of
    # training left"
    from ilpss.reference.jobs import _progress

    job = cli.make_jobs({"ppo": cli.SETTINGS["ppo"]}, ["chasers"], {"ppo": 1},
                        cli.EvalSettings(episodes=10))[0]
    report = _progress(job, 1)
    report(20_480, 20_000)
    line = capsys.readouterr().err
    assert "20,000 of 20,000 steps" in line and "about 0.0 min of training left" in line
