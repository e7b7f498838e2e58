"""A run on a Ray cluster of several nodes, simulated on this machine: the driver joins
it, each job works in its own node's folder, a worker node is killed mid-run, and the run
still ends with the results of an uninterrupted local run."""

from __future__ import annotations

import itertools
import threading
import time

import pytest

from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.executor import RayExecutor
from ilpss.experiments.run import run_experiment

pytestmark = pytest.mark.slow  # starts a Ray cluster of three nodes

ray = pytest.importorskip("ray", reason="the Ray executor needs the optional 'ray' extra")
cluster_utils = pytest.importorskip("ray.cluster_utils")
pytest.importorskip("pyarrow.fs", reason="a storage URI needs pyarrow (the 'cluster' extra)")


def _experiment() -> ExperimentConfig:
    return ExperimentConfig(n_seeds=2, workers=2, methods=("ilpss", "scratch", "prq")
                            ).with_overrides(
        lifelong={"train_episodes": 10, "rollout_episodes": 3, "n_kernels": 2})


def _node(cluster, folder):
    """A worker node of one CPU whose jobs make their working folders in ``folder``."""
    folder.mkdir()
    return cluster.add_node(num_cpus=1, env_vars={"TMPDIR": str(folder)})


def test_a_run_survives_a_lost_node_and_equals_the_local_run(tmp_path, monkeypatch):
    cfg = _experiment()
    local = run_experiment(cfg, tmp_path / "local", progress=False)
    storage, out = tmp_path / "storage", tmp_path / "cluster"
    # The head node runs no job (the driver is attached to it); two workers do.
    cluster = cluster_utils.Cluster(initialize_head=True, head_node_args={"num_cpus": 0})
    try:
        nodes = [_node(cluster, tmp_path / f"node_{k}") for k in range(2)]
        cluster.wait_for_nodes()
        # Joined through RAY_ADDRESS: ray.init gets no num_cpus (it refuses them when
        # joining), and the cluster's CPUs are its nodes', whatever --workers says.
        monkeypatch.setenv("RAY_ADDRESS", cluster.address)
        executor = RayExecutor(workers=1, progress=False)
        assert ray.cluster_resources()["CPU"] == 2
        monkeypatch.delenv("RAY_ADDRESS")

        def span(_: int) -> tuple[float, float]:
            start = time.time()
            time.sleep(1.0)
            return start, time.time()

        # --workers bounds the tasks in flight: one at a time although two CPUs are free.
        spans = executor.map(span, range(3))
        assert all(a[1] <= b[0] for a, b in itertools.pairwise(spans)), spans
        executor.workers = 2
        (a, b) = executor.map(span, range(2))
        assert max(a[0], b[0]) < min(a[1], b[1]), (a, b)  # and two at a time with 2

        remote = cfg.with_overrides(executor="ray", storage=storage.as_uri())
        finished, errors, done = [], [], []

        def drive() -> None:
            try:
                finished.append(run_experiment(
                    remote, out, progress=False, ray_address=cluster.address,
                    on_done=lambda spec, d: done.append((spec.seed, d))))
            except BaseException as exc:  # reported below
                errors.append(exc)

        driver = threading.Thread(target=drive)
        driver.start()
        # Kill a worker node once both jobs have checkpointed their first trial.
        latest = [storage / f"seed_{s:03d}" / "stream_00" / "ilpss" / "LATEST" for s in (0, 1)]
        deadline = time.monotonic() + 300
        while not all(p.exists() for p in latest) and driver.is_alive() \
                and time.monotonic() < deadline:
            time.sleep(0.05)
        assert all(p.exists() for p in latest) and not done, "no job was caught mid-run"
        cluster.remove_node(nodes[0], allow_graceful=False)
        _node(cluster, tmp_path / "node_2")  # a new node takes the lost one's place
        driver.join(600)
        assert not driver.is_alive(), "the run did not finish"
    finally:
        ray.shutdown()
        cluster.shutdown()
    assert not errors, errors
    assert finished == [local]
    # The lost node's job was started again and resumed from its last checkpoint.
    assert sorted(s for s, _ in done) == [0, 1]
    assert any(d.resumed.get("ilpss", 0) >= 1 for _, d in done), [d.resumed for _, d in done]
    # The driver wrote every result; the checkpoints are in the storage only.
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()) == [
        "config.json", "seed_000/stream_00/result.json", "seed_001/stream_00/result.json",
        "team_code.json"]
    for seed in (0, 1):
        assert (out / f"seed_{seed:03d}/stream_00/result.json").read_bytes() == (
            tmp_path / "local" / f"seed_{seed:03d}/stream_00/result.json").read_bytes()
    # Each job worked in its own node's folder: the killed node's job left its working
    # folder there, and the others removed theirs when they finished.
    assert list((tmp_path / "node_0").glob("ilpss-job-*"))
    assert not list((tmp_path / "node_1").glob("ilpss-job-*"))
    assert not list((tmp_path / "node_2").glob("ilpss-job-*"))
