"""Signal soak: signal handlers that raise, delivered at random points of the environments'
construction, reset, step and close and of a process's first use of the compiled rules.

    python benchmarks/signal_soak.py [--deliveries 10000] [--per-worker 100] [--seed 0]
                                     [--out docs/reliability.md]

Runs worker processes one after another, each a fresh interpreter (so that each one's
first environment loads the compiled rules: the first use). A worker installs handlers
that raise for ``SIGINT`` (Python's own: ``KeyboardInterrupt``), ``SIGALRM`` (an
exception, as a wall-clock bound's) and ``SIGTERM`` (a ``BaseException``, as a handler
calling ``sys.exit()``), then loops over random operations on a few environments
(``HolderEnv``, ``parallel_env``, ``HolderVectorEnv``, ``ParallelVectorEnv``): build one,
reset, step, close, drop. A thread of the worker sends one of the three signals to the
process after a random delay (exponential, mean ``--mean-ms``), waits until the main
loop has caught the handler's exception, lets it check the environments, then sends
the next: ``--per-worker`` deliveries per worker, ``--deliveries`` in all.

A ``close`` takes a few microseconds, so a signal sent at a random time almost never
lands in one. After its sent signals each worker therefore closes ``--closes-per-worker``
environments (each kind in turn) with a signal raised at a random point of the call: a
profile hook counts the points where the interpreter runs signal handlers (a Python
function's entry, a C function's return), and raises the signal at the k-th, k drawn
from one to the points a close of that kind has. Each must reach the program; the
environment is then closed again without error, and a new one of its kind resets and
steps.

Checked after each delivery (any failure is counted, with its description):

* **crash**: a worker ending by a signal or a non-zero status, or with no report;
* **lost**: a signal sent whose handler did not run within ``--patience`` seconds while
  the main loop went on;
* **swallowed**: a handler that ran but whose exception the main loop did not catch
  (something in between caught it), or an "Exception ignored" line on the worker's
  standard error (an exception lost in a finaliser or callback);
* **unusable**: an environment that, after the delivery, neither steps nor refuses
  with an error saying to call ``reset()``, or that does not reset and step after that.

``--out FILE`` writes the report between ``<!-- signal-soak:start -->`` and
``<!-- signal-soak:end -->`` in ``FILE``. The exit status is 1 if anything was counted.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import random
import re
import signal
import subprocess
import sys
import threading
import time
import traceback
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any

MARK_START, MARK_END = "<!-- signal-soak:start -->", "<!-- signal-soak:end -->"
SIGNALS = ("SIGINT", "SIGALRM", "SIGTERM")
KINDS = ("holder", "parallel", "holder_vector", "parallel_vector")
RESET = re.compile(r"call reset\(\)|before reset\(\)|reset\(\) first")


# ------------------------------------------------------------------ the worker
class Alarm(Exception):
    """What the worker's ``SIGALRM`` handler raises (a wall-clock bound's exception)."""


class Terminated(BaseException):
    """What the worker's ``SIGTERM`` handler raises (as ``sys.exit()`` would)."""


