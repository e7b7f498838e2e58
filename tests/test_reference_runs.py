"""Recorded runs that every change of the code must reproduce bit for bit.

``tests/data/reference_runs.json`` holds the learning curves, trial records, kernel
parameters, PRQ-learning's gains and the SHA-256 of every array of every checkpoint of

* a small lifelong run on the synthetic corridors of ``synthetic_smdp.py``: every method
  (ILPSS, learning anew, whole policies, PRQ-learning, ILPSS without discounting) and one
  more variant (Sarsa(lambda), option initial values, ``continuation_exponent=0.5``,
  ``max_depth=2``), with options that follow pointers to other options;
* a short protocol A on the drill (2 seeds, every method, a few episodes).

A change that alters any number of these fails here. Record the file again only when a
change of behaviour is intended (and say so in its commit)::

    python tests/test_reference_runs.py --record

The digests hold for one set of OpenBLAS kernels (``tests/blas.py``): on a CPU that cannot
run them, these tests are skipped with the reason, and recording is refused.
"""

from __future__ import annotations

import hashlib
import json
import sys
import tempfile
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

from blas import pin_recorded_kernels, reason_bits_differ

pin_recorded_kernels()  # as conftest.py does, for ``--record`` run as a script

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from synthetic_smdp import ZoneCorridor  # noqa: E402

_DIFFERS = reason_bits_differ()
pytestmark = pytest.mark.skipif(_DIFFERS is not None, reason=str(_DIFFERS))

FIXTURE = Path(__file__).resolve().parent / "data" / "reference_runs.json"
SYNTHETIC_METHODS = ("ilpss", "scratch", "whole_policies", "ilpss_no_discount")


def _array_digests(folder: Path) -> dict[str, str]:
    """``{"<file>:<array>": sha256}`` of every array of every archive below ``folder``."""
    out = {}
    for path in sorted(folder.rglob("*.npz")):
        with np.load(path, allow_pickle=False) as archive:
            for name in sorted(archive.files):
                if name == "__meta__":
                    continue
                a = np.ascontiguousarray(archive[name])
                h = hashlib.sha256(json.dumps([a.dtype.str, list(a.shape)]).encode())
                h.update(a.tobytes())
                out[f"{path.relative_to(folder).as_posix()}:{name}"] = h.hexdigest()
    return out


def _kernels(model: Any) -> dict[str, Any] | None:
    if model is None:
        return None
    out = {"type": type(model).__name__, "means": np.asarray(model.means_).tolist(),
           "covariances": np.asarray(model.covariances_).tolist()}
    if hasattr(model, "weights_"):
        out["weights"] = model.weights_.tolist()
    return out


def _lifelong(learner: Any, folder: Path) -> dict[str, Any]:
    learner.save(folder)
    lib = learner.library
    return {
        "records": [asdict(r) for r in learner.records],
        "kernels": _kernels(learner.kernel_model),
        "library": None if lib is None else {
            "option_ids": lib.option_ids.tolist(), "scales": lib.scales.tolist(),
            "uses": lib.uses.tolist(), "kernel_ids": lib.kernel_ids.tolist(),
            "registry": sorted([o, *kp] for o, kp in lib.registry.items()),
        },
        "arrays": _array_digests(folder),
    }


def _corridors() -> list[ZoneCorridor]:
    return [ZoneCorridor(cost=c, n_features=2) for c in (0.02, 0.05, 0.1, 0.03)]


