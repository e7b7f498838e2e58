"""Does SMDP learning beat the best fixed holder rule against each opponent?

    ilpss-holder-learning --episodes 1000 --eval 500 --seeds 3 --out docs/learning.md

For every team: learn with :class:`~ilpss.smdp.SmdpLearner` (the settings of
:class:`~ilpss.lifelong.LearnerConfig` unless overridden by ``--method``,
``--trace-decay``, ``--initial-value``, ``--alpha``; no options) for ``--episodes``
episodes per seed, then evaluate the greedy policy on
``--eval`` seeded episodes; evaluate every fixed holder rule on the same episode
seeds. Mean reward with a 95% t interval and success rate with a Wilson interval.
The fixed rules are looked up by name (``--rules module:attribute``), so this module
imports no drill code.
"""

from __future__ import annotations

import argparse
import importlib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from scipy import stats

from ilpss._io import atomic_write_bytes
from ilpss.experiments.config import DRILL_ENV_ID, DRILL_TILE_WIDTHS, PAPER_TEAMS
from ilpss.experiments.executor import LocalExecutor
from ilpss.lifelong import LearnerConfig
from ilpss.metrics import wilson_interval
from ilpss.smdp import SmdpLearner
from ilpss.tiles import TileCoder

EVAL_SEED = 10_000  # evaluation episodes use seeds EVAL_SEED + i, never seen in learning


def _rules(spec: str) -> dict[str, Any]:
    module, _, attribute = spec.partition(":")
    return dict(getattr(importlib.import_module(module), attribute))


def _evaluate(env: gym.Env, act, n: int) -> np.ndarray:
    """Rewards of ``n`` episodes with seeds EVAL_SEED.. (``act(obs) -> action``)."""
    rewards = np.empty(n)
    for i in range(n):
        obs, _ = env.reset(seed=EVAL_SEED + i)
        done, total = False, 0.0
        while not done:
            obs, r, term, trunc, _ = env.step(act(obs))
            total += r
            done = term or trunc
        rewards[i] = total
    return rewards


def learn_and_evaluate(job: tuple[str, int, int, int, LearnerConfig]) -> dict[str, Any]:
    """Learn on one team with one seed, then evaluate the greedy policy."""
    team, seed, episodes, n_eval, lc = job
    env = gym.make(DRILL_ENV_ID, opponent=team, disable_env_checker=True)
    coder = TileCoder.from_space(env.observation_space, np.asarray(DRILL_TILE_WIDTHS),
                                 n_tilings=lc.n_tilings)
    learner = SmdpLearner(3, coder, seed=seed, **lc.smdp_kwargs())
    curve = [r.total_reward for r in learner.train(env, episodes, seed=seed)]
    rng = np.random.default_rng(seed)
    rewards = _evaluate(env, lambda obs: learner.q.greedy(np.asarray(obs, float), rng), n_eval)
    return {"team": team, "seed": seed, "curve": curve, "eval": rewards.tolist()}


def rule_rewards(job: tuple[str, str, str, int]) -> dict[str, Any]:
    """Rewards of one fixed rule against one team on the evaluation seeds."""
    team, spec, name, n_eval = job
    rule = _rules(spec)[name]
    env = gym.make(DRILL_ENV_ID, opponent=team, disable_env_checker=True)
    rng = np.random.default_rng(0)
    return {"team": team, "rule": name,
            "eval": _evaluate(env, lambda obs: rule(obs, rng), n_eval).tolist()}


def _summary(rewards: np.ndarray) -> tuple[float, float, float, float, float, float]:
    mean = float(rewards.mean())
    half = float(stats.t.ppf(0.975, len(rewards) - 1) * rewards.std(ddof=1) / np.sqrt(len(rewards)))
    wins = int((rewards > 0).sum())
    lo, hi = wilson_interval(wins, len(rewards))
    return mean, mean - half, mean + half, wins / len(rewards), lo, hi


