"""ILPSS at any size of the drill, and the transfer across sizes by an inter-task mapping."""

from __future__ import annotations

import json

import numpy as np
import pytest

import soccer_drill.scenarios
from ilpss.experiments import drill_facts
from ilpss.experiments.cli import build_config, parser
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.cross_size import keepaway_mapping
from ilpss.experiments.drill_facts import holder_drill
from ilpss.experiments.run import run_experiment
from ilpss.policy import FrozenPolicy
from ilpss.tiles import TileCoder
from ilpss.transfer import map_policy

PILOT_METHODS = ("scratch", "finetune", "whole_policies", "ilpss", "transfer_2v2")


# ---------------------------------------------------------------- the drill's facts
def test_the_paper_drill_gives_exactly_the_facts_ilpss_always_used() -> None:
    drill = holder_drill("drill_2v2")
    assert drill.env_id == drill_facts.ENV_ID
    assert drill.tile_widths == drill_facts.TILE_WIDTHS
    assert drill.action_names == drill_facts.ACTION_NAMES
    assert (drill.lateral, drill.goal_distance) == (drill_facts.LATERAL,
                                                    drill_facts.GOAL_DISTANCE)
    assert drill.episode_reward == drill_facts.EPISODE_REWARD


def test_a_larger_drill_has_keepaways_features_widths_and_actions() -> None:
    drill = holder_drill("drill_3v2")
    assert len(drill.feature_names) == 13 == 4 * 2 + 2 + 3
    assert drill.action_names == ("HOLD", "PASS_1", "PASS_2", "DRIBBLE")
    angles = [i for i, w in enumerate(drill.tile_widths) if w == drill_facts.ANGLE_WIDTH]
    assert [drill.feature_names[i] for i in angles] == ["pass_angle_1", "pass_angle_2",
                                                        "dribble_angle"]
    assert drill.feature_names[drill.goal_distance] == "dist_goal"
    assert drill.feature_names[drill.lateral] == "lateral"


@pytest.mark.parametrize("scenario", ["drill_1v1", "drill_3v2", "drill_3v3"])
def test_every_scenario_pays_what_the_bounded_methods_clip_to(scenario: str) -> None:
    # The bounded methods clip their targets to drill_facts.EPISODE_REWARD at every size.
    assert holder_drill(scenario).episode_reward == drill_facts.EPISODE_REWARD


def test_an_unknown_scenario_is_refused_naming_the_scenarios() -> None:
    with pytest.raises(ValueError, match=r"ExperimentConfig.scenario must be one of 'drill_2v2', "
                                         r".*'drill_3v2'.*, got 'drill_9v9'"):
        ExperimentConfig(scenario="drill_9v9")


def test_a_keepaway_scenario_is_not_taken_for_a_drill() -> None:
    # Keepaway's holder has other features and pays by the second: its own experiment.
    assert "keepaway_3v2" in soccer_drill.scenarios.SCENARIOS
    with pytest.raises(ValueError, match=r"ExperimentConfig.scenario must be one of .*"
                                         r"'drill_3v3'.*, got 'keepaway_3v2'"):
        ExperimentConfig(scenario="keepaway_3v2")


# ---------------------------------------------------------------- the configuration
def test_the_default_configuration_records_what_it_always_recorded() -> None:
    record = ExperimentConfig().results_record()
    assert "scenario" not in record
    assert record["env_id"] == drill_facts.ENV_ID
    assert record["lifelong"]["learner"]["tile_widths"] == list(drill_facts.TILE_WIDTHS)


def test_a_scenario_brings_its_holder_and_its_tile_widths_and_is_recorded() -> None:
    cfg = ExperimentConfig(scenario="drill_3v2")
    assert cfg.env_id == holder_drill("drill_3v2").env_id
    assert cfg.lifelong.learner.tile_widths == holder_drill("drill_3v2").tile_widths
    record = cfg.results_record()
    assert record["scenario"] == "drill_3v2"
    again = ExperimentConfig.from_dict(json.loads(json.dumps(record)))
    assert again.results_record() == record
    back = cfg.with_overrides(scenario="drill_2v2")
    assert back.results_record() == ExperimentConfig().results_record()


