"""The README's main job: a small protocol A, its report, the kernels and two GIFs.

    ilpss-demo [--seeds 6] [--episodes 300] [--out results/demo]

Runs the paper's teams 1-3, then the held-out team 4, with the method the README
recommends (:data:`RECOMMENDED`), ILPSS as in the paper, fine-tuning and learning anew
(:data:`DEMO_METHODS`), on a budget that takes a few minutes on two cores; writes
``report.md`` (curves, metrics, verdicts, the command that made it), a picture of the
kernels on the field, and two GIFs against team 4: the recommended method's agent on the
first successful episode among the first :data:`GIF_EPISODES` environment seeds (how many
succeed is in the caption), and learning anew's first learning episode beside it.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import gymnasium as gym

from ilpss._io import FolderInUseError, atomic_write_bytes
from ilpss.experiments.checkpoints import StorageError
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.executor import stop_on_sigterm
from ilpss.experiments.figures import (
    greedy_episodes,
    plot_kernels_on_field,
    write_agent_gif,
    write_episode_gif,
)
from ilpss.experiments.folder import RunFolder
from ilpss.experiments.methods import METHODS
from ilpss.experiments.outputs import check_out_dir
from ilpss.experiments.report import label, write_report
from ilpss.experiments.run import JobError, run_experiment
from ilpss.lifelong import LifelongLearner, trial_seeds
from ilpss.smdp import SmdpLearner

RECOMMENDED = "ilpss_ft"
"""The method the README recommends (``docs/results.md`` and ``docs/discussion.md`` say
on what evidence)."""
DEMO_METHODS = ("scratch", "ilpss", "finetune", RECOMMENDED)
"""The demo's methods: learning anew, the paper's ILPSS, fine-tuning and the recommended
method."""
GIF_EPISODES = 20
"""The environment seeds ``0 .. GIF_EPISODES - 1`` among which the shown episode is the
first success."""


def main(argv: Sequence[str] | None = None) -> int:
    """Run the small protocol A and write its report, kernels picture and GIFs."""
    parser = argparse.ArgumentParser(prog="ilpss-demo", description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=6)
    parser.add_argument("--episodes", type=int, default=300)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default="results/demo")
    args = parser.parse_args(argv)
    command = "ilpss-demo " + shlex.join(sys.argv[1:] if argv is None else list(argv))
    try:  # the output folder and the configuration, before any work
        check_out_dir(args.out)
        cfg = ExperimentConfig(protocol="A", n_seeds=args.seeds, workers=args.workers,
                               methods=DEMO_METHODS, featured="ilpss").with_overrides(
            lifelong={"train_episodes": args.episodes, "rollout_episodes": 30})
    except ValueError as exc:
        parser.error(str(exc))
    stop_on_sigterm()
    start = time.perf_counter()
    try:
        results = run_experiment(cfg, args.out)
    except (FolderInUseError, StorageError, JobError, ValueError, OSError) as exc:
        parser.exit(1, f"{parser.prog}: error: {exc}\n")
    out = Path(args.out)
    report = write_report(cfg, results, out, command=command)
    lines = agent_lines(cfg, RunFolder(out))
    atomic_write_bytes(report, report.read_bytes() + "\n".join(["", *lines, ""]).encode())
    print(f"report:  {report}")
    print("\n".join(line for line in lines if line.startswith("- ")))
    print(f"done in {time.perf_counter() - start:.0f} s")
    return 0


def agent_lines(cfg: ExperimentConfig, folder: RunFolder) -> list[str]:
    """Write the kernels picture and the two GIFs of the first seed; their section of
    the report."""
    held_out = cfg.teams[-1]
    seed, target = cfg.first_seed, len(cfg.teams) - 1

    def env(render: bool = False) -> gym.Env:
        return gym.make(cfg.env_id, opponent=held_out, disable_env_checker=True,
                        render_mode="rgb_array_list" if render else None)

    lines = ["## The agents against the held-out team", ""]
    space = env().observation_space
    featured = cfg.featured_method
    assert featured is not None  # the demo's configuration features ILPSS
    kernels = LifelongLearner.load(folder.checkpoints(seed, 0, featured), space)
    if kernels.kernel_model is not None:
        plot_kernels_on_field(kernels, folder.figure("kernels.png"))
        lines += ["![kernels](kernels.png)", "",
                  f"The kernels of seed {seed}'s {label(featured)} learner after its "
                  f"{kernels.n_trials} trials, projected on the holder's position.", ""]
    recommended = LifelongLearner.load(folder.checkpoints(seed, 0, RECOMMENDED), space)
    episodes = greedy_episodes(recommended, env(), range(GIF_EPISODES))
    wins = [e for e in episodes if e["outcome"] == "success"]
    shown = (wins or episodes)[0]
    gif = write_agent_gif(recommended, env(render=True), folder.figure("recommended.gif"),
                          seed=shown["seed"])
    which = (f"the first success among environment seeds 0-{GIF_EPISODES - 1} (seed "
             f"{shown['seed']}; {len(wins)} of {GIF_EPISODES} succeed)" if wins else
             f"no episode of environment seeds 0-{GIF_EPISODES - 1} succeeds: seed 0")
    options = ", ".join(str(o) for o in gif["options"]) or "none"
    # Learning anew's first learning episode on the target, exactly as it was played.
    assert cfg.baseline is not None  # the demo's configuration has learning anew
    scratch = METHODS.get(cfg.baseline).config(cfg.lifelong)
    learner_seed, env_seed, _, _ = trial_seeds(seed, target)
    first = env(render=True)
    anew = SmdpLearner(int(first.action_space.n), scratch.learner.tile_coder(space), None,
                       scratch.learner, seed=learner_seed)
    fresh = write_episode_gif(anew, first, folder.figure("learning_anew_first.gif"),
                              seed=env_seed, learn=True)
    name = label(RECOMMENDED)
    return [*lines,
            f"![{name} against {held_out}](recommended.gif) "
            f"![learning anew's first episode](learning_anew_first.gif)", "",
            f"- Left: seed {seed}'s {name} agent against `{held_out}`, greedy with the "
            f"policy and options it learnt, on {which}: {gif['outcome']}, reward "
            f"{gif['reward']:+.2f}, options run: {options}.",
            f"- Right: learning anew's first learning episode against `{held_out}` (seed "
            f"{seed}, the first point of its curve): {fresh['outcome']}, reward "
            f"{fresh['reward']:+.2f}.",
            "- Under the field: the action and, when one runs, the option (its kernel and "
            "the task its policy was learnt on).", ""]


if __name__ == "__main__":
    raise SystemExit(main())
