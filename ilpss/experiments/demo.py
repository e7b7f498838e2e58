"""The README's main job: a small protocol A, its figure, the kernels and a GIF.

    ilpss-demo [--seeds 6] [--episodes 300] [--out results/demo]

Runs ILPSS over the paper's teams 1-3, then learns against the held-out team 4 with
the extracted options and anew (plus the two reuse baselines), on a budget that
takes a few minutes on two cores; writes ``report.md`` with the learning curves, a
picture of the kernels on the field, and a GIF of the ILPSS agent against team 4
with its active option shown.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence
from pathlib import Path

import gymnasium as gym

from ilpss._io import FolderInUseError
from ilpss.experiments.checkpoints import StorageError
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.executor import stop_on_sigterm
from ilpss.experiments.figures import plot_kernels_on_field, write_agent_gif
from ilpss.experiments.folder import RunFolder
from ilpss.experiments.outputs import check_out_dir
from ilpss.experiments.report import write_report
from ilpss.experiments.run import JobError, run_experiment
from ilpss.lifelong import LifelongLearner


def main(argv: Sequence[str] | None = None) -> int:
    """Run the small protocol A and write its report, kernels picture and GIF."""
    parser = argparse.ArgumentParser(prog="ilpss-demo", description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=6)
    parser.add_argument("--episodes", type=int, default=300)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default="results/demo")
    args = parser.parse_args(argv)
    try:  # the output folder and the configuration, before any work
        check_out_dir(args.out)
        cfg = ExperimentConfig(protocol="A", n_seeds=args.seeds,
                               workers=args.workers).with_overrides(
            lifelong={"train_episodes": args.episodes, "rollout_episodes": 30})
    except ValueError as exc:
        parser.error(str(exc))
    stop_on_sigterm()
    start = time.perf_counter()
    try:
        results = run_experiment(cfg, args.out)
    except (FolderInUseError, StorageError, JobError, ValueError) as exc:
        parser.exit(1, f"{parser.prog}: error: {exc}\n")
    report = write_report(cfg, results, args.out)
    out = Path(args.out)
    held_out = cfg.teams[-1]
    env = gym.make(cfg.env_id, opponent=held_out, render_mode="rgb_array_list",
                   disable_env_checker=True)
    checkpoints = RunFolder(out).checkpoints(cfg.first_seed, 0, "ilpss")
    learner = LifelongLearner.load(checkpoints, env.observation_space)
    if learner.kernel_model is not None:
        plot_kernels_on_field(learner, out / "kernels.png")
    gif = write_agent_gif(learner, env, out / "ilpss_vs_held_out.gif", seed=1)
    print(f"report:  {report}")
    print(f"gif:     {out / 'ilpss_vs_held_out.gif'} ({gif['outcome']}, options {gif['options']})")
    print(f"kernels: {out / 'kernels.png'}" if learner.kernel_model is not None
          else "kernels: none fitted (no successful rollouts on this budget)")
    print(f"done in {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
