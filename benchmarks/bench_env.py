"""Environment cost per cycle against the bare physics floor, measured in one run.

    python benchmarks/bench_env.py [--block 2000] [--rounds 25]

Each loop below runs in short blocks (``--block`` cycles), the loops taking turns, for
``--rounds`` rounds; a block's cost is the CPU time of this thread per cycle
(``time.thread_time``), so time the process spends descheduled on a loaded machine is
not counted. A loop's cost is its fastest block (the least disturbed by other jobs).
The table shows three ratios to the floor: of the fastest blocks, of the median blocks,
and the median over rounds of each round's ratio (a loop's block against the floor's
block of the same round, measured within a second of each other), with its interquartile
range. The paired one moves least between runs on a shared machine, where the speed of
the whole machine drifts: a fastest block is one extreme of 25, and the floor's
fastest block decides every ratio of the first column.

The loops: the bare pymunk cycle of the drill's own space (one velocity set per body,
then the sub-steps: the floor); an AEC cycle through ``soccer_drill.env()`` (scripted
defenders, random legal attacker actions drawn in advance, ``last()`` for both agents,
as users loop); the same behind PettingZoo's standard wrappers; a parallel-env cycle;
and a holder-env cycle (random policy). Then the safety checks, each measured alone as
the fastest of many short blocks: the thread guard of ``step``, the team time bound,
the team's command checks, an agent action's check; and what a reset costs, with the
physics space rebuilt (what ``reset`` does) and, for comparison, kept.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
import timeit
from collections.abc import Callable

import numpy as np
import pymunk

import soccer_drill
from soccer_drill.config import DrillConfig
from soccer_drill.drill.drills import BatchDrill
from soccer_drill.drill.spaces import DrillSpace


class RandomLegal:
    """Uniformly random legal actions, drawn in advance so user code costs almost nothing."""

    def __init__(self, seed: int = 0, size: int = 1 << 20) -> None:
        self._u = np.random.default_rng(seed).random(size).tolist()
        self._k = 0
        self._legal: dict[bytes, list[int]] = {}

    def __call__(self, mask: np.ndarray) -> int:
        key = mask.tobytes()
        legal = self._legal.get(key)
        if legal is None:
            legal = self._legal[key] = np.flatnonzero(mask).tolist()
        self._k = (self._k + 1) % len(self._u)
        return legal[int(self._u[self._k] * len(legal))]


def wrapped_env(**kwargs):
    """The drill behind PettingZoo's standard wrapper chain (for comparison only)."""
    from pettingzoo.utils import wrappers

    return wrappers.OrderEnforcingWrapper(
        wrappers.AssertOutOfBoundsWrapper(soccer_drill.raw_env(**kwargs))
    )


class AecLoop:
    """AEC episodes as users loop them; ``run(n)`` plays ``n`` more cycles."""

    def __init__(self, make: Callable = soccer_drill.env, opponent: str = "chasers") -> None:
        self.env = make(opponent=opponent)
        self.pick = RandomLegal()
        self.seed = 0
        self._start()

    def _start(self) -> None:
        self.env.reset(seed=self.seed)
        self.seed += 1
        self.turns = iter(self.env.agent_iter())

    def run(self, cycles: int) -> int:
        env, pick, last_agent = self.env, self.pick, self.env.possible_agents[-1]
        done = 0
        while done < cycles:
            for agent in self.turns:
                obs, _, term, trunc, _ = env.last()
                if term or trunc:
                    env.step(None)
                    continue
                env.step(pick(obs["action_mask"]))
                if agent == last_agent:
                    done += 1
                    if done >= cycles:
                        break
            else:
                self._start()
        return done


class ParallelLoop:
    """Parallel-env episodes; ``run(n)`` plays ``n`` more cycles."""

    def __init__(self, opponent: str = "chasers") -> None:
        self.env = soccer_drill.parallel_env(opponent=opponent)
        self.pick = RandomLegal()
        self.seed = 0
        self.obs: dict = {}

    def run(self, cycles: int) -> int:
        env, pick = self.env, self.pick
        for _ in range(cycles):
            if not env.agents:
                self.obs, _ = env.reset(seed=self.seed)
                self.seed += 1
            obs = self.obs
            self.obs, *_ = env.step({a: pick(obs[a]["action_mask"]) for a in env.agents})
        return cycles


class HolderLoop:
    """Holder-env episodes with a random policy; ``run(n)`` runs at least ``n`` cycles."""

    def __init__(self, opponent: str = "chasers") -> None:
        self.env = soccer_drill.HolderEnv(opponent=opponent)
        self.pick, self.mask = RandomLegal(), np.ones(3, dtype=np.int8)
        self.seed = 0
        self.finished = True
        self.decisions = self.cycles = 0

    def run(self, cycles: int) -> int:
        env, pick, mask = self.env, self.pick, self.mask
        done = 0
        while done < cycles:
            if self.finished:
                env.reset(seed=self.seed)
                self.seed += 1
            _, _, term, trunc, info = env.step(pick(mask))
            self.decisions += 1
            done += info["duration"]
            self.finished = term or trunc
        self.cycles += done
        return done


