"""Protocol A on a Ray cluster simulated on this machine, against the local executor.

    python benchmarks/bench_cluster.py [--episodes 100] [--seeds 4] [--workers 1 2 4]

Starts a cluster of a head node (no CPU: it runs no job) and two worker nodes of two
CPUs each (``ray.cluster_utils.Cluster``), then runs protocol A (all four methods,
``--seeds`` jobs) with each worker count, alternately with the local executor and on the
cluster (joined by its address, checkpoints in a ``file://`` storage, each node with its
own temporary folder), so that both see the same load. Prints the wall times and, per
worker count, the cluster's time over the local executor's, and each executor's speed-up
over its own 1-worker run, as a markdown table; also the machine's cores and load.
Results go to temporary folders. The cluster's nodes share this machine's cores: on a
2-core machine 4 workers oversubscribe it, whatever the executor.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.run import run_experiment


def timed(cfg: ExperimentConfig, **kwargs) -> tuple[float, list]:
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        results = run_experiment(cfg, Path(out) / "run", progress=False, **kwargs)
        return time.perf_counter() - start, results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2, 4])
    args = parser.parse_args()
    import ray
    from ray.cluster_utils import Cluster

    base = ExperimentConfig(protocol="A", n_seeds=args.seeds).with_overrides(
        lifelong={"train_episodes": args.episodes})
    loads = [os.getloadavg()[0]]
    times: dict[tuple[str, int], float] = {}
    with tempfile.TemporaryDirectory() as scratch:
        cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 0})
        try:
            for k in range(2):
                node_tmp = Path(scratch) / f"node_{k}"
                node_tmp.mkdir()
                cluster.add_node(num_cpus=2, env_vars={"TMPDIR": str(node_tmp)})
            cluster.wait_for_nodes()
            reference = None
            for w in args.workers:
                local_s, local = timed(base.with_overrides(workers=w))
                storage = (Path(scratch) / f"storage_{w}").as_uri()
                remote_s, remote = timed(
                    base.with_overrides(workers=w, executor="ray", storage=storage),
                    ray_address=cluster.address)
                reference = reference or local
                assert local == remote == reference, "the executors disagree"
                times["local", w], times["cluster", w] = local_s, remote_s
                loads.append(os.getloadavg()[0])
        finally:
            ray.shutdown()
            cluster.shutdown()
    first = args.workers[0]
    print(f"protocol A, {args.seeds} seeds (one job each), {args.episodes} learning episodes "
          f"per opponent, methods {', '.join(base.methods)}; {os.cpu_count()} cores; load "
          "average (1 min) " + " -> ".join(f"{x:.1f}" for x in loads))
    print(f"| workers | local (s) | cluster (s) | cluster / local | speed-up over {first} "
          "worker(s): local | cluster |")
    print("|---:|---:|---:|---:|---:|---:|")
    for w in args.workers:
        local_s, remote_s = times["local", w], times["cluster", w]
        print(f"| {w} | {local_s:.1f} | {remote_s:.1f} | {remote_s / local_s:.2f} | "
              f"{times['local', first] / local_s:.2f}x | "
              f"{times['cluster', first] / remote_s:.2f}x |")


if __name__ == "__main__":
    main()
