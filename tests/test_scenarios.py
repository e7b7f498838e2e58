"""The named scenarios: made by id, checked by Gymnasium's and PettingZoo's own tests."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test

import soccer_drill
from soccer_drill import scenarios
from soccer_drill.scenarios import SCENARIOS

NAMES = sorted(SCENARIOS)


@pytest.mark.parametrize("name", NAMES)
def test_a_scenario_is_made_by_its_gymnasium_id_and_passes_the_checker(name: str) -> None:
    s = SCENARIOS[name]
    env = gym.make(s.gym_id, config={"max_cycles": 40})
    assert env.unwrapped.config.size == (s.attackers, s.defenders)
    assert env.unwrapped.config.task == s.task
    k, d = s.attackers, s.defenders
    if s.task == "keepaway":  # HOLD and a pass per keeper; keepaway's state variables
        assert env.action_space.n == k
        assert env.observation_space.shape == (4 * k + 2 * d - 3,)
    else:  # HOLD, a pass per teammate, DRIBBLE; the drill's features
        assert env.action_space.n == k + 1
        assert env.observation_space.shape == (4 * (k - 1) + d + 3,)
    check_env(env.unwrapped, skip_render_check=True)
    vector = gym.make_vec(s.gym_id, num_envs=2, config={"max_cycles": 40})
    obs, _ = vector.reset(seed=0)
    assert obs.shape == (2, *env.observation_space.shape)


@pytest.mark.parametrize("name", NAMES)
def test_a_scenario_passes_pettingzoos_tests(name: str) -> None:
    config = {"max_cycles": 25}
    api_test(scenarios.env(name, config=config), num_cycles=25)
    parallel_api_test(scenarios.parallel_env(name, config=config), num_cycles=25)
    parallel_seed_test(lambda: scenarios.parallel_env(name, config=config), num_cycles=10)
    par = scenarios.parallel_env(name, render_mode="rgb_array")
    par.reset(seed=0)
    assert par.render().dtype == np.uint8
    holder = scenarios.holder_env(name, render_mode="rgb_array")
    holder.reset(seed=0)
    assert holder.render().dtype == np.uint8


def test_keepaways_parallel_env_pays_the_keepers_each_cycles_seconds() -> None:
    par = scenarios.parallel_env("keepaway_3v2", opponent="keepaway_takers",
                                 illegal_action="default")
    par.reset(seed=1)
    total, cycles = 0.0, 0
    while par.agents:  # the holder holds, the others take their default (GET_OPEN)
        _, rewards, _, _, _ = par.step({a: 0 for a in par.agents})
        total += rewards["attacker_0"]
        cycles += 1
    assert total == pytest.approx(0.1 * cycles)


def test_the_paper_drill_is_the_default_holder_env() -> None:
    a = gym.make("soccer_drill/Holder-v0").unwrapped
    b = scenarios.holder_env("drill_2v2")
    assert a.config == b.config
    assert np.array_equal(a.reset(seed=4)[0], b.reset(seed=4)[0])


def test_a_scenarios_id_makes_its_own_scenario_and_refuses_another_name() -> None:
    """Before, ``gym.make("soccer_drill/Holder1v1-v0", name="drill_3v3")`` made a 3v3 drill
    whose spec still said Holder1v1-v0 (the id kept its scenario in an argument)."""
    with pytest.raises(TypeError, match=r"Holder1v1-v0 makes the scenario 'drill_1v1'; it "
                                        r"takes no name \(got 'drill_3v3'\)"):
        gym.make("soccer_drill/Holder1v1-v0", name="drill_3v3")
    with pytest.raises(TypeError, match="makes the scenario 'keepaway_3v2'"):
        gym.make_vec("soccer_drill/Keepaway3v2-v0", num_envs=2,
                     vectorization_mode="vector_entry_point", name="drill_2v2")
    env = gym.make("soccer_drill/Keepaway3v2-v0", config={"max_cycles": 50})
    again = gym.make(gym.spec("soccer_drill/Keepaway3v2-v0").from_json(env.spec.to_json()))
    assert again.unwrapped.config == env.unwrapped.config
    assert again.unwrapped.config.task == "keepaway" and again.unwrapped.config.max_cycles == 50
    batched = gym.make_vec("soccer_drill/Holder3v2-v0", num_envs=2,
                           vectorization_mode="vector_entry_point")
    assert batched.config.attackers == 3


def test_an_unknown_scenario_is_refused_naming_the_known_ones() -> None:
    with pytest.raises(ValueError, match=r"scenario must be one of .*'drill_3v2'"):
        scenarios.parallel_env("drill_9v9")


def test_a_config_of_another_size_is_refused() -> None:
    with pytest.raises(ValueError, match=r"scenario 'drill_3v2' is drill 3v2; the config given is drill 2v2"):
        scenarios.holder_env("drill_3v2", config=soccer_drill.DrillConfig())


def test_the_scenarios_page_is_written_from_kept_per_seed_outcomes(tmp_path) -> None:
    import hashlib
    import json

    from soccer_drill import scenarios_table

    scenarios_table.main(["--episodes", "2", "--first-seed", "1000", "--out", str(tmp_path)])
    kept = json.loads((tmp_path / "data" / "scenarios_fixed_rules.json").read_text())
    record = kept["record"]
    body = json.dumps(record, sort_keys=True)
    assert kept["sha256"] == hashlib.sha256(body.encode()).hexdigest()
    assert record["schema_version"] == 2 and record["first_seed"] == 1000
    assert set(record["outcomes"]) | set(record["lengths"]) == set(SCENARIOS)
    assert set(record["lengths"]) == {"keepaway_3v2", "keepaway_4v3"}
    for kept in (record["outcomes"], record["lengths"]):
        assert all(len(got) == 2 for rules in kept.values() for got in rules.values())
    assert all(t > 0 for rules in record["lengths"].values() for got in rules.values()
               for t in got)
    page = (tmp_path / "scenarios.md").read_text()
    assert page == scenarios_table.page(record["outcomes"], 1000, record["lengths"])
    assert "| `drill_3v2` | 3v2 | drill | `soccer_drill/Holder3v2-v0` | `chasers` |" in page


def test_the_committed_scenarios_page_is_what_its_kept_outcomes_give(tmp_path) -> None:
    """docs/scenarios.md from docs/data's kept outcomes, no episode played; every
    scenario's row names where its learning curve is measured."""
    import shutil

    from soccer_drill import scenarios_table

    docs = Path(__file__).resolve().parents[1] / "docs"
    shutil.copytree(docs / "data", tmp_path / "data")
    scenarios_table.main(["--from-data", "--out", str(tmp_path)])
    page = (tmp_path / "scenarios.md").read_text()
    assert page == (docs / "scenarios.md").read_text()
    assert "not yet measured" not in page
    assert set(scenarios_table.LEARNING_CURVES) == set(SCENARIOS)


