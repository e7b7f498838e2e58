"""SB3's PPO on the batched holder against a ``DummyVecEnv`` of as many ``HolderEnv``, in one run.

    python benchmarks/bench_sb3.py [--sizes 8 64] [--rollouts 2] [--rounds 3]
                                   [--team interceptors_cover]

Needs ``stable-baselines3`` (and torch). For each size ``N``, PPO (``MlpPolicy``,
``n_steps=128``, one epoch of minibatches of 256, torch on one thread) learns ``N * 128 *
--rollouts`` steps on ``HolderSB3VecEnv(N)`` and on ``DummyVecEnv`` of ``N`` ``HolderEnv``,
the two taking turns for ``--rounds`` rounds. A cost is this process's CPU time
(``time.process_time``) per environment step: of the whole ``learn`` (rollouts and
updates), and of its rollouts alone (``collect_rollouts``, where the environments run).
The table gives each cost's median over the rounds, and the dummy's over the batched
(above 1: the batched environment is the faster).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import torch
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import DummyVecEnv

from soccer_drill.envs.holder import HolderEnv
from soccer_drill.vector.sb3 import HolderSB3VecEnv

N_STEPS = 128


def learn_cost(env: object, steps: int) -> tuple[float, float]:
    """CPU seconds per environment step of ``PPO.learn(steps)`` on ``env``: in all, and in
    the rollouts."""
    model = PPO("MlpPolicy", env, n_steps=N_STEPS, batch_size=256, n_epochs=1, seed=0,
                device="cpu", verbose=0)
    spent = [0.0]
    collect = model.collect_rollouts

    def timed(*args: object, **kwargs: object) -> bool:
        start = time.process_time()
        try:
            return collect(*args, **kwargs)
        finally:
            spent[0] += time.process_time() - start

    model.collect_rollouts = timed  # type: ignore[method-assign]
    start = time.process_time()
    model.learn(total_timesteps=steps)
    return (time.process_time() - start) / steps, spent[0] / steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[8, 64])
    parser.add_argument("--rollouts", type=int, default=2)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--team", default="interceptors_cover")
    args = parser.parse_args()
    torch.set_num_threads(1)
    makers = {
        "batched": lambda n: HolderSB3VecEnv(n, opponent=args.team),
        "dummy": lambda n: DummyVecEnv([lambda: HolderEnv(opponent=args.team)] * n),
    }
    costs: dict = {}
    for _ in range(args.rounds):
        for n in args.sizes:
            for kind, make in makers.items():
                env = make(n)
                costs.setdefault((n, kind), []).append(learn_cost(env, n * N_STEPS * args.rollouts))
                env.close()
    print(f"python {platform.python_version()}, torch {torch.__version__}, {os.cpu_count()} "
          f"cores, load {os.getloadavg()[0]:.1f}; {args.rounds} rounds, medians")
    print("| N | dummy: us per step (learn) | batched: us per step (learn) | dummy / batched "
          "| dummy: us per step (rollouts) | batched: us per step (rollouts) | dummy / batched |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for n in args.sizes:
        row = [str(n)]
        for part in (0, 1):
            dummy = statistics.median(c[part] for c in costs[(n, "dummy")]) * 1e6
            batched = statistics.median(c[part] for c in costs[(n, "batched")]) * 1e6
            row += [f"{dummy:.0f}", f"{batched:.0f}", f"{dummy / batched:.2f}x"]
        print("| " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()
