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

from soccer_drill import DrillConfig, Skill
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
from soccer_drill.teams import (
    GUARD_DEPTH,
    STATE,
    BatchCommands,
    BatchRandom,
    BatchView,
    compiled,
    every_drill,
    hypot,
    interception_point,
    mark_target,
    roll_table,
    rule_parameters,
    state_record,
    warms,
)

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
_PRESS_MODE, _COVER = COORDINATIONS.index("press"), COORDINATIONS.index("cover")

MOST = 4
"""The most defenders a team plays (``DrillConfig.defenders`` allows 1 to 4)."""
SETTINGS = np.dtype([
    ("guard", np.int8, (MOST,)),
    ("coordination", np.int64),
    ("speed", np.float64, (MOST,)),
    ("reaction_delay", np.int64),
    ("mark_fraction", np.float64),
    ("chase_loose", np.bool_),
    ("screen_distance", np.float64),
    ("guard_depth", np.float64),
    ("guard_track", np.float64),
    ("guard_spacing", np.float64),
    ("guard_reach", np.float64),
    ("press_probability", np.float64),
    ("sortie_cycles", np.int64),
])
"""A team's settings as its compiled plan reads them, by name (``coordination``: an index of
:data:`COORDINATIONS`; ``guard[k]``: defender ``k`` is a guard; the roles and speeds
cycled to :data:`MOST` defenders, of which a drill's plan reads its own number)."""
MEMORY = np.dtype([
    ("sortie_left", np.int64, (MOST,)),
    ("presser", np.int64),
    ("sorties", np.int64),
    ("count", np.int64),
    ("draws", np.float64, (MOST,)),
])
"""What a team remembers of one drill's episode: each guard's sortie cycles left, the
presser (-1: none yet), the sorties started, the states seen (for the delay), and this
cycle's two uniforms (the guards' on their line)."""


def plans_record(defenders: int) -> np.dtype:
    """The plan of one drill: its defenders' skills and ``MOVE_TO`` targets."""
    return np.dtype([("skill", np.int64, (defenders,)),
                     ("target", np.float64, (defenders, 2))])


PLANS = plans_record(2)
"""The plan of one drill of the 2v2 drill: its two defenders' skills and targets."""


_SPEED = Real(0.0, 1.0, low_open=True)
PARAMETERS: dict[str, Constraint] = {
    "roles": ListOf(OneOf(ROLES), min_len=1, max_len=MOST),
    "coordination": OneOf(COORDINATIONS),
    "speed": AnyOf((_SPEED, ListOf(_SPEED, 1, MOST, kinds=(list, tuple, np.ndarray)))),
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
    line, from the drill's generator of the team), or whenever the ball comes
    within ``guard_reach`` metres of the guard; it lasts ``sortie_cycles`` cycles,
    then the guard returns to the line. With ``press_probability = p`` a guard
    leaves its line at least once in an episode of ``n`` cycles with probability
    ``1 - (1 - p) ** n``.

    **Any number of defenders.** ``roles`` (and ``speed``, if a list) name the first
    defenders' and repeat in turn for the others (``("interceptor", "guard")`` with three
    defenders: interceptor, guard, interceptor; with one: the interceptor alone). Guards
    share the line: the ``n``-th of ``g`` has its home spot at ``(n + 1) / (g + 1)`` of
    the width and stands ``(n - (g - 1) / 2) * guard_spacing`` from the ball's abscissa
    when following it (one and two guards: as the paper's teams). With interceptors only
    and ``cover`` or ``screen``, the presser is the defender nearest the ball (changed
    when another is ``_SWITCH_MARGIN`` nearer) and every other defender covers or screens
    (a marker marks, of the attackers without the ball, the nearest to it).

    Parameters
    ----------
    roles
        The defenders' roles, each ``"interceptor"`` or ``"guard"`` (1 to 4, repeated in
        turn for more defenders).
    coordination
        ``"press"``, ``"cover"`` or ``"screen"`` (interceptors only).
    speed
        Fraction of the defenders' top speed, one number or a list (1 to 4, repeated in
        turn), in (0, 1].
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
        roles = tuple(roles)
        speeds = ((speed,) * len(roles) if is_real(speed)
                  else tuple(speed))  # type: ignore[arg-type]
        self.roles: tuple[str, ...] = roles
        self.coordination = coordination
        self.speeds = tuple(float(s) for s in speeds)
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
        self._batched: ParametricBatch | None = None

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

    def roles_of(self, defenders: int) -> tuple[str, ...]:
        """The roles of ``defenders`` defenders: :attr:`roles` repeated in turn."""
        return tuple(self.roles[k % len(self.roles)] for k in range(defenders))

    def speeds_of(self, defenders: int) -> tuple[float, ...]:
        """The speeds of ``defenders`` defenders: :attr:`speeds` repeated in turn."""
        return tuple(self.speeds[k % len(self.speeds)] for k in range(defenders))

    def settings(self) -> np.ndarray:
        """The settings as :func:`plan_into` reads them: one :data:`SETTINGS` record."""
        settings = np.zeros(1, dtype=SETTINGS)
        values = {
            "guard": [role == "guard" for role in self.roles_of(MOST)],
            "coordination": COORDINATIONS.index(self.coordination),
            "speed": self.speeds_of(MOST),
            **{name: getattr(self, name) for name in (
                "reaction_delay", "mark_fraction", "chase_loose", "screen_distance",
                "guard_depth", "guard_track", "guard_spacing", "guard_reach",
                "press_probability", "sortie_cycles")},
        }
        for name, value in values.items():
            settings[0][name] = value
        return settings

    def _drawing(self, defenders: int = 2) -> tuple[int, ...]:
        """The defenders who may draw a uniform for a random sortie (guards, when sorties
        can start at random), in defender order: each draws in a cycle it starts on its
        line, as the plan reads them."""
        if self.press_probability <= 0:
            return ()
        return tuple(k for k, role in enumerate(self.roles_of(defenders)) if role == "guard")

    @property
    def sorties(self) -> int:
        """Sorties started in the episode of the first drill of the last batch made (in the
        single environment: this episode's; for tests and statistics)."""
        return 0 if self._batched is None else int(self._batched.memory["sorties"][0])

    def batch(self, n: int) -> ParametricBatch:
        """This team for ``n`` drills (one in the single environment): :class:`ParametricBatch`."""
        self._batched = ParametricBatch(self, n)
        return self._batched


