"""A parametric family of defending teams, of which the paper's four teams are members.

Every team in this package is a :class:`ParametricTeam` with particular settings
(see :mod:`opponents.paper`). :func:`sample_opponents` draws distinct, seeded
settings, so a lifelong stream can meet as many different teams as it likes::

    from opponents import sample_opponents
    import soccer_drill

    for params in sample_opponents(25, seed=0):
        env = soccer_drill.HolderEnv(opponent="parametric", opponent_params=params)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from soccer_drill.config import DrillConfig
from soccer_drill.constraints import (
    AnyOf,
    Bool,
    Constraint,
    Integer,
    ListOf,
    OneOf,
    Real,
    check,
    check_fields,
    is_real,
)
from soccer_drill.rules.compiled import compiled, hypot, warms
from soccer_drill.rules.motion import (
    CONTROL_RADIUS,
    GUARD_DEPTH,
    GUARD_LINE,
    INTERCEPT,
    MARK,
    MOVE_TO,
    SPACING,
    interception_point,
    mark_target,
    roll_table,
    rule_parameters,
)
from soccer_drill.skills import Command, Skill
from soccer_drill.state import DrillView

ROLES = ("interceptor", "guard")
"""What a defender does: go for the ball, or protect the goal line."""

COORDINATIONS = ("press", "cover", "screen")
"""How two interceptors share the work (ignored with fewer than two interceptors):

* ``press``: both go for the ball.
* ``cover``: the defender nearer the ball presses it; the other marks the free
  attacker, standing in the passing lane, and goes for the ball once it is loose
  (a pass) if ``chase_loose`` is true.
* ``screen``: the nearer presses; the other stands ``screen_distance`` metres
  goal-side of the ball, blocking the way to the line, and goes for loose balls
  if ``chase_loose`` is true.
