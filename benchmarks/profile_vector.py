"""Where a cycle of the batched drill spends its CPU time, per component.

    python benchmarks/profile_vector.py [--size 64] [--cycles 400] [--team interceptors_cover]

Each component (the physics, the off-ball skills, the holder's ball skills, the team's
batched ``act`` with its bound and checks, ...) is wrapped in a counter of this
thread's CPU time (``time.thread_time_ns``), and the loops of ``bench_vector.py`` run
``--cycles`` cycles of ``--size`` drills: the agents loop (``ParallelVectorEnv``,
random legal actions) and the holder loop without waiting (``play_episodes``). The
table gives CPU microseconds per drill-cycle, inclusive (an indented component is part
of the one above it). The counters cost about 0.2 us a call, a few per cycle: unlike a
profiler, they leave the NumPy calls' cost as it is.
"""

from __future__ import annotations

import argparse
import collections
import functools
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import soccer_drill.drill.drills as drills_module
import soccer_drill.drill.spaces as physics_module
import soccer_drill.envs.core as core_module
import soccer_drill.envs.holder as loop_module
import soccer_drill.rules.cycle as cycle_module
import soccer_drill.rules.support as support_module
import soccer_drill.teams.driver as teams_module
import soccer_drill.vector.agents as agents_module

_MODULES = (drills_module, core_module, physics_module, cycle_module, teams_module,
            loop_module, agents_module)
_SPENT: collections.Counter = collections.Counter()

# (label, owner, attribute): a module-level function or a method.
COMPONENTS = (
    ("whole cycle of the agents (step)", agents_module.ParallelVectorEnv, "step"),
    ("whole cycle of the holder (HolderLoop.cycle)", loop_module.HolderLoop, "cycle"),
    ("  physics (pymunk spaces, batched reads/writes)", physics_module.BatchPhysics, "cycle"),
    ("  the drill's rules (BatchDrill.step less the physics)", drills_module.BatchDrill, "step"),
    ("    before the physics (skills, kicks, compiled)", cycle_module, "before_physics_of_drills"),
    ("    after the physics (ball, possession, outcome, compiled)", cycle_module,
     "after_physics_of_drills"),
    ("    tackles", drills_module.BatchDrill, "_tackle"),
    ("    rewards", drills_module.BatchDrill, "_rewards"),
    ("  team (batched act, its bound and checks)", teams_module.TeamDriver, "act"),
    ("  support players' commands (holder)", support_module.SupportDraws, "commands"),
    ("  observations and masks (agents)", agents_module.ParallelVectorEnv, "_observations"),
    ("  action checks (agents)", agents_module.ParallelVectorEnv, "_commands"),
    ("  resets", core_module.BatchCore, "reset"),
)


def _wrap(label: str, owner: object, name: str) -> None:
    original = getattr(owner, name)

    @functools.wraps(original)
    def counted(*args, **kwargs):
        start = time.thread_time_ns()
        try:
            return original(*args, **kwargs)
        finally:
            _SPENT[label] += time.thread_time_ns() - start

    setattr(owner, name, counted)
    for module in _MODULES:  # imported by name elsewhere
        if getattr(module, name, None) is original:
            setattr(module, name, counted)


def profile(loop: object, cycles: int) -> tuple[float, dict[str, float]]:
    """CPU us per drill-cycle of ``loop`` over about ``cycles`` batch cycles, in total and
    per component."""
    batch = loop.env._core.batch  # type: ignore[attr-defined]
    loop.run(batch.n * 20)  # type: ignore[attr-defined]
    _SPENT.clear()
    before = batch.cycles_run
    start = time.thread_time_ns()
    loop.run(batch.n * cycles)  # type: ignore[attr-defined]
    total = time.thread_time_ns() - start
    done = batch.cycles_run - before
    out = {label: _SPENT[label] / done / 1e3 for label, _, _ in COMPONENTS}
    out["  the drill's rules (BatchDrill.step less the physics)"] -= out[
        "  physics (pymunk spaces, batched reads/writes)"]
    return total / done / 1e3, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--cycles", type=int, default=400)
    parser.add_argument("--team", default="interceptors_cover")
    args = parser.parse_args()
    from bench_env import PhysicsLoop
    from bench_vector import Agents, HolderPlay, cost

    for label, owner, name in COMPONENTS:
        _wrap(label, owner, name)
    floor = cost(PhysicsLoop(), 2000)
    rows = {}
    for name, loop in (("agents", Agents(args.size, args.team)),
                       ("holder play", HolderPlay(args.size, args.team))):
        f = cost(PhysicsLoop(), 2000)
        total, parts = profile(loop, args.cycles)
        rows[name] = (total, (f + floor) / 2, parts)
    print(f"{args.size} drills, {args.team}; CPU us per drill-cycle (the floor: one drill's "
          "own pymunk space, measured beside each loop)")
    print("| component | " + " | ".join(rows) + " |\n|---|" + "---:|" * len(rows))
    print("| the floor | " + " | ".join(f"{f:.2f}" for _, f, _ in rows.values()) + " |")
    print("| whole loop (the ratio to the floor) | " + " | ".join(
        f"{t:.2f} ({t / f:.2f}x)" for t, f, _ in rows.values()) + " |")
    for label, _, _ in COMPONENTS:
        cells = [f"{parts[label]:.2f}" if parts[label] else "" for _, _, parts in rows.values()]
        if any(cells):
            print(f"| {label.replace('  ', '&nbsp;&nbsp;')} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
