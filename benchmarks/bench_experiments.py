"""Wall time of protocol A: one seed on one core, and the executors' scaling.

    python benchmarks/bench_experiments.py [--episodes 300] [--seeds 4]

Measures, in one run: one seed of protocol A (all four methods) on one core with the
local executor; then ``--seeds`` seeds with the Ray executor on 1 and on 2 workers
(speed-up = time(1) / time(2)), and with the local executor on 2 workers. Results go to
temporary folders; the figures are printed as a markdown table.
"""

from __future__ import annotations

import argparse
import tempfile
import time

from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.run import run_experiment


def timed(cfg: ExperimentConfig) -> float:
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        run_experiment(cfg, out, progress=False)
        return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=300)
    parser.add_argument("--seeds", type=int, default=4)
    args = parser.parse_args()
    base = ExperimentConfig(protocol="A").with_overrides(lifelong={"train_episodes": args.episodes})
    one = timed(base.with_overrides(n_seeds=1, workers=1))
    rows = [("1 seed, local, 1 worker", one, "-")]
    local2 = timed(base.with_overrides(n_seeds=args.seeds, workers=2))
    rows.append((f"{args.seeds} seeds, local, 2 workers", local2, "-"))
    try:
        import ray
    except ImportError:
        ray = None
    if ray is not None:
        ray1 = timed(base.with_overrides(n_seeds=args.seeds, workers=1, executor="ray"))
        ray.shutdown()
        ray2 = timed(base.with_overrides(n_seeds=args.seeds, workers=2, executor="ray"))
        ray.shutdown()
        rows.append((f"{args.seeds} seeds, Ray, 1 worker", ray1, "1.00x"))
        rows.append((f"{args.seeds} seeds, Ray, 2 workers", ray2, f"{ray1 / ray2:.2f}x"))
    print(f"protocol A, {args.episodes} learning episodes per opponent, methods {base.methods}")
    print("| run | wall time (s) | speed-up |")
    print("|---|---:|---:|")
    for name, seconds, speed in rows:
        print(f"| {name} | {seconds:.1f} | {speed} |")
    print(f"\nEstimated 30 seeds on 2 cores (local): {30 / args.seeds * local2 / 60:.1f} min")


if __name__ == "__main__":
    main()