"""

_SWITCH_MARGIN = 1.0  # metres: the presser changes only when the other is this much nearer
_EDGE = 2.0  # guards stay this far inside the touchlines
_MARK_FRACTION = 0.35  # soccer_drill's MARK skill stands this far from the attacker toward the ball
# The team's settings as one float64 array, the plan's (see _settings), by index.
(_GUARD_0, _GUARD_1, _COORDINATION, _SPEED_0, _SPEED_1, _DELAY, _MARK_AT, _CHASE_LOOSE,
 _SCREEN, _DEPTH, _TRACK, _GUARD_SPACING, _REACH, _PRESS, _SORTIE) = range(15)
_PRESS_MODE, _COVER, _SCREEN_MODE = range(3)  # COORDINATIONS' indices


_SPEED = Real(0.0, 1.0, low_open=True)
PARAMETERS: dict[str, Constraint] = {
    "roles": ListOf(OneOf(ROLES), min_len=2, max_len=2),
    "coordination": OneOf(COORDINATIONS),
    "speed": AnyOf((_SPEED, ListOf(_SPEED, 2, 2, kinds=(list, tuple, np.ndarray)))),
    "reaction_delay": Integer(0),
    "mark_fraction": Real(0.0, 1.0),
    "chase_loose": Bool(),
    "screen_distance": Real(0.0, 30.0),
    "guard_depth": Real(1e-3, 30.0),
    "guard_track": Real(0.0, 1.0),
    "guard_spacing": Real(0.0, 30.0),
    "guard_reach": Real(0.0, 50.0),
    "press_probability": Real(0.0, 1.0),
    "sortie_cycles": Integer(1),
}
"""What each parameter of :class:`ParametricTeam` allows (NumPy numbers too, never bools
for numbers)."""


class ParametricTeam:
    """Parametric defending team: interceptors and goal-line guards with tunable habits.

    Each defender has a role. An *interceptor* goes for the ball (how two
    interceptors share the work is ``coordination``, see :data:`COORDINATIONS`).
    A *guard* protects the goal line: it stands ``guard_depth`` metres up from the
    line, between its home spot and the ball's abscissa, and leaves the line for
    the ball only on a *sortie*. A sortie starts with probability
    ``press_probability`` **per cycle** (drawn independently for each guard on the
    line, from the generator handed to :meth:`reset`), or whenever the ball comes
    within ``guard_reach`` metres of the guard; it lasts ``sortie_cycles`` cycles,
    then the guard returns to the line. With ``press_probability = p`` a guard
    leaves its line at least once in an episode of ``n`` cycles with probability
    ``1 - (1 - p) ** n``.

    Parameters
    ----------
    roles
        The two defenders' roles, each ``"interceptor"`` or ``"guard"``.
    coordination
        ``"press"``, ``"cover"`` or ``"screen"`` (two interceptors only).
    speed
        Fraction of the defenders' top speed, one number or one per defender, in (0, 1].
    reaction_delay
        The team acts on the state this many cycles old (>= 0); with a
        delay, every command is a ``MOVE_TO`` to where the skill would have gone.
    mark_fraction
        A marker stands this fraction of the way from the free attacker
        to the ball (``cover``), in [0, 1]; 0.35 is the MARK skill's own spot.
    chase_loose
        In ``cover`` and ``screen``, the second defender goes for a loose ball.
    screen_distance
        Metres goal-side of the ball at which the screening defender stands.
    guard_depth
        Metres up from the goal line at which guards stand (> 0).
    guard_track
        How far guards follow the ball sideways, in [0, 1]: 0 keeps them at
        their home spots (one guard: the centre; two: at 1/3 and 2/3 of the width),
        1 keeps them level with the ball (two guards then stand ``guard_spacing`` apart).
    guard_spacing
        Lateral gap between two guards that follow the ball, metres.
    guard_reach
        A guard sorties when the ball is within this distance of it, metres
        (0 disables it).
    press_probability
        Per-cycle probability that a guard on its line starts a sortie.
    sortie_cycles
        Length of a sortie, cycles (>= 1).
    """

    def __init__(
        self,
        roles: Sequence[str] = ("interceptor", "interceptor"),
        coordination: str = "press",
        speed: float | Sequence[float] = 1.0,
        reaction_delay: int = 0,
        mark_fraction: float = _MARK_FRACTION,
        chase_loose: bool = True,
        screen_distance: float = 4.0,
        guard_depth: float = GUARD_DEPTH,
        guard_track: float = 1.0,
        guard_spacing: float = 6.0,
        guard_reach: float = 0.0,
        press_probability: float = 0.0,
        sortie_cycles: int = 10,
    ) -> None:
        check_fields("", locals(), PARAMETERS, get=dict.get)  # the parameters, by name
        speeds = (speed, speed) if is_real(speed) else tuple(speed)  # type: ignore[arg-type]
        roles = tuple(roles)
        self.roles: tuple[str, str] = roles  # type: ignore[assignment]
        self.coordination = coordination
        self.speeds = (float(speeds[0]), float(speeds[1]))
        self.reaction_delay = int(reaction_delay)
        self.mark_fraction = float(mark_fraction)
        self.chase_loose = bool(chase_loose)
        self.screen_distance = float(screen_distance)
        self.guard_depth = float(guard_depth)
        self.guard_track = float(guard_track)
        self.guard_spacing = float(guard_spacing)
        self.guard_reach = float(guard_reach)
        self.press_probability = float(press_probability)
        self.sortie_cycles = int(sortie_cycles)
        self._players: tuple[str, ...] = ()
        self._settings = self._settings_array()
        self._one: ParametricBatch | None = None  # this team in its one drill
        self._holder = np.zeros(1, dtype=np.int64)  # its holder, as the plan reads it
        self._rng: _OneDrill | None = None

    def params(self) -> dict[str, Any]:
        """The keyword parameters that rebuild this team (JSON-ready)."""
        return {
            "roles": list(self.roles),
            "coordination": self.coordination,
            "speed": list(self.speeds),
            "reaction_delay": self.reaction_delay,
            "mark_fraction": self.mark_fraction,
            "chase_loose": self.chase_loose,
            "screen_distance": self.screen_distance,
            "guard_depth": self.guard_depth,
            "guard_track": self.guard_track,
            "guard_spacing": self.guard_spacing,
            "guard_reach": self.guard_reach,
            "press_probability": self.press_probability,
            "sortie_cycles": self.sortie_cycles,
        }

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.params().items())
        return f"{type(self).__name__}({args})"

    def _settings_array(self) -> np.ndarray:
        """The settings as :func:`plan_into` reads them."""
        settings = np.array([
            self.roles[0] == "guard", self.roles[1] == "guard",
            COORDINATIONS.index(self.coordination), *self.speeds, self.reaction_delay,
            self.mark_fraction, self.chase_loose, self.screen_distance, self.guard_depth,
            self.guard_track, self.guard_spacing, self.guard_reach, self.press_probability,
            self.sortie_cycles,
        ], dtype=np.float64)
        settings.flags.writeable = False
        return settings

    def _drawing(self) -> tuple[int, ...]:
        """The defenders who may draw a uniform for a random sortie (guards, when sorties
        can start at random), in defender order: each draws in a cycle it starts on its
        line, as the plan reads them."""
        if self.press_probability <= 0:
            return ()
        return tuple(k for k in (0, 1) if self.roles[k] == "guard")

    @property
    def sorties(self) -> int:
        """Sorties started this episode (for tests and statistics)."""
        return 0 if self._one is None else int(self._one.sorties[0])

    # ------------------------------------------------------------------ protocol
    def reset(self, view: DrillView, rng: np.random.Generator) -> None:
        """Start an episode: sorties and the delay buffer are reset; ``rng`` feeds the sorties."""
        if self._one is None:
            self._one = ParametricBatch(self, 1)
        self._one.reset(view, _FIRST, None)
        self._players = tuple(view.players)
        self._rng = _OneDrill(rng)
        fixed = self._one.fixed  # a plan that never reads the state: its commands made once
        self._fixed = None if fixed is None else self._commands(fixed[0][0], fixed[1][0])

    def act(self, view: DrillView) -> dict[str, Command]:
        """One command per defender, from the (possibly delayed) state: the batched plan
        (:class:`ParametricBatch`) in this team's one drill."""
        if self._rng is None or self._one is None:
            raise RuntimeError("reset() first")
        if self._fixed is not None:
            return self._fixed
        state = view.state
        holder = self._holder
        holder[0] = state.holder
        skill, target = self._one.plan(_FIRST, np.array((state.pos,)), np.array((state.vel,)),
                                       holder, self._rng)
        return self._commands(skill[0], target[0])

    def _commands(self, skill: np.ndarray, target: np.ndarray) -> dict[str, Command]:
        targets = target.tolist()
        return {
            player: Command(Skill(s), tuple(targets[k]) if s == MOVE_TO else None, self.speeds[k])
            for k, (player, s) in enumerate(zip(self._players, skill.tolist(), strict=True))
        }

    def batch(self, n: int) -> ParametricBatch:
        """This team's behaviour for ``n`` drills at once (see :class:`ParametricBatch`)."""
        return ParametricBatch(self, n)


