"""Where an environment cycle's time goes: a sampling profile, per component.

    python benchmarks/profile_env.py [--cycles 40000] [--loop aec|parallel|holder] [--bytecodes]

Runs a loop of ``bench_env.py`` and samples the running Python stack every 0.5 ms of
this process's user CPU time (``ITIMER_VIRTUAL``, so time spent descheduled on a loaded
machine is not sampled, and the ``ITIMER_PROF`` timer of the team time bound is left
alone). Each sample goes to the component of its innermost frame that matches one (a
C function, such as pymunk's ``cpSpaceStep``, counts for the Python frame calling it);
samples taken inside an episode's reset are counted apart. Samples come at the kernel's
CPU-time accounting ticks (a few hundred per CPU second), hence the default length.
Prints a markdown table: the share of samples and the microseconds per cycle that share
is of the loop's CPU time per cycle. Unlike ``cProfile`` the loop runs at full speed.

``--bytecodes`` counts instead the Python bytecodes each component executes per cycle
(``sys.settrace`` opcode events, components as above): exact and the same in every run
of the same code, so two versions compare without noise, but blind to time spent in C
(pymunk's physics, NumPy) and slow (use ``--cycles 2000``).
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from bench_env import AecLoop, HolderLoop, ParallelLoop

# A sample with a frame of these anywhere on its stack is an episode's reset.
RESET_RULES: tuple[tuple[str, str], ...] = (
    ("soccer_drill/env.py", "reset"),
    ("soccer_drill/holder.py", "reset"),
    ("soccer_drill/core.py", "reset"),
)
# (path fragment, function name or "*", component), the first match wins for a frame.
RULES: tuple[tuple[str, str, str], ...] = (
    ("pymunk/space.py", "step", "physics: pymunk Space.step (sub-steps)"),
    ("pymunk/batch.py", "*", "physics: pymunk body reads and writes"),
    ("pymunk/", "*", "physics: pymunk body reads and writes"),
    ("soccer_drill/skills.py", "*", "drill: skills (commands to velocities)"),
    ("soccer_drill/rules/motion.py", "*", "drill: skills (commands to velocities)"),
    ("soccer_drill/support.py", "*", "drill: support player"),
    ("soccer_drill/rules/cycle.py", "*", "drill: ball holder, outcome, state"),
    # The compiled rules run inside Drill.step's frame: skills, caps, ball, possession, outcome.
    ("soccer_drill/drill.py", "step", "drill: step (its compiled rules and its own code)"),
    ("soccer_drill/time_bound.py", "*", "team: time bound"),
    ("soccer_drill/teams.py", "_call", "team: time bound"),
    ("soccer_drill/teams.py", "_drain", "team: time bound"),
    ("soccer_drill/teams.py", "*", "team: command checks"),
    ("opponents/", "*", "team: its own act()"),
    ("soccer_drill/state.py", "*", "team: its own act()"),
    ("soccer_drill/features.py", "*", "observations (features)"),
    ("soccer_drill/core.py", "command_for", "env: action checks"),
    ("soccer_drill/core.py", "mask", "env: masks"),
    ("soccer_drill/core.py", "*", "env: cycle and observation plumbing"),
    ("soccer_drill/env.py", "*", "env: AEC/parallel bookkeeping"),
    ("soccer_drill/holder.py", "*", "env: holder bookkeeping"),
    ("pettingzoo/", "*", "env: AEC/parallel bookkeeping"),
    ("benchmarks/", "*", "user loop (random legal actions)"),
)
_UNMATCHED = "other"


def component(frame) -> str:
    """The component of the innermost frame of ``frame``'s stack that matches a rule."""
    outer = frame
    while outer is not None:
        code = outer.f_code
        path = code.co_filename.replace("\\", "/")
        if any(f in path and code.co_name == name for f, name in RESET_RULES):
            return "reset (the episode's start, per cycle)"
        outer = outer.f_back
    while frame is not None:
        code = frame.f_code
        path = code.co_filename.replace("\\", "/")
        for fragment, function, name in RULES:
            if fragment in path and (function == "*" or function == code.co_name):
                return name
        frame = frame.f_back
    return _UNMATCHED


def profile(loop, cycles: int, interval: float = 0.0005) -> tuple[Counter, float]:
    """Samples per component and the CPU microseconds per cycle of ``loop.run(cycles)``."""
    samples: Counter = Counter()

    def sample(signum, frame) -> None:
        samples[component(frame)] += 1

    loop.run(min(cycles, 2000))  # warm up
    previous = signal.signal(signal.SIGVTALRM, sample)
    start = time.thread_time()
    try:
        signal.setitimer(signal.ITIMER_VIRTUAL, interval, interval)
        done = loop.run(cycles)
    finally:
        signal.setitimer(signal.ITIMER_VIRTUAL, 0.0)
        signal.signal(signal.SIGVTALRM, previous)
    return samples, (time.thread_time() - start) / done * 1e6


def bytecodes(loop, cycles: int) -> tuple[Counter, float]:
    """Python bytecodes executed per component, and per cycle, in ``loop.run(cycles)``.

    Counted with ``sys.settrace``'s opcode events, each bytecode going to the component
    of the frame executing it (so a C function's own work is not counted): the same for
    every run of the same code, whatever the load, unlike the sampled CPU time.
    """
    counts: Counter = Counter()

    def on_call(frame, event, arg):
        frame.f_trace_opcodes, frame.f_trace_lines = True, False
        name = component(frame)  # once per call: the stack decides, as for a sample

        def on_opcode(frame, event, arg):
            if event == "opcode":
                counts[name] += 1
            return on_opcode

        return on_opcode

    loop.run(min(cycles, 2000))  # warm up
    sys.settrace(on_call)
    try:
        done = loop.run(cycles)
    finally:
        sys.settrace(None)
    return counts, sum(counts.values()) / done


LOOPS = {"aec": AecLoop, "parallel": ParallelLoop, "holder": HolderLoop}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=40_000)
    parser.add_argument("--loop", choices=sorted(LOOPS), default="aec")
    parser.add_argument("--bytecodes", action="store_true",
                        help="count the Python bytecodes per component instead of sampling "
                             "CPU time (deterministic; use --cycles 2000: tracing is slow)")
    args = parser.parse_args()
    if args.bytecodes:
        counts, per_cycle = bytecodes(LOOPS[args.loop](), args.cycles)
        total = sum(counts.values())
        print(f"{args.loop}: {args.cycles} cycles, {per_cycle:.0f} Python bytecodes per cycle")
        print()
        print("| component | share | bytecodes per cycle |")
        print("|---|---:|---:|")
        for name, count in sorted(counts.items(), key=lambda kv: -kv[1]):
            print(f"| {name} | {count / total:.1%} | {count / args.cycles:.0f} |")
        return
    samples, per_cycle = profile(LOOPS[args.loop](), args.cycles)
    total = sum(samples.values())
    print(f"{args.loop}: {args.cycles} cycles, {per_cycle:.1f} CPU us per cycle, "
          f"{total} samples")
    print()
    print("| component | share | us per cycle |")
    print("|---|---:|---:|")
    for name, count in sorted(samples.items(), key=lambda kv: -kv[1]):
        print(f"| {name} | {count / total:.1%} | {count / total * per_cycle:.1f} |")


if __name__ == "__main__":
    main()
