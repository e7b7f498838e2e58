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

Called as ``policy(obs, rng)``, a policy reads the numbers of keepers and takers from the
observation's length, which keepaway's own sizes (fewer takers than keepers: 3v2, 4v3)
fix; at a size with as many takers as keepers or more, a length can be another size's
(2v4's 13 values are also 3v2's), so take a policy made for the size with
:func:`keeper_policy` (``keeper_policy("hand_coded", keepers=2, takers=4)``), which
reads the observation as that size's and refuses one of another length.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from soccer_drill.constraints import Integer, OneOf, check

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
    return _hand_coded(obs, rng, *keepaway_layout(obs))


def _hand_coded(obs: np.ndarray, rng: np.random.Generator, k: int, t: int) -> int:
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
    return _random_keeper(obs, rng, *keepaway_layout(obs))


def _random_keeper(obs: np.ndarray, rng: np.random.Generator, k: int, t: int) -> int:
    return int(rng.integers(k))


def always_hold(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Always hold the ball."""
    return HOLD


def _always_hold(obs: np.ndarray, rng: np.random.Generator, k: int, t: int) -> int:
    return HOLD


_AT_SIZE = {"hand_coded": _hand_coded, "random": _random_keeper, "hold": _always_hold}


def keeper_policy(name: str, keepers: int, takers: int) -> KeeperPolicy:
    """The policy ``name`` of :data:`KEEPER_POLICIES` for keepaway with ``keepers``
    keepers and ``takers`` takers (1 to 4 each, as the drill takes them; a lone keeper
    has no pass, so every policy holds), of any size: it reads the observation as that
    size's, and refuses one of another length (``ValueError``)."""
    check("name", name, OneOf(tuple(_AT_SIZE)))
    check("keepers", keepers, Integer(1, 4))
    check("takers", takers, Integer(1, 4))
    rule, size = _AT_SIZE[name], 4 * keepers + 2 * takers - 3

    def policy(obs: np.ndarray, rng: np.random.Generator) -> int:
        if len(obs) != size:
            raise ValueError(f"{len(obs)} values are not the state variables of keepaway "
                             f"{keepers}v{takers} ({size})")
        return rule(obs, rng, keepers, takers)

    policy.__name__ = policy.__qualname__ = f"{name}_{keepers}v{takers}"
    return policy


KEEPER_POLICIES: dict[str, KeeperPolicy] = {
    "hand_coded": hand_coded,
    "random": random_keeper,
    "hold": always_hold,
}
"""The keeper with the ball's fixed policies, by name."""