def synthetic_run(root: Path) -> tuple[dict[str, Any], int]:
    """Every method on four corridors; also the longest pointer chain that was followed."""
    from ilpss.baselines import PrqConfig, PrqLearner
    from ilpss.experiments.methods import METHODS
    from ilpss.lifelong import LearnerConfig, LifelongConfig, LifelongLearner, trial_seeds
    from ilpss.options import OptionLibrary

    base = LifelongConfig(
        n_kernels=2, train_episodes=30, rollout_episodes=8,
        learner=LearnerConfig(initial_value=1.0, tile_widths=(1.0, 0.5), n_tilings=8,
                              intra_option=True, option_initial_value=1.5),
    )
    variant = replace(
        base, library=replace(base.library, continuation_exponent=0.5, max_depth=2),
        learner=replace(base.learner, method="sarsa", intra_option=False,
                        option_initial_value=2.0))
    configs = {m: METHODS.get(m).config(base) for m in SYNTHETIC_METHODS} | {"variant": variant}
    longest = [1]
    real_resolve = OptionLibrary.resolve

    def resolve(self, *args, **kwargs):
        action, path = real_resolve(self, *args, **kwargs)
        longest[0] = max(longest[0], len(path))
        return action, path

    out: dict[str, Any] = {}
    OptionLibrary.resolve = resolve  # type: ignore[method-assign]
    try:
        learners = {}
        for name, cfg in configs.items():
            envs = _corridors()
            learner = LifelongLearner(cfg, envs[0].observation_space, 3, seed=11)
            for t, env in enumerate(envs):
                learner.run_trial(env, f"corridor_{t}")
            learners[name] = learner
            out[name] = _lifelong(learner, root / name)
    finally:
        OptionLibrary.resolve = real_resolve  # type: ignore[method-assign]
    scratch = learners["scratch"]
    prq_curves, prq_state = {}, {}
    for t in (2, 3):
        learner_seed, env_seed, _, _ = trial_seeds(11, t)
        lc = base.learner
        prq = PrqLearner(scratch.n_primitive, scratch.tile_coder, scratch.policies[:t],
                         replace(lc, trace_decay=0.0),
                         PrqConfig(psi=1.0, upsilon=0.9, delta_tau=0.1), seed=learner_seed)
        results = prq.train(_corridors()[t], base.train_episodes, seed=env_seed)
        rollouts = prq.evaluate(_corridors()[t], 3, seed=env_seed + 1)
        prq_curves[str(t)] = [r.total_reward for r in results]
        prq_state[str(t)] = {
            "gains": prq.reuse_gains.tolist(), "counts": prq.reuse_counts.tolist(),
            "reused": list(prq.reused), "rollouts": [r.total_reward for r in rollouts],
            "weights": hashlib.sha256(prq.q.weights.tobytes()).hexdigest(),
        }
    out["prq"] = {"curves": prq_curves, "state": prq_state}
    return out, longest[0]


def drill_run(root: Path) -> dict[str, Any]:
    """Protocol A on the drill: 2 seeds, every method, 5 episodes per team."""
    from ilpss.experiments.config import ExperimentConfig
    from ilpss.experiments.run import run_experiment

    methods = ("ilpss", "scratch", "whole_policies", "prq", "ilpss_no_discount")
    cfg = ExperimentConfig(n_seeds=2, workers=1, methods=methods).with_overrides(
        lifelong={"train_episodes": 5, "rollout_episodes": 3, "n_kernels": 2})
    results = run_experiment(cfg, root, progress=False)
    return {
        "results": [{k: r[k] for k in ("seed", "stream", "tasks", "first_target", "methods")}
                    for r in results],
        "arrays": _array_digests(root),
    }


def _recorded() -> dict[str, Any]:
    return json.loads(FIXTURE.read_text())


def _same(actual: Any, expected: Any, where: str = "") -> None:
    """Assert equality, naming the first place where the two differ."""
    if isinstance(expected, dict) and isinstance(actual, dict):
        assert sorted(actual) == sorted(expected), f"{where}: keys differ"
        for key in expected:
            _same(actual[key], expected[key], f"{where}.{key}")
    elif isinstance(expected, list) and isinstance(actual, list):
        assert len(actual) == len(expected), f"{where}: {len(actual)} != {len(expected)} items"
        for i, (a, e) in enumerate(zip(actual, expected, strict=True)):
            _same(a, e, f"{where}[{i}]")
    else:
        assert actual == expected, f"{where}: {actual!r} != recorded {expected!r}"


def _json(value: Any) -> Any:
    return json.loads(json.dumps(value))


def test_the_synthetic_run_of_every_method_is_unchanged(tmp_path):
    actual, longest = synthetic_run(tmp_path)
    assert longest >= 2, "the run must follow option pointers"
    _same(_json(actual), _recorded()["synthetic"], "synthetic")


@pytest.mark.slow
def test_a_short_protocol_a_on_the_drill_is_unchanged(tmp_path):
    _same(_json(drill_run(tmp_path)), _recorded()["drill"], "drill")


def record(fixture: Path = FIXTURE, synthetic: Any = None, drill: Any = None) -> None:
    """Write ``fixture`` from the code as it is: the runs of ``synthetic`` and ``drill``
    (by default this file's)."""
    if reason_bits_differ():
        raise SystemExit(f"not recording: {reason_bits_differ()}")
    synthetic, drill = synthetic or synthetic_run, drill or drill_run
    with tempfile.TemporaryDirectory() as tmp:
        runs, longest = synthetic(Path(tmp) / "synthetic")
        assert longest >= 2, f"no option pointer was followed (longest chain {longest})"
        data = {"synthetic": runs, "drill": drill(Path(tmp) / "drill")}
    fixture.parent.mkdir(exist_ok=True)
    fixture.write_text(json.dumps(_json(data), indent=1, sort_keys=True) + "\n")
    print(f"wrote {fixture} ({fixture.stat().st_size:,} bytes); longest pointer chain {longest}")


if __name__ == "__main__":
    if sys.argv[1:] != ["--record"]:
        raise SystemExit("usage: python tests/test_reference_runs.py --record")
    record()
