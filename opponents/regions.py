"""Teams whose behaviour depends on where the ball is, and holder rules that switch with them.

A :class:`Region` splits the field by one of the holder's features: ``dist_goal``
(feature 5, the distance to the goal line) or ``lateral`` (feature 6, the offset from
the line's centre), at a threshold. :class:`RegionTeam` plays one team while the ball
is on one side of it and another team on the other side; :class:`RegionRule` plays one
fixed holder rule on each side. Both decide by the same test on the same number, so
at every decision of the holder the rule's region is exactly the team's::

    from opponents.regions import Region, RegionRule, RegionTeam
    import soccer_drill

    near = Region("dist_goal", 12.0)          # below: within 12 m of the goal line
    team = RegionTeam(above="interceptors_press", below="goal_guards", region=near)
    env = soccer_drill.HolderEnv(opponent=team)
    rule = RegionRule(above="late_pass", below="early_pass", region=near)
"""

from __future__ import annotations

import reprlib
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from soccer_drill import TeamError, make_team
from soccer_drill.constraints import Name, OneOf, Real, check, checked
from soccer_drill.policies import HOLDER_POLICIES, layout
from soccer_drill.teams import (
    FEATURE_NAMES,
    BatchCommands,
    BatchRandom,
    BatchView,
    team_ids,
)

REGION_FEATURES = ("dist_goal", "lateral")
"""The features a :class:`Region` may split on (names of :data:`FEATURE_NAMES`)."""
_BOUNDS = {"dist_goal": (0.0, 36.0), "lateral": (-18.5, 18.5)}  # the features' ranges
_SEED_SCALE = 2**53  # a uniform draw in [0, 1) times this is a whole number: a seed


@dataclass(frozen=True)
class Region:
    """A split of the field by one of the holder's features at a threshold.

    A point is *below* when the feature's value there, rounded to float32 as the
    observation is, is at most ``threshold`` (rounded the same way), and *above*
    otherwise. The value at a point ``(x, y)``:

    | feature | index | value | below means |
    |---|---|---|---|
    | ``dist_goal`` | 5 | ``y`` (the goal line is ``y = 0``) | within ``threshold`` metres of the goal line |
    | ``lateral`` | 6 | ``x - field_size / 2`` | left of ``threshold`` (0: the left half) |

    Parameters
    ----------
    feature
        ``"dist_goal"`` or ``"lateral"``.
    threshold
        Metres, inside the feature's range ([0, 36] or [-18.5, 18.5] on the
        default 35 m field).
    """

    feature: str
    threshold: float

    def __post_init__(self) -> None:
        check("Region feature", self.feature, OneOf(REGION_FEATURES))
        threshold = Real(*_BOUNDS[self.feature])
        t = checked(f"Region threshold for {self.feature!r}", self.threshold, threshold)
        object.__setattr__(self, "threshold", t)

    @property
    def index(self) -> int:
        """The feature's index in the holder's 9 features."""
        return FEATURE_NAMES.index(self.feature)

    def below(self, value: float | np.ndarray) -> bool | np.ndarray:
        """Whether feature values (one, or an array) lie below: float32, as observed."""
        return np.float32(value) <= np.float32(self.threshold)

    def observed_below(self, obs: np.ndarray) -> bool:
        """Whether the holder whose features are ``obs`` is below (of any size: its
        distance to the goal line and lateral offset follow its teammates' and opponents'
        features, ``obs[3 m + d]`` and the next, :func:`soccer_drill.policies.layout`)."""
        m, d = layout(obs)
        return bool(self.below(obs[3 * m + d + (self.feature == "lateral")]))

    def value_at(self, x: float | np.ndarray, y: float | np.ndarray, field_size: float):
        """The feature's value at field point ``(x, y)`` (arrays too)."""
        return y if self.feature == "dist_goal" else x - field_size / 2

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: ``{"feature": ..., "threshold": ...}``."""
        return {"feature": self.feature, "threshold": self.threshold}


_REGION_FIELDS = tuple(field.name for field in fields(Region))


def _region(region: Region | Mapping[str, Any]) -> Region:
    """``region``, or the :class:`Region` a configuration's mapping of its fields gives
    (a ``ValueError`` naming the fields for anything else, as for a field's value)."""
    if isinstance(region, Region):
        return region
    if isinstance(region, Mapping) and set(region) == set(_REGION_FIELDS):
        return Region(**region)
    raise ValueError(f"region must be a Region or a mapping with exactly the keys "
                     f"{' and '.join(map(repr, _REGION_FIELDS))}, got {reprlib.repr(region)}")


def _children(u: float) -> list[np.random.Generator]:
    """Two independent generators derived from one uniform draw of the team's own."""
    return [np.random.default_rng(s) for s in np.random.SeedSequence(int(u * _SEED_SCALE)).spawn(2)]


class RegionTeam:
    """Defenders that play one team while the ball is above a :class:`Region` and another below.

    The region is decided each cycle at the ball's carrier (the attacker in possession),
    or at the ball itself while it is loose, by the same test a :class:`RegionRule`
    makes on the holder's features: so whenever the holder decides, the team plays the
    behaviour of the holder's region. Both teams are reset together and act every cycle
    (so their own state, such as a reaction delay's memory or a guard's sortie, runs on
    in either region); the commands of the region's team are played. It is written once,
    in batched form (:class:`RegionBatch`), for one drill as for many; both teams must
    have a batched form (``batch(n)``: every team of this package has).

    ## Seeding

    At each drill's reset one uniform draw from its generator derives two independent
    generators (``numpy.random.SeedSequence(...).spawn(2)``): the first for the team
    above, the second for the team below. So an episode depends on that generator alone.

    ## Arguments

    | argument | meaning |
    |---|---|
    | ``above`` | team id played while the ball is above the region's threshold |
    | ``below`` | team id played while it is below |
    | ``region`` | a :class:`Region`, or a mapping ``{"feature": ..., "threshold": ...}`` |
    | ``above_params``, ``below_params`` | keyword parameters of those teams (``None``: none) |
    """

    def __init__(
        self,
        above: str,
        below: str,
        region: Region | Mapping[str, Any],
        above_params: Mapping[str, Any] | None = None,
        below_params: Mapping[str, Any] | None = None,
    ) -> None:
        for name, team in (("above", above), ("below", below)):
            check(f"RegionTeam {name} (a team id)", team, Name(dots=False))
        self.region = _region(region)
        self.above_id, self.below_id = above, below
        self.above_params = dict(above_params or {})
        self.below_params = dict(below_params or {})
        self.teams = (make_team(above, **self.above_params), make_team(below, **self.below_params))
        for team_id, team in zip((above, below), self.teams, strict=True):
            if not callable(getattr(team, "batch", None)):
                raise TeamError(f"RegionTeam composes teams with a batched form (batch(n)); "
                                f"team {team_id!r} has none")

    def params(self) -> dict[str, Any]:
        """The keyword parameters that rebuild this team (JSON-ready)."""
        return {
            "above": self.above_id, "below": self.below_id, "region": self.region.to_dict(),
            "above_params": dict(self.above_params), "below_params": dict(self.below_params),
        }

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.params().items())
        return f"{type(self).__name__}({args})"

    def batch(self, n: int) -> RegionBatch:
        """This team for ``n`` drills at once (see :class:`RegionBatch`)."""
        return RegionBatch(self, n)