_FIRST = np.zeros(1, dtype=np.int64)  # the single team's drill (the plan reads it only)


class _OneDrill:
    """The single team's generator, drawn from as the batched plan draws from each drill's
    (``random(drills)``: one uniform per drill, the next ``Generator.random()``)."""

    def __init__(self, rng: np.random.Generator) -> None:
        self.rng = rng

    def random(self, drills: np.ndarray) -> np.ndarray:
        return self.rng.random(len(drills))


def _drill_numbers(cfg: DrillConfig) -> tuple[float, float, float, np.ndarray, float]:
    """What :func:`plan_into` reads of the drill's configuration, after the settings."""
    params = rule_parameters(cfg)
    return (cfg.field_size, cfg.defender_speed, float(params[CONTROL_RADIUS]), roll_table(cfg),
            float(params[SPACING]))


@compiled
def plan_into(skill, target, sortie_left, presser, draws, pos, vel, holder, settings, size,
              defender_speed, reach, table, spacing):
    """The two defenders' commands in one drill, written into ``skill`` and ``target``
    (a ``MOVE_TO``'s target; other skills' own targets are the drill's).

    Guards on their line start a sortie if the ball comes within reach, or if their
    uniform in ``draws`` falls below ``press_probability`` (read only for the guards
    :meth:`ParametricTeam._drawing` names); a guard on a sortie intercepts, else stands at
    its spot on the line. Two interceptors share the work by ``coordination``: the
    presser (kept until the other is ``_SWITCH_MARGIN`` nearer the ball) intercepts; the
    other marks or screens, or chases a loose ball. With a reaction delay every command
    becomes a ``MOVE_TO`` to where its skill would go in the state seen.
    ``sortie_left`` is updated in place; returns the presser and the sorties started.
    """
    bx, by = pos[4, 0], pos[4, 1]
    guards = int(settings[_GUARD_0] + settings[_GUARD_1])
    skill[0] = skill[1] = INTERCEPT
    started, n = 0, 0
    for k in range(2):
        if settings[_GUARD_0 + k] == 0.0:
            continue
        if sortie_left[k] == 0:
            gx, gy = pos[2 + k, 0], pos[2 + k, 1]
            reach_k = settings[_REACH]
            close = reach_k > 0 and hypot(bx - gx, by - gy) <= reach_k
            drawn = settings[_PRESS] > 0 and draws[k] < settings[_PRESS]
            if drawn or close:
                sortie_left[k] = int(settings[_SORTIE])
                started += 1
        if sortie_left[k] > 0:
            sortie_left[k] -= 1
        else:
            _guard_spot_into(skill, target, k, n, guards, bx, size, settings)
        n += 1
    if guards == 0 and settings[_COORDINATION] != _PRESS_MODE:
        d0 = hypot(pos[2, 0] - bx, pos[2, 1] - by)
        d1 = hypot(pos[3, 0] - bx, pos[3, 1] - by)
        if presser < 0 or (d0 if presser == 1 else d1) + _SWITCH_MARGIN < (
            d1 if presser == 1 else d0
        ):
            presser = 0 if d0 <= d1 else 1
        other = 1 - presser
        if not (holder < 0 and settings[_CHASE_LOOSE] != 0.0):
            if settings[_COORDINATION] == _COVER:
                fraction = settings[_MARK_AT]
                if fraction == _MARK_FRACTION:
                    skill[other] = MARK
                else:
                    skill[other] = MOVE_TO
                    target[other, 0], target[other, 1] = mark_target(pos, holder, 2 + other,
                                                                     fraction)
            else:  # screen: goal-side of the ball, min(max(...)) as the builtins compare
                ty = by - settings[_SCREEN]
                x = 1.0 if 1.0 > bx else bx
                skill[other] = MOVE_TO
                target[other, 0] = size - 1.0 if size - 1.0 < x else x
                target[other, 1] = 1.0 if 1.0 > ty else ty
    if settings[_DELAY] > 0:
        # React to the old state: go where the skill would have gone back then.
        for k in range(2):
            if skill[k] == INTERCEPT:
                target[k, 0], target[k, 1] = interception_point(
                    pos, vel, holder, 2 + k, defender_speed * settings[_SPEED_0 + k], reach,
                    table, spacing)
            elif skill[k] == MARK:
                target[k, 0], target[k, 1] = mark_target(pos, holder, 2 + k, _MARK_FRACTION)
            elif skill[k] == GUARD_LINE:
                x = 4.0 if 4.0 > bx else bx
                target[k, 0], target[k, 1] = (size - 4.0 if size - 4.0 < x else x), GUARD_DEPTH
            skill[k] = MOVE_TO
    return presser, started