def test_the_command_line_takes_a_scenario() -> None:
    args = parser().parse_args(["--scenario", "drill_3v3", "--out", "x"])
    assert build_config(args).env_id == holder_drill("drill_3v3").env_id


@pytest.mark.parametrize("protocol", ["R", "S", "L"])
def test_the_protocols_of_the_2v2_drills_regions_refuse_another_size(protocol: str) -> None:
    with pytest.raises(ValueError, match=rf"protocol {protocol} is made for drill_2v2 only.*"
                                         r"got 'drill_3v2'"):
        ExperimentConfig(protocol=protocol, scenario="drill_3v2", methods=("scratch",))


@pytest.mark.parametrize("method", ["ilpss_ft_oracle", "true_regions_ft_bounded_cut_primitives",
                                    "assigned_regions_ft_bounded_cut_primitives"])
def test_the_oracles_refuse_another_size(method: str) -> None:
    with pytest.raises(ValueError, match=rf"{method}.*made for drill_2v2 only.*'drill_3v2'"):
        ExperimentConfig(scenario="drill_3v2", methods=("scratch", method))


def test_widths_of_another_length_or_another_environment_are_refused() -> None:
    with pytest.raises(ValueError, match=r"tile_widths: scenario 'drill_3v2' has 13 "
                                         r"features .*got 2 widths"):
        ExperimentConfig(scenario="drill_3v2").with_overrides(
            lifelong={"learner": {"tile_widths": [1.0, 2.0]}})
    with pytest.raises(ValueError, match=r"env_id 'CartPole-v1' is not the drill's"):
        ExperimentConfig(scenario="drill_3v2", env_id="CartPole-v1")


# ---------------------------------------------------------------- the mapping
def test_keepaways_mapping_from_2v2_to_3v2_is_the_stated_one() -> None:
    source, target = holder_drill("drill_2v2"), holder_drill("drill_3v2")
    mapping = keepaway_mapping(source, target)
    named = {target.feature_names[j]: source.feature_names[f]
             for j, f in enumerate(mapping.features)}
    assert named == {
        "dist_mate_1": "dist_mate", "dist_mate_2": "dist_mate",
        "dist_opp_1": "dist_opp_near", "dist_opp_2": "dist_opp_far",
        "mate_1_dist_opp": "mate_dist_opp", "mate_2_dist_opp": "mate_dist_opp",
        "pass_angle_1": "pass_angle", "pass_angle_2": "pass_angle",
        "dist_goal": "dist_goal", "lateral": "lateral",
        "mate_1_dist_goal": "mate_dist_goal", "mate_2_dist_goal": "mate_dist_goal",
        "dribble_angle": "dribble_angle"}
    assert [(target.action_names[a], source.action_names[b])
            for a, b in enumerate(mapping.actions)] == [
        ("HOLD", "HOLD"), ("PASS_1", "PASS"), ("PASS_2", "PASS"), ("DRIBBLE", "DRIBBLE")]


def test_a_novel_opponent_is_mapped_to_the_farthest_old_one_and_a_size_to_itself() -> None:
    source, target = holder_drill("drill_3v2"), holder_drill("drill_3v3")
    mapping = keepaway_mapping(source, target)
    named = [(target.feature_names[j], source.feature_names[f])
             for j, f in enumerate(mapping.features)]
    assert ("dist_opp_3", "dist_opp_2") in named
    assert mapping.actions == (0, 1, 2, 3)
    same = keepaway_mapping(source, source)
    assert same.features == tuple(range(13)) and same.actions == (0, 1, 2, 3)


def test_a_drill_with_teammates_cannot_be_mapped_from_one_without() -> None:
    with pytest.raises(ValueError, match=r"drill_2v2's holder has 1 teammate\(s\) and "
                                         r"drill_1v1's none"):
        keepaway_mapping(holder_drill("drill_1v1"), holder_drill("drill_2v2"))