class RegionBatch:
    """:class:`RegionTeam` for ``n`` drills at once (``team.batch(n)``).

    Each drill's two generators are derived from one draw of the drill's own generator;
    each batched team draws from its own.
    """

    def __init__(self, team: RegionTeam, n: int) -> None:
        self.region = team.region
        self.teams = tuple(t.batch(n) for t in team.teams)  # type: ignore[attr-defined]
        self._streams = (BatchRandom(n), BatchRandom(n))

    def reset(self, view: BatchView, drills: np.ndarray, rng: BatchRandom) -> None:
        """Start an episode in ``drills``: derive each drill's two streams, reset both teams."""
        children = [_children(u) for u in rng.random(drills).tolist()]
        for k, (team, stream) in enumerate(zip(self.teams, self._streams, strict=True)):
            stream.seed(drills, [pair[k] for pair in children])
            team.reset(view, drills, stream)

    def below(self, view: BatchView, drills: np.ndarray) -> np.ndarray:
        """``(len(drills),)`` bool: the carrier (or loose ball) of each drill is below."""
        holder = view.holder[drills]
        ball = view.pos.shape[1] - 1
        where = view.pos[drills, np.where(holder >= 0, holder, ball)]
        return self.region.below(self.region.value_at(where[:, 0], where[:, 1],
                                                      view.config.field_size))

    def act(self, view: BatchView, drills: np.ndarray) -> BatchCommands:
        """Each drill's row from the team of its region (both teams act for every drill)."""
        above, below = (team.act(view, drills) for team in self.teams)
        low = self.below(view, drills)
        return BatchCommands(
            np.where(low[:, None], below.skill, above.skill),
            np.where(low[:, None, None], below.target, above.target),
            np.where(low[:, None], below.speed, above.speed),
        )


@dataclass(frozen=True)
class RegionRule:
    """A fixed holder rule that plays rule ``above`` above a :class:`Region` and ``below`` below it.

    The region is read from the holder's own features (``obs[region.index]``), with the
    test of :class:`RegionTeam`. Rules are names of
    :data:`soccer_drill.policies.HOLDER_POLICIES`. Called as ``rule(obs, rng)``, like them.
    """

    above: str
    below: str
    region: Region

    def __post_init__(self) -> None:
        for name in (self.above, self.below):
            if name not in HOLDER_POLICIES:
                raise ValueError(f"unknown holder rule {name!r}; known: {sorted(HOLDER_POLICIES)}")
        object.__setattr__(self, "region", _region(self.region))

    @property
    def name(self) -> str:
        """``"<above>|<below>"``, e.g. ``late_pass|shield_pass``."""
        return f"{self.above}|{self.below}"

    def __call__(self, obs: np.ndarray, rng: np.random.Generator) -> int:
        rule = self.below if self.region.observed_below(obs) else self.above
        return HOLDER_POLICIES[rule](obs, rng)


def composition(team_id: str) -> tuple[int, float, str, str] | None:
    """What an oracle knows of the team with id ``team_id``: ``(feature index, threshold,
    team below, team above)`` if it is a :class:`RegionTeam` (observations with
    ``obs[index] <= threshold`` in float32 meet the team below), else ``None`` (also for
    an id no team has, such as a task's label)."""
    if team_id not in team_ids():
        return None
    team = make_team(team_id)
    if not isinstance(team, RegionTeam):
        return None
    return team.region.index, team.region.threshold, team.below_id, team.above_id
