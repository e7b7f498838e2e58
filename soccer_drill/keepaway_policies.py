"""Fixed policies of the keeper with the ball in keepaway: the benchmark's baselines.

Each maps keepaway's state variables (:mod:`soccer_drill.rules.keepaway`: ``4 k + 2 t -
3`` of them with ``k`` keepers and ``t`` takers) and a random generator to an action of
the keepaway holder environment: 0 ``HOLD``, ``i`` (1 .. k - 1) a pass to the ``i``-th
nearest other keeper. Keepaway has no dribble.

| policy | rule |
|---|---|
| ``hand_coded`` | keepaway's hand-coded keeper (Stone, Sutton and Kuhlmann 2005): hold while no taker is within :data:`HOLD_DISTANCE` m; else score holding :data:`HOLD_SCORE` and each keeper ``i`` ``DIST_WEIGHT * min_dist(Ki, T) + min_ang(Ki, K1, T)`` (its nearest taker's distance, metres, and its passing lane, degrees), and take the highest (holding on ties) |
| ``random`` | uniform over the actions |
| ``hold`` | always hold |
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

HOLD = 0
HOLD_DISTANCE = 5.0
"""The hand-coded keeper holds while its nearest taker is farther than this (metres)."""
HOLD_SCORE = 90.0
"""The hand-coded keeper's score of holding (its hold threshold)."""
DIST_WEIGHT = 4.0
"""The hand-coded keeper's weight of a keeper's nearest taker's distance against its
passing lane's angle (degrees per metre)."""

KeeperPolicy = Callable[[np.ndarray, np.random.Generator], int]


def keepaway_layout(obs: np.ndarray) -> tuple[int, int]:
    """``(keepers, takers)`` of keepaway's state variables, from their length ``4 k + 2 t
    - 3`` and ``t < k`` (keepaway's; ``(3, 2)`` for 13, ``(4, 3)`` for 19)."""
    n = len(obs)
    for takers in range(1, 5):
        keepers, rest = divmod(n + 3 - 2 * takers, 4)
        if rest == 0 and 1 < keepers <= 4 and takers < keepers:
            return keepers, takers
    raise ValueError(f"{n} values are not keepaway's state variables (4 k + 2 t - 3, t < k)")


def hand_coded(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Keepaway's hand-coded keeper (the module's table)."""
    k, t = keepaway_layout(obs)
    if obs[k] > HOLD_DISTANCE:  # dist(K1, T1): the nearest taker
        return HOLD
    near = obs[2 * k + 2 * t - 1: 3 * k + 2 * t - 2]
    lanes = obs[3 * k + 2 * t - 2: 4 * k + 2 * t - 3]
    best, score = HOLD, HOLD_SCORE
    for i in range(k - 1):
        s = DIST_WEIGHT * float(near[i]) + float(lanes[i])
        if s > score:
            best, score = 1 + i, s
    return best


def random_keeper(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Uniformly random among ``HOLD`` and the passes."""
    return int(rng.integers(keepaway_layout(obs)[0]))


def always_hold(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Always hold the ball."""
    return HOLD


KEEPER_POLICIES: dict[str, KeeperPolicy] = {
    "hand_coded": hand_coded,
    "random": random_keeper,
    "hold": always_hold,
}
"""The keeper with the ball's fixed policies, by name."""