@pytest.mark.parametrize("argv, said", [
    (["--episodes", "0"], r"--episodes must be an integer in \[1, 100,000\], got 0"),
    (["--first-seed", "-1"], r"--first-seed must be an integer >= 0, got -1"),
    (["--out", "{file}"], r"cannot write '.*': '.*' is a file, not a folder"),
    (["--from-data"], r"--from-data cannot read '.*scenarios_fixed_rules.json': No such file"),
])
def test_the_scenarios_table_refuses_bad_arguments_as_usage_errors(tmp_path, capsys, argv, said):
    """A bad argument or output is said on one line, before any episode, and nothing is
    written (it was a traceback)."""
    import re

    from soccer_drill import scenarios_table

    blocker = tmp_path / "a_file"
    blocker.write_text("")
    argv = [a.format(file=blocker) for a in argv]
    if "--out" not in argv:
        argv += ["--out", str(tmp_path / "out")]
    with pytest.raises(SystemExit) as stopped:
        scenarios_table.main(argv)
    assert stopped.value.code == 2
    err = capsys.readouterr().err
    assert re.search(r"python -m soccer_drill.scenarios_table: error: " + said, err), err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]


def test_rules_that_score_alike_are_named_as_tied_with_the_best() -> None:
    # before, a rule tied with others on every episode was called the best alone
    from soccer_drill import scenarios_table

    docs = Path(__file__).resolve().parents[1] / "docs"
    record = scenarios_table.read_kept(docs / "data" / "scenarios_fixed_rules.json")
    outcomes = {name: dict(rules) for name, rules in record["outcomes"].items()}
    outcomes["drill_3v2"]["late_pass"] = outcomes["drill_3v2"]["lane"]
    page = scenarios_table.page(outcomes, record["first_seed"], record["lengths"])
    assert "| `lane` (tied with `late_pass`) | 82% [77%, 86%] |" in page
    assert "| `late_pass` | 80% [75%, 84%] |" in page  # drill_2v2: no tie


@pytest.mark.parametrize(("change", "said"), [
    (lambda r: r.pop("lengths"), r"missing field\(s\) \['lengths'\]"),
    (lambda r: r.update(first_seed="0"), "first_seed"),
])
def test_kept_outcomes_rewritten_with_their_digest_are_refused_in_one_line(tmp_path, capsys,
                                                                           change, said):
    # before, a field missing from numbers whose digest was recomputed ended in a KeyError
    # traceback
    import re

    from soccer_drill import scenarios_table
    from soccer_drill.files import read_digested_json, write_digested_json

    docs = Path(__file__).resolve().parents[1] / "docs"
    record = read_digested_json(docs / "data" / "scenarios_fixed_rules.json")
    change(record)
    write_digested_json(tmp_path / "data" / "scenarios_fixed_rules.json", record)
    with pytest.raises(SystemExit) as stopped:
        scenarios_table.main(["--from-data", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert stopped.value.code == 2 and re.search(said, err) and "Traceback" not in err
