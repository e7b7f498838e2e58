"""A pickled environment is for the code that made it: another version of ``soccer_drill``
is refused before any of the pickle's state is read, naming both versions.

Before, a pickle made by another version was loaded part by part into this version's
classes: a parametric team's batched form failed with ``AttributeError: 'ParametricBatch'
object has no attribute '_config'``, and a drill whose parts happened to fit would have
continued its episode with other rules.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import soccer_drill
from soccer_drill.envs import pickling
from soccer_drill.envs.pickling import PickleVersionError, code_version
from soccer_drill.vector import HolderVectorEnv, ParallelVectorEnv

_MAKERS = {
    "holder": lambda: soccer_drill.HolderEnv(opponent="interceptors_cover"),
    "aec": lambda: soccer_drill.env(opponent="interceptors_cover"),
    "parallel": lambda: soccer_drill.parallel_env(opponent="interceptors_cover"),
    "holder vector": lambda: HolderVectorEnv(num_envs=2, opponent="interceptors_cover"),
    "parallel vector": lambda: ParallelVectorEnv(num_envs=2, opponent="interceptors_cover"),
}


def _made(kind: str):
    env = _MAKERS[kind]()
    env.reset(seed=0)
    return env


@pytest.mark.parametrize("kind", list(_MAKERS))
def test_a_pickle_of_this_version_continues_its_episode(kind):
    env = _made(kind)
    copy = pickle.loads(pickle.dumps(env))
    assert type(copy) is type(env)
    if kind == "holder":
        np.testing.assert_array_equal(copy.step(2)[0], env.step(2)[0])


@pytest.mark.parametrize("kind", list(_MAKERS))
def test_a_pickle_of_another_version_is_refused_naming_both(kind, monkeypatch):
    env = _made(kind)
    other = "soccer_drill 0.0.9 (source 0123456789ab)"
    monkeypatch.setattr(pickling, "code_version", lambda: other)
    data = pickle.dumps(env)
    monkeypatch.undo()
    with pytest.raises(PickleVersionError) as refused:
        pickle.loads(data)
    said = str(refused.value)
    assert f"this {type(env).__name__} was pickled by {other}" in said
    assert f"cannot be loaded by {code_version()}" in said
    assert "a pickled environment is for the code that made it" in said


def _blank(cls):
    """An object of ``cls`` before its state, as ``copyreg.__newobj__`` makes it."""
    return cls.__new__(cls)


class _Unversioned:
    """An environment pickled as versions before this record did it: its class and its
    state, with no version."""

    def __init__(self, env):
        self.env = env

    def __reduce_ex__(self, protocol):
        state = {k: v for k, v in self.env.__dict__.items() if k != "_busy"}
        return _blank, (type(self.env),), state


@pytest.mark.parametrize("kind", ["holder", "holder vector"])
def test_a_pickle_that_records_no_version_is_refused_naming_this_one(kind):
    data = pickle.dumps(_Unversioned(_made(kind)))
    with pytest.raises(PickleVersionError, match=r"pickled by an earlier soccer_drill \(no "
                                                 r"version recorded\) and cannot be loaded by "
                                                 r"soccer_drill "):
        pickle.loads(data)


def test_the_version_names_the_distribution_and_the_source():
    assert code_version().startswith("soccer_drill ")
    assert "(source " in code_version() and code_version() == code_version()


_WARMED_TEAM = '''
from soccer_drill.teams import Command, Skill, warms

WARMED = []


@warms
def _warm(config):  # what a team's compiled code registers, to compile before its bound
    WARMED.append(config.defenders)


class Warmed:
    def reset(self, view, rng):
        self.players = view.players

    def act(self, view):
        if not WARMED:
            raise RuntimeError("act() before the warm-up")
        return {p: Command(Skill.INTERCEPT) for p in self.players}
'''

_LOAD_AND_STEP = '''
import pickle, sys
import numpy as np
for env in pickle.load(open(sys.argv[1], "rb")):
    if hasattr(env, "num_envs"):
        env.step(np.zeros(env.num_envs, dtype=np.int64))
    else:
        env.step(0)
import warmed_team
print("warmed", len(warmed_team.WARMED) > 0)
'''


@pytest.mark.parametrize("kind", ["holder", "holder vector"])
def test_a_pickle_loaded_in_a_new_process_runs_the_teams_warm_ups_before_it_plays(
        kind, tmp_path):
    """A worker or a resumed checkpoint loads an environment in a new process: the warm-ups
    the team's module registered (``warms``) run before its first bounded call, as when
    an environment is made (before, they did not, and a team compiling there was timed out)."""
    import os
    import subprocess
    import sys

    (tmp_path / "warmed_team.py").write_text(_WARMED_TEAM)
    sys.path.insert(0, str(tmp_path))
    try:
        import warmed_team

        maker = {"holder": soccer_drill.HolderEnv, "holder vector":
                 lambda opponent: HolderVectorEnv(num_envs=2, opponent=opponent)}[kind]
        env = maker(opponent=warmed_team.Warmed())
        env.reset(seed=0)
        (tmp_path / "env.pkl").write_bytes(pickle.dumps([env]))
    finally:
        sys.path.remove(str(tmp_path))
        sys.modules.pop("warmed_team", None)
    done = subprocess.run(
        [sys.executable, "-c", _LOAD_AND_STEP, str(tmp_path / "env.pkl")], capture_output=True,
        text=True, timeout=600, check=False,
        env={**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), *sys.path])})
    assert done.returncode == 0 and done.stdout.split() == ["warmed", "True"], done.stderr[-2000:]
