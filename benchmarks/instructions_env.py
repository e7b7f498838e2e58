"""Machine instructions per environment cycle, counted by valgrind: a ratio that load cannot move.

    python benchmarks/instructions_env.py [--cycles 2000] [--loops physics aec parallel holder]

CPU time on a shared or virtual machine varies from run to run by more than the changes
one wants to see (``bench_env.py``'s ratios moved by 10% between runs on the machine
behind ``docs/benchmarks.md``). The number of instructions a loop executes should not:
it depends on the code and the episodes. Yet runs of the same code have differed by
0.1% on one day and by up to 5% on another (not traced), so run each version more than
once and trust only changes well beyond that spread. Each loop of ``bench_env.py`` runs under
``valgrind --tool=cachegrind`` twice, once for a warm-up only and once for ``--cycles``
more cycles; the difference over ``--cycles`` is the instructions per cycle. The ratio
to the bare pymunk cycle is the floor ratio in instructions. An instruction of the
interpreter's Python code takes longer than one of pymunk's C code (more branches and
memory traffic per instruction), so the ratio in CPU time is larger than this one; use
it to compare two versions of the code, ``bench_env.py`` for the cost itself.

Needs ``valgrind`` on the PATH; about 40 s per loop and run, two runs in parallel.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

HERE = Path(__file__).resolve().parent
WARM_UP = 300

_CHILD = """
import sys
sys.path.insert(0, {benchmarks!r})
from bench_env import AecLoop, HolderLoop, ParallelLoop, PhysicsLoop
loop = {{"physics": PhysicsLoop, "aec": AecLoop, "parallel": ParallelLoop,
         "holder": HolderLoop}}[{loop!r}]()
loop.run({warm_up})
loop.run({cycles})
"""


def instructions(loop: str, cycles: int) -> int:
    """Instructions valgrind counts for a whole process that runs ``cycles`` cycles of ``loop``."""
    code = _CHILD.format(benchmarks=str(HERE), loop=loop, warm_up=WARM_UP, cycles=cycles)
    out = subprocess.run(
        ["valgrind", "--tool=cachegrind", "--cache-sim=no", "--cachegrind-out-file=/dev/null",
         sys.executable, "-c", code],
        capture_output=True, text=True, check=True, env={**os.environ, "PYTHONHASHSEED": "0"},
    )
    match = re.search(r"I\s+refs:\s+([\d,]+)", out.stderr)
    if match is None:
        raise RuntimeError(f"no instruction count in valgrind's output:\n{out.stderr[-2000:]}")
    return int(match.group(1).replace(",", ""))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=2000, help="cycles counted per loop")
    parser.add_argument("--loops", nargs="+", default=["physics", "aec", "parallel", "holder"],
                        choices=["physics", "aec", "parallel", "holder"])
    args = parser.parse_args()
    if shutil.which("valgrind") is None:
        raise SystemExit("valgrind is not on the PATH; install it to count instructions")
    loops = list(dict.fromkeys(["physics", *args.loops]))
    runs = [(loop, n) for loop in loops for n in (0, args.cycles)]
    with ThreadPoolExecutor(max_workers=2) as pool:
        counts = dict(zip(runs, pool.map(lambda run: instructions(*run), runs), strict=True))
    per_cycle = {loop: (counts[loop, args.cycles] - counts[loop, 0]) / args.cycles
                 for loop in loops}
    floor = per_cycle["physics"]
    print(f"valgrind cachegrind, {args.cycles} cycles per loop after {WARM_UP} of warm-up")
    print()
    print("| loop | instructions per cycle | x physics floor |")
    print("|---|---:|---:|")
    for loop in loops:
        print(f"| {loop} | {per_cycle[loop]:,.0f} | {per_cycle[loop] / floor:.2f} |")


if __name__ == "__main__":
    main()
