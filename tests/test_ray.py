"""The Ray executor runs a tiny sweep on a local Ray instance, with the same results."""

from __future__ import annotations

import pytest

from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.run import run_experiment

pytestmark = pytest.mark.slow  # starts Ray

ray = pytest.importorskip("ray", reason="the Ray executor needs the optional 'ray' extra")


def test_ray_sweep_matches_local_processes(tmp_path):
    cfg = ExperimentConfig(n_seeds=2, workers=2, methods=("ilpss", "scratch")).with_overrides(
        lifelong={"train_episodes": 5, "rollout_episodes": 3, "n_kernels": 2}
    )
    local = run_experiment(cfg, tmp_path / "local", progress=False)
    try:
        remote = run_experiment(cfg.with_overrides(executor="ray"), tmp_path / "ray",
                                progress=False)
    finally:
        ray.shutdown()
    assert remote == local
