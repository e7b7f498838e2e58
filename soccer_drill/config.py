"""The drill's physical and rule parameters, validated once at construction."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any

Point = tuple[float, float]


@dataclass(frozen=True)
class DrillConfig:
    """Every number of the drill, in SI units (metres, seconds, m/s).

    The defaults are tuned so that a random ball holder seldom succeeds, a good
    hand-coded rule often does, and the best rule differs between opponent teams
    (see ``docs/opponents.md``). The field is ``field_size`` square; ``x`` runs
    left to right, ``y`` from the goal line (``y = 0``) up to the attackers' side.
    """

    field_size: float = 35.0
    """Side of the square training region, in metres."""
    cycle_seconds: float = 0.1
    """Simulated time of one cycle (one decision of every agent)."""
    substeps: int = 10
    """Physics sub-steps per cycle (fixed step ``cycle_seconds / substeps``)."""
    max_cycles: int = 100
    """Cycles after which the episode is truncated (a failure: timeout)."""
    player_radius: float = 0.5
    """Radius of a player's body; players collide with each other and the walls."""
    wall_margin: float = 1.0
    """Players are stopped by walls this far outside the region; the ball is not."""
    attacker_speed: float = 6.0
    """Top running speed of an attacker without the ball."""
    dribble_speed: float = 4.6
    """Top speed of an attacker running with the ball (dribbling)."""
    hold_speed: float = 1.5
    """Top speed of the holder while shielding the ball (``HOLD``)."""
    defender_speed: float = 4.6
    """Top running speed of a defender."""
    player_acceleration: float = 20.0
    """Acceleration cap of every player, m/s^2."""
    ball_damping: float = 0.4
    """Fraction of its speed a rolling ball keeps after one second."""
    ball_max_speed: float = 25.0
    """Speed cap of the ball (a kick never exceeds it)."""
    pass_arrival_speed: float = 4.0
    """Speed a pass is aimed to have when it reaches the receiver."""
    kick_angle_noise: float = 4.0
    """Standard deviation of a kick's direction error, in degrees."""
    kick_speed_noise: float = 0.08
    """Standard deviation of a kick's relative speed error."""
    control_radius: float = 1.0
    """A player controls the ball within this centre-to-centre distance ..."""
    control_speed: float = 9.0
    """... if the ball's speed relative to the player is at most this."""
    ball_offset: float = 0.75
    """Distance ahead of the holder at which dribbling and shielding keep the ball."""
    tackle_probability: float = 0.2
    """Chance per cycle that a defender within control range of a held ball takes it."""
    pass_lockout_cycles: int = 4
    """Cycles after a pass during which the passer cannot regain the ball."""
    start_jitter: float = 1.5
    """Half-width of the uniform jitter added to each starting coordinate."""
    attacker_starts: tuple[Point, Point] = ((4.0, 31.0), (31.0, 31.0))
    """Nominal starting points of the two attackers (top corners)."""
    defender_starts: tuple[Point, Point] = ((13.0, 9.0), (22.0, 9.0))
    """Nominal starting points of the two defenders (near the goal line)."""
    reward_success_centre: float = 1.0
    """Attackers' reward for crossing the goal line at its centre."""
    reward_success_edge: float = 0.5
    """Attackers' reward for crossing at either end (linear in between)."""
    reward_failure: float = -1.0
    """Attackers' reward for an interception or the ball leaving the region."""
    reward_timeout: float = -1.0
    """Attackers' reward when ``max_cycles`` pass without an outcome."""

    def __post_init__(self) -> None:
        positive = (
            "field_size", "cycle_seconds", "player_radius", "attacker_speed",
            "dribble_speed", "hold_speed", "defender_speed", "player_acceleration",
            "ball_max_speed", "pass_arrival_speed", "control_radius", "control_speed",
            "ball_offset",
        )
        for name in (f.name for f in fields(self)):
            value = getattr(self, name)
            if isinstance(value, float | int) and not isinstance(value, bool):
                if not math.isfinite(value):
                    raise ValueError(f"DrillConfig.{name} must be finite, got {value!r}")
        for name in positive:
            if getattr(self, name) <= 0:
                raise ValueError(f"DrillConfig.{name} must be > 0, got {getattr(self, name)!r}")
        for name in ("substeps", "max_cycles"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < 1:
                raise ValueError(f"DrillConfig.{name} must be an integer >= 1, got {value!r}")
        if not isinstance(self.pass_lockout_cycles, int) or self.pass_lockout_cycles < 0:
            raise ValueError(
                "DrillConfig.pass_lockout_cycles must be an integer >= 0, "
                f"got {self.pass_lockout_cycles!r}"
            )
        for name in ("ball_damping", "tackle_probability"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"DrillConfig.{name} must lie in [0, 1], got {value!r}")
        for name in ("kick_angle_noise", "kick_speed_noise", "start_jitter", "wall_margin"):
            if getattr(self, name) < 0:
                raise ValueError(f"DrillConfig.{name} must be >= 0, got {getattr(self, name)!r}")
        if self.ball_offset + 0.05 >= self.control_radius:
            raise ValueError(
                "DrillConfig.ball_offset must be smaller than control_radius - 0.05 "
                f"(the holder must keep control), got {self.ball_offset} >= "
                f"{self.control_radius - 0.05}"
            )
        for name in ("attacker_starts", "defender_starts"):
            points = getattr(self, name)
            if len(points) != 2 or any(
                len(p) != 2 or not all(0.0 <= c <= self.field_size for c in p) for p in points
            ):
                raise ValueError(
                    f"DrillConfig.{name} must be two (x, y) points inside "
                    f"[0, {self.field_size}]^2, got {points!r}"
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
        values = dict(values)
        for name in ("attacker_starts", "defender_starts"):
            if name in values:
                values[name] = tuple(tuple(float(c) for c in p) for p in values[name])
        return cls(**values)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict of every field."""
        return asdict(self)

    def success_reward(self, x: float) -> float:
        """Attackers' reward for crossing the goal line at abscissa ``x``."""
        half = self.field_size / 2
        off_centre = min(abs(x - half) / half, 1.0)
        return self.reward_success_centre + (
            self.reward_success_edge - self.reward_success_centre
        ) * off_centre
