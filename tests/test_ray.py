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


def test_failing_ray_tasks_keep_the_others_results_and_are_named():
    """A task that raises, calls sys.exit() or kills its worker is that item's failure:
    the other items finish and are handed over, as with local processes."""
    import os
    import sys

    from ilpss.experiments.executor import JobsFailed, RayExecutor

    def job(i):
        if i == 1:
            raise ValueError("job 1 broke")
        if i == 2:
            sys.exit(4)  # Ray alone reports this as a crashed worker
        if i == 3:
            os._exit(1)  # the worker dies: no retries left
        return i * 10

    done = {}
    executor = RayExecutor(workers=2, progress=False, max_retries=0)
    try:
        with pytest.raises(JobsFailed) as err:
            executor.map(job, range(5), done=done.__setitem__)
    finally:
        executor.shutdown()
    assert done == {0: 0, 4: 40}
    failures = err.value.failures
    assert sorted(failures) == [1, 2, 3]
    assert isinstance(failures[1], ValueError) and str(failures[1]) == "job 1 broke"
    assert str(failures[2]) == "the job's code called sys.exit(4)"
    assert isinstance(failures[3], ray.exceptions.WorkerCrashedError)
