"""The named structures the compiled rules read: the drills' arrays and the rule parameters.

Each is a NumPy record type, one record per drill (or one for the parameters), so that the
rules read every value by name (``state.holder``, ``params.control_radius``) and a
compiled call takes a few structures rather than twenty arrays and numbers by position
(every argument handed to compiled code costs its dispatch, about as much as the rules of
a simple skill):

| record | one per | holds | written by |
|---|---|---|---|
| :data:`STATE` | drill | positions and velocities (the players, then the ball), who holds the ball, the cycle, the last passer and their lock-out, the outcome code | the drill's cycle |
| :data:`CYCLE` | drill | the players' commands (``skill``, ``target``, ``speed``, ``receiver``), then what a cycle works out on its way (the pass's two normals, the motions and velocities set before the physics, who may tackle, the kicker) | the environment, the support player and the team (the commands); the cycle (the rest) |
| :data:`PARAMETERS` | configuration | the numbers of a :class:`~soccer_drill.config.DrillConfig` the rules read, by name | :func:`rule_parameters` |

Python reads a field of every drill as an array view (``state["pos"]``: ``(n, 5, 2)`` in the 2v2 drill),
compiled code a drill's record (``state[i].pos``: ``(5, 2)``).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from soccer_drill.config import DrillConfig
from soccer_drill.interruptions import QuietIntEnum
from soccer_drill.tasks import TASKS


def state_record(players: int) -> np.dtype:
    """One drill's state with ``players`` players (:data:`STATE` for the paper's four)."""
    return np.dtype([
        ("pos", np.float64, (players + 1, 2)),
        ("vel", np.float64, (players + 1, 2)),
        ("holder", np.int64),
        ("cycle", np.int64),
        ("passer", np.int64),
        ("lockout_until", np.int64),
        ("outcome", np.int64),
        *_size_mark(players),
    ])


def _size_mark(players: int) -> list[tuple[str, type, tuple[int, ...]]]:
    """An empty field named for the number of players (none for the paper's four):
    numba's disk cache tells record types apart by their fields' names and types, not
    by their nested arrays' shapes, and would otherwise hand one size's compiled rules
    to another's records."""
    return [] if players == 4 else [(f"players_{players}", np.int8, (0,))]


def cycle_record(players: int) -> np.dtype:
    """One drill's cycle with ``players`` players (:data:`CYCLE` for the paper's four)."""
    return np.dtype([
        ("skill", np.int64, (players,)),
        ("target", np.float64, (players, 2)),
        ("speed", np.float64, (players,)),
        ("receiver", np.int64, (players,)),
        ("noise", np.float64, (2,)),
        ("motions", np.float64, (players, 5)),
        ("new_vel", np.float64, (players + 1, 2)),
        ("order", np.int64, (players,)),
        ("tacklers", np.int64),
        ("kicker", np.int64),
        ("passing", np.int64),
        *_size_mark(players),
    ])


STATE = state_record(4)
"""One drill's state: ``pos`` and ``vel`` of the players (``DrillConfig.player_names``
order: the attackers, then the defenders) then the ball (metres, m/s); ``holder`` the
player in possession (-1: a loose ball); ``cycle`` since the episode's start; ``passer``
the last player who passed (-1: none) and ``lockout_until`` the cycle before which it
cannot take the ball back; ``outcome`` an :class:`Outcome` code. This is the paper's
2v2 drill's; :func:`state_record` gives it for any number of players."""

CYCLE = cycle_record(4)
"""One drill's cycle: each player's command (a :class:`~soccer_drill.commands.Skill` value,
a ``MOVE_TO`` target, a fraction of the top speed, and for a ``PASS`` the teammate it
goes to, -1: the nearest), then the cycle's own working values: the two standard normals
of a pass, each player's motion (``vx, vy``, ball action, its vector), the velocities set
before the physics, the opponents who may tackle (nearest first) and their number, who
kicked the ball (-1: nobody), whether the holder passes. This is the paper's 2v2 drill's;
:func:`cycle_record` gives it for any number of players."""

PARAMETERS = np.dtype([
    ("field_size", np.float64),
    ("attacker_speed", np.float64),
    ("defender_speed", np.float64),
    ("dribble_speed", np.float64),
    ("hold_speed", np.float64),
    ("control_radius", np.float64),
    ("control_speed", np.float64),
    ("damping_rate", np.float64),
    ("arrival_speed", np.float64),
    ("ball_max_speed", np.float64),
    ("angle_noise", np.float64),
    ("speed_noise", np.float64),
    ("roll_spacing", np.float64),
    ("acceleration", np.float64),
    ("cycle_seconds", np.float64),
    ("ball_offset", np.float64),
    ("roll", np.float64),
    ("sub_dt", np.float64),
    ("substeps", np.int64),
    ("lockout_cycles", np.int64),
    ("max_cycles", np.int64),
    ("attackers", np.int64),
    ("goal_line", np.int64),
])
"""The numbers of a configuration the rules read: top speeds, the control radius and
speed, the ball's damping rate (per second) and top speed, the pass's arrival speed and
noise (radians, fraction), the spacing of the rolling ball's table (seconds), the players'
speed change per cycle, the cycle's length, where a held ball is kept, the ball's speed
kept per cycle, the sub-step's length, the sub-steps, a pass's lock-out and the episode's
length (cycles), the number of attackers (players ``0 .. attackers - 1``), and whether
``y = 0`` is a goal line (1, the drill) or an edge of the region like the others (0,
keepaway: :data:`~soccer_drill.tasks.TASKS`)."""


class Outcome(QuietIntEnum):
    """An episode's outcome code in :data:`STATE`: ``RUNNING`` while it runs."""

    RUNNING = 0
    SUCCESS = 1
    INTERCEPTION = 2
    OUT = 3
    TIMEOUT = 4


OUTCOME_NAMES: tuple[str | None, ...] = (None, "success", "interception", "out", "timeout")
"""Outcome names by code: ``OUTCOME_NAMES[state["outcome"][i]]`` (``None`` while running)."""
OUTCOMES: tuple[str, ...] = OUTCOME_NAMES[1:]
"""The four outcomes of an episode."""


def records(n: int, dtype: np.dtype) -> np.ndarray:
    """``n`` zeroed records of ``dtype``."""
    return np.zeros(n, dtype=dtype)


def immutable(array: np.ndarray) -> np.ndarray:
    """``array``'s values in an array that nothing can write to: its memory is a
    ``bytes`` object, so neither it nor its ``base`` can be made writeable again (a
    read-only flag alone can be set back by whoever holds the array that owns the
    memory). Shared arrays handed to team code are made so."""
    out = np.frombuffer(array.tobytes(), dtype=array.dtype).reshape(array.shape)
    assert not out.flags.writeable
    return out


@functools.lru_cache(maxsize=64)
def rule_parameters(cfg: DrillConfig) -> np.ndarray:
    """The numbers of ``cfg`` the rules read: one :data:`PARAMETERS` record, read-only
    (``rule_parameters(cfg)[0]["control_radius"]``; compiled code takes the array)."""
    times, _, _, spacing = roll_tuples(cfg.ball_damping, cfg.cycle_seconds)
    params = np.zeros(1, dtype=PARAMETERS)
    values = {
        "field_size": cfg.field_size,
        "attacker_speed": cfg.attacker_speed,
        "defender_speed": cfg.defender_speed,
        "dribble_speed": cfg.dribble_speed,
        "hold_speed": cfg.hold_speed,
        "control_radius": cfg.control_radius,
        "control_speed": cfg.control_speed,
        "damping_rate": -math.log(max(cfg.ball_damping, 1e-6)),
        "arrival_speed": cfg.pass_arrival_speed,
        "ball_max_speed": cfg.ball_max_speed,
        "angle_noise": math.radians(cfg.kick_angle_noise),
        "speed_noise": cfg.kick_speed_noise,
        "roll_spacing": spacing,
        "acceleration": cfg.player_acceleration * cfg.cycle_seconds,
        "cycle_seconds": cfg.cycle_seconds,
        "ball_offset": cfg.ball_offset,
        "roll": cfg.ball_damping**cfg.cycle_seconds,
        "sub_dt": cfg.cycle_seconds / cfg.substeps,
        "substeps": cfg.substeps,
        "lockout_cycles": cfg.pass_lockout_cycles,
        "max_cycles": cfg.max_cycles,
        "attackers": cfg.attackers,
        "goal_line": int(TASKS[cfg.task].goal_line),
    }
    for name, value in values.items():
        params[0][name] = value
    return immutable(params)  # one array per configuration, shared by every drill


@functools.lru_cache(maxsize=64)
def roll_table(cfg: DrillConfig) -> np.ndarray:
    """The rolling ball every 2 cycles for 3 s (``(3, K)`` float64, read-only): the
    times; per unit of initial speed, the distance travelled by then; and the speed
    there times the time to the next point."""
    times, travels, slowing, _ = roll_tuples(cfg.ball_damping, cfg.cycle_seconds)
    return immutable(np.array([times, travels, slowing]))


def roll_tuples(
    damping: float, cycle: float
) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...], float]:
    """The rolling ball's table as tuples (times, travels, slowing) and its spacing."""
    k = -math.log(max(damping, 1e-6))
    times = tuple(step * cycle for step in range(1, round(3.0 / cycle) + 1, 2))
    travels = tuple((1.0 - math.exp(-k * t)) / k if k > 0 else t for t in times)
    spacing = 2 * cycle
    slowing = tuple(math.exp(-k * t) * spacing for t in times)
    return times, travels, slowing, spacing