@compiled
def _guard_spot_into(skill, target, k, n, guards, bx, size, settings):
    """Guard ``k``, the ``n``-th of ``guards``, on its line: level with the ball as far as
    ``guard_track`` says, from its home spot."""
    track, depth = settings[_TRACK], settings[_DEPTH]
    if guards == 1:
        if track == 1.0 and depth == GUARD_DEPTH:
            skill[k] = GUARD_LINE  # exactly the skill's own spot
            return
        home, offset = size / 2, 0.0
    else:
        home = size * (n + 1) / 3
        offset = (n - 0.5) * settings[_GUARD_SPACING]
    x = home + track * (bx + offset - home)
    x = _EDGE if _EDGE > x else x  # min(max(x, _EDGE), size - _EDGE), as the builtins compare
    skill[k] = MOVE_TO
    target[k, 0] = size - _EDGE if size - _EDGE < x else x
    target[k, 1] = depth


# ---------------------------------------------------------------------- sampler
def sample_opponents(n: int, seed: int) -> list[dict[str, Any]]:
    """``n`` distinct, reproducible parameter sets of :class:`ParametricTeam`.

    Each dict is the ``opponent_params`` of the ``parametric`` team, e.g.
    ``HolderEnv(opponent="parametric", opponent_params=params)``. The draws cover
    every composition (two interceptors, interceptor and guard, two guards) and
    every coordination, with speeds 0.85-1.0 of the top speed, reaction delays of
    0-2 cycles (none in half the draws), guard depths 1.5-4 m, guard reaches
    1.5-3.5 m and sortie probabilities 0-0.05 per cycle. These ranges keep the
    sampled teams about as hard as the paper's (the fixed rules of
    :mod:`soccer_drill.policies` succeed in roughly 40-95 % of episodes against
    them, random play in about 1 %) while the best rule changes from team to team.
    The same ``(n, seed)`` always gives the same list; no two entries are equal.
    """
    check("n", n, Integer(0))
    rng = np.random.default_rng(seed)
    out: list[dict[str, Any]] = []
    seen: set[str] = set()
    compositions = (
        ("interceptor", "interceptor"), ("interceptor", "guard"), ("guard", "guard"),
    )
    while len(out) < n:
        roles = compositions[int(rng.integers(len(compositions)))]
        params: dict[str, Any] = {
            "roles": list(roles),
            "coordination": COORDINATIONS[int(rng.integers(len(COORDINATIONS)))]
            if roles == ("interceptor", "interceptor") else "press",
            "speed": [round(float(v), 2) for v in rng.uniform(0.85, 1.0, size=2)],
            "reaction_delay": int(rng.choice([0, 0, 1, 2])),
        }
        if roles == ("interceptor", "interceptor"):
            params["mark_fraction"] = round(float(rng.uniform(0.2, 0.6)), 2)
            params["chase_loose"] = bool(rng.random() < 0.7)
            params["screen_distance"] = round(float(rng.uniform(2.5, 6.0)), 1)
        else:
            params["guard_depth"] = round(float(rng.uniform(1.5, 4.0)), 1)
            params["guard_track"] = round(float(rng.uniform(0.6, 1.0)), 2)
            params["guard_spacing"] = round(float(rng.uniform(3.0, 9.0)), 1)
            params["guard_reach"] = round(float(rng.uniform(1.5, 3.5)), 1)
            params["press_probability"] = round(float(rng.uniform(0.0, 0.05)), 3)
            params["sortie_cycles"] = int(rng.integers(5, 16))
        key = repr(sorted(params.items()))
        if key not in seen:
            seen.add(key)
            out.append(params)
    return out