@compiled
def plan_into(skill, target, memory, seen, settings, params, table):
    """The defenders' commands in one drill, written into ``skill`` and ``target``
    (a ``MOVE_TO``'s target; other skills' own targets are the drill's), on the state it
    sees (``seen``: a :data:`~soccer_drill.rules.arrays.STATE` record).

    Guards on their line start a sortie if the ball comes within reach, or if their
    uniform in ``memory.draws`` falls below ``press_probability`` (read only for the
    guards :meth:`ParametricTeam._drawing` names); a guard on a sortie intercepts, else
    stands at its spot on the line. Two interceptors share the work by ``coordination``:
    the presser (kept until the other is ``_SWITCH_MARGIN`` nearer the ball) intercepts;
    the other marks or screens, or chases a loose ball. With a reaction delay every
    command becomes a ``MOVE_TO`` to where its skill would go in the state seen.
    ``memory``'s sorties and presser are updated.
    """
    t, p = settings[0], params[0]
    pos, vel, holder = seen.pos, seen.vel, seen.holder
    size = p.field_size
    defenders, attackers = skill.shape[0], p.attackers
    ball = pos.shape[0] - 1
    bx, by = pos[ball, 0], pos[ball, 1]
    guards = 0
    for k in range(defenders):
        guards += int(t.guard[k])
        skill[k] = Skill.INTERCEPT
    n = 0
    for k in range(defenders):
        if not t.guard[k]:
            continue
        if memory.sortie_left[k] == 0:
            gx, gy = pos[attackers + k, 0], pos[attackers + k, 1]
            reach_k = t.guard_reach
            close = reach_k > 0 and hypot(bx - gx, by - gy) <= reach_k
            drawn = t.press_probability > 0 and memory.draws[k] < t.press_probability
            if drawn or close:
                memory.sortie_left[k] = t.sortie_cycles
                memory.sorties += 1
        if memory.sortie_left[k] > 0:
            memory.sortie_left[k] -= 1
        else:
            _guard_spot_into(skill, target, k, n, guards, bx, size, settings)
        n += 1
    if guards == 0 and t.coordination != _PRESS_MODE and defenders > 1:
        # The presser: the nearest to the ball (the lower index among equals), changed
        # only when another is _SWITCH_MARGIN nearer than the one pressing.
        nearest, d_near = 0, hypot(pos[attackers, 0] - bx, pos[attackers, 1] - by)
        for k in range(1, defenders):
            d = hypot(pos[attackers + k, 0] - bx, pos[attackers + k, 1] - by)
            if d < d_near:
                nearest, d_near = k, d
        presser = memory.presser
        if presser < 0 or d_near + _SWITCH_MARGIN < hypot(
            pos[attackers + presser, 0] - bx, pos[attackers + presser, 1] - by
        ):
            presser = nearest
        memory.presser = presser
        if not (holder < 0 and t.chase_loose):
            for other in range(defenders):
                if other != presser:
                    _support_into(skill, target, other, pos, holder, size, settings, attackers)
    if t.reaction_delay > 0:
        # React to the old state: go where the skill would have gone back then.
        for k in range(defenders):
            if skill[k] == Skill.INTERCEPT:
                target[k, 0], target[k, 1] = interception_point(
                    pos, vel, holder, attackers + k, p.defender_speed * t.speed[k], params,
                    table)
            elif skill[k] == Skill.MARK:
                target[k, 0], target[k, 1] = mark_target(pos, holder, attackers + k,
                                                         _MARK_FRACTION, attackers)
            elif skill[k] == Skill.GUARD_LINE:
                x = 4.0 if 4.0 > bx else bx
                target[k, 0], target[k, 1] = (size - 4.0 if size - 4.0 < x else x), GUARD_DEPTH
            skill[k] = Skill.MOVE_TO


