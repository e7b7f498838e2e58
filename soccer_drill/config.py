"""The drill's physical and rule parameters, validated once at construction."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields
from typing import Any

import numpy as np
import pymunk

from soccer_drill.constraints import Integer, ListOf, OneOf, Real, check, checked
from soccer_drill.tasks import PAPER_STARTS, TASKS  # noqa: F401  (PAPER_STARTS: importable here)
from soccer_drill.tasks import drill_starts as default_starts  # noqa: F401  (the drill's, by its old name)

Point = tuple[float, float]


# The ranges are wide enough for any sensible drill and keep every derived quantity
# finite and every table small (e.g. the ball's roll table has 1.5 / cycle_seconds rows).
def _limited(default: float, constraint: Real | Integer) -> Any:
    """A numeric field whose constraint is declared in its metadata."""
    return field(default=default, metadata={"constraint": constraint})


PLAYERS_PER_TEAM = Integer(1, 4)
"""What ``DrillConfig.attackers`` and ``defenders`` allow."""
TASK = OneOf(tuple(TASKS))
"""What ``DrillConfig.task`` allows: a task of :data:`~soccer_drill.tasks.TASKS`."""
SUBSTEPS = Integer(1, 1000)
"""What ``DrillConfig.substeps`` allows, before :func:`step_bound`."""
_SPACE = pymunk.Space()  # pymunk's defaults, which the drill's spaces keep
COLLISION_BIAS: float = _SPACE.collision_bias
"""pymunk's ``Space.collision_bias`` (about 0.0018): the fraction of an overlap (beyond
:data:`COLLISION_SLOP`) not yet undone after 1 s."""
COLLISION_SLOP: float = _SPACE.collision_slop
"""pymunk's ``Space.collision_slop`` (0.1 m): the overlap it leaves alone."""
del _SPACE
SPEEDS = ("attacker_speed", "dribble_speed", "hold_speed", "defender_speed")
"""The fields a player's speed in a sub-step comes from (a dribbler runs at
``dribble_speed`` until the physics has moved it, even above ``attacker_speed``)."""


def step_bound(cycle_seconds: float, player_radius: float) -> float:
    """The furthest a player may move in one physics sub-step, in metres (0 or less: no
    move is short enough).

    pymunk has no continuous collision detection: it sees a contact only where two
    shapes overlap after a sub-step, and undoes an overlap gradually (beyond the slop
    ``s``, a fraction ``c = 1 - COLLISION_BIAS ** cycle_seconds`` of it per cycle), while
    the drill sets a player's velocity again at the start of every cycle. A player
    running into a wall then settles about ``s + d / c`` deep into it, ``d`` being its
    move in one sub-step; once that reaches ``player_radius + 0.1`` (the walls are 0.1 m
    thick on each side) its centre is past the wall's middle, and the wall pushes it out
    of the field. Two players running into each other settle ``s + 2 d / c`` deep, and
    pass through each other at ``2 * player_radius``. So ``d`` must stay below ``c *
    (player_radius - s / 2)`` (and players of a radius of at most ``s / 2`` pass through
    each other at any speed). Measured at cycles of 0.01 to 1 s, 1 to 30 sub-steps and
    radii of 0.1 to 2 m: players left the field from 0.8 to 1.05 times ``c *
    player_radius`` (the four pressing into a wall or a corner together); two players
    running into each other (radii from 0.06 m) passed through each other from twice the
    bound on, never at 1.5 times it. At the bound, half of the limit, every centre stayed
    at least about half a radius short of a wall's middle.
    """
    return 0.5 * (1.0 - COLLISION_BIAS**cycle_seconds) * (player_radius - COLLISION_SLOP / 2)


def fewest_substeps(top_speed: float, cycle_seconds: float, player_radius: float) -> int:
    """The fewest sub-steps per cycle that keep a player at ``top_speed`` within
    :func:`step_bound` (possibly more than ``substeps`` allows).

    Raises
    ------
    ValueError
        If no number of sub-steps does: ``player_radius`` at most half of
        :data:`COLLISION_SLOP`.
    """
    bound = step_bound(cycle_seconds, player_radius)
    if bound <= 0.0:
        raise ValueError(
            f"DrillConfig: player_radius {player_radius:g} is at most half of pymunk's "
            f"collision slop ({COLLISION_SLOP:.3g} m, the overlap it leaves alone), so two "
            f"players pass through each other at any speed; make player_radius larger than "
            f"{COLLISION_SLOP / 2:.3g}")
    need = max(1, math.ceil(top_speed * cycle_seconds / bound))
    while top_speed * cycle_seconds / need > bound:  # the rounding of the division
        need += 1
    return need


