"""The batched drill's cost per drill-cycle against one drill's physics floor, in one run.

    python benchmarks/bench_vector.py [--sizes 1 16 64 256 1024] [--cycles 6000] [--rounds 3]
                                      [--against DIR]

The floor is ``bench_env.PhysicsLoop``: one drill's own pymunk space (four players, the
ball, the walls), one velocity set per body and the sub-steps per cycle. Each loop runs
blocks of about ``--cycles`` drill-cycles, the loops taking turns with the floor for
``--rounds`` rounds; a loop's ratio is the median over rounds of its block's CPU time
per drill-cycle (``time.thread_time``) over the floor's block of the same round. The
loops, with the paper's teams (``interceptors_cover`` here; ``--team`` another):

* ``holder step``: ``HolderVectorEnv.step`` (random actions): every drill waits for the
  slowest drill's decision, so its drill-cycles are the cycles the drills ran, not the
  cycles the batch ran;
* ``holder async``: ``send``/``recv`` with ``batch_size = N / 4`` (random actions): a
  batch comes back as soon as a quarter of the drills are done, so a drill waits for
  the first quarter to finish, not for the slowest;
* ``holder play``: ``play_episodes`` with a fixed rule (``pass_first``): no drill waits;
* ``agents``: ``ParallelVectorEnv`` with the attackers as agents (random legal actions)
  and the team's defenders;
* ``single env()``: the AEC environment's cycle (``bench_env.AecLoop``), for its own aim;
* ``single holder step``: ``HolderEnv.step`` (``bench_env.HolderLoop``), what one drill's
  decision costs without the batch.

For the holder loops the cost per decision (one holder's action, what an agent pays per
``step`` of one drill) is printed beside the cost per drill-cycle.

Each round runs one block of every loop in a subprocess of its own, whose loops start
afresh (seed 0). ``--against DIR`` measures another checkout of the project (e.g. ``git
worktree add /tmp/before main``) in the same run: each round runs one such subprocess per
tree (this file's loops, on ``DIR``'s ``soccer_drill``), the trees going first in turn
(the second reads a few per cent slower), every ratio against the floor measured in its
own process in that round; the table has both trees' medians over rounds.

Then each batched loop's cost per cycle split into a fixed part and a part per drill (a
line through its costs at the sizes from 2 to ``--fit-max``), and the size from which it
is at most the floor; memory per drill (``tracemalloc``: what building and resetting N
drills allocates, per drill); and a profile per component at ``--profile-size`` drills.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import platform
import pstats
import statistics
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_env import AecLoop, HolderLoop, PhysicsLoop

from soccer_drill.policies import HOLDER_POLICIES
from soccer_drill.vector import HolderVectorEnv, ParallelVectorEnv, play_episodes


class HolderStep:
    def __init__(self, n: int, team: str) -> None:
        self.env = HolderVectorEnv(num_envs=n, opponent=team)
        self.env.reset(seed=0)
        self.rng = np.random.default_rng(0)

        self.decisions = 0

    def run(self, cycles: int) -> int:
        done = 0
        while done < cycles:
            *_, info = self.env.step(self.rng.integers(3, size=self.env.num_envs))
            done += int(info["duration"].sum())
            self.decisions += int((info["duration"] > 0).sum())  # autoresets decide nothing
        return done


class HolderAsync:
    """``send``/``recv`` with ``batch_size = N / 4`` (random actions): a drill gets its next
    action once a quarter of the drills are done, not when the slowest is."""

    def __init__(self, n: int, team: str) -> None:
        self.env = HolderVectorEnv(num_envs=n, opponent=team, batch_size=max(1, n // 4))
        self.env.async_reset(seed=0)
        self.rng = np.random.default_rng(0)
        self.decisions = 0

    def run(self, cycles: int) -> int:
        done = 0
        while done < cycles:
            *_, info = self.env.recv()
            ids = info["env_id"]
            self.env.send(self.rng.integers(3, size=len(ids)), ids)
            done += int(info["duration"].sum())
            self.decisions += int((info["duration"] > 0).sum())
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


class SingleHolder:
    def __init__(self, team: str) -> None:
        self.loop = HolderLoop(team)

    @property
    def decisions(self) -> int:
        return self.loop.decisions

    def run(self, cycles: int) -> int:
        return self.loop.run(cycles)


class Single:
    def __init__(self) -> None:
        self.loop = AecLoop()

    def run(self, cycles: int) -> int:
        return self.loop.run(cycles)


def cost(loop, cycles: int) -> float:
    """CPU us per drill-cycle of a block of about ``cycles`` drill-cycles (and, for the
    holder's loops, ``loop.last_decision_cost``: us per decision)."""
    decisions = getattr(loop, "decisions", None)
    start = time.thread_time()
    n = loop.run(cycles)
    spent = time.thread_time() - start
    if decisions is not None:
        loop.last_decision_cost = spent / max(1, loop.decisions - decisions) * 1e6
    return spent / n * 1e6


def measure(sizes: list[int], team: str, cycles: int, rounds: int) -> dict:
    """Every loop's ratios to the floor (one per round), costs and costs per decision."""
    floor = PhysicsLoop()
    loops: dict[str, object] = {"single env()": Single(), "single holder step": SingleHolder(team)}
    for n in sizes:
        loops[f"holder step N={n}"] = HolderStep(n, team)
        try:
            loops[f"holder async N={n}"] = HolderAsync(n, team)
        except TypeError:  # a checkout (--against) from before send/recv
            pass
        loops[f"holder play N={n}"] = HolderPlay(n, team)
        loops[f"agents N={n}"] = Agents(n, team)
    out: dict = {"ratios": {k: [] for k in loops}, "costs": {k: [] for k in loops},
                 "per_decision": {}, "floors": []}
    for _ in range(rounds):
        for name, loop in loops.items():
            f = cost(floor, 2000)
            c = cost(loop, cycles)
            out["floors"].append(f)
            out["costs"][name].append(c)
            out["ratios"][name].append(c / f)
            if hasattr(loop, "last_decision_cost"):
                out["per_decision"].setdefault(name, []).append(loop.last_decision_cost)
    return out


def fixed_and_marginal(sizes: list[int], costs: list[float]) -> tuple[float, float]:
    """The least-squares line ``a + b * N`` through a loop's CPU us per batch cycle
    (``N`` times its us per drill-cycle) at batch sizes ``sizes``: ``a`` is what a cycle
    costs whatever its size (Python and the count of NumPy calls), ``b`` what each
    drill adds (the arrays' length, the physics). Sizes below 2 are left out (one drill
    takes another path)."""
    points = [(n, n * c) for n, c in zip(sizes, costs, strict=True) if n >= 2]
    if len(points) < 2:
        raise ValueError(f"need costs at two batch sizes >= 2, got sizes {sizes}")
    b, a = np.polyfit([n for n, _ in points], [c for _, c in points], 1)
    return float(a), float(b)


def _worker(tree: str, args: argparse.Namespace) -> dict:
    """One round of every loop on ``tree``'s code, in a subprocess."""
    env = {**os.environ, "PYTHONPATH": tree}
    command = [sys.executable, str(Path(__file__).resolve()), "--json", "--rounds", "1",
               "--cycles", str(args.cycles), "--team", args.team, "--sizes", *map(str, args.sizes)]
    done = subprocess.run(command, env=env, cwd="/", capture_output=True, text=True, check=True)
    return json.loads(done.stdout)


def _merge(into: dict | None, part: dict) -> dict:
    if into is None:
        return part
    for key in ("ratios", "costs", "per_decision"):
        for name, values in part[key].items():
            into[key].setdefault(name, []).extend(values)
    into["floors"].extend(part["floors"])
    return into


def memory_per_drill(n: int, team: str) -> float:
    HolderVectorEnv(num_envs=1, opponent=team).reset(seed=0)  # first use: compiled rules
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
        "physics (pymunk spaces, batched reads/writes)": ("drill/spaces.py", "cycle"),
        "team (batched act and its checks)": ("teams/driver.py", "act"),
        "the drill's cycle (BatchDrill.step: skills, ball, physics, possession; the "
        "compiled rules, which cProfile does not see apart, inside it)": (
            "drill/drills.py", "step"),
        "observations and masks": ("vector/agents.py", "_observations"),
        "action checks": ("vector/agents.py", "_commands"),
        "whole step": ("vector/agents.py", "step"),
    }
    out = []
    for label, (file, func) in groups.items():
        total = sum(v[3] for k, v in stats.items() if k[0].endswith(file) and k[2] == func)
        out.append((label, total / (cycles // n * n) * 1e6))
    return out


def _print_fits(done: dict, sizes: list[int]) -> None:
    """Each batched loop's cost per cycle as a fixed part and a part per drill, and the
    size from which its cost per drill-cycle is at most the floor (where ``a + b N <=
    N * floor``; none if each drill alone costs more than the floor)."""
    if len([n for n in sizes if n >= 2]) < 2:
        return
    labels = list(done)
    print("\n| loop | " + " | ".join(
        f"{k}: us per cycle, fixed | {k}: us per drill | {k}: per drill / floor | "
        f"{k}: at the floor from N =" for k in labels) + " |")
    print("|---|" + "---:|---:|---:|---:|" * len(labels))
    for kind in ("holder step", "holder async", "holder play", "agents"):
        cells = []
        for k in labels:
            costs = done[k]["costs"]
            have = [n for n in sizes if f"{kind} N={n}" in costs]
            if len([n for n in have if n >= 2]) < 2:
                cells += ["", "", "", ""]
                continue
            floor = statistics.median(done[k]["floors"])
            a, b = fixed_and_marginal(have, [statistics.median(costs[f"{kind} N={n}"]) for n in have])
            cells += [f"{a:.0f}", f"{b:.1f}", f"{b / floor:.2f}x",
                      f"{a / (floor - b):.0f}" if b < floor else "none"]
        print(f"| {kind} | " + " | ".join(cells) + " |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1, 16, 64, 256, 1024])
    parser.add_argument("--cycles", type=int, default=6000)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--team", default="interceptors_cover")
    parser.add_argument("--profile-size", type=int, default=64)
    parser.add_argument("--fit-max", type=int, default=256,
                        help="largest batch size in the fixed + per drill fit (beyond it the "
                             "spaces' size adds to each drill's cost)")
    parser.add_argument("--against", metavar="DIR", help="another checkout, measured in the same run")
    parser.add_argument("--json", action="store_true", help=argparse.SUPPRESS)  # a worker's output
    args = parser.parse_args()
    if args.json:
        print(json.dumps(measure(args.sizes, args.team, args.cycles, args.rounds)))
        return
    here = str(Path(__file__).resolve().parents[1])
    trees = {"this": here} if args.against is None else {"before": args.against, "after": here}
    runs: dict[str, dict | None] = dict.fromkeys(trees)
    for k in range(args.rounds):
        # the trees take turns going first: the one run second reads a few per cent slower
        for label, tree in (list(trees.items()) if k % 2 == 0 else reversed(trees.items())):
            runs[label] = _merge(runs[label], _worker(tree, args))
    done = {k: v for k, v in runs.items() if v is not None}
    print(f"python {platform.python_version()}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}; "
          + "; ".join(f"{k}: floor {statistics.median(v['floors']):.1f} us/cycle (median of "
                      f"{len(v['floors'])} blocks)" for k, v in done.items()))
    labels = list(done)
    print("| loop | " + " | ".join(f"{k}: us per drill-cycle | {k}: ratio to the floor" for k in labels)
          + " | " + " | ".join(f"{k}: us per decision" for k in labels) + " |")
    print("|---|" + "---:|---:|" * len(labels) + "---:|" * len(labels))
    names = list(dict.fromkeys(name for k in reversed(labels) for name in done[k]["ratios"]))
    for name in names:  # a loop the other tree has not got: an empty cell
        cells = []
        for k in labels:
            costs, ratios = done[k]["costs"].get(name), done[k]["ratios"].get(name)
            cells += ([f"{statistics.median(costs):.1f}", f"{statistics.median(ratios):.2f}x"]
                      if ratios else ["", ""])
        for k in labels:
            per = done[k]["per_decision"].get(name)
            cells.append(f"{statistics.median(per):.0f}" if per else "")
        print(f"| {name} | " + " | ".join(cells) + " |")
    _print_fits(done, [n for n in args.sizes if n <= args.fit_max])
    print("\n| drills | memory per drill (KiB) |\n|---:|---:|")
    for n in args.sizes:
        print(f"| {n} | {memory_per_drill(n, args.team):.1f} |")
    print(f"\nprofile of the agents loop at N={args.profile_size} (CPU us per drill-cycle, inclusive):")
    print("| component | us per drill-cycle |\n|---|---:|")
    for label, us in profile(args.profile_size, args.team, 64 * 200):
        print(f"| {label} | {us:.2f} |")


if __name__ == "__main__":
    main()
