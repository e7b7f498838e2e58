"""What the AEC, parallel and holder environments share: setup, spaces, checks, one cycle."""

from __future__ import annotations

import sys
import threading
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from typing import Any, Literal

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding

from soccer_drill.config import DrillConfig
from soccer_drill.constraints import is_int
from soccer_drill.drill import Drill
from soccer_drill.rules.features import (
    feature_bounds,
    features,
    full_bounds,
    full_observation,
    kinematic_bounds,
    kinematics,
)
from soccer_drill.rules.support import SupportPlayer
from soccer_drill.skills import ATTACKER_ACTIONS, DEFENDER_ACTIONS, Command, Skill
from soccer_drill.state import PLAYER_NAMES, DrillView
from soccer_drill.teams import (
    DEFAULT_TEAM_TIMEOUT,
    Team,
    TeamDriver,
    check_team_timeout,
    resolve_team,
)

ObsType = Literal["features", "kinematic", "full"]
OBS_TYPES = ("features", "kinematic", "full")
"""The observation types of the multi-agent environments (``obs_type``)."""
IllegalAction = Literal["raise", "default"]

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
# The same masks as tuples of bools, for checking an action (indexing a tuple is cheaper).
_ATTACKER_HOLDER_LEGAL = tuple(bool(x) for x in HOLDER_MASK)
_ATTACKER_OFF_BALL_LEGAL = tuple(bool(x) for x in OFF_BALL_MASK)


def resolve_shared_spaces(shared_spaces: object, opponent: object) -> bool:
    """The ``shared_spaces`` argument of the multi-agent environments: ``None`` is ``True``
    with no opponent (identical spaces whenever the defenders are agents too), else a
    bool (NumPy's too); anything else ``TypeError``."""
    if shared_spaces is None:
        return opponent is None
    if isinstance(shared_spaces, bool | np.bool_):
        return bool(shared_spaces)
    raise TypeError(
        "shared_spaces must be None (identical spaces when there is no opponent), "
        f"True or False, got {shared_spaces!r}"
    )


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


