"""What the compiled rules cost at first use: compiling them, or loading them from the cache.

    python benchmarks/bench_compile.py [--rounds 3]

Each round runs three fresh processes, one after another:

* ``empty cache``: numba's cache directory (``NUMBA_CACHE_DIR``) is a new, empty
  folder, so every rule is compiled, as on a fresh machine or after a change of the
  rules' code;
* ``filled cache``: the same folder, now holding what the first process compiled, so
  every rule is loaded from it (every later process of the project);
* ``plain Python``: ``NUMBA_DISABLE_JIT=1``, nothing compiled.

In each, the CPU and wall time of: importing ``soccer_drill``; ``compiled.warm_up()``
(every registered rule, the parametric teams' too, as ``TeamDriver`` runs it before a
team's first call); and one ``HolderEnv`` episode against ``interceptors_cover`` after
it. The table has the median over rounds.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

_CHILD = """
import json, time
def now():
    return time.process_time(), time.perf_counter()
def since(t):
    c, w = now()
    return c - t[0], w - t[1]
t = now()
import soccer_drill, opponents.parametric
from soccer_drill.rules.compiled import warm_up
out = {"import": since(t)}
t = now()
warm_up()
out["warm_up"] = since(t)
t = now()
env = soccer_drill.HolderEnv(opponent="interceptors_cover")
obs, _ = env.reset(seed=0)
done = False
while not done:
    obs, _, term, trunc, _ = env.step(2)
    done = term or trunc
out["first episode"] = since(t)
print(json.dumps(out))
"""


def _child(environment: dict[str, str]) -> dict[str, tuple[float, float]]:
    done = subprocess.run([sys.executable, "-c", _CHILD], env=environment, capture_output=True,
                          text=True, check=True)
    return json.loads(done.stdout)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    runs: dict[str, list[dict]] = {"empty cache": [], "filled cache": [], "plain Python": []}
    for _ in range(args.rounds):
        with tempfile.TemporaryDirectory() as cache:
            compiled = {**os.environ, "NUMBA_CACHE_DIR": cache}
            runs["empty cache"].append(_child(compiled))
            runs["filled cache"].append(_child(compiled))
        runs["plain Python"].append(_child({**os.environ, "NUMBA_DISABLE_JIT": "1"}))
    parts = list(runs["empty cache"][0])
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} cores, load "
          f"{os.getloadavg()[0]:.1f}; median of {args.rounds} rounds, seconds (CPU / wall)")
    print("| process | " + " | ".join(parts) + " |")
    print("|---|" + "---:|" * len(parts))
    for label, rounds in runs.items():
        cells = []
        for part in parts:
            cpu = statistics.median(r[part][0] for r in rounds)
            wall = statistics.median(r[part][1] for r in rounds)
            cells.append(f"{cpu:.2f} / {wall:.2f}")
        print(f"| {label} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
