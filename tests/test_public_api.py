"""The declared public API: every ``__all__`` of the three packages, held by a snapshot.

Widening a package's surface is a decision made here, in review: add the name to
:data:`SNAPSHOT` (and keep the total under :data:`LIMIT`). A name a package uses only
inside itself stays out of ``__all__``; a test or a notebook may still import it by its
module path.
"""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("soccer_drill", "opponents", "ilpss")
LIMIT = 250
"""Fewer public names than this, in all (there were 401 in 44 lists before the stack was made one)."""
OPTIONAL = {"torch", "stable_baselines3", "ray"}
"""Extras a module may need to import; its names are checked where they are installed."""

SNAPSHOT: dict[str, list[str]] = {
    "ilpss._io": [
        "FolderInUseError", "atomic_write_bytes", "canonical_json", "check_inside",
        "json_differences", "json_record_bytes", "load_archive", "load_json_record",
        "load_npz", "locked_folder", "read_json", "read_regular", "release_inherited_locks",
        "remove_stale_temporaries", "save_figure", "save_npz_atomic", "sha256_file"
    ],
    "ilpss._schema": [
        "ArchiveSchema", "BOOL", "Checked", "FLOAT", "Field", "INTEGER", "MappingOf",
        "RowsSumToOne", "Symmetric", "TEXT"
    ],
    "ilpss.baselines": ["PrqConfig", "PrqLearner"],
    "ilpss.episode": [
        "DecisionLimitError", "EpisodeLog", "EpisodeResult", "EpisodicLearner", "check_env",
        "observation", "options_used", "step_duration"
    ],
    "ilpss.experiments.checkpoints": [
        "LocalStore", "StorageSettings", "UriStore", "checkpoint_store"
    ],
    "ilpss.experiments.config": ["ExperimentConfig"],
    "ilpss.experiments.confirm": ["analyse", "main", "pick"],
    "ilpss.experiments.folder": ["RunFolder", "checkpoint_key"],
    "ilpss.experiments.kept_jobs": ["KeptJobs", "run_kept"],
    "ilpss.experiments.methods": [
        "FineTuneMethod", "Job", "LifelongMethod", "METHODS", "Method", "MethodSettings",
        "PrqMethod", "lifelong_entry", "register_method"
    ],
    "ilpss.experiments.oracles": [
        "ASSIGNED_REGIONS_FINETUNE", "ORACLE_REGIONS_FINETUNE", "TRUE_REGIONS_FINETUNE",
        "TrueRegions"
    ],
    "ilpss.experiments.outputs": ["check_out_dir", "check_out_file"],
    "ilpss.experiments.plan": ["Plan"],
    "ilpss.experiments.power": [],
    "ilpss.experiments.protocols": [
        "Protocol", "Stream", "StreamSettings", "Task", "make_env", "register_protocol"
    ],
    "ilpss.experiments.provenance": ["check_same_code", "describe"],
    "ilpss.experiments.region_use": ["main", "region_use"],
    "ilpss.experiments.registry": [
        "ENV_PACKAGES", "SAMPLERS", "register_environment_package", "register_sampler"
    ],
    "ilpss.experiments.report": ["REPORT_BODIES", "register_report_body", "write_report"],
    "ilpss.experiments.run": [
        "JobDone", "JobSpec", "load_result", "run_experiment"
    ],
    "ilpss.experiments.sections": ["PAGE_SECTIONS"],
    "ilpss.experiments.seed_data": ["SeedData"],
    "ilpss.kernels": [
        "KernelModel", "RegionKernels", "SharedKernelModel", "UniformKernel",
        "kernel_distances", "match_kernels", "select_n_components"
    ],
    "ilpss.metrics": [
        "BELOW_MARGIN", "GAINS", "INTERVALS", "ImprovementTest", "METRIC", "METRICS",
        "Metric", "MetricEstimate", "Paired", "area_above_floor", "asymptotic_gain",
        "asymptotic_performance", "compare", "episodes_below", "fieller_interval",
        "format_metrics_markdown", "headline_metrics", "holm", "improvement_test",
        "jumpstart", "kaplan_meier", "km_median", "largest_dip", "mean_curve_band",
        "median_interval", "pairwise_metrics", "per_seed_gains",
        "percentile_bootstrap_interval", "restricted_mean_time", "sign_flip_pvalue",
        "smooth", "t_interval", "t_test_pvalue", "threshold_times", "time_to_threshold", "time_to_threshold_ratio",
        "total_reward", "total_reward_gain", "transfer_ratio", "trend_slopes",
        "wilson_interval"
    ],
    "ilpss.options": ["LibraryState", "OptionLibrary", "OptionSettings"],
    "ilpss.plots": ["plot_learning_curves"],
    "ilpss.policy": ["FrozenPolicy", "LinearPolicy", "epsilon_greedy_choice", "greedy_choice"],
    "ilpss.reference.holder": ["evaluate", "train", "transfer"],
    "ilpss.reference.jobs": [],
    "ilpss.reference.marl_ppo": ["train"],
    "ilpss.reference.page": [],
    "ilpss.reference.settings": ["HolderSetting", "PPOConfig", "SETTINGS"],
    "ilpss.reuse": [
        "BestOfPast", "EmKernels", "Fresh", "GivenRegions", "KernelSettings", "LatestPast",
        "OfferRule", "REUSES", "Regions", "Reuse", "StartRule", "Uniform", "learn_with",
        "register_reuse"
    ],
    "ilpss.smdp": ["KEEPAWAY", "LearnerConfig", "SMDP_CONSTRAINTS", "SmdpLearner"],
    "ilpss.statewise": ["StatewiseStart"],
    "ilpss.tiles": ["TileCoder"],
    "ilpss.traces": ["DivergedError"],
    "opponents": [
        "PAPER_TEAMS", "ParametricTeam", "Region", "RegionRule", "RegionTeam",
        "sample_opponents", "spec_label"
    ],
    "soccer_drill": [
        "Command", "DrillConfig", "DrillState", "DrillView", "HolderEnv", "PLAYER_NAMES",
        "Skill", "Team", "TeamError", "available_teams", "env", "make_team", "parallel_env",
        "raw_env", "register"
    ],
    "soccer_drill.constraints": [
        "AnyOf", "Bool", "Constraint", "Integer", "JsonObject", "ListOf", "Name", "NoneOr",
        "OneOf", "Real", "Text", "check", "check_fields", "check_keys", "checked", "from_json", "is_int",
        "is_real"
    ],
    "soccer_drill.files": [
        "TEMPORARY", "atomic_write_bytes", "atomic_write_text", "check_output_file"
    ],
    "soccer_drill.registry": ["PROJECT_DISTRIBUTION", "PluginWarning", "Registry"],
    "soccer_drill.rules.first_use": ["warm_up"],
    "soccer_drill.teams": [
        "BatchCommands", "BatchRandom", "BatchTeam", "BatchView", "FEATURE_NAMES",
        "GUARD_DEPTH", "PluginWarning", "STATE", "SameCommands", "broken_teams", "compiled",
        "describe", "every_drill", "hypot", "interception_point", "mark_target", "refresh",
        "roll_table", "rule_parameters", "state_record", "team_code", "team_ids", "warms"
    ],
    "soccer_drill.vector": ["HolderVectorEnv", "ParallelVectorEnv", "play_episodes"],
    "soccer_drill.vector.attack": ["ATTACKS", "HolderRuleAttack"],
    "soccer_drill.vector.sb3": ["HolderSB3VecEnv"],
}


def declared() -> dict[str, list[str]]:
    """Each module's ``__all__``, read from its source (no import needed)."""
    found = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            for node in ast.parse(path.read_text(encoding="utf-8")).body:
                targets = (node.targets if isinstance(node, ast.Assign)
                           else [node.target] if isinstance(node, ast.AnnAssign) else [])
                if any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets):
                    module = ".".join(path.relative_to(ROOT).with_suffix("").parts)
                    found[module.removesuffix(".__init__")] = sorted(
                        ast.literal_eval(node.value))
    return found


def test_every_all_is_the_snapshot():
    assert declared() == SNAPSHOT


def test_the_public_api_is_small():
    assert sum(map(len, SNAPSHOT.values())) < LIMIT


@pytest.mark.parametrize("module", sorted(SNAPSHOT))
def test_every_public_name_is_there(module):
    try:
        loaded = importlib.import_module(module)
    except ModuleNotFoundError as error:
        if error.name not in OPTIONAL:
            raise
        pytest.skip(f"{module} needs {error.name}")
    missing = [name for name in SNAPSHOT[module] if not hasattr(loaded, name)]
    assert missing == []
