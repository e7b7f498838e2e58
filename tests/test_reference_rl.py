"""``soccer-drill-reference`` at a tiny size: it writes its page, figures and kept jobs,
a rerun computes nothing, the same seeds give the same numbers, and a changed setting is
computed again without taking the other's results.

The run needs torch (``pip install -e ".[integrations]"``, ``pytest -m integrations``);
the checks of the flags run in the default suite, without it.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from ilpss._io import load_json_record
from ilpss.experiments.kept_jobs import JOB_SCHEMA
from ilpss.reference import cli

TINY = ["--teams", "chasers", "--seeds", "2", "--eval", "10", "--workers", "2",
        "--ppo", "steps=256", "n_envs=4", "n_steps=64", "batch_size=128", "n_epochs=2",
        "--source-steps", "256", "--target-episodes", "40", "--window", "10",
        "--attacks", "early_pass", "dribble", "--crossplay-episodes", "4"]


def _run(capsys, tmp_path: Path, keep: str, *extra: str) -> tuple[int, int]:
    code = cli.main([*TINY, *extra, "--keep", str(tmp_path / keep),
                     "--out", str(tmp_path / f"{keep}.md"),
                     "--learning-page", str(Path(__file__).parent.parent / "docs" / "learning.md")])
    printed = capsys.readouterr().out
    assert code == 0, printed
    computed, loaded = re.search(r"(\d+) job\(s\) computed, (\d+) loaded", printed).groups()
    return int(computed), int(loaded)


def _records(folder: Path) -> dict[str, dict]:
    return {p.name: load_json_record(p, JOB_SCHEMA)
            for p in sorted(folder.glob("reference-*.json"))}


def _no_times(result: object) -> object:
    """A result without its wall times (the only values that differ between runs)."""
    if isinstance(result, dict):
        return {k: _no_times(v) for k, v in result.items() if k != "source_seconds"}
    if isinstance(result, list) and len(result) == 5 and all(
            x is None or isinstance(x, int | float) for x in result):
        return [result[0], *result[2:]]  # a curve row: [steps, seconds, ...]
    if isinstance(result, list):
        return [_no_times(v) for v in result]
    return result


@pytest.mark.integrations
def test_tiny_run_writes_resumes_is_deterministic_and_recomputes_a_changed_setting(
        tmp_path, capsys):
    for module in ("torch", "stable_baselines3", "sb3_contrib"):
        pytest.importorskip(module)
    # every setting: 2 seeds x (ppo, maskable_ppo, mappo, ippo on chasers; defenders;
    # self_play, self_play_pfsp, self_play_pfsp_long, self_play_pfsp_long_kept,
    # self_play_league; transfer)
    assert _run(capsys, tmp_path, "a") == (22, 0)
    page = (tmp_path / "a.md").read_text(encoding="utf-8")
    for name in cli.SETTINGS:
        assert f"## `{name}`" in page
        assert (tmp_path / "figures" / f"reference_{name}.png").stat().st_size > 1000
    assert "Budget: 256 decisions per training seed; 2 training seeds" in page
    assert "Budget: 256 environment steps per training seed" in page
    # 256 steps learn nothing: the page counts it, team by team
    assert "| chasers | 0 of 2 |" in page
    assert "Cross-play" in page and "| early_pass |" in page
    assert "prioritised fictitious self-play" in page and "Opponents drawn per rollout" in page
    assert "A main exploiter per side in 1 of each half's 2 drills" in page
    first = _records(tmp_path / "a")
    assert len(first) == 22
    # the rules against chasers, goal_guards (the transfer row's target) and, for the
    # defenders' bar, the paper's teams
    assert len(list((tmp_path / "a").glob("rule-*.json"))) == 5 * 9
    for record in first.values():
        assert record["code"]["source_digest"] and record["key"]["seed"] in (0, 1)
        assert record["code"]["libraries"] == record["key"]["libraries"]
    # the page's tables come from the summary beside it, alone
    from ilpss.reference.page import check_summary_tables, load_summary
    summary = load_summary(tmp_path / "a_seeds.json.gz")
    assert not check_summary_tables(summary, page)

    # a rerun computes nothing and leaves every record as it was
    assert _run(capsys, tmp_path, "a") == (0, 22)
    assert _records(tmp_path / "a") == first

    # the same seeds in another folder: the same numbers (wall times aside)
    assert _run(capsys, tmp_path, "b", "--settings", "ppo", "mappo", "self_play",
                "self_play_pfsp", "self_play_league", "transfer") == (12, 0)
    again = _records(tmp_path / "b")
    assert set(again) <= set(first)
    for name, record in again.items():
        assert _no_times(record["result"]) == _no_times(first[name]["result"]), name
    seeds = [r["result"]["eval"]["chasers"] for r in again.values()
             if r["key"]["name"] == "mappo"]
    assert len(seeds) == 2

    # a changed setting is computed again, and the old results stay as they were
    assert _run(capsys, tmp_path, "a", "--settings", "ppo", "--timeout-reward", "-1.5") == (2, 0)
    now = _records(tmp_path / "a")
    assert len(now) == 24 and all(now[name] == first[name] for name in first)
    changed = [r for name, r in now.items() if name not in first]
    assert all(r["key"]["setting"]["reward"]["timeout_reward"] == -1.5 for r in changed)
    assert "--timeout-reward -1.5" in (tmp_path / "a.md").read_text(encoding="utf-8")


@pytest.mark.parametrize("argv, message", [
    (["--ppo", "gama=0.9"], "KEY one of"),
    (["--ppo", "gamma=high"], "gamma takes a number"),
    (["--ppo", "gamma=2"], "PPOConfig.gamma must be a finite number in [0, 1]"),
    (["--ppo", "batch_size=100"], "must divide n_envs * n_steps"),
    (["--seeds", "0"], "--seeds must be at least 1"),
    (["--first-seed", "-1"], "--first-seed must be an integer >= 0, got -1"),
    (["--seeds", "5", "ppo=0"], "--seeds ppo=N must be at least 1, got 0"),
    (["--marl", "critic=both"], "MarlSetting.critic must be"),
    (["--marl", "shaping=-1"], "MarlSetting.shaping must be"),
    (["--marl", "mask_input=maybe"], "mask_input takes true or false"),
    (["--attacks", "no_such_attack"], "registered: "),
    (["--ray-address", "10.0.0.1:6379"], "--ray-address needs --executor ray"),
    (["--learning-page", "no/such/page.md"], "no such file"),
    (["--seeds", "5", "ppx=10"], "give SETTING=N with SETTING one of"),
    (["--seeds", "many"], "--seeds must start with a number of seeds"),
    (["--settings", "ppo", "--seeds", "5", "mappo=10"],
     "--seeds names ['mappo'], which --settings does not select"),
    # checked even when no selected setting reads it (it is on the page's command line)
    (["--settings", "ppo", "--marl", "critic=foo"], "MarlSetting.critic must be"),
    (["--teams", "chasers", "chasers"], "--teams must not repeat"),
    (["--timeout-reward", "5"], "timeout_reward must be None or a finite number in [-10, 1]"),
    (["--window", "3000"], "window (3000) must be at most half"),
    (["--teams", "no_such_team"], "no_such_team"),
])
def test_bad_flags_are_refused_naming_what_is_allowed(argv, message, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main([*argv, "--keep", str(tmp_path / "k"), "--out", str(tmp_path / "p.md")])
    assert exc.value.code == 2
    assert message in capsys.readouterr().err
    assert not list(tmp_path.glob("k/*.json"))


def test_seeds_per_setting_add_jobs_to_those_settings_only():
    ev = cli.EvalSettings(episodes=10)
    settings = {name: cli.SETTINGS[name] for name in ("ppo", "mappo", "transfer")}
    every, per = cli.parse_seeds(["2", "ppo=4"])
    jobs = cli.make_jobs(settings, ["chasers", "goal_guards"], {**dict.fromkeys(settings, every),
                                                               **per}, ev)
    counts = {name: sorted({j.seed for j in jobs if j.name == name}) for name in settings}
    assert counts == {"ppo": [0, 1, 2, 3], "mappo": [0, 1], "transfer": [0, 1]}
    assert len(jobs) == 4 * 2 + 2 * 2 + 2
    assert [j.seed for j in jobs] == sorted(j.seed for j in jobs)  # seed by seed


BLOCKED = """
import sys


