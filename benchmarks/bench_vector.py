"""The batched drill's cost per drill-cycle against one drill's physics floor, in one run.

    python benchmarks/bench_vector.py [--sizes 1 16 64 256 1024] [--cycles 6000] [--rounds 3]

The floor is ``bench_env.PhysicsLoop``: one drill's own pymunk space (four players, the
ball, the walls), one velocity set per body and the sub-steps per cycle. Each loop runs
blocks of about ``--cycles`` drill-cycles, the loops taking turns with the floor for
``--rounds`` rounds; a loop's ratio is the median over rounds of its block's CPU time
per drill-cycle (``time.thread_time``) over the floor's block of the same round. The
loops, with the paper's teams (``interceptors_cover`` here; ``--team`` another):

* ``holder step``: ``HolderVectorEnv.step`` (random actions): every drill waits for the
  slowest drill's decision, so its drill-cycles are the cycles the drills ran, not the
  cycles the batch ran;
* ``holder play``: ``play_episodes`` with a fixed rule (``pass_first``): no drill waits;
* ``agents``: ``ParallelVectorEnv`` with the attackers as agents (random legal actions)
  and the team's defenders;
* ``single env()``: the AEC environment's cycle (``bench_env.AecLoop``), for its own aim.

Then memory per drill (``tracemalloc``: what building and resetting N drills allocates,
per drill) and a profile per component at ``--profile-size`` drills.
"""

from __future__ import annotations

import argparse
import cProfile
import os
import platform
import pstats
import statistics
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_env import AecLoop, PhysicsLoop

from soccer_drill.policies import HOLDER_POLICIES
from soccer_drill.vector import HolderVectorEnv, play_episodes
from soccer_drill.vector_agents import ParallelVectorEnv


class HolderStep:
    def __init__(self, n: int, team: str) -> None:
        self.env = HolderVectorEnv(num_envs=n, opponent=team)
        self.env.reset(seed=0)
        self.rng = np.random.default_rng(0)

    def run(self, cycles: int) -> int:
        done = 0
        while done < cycles:
            *_, info = self.env.step(self.rng.integers(3, size=self.env.num_envs))
            done += int(info["duration"].sum())
        return done


class HolderPlay:
    def __init__(self, n: int, team: str) -> None:
        self.env = HolderVectorEnv(num_envs=n, opponent=team)
        self.seed = 0

    def run(self, cycles: int) -> int:
        episodes = max(self.env.num_envs, cycles // 80)  # about 80 cycles an episode
        batch = self.env._core.batch
        before = batch.cycles_run
        play_episodes(self.env, HOLDER_POLICIES["pass_first"], range(self.seed, self.seed + episodes))
        self.seed += episodes
        return batch.cycles_run - before


class Agents:
    def __init__(self, n: int, team: str) -> None:
        self.env = ParallelVectorEnv(num_envs=n, opponent=team)
        self.obs, _ = self.env.reset(seed=0)
        self.rng = np.random.default_rng(0)

    def run(self, cycles: int) -> int:
        n = self.env.num_envs
        steps = max(1, cycles // n)
        for _ in range(steps):
            acts = {a: (self.rng.random((n, 5)) * self.obs[a]["action_mask"]).argmax(1)
                    for a in self.env.agents}
            self.obs, *_ = self.env.step(acts)
        return steps * n


class Single:
    def __init__(self) -> None:
        self.loop = AecLoop()

    def run(self, cycles: int) -> int:
        return self.loop.run(cycles)


def cost(loop, cycles: int) -> float:
    start = time.thread_time()
    n = loop.run(cycles)
    return (time.thread_time() - start) / n * 1e6


def memory_per_drill(n: int, team: str) -> float:
    tracemalloc.start()
    env = HolderVectorEnv(num_envs=n, opponent=team)
    env.reset(seed=0)
    size, _ = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    del env
    return size / n / 1024


def profile(n: int, team: str, cycles: int) -> list[tuple[str, float]]:
    env = ParallelVectorEnv(num_envs=n, opponent=team)
    loop = Agents.__new__(Agents)
    loop.env, loop.rng = env, np.random.default_rng(0)
    loop.obs, _ = env.reset(seed=0)
    prof = cProfile.Profile(timer=time.thread_time)
    prof.enable()
    loop.run(cycles)
    prof.disable()
    stats = pstats.Stats(prof).stats  # type: ignore[attr-defined]
    groups = {
        "physics (pymunk spaces, batched reads/writes)": ("batch_physics.py", "cycle"),
        "team (batched act and its checks)": ("batch_teams.py", "act"),
        "off-ball skills (targets, interception, support spots)": ("batch_skills.py", "off_ball_targets"),
        "holder's ball skills": ("batch_skills.py", "holder_motion"),
        "possession and tackles": ("batch.py", "_possession"),
        "outcome": ("batch.py", "_judge"),
        "observations and masks": ("vector_agents.py", "_observations"),
        "action checks": ("vector_agents.py", "_commands"),
        "whole step": ("vector_agents.py", "step"),
    }
    out = []
    for label, (file, func) in groups.items():
        total = sum(v[3] for k, v in stats.items() if k[0].endswith(file) and k[2] == func)
        out.append((label, total / (cycles // n * n) * 1e6))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1, 16, 64, 256, 1024])
    parser.add_argument("--cycles", type=int, default=6000)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--team", default="interceptors_cover")
    parser.add_argument("--profile-size", type=int, default=64)
    args = parser.parse_args()
    floor = PhysicsLoop()
    loops: dict[str, object] = {"single env()": Single()}
    for n in args.sizes:
        loops[f"holder step N={n}"] = HolderStep(n, args.team)
        loops[f"holder play N={n}"] = HolderPlay(n, args.team)
        loops[f"agents N={n}"] = Agents(n, args.team)
    ratios: dict[str, list[float]] = {k: [] for k in loops}
    costs: dict[str, list[float]] = {k: [] for k in loops}
    floors = []
    for _ in range(args.rounds):
        for name, loop in loops.items():
            f = cost(floor, 2000)
            c = cost(loop, args.cycles)
            floors.append(f)
            costs[name].append(c)
            ratios[name].append(c / f)
    print(f"python {platform.python_version()}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}; "
          f"floor {statistics.median(floors):.1f} us/cycle (median of {len(floors)} blocks)")
    print("| loop | us per drill-cycle (median) | ratio to the floor (median over rounds) |")
    print("|---|---:|---:|")
    for name in loops:
        print(f"| {name} | {statistics.median(costs[name]):.1f} | {statistics.median(ratios[name]):.2f}x |")
    print("\n| drills | memory per drill (KiB) |\n|---:|---:|")
    for n in args.sizes:
        print(f"| {n} | {memory_per_drill(n, args.team):.1f} |")
    print(f"\nprofile of the agents loop at N={args.profile_size} (CPU us per drill-cycle, inclusive):")
    print("| component | us per drill-cycle |\n|---|---:|")
    for label, us in profile(args.profile_size, args.team, 64 * 200):
        print(f"| {label} | {us:.2f} |")


if __name__ == "__main__":
    main()
