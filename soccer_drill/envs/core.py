"""The episodes of ``n`` drills, under every environment: :class:`BatchCore`.

The single environments (``raw_env``, ``parallel_env``, ``HolderEnv``) are one drill of a
core, in a pymunk space of its own; the vector environments many, in shared spaces. The
core holds the drills, each drill's generator, the scripted team and the support players;
this module also holds what the environments say alike: the observations they offer
(:data:`~soccer_drill.rules.features.OBSERVATION_TYPES`, as :class:`Observation`), the
action masks and the words of a refused action, of a call made before ``reset``, or of
one made while another runs.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Literal, TypeVar

import numpy as np
from gymnasium import spaces

from soccer_drill.commands import (
    ATTACKER_ACTIONS,
    DEFENDER_ACTIONS,
    attacker_action_names,
    attacker_action_skills,
)
from soccer_drill.config import DrillConfig
from soccer_drill.constraints import (
    Bool,
    Integer,
    NoneOr,
    OneOf,
    check_keys,
    checked,
    is_int,
)
from soccer_drill.drill.drills import BatchDrill
from soccer_drill.drill.spaces import DRILLS_PER_SPACE, DrillSpace
from soccer_drill.rules.arrays import Outcome, rule_parameters
from soccer_drill.rules.compiled import bind
from soccer_drill.rules.features import OBSERVATION_TYPES, ObservationType
from soccer_drill.rules.first_use import warm_up
from soccer_drill.rules.task_rules import task_rules
from soccer_drill.teams.driver import TeamDriver
from soccer_drill.teams.registry import Team, check_team_timeout

_T = TypeVar("_T")
IllegalAction = Literal["raise", "default"]
ILLEGAL_ACTION = OneOf(("raise", "default"))
"""What ``illegal_action`` may be."""
ObsType = str
"""A key of :data:`~soccer_drill.rules.features.OBSERVATION_TYPES`."""

# The action masks by role, and the action a masked one is replaced by (illegal_action
# "default"): the single and the batched multi-agent environments read them here.
HOLDER_MASK = np.array([1, 1, 1, 0, 0], dtype=np.int8)
"""An attacker holding the ball: HOLD, PASS, DRIBBLE."""
OFF_BALL_MASK = np.array([0, 0, 0, 1, 1], dtype=np.int8)
"""An attacker off the ball: GET_OPEN, GO_TO_BALL."""
DEFENDER_MASK = np.ones(len(DEFENDER_ACTIONS), dtype=np.int8)
"""A defender agent: all three of its actions."""
SHARED_DEFENDER_MASK = np.array([1, 1, 1, 0, 0], dtype=np.int8)
"""A defender with shared spaces (an attacker's ``Discrete(5)``): its last two masked."""
for _mask in (HOLDER_MASK, OFF_BALL_MASK, DEFENDER_MASK, SHARED_DEFENDER_MASK):
    _mask.flags.writeable = False
HOLDER_DEFAULT, OFF_BALL_DEFAULT, DEFENDER_DEFAULT = 0, 3, 0
"""The default actions by role: HOLD, GET_OPEN, INTERCEPT."""
ATTACKER_SKILLS = np.array([int(s) for s in ATTACKER_ACTIONS])
"""An attacker's action, as the skill value the drill reads."""
DEFENDER_SKILLS = np.array([int(s) for s in DEFENDER_ACTIONS])
"""A defender's action, as the skill value."""


class AttackerActions:
    """An attacker agent's actions in a drill with ``attackers`` attackers (the module's
    constants with two): their names and skills, each pass's rank of teammate (-1 for
    the other actions), the masks by role and the default actions."""

    def __init__(self, attackers: int) -> None:
        self.attackers = attackers
        self.names = attacker_action_names(attackers)
        self.skills = np.array([int(s) for s in attacker_action_skills(attackers)])
        self.ranks = np.array([-1, *range(attackers - 1), -1, -1, -1])
        ball = attackers + 1  # HOLD, the passes, DRIBBLE
        self.holder_mask = np.array([1] * ball + [0, 0], dtype=np.int8)
        self.off_ball_mask = np.array([0] * ball + [1, 1], dtype=np.int8)
        self.shared_defender_mask = np.array([1, 1, 1] + [0] * (ball - 1), dtype=np.int8)
        for mask in (self.holder_mask, self.off_ball_mask, self.shared_defender_mask):
            mask.flags.writeable = False
        self.off_ball_default = ball  # GET_OPEN


def make_config(config: DrillConfig | Mapping[str, Any] | None, max_cycles: int | None) -> DrillConfig:
    """Resolve the ``config`` and ``max_cycles`` arguments into one :class:`DrillConfig`."""
    if config is None:
        config = DrillConfig()
    elif isinstance(config, Mapping):
        config = DrillConfig.from_dict(dict(config))
    elif not isinstance(config, DrillConfig):
        raise TypeError(f"config must be a DrillConfig, a dict or None, got {type(config).__name__}")
    if max_cycles is not None and max_cycles != config.max_cycles:
        config = DrillConfig.from_dict({**config.to_dict(), "max_cycles": max_cycles})
    return config


def resolve_shared_spaces(shared_spaces: object, opponent: object) -> bool:
    """The ``shared_spaces`` argument of the multi-agent environments: ``None`` is ``True``
    with no opponent (identical spaces whenever the defenders are agents too), else a
    bool (NumPy's too)."""
    shared = checked("shared_spaces", shared_spaces, NoneOr(Bool()))
    return opponent is None if shared is None else bool(shared)


class Observation:
    """An observation type of :data:`~soccer_drill.rules.features.OBSERVATION_TYPES` for
    one configuration: its ``Box`` and its values.

    ``observation(state, rows, players)`` is ``(len(rows), size)`` float32: for each row,
    the observation of player ``players[r]`` in drill ``rows[r]`` of ``state`` (int64
    arrays; :data:`~soccer_drill.rules.arrays.STATE` records).
    """

    def __init__(self, kind: ObservationType, config: DrillConfig) -> None:
        self.kind = kind
        low, high = kind.bounds(config)
        self.size = len(low)
        self.box = spaces.Box(low, high, dtype=np.float32)
        self.low, self.high = low.astype(np.float64), high.astype(np.float64)  # as compiled
        self._config = config
        self._params = rule_parameters(config)
        self._bound: tuple = (None, None, None, None, None)  # see again()

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        del state["_params"]  # the configuration's read-only record, taken again by a copy
        del state["_bound"]
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        # The same read-only array as the original's: a writable copy would be another
        # type for the compiled rules, compiled anew at the copy's first observation.
        self._params = rule_parameters(self._config)
        self._bound = (None, None, None, None, None)

    def __call__(self, state: np.ndarray, rows: np.ndarray, players: np.ndarray) -> np.ndarray:
        out = np.empty((len(rows), self.size), np.float32)
        self.kind.rule(out, state, rows, players, self._params, self.low, self.high)
        return out

    def again(self, state: np.ndarray, rows: np.ndarray, players: np.ndarray) -> np.ndarray:
        """As calling it, for a caller that asks with the same three arrays each time (the
        single environment's drill and agents): into one array of this object, overwritten
        by the next call, the rule bound to the arrays
        (:func:`~soccer_drill.rules.compiled.bind`) while they are the same."""
        bound_state, bound_rows, bound_players, out, call = self._bound
        if state is not bound_state or rows is not bound_rows or players is not bound_players:
            out = np.empty((len(rows), self.size), np.float32)
            call = bind(self.kind.rule, out, state, rows, players, self._params, self.low,
                        self.high)
            self._bound = (state, rows, players, out, call)
        call()
        return out


def observation(obs_type: object, config: DrillConfig) -> Observation:
    """The :class:`Observation` an environment's ``obs_type`` names (a key of
    :data:`~soccer_drill.rules.features.OBSERVATION_TYPES`)."""
    name = checked("obs_type", obs_type, OneOf(tuple(OBSERVATION_TYPES)))
    return Observation(OBSERVATION_TYPES[name], config)


class BatchCore:
    """``n`` drills with their generators, scripted team and support players: the episodes
    under every environment.

    Parameters
    ----------
    n
        Number of drills.
    opponent
        Team id, team instance, or ``None`` (no scripted team).
    opponent_params
        Keyword parameters of the team factory.
    config
        The drills' parameters.
    team_timeout
        CPU-time bound of one call of the team, or of each drill's copy's (``None``: no
        bound).
    support
        The attackers an environment names are driven by the support behaviour of the
        configuration's task (:attr:`support`: the drill's
        :class:`~soccer_drill.rules.support.SupportDraws`, keepaway's ``GetOpen``:
        :data:`~soccer_drill.rules.task_rules.TASK_RULES`).
    drills_per_space
        Drills sharing one pymunk space; ``None``: the single environments' one drill,
        whose errors name no drill. One drill (``n`` 1, whatever ``drills_per_space``) is
        in a space of its own with the ball a body too (:class:`DrillSpace`), the single
        drill's physics: a batch of one plays the single environment's episodes.
    attack
        A scripted attack (:mod:`soccer_drill.vector.attack`), seeded at each reset with
        the seeds a team would get (there is no team then); ``None``: none.

    Seeding: drill ``i`` has its own generator, the stream that a single environment's
    ``reset(seed=s_i)`` starts (``np.random.default_rng(s_i)``); at each of its episode's
    starts it draws the start (:meth:`BatchDrill.reset`), then the seeds of its support
    player's and its team's (or attack's) own generators, so that their draws never shift
    the physics noise.
    """

    def __init__(
        self,
        n: int,
        opponent: str | Team | None,
        opponent_params: Mapping[str, Any] | None,
        config: DrillConfig,
        team_timeout: float | None,
        support: bool,
        drills_per_space: int | None = DRILLS_PER_SPACE,
        attack: Any = None,
    ) -> None:
        team_timeout = check_team_timeout(team_timeout)  # checked even without a team
        warm_up(config)  # the rules compiled (or loaded) whole, with signals held back, before any step
        single = drills_per_space is None
        self.n, self.config = n, config
        self.batch = BatchDrill(n, config, drills_per_space or DRILLS_PER_SPACE,
                                DrillSpace(config) if single or n == 1 else None)
        self.generators = [np.random.default_rng(s) for s in np.random.SeedSequence().spawn(n)]
        if opponent is None:
            if opponent_params:
                raise ValueError("opponent_params given but opponent is None")
            self.team: TeamDriver | None = None
        else:
            self.team = TeamDriver(opponent, opponent_params, self.batch, team_timeout, single)
        self.support = task_rules(config).support(n, config) if support else None
        self.attack = attack
        self.every = np.arange(n)
        self.every.flags.writeable = False
        self.interrupted: str | None = None
        """The call of the environment that stopped part-way (see :meth:`changing`), until
        every drill is reset."""

    def changing(self, call: str, work: Callable[[], _T], every_drill: bool = False) -> _T:
        """``work()``, a call of the environment that changes its drills (``call`` names
        it in errors), made all or nothing as far as the caller can tell.

        Every check of the call's arguments comes before it, so that a refused call
        changes nothing. If ``work`` stops part-way -- a Ctrl-C, a team's error, anything
        raised -- drills may be part-way through a cycle or a reset (a cycle is not undone:
        it would mean copying every drill's physics and generators before each one), so
        :attr:`interrupted` stays set and :meth:`check_usable` refuses every later step
        until a reset of every drill (``every_drill``) has ended. A reset of some drills
        keeps an earlier interruption. The flag is set before ``work`` starts and cleared
        after its result is complete, so an interruption at any point in between is seen.
        """
        before = self.interrupted
        self.interrupted = call if every_drill or before is None else before
        try:
            out = work()
        except BaseException as exc:
            if every_drill or before is None:
                self.interrupted = f"{call} (stopped by {type(exc).__name__})"
            raise
        self.interrupted = None if every_drill else before
        return out

    def check_usable(self) -> None:
        """The team's error, or ``RuntimeError`` if a call stopped part-way
        (:meth:`changing`) and the drills were not all reset since."""
        if self.team is not None:
            self.team.check_usable()
        if self.interrupted is not None:
            again = ("call reset() to start it again" if self.n == 1 else
                     "call reset() of every drill to start them all again (a reset of some "
                     "drills does not)")
            raise RuntimeError(f"{self.interrupted} stopped part-way, which may leave drills "
                               f"part-way through a cycle or a reset; {again}")

    def seed(self, seeds: Sequence[int | None] | None) -> None:
        """Reseed the drills: one seed (or ``None``: keep) per drill; ``None`` keeps every
        stream. The run then depends on the seeds alone: the physics is fresh after the
        reset of every drill that follows (each space built anew)."""
        if seeds is None:
            return
        for i, s in enumerate(seeds):
            if s is not None:
                self.generators[i] = np.random.default_rng(s)

    def reset(self, drills: np.ndarray) -> None:
        """Start a new episode in each of ``drills``."""
        if not len(drills):
            return
        gens = [self.generators[i] for i in drills.tolist()]
        self.batch.reset(drills, gens)
        support_seeds, team_seeds = zip(*(g.integers(2**63, size=2).tolist() for g in gens),
                                        strict=True)
        if self.support is not None:
            self.support.seed(drills, list(support_seeds))
        if self.team is not None:
            self.team.reset(drills, list(team_seeds))
        if self.attack is not None:
            self.attack.reset(drills, list(team_seeds))

    def advance(self, active: np.ndarray, drills: np.ndarray | None = None) -> None:
        """One cycle of the drills where ``active`` (``drills``: the same as indices, if
        the caller has them), with the commands set in the drills' arrays (the team's
        written here)."""
        if self.team is not None:
            self.team.act(np.flatnonzero(active) if drills is None else drills)
        self.batch.step(active, self.generators)

    @property
    def ended(self) -> np.ndarray:
        """``(n,)`` bool: the drills whose episode has an outcome."""
        return self.batch.outcome != Outcome.RUNNING


SEED = NoneOr(Integer(0))
"""What a single environment's ``reset(seed=...)`` takes: ``None`` (continue the
generator) or an integer >= 0, Python's or NumPy's (not a bool, a float or a list, which
NumPy would take as a seed sequence)."""


def check_reset_options(options: object, allowed: tuple[str, ...] | None, where: str
                        ) -> Mapping[str, Any]:
    """``reset``'s ``options``, checked alike in every environment: ``None`` (none) or a
    dict (or other mapping) whose keys are all in ``allowed``; anything else refused,
    naming what was given and the keys ``where`` takes (an empty mapping always passes,
    as wrappers may give one). ``allowed=None``: any keys, none read (PettingZoo's
    environments, whose API test resets with ``options={"options": 1}``)."""
    if options is None:
        return {}
    if not isinstance(options, Mapping):
        keys = "any, none read" if allowed is None else ", ".join(map(repr, allowed)) or "none"
        raise TypeError(f"{where}'s options must be None or a dict (keys: {keys}), got "
                        f"{type(options).__name__}")
    if allowed is not None:
        check_keys(f"{where}'s options", options, allowed, required=())
    return options


def check_seed(seed: object, n: int) -> list[int | None] | None:
    """A batched ``reset``'s ``seed`` as one seed (``None``: keep the stream) per drill.

    ``None`` stays ``None``; an integer ``s`` gives drill ``i`` the seed ``s + i``; a
    sequence must hold exactly ``n`` entries, each ``None`` or an integer. Integers are
    Python or NumPy ones (not bools), ``>= 0``. Anything else: ``ValueError`` saying what
    was given and what is allowed, before any drill is touched.
    """
    if seed is None:
        return None
    allowed = (
        f"seed must be None, an integer >= 0 (drill i gets seed + i) or a sequence of {n} "
        "seeds, one per drill, each None or an integer >= 0"
    )
    if is_int(seed):
        if seed < 0:  # type: ignore[operator]
            raise ValueError(f"{allowed}; got {seed!r}")
        return [int(seed) + i for i in range(n)]  # type: ignore[call-overload]
    if isinstance(seed, np.ndarray) and seed.ndim != 1:
        raise ValueError(f"{allowed}; got an array of shape {seed.shape}")
    if isinstance(seed, str | bytes) or not isinstance(seed, Sequence | np.ndarray):
        raise ValueError(f"{allowed}; got {seed!r} of type {type(seed).__name__}")
    seeds = list(seed)
    if len(seeds) != n:
        raise ValueError(f"{allowed}; got a sequence of {len(seeds)}")
    for i, s in enumerate(seeds):
        if s is not None and not (is_int(s) and s >= 0):
            raise ValueError(f"{allowed}; got seed[{i}] = {s!r} of type {type(s).__name__}")
    return [None if s is None else int(s) for s in seeds]


# ------------------------------------------------------------------- the words
def concurrent_use(env: object, method: str) -> RuntimeError:
    """The error for ``method`` called while the environment is inside a step or reset:
    from that very step or reset (re-entrant: a scripted team's ``act()`` stepping the
    environment that called it), or from another thread."""
    if _inside_own_call(env):
        return RuntimeError(
            f"{type(env).__name__}.{method}() called from inside its own step() or reset() "
            "(re-entrant: e.g. a scripted team's act() or reset() using the environment "
            "that runs it); a team gets the drill through its view and must not step or "
            "reset the environment"
        )
    return RuntimeError(
        f"{type(env).__name__}.{method}() called from thread "
        f"{threading.current_thread().name!r} while another thread is stepping or resetting "
        "the same environment; an environment must not be used from two threads at once "
        "(give each thread its own environment)"
    )


_CALLS = ("step", "reset", "async_reset", "send", "recv")  # the calls that hold the lock


def _inside_own_call(env: object) -> bool:
    """Whether this thread is inside a call of ``env`` that holds its lock (:data:`_CALLS`)
    besides the call that was refused (read only then, so it costs a step nothing)."""
    calls, frame = 0, sys._getframe(1)
    while frame is not None:
        if frame.f_code.co_name in _CALLS and frame.f_locals.get("self") is env:
            calls += 1  # the refused call is one of them
        frame = frame.f_back
    return calls >= 2


def not_reset(method: str) -> RuntimeError:
    """The error for ``method`` called before the first ``reset()``."""
    return RuntimeError(f"{method}() called before reset(); call reset() first")


def action_names(index: int, n: int, attackers: int = 2) -> list[str]:
    """The names of player ``index``'s ``n`` actions (with shared spaces a defender has an
    attacker's, its last ones padding)."""
    actions = (attacker_action_names(attackers) if index < attackers
               else [s.name for s in DEFENDER_ACTIONS])
    return list(actions) + ["padding"] * (n - len(actions))


def action_list(index: int, n: int, attackers: int = 2) -> str:
    """``0=HOLD, 1=PASS, ...``: player ``index``'s ``n`` actions, for messages."""
    return ", ".join(f"{k}={name}" for k, name in enumerate(action_names(index, n, attackers)))


def out_of_range(agent: str, index: int, n: int, action: int, attackers: int = 2) -> str:
    """Why ``action`` of ``agent`` (player ``index``, ``n`` actions) is refused: out of
    range (the single and the batched multi-agent environments alike)."""
    return (f"action {action} for {agent!r} is out of range; allowed: 0..{n - 1} "
            f"({action_list(index, n, attackers)})")


def masked_action(agent: str, index: int, n: int, action: int, cycle: int,
                  mask: np.ndarray, attackers: int = 2) -> str:
    """Why ``action`` of ``agent`` is refused: masked now (``mask``: its action mask)."""
    names = action_names(index, n, attackers)
    legal_now = [f"{k}={names[k]}" for k in np.flatnonzero(mask)]
    return (f"action {action} ({names[action]}) is masked for {agent!r} at cycle {cycle}; "
            f"legal actions now: {legal_now}. illegal_action='default' replaces a masked "
            "action by the role's default action instead (and reports it in infos)")
