"""Agent cost per decision of the SMDP learner as its option library grows, in one run.

Two series, each measured in one run with interleaved rounds (medians reported), on one
Gymnasium environment with 9 features and Discrete(3) actions:

* **options**: the learner with ``LearnerConfig``'s defaults (Watkins's Q(0.9), replacing
  traces, optimistic values) offered 0, 15, 45, 90 and 180 options of a lifelong-like
  library: 5 kernels (a ``SharedKernelModel`` fitted on states of random rollouts) x 0,
  3, 9, 18 and 36 frozen policies. The first 3 policies choose primitives only; every
  later policy was "learnt" with every option that existed before it (its choices are
  the primitives and those options, with random weights whose option values are offset
  so that its greedy choice is an option, i.e. a pointer, at about half of the states).
  This is the library of a protocol-C run after 36 opponents, without pruning.
* **pointers**: the same learner offered 5 options (one per kernel) of policy ``j`` of
  a chain of policies in which policy ``i`` always points to an option of policy
  ``i - 1`` (``max_depth`` = 8): every step of a running option consults ``j + 1``
  policies, for ``j + 1`` = 1, 2, 4 and 8.

Reported per configuration: agent microseconds per decision (the CPU time of this thread
outside the environment's ``step``/``reset``, divided by the decision states visited, so
time spent descheduled on a loaded machine is not counted), its ratio to
the learner with 3 primitives and no options measured in the same run, and the share of
decisions taken by a running option.

Usage::

    python benchmarks/bench_learner_library.py                       # the drill if installed
    python benchmarks/bench_learner_library.py --env-id synthetic    # stand-in
    python benchmarks/bench_learner_library.py --profile 90          # cProfile of one config

``--profile N`` runs the learner with N options under :mod:`cProfile` instead and prints
the functions with the most own time, in microseconds per decision.
"""

from __future__ import annotations

import argparse
import cProfile
import os
import platform
import pstats
import statistics
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_learner import DRILL_ID, TimedEnv, _cpu_name, collect_states, keepaway_coder, make_env

from ilpss.kernels import SharedKernelModel
from ilpss.options import OptionLibrary, OptionSettings
from ilpss.policy import FrozenPolicy
from ilpss.smdp import KEEPAWAY, SmdpLearner
from ilpss.tiles import TileCoder

N_KERNELS = 5
N_PRIMITIVE = 3
OPTION_COUNTS = (0, 15, 45, 90, 180)
CHAIN_DEPTHS = (1, 2, 4, 8)
WEIGHT_SCALE = 0.01  # per tile: action values of about +-0.17
ILPSS_DIR = str(Path(__file__).resolve().parents[1] / "ilpss")
# Code of the environment, left out of the profile.
ENVIRONMENT_CODE = ("benchmarks", "gymnasium", "soccer_drill", "opponents", "pymunk")


def _fit_kernels(states: np.ndarray, seed: int) -> SharedKernelModel:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return SharedKernelModel(n_components=N_KERNELS, random_state=seed).fit([states])


def _pointing_policy(
    coder: TileCoder, option_ids: tuple[int, ...], states: np.ndarray,
    rng: np.random.Generator,
) -> FrozenPolicy:
    """Random weights; option rows offset so that the greedy choice is an option at
    about half of ``states``."""
    weights = rng.normal(0.0, WEIGHT_SCALE, size=(N_PRIMITIVE + len(option_ids),
                                                  coder.n_weights))
    if option_ids:
        q = np.take(weights, coder.active_batch(states), axis=1).sum(axis=2)  # (C, n)
        gap = q[:N_PRIMITIVE].max(axis=0) - q[N_PRIMITIVE:].max(axis=0)
        weights[N_PRIMITIVE:] += float(np.median(gap)) / coder.n_active
    return FrozenPolicy(coder, N_PRIMITIVE, option_ids, weights)