class Worker:
    """One process's loop of operations under signals (see the module docstring)."""

    def __init__(self, seed: int, deliveries: int, mean_ms: float, patience: float,
                 closes: int = 0) -> None:
        self.closes = closes
        self.close_points: dict[str, int] = {}  # the points a close of each kind has
        self.rng = random.Random(seed)
        self.sender_rng = random.Random(seed + 1)
        self.deliveries, self.mean, self.patience = deliveries, mean_ms / 1000, patience
        self.sent = self.ran = self.caught = 0
        self.problems: list[str] = []
        self.at: Counter[str] = Counter()  # the operation each delivery landed in
        self.kinds: Counter[str] = Counter()
        self.operation = "start"
        self.handled = threading.Event()  # the main loop caught (or gave up on) a delivery
        self.go = threading.Event()
        self.done = False
        self.envs: list[Slot] = []
        self.last_ran, self.last_frame, self.trace = "", None, None

    # the handlers
    def _ran(self, signum: int, frame: Any) -> None:
        self.ran += 1
        self.at[self.operation] += 1
        self.last_ran, self.last_frame = self.operation, frame
        if signum == signal.SIGALRM:
            raise Alarm
        if signum == signal.SIGTERM:
            raise Terminated
        raise KeyboardInterrupt

    def install(self) -> None:
        for name in SIGNALS:
            signal.signal(getattr(signal, name), self._ran)

    # the sender thread
    def send(self) -> None:
        self.go.wait()  # the main loop is ready to catch
        for _ in range(self.deliveries):
            time.sleep(self.sender_rng.expovariate(1 / self.mean))
            name = self.sender_rng.choice(SIGNALS)
            self.handled.clear()
            before = self.ran
            self.sent += 1
            self.kinds[name] += 1
            os.kill(os.getpid(), getattr(signal, name))
            if not self.handled.wait(self.patience):
                if self.ran == before:
                    self.problems.append(f"lost: {name} sent during {self.operation}, its "
                                         f"handler did not run in {self.patience:g} s")
                else:
                    self.problems.append(f"swallowed: {name}'s handler ran during "
                                         f"{self.last_ran}, its exception never reached "
                                         "the loop")
                    if self.trace is None:
                        self.trace = "".join(traceback.format_stack(self.last_frame))
        self.done = True

    # the main loop
    def run(self) -> dict:
        import numpy as np

        import soccer_drill.vector  # noqa: F401  (imported before any signal: imports are not soaked)

        self.np = np
        self.install()
        sender = threading.Thread(target=self.send, daemon=True)
        sender.start()
        self.first = True
        self.go.set()
        while not self.done:
            try:
                self.operate()
            except (KeyboardInterrupt, Alarm, Terminated):
                self.caught += 1
                self.check()
                self.handled.set()
        for slot in self.envs:
            slot.env.close()
        for i in range(self.closes):
            self.close_at_a_random_point(KINDS[i % len(KINDS)])
        return {"sent": self.sent, "ran": self.ran, "caught": self.caught,
                "problems": self.problems, "trace": self.trace, "at": dict(self.at), "kinds": dict(self.kinds)}

    def make(self, kind: str | None = None) -> Slot:
        import soccer_drill
        from soccer_drill.vector import HolderVectorEnv, ParallelVectorEnv

        kind = self.rng.choice(KINDS) if kind is None else kind
        self.operation = "first use (compiled rules)" if self.first else "construction"
        if kind == "holder":
            env = soccer_drill.HolderEnv(opponent="chasers")
        elif kind == "parallel":
            env = soccer_drill.parallel_env(opponent="goal_guards")
        elif kind == "holder_vector":
            env = HolderVectorEnv(self.rng.randint(1, 3), opponent="chasers",
                                  drills_per_space=self.rng.choice((1, 64)))
        else:
            env = ParallelVectorEnv(num_envs=self.rng.randint(1, 3), opponent="goal_guards")
        self.first = False
        return Slot(env, kind)

    def operate(self) -> None:
        """One random operation (or a few steps)."""
        rng = self.rng
        if not self.envs or (len(self.envs) < 3 and rng.random() < 0.05):
            self.operation = "construction"
            self.envs.append(self.make())
            return
        slot = rng.choice(self.envs)
        roll = rng.random()
        if slot.obs is None or roll < 0.08:
            self.operation = "reset"
            self.reset(slot)
        elif roll < 0.11:
            self.operation = "close"
            self.envs.remove(slot)
            slot.env.close()
        elif roll < 0.13:
            self.operation = "drop"
            self.envs.remove(slot)
        else:
            self.operation = "step"
            for _ in range(rng.randint(1, 20)):
                if self.step(slot):
                    slot.obs = None
                    break
        self.operation = "between"

    def reset(self, slot: Slot) -> None:
        slot.obs = None
        slot.obs = slot.env.reset(seed=self.rng.randrange(2**31))[0]

    def step(self, slot: Slot) -> bool:
        """One step with legal actions; whether the episode (a single environment's) ended."""
        np, env, obs = self.np, slot.env, slot.obs
        if slot.kind == "holder":
            _, _, term, trunc, _ = env.step(0)
            return term or trunc
        if slot.kind == "holder_vector":
            env.step(np.zeros(env.num_envs, dtype=np.int64))
            return False
        if slot.kind == "parallel":
            actions = {a: int(np.flatnonzero(obs[a]["action_mask"])[0]) for a in env.agents}
            slot.obs = env.step(actions)[0]
            return not env.agents
        actions = {a: o["action_mask"].argmax(axis=1) for a, o in obs.items()}
        slot.obs = env.step(actions)[0]
        return False

    def close_at_a_random_point(self, kind: str) -> None:
        """Close a used environment of ``kind`` with a signal at a random point of the call
        (the module docstring); count what went wrong."""
        if kind not in self.close_points:  # how many points a close of this kind has
            slot = self.used(kind)
            counter = AtPoint(10**9, signal.SIGALRM)
            sys.setprofile(counter)
            try:
                slot.env.close()
            finally:
                sys.setprofile(None)
            self.close_points[kind] = counter.seen
        slot = self.used(kind)
        name = self.rng.choice(SIGNALS)
        hook = AtPoint(self.rng.randint(1, self.close_points[kind]), getattr(signal, name))
        self.operation = "close"
        try:
            sys.setprofile(hook)
            try:
                slot.env.close()
            finally:
                sys.setprofile(None)
        except (KeyboardInterrupt, Alarm, Terminated):
            self.caught += 1
        self.operation = "between"
        if not hook.raised:  # this close had fewer points: nothing was delivered
            return
        self.sent += 1
        self.kinds[name] += 1
        if self.caught < self.ran:
            self.problems.append(f"swallowed: {name}'s handler ran during a close of "
                                 f"{kind}, its exception never reached the program")
            self.caught = self.ran
        try:
            slot.env.close()
            self.used(kind).env.close()
        except Exception as exc:
            self.problems.append(f"unusable: {kind} after a delivery during close: "
                                 f"{type(exc).__name__}: {exc}")

    def used(self, kind: str) -> Slot:
        """A new environment of ``kind``, reset and stepped once."""
        slot = self.make(kind)
        self.operation = "between"
        self.reset(slot)
        self.step(slot)
        return slot

    def check(self) -> None:
        """Every environment steps or refuses saying to call reset(); then resets and steps."""
        for slot in list(self.envs):
            if slot.obs is None:
                continue
            try:
                self.step(slot)
            except Exception as exc:
                if not RESET.search(str(exc)):
                    self.problems.append(f"unusable: {slot.kind} after a delivery during "
                                         f"{self.operation}: {type(exc).__name__}: {exc}")
                    self.envs.remove(slot)
                    continue
            try:
                self.reset(slot)
                self.step(slot)
            except Exception as exc:
                self.problems.append(f"unusable: {slot.kind} did not reset and step after a "
                                     f"delivery during {self.operation}: "
                                     f"{type(exc).__name__}: {exc}")
                self.envs.remove(slot)