def spec_label(params: Mapping[str, Any]) -> str:
    """A short human-readable label of a parameter set (for tables and plots)."""
    roles = params.get("roles", ("interceptor", "interceptor"))
    short = "".join("I" if r == "interceptor" else "G" for r in roles)
    label = short
    if tuple(roles) == ("interceptor", "interceptor"):
        label += f"-{params.get('coordination', 'press')}"
    delay = params.get("reaction_delay", 0)
    if delay:
        label += f"-d{delay}"
    return label


# ---------------------------------------------------------------------- batched
class ParametricBatch:
    """:class:`ParametricTeam`'s behaviour for ``n`` drills at once (``team.batch(n)``), and
    the single team's in its one drill.

    Each drill has its own sorties, presser and reaction-delay buffer, and its sortie
    draws come from its own generator in the order the single team makes them; the plan
    (:func:`plan_into`) runs drill by drill in one compiled loop.

    The delay's buffer holds at most ``max_cycles + 1`` states per drill: an episode
    acts at most ``max_cycles`` times, so a longer delay sees the episode's first state
    throughout and would only cost memory. Two interceptors pressing without delay read
    no state: their plan (:attr:`fixed`) is made once.
    """

    def __init__(self, team: ParametricTeam, n: int) -> None:
        self.team, self.n = team, n
        self._depth = 0  # the buffer's, set at the first reset (which knows max_cycles)
        self._pos = np.zeros((n, 0, 5, 2))
        self._vel = np.zeros((n, 0, 5, 2))
        self._holder = np.zeros((n, 0), dtype=np.int64)
        self._count = np.zeros(n, dtype=np.int64)
        self._sortie_left = np.zeros((n, 2), dtype=np.int64)
        self._presser = np.full(n, -1, dtype=np.int64)
        self.sorties = np.zeros(n, dtype=np.int64)
        """Sorties started in each drill's episode."""
        self._speeds = np.array([team.speeds])
        self._rng: Any = None
        self._drawing = team._drawing()
        self.fixed: tuple[np.ndarray, np.ndarray] | None = None
        """``(skill, target)`` of one drill when the plan never reads the state, else ``None``."""
        if (team.roles == ("interceptor", "interceptor") and team.coordination == "press"
                and team.reaction_delay == 0):
            self.fixed = (np.full((1, 2), INTERCEPT, dtype=np.int64), np.zeros((1, 2, 2)))

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        if "_numbers" in state:  # a copy's arrays are writable: read-only, as compiled
            self._settings = self._settings.copy()
            self._settings.flags.writeable = False
            self._numbers = _drill_numbers(self._config)
            self._prebuild()

    def reset(self, view: Any, drills: np.ndarray, rng: Any) -> None:
        """Start an episode in ``drills``; ``rng`` (a ``BatchRandom``) feeds the sorties."""
        if len(view.players) != 2:
            raise ValueError(f"this team drives two defenders, got players {view.players!r}")
        depth = min(self.team.reaction_delay, view.config.max_cycles) + 1
        if depth != self._depth:
            self._depth = depth
            self._pos = np.zeros((self.n, depth, 5, 2))
            self._vel = np.zeros((self.n, depth, 5, 2))
            self._holder = np.zeros((self.n, depth), dtype=np.int64)
        self._rng = rng
        self._config = view.config
        self._numbers = _drill_numbers(view.config)
        # Read-only, as compiled before any team's call (a copy of the team's is writable).
        self._settings = self.team._settings_array()
        self._prebuild()
        self._count[drills] = 0
        self._sortie_left[drills] = 0
        self._presser[drills] = -1
        self.sorties[drills] = 0

    def _prebuild(self) -> None:
        """What the plan's loop reads after a cycle's rows, in one tuple."""
        self._rest = (self._sortie_left, self._presser, self.sorties, self._pos, self._vel,
                      self._holder, self._count, self._settings, *self._numbers)

    def act(self, view: Any, drills: np.ndarray) -> Any:
        """The two defenders' commands in each of ``drills`` (:meth:`plan`)."""
        from soccer_drill.teams.batch import BatchCommands, every_drill

        m = len(drills)
        if self.fixed is not None:
            skill, target = (np.repeat(a, m, axis=0) for a in self.fixed)
        else:  # the view's fresh copies, the team's own: writable, as the plan is compiled
            pos, vel, holder = view.pos, view.vel, view.holder
            if every_drill(drills, view.n):
                for array in (pos, vel, holder):
                    array.flags.writeable = True
            else:
                pos, vel, holder = pos[drills], vel[drills], holder[drills]
            skill, target = self.plan(np.array(drills, dtype=np.int64), pos, vel, holder,
                                      self._rng)
        return BatchCommands(skill, target, np.repeat(self._speeds, m, axis=0))

    def plan(self, drills: np.ndarray, pos: np.ndarray, vel: np.ndarray, holder: np.ndarray,
             rng: Any) -> tuple[np.ndarray, np.ndarray]:
        """The plan (:func:`plan_into`) of each of ``drills`` from its current state (rows
        of ``pos``, ``vel``, ``holder``; ``drills`` too: writable int64 and float64 arrays,
        as compiled), on the state it
        sees ``reaction_delay`` cycles old; ``rng.random(drills)`` gives each drill's next
        uniform. Returns ``(skill, target)``."""
        m = len(drills)
        draws = np.zeros((m, 2))
        if self._drawing and m == 1:  # the single team's: no arrays of drills to index
            left = self._sortie_left[drills[0]]
            for k in self._drawing:
                if left[k] == 0:
                    draws[0, k] = rng.random(drills)[0]
        elif self._drawing:
            left = self._sortie_left[drills]
            for k in self._drawing:  # each drill's guard k on its line, in turn
                on_line = left[:, k] == 0
                if np.count_nonzero(on_line):
                    draws[on_line, k] = rng.random(drills[on_line])
        skill = np.empty((m, 2), dtype=np.int64)
        target = np.zeros((m, 2, 2))
        _plans_of_drills(skill, target, drills, draws, pos, vel, holder, *self._rest)
        return skill, target


