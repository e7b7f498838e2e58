"""The README's main job: a small protocol A, its report, the kernels and two GIFs.

    ilpss-demo [--seeds 6] [--episodes 300] [--out results/demo]

Runs the paper's teams 1-3, then the held-out team 4, with the method the README
recommends (:data:`RECOMMENDED`), ILPSS as in the paper, fine-tuning and learning anew
(:func:`demo_methods`), on a budget that takes a few minutes on two cores; writes
``report.md`` (curves, metrics, verdicts, the command that made it), a picture of the
kernels on the field, and two GIFs against team 4: the recommended method's agent on the
first successful episode among the first :data:`GIF_EPISODES` environment seeds (how many
succeed is in the caption), and learning anew's first learning episode beside it.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym

from ilpss._io import FolderInUseError, atomic_write_bytes
from ilpss.experiments.checkpoints import StorageError
from ilpss.experiments.config import TRAIN_EPISODES, ExperimentConfig
from ilpss.experiments.drill_facts import (
    PANEL,
    SIDE_BY_SIDE,
    TEAM_ERROR,
    drill_exception,
    drill_object,
)
from ilpss.experiments.executor import stop_on_sigterm, stopped_in_one_line
from ilpss.experiments.figures import (
    greedy_agent,
    greedy_runs,
    plot_kernels_on_field,
    write_episode_gif,
)
from ilpss.experiments.folder import RunFolder
from ilpss.experiments.methods import METHODS, FineTuneMethod, LifelongMethod
from ilpss.experiments.outputs import check_out_dir, check_utf8, unwritten_report
from ilpss.experiments.protocols import make_env
from ilpss.experiments.report import write_report
from ilpss.experiments.report_text import label
from ilpss.experiments.run import JobError, run_experiment
from ilpss.lifelong import LifelongLearner, trial_seeds
from ilpss.options import OptionLibrary
from ilpss.policy import FrozenPolicy
from ilpss.smdp import LearnerConfig, SmdpLearner
from soccer_drill.constraints import check

RECOMMENDED = "whole_policies_ft_bounded_cut"
"""The method the README recommends (``docs/results.md`` and ``docs/discussion.md`` say
on what evidence): the one place the demo takes it from, a lifelong or a fine-tuning
method (:func:`check_showable`). The README's paragraph on ``make demo`` names it too
(``tests/test_readme.py`` checks that it does)."""
SHOWN_METHODS = ("scratch", "ilpss", "finetune")
"""The methods the demo runs beside the recommended one: learning anew (the baseline and
the right GIF), the paper's ILPSS (its kernels are drawn) and fine-tuning."""
OUTPUTS = ("report.md", "kernels.png", "side_by_side.gif", "recommended.gif",
           "learning_anew_first.gif")
"""What the demo writes beside its run's folders: the report, the kernels picture, the
two agents side by side on one episode seed and their own GIFs (:func:`agent_lines`)."""
GIF_EPISODES = 20
"""The environment seeds ``0 .. GIF_EPISODES - 1`` among which the shown episode is the
first success."""


def demo_methods() -> tuple[str, ...]:
    """:data:`SHOWN_METHODS` and :data:`RECOMMENDED`, each once, in that order."""
    return tuple(dict.fromkeys((*SHOWN_METHODS, RECOMMENDED)))


def main(argv: Sequence[str] | None = None) -> int:
    """Run the small protocol A and write its report, kernels picture and GIFs."""
    with stopped_in_one_line("ilpss-demo"):  # Ctrl-C or SIGTERM: one line, 130 or 143
        return _main(argv)