class AtPoint:
    """A profile hook that raises ``signum`` at the ``k``-th point where the interpreter
    runs signal handlers (a Python function's entry, a C function's return)."""

    def __init__(self, k: int, signum: int) -> None:
        self.k, self.signum, self.seen, self.raised = k, signum, 0, False

    def __call__(self, frame: Any, event: str, arg: Any) -> None:
        if event in ("call", "c_return"):
            self.seen += 1
            if self.seen == self.k:
                self.raised = True
                signal.raise_signal(self.signum)


class Slot:
    """An environment of the worker, its kind and its last observations (``None``: to reset)."""

    def __init__(self, env: Any, kind: str) -> None:
        self.env, self.kind, self.obs = env, kind, None


# ------------------------------------------------------------------ the driver
def run_worker(seed: int, deliveries: int, args: argparse.Namespace) -> dict:
    """One worker in a fresh interpreter; its report, or a crash described."""
    command = [sys.executable, __file__, "--worker", str(seed), "--per-worker", str(deliveries),
               "--mean-ms", str(args.mean_ms), "--patience", str(args.patience),
               "--closes-per-worker", str(args.closes_per_worker)]
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=args.timeout)
    except subprocess.TimeoutExpired:
        return {"crash": f"worker {seed} did not end within {args.timeout:g} s"}
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    if done.returncode != 0 or not lines:
        if args.verbose:
            print(f"worker {seed}'s standard error:\n{done.stderr[-6000:]}", flush=True)
        tail = done.stderr.strip().splitlines()[-3:]
        return {"crash": f"worker {seed} ended with status {done.returncode}: {' | '.join(tail)}"}
    report = json.loads(lines[-1])
    ignored = [line for line in done.stderr.splitlines() if "Exception ignored" in line]
    report["problems"] += [f"swallowed: worker {seed}: {line}" for line in ignored]
    return report


def soak(args: argparse.Namespace) -> dict:
    totals: dict = {"sent": 0, "ran": 0, "caught": 0, "workers": 0, "crashes": [],
                    "problems": [], "at": Counter(), "kinds": Counter()}
    start, left, seed = time.perf_counter(), args.deliveries, args.seed * 100_000
    while left > 0:
        n = min(args.per_worker, left)
        report = run_worker(seed, n, args)
        totals["workers"] += 1
        seed += 1
        left -= n
        if "crash" in report:
            totals["crashes"].append(report["crash"])
            continue
        for key in ("sent", "ran", "caught"):
            totals[key] += report[key]
        totals["problems"] += report["problems"]
        if report.get("trace") and args.verbose:
            print(f"worker {seed - 1}: where a swallowed handler ran:\n{report['trace']}",
                  flush=True)
        totals["at"].update(report["at"])
        totals["kinds"].update(report["kinds"])
        if args.verbose:
            print(f"{totals['workers']} workers, {totals['sent']:,} sent, "
                  f"{len(totals['problems']) + len(totals['crashes'])} problems", flush=True)
    totals["seconds"] = time.perf_counter() - start
    return totals