def _small_coders() -> tuple[TileCoder, TileCoder]:
    """A source of 3 variables (a teammate's distance, an opponent's, an angle) and a target
    with a second teammate: 4 variables, the first two both mapped to the source's first."""
    source = TileCoder([0.0, 0.0, 0.0], [10.0, 10.0, 180.0], [3.0, 3.0, 10.0], n_tilings=4)
    target = TileCoder([0.0, 0.0, 0.0, 0.0], [10.0, 10.0, 10.0, 180.0], [3.0, 3.0, 3.0, 10.0],
                       n_tilings=4)
    return source, target


def test_a_mapped_policy_holds_the_mapped_weights_variable_by_variable() -> None:
    source, target = _small_coders()
    rng = np.random.default_rng(0)
    policy = FrozenPolicy(source, 3, (), rng.normal(size=(3, source.n_weights)))
    features, actions = (0, 0, 1, 2), (0, 1, 1, 2)  # HOLD, two passes to one, DRIBBLE
    mapped = map_policy(policy, target, features, actions)
    assert (mapped.n_primitive, mapped.tile_coder) == (4, target)
    for j, f in enumerate(features):
        for a, b in enumerate(actions):
            np.testing.assert_array_equal(mapped.weights[a, target.feature_tiles(j)],
                                          policy.weights[b, source.feature_tiles(f)])


def test_a_transferred_policy_gives_the_mapped_greedy_actions() -> None:
    # The source's values depend on the variables mapped one to one (the opponent, the
    # angle): at any target state, the target's greedy action is one the source's greedy
    # action at the corresponding state maps to (the two passes tie).
    source, target = _small_coders()
    rng = np.random.default_rng(1)
    weights = rng.normal(size=(3, source.n_weights))
    weights[:, source.feature_tiles(0)] = 0.0  # the teammate's variable, mapped twice
    policy = FrozenPolicy(source, 3, (), weights)
    features, actions = (0, 0, 1, 2), (0, 1, 1, 2)
    mapped = map_policy(policy, target, features, actions)
    states = np.column_stack([rng.uniform(0, 10, (200, 3)), rng.uniform(0, 180, 200)])
    choices = set()
    for state in states:
        source_state = state[[0, 2, 3]]
        best = int(np.argmax(policy.q_values(source_state)))
        q = mapped.q_values(state)
        mine = {a for a in range(4) if q[a] == q.max()}
        assert mine == {a for a, b in enumerate(actions) if b == best}
        np.testing.assert_allclose(q[[0, 1, 3]], policy.q_values(source_state))
        choices.add(best)
    assert choices == {0, 1, 2}  # every action is greedy somewhere: the check has teeth


def test_a_variable_tiled_otherwise_than_its_source_is_refused() -> None:
    source, _ = _small_coders()
    target = TileCoder([0.0, 0.0], [10.0, 20.0], [3.0, 3.0], n_tilings=4)
    policy = FrozenPolicy(source, 2)
    with pytest.raises(ValueError, match=r"target variable 1 \(range \[0, 20\], width 3, 4 "
                                         r"tilings\) is mapped to source variable 1, tiled "
                                         r"otherwise \(range \[0, 10\]"):
        map_policy(policy, target, (0, 1), (0, 1))
    with pytest.raises(ValueError, match="mapped to source action 2, and the source has 2"):
        map_policy(policy, TileCoder([0.0], [10.0], [3.0], n_tilings=4), (0,), (0, 2))


def test_the_drills_holders_are_tiled_alike_where_the_mapping_joins_them() -> None:
    import gymnasium as gym

    from ilpss.smdp import LearnerConfig

    coders = {}
    for scenario in ("drill_2v2", "drill_3v2"):
        drill = holder_drill(scenario)
        space = gym.make(drill.env_id, disable_env_checker=True).observation_space
        coders[scenario] = LearnerConfig(tile_widths=drill.tile_widths).tile_coder(space)
    mapping = keepaway_mapping(holder_drill("drill_2v2"), holder_drill("drill_3v2"))
    policy = FrozenPolicy(coders["drill_2v2"], 3)
    assert map_policy(policy, coders["drill_3v2"], mapping.features,
                      mapping.actions).n_primitive == 4


