"""Environment throughput against the bare physics floor, measured in one run.

    python benchmarks/bench_env.py [--cycles 20000] [--repeats 3]

Prints a markdown table: AEC cycles per second through ``soccer_drill.env()`` (scripted
defenders, random legal attacker actions, observations read with ``last()`` as users do),
parallel-env cycles per second, holder decisions per second (random policy), and the
bare pymunk cost of the same bodies and sub-steps, with the ratio per cycle. Then two
costs measured in the same run, each as the fastest of many short blocks (robust to a
loaded machine): the thread guard of ``step`` (``env.step`` against a direct call of the
unguarded ``env._step``, both around an empty step, so only the guard differs), and
what rebuilding the physics space costs per reset (``Drill.reset`` against the same
reset with the space kept from the previous episode, as before the rebuild).
"""

from __future__ import annotations

import argparse
import platform
import time
import timeit

import numpy as np
import pymunk

import soccer_drill
from soccer_drill.drill import Drill


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


def aec_cycles_per_second(cycles: int, opponent: str = "chasers", make=soccer_drill.env) -> float:
    env = make(opponent=opponent)
    pick = RandomLegal()
    done_cycles, seed = 0, 0
    start = time.perf_counter()
    while done_cycles < cycles:
        env.reset(seed=seed)
        seed += 1
        for agent in env.agent_iter():
            obs, _, term, trunc, _ = env.last()
            if term or trunc:
                env.step(None)
                continue
            env.step(pick(obs["action_mask"]))
            if agent == env.possible_agents[-1]:
                done_cycles += 1
    return done_cycles / (time.perf_counter() - start)


def parallel_cycles_per_second(cycles: int, opponent: str = "chasers") -> float:
    env = soccer_drill.parallel_env(opponent=opponent)
    pick = RandomLegal()
    done_cycles, seed = 0, 0
    start = time.perf_counter()
    while done_cycles < cycles:
        obs, _ = env.reset(seed=seed)
        seed += 1
        while env.agents:
            actions = {a: pick(obs[a]["action_mask"]) for a in env.agents}
            obs, *_ = env.step(actions)
            done_cycles += 1
    return done_cycles / (time.perf_counter() - start)


def holder_rates(decisions: int, opponent: str = "chasers") -> tuple[float, float]:
    """(decisions per second, cycles per second) of the holder env with a random policy."""
    env = soccer_drill.HolderEnv(opponent=opponent)
    pick, mask = RandomLegal(), np.ones(3, dtype=np.int8)
    done, cycles, seed = 0, 0, 0
    start = time.perf_counter()
    while done < decisions:
        env.reset(seed=seed)
        seed += 1
        finished = False
        while not finished:
            _, _, term, trunc, info = env.step(pick(mask))
            done += 1
            cycles += info["duration"]
            finished = term or trunc
    elapsed = time.perf_counter() - start
    return done / elapsed, cycles / elapsed


def physics_cycles_per_second(cycles: int) -> float:
    """The floor: the drill's own pymunk space (4 players, ball, walls), stepped bare."""
    drill = Drill()
    drill.reset(np.random.default_rng(0))
    space: pymunk.Space = drill._space
    cfg = drill.config
    dt = cfg.cycle_seconds / cfg.substeps
    bodies = [*drill._players, drill._ball]
    rng = np.random.default_rng(0)
    velocities = rng.uniform(-3, 3, size=(cycles, len(bodies), 2)).tolist()
    start = time.perf_counter()
    for c in range(cycles):
        for body, v in zip(bodies, velocities[c], strict=True):  # one velocity set per cycle
            body.velocity = v
        for _ in range(cfg.substeps):
            space.step(dt)
    return cycles / (time.perf_counter() - start)


def _fastest_us(call, number: int, repeat: int) -> float:
    """Microseconds per call: the fastest of ``repeat`` blocks of ``number`` calls."""
    return min(timeit.repeat(call, number=number, repeat=repeat)) / number * 1e6