@compiled
def _support_into(skill, target, other, pos, holder, size, settings, attackers):
    """Defender ``other``, not pressing: it covers (marks the free attacker from the
    passing lane) or screens (stands goal-side of the ball), by ``coordination``."""
    t = settings[0]
    ball = pos.shape[0] - 1
    bx, by = pos[ball, 0], pos[ball, 1]
    if t.coordination == _COVER:
        fraction = t.mark_fraction
        if fraction == _MARK_FRACTION:
            skill[other] = Skill.MARK
        else:
            skill[other] = Skill.MOVE_TO
            target[other, 0], target[other, 1] = mark_target(pos, holder, attackers + other,
                                                             fraction, attackers)
    else:  # screen: goal-side of the ball, min(max(...)) as the builtins compare
        ty = by - t.screen_distance
        x = 1.0 if 1.0 > bx else bx
        skill[other] = Skill.MOVE_TO
        target[other, 0] = size - 1.0 if size - 1.0 < x else x
        target[other, 1] = 1.0 if 1.0 > ty else ty


@compiled
def _guard_spot_into(skill, target, k, n, guards, bx, size, settings):
    """Guard ``k``, the ``n``-th of ``guards``, on its line: level with the ball as far as
    ``guard_track`` says, from its home spot."""
    t = settings[0]
    track, depth = t.guard_track, t.guard_depth
    if guards == 1:
        if track == 1.0 and depth == GUARD_DEPTH:
            skill[k] = Skill.GUARD_LINE  # exactly the skill's own spot
            return
        home, offset = size / 2, 0.0
    else:
        home = size * (n + 1) / (guards + 1)
        offset = (n - (guards - 1) / 2) * t.guard_spacing
    x = home + track * (bx + offset - home)
    x = _EDGE if _EDGE > x else x  # min(max(x, _EDGE), size - _EDGE), as the builtins compare
    skill[k] = Skill.MOVE_TO
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
    """:class:`ParametricTeam`'s behaviour for ``n`` drills at once (``team.batch(n)``; one
    in the single environment).

    Each drill has its own sorties, presser and reaction-delay memory, and its sortie draws
    come from its own generator in the order a single drill makes them; the plan
    (:func:`plan_into`) runs drill by drill in one compiled loop.

    The delay's memory holds at most ``max_cycles + 1`` states per drill: an episode
    acts at most ``max_cycles`` times, so a longer delay sees the episode's first state
    throughout and would only cost memory. Two interceptors pressing without delay read
    no state: their plan is the same every cycle (:attr:`fixed`).
    """

    def __init__(self, team: ParametricTeam, n: int) -> None:
        self.team, self.n = team, n
        self.memory = np.zeros(n, dtype=MEMORY)
        """What the team remembers of each drill's episode (:data:`MEMORY`)."""
        self._history = np.zeros((n, 0), dtype=STATE)  # the states seen, a ring per drill
        self._defenders = 0  # set at the first reset, from the drill's players
        self._settings = team.settings()
        self._rng: BatchRandom | None = None
        self._made: dict[int, BatchCommands] = {}
        self._speed_rows: dict[int, np.ndarray] = {}  # the speeds of m drills, by m
        self.fixed = (set(team.roles) == {"interceptor"}
                      and team.coordination == "press" and team.reaction_delay == 0)
        """Whether the plan never reads the state (its commands made once)."""

    def reset(self, view: BatchView, drills: np.ndarray, rng: BatchRandom) -> None:
        """Start an episode in ``drills``; ``rng`` feeds the sorties."""
        defenders = len(view.players)
        if defenders != self._defenders:
            self._defenders, self._made, self._speed_rows = defenders, {}, {}
            self._speeds = np.array([self.team.speeds_of(defenders)])
            self._drawing = self.team._drawing(defenders)
            self._plans = plans_record(defenders)
        depth = min(self.team.reaction_delay, view.config.max_cycles) + 1
        if depth != self._history.shape[1] or self._history.dtype != view.state.dtype:
            self._history = np.zeros((self.n, depth), dtype=view.state.dtype)
        self._rng = rng
        memory = self.memory
        memory["sortie_left"][drills] = 0
        memory["presser"][drills] = -1
        memory["sorties"][drills] = 0
        memory["count"][drills] = 0

    def act(self, view: BatchView, drills: np.ndarray) -> BatchCommands:
        """The defenders' commands in each of ``drills`` (:func:`plan_into`)."""
        m, d = len(drills), self._defenders
        if self.fixed:
            made = self._made.get(m)
            if made is None:
                made = self._made[m] = BatchCommands(
                    np.full((m, d), int(Skill.INTERCEPT)), np.zeros((m, d, 2)),
                    np.repeat(self._speeds, m, axis=0))
            return made
        self._draw(drills)
        plans = np.zeros(m, dtype=self._plans)
        state = view.state if every_drill(drills, view.n) else view.state[drills]
        _plans_of_drills(plans, drills, state, self.memory, self._history, self._settings,
                         view.params, view.table)
        speeds = self._speed_rows.get(m)  # the same every cycle: made once per number of rows
        if speeds is None:
            speeds = self._speed_rows[m] = np.repeat(self._speeds, m, axis=0)
        return BatchCommands(plans["skill"], plans["target"], speeds)

    def _draw(self, drills: np.ndarray) -> None:
        """This cycle's uniform of each guard on its line that may start a sortie at
        random, from each drill's generator, defender 0 first."""
        if not self._drawing:
            return
        draws, left = self.memory["draws"], self.memory["sortie_left"][drills]
        for k in self._drawing:
            on_line = drills[left[:, k] == 0]
            if len(on_line):
                draws[on_line, k] = self._rng.random(on_line)  # type: ignore[union-attr]


