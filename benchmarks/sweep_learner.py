"""Sweep of SMDP learner settings against the four paper teams (no options).

    python benchmarks/sweep_learner.py NAME '{"method": "q", "initial_value": 1.0, "trace_decay": 0.9}' \
        --episodes 1000 --seeds 3 --eval 150

For every paper team and seed: learn for ``--episodes`` episodes with the given
:class:`~ilpss.smdp.SmdpLearner` keyword arguments, then evaluate the greedy policy on
``--eval`` unseen episode seeds, both the final weights and the snapshot taken at the
end of the 100-episode block with the best training reward. Prints one line per setting
(mean greedy reward per team, then each seed) and the mean training reward per
100 episodes. The figures of the sweep that chose ``LearnerConfig``'s defaults are in
``docs/learning_sweep.md``.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import gymnasium as gym
import numpy as np

from ilpss.experiments.drill_facts import ENV_ID as DRILL_ENV_ID
from ilpss.experiments.drill_facts import PAPER_TEAMS
from ilpss.experiments.drill_facts import TILE_WIDTHS as DRILL_TILE_WIDTHS
from ilpss.experiments.executor import LocalExecutor
from ilpss.experiments.holder_learning import evaluation_rewards
from ilpss.lifelong import LearnerConfig
from ilpss.smdp import KEEPAWAY, SmdpLearner

BLOCK = 100


def job(args: tuple[str, int, int, int, dict[str, Any]]) -> tuple[str, int, list[float], float, float]:
    """Learn on one team with one seed; greedy reward of the final and the best-block weights."""
    team, seed, episodes, n_eval, kwargs = args
    env = gym.make(DRILL_ENV_ID, opponent=team, disable_env_checker=True)
    coder = LearnerConfig(tile_widths=DRILL_TILE_WIDTHS).tile_coder(env.observation_space)
    learner = SmdpLearner(3, coder, None, replace(KEEPAWAY, **kwargs), seed=seed)
    curve: list[float] = []
    best_score, best_weights = -np.inf, learner.q.weights.copy()
    for b in range(episodes // BLOCK):
        curve += [r.total_reward for r in learner.train(env, BLOCK, seed=seed if b == 0 else None)]
        if np.mean(curve[-BLOCK:]) >= best_score:
            best_score, best_weights = float(np.mean(curve[-BLOCK:])), learner.q.weights.copy()
    rng = np.random.default_rng(seed)
    final = evaluation_rewards(env, lambda o: learner.q.greedy(np.asarray(o, float), rng), n_eval)
    learner.q.weights[:] = best_weights
    snap = evaluation_rewards(env, lambda o: learner.q.greedy(np.asarray(o, float), rng), n_eval)
    blocks = [float(np.mean(curve[i:i + BLOCK])) for i in range(0, len(curve), BLOCK)]
    return team, seed, blocks, float(final.mean()), float(snap.mean())


def main(argv: Sequence[str] | None = None) -> int:
    """Run one setting of the sweep and print its line."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("name")
    p.add_argument("kwargs", help="LearnerConfig fields as JSON (on top of keepaway's Sarsa(0))")
    p.add_argument("--episodes", type=int, default=1000)
    p.add_argument("--seeds", type=int, default=3)
    p.add_argument("--eval", type=int, default=150)
    p.add_argument("--workers", type=int, default=2)
    args = p.parse_args(argv)
    start = time.perf_counter()
    jobs = [(t, s, args.episodes, args.eval, json.loads(args.kwargs))
            for t in PAPER_TEAMS for s in range(args.seeds)]
    results = LocalExecutor(args.workers).map(job, jobs, desc=args.name)
    cells = [args.name, f"{time.perf_counter() - start:.0f} s"]
    for team in PAPER_TEAMS:
        mine = [r for r in results if r[0] == team]
        final, snap = [r[3] for r in mine], [r[4] for r in mine]
        cells.append(f"{team}: {np.mean(final):+.2f} ({' '.join(f'{v:+.2f}' for v in final)}) "
                     f"best block {np.mean(snap):+.2f}")
    print(" | ".join(cells))
    for team in PAPER_TEAMS:
        blocks = np.mean([r[2] for r in results if r[0] == team], axis=0)
        print(f"    {team}: " + " ".join(f"{v:+.2f}" for v in blocks))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