class PhysicsLoop:
    """The floor: the drill's own pymunk space (4 players, ball, walls), stepped bare."""

    def __init__(self, cycles: int = 1 << 16) -> None:
        cfg = DrillConfig()
        physics = DrillSpace(cfg)
        start = np.zeros((1, 5, 2))
        start[0, :4] = [*cfg.attacker_starts, *cfg.defender_starts]
        start[0, 4] = start[0, 0, 0], start[0, 0, 1] - cfg.ball_offset
        physics.renew(np.zeros(1, dtype=np.int64), start)
        self.space: pymunk.Space = physics.space
        self.bodies = list(self.space.bodies)  # the 4 players and the ball
        self.dt, self.substeps = cfg.cycle_seconds / cfg.substeps, cfg.substeps
        rng = np.random.default_rng(0)
        self.velocities = rng.uniform(-3, 3, size=(cycles, len(self.bodies), 2)).tolist()
        self.k = 0

    def run(self, cycles: int) -> int:
        space, bodies, dt, substeps = self.space, self.bodies, self.dt, self.substeps
        velocities, k = self.velocities, self.k
        for _ in range(cycles):
            for body, v in zip(bodies, velocities[k], strict=True):  # one velocity set per cycle
                body.velocity = v
            for _ in range(substeps):
                space.step(dt)
            k = (k + 1) % len(velocities)
        self.k = k
        return cycles


def cycle_costs(loops: dict[str, object], block: int, rounds: int) -> dict[str, list[float]]:
    """Per loop, the CPU microseconds per cycle of each block, the loops taking turns."""
    costs: dict[str, list[float]] = {name: [] for name in loops}
    for _ in range(rounds):
        for name, loop in loops.items():
            start = time.thread_time()
            n = loop.run(block)  # type: ignore[attr-defined]
            costs[name].append((time.thread_time() - start) / n * 1e6)
    return costs


def _fastest_us(call: Callable[[], object], number: int, repeat: int) -> float:
    """CPU microseconds per call: the fastest of ``repeat`` blocks of ``number`` calls."""
    timer = timeit.Timer(call, timer=time.thread_time)
    return min(timer.repeat(number=number, repeat=repeat)) / number * 1e6


def reset_us(rebuild: bool, number: int = 100, repeat: int = 30) -> float:
    """Microseconds per reset of a single drill; ``rebuild=False`` keeps the previous space."""
    cfg, rng, one = DrillConfig(), np.random.default_rng(0), np.zeros(1, dtype=np.int64)
    drill = BatchDrill(1, cfg, physics=DrillSpace(cfg))
    drill.reset(one, [rng])
    if not rebuild:
        drill.physics.renew = lambda drills, pos: None  # the old reset: same bodies, same space
    return _fastest_us(lambda: drill.reset(one, [rng]), number, repeat)


def env_reset_us(opponent: str = "chasers", number: int = 100, repeat: int = 30) -> float:
    """Microseconds per ``env.reset(seed=...)`` of the AEC environment (team reset included)."""
    env = soccer_drill.env(opponent=opponent)
    seeds = iter(range(10**9))
    return _fastest_us(lambda: env.reset(seed=next(seeds)), number, repeat)


def guard_us(number: int = 20_000, repeat: int = 30) -> float:
    """Microseconds the thread guard adds to one ``step`` call (around an empty step)."""
    env = soccer_drill.env(opponent="chasers")
    env.reset(seed=0)
    env._step = lambda action: None  # only the guard is left in env.step
    guarded = _fastest_us(lambda: env.step(0), number, repeat)
    bare = _fastest_us(lambda: env._step(0), number, repeat)
    return guarded - bare


def team_check_costs(number: int = 20_000, repeat: int = 30) -> dict[str, float]:
    """Microseconds per cycle of the team's safety checks, each alone.

    ``bound``: the team driver's ``act`` with the time bound against the same driver
    without it. ``commands``: checking and writing the commands the team returned (the
    chasers' one command, in arrays). ``action``: checking one agent's action and setting
    its command.
    """
    from soccer_drill.teams.driver import check_commands

    env = soccer_drill.env(opponent="chasers")
    env.reset(seed=0)
    driver, batch = env._core.team, env._core.batch
    one = np.zeros(1, dtype=np.int64)
    bounded = _fastest_us(lambda: driver.act(one), number, repeat)
    timeout, driver.team_timeout = driver.team_timeout, None
    unbounded = _fastest_us(lambda: driver.act(one), number, repeat)
    driver.team_timeout = timeout
    returned = driver.batched.act(driver.view, one)
    commands = _fastest_us(lambda: check_commands(returned, batch.commands, one, batch.cycle,
                                                  driver.name, driver.view.players, False),
                           number, repeat)
    action = _fastest_us(lambda: env._command("attacker_0", 0, 3), number, repeat)
    return {"bound": bounded - unbounded, "commands": commands, "action": action}