@compiled
def _plans_of_drills(plans, drills, state, memory, history, settings, params, table):
    """:func:`plan_into` of drill ``drills[r]`` for each row ``r`` (``state[r]``: its state
    now), on the state it sees: the current one is kept in the drill's ring of the last
    ``depth`` states, and the oldest there (``reaction_delay`` cycles old, or the
    episode's first) is planned on."""
    depth = history.shape[1]
    for r in range(drills.shape[0]):
        i = drills[r]
        mem = memory[i]
        seen = state[r]
        if depth > 1:
            mem.count += 1
            slot = (mem.count - 1) % depth
            history[i, slot] = state[r]
            oldest = 0 if mem.count <= depth else mem.count % depth
            seen = history[i, oldest]
        plan_into(plans[r].skill, plans[r].target, mem, seen, settings, params, table)


@warms
def _compile_plans(config: DrillConfig | None) -> None:
    """:func:`plan_into` and its batched loop, called once with their callers' types
    (compiled before a team's time-bounded call reaches them)."""
    cfg = config or DrillConfig()
    record = state_record(cfg.players)
    team = ParametricTeam(roles=("interceptor", "guard"), press_probability=0.5)
    cover = ParametricTeam(coordination="cover", mark_fraction=0.3)
    state = np.zeros(1, dtype=record)
    state["pos"][0] = [*cfg.attacker_starts, *cfg.defender_starts, (10.0, 10.0)]
    drills = np.zeros(1, dtype=np.int64)
    drills.flags.writeable = False  # as the driver hands them
    shown = state.copy()
    shown.flags.writeable = False  # as the view hands every drill (some: a writable gather)
    for depth in (1, 2):
        for seen in (state, shown):
            for settings in (team.settings(), cover.settings()):
                _plans_of_drills(np.zeros(1, dtype=plans_record(cfg.defenders)), drills, seen,
                                 np.zeros(1, dtype=MEMORY), np.zeros((1, depth), dtype=record),
                                 settings, rule_parameters(cfg), roll_table(cfg))