@compiled
def _plans_of_drills(skill, target, drills, draws, pos, vel, holder, sortie_left, presser, sorties,
                     hist_pos, hist_vel, hist_holder, count, settings, size, defender_speed,
                     reach, table, spacing):
    """:func:`plan_into` of drill ``drills[r]`` for each row ``r``, on the state it sees:
    the current one is kept in the drill's ring of the last ``depth`` states, and the
    oldest there (``reaction_delay`` cycles old, or the episode's first) is planned on."""
    depth = hist_pos.shape[1]
    for r in range(drills.shape[0]):
        i = drills[r]
        if depth == 1:
            seen_pos, seen_vel, seen_holder = pos[r], vel[r], holder[r]
        else:
            count[i] += 1
            slot = (count[i] - 1) % depth
            hist_pos[i, slot] = pos[r]
            hist_vel[i, slot] = vel[r]
            hist_holder[i, slot] = holder[r]
            oldest = 0 if count[i] <= depth else count[i] % depth
            seen_pos, seen_vel = hist_pos[i, oldest], hist_vel[i, oldest]
            seen_holder = hist_holder[i, oldest]
        presser[i], started = plan_into(skill[r], target[r], sortie_left[i], presser[i],
                                        draws[r], seen_pos, seen_vel, seen_holder, settings,
                                        size, defender_speed, reach, table, spacing)
        sorties[i] += started


