"""How keepaway's episodes end, and how many passes reach a keeper too fast to control.

    python benchmarks/keepaway_endings.py [--episodes 200] [--policy hand_coded]

For each named keepaway scenario, ``--episodes`` episodes (seeds 0, 1, ...) of
``HolderEnv`` with the keeper policy ``--policy`` of ``soccer_drill.keepaway_policies``.
Every cycle's state is read after the cycle (the environment's loop, wrapped in this
process only). Per scenario: the episodes by outcome and by the last action of the keeper
with the ball (a pass, or not), and of the episodes that end ``out`` after a pass, those
in which the ball came within ``control_radius`` of a keeper other than its passer at a
relative speed above ``control_speed`` (a pass that ran through a keeper who could not
control it).
"""

from __future__ import annotations

import argparse
import collections
import math

import numpy as np

from soccer_drill import keepaway_policies
from soccer_drill.scenarios import SCENARIOS, holder_env


def through_keeper(states: list, keepers: int, radius: float, speed: float) -> bool:
    """Whether, in ``states``, the ball came within ``radius`` of a keeper other than
    its passer faster than ``speed`` relative to it."""
    for s in states:
        (bx, by), (bvx, bvy) = s.pos[-1], s.vel[-1]
        for k in range(keepers):
            if k == s.passer:
                continue
            (x, y), (vx, vy) = s.pos[k], s.vel[k]
            if math.hypot(bx - x, by - y) <= radius and math.hypot(bvx - vx, bvy - vy) > speed:
                return True
    return False


def endings(name: str, episodes: int, policy_name: str) -> tuple[collections.Counter, int]:
    """The episodes' (outcome, last action) counts, and the passes that went through."""
    env = holder_env(name)
    cfg = env.config
    policy = keepaway_policies.keeper_policy(policy_name, cfg.attackers, cfg.defenders)
    loop, states = env.loop, []
    run_cycle = loop.cycle

    def cycle(drills: np.ndarray) -> bool:
        running = run_cycle(drills)
        states.append(loop.core.batch.state_of(0))
        return running

    loop.cycle = cycle  # this process's environment only: reads the state after each cycle
    counts, through = collections.Counter(), 0
    for seed in range(episodes):
        obs, _ = env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        done = False
        while not done:
            states.clear()
            action = policy(obs, rng)
            obs, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
        passed = action > 0  # 0 is HOLD, the others pass
        counts[(info["outcome"], "pass" if passed else "hold")] += 1
        if info["outcome"] == "out" and passed:
            through += through_keeper(states, cfg.attackers, cfg.control_radius,
                                      cfg.control_speed)
    return counts, through


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--policy", default="hand_coded",
                        choices=sorted(keepaway_policies.KEEPER_POLICIES))
    args = parser.parse_args()
    print(f"{args.episodes} episodes (seeds 0..{args.episodes - 1}), keepers: {args.policy}")
    print("| scenario | out after a pass | of them, through a keeper too fast to control "
          "| out after a hold | a taker won the ball | timeout |")
    print("|---|---:|---:|---:|---:|---:|")
    for name in (n for n, s in SCENARIOS.items() if s.task == "keepaway"):
        counts, through = endings(name, args.episodes, args.policy)
        taken = sum(v for (outcome, _), v in counts.items()
                    if outcome not in ("out", "timeout"))
        timeouts = sum(v for (outcome, _), v in counts.items() if outcome == "timeout")
        print(f"| `{name}` | {counts[('out', 'pass')]} | {through} | {counts[('out', 'hold')]} "
              f"| {taken} | {timeouts} |")


if __name__ == "__main__":
    main()
