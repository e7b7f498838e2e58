"""Recorded runs of the switches that hand control back to the primitives, bit for bit.

``tests/data/reference_handover.json`` holds the learning curves, trial records, kernel
parameters and the SHA-256 of every array of every checkpoint of lifelong runs that
turn on ``option_bonus``, ``interruption`` and ``intra_option_primitives`` (with and
without ``intra_option``, with Q(lambda) and Sarsa(lambda), with the paper's and a
fractional ``continuation_exponent``), on the synthetic corridors of
``synthetic_smdp.py`` (2 and 9 features) and in a short protocol A on the drill. Every
run follows option pointers. Speed-ups of the learner must leave all of it unchanged;
record the file again only for an intended change of behaviour (and say so in its
commit)::

    python tests/test_reference_handover.py --record
"""

from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from blas import reason_bits_differ
from synthetic_smdp import ZoneCorridor
from test_reference_runs import _array_digests, _json, _lifelong, _same, record

_DIFFERS = reason_bits_differ()
pytestmark = pytest.mark.skipif(_DIFFERS is not None, reason=str(_DIFFERS))

FIXTURE = Path(__file__).resolve().parent / "data" / "reference_handover.json"
HANDOVER_LEARNER = {
    "option_bonus": 1.5, "option_bonus_episodes": 100, "option_initial_value": 0.0,
    "interruption": True, "intra_option_primitives": True, "intra_option": True,
}
HANDOVER_LIBRARY = {"max_match_distance": None, "used_min_decisions": 20}


def _configs() -> dict[str, Any]:
    from ilpss.lifelong import LearnerConfig, LifelongConfig
    from ilpss.options import OptionSettings

    handover = LifelongConfig(
        n_kernels=2, train_episodes=40, rollout_episodes=8, kernel_reg_covar=0.1,
        library=OptionSettings(**HANDOVER_LIBRARY),
        learner=LearnerConfig(tile_widths=(1.0, 0.5), n_tilings=8, **HANDOVER_LEARNER),
    )
    return {
        "handover": handover,
        "handover_sarsa": replace(
            handover,
            library=replace(handover.library, continuation_exponent=0.5, used_min_decisions=1),
            learner=replace(handover.learner, method="sarsa", trace_decay=0.5,
                            intra_option=False, option_initial_value=1.5)),
        "handover_9_features": replace(
            handover, n_kernels=3, train_episodes=30,
            learner=replace(handover.learner, tile_widths=(1.0,) + (0.25,) * 8)),
    }


def synthetic_run(root: Path) -> tuple[dict[str, Any], int]:
    """Each configuration on four corridors; also the longest pointer chain followed."""
    from ilpss.lifelong import LifelongLearner
    from ilpss.options import OptionLibrary

    longest = [1]
    real_resolve = OptionLibrary.resolve

    def resolve(self, *args, **kwargs):
        action, path = real_resolve(self, *args, **kwargs)
        longest[0] = max(longest[0], len(path))
        return action, path

    out: dict[str, Any] = {}
    OptionLibrary.resolve = resolve  # type: ignore[method-assign]
    try:
        for name, cfg in _configs().items():
            n_features = len(cfg.learner.tile_widths)
            envs = [ZoneCorridor(cost=c, n_features=n_features) for c in (0.02, 0.05, 0.1, 0.03)]
            learner = LifelongLearner(cfg, envs[0].observation_space, 3, seed=5)
            for t, env in enumerate(envs):
                learner.run_trial(env, f"corridor_{t}")
            out[name] = _lifelong(learner, root / name)
    finally:
        OptionLibrary.resolve = real_resolve  # type: ignore[method-assign]
    return out, longest[0]


def drill_run(root: Path) -> dict[str, Any]:
    """Protocol A on the drill with the switches on: 1 seed, ILPSS, learning anew and PRQ-learning."""
    from ilpss.experiments.config import ExperimentConfig
    from ilpss.experiments.run import run_experiment

    cfg = ExperimentConfig(n_seeds=1, workers=1, methods=("ilpss", "scratch", "prq")).with_overrides(
        lifelong={"train_episodes": 150, "rollout_episodes": 10, "n_kernels": 2,
                  "kernel_reg_covar": 0.1, "learner": HANDOVER_LEARNER,
                  "library": HANDOVER_LIBRARY})
    results = run_experiment(cfg, root, progress=False)
    return {
        "results": [{k: r[k] for k in ("seed", "stream", "tasks", "first_target", "methods")}
                    for r in results],
        "arrays": _array_digests(root),
    }


def _recorded() -> dict[str, Any]:
    return json.loads(FIXTURE.read_text())


def test_the_synthetic_handover_runs_are_unchanged(tmp_path):
    actual, longest = synthetic_run(tmp_path)
    assert longest >= 2, "the runs must follow option pointers"
    _same(_json(actual), _recorded()["synthetic"], "synthetic")


@pytest.mark.slow
def test_a_short_protocol_a_with_the_handover_switches_is_unchanged(tmp_path):
    _same(_json(drill_run(tmp_path)), _recorded()["drill"], "drill")


if __name__ == "__main__":
    if sys.argv[1:] != ["--record"]:
        raise SystemExit("usage: python tests/test_reference_handover.py --record")
    record(FIXTURE, synthetic_run, drill_run)


def test_the_fixtures_are_skipped_under_another_numpy_major_version(monkeypatch):
    """numpy 1.26 (which the project allows) computes other last bits: the recorded digests
    are skipped, with the reason, rather than failed (before: a digest mismatch)."""
    import numpy as np
    from blas import reason_bits_differ

    monkeypatch.setattr(np, "__version__", "1.26.4")
    assert "recorded with numpy 2; this process runs numpy 1.26.4" in reason_bits_differ()