def growing_libraries(
    coder: TileCoder, states: np.ndarray, seed: int
) -> dict[int, OptionLibrary | None]:
    """``{n_options: library}`` for :data:`OPTION_COUNTS`, one lifelong sequence of
    policies (every library is a prefix of the next)."""
    rng = np.random.default_rng(seed)
    model = _fit_kernels(states, seed)
    probe = states[rng.choice(states.shape[0], 300, replace=False)]
    first = [_pointing_policy(coder, (), probe, rng) for _ in range(3)]
    lib = OptionLibrary(model, first)
    out: dict[int, OptionLibrary | None] = {0: None}
    while len(lib) < max(OPTION_COUNTS):
        if len(lib) in OPTION_COUNTS:
            out[len(lib)] = lib
        ids = tuple(int(o) for o in lib.option_ids)
        lib = lib.refit(model, [_pointing_policy(coder, ids, probe, rng)])
    out[len(lib)] = lib
    return out


def chain_libraries(
    coder: TileCoder, states: np.ndarray, seed: int
) -> dict[int, OptionLibrary]:
    """``{policies consulted: library}``: each library offers the 5 options of policy
    ``j``, which points to policy ``j - 1``, ..., to policy 0 (primitives only)."""
    rng = np.random.default_rng(seed + 1)
    model = _fit_kernels(states, seed)
    settings = OptionSettings(max_depth=max(CHAIN_DEPTHS), discount=0.01)
    lib = OptionLibrary(model, [_pointing_policy(coder, (), states[:1], rng)], settings)
    for _ in range(max(CHAIN_DEPTHS) - 1):
        ids = tuple(int(o) for o in lib.option_ids)
        weights = rng.normal(0.0, WEIGHT_SCALE, size=(N_PRIMITIVE + len(ids), coder.n_weights))
        # Always point to the newest policy's first option (its kernel 0).
        weights[N_PRIMITIVE + ids.index(int(lib.option_ids[lib.option_policy ==
                                                           len(lib.policies) - 1][0]))] += 1.0
        lib = lib.refit(model, [FrozenPolicy(coder, N_PRIMITIVE, ids, weights)])
    out = {}
    for depth in CHAIN_DEPTHS:
        copy = lib.refit(model, ())  # same identities; pruning below leaves `lib` alone
        own = [int(o) for o, p in zip(copy.option_ids, copy.option_policy, strict=True)
               if p == depth - 1]
        copy.end_trial(used=own)  # every other option is discounted below the threshold
        assert len(copy) == N_KERNELS, len(copy)
        out[depth] = copy
    return out


class CpuTimedEnv(TimedEnv):
    """:class:`TimedEnv` counting this thread's CPU time (``time.thread_time``)."""

    def step(self, action: int):
        t0 = time.thread_time()
        out = self.env.step(action)
        self.env_time += time.thread_time() - t0
        return out

    def reset(self, **kwargs: Any):
        t0 = time.thread_time()
        out = self.env.reset(**kwargs)
        self.env_time += time.thread_time() - t0
        return out


def make_learner(library: OptionLibrary | None, coder: TileCoder, seed: int) -> SmdpLearner:
    return SmdpLearner(N_PRIMITIVE, coder, library, config=KEEPAWAY, seed=seed)


def run_learner(env: TimedEnv, learner: SmdpLearner, n: int) -> tuple[float, float]:
    """(agent us/decision, share of decisions inside options) over at least ``n``
    decisions of learning."""
    done = in_options = 0
    env.env_time = 0.0
    t0 = time.thread_time()
    while done < n:
        res = learner.run_episode(env, learn=True)
        done += res.decisions
        in_options += sum(run.n_decisions for run in res.option_runs)
    total = time.thread_time() - t0
    return (total - env.env_time) / done * 1e6, in_options / done


def measure(
    env: TimedEnv, learners: dict[str, SmdpLearner], decisions: int, rounds: int
) -> dict[str, tuple[float, float]]:
    for learner in learners.values():  # warm-up
        run_learner(env, learner, 200)
    rows: dict[str, list[tuple[float, float]]] = {name: [] for name in learners}
    for _ in range(rounds):  # interleaved, so drifts of a shared machine hit every config
        for name, learner in learners.items():
            rows[name].append(run_learner(env, learner, decisions))
    return {name: (statistics.median(c for c, _ in v), statistics.median(s for _, s in v))
            for name, v in rows.items()}