class DrillCore:
    """One drill, its scripted team and support players, spaces and action checks.

    Parameters
    ----------
    opponent
        Team id (see :func:`soccer_drill.teams.team_ids`), a :class:`Team`
        instance, or ``None`` for no scripted team (the defenders are agents).
    opponent_params
        Keyword parameters for the team factory.
    config
        Drill parameters.
    obs_type
        ``"features"`` (the 9 features), ``"kinematic"`` (26 values) or ``"full"``
        (both and the time left, 36 values).
    illegal_action
        ``"raise"`` (a masked action is an error) or ``"default"``
        (it is replaced by the role's default: HOLD, GET_OPEN or INTERCEPT, and
        :attr:`replaced` says so).
    scripted_attackers
        Attackers driven by :class:`SupportPlayer`.
    team_timeout
        Seconds of CPU time each ``reset``/``act`` call of the team may take, or
        ``None`` for no bound (see :class:`~soccer_drill.teams.TeamDriver`).
    shared_spaces
        Defenders get the attackers' ``Discrete(5)`` actions, the last
        two always masked.

    Attributes
    ----------
    replaced
        ``(given, taken)`` after :meth:`command_for` replaced a masked action,
        else ``None``; the caller reads it and sets it back to ``None``.
    busy
        A lock an environment holds while it steps or resets, so that a second
        thread using the same environment at the same time gets a clear error
        (:func:`concurrent_use`) instead of corrupting the physics engine.
    """

    def __init__(
        self,
        opponent: str | Team | None,
        opponent_params: Mapping[str, Any] | None,
        config: DrillConfig,
        obs_type: ObsType = "features",
        illegal_action: IllegalAction = "raise",
        scripted_attackers: tuple[int, ...] = (),
        team_timeout: float | None = DEFAULT_TEAM_TIMEOUT,
        shared_spaces: bool = False,
    ) -> None:
        if obs_type not in OBS_TYPES:
            raise ValueError(f"obs_type must be one of {OBS_TYPES}, got {obs_type!r}")
        if illegal_action not in ("raise", "default"):
            raise ValueError(
                f"illegal_action must be 'raise' or 'default', got {illegal_action!r}"
            )
        if isinstance(shared_spaces, np.bool_):
            shared_spaces = bool(shared_spaces)
        if not isinstance(shared_spaces, bool):
            raise TypeError(f"shared_spaces must be True or False, got {shared_spaces!r}")
        team_timeout = check_team_timeout(team_timeout)  # checked even without a team
        self.config = config
        self.drill = Drill(config)
        self.obs_type = obs_type
        self.illegal_action = illegal_action
        self.shared_spaces = shared_spaces
        self._defender_mask = SHARED_DEFENDER_MASK if shared_spaces else DEFENDER_MASK
        self._defender_legal = tuple(bool(x) for x in self._defender_mask)
        self._defender_commands = _legal_commands(DEFENDER_ACTIONS, self._defender_legal)
        self.replaced: tuple[int, int] | None = None
        self.busy = threading.Lock()
        self.team_name: str | None
        if opponent is None:
            if opponent_params:
                raise ValueError("opponent_params given but opponent is None")
            self.team, self.team_name = None, None
        else:
            self.team, self.team_name, _ = resolve_team(opponent, opponent_params, team_timeout)
        scripted = set(scripted_attackers) | ({2, 3} if self.team is not None else set())
        self.agent_indices = tuple(i for i in range(4) if i not in scripted)
        self.scripted_attackers = tuple(sorted(scripted_attackers))
        self.support = SupportPlayer()
        self._driver = (
            TeamDriver(self.team, self.team_name or "", PLAYER_NAMES[2:], team_timeout)
            if self.team
            else None
        )
        self.view = DrillView(self.drill, PLAYER_NAMES[2:])
        # The bounds as float64 arrays, as the compiled observation rules read them.
        if obs_type in ("features", "full"):
            low, high = (feature_bounds if obs_type == "features" else full_bounds)(config)
            self._observe = features if obs_type == "features" else full_observation
            self._obs_args: tuple = (config, low.astype(np.float64), high.astype(np.float64))
        else:
            low, high = kinematic_bounds(config)
            self._observe = kinematics
            self._obs_args = (low.astype(np.float64), high.astype(np.float64))
        self.obs_box = spaces.Box(low, high, dtype=np.float32)
        self.np_random, _ = seeding.np_random()

    @contextmanager
    def exclusive(self, env: object, method: str) -> Iterator[None]:
        """Hold :attr:`busy` for ``env.method()``, or raise :func:`concurrent_use` at once.

        For ``reset``; the ``step`` methods take the lock inline, which is cheaper.
        """
        if not self.busy.acquire(False):
            raise concurrent_use(env, method)
        try:
            yield
        finally:
            self.busy.release()

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        del state["busy"]  # a lock cannot be pickled; a copy gets its own
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self.busy = threading.Lock()

    @property
    def has_reset(self) -> bool:
        """Whether :meth:`reset` has run (so that there is a state to observe or draw)."""
        return hasattr(self.drill, "state")

    # -------------------------------------------------------------- episodes
    def seed(self, seed: int | None) -> None:
        """Reseed the drill's generator (``None`` keeps the current stream)."""
        if seed is not None:
            self.np_random, _ = seeding.np_random(seed)

    def reset(self) -> None:
        """Start an episode: place the players, seed the support player and the team."""
        self.drill.reset(self.np_random)
        # Children draw from their own streams so a team's draws never shift the physics noise.
        support_seed, team_seed = self.np_random.integers(2**63, size=2)
        if self.scripted_attackers:  # else nothing draws from it: not made (~15 us)
            self.support.reset(np.random.default_rng(int(support_seed)))
        if self._driver is not None:
            self._driver.reset(self.view, np.random.default_rng(int(team_seed)))

    def advance(self, commands: list[Command | None]) -> None:
        """One cycle; ``commands`` holds the agents' commands, ``None`` for the others."""
        state, cfg = self.drill.state, self.config
        for i in self.scripted_attackers:
            if commands[i] is None:
                commands[i] = self.support.command(state, i, cfg)
        if self._driver is not None:
            for i, command in self._driver.act(self.view):
                commands[i] = command
        self.drill.step(commands, self.np_random)  # type: ignore[arg-type]

    # ---------------------------------------------------------- observations
    def observe(self, index: int) -> np.ndarray:
        """Observation (features or kinematic) of player ``index``."""
        return self._observe(self.drill.state, index, *self._obs_args)

    def mask(self, index: int) -> np.ndarray:
        """Action mask of player ``index`` (read-only int8)."""
        if index >= 2:
            return self._defender_mask
        return HOLDER_MASK if self.drill.state.holder == index else OFF_BALL_MASK

    # --------------------------------------------------------------- actions
    def command_for(self, agent: str, index: int, action: object) -> Command:
        """Check ``action`` of ``agent`` and turn it into a command."""
        if type(action) is int:  # the common case: a legal plain int (a bool is not one)
            if index >= 2:
                legal = self._defender_commands
            elif self.drill.state.holder == index:
                legal = _HOLDER_COMMANDS
            else:
                legal = _OFF_BALL_COMMANDS
            if 0 <= action < len(legal) and (command := legal[action]) is not None:
                return command
        actions = ATTACKER_ACTIONS if index < 2 else DEFENDER_ACTIONS
        n = len(ATTACKER_ACTIONS) if self.shared_spaces else len(actions)
        if type(action) is int:  # the common case: a plain int (a bool is not one)
            a = action
        else:
            if isinstance(action, np.ndarray) and action.shape == ():
                action = action.item()
            if not is_int(action):
                raise TypeError(
                    f"action for {agent!r} must be an integer in [0, {n - 1}] "
                    f"({action_list(index, n)}), got {action!r} of type {type(action).__name__}"
                )
            a = int(action)
        if not 0 <= a < n:
            raise ValueError(out_of_range(agent, index, n, a))
        if index >= 2:
            legal = self._defender_legal
        else:
            legal = _ATTACKER_HOLDER_LEGAL if self.drill.state.holder == index else (
                _ATTACKER_OFF_BALL_LEGAL
            )
        if not legal[a]:
            if self.illegal_action == "default":
                given = a
                holds = self.drill.state.holder == index
                a = (HOLDER_DEFAULT if holds else OFF_BALL_DEFAULT) if index < 2 else DEFENDER_DEFAULT
                self.replaced = (given, a)
            else:
                raise ValueError(masked_action(agent, index, n, a, self.drill.state.cycle,
                                               self.mask(index)))
        return _COMMANDS[actions[a]]


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


