"""Calibration of the drill: every team against every fixed holder rule.

    soccer-drill-calibrate [--episodes 500] [--out docs/opponents.md] [--gifs docs/gifs]

For each team, success rate (95% Wilson interval) and mean reward (95% t interval)
over seeded episodes of each fixed holder rule of :mod:`soccer_drill.policies`, the
three criteria the drill is tuned for, and a small GIF of each team.
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import stats

from opponents import PAPER_TEAMS
from soccer_drill.gif import write_episode_gif
from soccer_drill.holder import HolderEnv
from soccer_drill.policies import HOLDER_POLICIES

TEAMS = (*PAPER_TEAMS, "chasers")


@dataclass(frozen=True)
class Cell:
    """One team against one rule."""

    team: str
    rule: str
    successes: int
    episodes: int
    mean_reward: float
    reward_low: float
    reward_high: float

    @property
    def success_rate(self) -> float:
        return self.successes / self.episodes

    @property
    def success_interval(self) -> tuple[float, float]:
        ci = stats.binomtest(self.successes, self.episodes).proportion_ci(method="wilson")
        return ci.low, ci.high


def evaluate(team: str, rule: str, episodes: int, first_seed: int = 0) -> Cell:
    """Play ``episodes`` seeded episodes of ``rule`` against ``team``."""
    env = HolderEnv(opponent=team)
    policy = HOLDER_POLICIES[rule]
    rng = np.random.default_rng(first_seed)
    rewards = np.empty(episodes)
    wins = 0
    for i in range(episodes):
        obs, _ = env.reset(seed=first_seed + i)
        done, total = False, 0.0
        while not done:
            obs, reward, term, trunc, info = env.step(policy(obs, rng))
            total += reward
            done = term or trunc
        wins += info["outcome"] == "success"
        rewards[i] = total
    half = stats.t.ppf(0.975, episodes - 1) * rewards.std(ddof=1) / np.sqrt(episodes)
    mean = float(rewards.mean())
    return Cell(team, rule, wins, episodes, mean, mean - half, mean + half)


def _evaluate(args: tuple[str, str, int]) -> Cell:
    return evaluate(*args)


def calibrate(
    episodes: int, teams: Sequence[str] = TEAMS, workers: int = 2
) -> dict[tuple[str, str], Cell]:
    """Every (team, rule) cell, in parallel processes."""
    jobs = [(t, r, episodes) for t in teams for r in HOLDER_POLICIES]
    with ProcessPoolExecutor(workers) as pool:
        cells = list(pool.map(_evaluate, jobs))
    return {(c.team, c.rule): c for c in cells}


def criteria(cells: dict[tuple[str, str], Cell], teams: Sequence[str] = PAPER_TEAMS) -> list[str]:
    """The three calibration criteria, each with its measured figures and verdict."""
    rules = [r for r in HOLDER_POLICIES if r != "random"]
    worst_random = max(cells[(t, "random")].success_rate for t in teams)
    best = {t: max(rules, key=lambda r: cells[(t, r)].success_rate) for t in teams}
    weakest = min(cells[(t, best[t])].success_rate for t in teams)
    rankings = {
        t: tuple(sorted(rules, key=lambda r: -cells[(t, r)].mean_reward)) for t in teams
    }
    return [
        f"1. The random holder succeeds in less than a quarter of episodes against every "
        f"paper team: highest random success rate {worst_random:.1%} -> "
        f"{'met' if worst_random < 0.25 else 'NOT met'}.",
        "2. Some fixed rule succeeds in at least a third of episodes against every paper "
        "team: the best rule per team reaches "
        + ", ".join(f"{t} {best[t]} {cells[(t, best[t])].success_rate:.1%}" for t in teams)
        + f" -> {'met' if weakest >= 1 / 3 else 'NOT met'} (lowest {weakest:.1%}).",
        "3. The ranking of the fixed rules (by mean reward) is not the same against all four "
        f"teams: {len(set(rankings.values()))} distinct rankings; best rule by mean reward "
        + ", ".join(f"{t}: {rankings[t][0]}" for t in teams)
        + f" -> {'met' if len(set(rankings.values())) > 1 else 'NOT met'}.",
    ]


def write_markdown(
    cells: dict[tuple[str, str], Cell], episodes: int, path: str | os.PathLike[str],
    gifs: dict[str, str],
) -> Path:
    """``docs/opponents.md``: the table, the criteria and the GIFs."""
    teams = sorted({t for t, _ in cells}, key=TEAMS.index)
    lines = [
        "# Opponent teams and the calibrated drill",
        "",
        f"Command: `soccer-drill-calibrate --episodes {episodes}` (seeds 0..{episodes - 1} for "
        "every cell; the holder environment with its defaults). Success rate with a 95% Wilson "
        "interval; mean reward with a 95% t interval.",
        "",
        "## Criteria",
        "",
        *criteria(cells),
        "",
        "## Table",
        "",
        "| team | rule | success rate [95% CI] | mean reward [95% CI] |",
        "|---|---|---|---|",
    ]
    for t in teams:
        for r in HOLDER_POLICIES:
            c = cells[(t, r)]
            lo, hi = c.success_interval
            lines.append(
                f"| {t} | {r} | {c.success_rate:.1%} [{lo:.1%}, {hi:.1%}] | "
                f"{c.mean_reward:+.3f} [{c.reward_low:+.3f}, {c.reward_high:+.3f}] |"
            )
    lines += ["", "## The teams", ""]
    for t in teams:
        if t in gifs:
            lines += [f"### {t}", "", f"![{t}]({gifs[t]})", ""]
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.tmp")
    tmp.write_text("\n".join(lines) + "\n")
    os.replace(tmp, out)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="soccer-drill-calibrate", description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=500)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default="docs/opponents.md")
    parser.add_argument("--gifs", default="docs/gifs", help="folder for one GIF per team ('' for none)")
    args = parser.parse_args(argv)
    if args.episodes < 2:
        parser.error("--episodes must be at least 2")
    cells = calibrate(args.episodes, workers=args.workers)
    gifs = {}
    if args.gifs:
        out_dir = Path(args.out).parent
        for team in TEAMS:
            path = Path(args.gifs) / f"{team}.gif"
            write_episode_gif(path, team=team, seed=1, policy="lane", fps=8)
            gifs[team] = os.path.relpath(path, out_dir)
    print(write_markdown(cells, args.episodes, args.out, gifs).read_text())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
