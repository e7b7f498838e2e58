"""The drill's rules give the same floats compiled (numba) and as plain Python.

The rules are written once (:mod:`soccer_drill.rules.compiled`); these tests check the two
promises that make the plain-Python fallback a fallback rather than another drill: the
length function compiled code uses is CPython's ``math.hypot`` float for float, and
whole episodes, single and batched, are the same bit for bit with ``NUMBA_DISABLE_JIT=1``.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from episode_digests import _feed, digest

import soccer_drill
from soccer_drill.rules.compiled import COMPILED, python_hypot
from soccer_drill.vector import HolderVectorEnv
from soccer_drill.vector.agents import ParallelVectorEnv

_SINGLE = (
    ("aec", "chasers", {"obs_type": "kinematic", "obs_format": "flat", "shared_spaces": False}),
    ("parallel", None, {"obs_type": "features", "obs_format": "dict", "shared_spaces": True}),
    ("holder", "interceptors_cover", {}),
)


def _vector_digest(opponent: str) -> str:
    env = HolderVectorEnv(num_envs=6, opponent=opponent)
    rng = np.random.default_rng(5)
    h = hashlib.sha256()
    obs, infos = env.reset(seed=11)
    _feed(h, (obs, infos["cycles"]))
    for _ in range(40):
        obs, rewards, terminated, truncated, infos = env.step(rng.integers(3, size=6))
        _feed(h, (obs, rewards, terminated, truncated, infos["cycles"],
                  [str(o) for o in infos["outcome"]]))
    return h.hexdigest()


def _parallel_vector_digest(obs_type: str = "kinematic", attack: str | None = None) -> str:
    env = (ParallelVectorEnv(num_envs=4, opponent="goal_guards", obs_type=obs_type)
           if attack is None else ParallelVectorEnv(num_envs=4, attack=attack, obs_type=obs_type))
    rng = np.random.default_rng(6)
    h = hashlib.sha256()
    obs, _ = env.reset(seed=3)
    for _ in range(60):
        actions = {a: np.where(o["action_mask"][:, 0] == 1, rng.integers(3, size=4),
                               3 + rng.integers(2, size=4)) for a, o in obs.items()}
        obs, rewards, terminations, truncations, _ = env.step(actions)
        _feed(h, ({a: o["observation"] for a, o in obs.items()}, rewards, terminations,
                  truncations, env.state()))
    return h.hexdigest()


def digests() -> dict[str, str]:
    """Digests of a few single and batched configurations, in this process's mode."""
    out = {f"{api}/{opponent}": digest(api, opponent, kwargs) for api, opponent, kwargs in _SINGLE}
    out["vector/parametric"] = _vector_digest("parametric")
    out["vector/chasers"] = _vector_digest("chasers")
    out["parallel_vector/goal_guards"] = _parallel_vector_digest()
    out["parallel_vector/goal_guards/full"] = _parallel_vector_digest("full")
    out["parallel_vector/attack/mixed_rules"] = _parallel_vector_digest("full", "mixed_rules")
    return out


@pytest.mark.skipif(not COMPILED, reason="the rules are not compiled in this process")
def test_compiled_lengths_are_cpythons_math_hypot_float_for_float():
    rng = np.random.default_rng(0)
    for scale in (1e-200, 1e-6, 1.0, 35.0, 1e6, 1e200):
        xs, ys = rng.normal(0.0, scale, 20_000), rng.normal(0.0, scale, 20_000)
        xs[:50], ys[50:100] = 0.0, -0.0
        for x, y in zip(xs.tolist(), ys.tolist(), strict=True):
            assert python_hypot(x, y) == math.hypot(x, y), (x, y)
    for x, y in ((math.inf, math.nan), (math.nan, 1.0), (-math.inf, 2.0), (0.0, 0.0)):
        same = python_hypot(x, y) == math.hypot(x, y) or (
            math.isnan(python_hypot(x, y)) and math.isnan(math.hypot(x, y)))
        assert same, (x, y)


@pytest.mark.slow
@pytest.mark.skipif(not COMPILED, reason="the rules are not compiled in this process")
def test_episodes_are_the_same_compiled_and_as_plain_python():
    here = Path(__file__).resolve().parent
    script = (f"import sys, json; sys.path.insert(0, {str(here)!r}); import test_compiled; "
              "print(json.dumps(test_compiled.digests()))")
    plain = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=600,
        env={**os.environ, "NUMBA_DISABLE_JIT": "1"}, cwd=here.parent, check=True,
    )
    assert json.loads(plain.stdout) == digests()


def test_the_package_says_whether_its_rules_are_compiled():
    assert soccer_drill.rules.compiled.COMPILED == (
        os.environ.get("NUMBA_DISABLE_JIT", "0") in ("", "0"))