def reset_us(rebuild: bool, number: int = 100, repeat: int = 30) -> float:
    """Microseconds per ``Drill.reset``; ``rebuild=False`` keeps the previous space."""
    drill = Drill()
    rng = np.random.default_rng(0)
    drill.reset(rng)
    if not rebuild:
        drill._build_space = lambda: None  # the old reset: same bodies, same space
    return _fastest_us(lambda: drill.reset(rng), number, repeat)


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
    parser.add_argument("--cycles", type=int, default=20000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    best: dict[str, float] = {}
    for _ in range(args.repeats):  # interleaved repeats, best of each: robust to noise
        for name, value in (
            ("physics", physics_cycles_per_second(args.cycles)),
            ("aec", aec_cycles_per_second(args.cycles)),
            ("aec_wrapped", aec_cycles_per_second(args.cycles, make=wrapped_env)),
            ("parallel", parallel_cycles_per_second(args.cycles)),
        ):
            best[name] = max(best.get(name, 0.0), value)
        decisions, holder_cycles = holder_rates(args.cycles // 2)
        best["holder"] = max(best.get("holder", 0.0), decisions)
        best["holder_cycles"] = max(best.get("holder_cycles", 0.0), holder_cycles)
    low: dict[str, float] = {}
    for _ in range(args.repeats):  # fastest of each, interleaved
        for name, value in (
            ("reset_rebuild", reset_us(rebuild=True)),
            ("reset_reuse", reset_us(rebuild=False)),
            ("env_reset", env_reset_us()),
            ("guard", guard_us()),
        ):
            low[name] = min(low.get(name, float("inf")), value)
    phys = best["physics"]
    print(f"python {platform.python_version()}, pymunk {pymunk.version}, {platform.machine()}")
    print("| measure | per second | us per cycle | x physics floor |")
    print("|---|---|---|---|")
    print(f"| bare pymunk cycle (10 sub-steps, same bodies) | {phys:,.0f} | {1e6 / phys:.1f} | 1.0 |")
    for key, label in (("aec", "AEC cycle via env(), chasers, 2 agent turns"),
                       ("aec_wrapped", "same, behind PettingZoo's standard wrappers"),
                       ("parallel", "parallel_env cycle, chasers"),
                       ("holder_cycles", "holder env cycle (random policy)")):
        print(f"| {label} | {best[key]:,.0f} | {1e6 / best[key]:.1f} | {phys / best[key]:.2f} |")
    print(f"| holder decisions (random policy) | {best['holder']:,.0f} | - | - |")
    cycle = 1e6 / best["aec"]
    print()
    print("| thread guard | us |")
    print("|---|---|")
    print(f"| per step() call | {low['guard']:.2f} |")
    print(f"| per AEC cycle (2 agent turns) | {2 * low['guard']:.2f} "
          f"({2 * low['guard'] / cycle:.1%} of the cycle's {cycle:.1f} us) |")
    avg_cycles = best["holder_cycles"] / best["holder"]  # cycles per holder decision
    print()
    print("| reset | us per reset |")
    print("|---|---|")
    print(f"| Drill.reset, space rebuilt | {low['reset_rebuild']:.1f} |")
    print(f"| Drill.reset, space kept (before the rebuild) | {low['reset_reuse']:.1f} |")
    print(f"| cost of the rebuild | {low['reset_rebuild'] - low['reset_reuse']:+.1f} |")
    print(f"| env.reset(seed) of the AEC env, chasers | {low['env_reset']:.1f} |")
    episode_us = mean_episode_cycles() * cycle
    rebuild = low["reset_rebuild"] - low["reset_reuse"]
    print(f"| rebuild / (AEC episode of random legal actions, {episode_us / cycle:.0f} cycles "
          f"= {episode_us / 1000:.1f} ms) | {rebuild / episode_us:.1%} |")
    print(f"| rebuild / (bare pymunk cycle) | {rebuild / (1e6 / phys):.1f} cycles |")
    print(f"(a holder decision lasts {avg_cycles:.1f} cycles on average)")


if __name__ == "__main__":
    main()
