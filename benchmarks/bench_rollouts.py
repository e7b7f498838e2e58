"""What share of an ILPSS trial its greedy rollouts take, and how much of them is the drill.

    python benchmarks/bench_rollouts.py [--trials 3] [--seed 1000] [--teams ...]

A trial (:meth:`ilpss.lifelong.LifelongLearner.run_trial`) learns for
``train_episodes`` episodes, then rolls the learnt policy out greedily for
``rollout_episodes`` episodes (its traces and the options it used) and refits the
kernels. The rollouts are the one place of a trial where many episodes of a frozen
policy could share the batched drill (``soccer_drill.vector``). This measures, per
team of the paper and over ``--trials`` trials of one lifelong learner with
``LifelongConfig``'s defaults (development seed ``--seed``):

* ``learn``: CPU seconds of the learning episodes;
* ``close``: the trial's close (:meth:`~ilpss.lifelong.LifelongLearner.extract`: the
  rollouts, the bag of states, the refit);
* ``rollouts``: the same number of greedy rollouts of the same learnt policy, timed on
  their own, and ``in the drill``: the part of them spent in the drill's ``step``.

The last column is the most that batching the rollouts could save, as a share of a
trial: their time in the drill times ``1 - batched / single``, with the costs per
decision of ``benchmarks/bench_vector.py`` (``--batched-us``, ``--single-us``: one
``HolderEnv.step`` and a holder in a batch of 64 through ``send``/``recv``).
CPU time of this thread (``time.thread_time``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium as gym

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ilpss.experiments.drill_facts import ENV_ID, PAPER_TEAMS
from ilpss.lifelong import LifelongConfig, LifelongLearner


class StepTimer(gym.Wrapper):
    """Adds up the CPU time of this thread spent in the wrapped environment's ``step``."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        self.seconds = 0.0

    def step(self, action: Any) -> Any:
        start = time.thread_time()
        try:
            return self.env.step(action)
        finally:
            self.seconds += time.thread_time() - start


def measure(team: str, trials: int, seed: int) -> dict[str, float]:
    """CPU seconds of ``trials`` trials against ``team``, by part."""
    config = LifelongConfig()
    env = StepTimer(gym.make(ENV_ID, opponent=team, disable_env_checker=True))
    lifelong = LifelongLearner(config, env.observation_space, int(env.action_space.n), seed)
    spent = dict.fromkeys(("learn", "close", "rollouts", "in the drill"), 0.0)
    for _ in range(trials):
        start = time.thread_time()
        learner, results = lifelong.learn(env)
        learnt = time.thread_time()
        lifelong.extract(env, team, learner, results)
        closed = time.thread_time()
        env.seconds = 0.0
        learner.evaluate(env, config.rollout_episodes, seed=seed + 7)
        spent["rollouts"] += time.thread_time() - closed
        spent["in the drill"] += env.seconds
        spent["learn"] += learnt - start
        spent["close"] += closed - learnt
    env.close()
    return spent


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=3)
    parser.add_argument("--seed", type=int, default=1000)
    parser.add_argument("--teams", nargs="+", default=list(PAPER_TEAMS))
    parser.add_argument("--batched-us", type=float, default=104.0,
                        help="us per decision of a holder in a batch (bench_vector: holder async N=64)")
    parser.add_argument("--single-us", type=float, default=251.0,
                        help="us per decision of one HolderEnv.step (bench_vector: single holder step)")
    args = parser.parse_args(argv)
    if args.trials < 1 or not 0 < args.batched_us <= args.single_us:
        parser.error("--trials must be >= 1 and 0 < --batched-us <= --single-us")
    keep = 1 - args.batched_us / args.single_us
    print(f"{args.trials} trials per team, LifelongConfig's defaults, seed {args.seed}; "
          f"CPU seconds")
    print("| team | learn | close | rollouts | in the drill | rollouts / trial | "
          "batching saves at most |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    total = dict.fromkeys(("learn", "close", "rollouts", "in the drill"), 0.0)
    for team in [*args.teams, "all"]:
        spent = total if team == "all" else measure(team, args.trials, args.seed)
        if team != "all":
            for key, value in spent.items():
                total[key] += value
        trial = spent["learn"] + spent["close"]
        print(f"| {team} | {spent['learn']:.2f} | {spent['close']:.2f} | {spent['rollouts']:.2f} | "
              f"{spent['in the drill']:.2f} | {spent['rollouts'] / trial:.1%} | "
              f"{spent['in the drill'] * keep / trial:.1%} |")


if __name__ == "__main__":
    main()
