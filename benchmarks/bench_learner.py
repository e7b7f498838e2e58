"""Decisions per second of SMDP learning versus plain random stepping, in one run.

Measures, on one Gymnasium environment with 9 continuous features and Discrete(3)
actions:

* ``random``: ``env.step`` with uniformly random actions (``env.reset`` at episode end),
  the cost of the environment alone;
* ``learner``: :class:`ilpss.smdp.SmdpLearner` learning (Sarsa, 32 tilings x 9 features,
  3 primitives, no options);
* ``learner+15 options``: the same with an option library of 5 kernels (a
  ``SharedKernelModel`` fitted on states of random rollouts) x 3 frozen policies;
* ``learner+15 options+intra``: the same with intra-option updates;
* ``Q(0.9)``: the learner with ``LearnerConfig``'s defaults (Watkins's Q(lambda), replacing
  traces), without and with the 15 options.

Configurations are interleaved over several rounds and the median rate is reported,
with the learner's overhead per decision (``1/rate - 1/rate_random``).

Usage::

    python benchmarks/bench_learner.py                          # the drill if installed
    python benchmarks/bench_learner.py --env-id soccer_drill/Holder-v0
    python benchmarks/bench_learner.py --env-id synthetic       # stand-in, ~180 us/step

``--env-id synthetic`` uses a 9-feature random-walk SMDP defined here whose step
busy-waits ``--synthetic-step-us`` microseconds to imitate the drill's physics.
"""

from __future__ import annotations

import argparse
import importlib
import os
import platform
import statistics
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from dataclasses import replace

from ilpss.kernels import SharedKernelModel
from ilpss.lifelong import LearnerConfig
from ilpss.options import OptionLibrary
from ilpss.policy import FrozenPolicy
from ilpss.smdp import KEEPAWAY, SmdpLearner
from ilpss.tiles import KEEPAWAY_ANGLE_WIDTH, KEEPAWAY_DISTANCE_WIDTH, TileCoder

DRILL_ID = "soccer_drill/Holder-v0"
# Feature units of the drill's holder observation: indices 4 and 8 are angles (degrees),
# the others distances or offsets (metres).
ANGLE_FEATURES = (4, 8)


class SyntheticHolderEnv(gym.Env):
    """Stand-in for the drill's holder SMDP: 9 features in the drill's ranges, a bounded
    random walk, episodes of up to ~40 decisions, durations 1-6 cycles, and a busy-wait
    per step to imitate the cost of the physics."""

    def __init__(self, step_us: float = 180.0) -> None:
        low = np.array([0, 0, 0, 0, 0, 0, -17.5, 0, 0], dtype=np.float32)
        high = np.array([50, 50, 50, 50, 180, 50, 17.5, 50, 180], dtype=np.float32)
        self.observation_space = gym.spaces.Box(low, high, dtype=np.float32)
        self.action_space = gym.spaces.Discrete(3)
        self.step_s = step_us * 1e-6
        self._low, self._high = low.astype(np.float64), high.astype(np.float64)
        self.x = np.zeros(9)
        self.cycles = 0

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.x = self.np_random.uniform(self._low, self._high)
        self.cycles = 0
        return self.x.astype(np.float32), {"duration": 0, "outcome": None}

    def step(self, action: int):
        end = time.perf_counter() + self.step_s
        while time.perf_counter() < end:
            pass
        rng = self.np_random
        d = int(rng.integers(1, 7))
        drift = (int(action) - 1) * 0.02 * (self._high - self._low)
        self.x = np.clip(
            self.x + drift + rng.normal(0, 0.03, 9) * (self._high - self._low),
            self._low,
            self._high,
        )
        self.cycles += d
        if self.x[5] < 3.0:
            return (
                self.x.astype(np.float32),
                1.0,
                True,
                False,
                {"duration": d, "outcome": "success"},
            )
        if rng.random() < 0.03:
            return (
                self.x.astype(np.float32),
                -1.0,
                True,
                False,
                {"duration": d, "outcome": "interception"},
            )
        if self.cycles >= 100:
            return (
                self.x.astype(np.float32),
                -1.0,
                False,
                True,
                {"duration": d, "outcome": "timeout"},
            )
        return self.x.astype(np.float32), 0.0, False, False, {"duration": d, "outcome": None}


def make_env(env_id: str, step_us: float) -> tuple[gym.Env, str]:
    if env_id == "synthetic":
        return SyntheticHolderEnv(step_us), f"synthetic 9-feature SMDP ({step_us:.0f} us/step)"
    if env_id.startswith("soccer_drill/"):
        importlib.import_module("soccer_drill")
    return gym.make(env_id), env_id


def keepaway_coder(space: gym.spaces.Box) -> TileCoder:
    widths = np.full(space.shape[0], KEEPAWAY_DISTANCE_WIDTH)
    for i in ANGLE_FEATURES:
        if i < widths.shape[0]:
            widths[i] = KEEPAWAY_ANGLE_WIDTH
    return LearnerConfig(tile_widths=tuple(widths), n_tilings=32).tile_coder(space)


def collect_states(env: gym.Env, n: int, rng: np.random.Generator) -> np.ndarray:
    states = []
    obs, _ = env.reset(seed=int(rng.integers(2**31)))
    while len(states) < n:
        states.append(np.asarray(obs, dtype=np.float64))
        obs, _, term, trunc, _ = env.step(int(rng.integers(3)))
        if term or trunc:
            obs, _ = env.reset()
    return np.array(states)