def profile(env: TimedEnv, learner: SmdpLearner, decisions: int) -> None:
    """cProfile of learning, per decision: every ``ilpss`` function with its own time
    plus the whole time of the NumPy, SciPy and built-in functions it calls (the
    environment is left out)."""
    run_learner(env, learner, 200)
    prof = cProfile.Profile()
    done = 0
    prof.enable()
    while done < decisions:
        done += learner.run_episode(env, learn=True).decisions
    prof.disable()
    stats = pstats.Stats(prof).stats  # type: ignore[attr-defined]
    ours = {f for f in stats if f[0].startswith(ILPSS_DIR)}
    own = {f: stats[f][2] for f in ours}
    calls = {f: stats[f][1] for f in ours}
    for callee, (_, _, _, _, callers) in stats.items():
        if callee in ours or any(part in callee[0] for part in ENVIRONMENT_CODE):
            continue
        for caller, (_, _, _, ct) in callers.items():
            if caller in ours:  # NumPy, SciPy and built-ins: charged to their caller
                own[caller] += ct
    total = sum(own.values())
    print(f"{done} decisions under cProfile: the learner's functions (with the built-in "
          f"and NumPy functions they call) take {total / done * 1e6:.1f} us/decision\n")
    print("| function | calls/decision | us/decision | share |")
    print("|---|---:|---:|---:|")
    for f in sorted(ours, key=lambda f: -own[f]):
        if own[f] / total < 0.005:
            break
        print(f"| `{Path(f[0]).parent.name}/{Path(f[0]).name}:{f[2]}` | {calls[f] / done:.2f} | "
              f"{own[f] / done * 1e6:.1f} | {own[f] / total:.0%} |")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--env-id", default=None,
                        help=f"Gymnasium id, or 'synthetic' (default: {DRILL_ID} if importable)")
    parser.add_argument("--decisions", type=int, default=3000, help="decisions per round")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--synthetic-step-us", type=float, default=0.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--series", choices=("options", "pointers", "both"), default="both")
    parser.add_argument("--profile", type=int, default=None, metavar="N_OPTIONS",
                        choices=OPTION_COUNTS, help="profile the learner with N options")
    args = parser.parse_args(argv)

    env_id = args.env_id
    if env_id is None:
        try:
            import soccer_drill  # noqa: F401

            env_id = DRILL_ID
        except ImportError:
            env_id = "synthetic"
    raw, label = make_env(env_id, args.synthetic_step_us)
    coder = keepaway_coder(raw.observation_space)
    states = collect_states(raw, 1500, np.random.default_rng(args.seed))
    env = CpuTimedEnv(raw)
    print(f"environment: {label}")
    print(f"machine: {platform.machine()} ({_cpu_name()}, {os.cpu_count()} cpus), "
          f"Python {platform.python_version()}, numpy {np.__version__}")
    print(f"tile coder: {coder.n_features} features x {coder.n_tilings} tilings, "
          f"{coder.n_weights} weights per choice; learner: LearnerConfig() defaults\n")

    if args.profile is not None:
        lib = growing_libraries(coder, states, args.seed)[args.profile]
        profile(env, make_learner(lib, coder, args.seed), args.decisions * args.rounds)
        return
    print(f"{args.rounds} interleaved rounds x {args.decisions} decisions, medians\n")
    if args.series in ("options", "both"):
        libs = growing_libraries(coder, states, args.seed)
        learners = {f"{n} options": make_learner(lib, coder, args.seed)
                    for n, lib in libs.items()}
        _table("options offered", measure(env, learners, args.decisions, args.rounds),
               "0 options")
    if args.series in ("pointers", "both"):
        chains = chain_libraries(coder, states, args.seed)
        learners: dict[str, Any] = {"no options": make_learner(None, coder, args.seed)}
        learners |= {f"{d} policies per option step": make_learner(lib, coder, args.seed)
                     for d, lib in chains.items()}
        _table("5 options, each consulting", measure(env, learners, args.decisions,
                                                     args.rounds), "no options")


def _table(what: str, med: dict[str, tuple[float, float]], base: str) -> None:
    ref = med[base][0]
    print(f"| {what} | agent us/decision | ratio to {base} | decisions inside options |")
    print("|---|---:|---:|---:|")
    for name, (cost, share) in med.items():
        print(f"| {name} | {cost:.1f} | {cost / ref:.2f}x | {share:.0%} |")
    print()


if __name__ == "__main__":
    main()
