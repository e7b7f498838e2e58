"""Fixed ball-holder policies: baselines, calibration rules and GIF drivers.

Each policy maps the holder's features (see :mod:`soccer_drill.rules.features`) and a
random generator to an action of the holder environment (0 HOLD, 1 PASS, 2 DRIBBLE in
the 2v2 drill). They read features only, so they run on any holder observation, of any
size: the features' length ``4 m + d + 3`` gives the numbers of teammates ``m`` (0 to 3)
and opponents ``d`` (1 to 4), the actions are HOLD, a pass per teammate (nearest first)
and DRIBBLE (``m + 1``), and a rule that passes passes to the first teammate, nearest
first, its condition allows (the only one in the 2v2 drill).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

HOLD, PASS, DRIBBLE = 0, 1, 2
"""The actions in the 2v2 drill."""
HolderPolicy = Callable[[np.ndarray, np.random.Generator], int]


def layout(obs: np.ndarray) -> tuple[int, int]:
    """``(teammates, opponents)`` of a holder's features, from their length ``4 m + d +
    3`` (``d`` in 1..4 makes it one of four lengths per ``m``): ``(1, 2)`` for the 9."""
    m, d = divmod(len(obs) - 4, 4)
    return m, d + 1


def _dribble(obs: np.ndarray) -> int:
    return layout(obs)[0] + 1


# The features are compared as the observation holds them (float32 scalars, with NumPy's
# arithmetic), so that a rule decides the same at 2v2 as it always has.
def _near(obs: np.ndarray) -> np.floating:
    """The nearest opponent's distance."""
    return obs[layout(obs)[0]]


def _dribble_angle(obs: np.ndarray) -> np.floating:
    return obs[-1]


def _pass_to(obs: np.ndarray, lane: float, free: Callable[[np.floating], bool]) -> int | None:
    """The pass to the first teammate (nearest first) whose passing lane is wider than
    ``lane`` degrees and whose distance to its nearest opponent is ``free``, or ``None``."""
    m, d = layout(obs)
    for k in range(m):
        if obs[2 * m + d + k] > lane and free(obs[m + d + k]):
            return 1 + k
    return None


def random_policy(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Uniformly random among the holder's actions (HOLD, PASS and DRIBBLE at 2v2)."""
    return int(rng.integers(layout(obs)[0] + 2))


def always_dribble(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Always dribble toward the goal line."""
    return _dribble(obs)


def always_hold(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Always shield the ball (never scores: a lower bound)."""
    return HOLD


def keepaway_rule(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Keepaway's hand-coded rule: dribble while free, pass when pressed and the lane is open, else hold."""
    if _near(obs) > 5.0:
        return _dribble(obs)
    target = _pass_to(obs, 20.0, lambda mate_opp: mate_opp > 4.0)
    return HOLD if target is None else target


def lane_rule(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Dribble when the dribbling lane is open, else pass if the passing lane is, else hold."""
    if _dribble_angle(obs) > 35.0 or _near(obs) > 9.0:
        return _dribble(obs)
    target = _pass_to(obs, 15.0, lambda mate_opp: mate_opp > 5.0)
    return HOLD if target is None else target


def pass_first(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Pass whenever the teammate is free and the lane open, otherwise dribble."""
    near = _near(obs)
    target = _pass_to(obs, 20.0, lambda mate_opp: mate_opp > near + 2.0)
    return _dribble(obs) if target is None else target


def _pressure_rule(obs: np.ndarray, pressure: float, shield: bool) -> int:
    """Dribble until the nearer defender is within ``pressure`` metres; then pass if the
    lane is open (> 30 deg) and the teammate free (> 5 m); otherwise shield the ball if
    ``shield`` and the dribbling lane is blocked (< 30 deg), else keep dribbling."""
    if _near(obs) > pressure:
        return _dribble(obs)
    target = _pass_to(obs, 30.0, lambda mate_opp: mate_opp > 5.0)
    if target is not None:
        return target
    if shield and _dribble_angle(obs) < 30.0:
        return HOLD
    return _dribble(obs)


def late_pass(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Dribble until a defender is within 3 m, then pass if the lane is open, else dribble on."""
    return _pressure_rule(obs, 3.0, shield=False)


def early_pass(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Dribble until a defender is within 6 m, then pass if the lane is open, else dribble on."""
    return _pressure_rule(obs, 6.0, shield=False)


def shield_pass(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Dribble until a defender is within 2 m, then pass if open, else shield if the way is blocked."""
    return _pressure_rule(obs, 2.0, shield=True)


HOLDER_POLICIES: dict[str, HolderPolicy] = {
    "random": random_policy,
    "dribble": always_dribble,
    "hold": always_hold,
    "keepaway": keepaway_rule,
    "lane": lane_rule,
    "pass_first": pass_first,
    "late_pass": late_pass,
    "early_pass": early_pass,
    "shield_pass": shield_pass,
}
"""Fixed holder policies by name."""


def get_policy(name: str) -> HolderPolicy:
    """The fixed holder policy called ``name``."""
    try:
        return HOLDER_POLICIES[name]
    except KeyError:
        raise ValueError(
            f"unknown holder policy {name!r}; known: {sorted(HOLDER_POLICIES)}"
        ) from None