def _inside_own_call(env: object) -> bool:
    """Whether this thread is inside a ``step`` or ``reset`` of ``env`` besides the call
    that was refused (read only then, so it costs a step nothing)."""
    calls, frame = 0, sys._getframe(1)
    while frame is not None:
        if frame.f_code.co_name in ("step", "reset") and frame.f_locals.get("self") is env:
            calls += 1  # the refused call is one of them
        frame = frame.f_back
    return calls >= 2


def not_reset(method: str) -> RuntimeError:
    """The error for ``method`` called before the first ``reset()``."""
    return RuntimeError(f"{method}() called before reset(); call reset() first")


def action_names(index: int, n: int) -> list[str]:
    """The names of player ``index``'s ``n`` actions (with shared spaces a defender has an
    attacker's five, its last two padding)."""
    actions = ATTACKER_ACTIONS if index < 2 else DEFENDER_ACTIONS
    return [s.name for s in actions] + ["padding"] * (n - len(actions))


def action_list(index: int, n: int) -> str:
    """``0=HOLD, 1=PASS, ...``: player ``index``'s ``n`` actions, for messages."""
    return ", ".join(f"{k}={name}" for k, name in enumerate(action_names(index, n)))


def out_of_range(agent: str, index: int, n: int, action: int) -> str:
    """Why ``action`` of ``agent`` (player ``index``, ``n`` actions) is refused: out of
    range (the single and the batched multi-agent environments alike)."""
    return (f"action {action} for {agent!r} is out of range; allowed: 0..{n - 1} "
            f"({action_list(index, n)})")


def masked_action(agent: str, index: int, n: int, action: int, cycle: int,
                  mask: np.ndarray) -> str:
    """Why ``action`` of ``agent`` is refused: masked now (``mask``: its action mask)."""
    names = action_names(index, n)
    legal_now = [f"{k}={names[k]}" for k in np.flatnonzero(mask)]
    return (f"action {action} ({names[action]}) is masked for {agent!r} at cycle {cycle}; "
            f"legal actions now: {legal_now}. illegal_action='default' replaces a masked "
            "action by the role's default action instead (and reports it in infos)")


_COMMANDS = {skill: Command(skill) for skill in Skill if skill is not Skill.MOVE_TO}


def _legal_commands(actions: tuple[Skill, ...], legal: tuple[bool, ...]) -> tuple:
    """Per action index, its command if the mask allows it, else ``None``."""
    return tuple(
        _COMMANDS[actions[a]] if ok and a < len(actions) else None for a, ok in enumerate(legal)
    )


# command_for's shortcut for a legal action: the command of each action index, by role.
_HOLDER_COMMANDS = _legal_commands(ATTACKER_ACTIONS, _ATTACKER_HOLDER_LEGAL)
_OFF_BALL_COMMANDS = _legal_commands(ATTACKER_ACTIONS, _ATTACKER_OFF_BALL_LEGAL)