def report(args: argparse.Namespace, totals: dict) -> str:
    problems = Counter(p.split(":")[0] for p in totals["problems"])
    lines = [
        MARK_START,
        "## Signal soak",
        "",
        f"Command: `python benchmarks/signal_soak.py --deliveries {args.deliveries} "
        f"--per-worker {args.per_worker} --closes-per-worker {args.closes_per_worker} "
        f"--seed {args.seed}`",
        "",
        f"Python {platform.python_version()}, {os.cpu_count()} cores; {totals['workers']} "
        f"worker processes, each a fresh interpreter; {totals['seconds']:.0f} s.",
        "",
        "| measure | value |",
        "|---|---:|",
        f"| signals sent (at random times, and at a random point of a close) | "
        f"{totals['sent']:,} |",
        f"| handlers run | {totals['ran']:,} |",
        f"| exceptions caught by the program | {totals['caught']:,} |",
        f"| **crashes** (a worker killed by a signal, a non-zero status, no report) | "
        f"**{len(totals['crashes'])}** |",
        f"| **lost** (sent, handler never ran) | **{problems['lost']}** |",
        f"| **swallowed** (handler ran, exception never reached the program; or \"Exception "
        f"ignored\") | **{problems['swallowed']}** |",
        f"| **unusable environments** (neither stepping nor refusing with \"call reset()\", "
        f"or not usable after `reset()`) | **{problems['unusable']}** |",
        "",
        "Signals sent: " + ", ".join(f"{k} {v:,}" for k, v in sorted(totals["kinds"].items()))
        + ".",
        "",
        "Where the handlers ran (the worker's operation at the time):",
        "",
        "| operation | deliveries |",
        "|---|---:|",
        *(f"| {op} | {count:,} |" for op, count in totals["at"].most_common()),
    ]
    shown = totals["crashes"][:10] + totals["problems"][:10]
    if shown:
        lines += ["", "First problems:", "", *(f"- {p}" for p in shown)]
    lines.append(MARK_END)
    return "\n".join(lines) + "\n"


def write_section(path: Path, section: str) -> None:
    text = path.read_text() if path.exists() else ""
    if MARK_START in text and MARK_END in text:
        before, rest = text.split(MARK_START, 1)
        after = rest.split(MARK_END, 1)[1].lstrip("\n")
        text = before + section + after
    else:
        text = text.rstrip("\n") + "\n\n" + section
    from soccer_drill.files import atomic_write_text

    atomic_write_text(path, text)


def parse(argv: Sequence[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--deliveries", type=int, default=10_000, help="signals sent in all")
    p.add_argument("--per-worker", type=int, default=100, help="signals per worker process")
    p.add_argument("--mean-ms", type=float, default=15.0,
                   help="mean delay before each signal, in milliseconds")
    p.add_argument("--patience", type=float, default=120.0,
                   help="seconds a sent signal may take to be handled before it counts as lost")
    p.add_argument("--closes-per-worker", type=int, default=12,
                   help="environments each worker closes with a signal at a random point")
    p.add_argument("--timeout", type=float, default=1800.0, help="seconds a worker may take")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=None, help="write the report into this file")
    p.add_argument("--verbose", action="store_true")
    p.add_argument("--worker", type=int, default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    for name in ("deliveries", "per_worker"):
        if getattr(args, name) < 1:
            p.error(f"--{name.replace('_', '-')} must be at least 1")
    if args.closes_per_worker < 0:
        p.error("--closes-per-worker must be at least 0")
    if not (args.mean_ms > 0 and args.patience > 0 and args.timeout > 0):
        p.error("--mean-ms, --patience and --timeout must be positive")
    return args


def main(argv: Sequence[str] | None = None) -> int:
    args = parse(argv)
    if args.worker is not None:
        worker = Worker(args.worker, args.per_worker, args.mean_ms, args.patience,
                        args.closes_per_worker)
        print(json.dumps(worker.run()), flush=True)
        return 0
    totals = soak(args)
    section = report(args, totals)
    print(section)
    if args.out is not None:
        write_section(args.out, section)
    return 1 if totals["crashes"] or totals["problems"] else 0


if __name__ == "__main__":
    sys.exit(main())