@pytest.mark.slow
@pytest.mark.skipif(not COMPILED, reason="the rules are not compiled in this process")
def test_a_fresh_process_compiles_the_rules_before_a_teams_time_bound(tmp_path):
    """With nothing compiled yet (an empty cache), the rules a team calls are compiled
    before its first bounded call, not inside it: a tight bound is not exceeded."""
    script = (
        "import numpy as np, soccer_drill\n"
        "from soccer_drill.vector import HolderVectorEnv\n"
        "env = soccer_drill.HolderEnv(opponent='interceptors_cover', team_timeout=0.2)\n"
        "env.reset(seed=0)\n"
        "for _ in range(3): env.step(0)\n"
        "venv = HolderVectorEnv(num_envs=3, opponent='interceptor_guard', team_timeout=0.2)\n"
        "venv.reset(seed=0)\n"
        "for _ in range(3): venv.step(np.zeros(3, dtype=np.int64))\n"
        "print('played')\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=600,
        env={**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}, check=False,
    )
    assert done.returncode == 0 and done.stdout.strip() == "played", done.stderr[-2000:]
    assert any(tmp_path.rglob("*.nbi"))  # it did compile into the empty cache


_RECORD_RULES = '''
import sys
import numpy as np
from soccer_drill.rules.compiled import compiled

@compiled
def inner(rec):
    total = 0.0
    for k in range(rec[0].a.shape[0]):
        total += rec[0].a[k]
    return total

@compiled
def outer(rec):
    return inner(rec)

DTYPES = {"two": np.dtype([("a", np.float64, (2,))]),
          "three": np.dtype([("a", np.float64, (3,)), ("b", np.int64)])}
for name in sys.argv[1:]:
    outer(np.zeros(1, DTYPES[name]))
for result in outer.overloads.values():
    print(result.fndesc.mangled_name)
'''


@pytest.mark.skipif(not COMPILED, reason="the rules are not compiled in this process")
def test_code_compiled_in_two_processes_for_different_records_has_different_names(tmp_path):
    """numba names compiled code by a counter that starts alike in every process, and a
    process that holds code for two layouts of records under one name runs one for the
    other. The first process compiles for one layout (into the disk cache), the second
    for another, then loads the first's: every piece of code it holds has a name of its own."""
    (tmp_path / "records_rules.py").write_text(_RECORD_RULES)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"),
           "PYTHONPATH": os.pathsep.join([str(tmp_path), *sys.path])}

    def names(*layouts: str) -> list[str]:
        done = subprocess.run([sys.executable, str(tmp_path / "records_rules.py"), *layouts],
                              capture_output=True, text=True, timeout=300, env=env,
                              check=False)
        assert done.returncode == 0, done.stderr[-2000:]
        return done.stdout.split()

    first = names("two")
    second = names("three", "two")
    assert len(first) == 1 and first[0] in second  # the first's code, loaded from the cache
    assert len(second) == 2 and len(set(second)) == 2


_SIZES_IN_TURN = '''
import sys
import numpy as np
import soccer_drill
from soccer_drill import keepaway_policies

for size in sys.argv[1:]:
    keepers, takers = map(int, size.split("v"))
    env = soccer_drill.HolderEnv(config={"task": "keepaway", "attackers": keepers,
                                         "defenders": takers})
    policy = keepaway_policies.keeper_policy("hand_coded", keepers, takers)
    obs, _ = env.reset(seed=1)
    start = np.array(env.drill_state.pos)
    rng = np.random.default_rng(1)
    for _ in range(3):
        obs, *_ = env.step(policy(obs, rng))
    print(size, float(np.abs(np.array(env.drill_state.pos) - start).max()))
'''


@pytest.mark.slow
@pytest.mark.skipif(not COMPILED, reason="the rules are not compiled in this process")
def test_a_drill_size_loaded_from_the_cache_beside_another_compiled_anew_plays(tmp_path):
    """One process compiles keepaway 3v2 into an empty cache; the next compiles 2v1, then
    loads 3v2 and then 2v1 again: every drill plays (before: in 3v2 nobody moved,
    or the process crashed)."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}

    def play(*sizes: str) -> dict[str, float]:
        done = subprocess.run([sys.executable, "-c", _SIZES_IN_TURN, *sizes],
                              capture_output=True, text=True, timeout=600, env=env,
                              check=False)
        assert done.returncode == 0, done.stderr[-2000:]
        return {size: float(moved) for size, moved in
                (line.split() for line in done.stdout.splitlines())}

    assert play("3v2")["3v2"] > 0.5
    moved = play("2v1", "3v2")
    assert moved["2v1"] > 0.5 and moved["3v2"] > 0.5, moved


@pytest.mark.skipif(not COMPILED, reason="the rules are not compiled in this process")
@pytest.mark.parametrize("source", ["<string>", "/nonexistent/ipykernel_0/123.py"])
def test_a_compiled_function_with_no_source_file_compiles_without_a_warning(source):
    """A team's function defined in a notebook's cell (IPython names a file that is not
    there), by exec or by python -c: compiled in memory, with no warning about the drill's
    rules (before: FileNotFoundError when decorated, or a warning about a minute's compile
    and NUMBA_CACHE_DIR)."""
    import warnings

    from soccer_drill.rules.compiled import compiled

    namespace = {"compiled": compiled}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        exec(compile("@compiled\ndef twice(x):\n    return 2.0 * x\n", source, "exec"),
             namespace)
        assert namespace["twice"](np.float64(3.0)) == 6.0
