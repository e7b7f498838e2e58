"""Fixed ball-holder policies: baselines, calibration rules and GIF drivers.

Each policy maps the holder's 9 features (see :mod:`soccer_drill.rules.features`) and a
random generator to an action of the holder environment (0 HOLD, 1 PASS,
2 DRIBBLE). They read features only, so they run on any holder observation.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

HOLD, PASS, DRIBBLE = 0, 1, 2
HolderPolicy = Callable[[np.ndarray, np.random.Generator], int]

# Feature indices (see soccer_drill.rules.features.FEATURE_NAMES).
_DIST_OPP, _MATE_OPP, _PASS_ANGLE, _DRIBBLE_ANGLE = 1, 3, 4, 8


def random_policy(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Uniformly random among HOLD, PASS and DRIBBLE."""
    return int(rng.integers(3))


def always_dribble(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Always dribble toward the goal line."""
    return DRIBBLE


def always_hold(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Always shield the ball (never scores: a lower bound)."""
    return HOLD


def keepaway_rule(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Keepaway's hand-coded rule: dribble while free, pass when pressed and the lane is open, else hold."""
    if obs[_DIST_OPP] > 5.0:
        return DRIBBLE
    if obs[_PASS_ANGLE] > 20.0 and obs[_MATE_OPP] > 4.0:
        return PASS
    return HOLD


def lane_rule(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Dribble when the dribbling lane is open, else pass if the passing lane is, else hold."""
    if obs[_DRIBBLE_ANGLE] > 35.0 or obs[_DIST_OPP] > 9.0:
        return DRIBBLE
    if obs[_PASS_ANGLE] > 15.0 and obs[_MATE_OPP] > 5.0:
        return PASS
    return HOLD


def pass_first(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Pass whenever the teammate is free and the lane open, otherwise dribble."""
    if obs[_PASS_ANGLE] > 20.0 and obs[_MATE_OPP] > obs[_DIST_OPP] + 2.0:
        return PASS
    return DRIBBLE


def _pressure_rule(obs: np.ndarray, pressure: float, shield: bool) -> int:
    """Dribble until the nearer defender is within ``pressure`` metres; then pass if the
    lane is open (> 30 deg) and the teammate free (> 5 m); otherwise shield the ball if
    ``shield`` and the dribbling lane is blocked (< 30 deg), else keep dribbling."""
    if obs[_DIST_OPP] > pressure:
        return DRIBBLE
    if obs[_PASS_ANGLE] > 30.0 and obs[_MATE_OPP] > 5.0:
        return PASS
    if shield and obs[_DRIBBLE_ANGLE] < 30.0:
        return HOLD
    return DRIBBLE


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