_COUNTS = ("no", "one", "two", "three", "four")
_STARTS = ("attacker_starts", "defender_starts")
@dataclass(frozen=True)
class DrillConfig:
    """Every number of the drill, in SI units (metres, seconds, m/s).

    The defaults are tuned so that a random ball holder seldom succeeds, a good
    hand-coded rule often does, and the best rule differs between opponent teams
    (see ``docs/opponents.md``). The field is ``field_size`` square; ``x`` runs
    left to right, ``y`` from the goal line (``y = 0``) up to the attackers' side.

    Each numeric field declares the interval it must lie in (its ``constraint``
    metadata, a :class:`~soccer_drill.constraints.Real` or
    :class:`~soccer_drill.constraints.Integer`). A value outside it, NaN, infinity, a
    bool or a non-number raises ``ValueError`` naming the field and the interval. NumPy
    numbers are accepted and stored as Python ``float``/``int``; the start points
    are stored as tuples of floats.

    ``field_size`` may be 10 to 1000 m, but the default starts (not given:
    :mod:`soccer_drill.tasks`) must fit in it: a side of two players keeps the paper's
    points, which need a field of at least 32.5 m with two attackers and 23 m with two
    defenders (13.5 m for the other sizes' starts with three or four attackers); a
    smaller field needs ``attacker_starts`` and ``defender_starts`` of its
    own (the error says so).
    """

    field_size: float = _limited(35.0, Real(10.0, 1000.0))
    """Side of the square training region, in metres."""
    cycle_seconds: float = _limited(0.1, Real(0.001, 1.0))
    """Simulated time of one cycle (one decision of every agent)."""
    substeps: int = _limited(10, SUBSTEPS)
    """Physics sub-steps per cycle (fixed step ``cycle_seconds / substeps``): enough that
    no player moves further than :func:`step_bound` in one."""
    max_cycles: int = _limited(100, Integer(1, 1_000_000))
    """Cycles after which the episode is truncated (a failure: timeout)."""
    player_radius: float = _limited(0.5, Real(0.05, 5.0))
    """Radius of a player's body; players collide with each other and the walls."""
    wall_margin: float = _limited(1.0, Real(0.0, 100.0))
    """Players are stopped by walls this far outside the region; the ball is not."""
    attacker_speed: float = _limited(6.0, Real(0.0, 100.0, low_open=True))
    """Top running speed of an attacker without the ball."""
    dribble_speed: float = _limited(4.6, Real(0.0, 100.0, low_open=True))
    """Top speed of an attacker running with the ball (dribbling)."""
    hold_speed: float = _limited(1.5, Real(0.0, 100.0, low_open=True))
    """Top speed of the holder while shielding the ball (``HOLD``)."""
    defender_speed: float = _limited(4.6, Real(0.0, 100.0, low_open=True))
    """Top running speed of a defender."""
    player_acceleration: float = _limited(20.0, Real(0.0, 10_000.0, low_open=True))
    """Acceleration cap of every player, m/s^2."""
    ball_damping: float = _limited(0.4, Real(0.0, 1.0))
    """Fraction of its speed a rolling ball keeps after one second."""
    ball_max_speed: float = _limited(25.0, Real(0.0, 1000.0, low_open=True))
    """Speed cap of the ball (a kick never exceeds it)."""
    pass_arrival_speed: float = _limited(4.0, Real(0.0, 1000.0, low_open=True))
    """Speed a pass is aimed to have when it reaches the receiver."""
    kick_angle_noise: float = _limited(4.0, Real(0.0, 180.0))
    """Standard deviation of a kick's direction error, in degrees."""
    kick_speed_noise: float = _limited(0.08, Real(0.0, 1.0))
    """Standard deviation of a kick's relative speed error."""
    control_radius: float = _limited(1.0, Real(0.0, 10.0, low_open=True))
    """A player controls the ball within this centre-to-centre distance ..."""
    control_speed: float = _limited(9.0, Real(0.0, 1000.0, low_open=True))
    """... if the ball's speed relative to the player is at most this."""
    ball_offset: float = _limited(0.75, Real(0.0, 10.0, low_open=True))
    """Distance ahead of the holder at which dribbling and shielding keep the ball."""
    tackle_probability: float = _limited(0.2, Real(0.0, 1.0))
    """Chance per cycle that a defender within control range of a held ball takes it."""
    pass_lockout_cycles: int = _limited(4, Integer(0, 1_000_000))
    """Cycles after a pass during which the passer cannot regain the ball."""
    start_jitter: float = _limited(1.5, Real(0.0, 100.0))
    """Half-width of the uniform jitter added to each starting coordinate; every jittered
    start must lie inside the walls, and the ball (``ball_offset`` below an attacker) in
    the field, above the goal line."""
    attackers: int = _limited(2, PLAYERS_PER_TEAM)
    """Number of attackers (1 to 4)."""
    defenders: int = _limited(2, PLAYERS_PER_TEAM)
    """Number of defenders (1 to 4)."""
    attacker_starts: tuple[Point, ...] | None = None
    """Nominal starting points of the attackers, one per attacker; ``None``: the task's
    (:data:`~soccer_drill.tasks.TASKS`; the drill's :func:`default_starts`, for two attackers in the 35 m region: the top corners,
    ``(4, 31)`` and ``(31, 31)``)."""
    defender_starts: tuple[Point, ...] | None = None
    """Nominal starting points of the defenders, one per defender; ``None``: the task's
    (the drill's :func:`default_starts`, for two defenders in the 35 m region: ``(13, 9)`` and
    ``(22, 9)``, near the goal line)."""
    reward_success_centre: float = _limited(1.0, Real(-1000.0, 1000.0))
    """Attackers' reward for crossing the goal line at its centre."""
    reward_success_edge: float = _limited(0.5, Real(-1000.0, 1000.0))
    """Attackers' reward for crossing at either end (linear in between)."""
    reward_failure: float = _limited(-1.0, Real(-1000.0, 1000.0))
    """Attackers' reward for an interception or the ball leaving the region."""
    reward_timeout: float = _limited(-1.0, Real(-1000.0, 1000.0))
    """Attackers' reward when ``max_cycles`` pass without an outcome."""
    task: str = "drill"
    """What the attackers do (:data:`~soccer_drill.tasks.TASKS`): ``"drill"``, carry the
    ball over the goal line (the paper's drill), or ``"keepaway"``, keep it inside the
    region as long as they can. It gives the default starts, whether ``y = 0`` is a goal
    line, and the reward (keepaway: the seconds the episode runs, the outcome rewards
    unused)."""

    def __post_init__(self) -> None:
        # NumPy numbers are accepted and stored as Python numbers, so to_dict() is JSON.
        for f in fields(self):
            constraint = f.metadata.get("constraint")
            if constraint is not None:
                value = checked(f"DrillConfig.{f.name}", getattr(self, f.name), constraint)
                object.__setattr__(self, f.name, value)
        check("DrillConfig.ball_offset", self.ball_offset,
              Real(0.0, self.control_radius - 0.05, high_open=True),
              why="smaller than control_radius - 0.05: the holder must keep control")
        check("DrillConfig.task", self.task, TASK)
        self._check_substeps()
        self._check_control_per_cycle()
        defaulted = []  # the starts not given, so the task's
        for name, count in (("attacker_starts", self.attackers),
                            ("defender_starts", self.defenders)):
            if getattr(self, name) is None:
                defaulted.append(name)
                object.__setattr__(self, name, TASKS[self.task].starts(name, count, self.field_size))
        for name in [n for n in _STARTS if n not in defaulted]:  # given: their own error
            self._check_start_points(self.field_size, name, getattr(self, name))
        try:
            self._check_starts(self.field_size, {n: getattr(self, n) for n in _STARTS})
        except ValueError as exc:
            if not defaulted:
                raise
            raise ValueError(self._default_starts_refused(defaulted, exc)) from None
        for name in _STARTS:
            points = tuple((float(x), float(y)) for x, y in getattr(self, name))
            object.__setattr__(self, name, points)

    def _check_starts(self, size: float, starts: dict[str, Any]) -> None:
        """``starts`` (by field name) inside a field of ``size``, with room for the jitter
        and the ball (:meth:`_check_start_area`); ``ValueError`` naming the first that is not."""
        for name in _STARTS:
            self._check_start_points(size, name, starts[name])
        self._check_start_area(size, starts)

    def _check_start_points(self, size: float, name: str, points: object) -> None:
        """``points``, the starts ``name``: one ``(x, y)`` per player of its side, inside
        a field of ``size``."""
        count = self.attackers if name == "attacker_starts" else self.defenders
        point = ListOf(Real(0.0, size), 2, 2, kinds=(list, tuple, np.ndarray))
        check(f"DrillConfig.{name}", points,
              ListOf(point, count, count, kinds=(list, tuple, np.ndarray)),
              why=f"{_COUNTS[count]} (x, y) point{'s' * (count > 1)} inside the "
                  f"field, one per {name.split('_')[0]}")

    def _default_starts_refused(self, defaulted: list[str], exc: ValueError) -> str:
        """Why the task's default starts do not fit this field: the smallest field_size
        they fit (to 0.1 m, the other fields as given), then the check's own words."""
        task, given = TASKS[self.task], {n: getattr(self, n) for n in _STARTS}

        def fits(size: float) -> bool:
            starts = {n: (task.starts(n, c, size) if n in defaulted else given[n])
                      for n, c in zip(_STARTS, (self.attackers, self.defenders), strict=True)}
            try:
                self._check_starts(size, starts)
            except ValueError:
                return False
            return True

        low, high = self.field_size, 1000.0  # field_size's own bound: 1000 m
        if not fits(high):
            need = "no field_size up to 1000 m fits them with these settings"
        else:
            while high - low > 0.01:  # fitting grows with the field: bisect
                low, high = ((low + high) / 2, high) if not fits((low + high) / 2) else (
                    low, (low + high) / 2)
            tenths = math.ceil(low * 10)  # the smallest size in tenths of a metre that fits
            while not fits(tenths / 10):
                tenths += 1
            need = f"they need field_size >= {tenths / 10:g}"
        return (f"DrillConfig: field_size {self.field_size:g} is too small for the "
                f"{self.task}'s default starts ({' and '.join(defaulted)} not given) of "
                f"{self.attackers} attacker(s) and {self.defenders} defender(s): {need} "
                f"(start_jitter {self.start_jitter:g}; two players of a side keep the paper's "
                "points in a field of any size: soccer_drill.tasks); give a larger "
                "field_size, or attacker_starts and defender_starts that fit. The check "
                f"said: {exc}")

    def _check_substeps(self) -> None:
        """Sub-steps short enough that no player can pass through a wall or another
        player (:func:`step_bound`): a player may run at any allowed speed, toward any
        target."""
        name = max(SPEEDS, key=lambda n: getattr(self, n))  # the first of the fastest
        top, cycle = getattr(self, name), self.cycle_seconds
        bound = step_bound(cycle, self.player_radius)
        if top * cycle / self.substeps <= bound:
            return
        need = fewest_substeps(top, cycle, self.player_radius)  # or no number will do
        fastest = bound * self.substeps / cycle
        if need <= SUBSTEPS.high:
            fix = f"make substeps at least {need}, or every speed at most {fastest:.3g} m/s"
        else:
            fix = (f"substeps cannot be raised enough (at most {SUBSTEPS.high:g}, for speeds up "
                   f"to {bound * SUBSTEPS.high / cycle:.3g} m/s): make every speed at most "
                   f"{fastest:.3g} m/s")
        raise ValueError(
            f"DrillConfig: with {self.substeps} physics sub-step(s) per cycle of {cycle:g} s, "
            f"a player at its top speed of {top:g} m/s ({name}) moves "
            f"{top * cycle / self.substeps:.3g} m in a sub-step, and can pass through a wall "
            f"or a player: with player_radius {self.player_radius:g}, at most {bound:.3g} m "
            f"is allowed; {fix}, or player_radius larger"
        )

    def _check_control_per_cycle(self) -> None:
        """A ball that a player could control never passes it unseen.

        The ball collides with nothing (it cannot pass through anything in the physics);
        who controls it is decided once per cycle, from where the ball and the players
        are then. A ball moving relative to a player at a speed it can be controlled at
        (``control_speed``, and never faster than ``ball_max_speed`` plus the fastest
        player) must therefore move at most the control area's width, ``2 *
        control_radius``, in a cycle: else it can go through a player who would have
        controlled it without ever being within ``control_radius`` of it at the end of a
        cycle (an interception becomes a pass, or a pass is never received).
        """
        fastest = max(getattr(self, name) for name in SPEEDS)
        speed = min(self.control_speed, self.ball_max_speed + fastest)
        width, cycle = 2.0 * self.control_radius, self.cycle_seconds
        if speed * cycle <= width:
            return
        raise ValueError(
            f"DrillConfig: a ball that a player can control moves up to {speed:g} m/s relative "
            f"to it (control_speed {self.control_speed:g}, ball_max_speed "
            f"{self.ball_max_speed:g} plus the fastest player's {fastest:g}), "
            f"{speed * cycle:.3g} m in a cycle of {cycle:g} s: more than the control area's "
            f"width of {width:g} m (2 * control_radius), so it can pass through a player who "
            f"would control it; make control_speed (or ball_max_speed plus the fastest "
            f"player's speed) at most {width / cycle:.3g} m/s, cycle_seconds shorter or "
            "control_radius larger"
        )

    def _check_start_area(self, size: float, starts: dict[str, Any]) -> None:
        """Every jittered start inside the walls, and the ball given to an attacker
        (``ball_offset`` below it) inside the field, above the goal line: an episode
        starts in play."""
        j = self.start_jitter
        reach = self.wall_margin - self.player_radius  # a player's centre, past the field
        for name in _STARTS:
            for x, y in starts[name]:
                if not all(-reach <= c - j and c + j <= size + reach for c in (x, y)):
                    raise ValueError(
                        f"DrillConfig: start_jitter {j:g} can put the player starting at "
                        f"({x:g}, {y:g}) ({name}) outside the walls: each coordinate must stay "
                        f"within [{-reach:g}, {size + reach:g}] (wall_margin - player_radius "
                        "past the field); make start_jitter smaller or move the start"
                    )
                ball_y = y - self.ball_offset
                if name == "attacker_starts" and not (
                    0.0 <= x - j and x + j <= size and 0.0 < ball_y - j and ball_y + j <= size
                ):
                    raise ValueError(
                        f"DrillConfig: start_jitter {j:g} can put the ball of the attacker "
                        f"starting at ({x:g}, {y:g}) (ball_offset {self.ball_offset:g} below it) "
                        f"outside the field or on the goal line: x must stay within "
                        f"[0, {size:g}] and the ball's y within (0, {size:g}]; make "
                        "start_jitter smaller or move the start"
                    )

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> DrillConfig:
        """Build from a plain dict (e.g. JSON), rejecting unknown keys by name."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(values) - known)
        if unknown:
            raise ValueError(
                f"unknown DrillConfig field(s) {unknown}; allowed: {sorted(known)}"
            )
        return cls(**values)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict of every field."""
        return asdict(self)

    @property
    def players(self) -> int:
        """Number of players, attackers then defenders (the ball is body ``players``)."""
        return self.attackers + self.defenders

    @property
    def player_names(self) -> tuple[str, ...]:
        """The players' names in index order: ``attacker_0``, ... then ``defender_0``, ..."""
        return (*(f"attacker_{k}" for k in range(self.attackers)),
                *(f"defender_{k}" for k in range(self.defenders)))

    @property
    def size(self) -> tuple[int, int]:
        """``(attackers, defenders)``."""
        return self.attackers, self.defenders

    def success_reward(self, x: float) -> float:
        """Attackers' reward for crossing the goal line at abscissa ``x``."""
        half = self.field_size / 2
        off_centre = min(abs(x - half) / half, 1.0)
        return self.reward_success_centre + (
            self.reward_success_edge - self.reward_success_centre
        ) * off_centre


