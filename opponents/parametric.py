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

import math
from collections import deque
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from soccer_drill.skills import GUARD_DEPTH, Command, Skill, ball_interception_point
from soccer_drill.state import BALL, PLAYER_NAMES, DrillState, DrillView

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


def _is_number(value: object) -> bool:
    """A Python or NumPy real number, not a bool (``True`` is an ``int`` to Python)."""
    return isinstance(value, int | float | np.integer | np.floating) and not isinstance(value, bool)


def _is_integer(value: object) -> bool:
    """A Python or NumPy integer, not a bool."""
    return isinstance(value, int | np.integer) and not isinstance(value, bool)


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

    Args:
        roles: the two defenders' roles, each ``"interceptor"`` or ``"guard"``.
        coordination: ``"press"``, ``"cover"`` or ``"screen"`` (two interceptors only).
        speed: fraction of the defenders' top speed, one number or one per defender, in (0, 1].
        reaction_delay: the team acts on the state this many cycles old (>= 0); with a
            delay, every command is a ``MOVE_TO`` to where the skill would have gone.
        mark_fraction: a marker stands this fraction of the way from the free attacker
            to the ball (``cover``), in [0, 1]; 0.35 is the MARK skill's own spot.
        chase_loose: in ``cover`` and ``screen``, the second defender goes for a loose ball.
        screen_distance: metres goal-side of the ball at which the screening defender stands.
        guard_depth: metres up from the goal line at which guards stand (> 0).
        guard_track: how far guards follow the ball sideways, in [0, 1]: 0 keeps them at
            their home spots (one guard: the centre; two: at 1/3 and 2/3 of the width),
            1 keeps them level with the ball (two guards then stand ``guard_spacing`` apart).
        guard_spacing: lateral gap between two guards that follow the ball, metres.
        guard_reach: a guard sorties when the ball is within this distance of it, metres
            (0 disables it).
        press_probability: per-cycle probability that a guard on its line starts a sortie.
        sortie_cycles: length of a sortie, cycles (>= 1).
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
        roles = tuple(roles)
        if len(roles) != 2 or any(r not in ROLES for r in roles):
            raise ValueError(f"roles must be two of {ROLES}, got {roles!r}")
        if coordination not in COORDINATIONS:
            raise ValueError(f"coordination must be one of {COORDINATIONS}, got {coordination!r}")
        if isinstance(speed, int | float | np.number | np.bool_):  # a bool too: refused below
            speeds = (speed, speed)
        else:
            try:
                speeds = tuple(speed)
            except TypeError:  # not a number nor a sequence: the message below says what is
                speeds = (speed,)
        if len(speeds) != 2 or not all(_is_number(s) and 0.0 < s <= 1.0 for s in speeds):
            raise ValueError(f"speed must be in (0, 1], one or two values, got {speed!r}")
        if not _is_integer(reaction_delay) or reaction_delay < 0:
            raise ValueError(f"reaction_delay must be an integer >= 0, got {reaction_delay!r}")
        if not _is_integer(sortie_cycles) or sortie_cycles < 1:
            raise ValueError(f"sortie_cycles must be an integer >= 1, got {sortie_cycles!r}")
        for name, value, lo, hi in (
            ("mark_fraction", mark_fraction, 0.0, 1.0),
            ("guard_track", guard_track, 0.0, 1.0),
            ("press_probability", press_probability, 0.0, 1.0),
            ("screen_distance", screen_distance, 0.0, 30.0),
            ("guard_spacing", guard_spacing, 0.0, 30.0),
            ("guard_reach", guard_reach, 0.0, 50.0),
            ("guard_depth", guard_depth, 1e-3, 30.0),
        ):
            if not (_is_number(value) and math.isfinite(value) and lo <= value <= hi):
                raise ValueError(f"{name} must lie in [{lo}, {hi}], got {value!r}")
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
        self._indices: tuple[int, ...] = ()
        self._rng: np.random.Generator | None = None
        self._history: deque[DrillState] = deque(maxlen=self.reaction_delay + 1)
        self._sortie_left = [0, 0]
        self._presser = -1
        self.sorties = 0
        """Sorties started this episode (for tests and statistics)."""

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

    # ------------------------------------------------------------------ protocol
    def reset(self, view: DrillView, rng: np.random.Generator) -> None:
        """Start an episode: sorties and the delay buffer are reset; ``rng`` feeds the sorties."""
        if len(view.players) != 2:
            raise ValueError(f"this team drives two defenders, got players {view.players!r}")
        self._players = tuple(view.players)
        self._indices = tuple(PLAYER_NAMES.index(p) for p in self._players)
        self._rng = rng
        self._history.clear()
        self._sortie_left = [0, 0]
        self._presser = -1
        self.sorties = 0

    def act(self, view: DrillView) -> dict[str, Command]:
        """One command per defender, from the (possibly delayed) state."""
        if self._rng is None:
            raise RuntimeError("reset() first")
        current = view.state
        self._history.append(current)
        seen = self._history[0]  # reaction_delay cycles old (or the oldest we have)
        cfg = view.config
        skills = self._plan(seen, cfg.field_size)
        commands = {}
        for k, (player, index) in enumerate(zip(self._players, self._indices, strict=True)):
            skill, target = skills[k]
            speed = self.speeds[k]
            if target is None and self.reaction_delay > 0:
                # React to the old state: go where the skill would have gone back then.
                target = self._skill_target(seen, index, skill, cfg, speed)
                skill = Skill.MOVE_TO
            commands[player] = Command(skill, target, speed)
        return commands

    def batch(self, n: int) -> ParametricBatch:
        """This team's behaviour for ``n`` drills at once (see :class:`ParametricBatch`)."""
        return ParametricBatch(self, n)

    # ------------------------------------------------------------------ behaviour
    def _plan(
        self, s: DrillState, size: float
    ) -> list[tuple[Skill, tuple[float, float] | None]]:
        """``(skill, target)`` per defender; target ``None`` means the skill's own."""
        idx = self._indices
        bx, by = s.pos[BALL]
        loose = s.holder < 0
        plan: list[tuple[Skill, tuple[float, float] | None]] = [(Skill.INTERCEPT, None)] * 2
        interceptors = [k for k in (0, 1) if self.roles[k] == "interceptor"]
        guards = [k for k in (0, 1) if self.roles[k] == "guard"]

        # Guards: sorties (random, or the ball came close), else the line.
        rng = self._rng
        assert rng is not None
        for n, k in enumerate(guards):
            if self._sortie_left[k] == 0:
                gx, gy = s.pos[idx[k]]
                close = self.guard_reach > 0 and math.hypot(bx - gx, by - gy) <= self.guard_reach
                draw = self.press_probability > 0 and rng.random() < self.press_probability
                if draw or close:
                    self._sortie_left[k] = self.sortie_cycles
                    self.sorties += 1
            if self._sortie_left[k] > 0:
                self._sortie_left[k] -= 1
                plan[k] = (Skill.INTERCEPT, None)
            else:
                plan[k] = self._guard_spot(n, len(guards), s, size)

        if len(interceptors) == 2 and self.coordination != "press":
            d = [math.hypot(s.pos[idx[k]][0] - bx, s.pos[idx[k]][1] - by) for k in (0, 1)]
            if self._presser < 0 or d[1 - self._presser] + _SWITCH_MARGIN < d[self._presser]:
                self._presser = 0 if d[0] <= d[1] else 1
            other = 1 - self._presser
            if not (loose and self.chase_loose):
                if self.coordination == "cover":
                    plan[other] = self._mark(s, idx[other])
                else:  # screen
                    ty = max(by - self.screen_distance, 1.0)
                    plan[other] = (Skill.MOVE_TO, (min(max(bx, 1.0), size - 1.0), ty))
        return plan

    def _guard_spot(
        self, n: int, count: int, s: DrillState, size: float
    ) -> tuple[Skill, tuple[float, float] | None]:
        bx = s.pos[BALL][0]
        if count == 1:
            if self.guard_track == 1.0 and self.guard_depth == GUARD_DEPTH:
                return Skill.GUARD_LINE, None  # exactly the skill's own spot
            home, offset = size / 2, 0.0
        else:
            home = size * (n + 1) / 3
            offset = (n - 0.5) * self.guard_spacing
        x = home + self.guard_track * (bx + offset - home)
        return Skill.MOVE_TO, (min(max(x, _EDGE), size - _EDGE), self.guard_depth)

    def _mark(self, s: DrillState, index: int) -> tuple[Skill, tuple[float, float] | None]:
        if self.mark_fraction == _MARK_FRACTION:
            return Skill.MARK, None
        bx, by = s.pos[BALL]
        fx, fy = s.pos[s.free_opponent_of(index)]
        f = self.mark_fraction
        return Skill.MOVE_TO, (fx + f * (bx - fx), fy + f * (by - fy))

    @staticmethod
    def _skill_target(
        s: DrillState, index: int, skill: Skill, cfg: Any, speed: float
    ) -> tuple[float, float]:
        if skill is Skill.INTERCEPT:
            return ball_interception_point(s, index, cfg.defender_speed * speed, cfg)
        if skill is Skill.MARK:
            bx, by = s.pos[BALL]
            fx, fy = s.pos[s.free_opponent_of(index)]
            f = _MARK_FRACTION
            return fx + f * (bx - fx), fy + f * (by - fy)
        if skill is Skill.GUARD_LINE:
            x = min(max(s.pos[BALL][0], 4.0), cfg.field_size - 4.0)
            return x, GUARD_DEPTH
        raise AssertionError(f"no target rule for {skill!r}")  # pragma: no cover


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
    if not _is_integer(n) or n < 0:
        raise ValueError(f"n must be an integer >= 0, got {n!r}")
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
    """:class:`ParametricTeam`'s behaviour for ``n`` drills at once (``team.batch(n)``).

    The same plan as :meth:`ParametricTeam.act` (sorties, the presser's hysteresis, the
    reaction delay, every target), computed for all drills acting in a cycle on arrays
    (:mod:`soccer_drill.batch_teams`); each drill's sortie draws come from its own
    generator in the order the single team makes them.

    The delay's buffer holds at most ``max_cycles + 1`` states per drill: an episode
    acts at most ``max_cycles`` times, so a longer delay sees the episode's first state
    throughout, as the single team does, and would only cost memory.
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
        self._rng: Any = None

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
        self._count[drills] = 0
        self._sortie_left[drills] = 0
        self._presser[drills] = -1
        self.sorties[drills] = 0

    def _seen(self, view: Any, drills: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The states ``reaction_delay`` cycles old (or the oldest since reset)."""
        from soccer_drill.batch_teams import every_drill

        if every_drill(drills, view.n):  # the arrays themselves (read-only views), no copies
            pos, vel, holder = view.pos, view.vel, view.holder
        else:
            pos, vel, holder = view.pos[drills], view.vel[drills], view.holder[drills]
        depth = self._depth
        if depth == 1:
            return pos, vel, holder
        count = self._count[drills] + 1
        self._count[drills] = count
        slot = (count - 1) % depth
        self._pos[drills, slot] = pos
        self._vel[drills, slot] = vel
        self._holder[drills, slot] = holder
        oldest = np.where(count <= depth, 0, count % depth)
        return self._pos[drills, oldest], self._vel[drills, oldest], self._holder[drills, oldest]

    def act(self, view: Any, drills: np.ndarray) -> Any:
        """The two defenders' commands in each of ``drills``."""
        from soccer_drill.batch_teams import BatchCommands
        from soccer_drill.motion import interception_points, mark_targets

        t, cfg = self.team, view.config
        size = cfg.field_size
        pos, vel, holder = self._seen(view, drills)
        m = len(drills)
        bx, by = pos[:, BALL, 0], pos[:, BALL, 1]
        skill = np.full((m, 2), int(Skill.INTERCEPT), dtype=np.int64)
        target = np.zeros((m, 2, 2))
        guards = [k for k in (0, 1) if t.roles[k] == "guard"]
        for n_guard, k in enumerate(guards):
            left = self._sortie_left[drills, k]
            on_line = left == 0
            gx, gy = pos[:, 2 + k, 0], pos[:, 2 + k, 1]
            start = on_line & (t.guard_reach > 0) & (np.hypot(bx - gx, by - gy) <= t.guard_reach)
            if t.press_probability > 0 and np.count_nonzero(on_line):
                draws = np.zeros(m, dtype=bool)
                draws[on_line] = self._rng.random(drills[on_line]) < t.press_probability
                start |= draws & on_line
            left = np.where(start, t.sortie_cycles, left)
            self.sorties[drills[start]] += 1
            out = left > 0
            self._sortie_left[drills, k] = np.where(out, left - 1, left)
            spot_skill, spot = self._guard_spots(n_guard, len(guards), bx, size)
            skill[:, k] = np.where(out, int(Skill.INTERCEPT), spot_skill)
            target[:, k] = np.where(out[:, None], 0.0, spot)
        interceptors = [k for k in (0, 1) if t.roles[k] == "interceptor"]
        if len(interceptors) == 2 and t.coordination != "press":
            d = np.hypot(pos[:, 2:4, 0] - bx[:, None], pos[:, 2:4, 1] - by[:, None])
            r = np.arange(m)
            presser = self._presser[drills]
            p = np.where(presser >= 0, presser, 0)
            switch = (presser < 0) | (d[r, 1 - p] + _SWITCH_MARGIN < d[r, p])
            presser = np.where(switch, np.where(d[:, 0] <= d[:, 1], 0, 1), presser)
            self._presser[drills] = presser
            other = 1 - presser
            second = ~((holder < 0) & t.chase_loose)
            if t.coordination == "cover":
                if t.mark_fraction == _MARK_FRACTION:
                    what, where = int(Skill.MARK), np.zeros((m, 2))
                else:
                    spots = mark_targets(pos, holder, t.mark_fraction)
                    what, where = int(Skill.MOVE_TO), spots[r, 2 + other]
            else:  # screen
                what = int(Skill.MOVE_TO)
                where = np.stack(
                    (np.minimum(np.maximum(bx, 1.0), size - 1.0),
                     np.maximum(by - t.screen_distance, 1.0)), axis=1)
            rows = r[second]
            skill[rows, other[second]] = what
            target[rows, other[second]] = where[second] if where.ndim == 2 else where
        speed = np.broadcast_to(np.array(t.speeds), (m, 2)).copy()
        if t.reaction_delay > 0:
            # React to the old state: go where the skill would have gone back then.
            vmax = np.ones((m, 4))
            vmax[:, 2:] = cfg.defender_speed * speed
            to_ball = interception_points(pos, vel, holder, vmax, cfg)[:, 2:]
            marks = mark_targets(pos, holder)[:, 2:]
            line = np.stack(
                (np.minimum(np.maximum(bx, 4.0), size - 4.0), np.full(m, GUARD_DEPTH)), axis=1)
            own = np.stack([skill == int(s) for s in (Skill.INTERCEPT, Skill.MARK, Skill.GUARD_LINE)])
            target = np.where(own[0][..., None], to_ball, target)
            target = np.where(own[1][..., None], marks, target)
            target = np.where(own[2][..., None], line[:, None, :], target)
            skill = np.where(own.any(axis=0), int(Skill.MOVE_TO), skill)
        return BatchCommands(skill, target, speed)

    def _guard_spots(
        self, n_guard: int, count: int, bx: np.ndarray, size: float
    ) -> tuple[int | np.ndarray, np.ndarray]:
        t = self.team
        if count == 1:
            if t.guard_track == 1.0 and t.guard_depth == GUARD_DEPTH:
                return int(Skill.GUARD_LINE), np.zeros((len(bx), 2))
            home, offset = size / 2, 0.0
        else:
            home = size * (n_guard + 1) / 3
            offset = (n_guard - 0.5) * t.guard_spacing
        x = home + t.guard_track * (bx + offset - home)
        spot = np.stack(
            (np.minimum(np.maximum(x, _EDGE), size - _EDGE), np.full(len(bx), t.guard_depth)),
            axis=1)
        return int(Skill.MOVE_TO), spot
