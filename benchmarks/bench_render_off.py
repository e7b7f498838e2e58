"""Stepping without rendering against the code before a change, measured in one run.

    python benchmarks/bench_render_off.py --before DIR [--rounds 5] [--block 2000] [--blocks 7]

``DIR`` holds the code before (its ``soccer_drill`` and ``opponents`` packages, e.g.
``git archive <commit> soccer_drill opponents | tar -x -C DIR``). Each round runs one
process on the code before and one on this checkout, in alternating order, each timing
the loops of ``bench_env.py`` made with ``render_mode=None`` (an AEC cycle, a parallel
cycle, a holder-env cycle, against ``chasers``) in ``--blocks`` blocks of ``--block``
cycles after a warm-up; a loop's cost in a process is its fastest block, in CPU time of
the thread per cycle. The table gives each loop's cost on either side (the median over
rounds), the median over rounds of the ratio now / before with its range, and the ratio
of the fastest process on either side (the least disturbed by other jobs).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
LOOPS = ("AecLoop", "ParallelLoop", "HolderLoop")


def child(block: int, blocks: int) -> dict[str, float]:
    """Each loop's fastest block, microseconds of thread CPU time per cycle."""
    sys.path.insert(0, str(HERE))
    import bench_env

    loops = {name: getattr(bench_env, name)() for name in LOOPS}
    for loop in loops.values():
        loop.run(block)  # warm-up: compiled rules, caches
    best = dict.fromkeys(loops, float("inf"))
    for _ in range(blocks):
        for name, loop in loops.items():
            start = time.thread_time()
            done = loop.run(block)
            best[name] = min(best[name], (time.thread_time() - start) / done * 1e6)
    return best


def run(code: Path, block: int, blocks: int) -> dict[str, float]:
    env = {**os.environ, "PYTHONPATH": f"{code}{os.pathsep}{HERE}"}
    out = subprocess.run([sys.executable, __file__, "--child", "--block", str(block),
                          "--blocks", str(blocks)], env=env, cwd=code, check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", type=Path, help="a folder with the code before")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--block", type=int, default=2000)
    parser.add_argument("--blocks", type=int, default=7)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(child(args.block, args.blocks)))
        return
    if args.before is None or not (args.before / "soccer_drill").is_dir():
        parser.error("--before must name a folder holding the code before (its soccer_drill)")
    sides = {"before": args.before.resolve(), "now": REPO}
    results: dict[str, list[dict[str, float]]] = {"before": [], "now": []}
    for r in range(args.rounds):
        order = ("before", "now") if r % 2 == 0 else ("now", "before")
        for side in order:
            results[side].append(run(sides[side], args.block, args.blocks))
        print(f"round {r + 1}/{args.rounds} done", file=sys.stderr)
    print("| loop (render_mode=None) | before, us/cycle | now, us/cycle | now / before "
          "(median of rounds) | range over rounds | fastest now / fastest before |")
    print("|---|---|---|---|---|---|")
    for name in LOOPS:
        before = [x[name] for x in results["before"]]
        now = [x[name] for x in results["now"]]
        ratios = [n / b for n, b in zip(now, before, strict=True)]
        print(f"| {name} | {statistics.median(before):.1f} | {statistics.median(now):.1f} | "
              f"{statistics.median(ratios):.3f} | {min(ratios):.3f}-{max(ratios):.3f} | "
              f"{min(now) / min(before):.3f} |")


if __name__ == "__main__":
    main()
