"""The four defending teams of the ILPSS paper (section 5), as settings of the parametric family.

"The first two only intercept the ball, with different coordination protocols
between the players. One opponent in the third type intercepts the ball while
the other protects the goal line, while both opponents protect the goal in the
fourth type, and only leave it for the ball with small probability."

Each class is :class:`~opponents.parametric.ParametricTeam` with the settings in
its ``DEFAULTS``; keyword arguments override them (so ``HolderEnv(opponent=
"goal_guards", opponent_params={"press_probability": 0.05})`` is a variant).
"""

from __future__ import annotations

from typing import Any, ClassVar

from opponents.parametric import ParametricTeam
from opponents.presets import Preset


class _PaperTeam(Preset, ParametricTeam):
    pass


class InterceptorsPress(_PaperTeam):
    """Paper team 1: two interceptors who both press the ball.

    Both defenders run at full speed to the ball, or to the earliest point of a
    rolling ball's path they can reach (the ``INTERCEPT`` skill), whoever holds
    it. The holder is double-teamed, but the other attacker is always free, so a
    timely pass beats them.

    Settings: ``roles=("interceptor", "interceptor")``, ``coordination="press"``,
    ``speed=1.0``, no reaction delay. No randomness of its own. It behaves exactly as
    :class:`~opponents.chasers.Chasers` at full speed, an independent minimal
    implementation that cross-checks the family (``tests/test_opponents.py``).
    """

    DEFAULTS: ClassVar[dict[str, Any]] = {
        "roles": ("interceptor", "interceptor"),
        "coordination": "press",
        "speed": 1.0,
    }


class InterceptorsCover(_PaperTeam):
    """Paper team 2: the nearer interceptor presses, the other marks the passing lane.

    The defender nearer the ball (with a 1 m hysteresis) presses it
    (``INTERCEPT``); the other marks the free attacker from the passing lane
    (``MARK``: 35 % of the way from the attacker to the ball) and goes for the
    ball as soon as it is loose (a pass, a lost ball). Passing is risky against
    them; a single presser can be dribbled round.

    Settings: ``roles=("interceptor", "interceptor")``, ``coordination="cover"``,
    ``mark_fraction=0.35``, ``chase_loose=True``, ``speed=1.0``, no delay. No
    randomness of its own.
    """

    DEFAULTS: ClassVar[dict[str, Any]] = {
        "roles": ("interceptor", "interceptor"),
        "coordination": "cover",
        "mark_fraction": 0.35,
        "chase_loose": True,
        "speed": 1.0,
    }


class InterceptorGuard(_PaperTeam):
    """Paper team 3: one interceptor presses the ball, one guard holds the goal line.

    ``defender_0`` intercepts the ball at full speed. ``defender_1`` guards the
    line (``GUARD_LINE``: level with the ball, 2.5 m up from the line) and steps
    out for the ball only when it comes within ``guard_reach`` metres (a sortie of
    ``sortie_cycles`` cycles). Beating it takes getting away from the interceptor
    and then past the guard, typically with a pass across the line.

    Settings: ``roles=("interceptor", "guard")``, ``guard_depth=2.5``,
    ``guard_track=1.0``, ``guard_reach=2.5``, ``sortie_cycles=8``,
    ``press_probability=0``. No randomness of its own.
    """

    DEFAULTS: ClassVar[dict[str, Any]] = {
        "roles": ("interceptor", "guard"),
        "guard_depth": 2.5,
        "guard_track": 1.0,
        "guard_reach": 2.5,
        "sortie_cycles": 8,
        "press_probability": 0.0,
        "speed": 1.0,
    }


class GoalGuards(_PaperTeam):
    """Paper team 4: two goal-line guards who leave the line for the ball with small probability.

    Both defenders stand ``guard_depth`` metres up from the goal line,
    ``guard_spacing`` metres apart, following the ball sideways by ``guard_track``
    (0.8: they lag toward their home spots at 1/3 and 2/3 of the width). Each
    cycle, each guard on its line starts a sortie for the ball with probability
    ``press_probability = 0.02`` (so about 87 % of 100-cycle episodes see at least
    one sortie per guard), and always when the ball comes within ``guard_reach``
    metres; a sortie lasts ``sortie_cycles`` cycles. The draws come from the
    generator handed to ``reset``.

    Settings: ``roles=("guard", "guard")``, ``guard_depth=2.5``, ``guard_track=0.8``,
    ``guard_spacing=6.0``, ``guard_reach=2.0``, ``press_probability=0.02``,
    ``sortie_cycles=10``.
    """

    DEFAULTS: ClassVar[dict[str, Any]] = {
        "roles": ("guard", "guard"),
        "guard_depth": 2.5,
        "guard_track": 0.8,
        "guard_spacing": 6.0,
        "guard_reach": 2.0,
        "press_probability": 0.02,
        "sortie_cycles": 10,
        "speed": 1.0,
    }
