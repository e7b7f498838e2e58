"""The modules' old paths, from before the subpackages, import as before: each as the very
module at its new path, with the names plugins and users took from it."""

from __future__ import annotations

import importlib
import pickle
import subprocess
import sys
from pathlib import Path

import pytest

import soccer_drill
from soccer_drill._moved import MOVED

# Names users and plugins import from an old path, by old path.
USED = {
    "soccer_drill.batch": ["BatchDrill", "OUTCOME_NAMES", "RUNNING", "rows"],
    "soccer_drill.batch_physics": ["BatchPhysics", "DRILLS_PER_SPACE", "check_drills_per_space"],
    "soccer_drill.batch_core": ["BatchCore", "check_num_envs", "check_seed"],
    "soccer_drill.batch_teams": ["BatchCommands", "BatchRandom", "BatchView", "BatchTeamDriver",
                                 "check_commands", "every_drill"],
    "soccer_drill.batch_render": ["BatchRenderer", "check_render_mode"],
    "soccer_drill.vector_agents": ["ParallelVectorEnv", "is_legal"],
    "soccer_drill.env": ["env", "parallel_env", "raw_env"],
    "soccer_drill.holder": ["HolderEnv", "check_decision_cycles", "check_holder_action"],
    "soccer_drill.core": ["DrillCore", "HOLDER_MASK", "concurrent_use"],
    "soccer_drill.features": ["FEATURE_NAMES", "features", "feature_bounds", "batch_features"],
    "soccer_drill.support": ["SupportPlayer", "support_commands_of_drills"],
    "soccer_drill.time_bound": ["Overrun", "call_within", "counted_cpu"],
    "soccer_drill.interruptions": ["MAX_ITEMS", "CtrlCDeferred", "delivered_by_signal",
                                   "short_repr"],
    "soccer_drill.screen": ["RENDER_MODES", "Screen", "frames_per_second"],
    "soccer_drill.video": ["RecordVideo"],
    "soccer_drill.gif": ["main", "record_episode", "save_gif", "write_episode_gif"],
    "soccer_drill.render": ["MAX_SIDE", "Renderer", "surface_pixels"],
    "soccer_drill.drill": ["Drill", "OUTCOMES", "space_step"],
    "soccer_drill.teams": ["DEFAULT_TEAM_TIMEOUT", "PluginWarning", "Team", "TeamDriver",
                           "TeamError", "available_teams", "broken_teams", "check_commands",
                           "describe", "make_team", "refresh", "register", "resolve_team",
                           "team_code", "team_ids"],
    "soccer_drill.vector": ["HolderVectorEnv", "ParallelVectorEnv", "check_drill_indices",
                            "first_non_integer", "play_episodes"],
}


@pytest.mark.parametrize("old", sorted(USED))
def test_an_old_path_imports_with_the_names_taken_from_it(old):
    module = importlib.import_module(old)
    for name in USED[old]:
        assert hasattr(module, name), (old, name)
    if old in MOVED:
        assert module is importlib.import_module(MOVED[old])
        assert sys.modules[old] is module


def test_every_moved_module_is_listed_and_none_is_left_behind():
    assert set(MOVED) <= set(USED) | {"soccer_drill.sb3"}
    package = Path(soccer_drill.__path__[0])
    for old in MOVED:
        assert not (package / f"{old.rpartition('.')[2]}.py").exists(), old


def test_the_functions_named_like_old_modules_stay_functions():
    import soccer_drill.env

    assert callable(soccer_drill.env) and soccer_drill.env.__name__ == "env"


def test_old_paths_import_in_a_fresh_process_in_any_order_and_unpickle():
    """What a user's script or a pickle made before the move does: name an old path first."""
    from soccer_drill.teams.batch import BatchCommands

    # Protocol 0 names a class as text: its module replaced by the old path.
    old = pickle.dumps(BatchCommands(1, 2, 3), protocol=0).replace(
        b"soccer_drill.teams.batch", b"soccer_drill.batch_teams")
    assert b"soccer_drill.batch_teams" in old
    code = (
        "import pickle, sys\n"
        "import soccer_drill.env\n"
        "commands = pickle.loads(sys.stdin.buffer.read())\n"
        "from soccer_drill.batch_teams import BatchCommands\n"
        "assert type(commands) is BatchCommands and tuple(commands) == (1, 2, 3)\n"
        "import soccer_drill.render, soccer_drill.gif\n"
        "from soccer_drill.vector_agents import ParallelVectorEnv\n"
        "import soccer_drill\n"
        "assert callable(soccer_drill.env)\n"
        "assert sys.modules['soccer_drill.gif'] is sys.modules['soccer_drill.rendering.gif']\n"
    )
    done = subprocess.run([sys.executable, "-c", code], input=old, capture_output=True,
                          timeout=120, check=False)
    assert done.returncode == 0, done.stderr.decode()
