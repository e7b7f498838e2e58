"""Immutable snapshots of the drill, and the read-only view handed to scripted teams."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

if TYPE_CHECKING:
    from soccer_drill.config import DrillConfig

PLAYER_NAMES: tuple[str, str, str, str] = ("attacker_0", "attacker_1", "defender_0", "defender_1")
"""Player names in index order in the paper's 2v2 drill; index 4 is the ball in
:attr:`DrillState.pos` (``DrillConfig.player_names`` for any size: the ball is last)."""
ATTACKERS: tuple[int, int] = (0, 1)
DEFENDERS: tuple[int, int] = (2, 3)
BALL = 4


class DrillState(NamedTuple):
    """One cycle's snapshot: immutable, so it can be shared without copying.

    Assigning to a field (or adding one) raises ``AttributeError``, and ``pos`` and
    ``vel`` are tuples of tuples. (A named tuple rather than a frozen dataclass: one
    is built every cycle, and a frozen dataclass, whose ``__init__`` sets each field
    through ``object.__setattr__``, takes about three times as long to build.)

    Attributes
    ----------
    pos
        ``(x, y)`` of the players (attackers, then defenders) then the ball, metres.
    vel
        Their velocities, m/s.
    holder
        Index of the player in possession, or -1 for a loose ball.
    cycle
        Cycles elapsed since reset.
    passer
        Index of the last player who passed, or -1.
    lockout_until
        The passer cannot regain the ball before this cycle.
    """

    pos: tuple[tuple[float, float], ...]
    vel: tuple[tuple[float, float], ...]
    holder: int
    cycle: int
    passer: int = -1
    lockout_until: int = 0

    @staticmethod
    def opponents_of(player: int) -> tuple[int, int]:
        """Indices of ``player``'s two opponents (in the 2v2 drill)."""
        return DEFENDERS if player < 2 else ATTACKERS

    @staticmethod
    def teammate_of(player: int) -> int:
        """Index of ``player``'s teammate (in the 2v2 drill)."""
        return player ^ 1

    def free_opponent_of(self, player: int) -> int:
        """The opponent without the ball (or, for a loose ball, the one farther from it),
        in the 2v2 drill."""
        a, b = self.opponents_of(player)
        if self.holder == a:
            return b
        if self.holder == b:
            return a
        bx, by = self.pos[BALL]
        da = math.hypot(self.pos[a][0] - bx, self.pos[a][1] - by)
        db = math.hypot(self.pos[b][0] - bx, self.pos[b][1] - by)
        return a if da > db else b

    def distance(self, i: int, j: int) -> float:
        """Distance between bodies ``i`` and ``j`` (the last, ``len(pos) - 1``, is the
        ball), metres."""
        return math.hypot(self.pos[i][0] - self.pos[j][0], self.pos[i][1] - self.pos[j][1])


def _frozen(values: object) -> np.ndarray:
    array = np.array(values, dtype=np.float64)
    array.flags.writeable = False
    return array


class ReadOnlyView:
    """What a team is handed: a window on ``source`` (a drill, or a batch of drills) and
    the names of the players the team drives, whose own attributes cannot be set or
    deleted (:class:`DrillView` for one drill, ``soccer_drill.teams.batch.BatchView`` for
    a batch)."""

    __slots__ = ("_players", "_source")

    def __init__(self, source: object, players: tuple[str, ...]) -> None:
        object.__setattr__(self, "_source", source)
        object.__setattr__(self, "_players", tuple(players))

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError(f"{type(self).__name__} is read-only: cannot set {name!r}")

    def __delattr__(self, name: str) -> None:
        raise AttributeError(f"{type(self).__name__} is read-only: cannot delete {name!r}")

    def __reduce__(self) -> tuple[type, tuple[object, tuple[str, ...]]]:
        return type(self), (self._source, self._players)

    @property
    def players(self) -> tuple[str, ...]:
        """Names of the players the team drives."""
        return self._players

    @property
    def config(self) -> DrillConfig:
        """The drill's configuration (every drill's, in a batch)."""
        return self._source.config  # type: ignore[attr-defined]


class DrillView(ReadOnlyView):
    """A live, read-only window on the drill, handed to scripted teams.

    ``view.state`` is always the current (immutable) :class:`DrillState`; the array
    properties are fresh read-only copies; and the view's own attributes cannot be
    set. So a team cannot change the drill by writing to what it is given. (It runs
    in the same process, so this guards against mistakes, not against a team that
    sets out to reach the drill's internals.)
    """

    __slots__ = ()

    @property
    def state(self) -> DrillState:
        """The current snapshot."""
        return self._source.state  # type: ignore[attr-defined]

    @property
    def cycle(self) -> int:
        """Cycles elapsed since reset."""
        return self.state.cycle

    @property
    def positions(self) -> np.ndarray:
        """``(players, 2)`` player positions in ``config.player_names`` order, metres
        (read-only)."""
        return _frozen(self.state.pos[:-1])

    @property
    def velocities(self) -> np.ndarray:
        """``(players, 2)`` player velocities, m/s (read-only)."""
        return _frozen(self.state.vel[:-1])

    @property
    def ball_position(self) -> np.ndarray:
        """``(2,)`` ball position, metres (read-only)."""
        return _frozen(self.state.pos[-1])

    @property
    def ball_velocity(self) -> np.ndarray:
        """``(2,)`` ball velocity, m/s (read-only)."""
        return _frozen(self.state.vel[-1])

    @property
    def holder(self) -> str | None:
        """Name of the player in possession, or ``None`` for a loose ball."""
        h = self.state.holder
        return self.config.player_names[h] if h >= 0 else None