def main(argv: Sequence[str] | None = None) -> int:
    """Run the comparison and write its markdown table."""
    p = argparse.ArgumentParser(prog="ilpss-holder-learning", description=__doc__.splitlines()[0])
    p.add_argument("--teams", nargs="+", default=list(PAPER_TEAMS))
    p.add_argument("--episodes", type=int, default=1000)
    p.add_argument("--eval", type=int, default=500)
    p.add_argument("--seeds", type=int, default=3)
    p.add_argument("--rules", default="soccer_drill.policies:HOLDER_POLICIES")
    p.add_argument("--workers", type=int, default=2)
    defaults = LearnerConfig()
    p.add_argument("--method", choices=["sarsa", "q"], default=defaults.method)
    p.add_argument("--trace-decay", type=float, default=defaults.trace_decay, help="lambda")
    p.add_argument("--initial-value", type=float, default=defaults.initial_value)
    p.add_argument("--alpha", type=float, default=defaults.alpha)
    p.add_argument("--out", default="docs/learning.md")
    args = p.parse_args(argv)
    lc = LearnerConfig(alpha=args.alpha, method=args.method, initial_value=args.initial_value,
                       trace_decay=args.trace_decay)
    pool = LocalExecutor(args.workers)
    learnt = pool.map(learn_and_evaluate,
                      [(t, s, args.episodes, args.eval, lc) for t in args.teams
                       for s in range(args.seeds)],
                      desc="learning")
    names = sorted(_rules(args.rules))
    fixed = pool.map(rule_rewards, [(t, args.rules, n, args.eval) for t in args.teams for n in names],
                     desc="fixed rules")
    lines = [
        "# SMDP learning against the best fixed holder rule",
        "",
        f"Command: `ilpss-holder-learning --episodes {args.episodes} --eval {args.eval} "
        f"--seeds {args.seeds} --method {lc.method} --trace-decay {lc.trace_decay:g} "
        f"--initial-value {lc.initial_value:g} --alpha {lc.alpha:g}`. Learning: SMDP "
        f"{'Q' if lc.method == 'q' else 'Sarsa'}({lc.trace_decay:g}) with replacing traces, "
        f"keepaway's tile coding, step size {lc.alpha:g}, epsilon {lc.epsilon:g}, initial "
        f"values {lc.initial_value:g}, no options, {args.episodes} episodes per seed. "
        f"Evaluation: the greedy policy of each seed and every fixed rule on the same {args.eval} episode seeds "
        "(unseen in learning). Mean reward with a 95% t interval; success rate with a 95% "
        "Wilson interval.",
        "",
        "| team | learnt: mean reward [95% CI] | learnt: success | best fixed rule | "
        "rule: mean reward [95% CI] | rule: success | learnt better? |",
        "|---|---|---|---|---|---|---|",
    ]
    beaten = 0
    for team in args.teams:
        mine = np.concatenate([r["eval"] for r in learnt if r["team"] == team])
        rules = {r["rule"]: np.asarray(r["eval"]) for r in fixed if r["team"] == team}
        best = max(rules, key=lambda n: rules[n].mean())
        m = _summary(mine)
        b = _summary(rules[best])
        diff = stats.ttest_ind(mine, rules[best], equal_var=False)
        better = m[0] > b[0] and diff.pvalue < 0.05
        beaten += better
        lines.append(
            f"| {team} | {m[0]:+.3f} [{m[1]:+.3f}, {m[2]:+.3f}] | {m[3]:.1%} [{m[4]:.1%}, {m[5]:.1%}] "
            f"| {best} | {b[0]:+.3f} [{b[1]:+.3f}, {b[2]:+.3f}] | {b[3]:.1%} [{b[4]:.1%}, {b[5]:.1%}] "
            f"| {'yes' if better else 'no'} (Welch p = {diff.pvalue:.3g}) |"
        )
    lines += ["", f"**The learnt policy beats the best fixed rule on {beaten} of "
              f"{len(args.teams)} teams** (higher mean reward, Welch t-test p < 0.05).", ""]
    curves = {t: np.mean([r["curve"] for r in learnt if r["team"] == t], axis=0) for t in args.teams}
    lines += ["Mean learning reward per 100 episodes (mean over seeds):", "",
              "| team | " + " | ".join(f"{i}-{i + 99}" for i in range(0, args.episodes, 100)) + " |",
              "|---|" + "---|" * len(range(0, args.episodes, 100))]
    for t, c in curves.items():
        cells = [f"{np.mean(c[i:i + 100]):+.2f}" for i in range(0, args.episodes, 100)]
        lines.append(f"| {t} | " + " | ".join(cells) + " |")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(out, ("\n".join(lines) + "\n").encode())
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