@warms
def _compile_plans() -> None:
    """:func:`plan_into` and its batched loop, called once with their callers' types
    (compiled before a team's time-bounded call reaches them)."""
    cfg = DrillConfig()
    numbers = _drill_numbers(cfg)
    settings = ParametricTeam(roles=("interceptor", "guard"), press_probability=0.5)._settings
    pos = np.array([*cfg.attacker_starts, *cfg.defender_starts, (10.0, 10.0)])
    plan_into(np.zeros(2, dtype=np.int64), np.zeros((2, 2)), np.zeros(2, dtype=np.int64), -1,
              np.zeros(2), pos, np.zeros((5, 2)), -1, settings, *numbers)
    for depth in (1, 2):
        _plans_of_drills(np.zeros((1, 2), dtype=np.int64), np.zeros((1, 2, 2)),
                         np.zeros(1, dtype=np.int64), np.zeros((1, 2)), pos[None],
                         np.zeros((1, 5, 2)), np.full(1, -1, dtype=np.int64),
                         np.zeros((1, 2), dtype=np.int64), np.full(1, -1, dtype=np.int64),
                         np.zeros(1, dtype=np.int64), np.zeros((1, depth, 5, 2)),
                         np.zeros((1, depth, 5, 2)), np.zeros((1, depth), dtype=np.int64),
                         np.zeros(1, dtype=np.int64), settings, *numbers)