def _main(argv: Sequence[str] | None) -> int:
    parser = argparse.ArgumentParser(prog="ilpss-demo", description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=6,
                        help="seeds: independent runs of the whole protocol (default %(default)s)")
    parser.add_argument("--episodes", type=int, default=300,
                        help="learning episodes per team (default %(default)s)")
    parser.add_argument("--workers", type=int, default=2,
                        help="parallel jobs, worker processes (default %(default)s)")
    parser.add_argument("--out", default="results/demo",
                        help="the run folder: report.md, the kernels picture, the GIFs and the "
                        "results, resumed if it holds this run (default %(default)s)")
    args = parser.parse_args(argv)
    command = "ilpss-demo " + shlex.join(sys.argv[1:] if argv is None else list(argv))
    try:  # the configuration, the method shown and the output folder, before any work
        check_utf8(args)
        check("--episodes", args.episodes, TRAIN_EPISODES)
        cfg = ExperimentConfig(protocol="A", n_seeds=args.seeds, workers=args.workers,
                               methods=demo_methods(), featured="ilpss").with_overrides(
            lifelong={"train_episodes": args.episodes, "rollout_episodes": 30})
        check_showable(RECOMMENDED)
        check_out_dir(args.out)  # last: it creates the folder
    except ValueError as exc:
        parser.error(str(exc))
    stop_on_sigterm()
    start = time.perf_counter()
    try:
        results = run_experiment(cfg, args.out)
    except (FolderInUseError, StorageError, JobError, ValueError, OSError,
            drill_exception(TEAM_ERROR)) as exc:  # TeamError: a team fails to load
        parser.exit(1, f"{parser.prog}: error: {exc}\n")
    out = Path(args.out)
    try:
        report = write_report(cfg, results, out, command=command)
        lines = agent_lines(cfg, RunFolder(out))
        atomic_write_bytes(report, report.read_bytes() + "\n".join(["", *lines, ""]).encode())
    except OSError as exc:  # a full disk: the results stay, a rerun writes the report
        parser.exit(1, f"{parser.prog}: error: {unwritten_report(out, exc)}\n")
    print(f"report:  {report}")
    print("\n".join(line for line in lines if line.startswith("- ")))
    print(f"done in {time.perf_counter() - start:.0f} s")
    return 0


@dataclass(frozen=True)
class TargetAgent:
    """What a method learnt against the held-out team, played greedily: call it with a
    seed for an agent (seeded as the environment's episode, as the GIF's is)."""

    policy: FrozenPolicy
    library: OptionLibrary | None
    config: LearnerConfig
    task_names: tuple[str, ...]
    """The tasks of the policies its options come from, in order."""

    def __call__(self, seed: int) -> SmdpLearner:
        return greedy_agent(self.policy, self.library, self.config, seed)


def check_showable(method: str) -> None:
    """Refuse (``ValueError``), before any work, a method whose agent the demo cannot
    show: it shows a lifelong method's (from its checkpoint) or fine-tuning's (learnt
    again from learning anew's checkpoint)."""
    if not isinstance(METHODS.get(method), LifelongMethod | FineTuneMethod):
        raise ValueError(
            f"the demo shows the recommended method's agent, and {method!r} is neither a "
            "lifelong nor a fine-tuning method: it leaves no policy to show"
        )