def mean_episode_cycles(episodes: int = 200, opponent: str = "chasers") -> float:
    """Mean length of an AEC episode with random legal actions, in cycles."""
    env = soccer_drill.env(opponent=opponent)
    pick, total = RandomLegal(), 0
    for seed in range(episodes):
        env.reset(seed=seed)
        for _ in env.agent_iter():
            obs, _, term, trunc, _ = env.last()
            env.step(None if term or trunc else pick(obs["action_mask"]))
        total += env.drill_state.cycle
    return total / episodes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--block", type=int, default=2000, help="cycles per block")
    parser.add_argument("--rounds", type=int, default=25, help="blocks per loop")
    args = parser.parse_args()
    load_before = os.getloadavg()
    holder = HolderLoop()
    loops = {
        "physics": PhysicsLoop(),
        "aec": AecLoop(),
        "aec_wrapped": AecLoop(make=wrapped_env),
        "parallel": ParallelLoop(),
        "holder": holder,
    }
    costs = cycle_costs(loops, args.block, args.rounds)
    low: dict[str, float] = {}
    checks: dict[str, float] = {}
    for _ in range(3):  # fastest of each, interleaved
        for name, value in (
            ("reset_rebuild", reset_us(rebuild=True)),
            ("reset_reuse", reset_us(rebuild=False)),
            ("env_reset", env_reset_us()),
            ("guard", guard_us()),
        ):
            low[name] = min(low.get(name, float("inf")), value)
        for name, value in team_check_costs().items():
            checks[name] = min(checks.get(name, float("inf")), value)
    load_after = os.getloadavg()
    best = {name: min(values) for name, values in costs.items()}
    median = {name: statistics.median(values) for name, values in costs.items()}
    phys, phys_median = best["physics"], median["physics"]
    print(f"python {platform.python_version()}, pymunk {pymunk.version}, {platform.machine()}, "
          f"{os.cpu_count()} CPUs; load average {load_before[0]:.1f} before, "
          f"{load_after[0]:.1f} after; {args.rounds} blocks of {args.block} cycles per loop")
    print()
    paired = {name: sorted(v / p for v, p in zip(values, costs["physics"], strict=True))
              for name, values in costs.items()}
    print("| loop | CPU us per cycle (fastest block) | x physics floor | x floor (median "
          "blocks) | x floor (paired by round: median [quartiles]) |")
    print("|---|---:|---:|---:|---:|")
    for key, label in (("physics", "bare pymunk cycle (10 sub-steps, same bodies)"),
                       ("aec", "AEC cycle via env(), chasers, 2 agent turns"),
                       ("aec_wrapped", "same, behind PettingZoo's standard wrappers"),
                       ("parallel", "parallel_env cycle, chasers"),
                       ("holder", "holder env cycle (random policy)")):
        quartiles = statistics.quantiles(paired[key], n=4)
        print(f"| {label} | {best[key]:.1f} | {best[key] / phys:.2f} | "
              f"{median[key] / phys_median:.2f} | {statistics.median(paired[key]):.2f} "
              f"[{quartiles[0]:.2f}, {quartiles[2]:.2f}] |")
    print(f"(a holder decision lasts {holder.cycles / holder.decisions:.1f} cycles on average)")
    cycle = best["aec"]
    print()
    print("| safety check | us per call | per AEC cycle | share of the AEC cycle |")
    print("|---|---:|---:|---:|")
    for label, per_call, calls in (
        ("thread guard (per `step`)", low["guard"], 2),
        ("team time bound (per `act`)", checks["bound"], 1),
        ("team command checks (the chasers' 2 commands: one object)", checks["commands"], 1),
        ("agent action check (per action)", checks["action"], 2),
    ):
        print(f"| {label} | {per_call:.2f} | {per_call * calls:.2f} | "
              f"{per_call * calls / cycle:.1%} |")
    episode_us = mean_episode_cycles() * cycle
    rebuild = low["reset_rebuild"] - low["reset_reuse"]
    print()
    print("| reset | us per reset |")
    print("|---|---:|")
    print(f"| Drill.reset, space rebuilt | {low['reset_rebuild']:.1f} |")
    print(f"| Drill.reset, space kept (for comparison) | {low['reset_reuse']:.1f} |")
    print(f"| cost of the rebuild | {rebuild:+.1f} |")
    print(f"| env.reset(seed) of the AEC env, chasers | {low['env_reset']:.1f} |")
    print(f"| rebuild / (AEC episode of random legal actions, {episode_us / cycle:.0f} cycles "
          f"= {episode_us / 1000:.1f} ms) | {rebuild / episode_us:.1%} |")
    print(f"| rebuild / (bare pymunk cycle) | {rebuild / phys:.1f} cycles |")


if __name__ == "__main__":
    main()