# ---------------------------------------------------------------- runs
@pytest.mark.slow
def test_protocol_a_runs_every_method_at_3v3_and_the_transfer_at_2v2_is_fine_tuning(
        tmp_path) -> None:
    tiny = {"n_seeds": 1, "workers": 1, "teams": ("interceptors_press", "goal_guards"),
            "lifelong": {"train_episodes": 4, "rollout_episodes": 2}}
    larger = ExperimentConfig(scenario="drill_3v3", methods=PILOT_METHODS).with_overrides(**tiny)
    (job,) = run_experiment(larger, tmp_path / "3v3", progress=False)
    assert set(job["methods"]) == set(PILOT_METHODS)
    assert json.loads((tmp_path / "3v3" / "config.json").read_text())["scenario"] == "drill_3v3"
    # At the source's own size the mapping is the identity: the transfer is fine-tuning
    # from the latest source, episode for episode (its sources are learning anew's).
    paper = ExperimentConfig(methods=("scratch", "finetune", "transfer_2v2")).with_overrides(
        **{**tiny, "lifelong": {"train_episodes": 12, "rollout_episodes": 2}})
    (job,) = run_experiment(paper, tmp_path / "2v2", progress=False)
    curves = job["methods"]
    assert curves["transfer_2v2"]["curves"] == curves["finetune"]["curves"]
    assert curves["transfer_2v2"]["curves"] != curves["scratch"]["curves"]


@pytest.mark.slow
def test_the_larger_drills_page_is_made_from_its_kept_numbers(tmp_path, capsys) -> None:
    from ilpss.experiments.larger_drill import main

    runs, docs = tmp_path / "runs", tmp_path / "docs"
    tiny = ["--seeds", "2", "--episodes", "4", "--rollouts", "2", "--workers", "1", "--quiet"]
    assert main(["--runs", str(runs), "--docs", str(docs), *tiny]) == 0
    text = (docs / "larger_drill.md").read_text()
    assert "## Protocol A in `drill_3v2`" in text
    assert "## Transfer across sizes: drill_2v2 to drill_3v2" in text
    assert "| `dist_mate_2` | `dist_mate` |" in text and "| action `PASS_2` | action `PASS` |" in text
    assert "all 2 seeds" in text
    assert "ilpss-larger-drill --seeds 2 --first-seed 0 --episodes 4 --rollouts 2" in text
    # The kept numbers give the same page, and the finished seeds of the folder too.
    for flags in (["--from-data", str(docs / "data" / "larger_drill")],
                  ["--runs", str(runs), "--finished", *tiny]):
        (docs / "larger_drill.md").unlink()
        assert main(["--docs", str(docs), *flags]) == 0
        assert (docs / "larger_drill.md").read_text() == text
    with pytest.raises(SystemExit):
        main(["--runs", str(runs), "--docs", str(docs), "--finished", "--seeds", "3"])
    assert "its run has another configuration than these flags give" in capsys.readouterr().err


@pytest.mark.parametrize("runs", ["a_file", "docs"])
def test_the_larger_drill_command_refuses_a_bad_runs_folder_in_one_line_making_nothing(
        tmp_path, monkeypatch, capsys, runs) -> None:
    # before, a --runs that is a file (or the --docs folder) ended in a traceback, after
    # --docs and its subfolders had been made
    from ilpss.experiments import larger_drill

    monkeypatch.chdir(tmp_path)
    (tmp_path / "a_file").write_text("x")
    with pytest.raises(SystemExit):
        larger_drill.main(["--runs", runs, "--docs", "docs", "--seeds", "2", "--episodes", "4",
                           "--rollouts", "2"])
    err = capsys.readouterr().err
    assert "Traceback" not in err and "error: --" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]


def test_numbers_that_cannot_be_read_make_no_folder(tmp_path, monkeypatch, capsys) -> None:
    # before, --from-data nosuch made the --docs folder and its subfolders, then failed
    from ilpss.experiments import larger_drill

    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit):
        larger_drill.main(["--from-data", "nosuch", "--docs", "docs"])
    assert "Traceback" not in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
