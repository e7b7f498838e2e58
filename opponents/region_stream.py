"""The teams of targets composed by region: two pure behaviours and their compositions.

Two behaviours whose best fixed holder rules are far apart (``docs/regions.md`` measures
it), and teams that play one of them on one side of a :class:`~opponents.regions.Region`
and the other on the other side:

| id | kind | what it does |
|---|---|---|
| ``interceptors_press`` | source (paper team 1) | both defenders press the ball; best rule ``late_pass`` |
| ``contain_cover`` | source | a slow presser that waits in the holder's path and a close marker; best rule ``lane`` |
| ``press_far_contain_near`` | target | ``interceptors_press`` beyond 12 m of the goal line, ``contain_cover`` within it |
| ``contain_left_press_right`` | target | ``contain_cover`` in the left half, ``interceptors_press`` in the right |
| ``press_left_contain_right`` | target | ``interceptors_press`` in the left half, ``contain_cover`` in the right |
| ``press_far_contain_near_9`` | target | ``press_far_contain_near`` with the boundary 9 m from the line |
| ``press_far_contain_near_15`` | target | ``press_far_contain_near`` with the boundary 15 m from the line |

The last two and ``press_far_contain_near`` are the sharp test's targets: every episode
starts far from the line and nearly all reach near it, so the gain needs a change of
behaviour within the episode (choosing one source per episode gets none of it).

Each class is a setting of :class:`~opponents.parametric.ParametricTeam` or
:class:`~opponents.regions.RegionTeam` (``DEFAULTS``); keyword arguments override it.
"""

from __future__ import annotations

from typing import Any, ClassVar

from opponents.parametric import ParametricTeam
from opponents.presets import Preset
from opponents.regions import Region, RegionTeam

NEAR = Region("dist_goal", 12.0)
"""Below: the holder is within 12 m of the goal line (feature 5 <= 12); above: farther."""
LEFT = Region("lateral", 0.0)
"""Below: the holder is in the left half (feature 6 <= 0); above: the right half."""

SOURCES: tuple[str, str] = ("interceptors_press", "contain_cover")
"""The pure behaviours, in the stream's order."""
TARGETS: tuple[str, str, str] = (
    "press_far_contain_near", "contain_left_press_right", "press_left_contain_right",
)
"""The compositions kept as targets by the pre-check (``docs/regions.md``)."""
SHARP_SOURCES: tuple[str, ...] = ("interceptors_press", "interceptors_cover",
                                  "interceptor_guard", "goal_guards", "contain_cover")
"""The sharp test's sources: the paper's four teams, then the contain (the targets' two
behaviours among three others: which source to run where must be found)."""
SHARP_TARGETS: tuple[str, ...] = ("press_far_contain_near_9", "press_far_contain_near",
                                  "press_far_contain_near_15")
"""The sharp test's targets: the press far from the goal line, the contain near it, at three
boundaries; each kept by the pre-check as needing a change within the episode
(``docs/regions.md``)."""


class ContainCover(Preset, ParametricTeam):
    """Slow cover: the nearer defender waits in the holder's path, the other marks the free attacker closely.

    Paper team 2's coordination (``cover``) at 70% of the defenders' top speed (3.2 m/s,
    slower than a dribbling holder's 4.6), with the marker 20% of the way from the free
    attacker to the ball instead of 35%. The presser aims where the holder will be
    (``INTERCEPT`` leads a carried ball by up to 1.5 s) and, too slow to overrun it,
    stands in its path: a holder who keeps dribbling runs into it, most often along a
    touchline, and is tackled. What beats it is shielding the ball while the dribbling
    lane is shut and passing as soon as the passing lane opens (the ``lane`` rule); every
    rule that dribbles on under pressure (``dribble``, ``late_pass``, ``early_pass``)
    fails. No randomness of its own.

    Settings: ``roles=("interceptor", "interceptor")``, ``coordination="cover"``,
    ``speed=0.7``, ``mark_fraction=0.2``, ``chase_loose=True``, no reaction delay.
    """

    DEFAULTS: ClassVar[dict[str, Any]] = {
        "roles": ("interceptor", "interceptor"),
        "coordination": "cover",
        "speed": 0.7,
        "mark_fraction": 0.2,
        "chase_loose": True,
    }


class _Composition(Preset, RegionTeam):
    pass


class PressFarContainNear(_Composition):
    """Press while the ball is more than 12 m from the goal line, contain within 12 m.

    ``interceptors_press`` above :data:`NEAR` (feature 5, the holder's distance to the
    goal line, > 12), ``contain_cover`` below it (<= 12). Every episode starts far
    (the attackers start about 31 m up), so the press must be beaten first
    (``late_pass``), then the contain near the line (``lane``).

    Settings: ``above="interceptors_press"``, ``below="contain_cover"``,
    ``region={"feature": "dist_goal", "threshold": 12.0}``.
    """

    DEFAULTS: ClassVar[dict[str, Any]] = {
        "above": "interceptors_press", "below": "contain_cover", "region": NEAR,
    }


class ContainLeftPressRight(_Composition):
    """Contain in the left half of the field, press in the right half.

    ``contain_cover`` below :data:`LEFT` (feature 6, the holder's offset from the goal
    line's centre, <= 0), ``interceptors_press`` above it (> 0). The attackers start in
    the two top corners, the holder in either, so about half of the episodes start in
    each half.

    Settings: ``above="interceptors_press"``, ``below="contain_cover"``,
    ``region={"feature": "lateral", "threshold": 0.0}``.
    """

    DEFAULTS: ClassVar[dict[str, Any]] = {
        "above": "interceptors_press", "below": "contain_cover", "region": LEFT,
    }


class PressLeftContainRight(_Composition):
    """Press in the left half of the field, contain in the right half.

    ``interceptors_press`` below :data:`LEFT` (feature 6 <= 0), ``contain_cover`` above
    it (> 0): :class:`ContainLeftPressRight` mirrored.

    Settings: ``above="contain_cover"``, ``below="interceptors_press"``,
    ``region={"feature": "lateral", "threshold": 0.0}``.
    """

    DEFAULTS: ClassVar[dict[str, Any]] = {
        "above": "contain_cover", "below": "interceptors_press", "region": LEFT,
    }



class _PressFarContainNearAt(_Composition):
    """:class:`PressFarContainNear` with the boundary elsewhere."""


class PressFarContainNear9(_PressFarContainNearAt):
    """:class:`PressFarContainNear` with the boundary 9 m from the goal line.

    Settings: ``above="interceptors_press"``, ``below="contain_cover"``,
    ``region={"feature": "dist_goal", "threshold": 9.0}``.
    """

    DEFAULTS: ClassVar[dict[str, Any]] = {
        "above": "interceptors_press", "below": "contain_cover",
        "region": Region("dist_goal", 9.0),
    }


class PressFarContainNear15(_PressFarContainNearAt):
    """:class:`PressFarContainNear` with the boundary 15 m from the goal line.

    Settings: ``above="interceptors_press"``, ``below="contain_cover"``,
    ``region={"feature": "dist_goal", "threshold": 15.0}``.
    """

    DEFAULTS: ClassVar[dict[str, Any]] = {
        "above": "interceptors_press", "below": "contain_cover",
        "region": Region("dist_goal", 15.0),
    }
