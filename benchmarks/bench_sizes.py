"""Cost per player-cycle at 3v2 against 2v2, each against its own physics floor, in one run.

    python benchmarks/bench_sizes.py [--block 1000] [--rounds 9] [--drills 256]

For each size, the loops take turns in blocks (``--block`` cycles of one drill, or
``--block // 8`` cycles of the batch), ``--rounds`` rounds, a block's cost the CPU time of
this thread (``time.thread_time``). The loops of a size:

* ``floor``: the bare pymunk cycle of one drill's own space with that size's bodies (one
  velocity set per body, the sub-steps), as ``benchmarks/bench_env.py``'s floor;
* ``parallel``: a ``parallel_env`` cycle, the attackers agents (a random legal action for
  each, chosen from its mask by the loop), ``chasers`` defending; and the same loop's
  ``reset`` and ``step`` calls alone (the environment's cost, without the client's choice);
* ``holder``: a ``HolderEnv`` cycle (random actions);
* ``batch floor``: the bare ``BatchPhysics`` cycle of ``--drills`` drills (one batched
  write, the sub-steps, one batched read), per drill;
* ``batched holder``: ``HolderVectorEnv`` of ``--drills`` drills, random actions, per
  drill-cycle run.

A cost is the median block; the ratios divide it by its own size's floor (single loops
by ``floor``, the batched one by ``batch floor``) measured in the same rounds, and the
last column compares 3v2's ratio with 2v2's (below 1: 3v2 costs no more over its floor).
Per player-cycle divides a cycle's cost by the number of players (4 or 5).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import numpy as np
import pymunk

import soccer_drill
from soccer_drill.config import DrillConfig
from soccer_drill.drill.spaces import BatchPhysics, DrillSpace
from soccer_drill.vector import HolderVectorEnv


class Floor:
    """One drill's own pymunk space of ``cfg``'s size, stepped bare."""

    def __init__(self, cfg: DrillConfig) -> None:
        physics = DrillSpace(cfg)
        start = np.zeros((1, cfg.players + 1, 2))
        start[0, :-1] = [*cfg.attacker_starts, *cfg.defender_starts]
        start[0, -1] = start[0, 0, 0], start[0, 0, 1] - cfg.ball_offset
        physics.renew(np.zeros(1, dtype=np.int64), start)
        self.space, self.bodies = physics.space, list(physics.space.bodies)
        self.dt, self.substeps = cfg.cycle_seconds / cfg.substeps, cfg.substeps
        self.velocities = np.random.default_rng(0).uniform(
            -3, 3, size=(4096, len(self.bodies), 2)).tolist()
        self.k = 0

    def run(self, cycles: int) -> int:
        for _ in range(cycles):
            for body, v in zip(self.bodies, self.velocities[self.k], strict=True):
                body.velocity = v
            for _ in range(self.substeps):
                self.space.step(self.dt)
            self.k = (self.k + 1) % len(self.velocities)
        return cycles


class Parallel:
    """``parallel_env`` episodes, the attackers agents, random legal actions.

    ``env_seconds`` adds up the CPU time of the environment's own calls (``reset`` and
    ``step``), leaving out the client's random legal choice (``np.flatnonzero`` of each
    agent's mask), which the block's time includes."""

    def __init__(self, cfg: DrillConfig) -> None:
        self.env = soccer_drill.parallel_env(config=cfg, opponent="chasers")
        self.u = np.random.default_rng(0).random(1 << 20).tolist()
        self.k, self.seed, self.obs = 0, 0, {}
        self.env_seconds = 0.0

    def run(self, cycles: int) -> int:
        env, clock, spent = self.env, time.thread_time, 0.0
        for _ in range(cycles):
            if not env.agents:
                start = clock()
                self.obs, _ = env.reset(seed=self.seed)
                spent += clock() - start
                self.seed += 1
            actions = {}
            for a in env.agents:
                legal = np.flatnonzero(self.obs[a]["action_mask"])
                self.k = (self.k + 1) % len(self.u)
                actions[a] = int(legal[int(self.u[self.k] * len(legal))])
            start = clock()
            self.obs, *_ = env.step(actions)
            spent += clock() - start
        self.env_seconds = spent
        return cycles


ENV_ONLY = "parallel, the environment's calls only"


class Holder:
    """``HolderEnv`` episodes with random actions; counts the cycles run."""

    def __init__(self, cfg: DrillConfig) -> None:
        self.env = soccer_drill.HolderEnv(config=cfg)
        self.rng, self.seed, self.finished = np.random.default_rng(0), 0, True

    def run(self, cycles: int) -> int:
        done, n = 0, self.env.action_space.n
        while done < cycles:
            if self.finished:
                self.env.reset(seed=self.seed)
                self.seed += 1
            _, _, term, trunc, info = self.env.step(int(self.rng.integers(n)))
            done += info["duration"]
            self.finished = term or trunc
        return done


class BatchFloor:
    """``BatchPhysics`` of ``drills`` drills, stepped bare; counts drill-cycles."""

    def __init__(self, cfg: DrillConfig, drills: int) -> None:
        self.physics = BatchPhysics(drills, cfg)
        rng = np.random.default_rng(0)
        self.pos = np.tile(np.array([*cfg.attacker_starts, *cfg.defender_starts, (10.0, 10.0)]),
                           (drills, 1, 1))
        self.vel = rng.uniform(-3, 3, size=(64, drills, cfg.players + 1, 2))
        self.drills, self.k = drills, 0

    def run(self, cycles: int) -> int:
        for _ in range(cycles):
            out = self.physics.cycle(self.pos, self.vel[self.k % 64], None)
            self.pos[:, :-1] = out[:, :, 0:2]
            self.k += 1
        return cycles * self.drills


class BatchedHolder:
    """``HolderVectorEnv`` of ``drills`` drills, random actions; counts drill-cycles."""

    def __init__(self, cfg: DrillConfig, drills: int) -> None:
        self.env = HolderVectorEnv(num_envs=drills, config=cfg, opponent="chasers")
        self.env.reset(seed=0)
        self.rng, self.n = np.random.default_rng(0), self.env.single_action_space.n

    def run(self, cycles: int) -> int:
        batch = self.env.loop.core.batch
        before = batch.cycles_run
        for _ in range(max(1, cycles // 4)):  # a step runs about four cycles
            self.env.step(self.rng.integers(self.n, size=self.env.num_envs))
        return batch.cycles_run - before


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--block", type=int, default=1000)
    parser.add_argument("--rounds", type=int, default=9)
    parser.add_argument("--drills", type=int, default=256)
    args = parser.parse_args()
    sizes = {"2v2": DrillConfig(), "3v2": DrillConfig(attackers=3, defenders=2)}
    loops = {}
    for size, cfg in sizes.items():
        loops[size] = {"floor": Floor(cfg), "parallel": Parallel(cfg), "holder": Holder(cfg),
                       "batch floor": BatchFloor(cfg, args.drills),
                       "batched holder": BatchedHolder(cfg, args.drills)}
    costs = {size: {name: [] for name in [*group, ENV_ONLY]} for size, group in loops.items()}
    load_before = os.getloadavg()
    for _ in range(args.rounds):
        for size, group in loops.items():
            for name, loop in group.items():
                block = args.block if "batch" not in name else max(1, args.block // 8)
                start = time.thread_time()
                n = loop.run(block)
                costs[size][name].append((time.thread_time() - start) / n * 1e6)
                if isinstance(loop, Parallel):
                    costs[size][ENV_ONLY].append(loop.env_seconds / n * 1e6)
    load_after = os.getloadavg()
    print(f"python {platform.python_version()}, pymunk {pymunk.version}, {os.cpu_count()} CPUs; "
          f"load average {load_before[0]:.1f} before, {load_after[0]:.1f} after; "
          f"{args.rounds} rounds, blocks of {args.block} cycles ({args.block // 8} of the "
          f"batch of {args.drills} drills)")
    print()
    print("| loop | 2v2: us per player-cycle | x its floor | 3v2: us per player-cycle "
          "| x its floor | 3v2's ratio / 2v2's |")
    print("|---|---:|---:|---:|---:|---:|")
    median = {size: {name: statistics.median(v) for name, v in group.items()}
              for size, group in costs.items()}
    players = {size: cfg.players for size, cfg in sizes.items()}
    for name, floor in (("floor", "floor"), ("parallel", "floor"), (ENV_ONLY, "floor"),
                        ("holder", "floor"),
                        ("batch floor", "batch floor"), ("batched holder", "batch floor")):
        cells, ratios = [], []
        for size in sizes:
            per_player = median[size][name] / players[size]
            ratio = median[size][name] / median[size][floor]
            cells += [f"{per_player:.2f}", f"{ratio:.2f}"]
            ratios.append(ratio)
        print(f"| {name} | " + " | ".join(cells) + f" | {ratios[1] / ratios[0]:.2f} |")


if __name__ == "__main__":
    main()