def target_agent(cfg: ExperimentConfig, folder: RunFolder, method: str,
                 seed: int) -> TargetAgent:
    """The agent ``method`` learnt against the held-out team in seed ``seed``'s job: a
    lifelong method's from its checkpoint; fine-tuning's learnt again from learning
    anew's checkpoint, as in the run (the episodes must be the run's curve, else
    ``ValueError``)."""
    check_showable(method)
    stream = cfg.streams(seed)[0]
    target = stream.first_target  # the held-out team, right after the sources
    env = make_env(cfg.env_id, stream.tasks[target])
    kind = METHODS.get(method)
    if isinstance(kind, LifelongMethod):
        learner = LifelongLearner.load(folder.checkpoints(seed, 0, method), env.observation_space)
        return TargetAgent(learner.policies[-1], learner.library, learner.config.learner,
                           tuple(r.name for r in learner.records))
    scratch = LifelongLearner.load(folder.checkpoints(seed, 0, "scratch"), env.observation_space)
    learner, episodes = kind.learn_target(cfg, seed, scratch, target, env)
    run = json.loads(folder.result(seed, 0).read_text(encoding="utf-8"))
    if [float(e.total_reward) for e in episodes] != run["methods"][method]["curves"][str(target)]:
        raise ValueError(f"{method} learnt again on seed {seed} does not play the run's "
                         f"episodes ({folder.result(seed, 0)}): not the run's agent")
    return TargetAgent(learner.freeze(), None, cfg.lifelong.learner, ())


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
    recommended = target_agent(cfg, folder, RECOMMENDED, seed)
    episodes = greedy_runs(recommended, env(), range(GIF_EPISODES))
    wins = [e for e in episodes if e["outcome"] == "success"]
    shown = (wins or episodes)[0]
    gif = write_episode_gif(recommended(shown["seed"]), env(render=True),
                            folder.figure("recommended.gif"), seed=shown["seed"],
                            task_names=list(recommended.task_names),
                            label=f"{label(RECOMMENDED)}, greedy")
    which = (f"the first success among environment seeds 0-{GIF_EPISODES - 1} (seed "
             f"{shown['seed']}; {len(wins)} of {GIF_EPISODES} succeed)" if wins else
             f"environment seed 0 (none of environment seeds 0-{GIF_EPISODES - 1} "
             "succeeds)")
    options = ", ".join(str(o) for o in gif["options"]) or "none"
    # Learning anew's first learning episode on the target, exactly as it was played.
    assert cfg.baseline is not None  # the demo's configuration has learning anew
    scratch = METHODS.get(cfg.baseline).config(cfg.lifelong)
    learner_seed, env_seed, _, _ = trial_seeds(seed, target)
    first = env(render=True)
    anew = SmdpLearner(int(first.action_space.n), scratch.learner.tile_coder(space), None,
                       scratch.learner, seed=learner_seed)
    fresh = write_episode_gif(anew, first, folder.figure("learning_anew_first.gif"),
                              seed=env_seed, learn=True, label="learning anew, 1st episode")
    name = label(RECOMMENDED)
    # Side by side on the recommended agent's episode seed: it, and learning anew's first
    # learning episode (a learner seeded as in the run, on that seed).
    novice = SmdpLearner(int(first.action_space.n), scratch.learner.tile_coder(space), None,
                         scratch.learner, seed=learner_seed)
    panel = drill_object(PANEL)
    drill_object(SIDE_BY_SIDE)(
        folder.figure("side_by_side.gif"),
        [panel(f"{name}, greedy", lambda e, s: recommended(s).run_episode(e, learn=False, seed=s)),
         panel("learning anew, 1st episode",
               lambda e, s: novice.run_episode(e, learn=True, seed=s))],
        lambda: env(render=True), [shown["seed"]])
    learnt = ("policy it learnt" if recommended.library is None else
              "policy and options it learnt")
    return [*lines,
            f"![{name} beside learning anew against {held_out}](side_by_side.gif)", "",
            f"Left, {name} greedy; right, learning anew's first learning episode: both on "
            f"environment seed {shown['seed']} against `{held_out}`.", "",
            f"![{name} against {held_out}](recommended.gif) "
            f"![learning anew's first episode](learning_anew_first.gif)", "",
            f"- Left: seed {seed}'s {name} agent against `{held_out}`, greedy with the "
            f"{learnt}, on {which}: {gif['outcome']}, reward "
            f"{gif['reward']:+.2f}, options run: {options}.",
            f"- Right: learning anew's first learning episode against `{held_out}` (seed "
            f"{seed}, the first point of its curve): {fresh['outcome']}, reward "
            f"{fresh['reward']:+.2f}.",
            "- Under the field of these two (not of the side-by-side one): the action and, "
            "when one runs, the option (its kernel and the task its policy was learnt on).",
            ""]


if __name__ == "__main__":
    raise SystemExit(main())