def build_library(env: gym.Env, coder: TileCoder, seed: int) -> OptionLibrary:
    """5 kernels fitted on random-rollout states x 3 frozen random policies = 15 options."""
    rng = np.random.default_rng(seed)
    states = collect_states(env, 1500, rng)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = SharedKernelModel(n_components=5, random_state=seed).fit([states])
    policies = [
        FrozenPolicy(coder, 3, (), rng.normal(0, 0.01, size=(3, coder.n_weights))) for _ in range(3)
    ]
    return OptionLibrary(model, policies)


class TimedEnv(gym.Wrapper):
    """Accumulates the wall time spent inside ``step`` and ``reset``.

    The environment's cost per decision depends on the policy (on the drill, on how many
    cycles each macro-action lasts), so the learner's own cost is measured as the time
    outside the environment, not as a difference of decision rates.
    """

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        self.env_time = 0.0

    def step(self, action: int):
        t0 = time.perf_counter()
        out = self.env.step(action)
        self.env_time += time.perf_counter() - t0
        return out

    def reset(self, **kwargs: Any):
        t0 = time.perf_counter()
        out = self.env.reset(**kwargs)
        self.env_time += time.perf_counter() - t0
        return out


def time_random(env: TimedEnv, n: int, rng: np.random.Generator) -> tuple[float, float, float]:
    """(decisions/s, env us/decision, agent us/decision) of a uniformly random policy."""
    env.reset(seed=int(rng.integers(2**31)))
    env.env_time = 0.0
    t0 = time.perf_counter()
    for _ in range(n):
        _, _, term, trunc, _ = env.step(int(rng.integers(3)))
        if term or trunc:
            env.reset()
    total = time.perf_counter() - t0
    return n / total, env.env_time / n * 1e6, (total - env.env_time) / n * 1e6


def time_learner(env: TimedEnv, learner: SmdpLearner, n: int) -> tuple[float, float, float]:
    """(decisions/s, env us/decision, learner us/decision) while learning."""
    done = 0
    env.env_time = 0.0
    t0 = time.perf_counter()
    while done < n:
        done += learner.run_episode(env, learn=True).decisions
    total = time.perf_counter() - t0
    return done / total, env.env_time / done * 1e6, (total - env.env_time) / done * 1e6


def _cpu_name() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown cpu"


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--env-id",
        default=None,
        help=f"Gymnasium id, or 'synthetic' (default: {DRILL_ID} if importable, else synthetic)",
    )
    parser.add_argument("--decisions", type=int, default=4000, help="decisions per round")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--synthetic-step-us", type=float, default=180.0)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)

    env_id = args.env_id
    if env_id is None:
        try:
            importlib.import_module("soccer_drill")
            env_id = DRILL_ID
        except ImportError:
            env_id = "synthetic"
    env, label = make_env(env_id, args.synthetic_step_us)
    space = env.observation_space
    if not isinstance(space, gym.spaces.Box) or space.shape != (9,):
        raise SystemExit(f"expected a Box observation of 9 features, got {space}")

    coder = keepaway_coder(space)
    library = build_library(env, coder, args.seed)
    assert len(library) == 15
    learners = {
        "learner (3 primitives)": SmdpLearner(3, coder, config=KEEPAWAY, seed=args.seed),
        "learner + 15 options": SmdpLearner(3, coder, library, config=KEEPAWAY, seed=args.seed),
        "learner + 15 options + intra-option": SmdpLearner(3, coder, library, config=replace(KEEPAWAY, intra_option=True), seed=args.seed),
        # LearnerConfig's defaults: Watkins's Q(0.9), replacing traces, optimistic values.
        "Q(0.9) learner (3 primitives)": SmdpLearner(3, coder, config=LearnerConfig(method="q", trace_decay=0.9, initial_value=1.0), seed=args.seed),
        "Q(0.9) learner + 15 options": SmdpLearner(3, coder, library, config=LearnerConfig(method="q", trace_decay=0.9, initial_value=1.0), seed=args.seed),
    }
    rng = np.random.default_rng(args.seed)
    timed = TimedEnv(env)
    rows: dict[str, list[tuple[float, float, float]]] = {"random policy": []}
    rows.update({name: [] for name in learners})
    # Warm-up, then interleaved rounds so that drifts of the machine hit every config.
    time_random(timed, 200, rng)
    for learner in learners.values():
        time_learner(timed, learner, 200)
    for _ in range(args.rounds):
        rows["random policy"].append(time_random(timed, args.decisions, rng))
        for name, learner in learners.items():
            rows[name].append(time_learner(timed, learner, args.decisions))

    med = {
        name: tuple(statistics.median(col) for col in zip(*v, strict=True))
        for name, v in rows.items()
    }
    print(f"environment: {label}")
    print(
        f"machine: {platform.machine()} ({_cpu_name()}, {os.cpu_count()} cpus), "
        f"Python {platform.python_version()}, numpy {np.__version__}"
    )
    print(
        f"tile coder: {coder.n_features} features x {coder.n_tilings} tilings, "
        f"{coder.n_weights} weights per choice"
    )
    print(f"{args.rounds} rounds x {args.decisions} decisions, medians\n")
    print("| configuration | decisions/s | env us/decision | agent us/decision |")
    print("|---|---:|---:|---:|")
    for name, (rate, env_us, agent_us) in med.items():
        print(f"| {name} | {rate:,.0f} | {env_us:.0f} | {agent_us:.1f} |")
    return {"env": label, "rates": med}


if __name__ == "__main__":
    main()