class Absent:  # torch and SB3 fail to import, as where they are not installed
    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] in ("torch", "stable_baselines3", "sb3_contrib"):
            raise ImportError(f"No module named {name!r}")


sys.meta_path.insert(0, Absent())
from ilpss.reference import cli
try:
    cli.main(sys.argv[1:])
except SystemExit as exc:
    print("exit", exc.code)
"""


@pytest.mark.parametrize("argv, message", [
    (["--seeds", "0"], "--seeds must be at least 1"),
    (["--first-seed", "-1"], "--first-seed must be an integer >= 0, got -1"),
    (["--teams", "chasers", "--seeds", "1"], "pip install 'soccer-drill-ilpss[integrations]'"),
])
def test_without_torch_the_flags_are_checked_and_the_missing_extra_named(argv, message,
                                                                          tmp_path):
    run = subprocess.run([sys.executable, "-c", BLOCKED, *argv, "--keep", str(tmp_path / "k"),
                          "--out", str(tmp_path / "p.md")],
                         capture_output=True, text=True, check=False, cwd=tmp_path)
    assert "exit 2" in run.stdout, run.stderr[-2000:]
    assert message in run.stderr
    assert not (tmp_path / "k").exists()  # no folder made for a run that cannot start
    setting = json.loads(json.dumps(cli.dataclasses.asdict(cli.SETTINGS["ppo"])))
    assert setting["ppo"]["gamma"] == 1.0 and setting["reward"]["timeout_reward"] is None
    assert setting["timeout_terminal"] is True


@pytest.mark.integrations
@pytest.mark.parametrize("reward, terminal", [(None, True), (-1.5, False), (-1.5, True)])
def test_the_timeout_wrapper_changes_only_a_timeout(reward, terminal):
    pytest.importorskip("stable_baselines3")
    import numpy as np
    from gymnasium import spaces
    from stable_baselines3.common.vec_env import VecEnv

    from ilpss.reference.holder import TimeoutWrapper
    from ilpss.reference.settings import RewardOption

    class Ends(VecEnv):  # three drills: a timeout, an interception, one going on
        def __init__(self):
            super().__init__(3, spaces.Box(-1, 1, (1,)), spaces.Discrete(3))

        def reset(self):
            return np.zeros((3, 1), np.float32)

        def step_async(self, actions):
            pass

        def step_wait(self):
            infos = [{"outcome": "timeout", "TimeLimit.truncated": True},
                     {"outcome": "intercepted", "TimeLimit.truncated": False},
                     {"outcome": None, "TimeLimit.truncated": False}]
            return (np.zeros((3, 1), np.float32), np.array([-1.0, -1.0, 0.0], np.float32),
                    np.array([True, True, False]), infos)

        def get_attr(self, name, indices=None):
            return [None] * 3

        def env_is_wrapped(self, wrapper_class, indices=None):
            return [False] * 3

        close = set_attr = env_method = lambda *a, **k: None

    env = TimeoutWrapper(Ends(), RewardOption(reward), terminal)
    env.reset()
    _, rewards, dones, infos = env.step(np.zeros(3, np.int64))
    assert rewards.tolist() == [-1.0 if reward is None else reward, -1.0, 0.0]
    assert [i["TimeLimit.truncated"] for i in infos] == [not terminal, False, False]
    assert dones.tolist() == [True, True, False]


@pytest.mark.integrations
def test_the_ray_executor_gives_the_local_processes_numbers(tmp_path, capsys):
    for module in ("torch", "stable_baselines3", "sb3_contrib"):
        pytest.importorskip(module)
    ray = pytest.importorskip("ray")
    small = ["--settings", "mappo", "defenders", "--seeds", "1"]
    assert _run(capsys, tmp_path, "local", *small) == (2, 0)
    try:
        assert _run(capsys, tmp_path, "ray", *small, "--executor", "ray") == (2, 0)
    finally:
        ray.shutdown()
    local, remote = _records(tmp_path / "local"), _records(tmp_path / "ray")
    assert set(local) == set(remote)
    for name in local:
        assert _no_times(remote[name]["result"]) == _no_times(local[name]["result"]), name


def test_the_first_seed_moves_every_settings_seeds():
    ev = cli.EvalSettings(episodes=10)
    settings = {name: cli.SETTINGS[name] for name in ("mappo", "self_play")}
    jobs = cli.make_jobs(settings, ["chasers"], {"mappo": 2, "self_play": 3}, ev,
                         first_seed=1000)
    seeds = {name: sorted(j.seed for j in jobs if j.name == name) for name in settings}
    assert seeds == {"mappo": [1000, 1001], "self_play": [1000, 1001, 1002]}


@pytest.mark.integrations
def test_numbers_or_figures_over_the_page_are_refused_before_training(tmp_path, capsys):
    # before, --summary was never checked: the same path as --out lost the numbers to the
    # page after hours of training
    pytest.importorskip("sb3_contrib")
    page = tmp_path / "p.md"
    for flags, said in ((["--summary", str(page)], "its name ends in '.json.gz'"),
                        (["--figures", str(page)], "exists and is not a folder")):
        page.write_text("a page")
        with pytest.raises(SystemExit) as exit_info:
            cli.main(["--teams", "chasers", "--seeds", "2", "--keep", str(tmp_path / "k"),
                      "--out", str(page), *flags])
        assert exit_info.value.code == 2
        assert said in capsys.readouterr().err
