"""The drill as PettingZoo AEC and parallel environments."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils import EzPickle
from pettingzoo import AECEnv, ParallelEnv
from pettingzoo.utils import AgentSelector

from soccer_drill.config import DrillConfig
from soccer_drill.core import DrillCore, IllegalAction, ObsType, action_spaces, make_config
from soccer_drill.state import PLAYER_NAMES
from soccer_drill.teams import DEFAULT_TEAM_TIMEOUT, Team

_METADATA = {
    "render_modes": ["human", "rgb_array"],
    "name": "soccer_drill_v0",
    "is_parallelizable": True,
    "render_fps": 10,
}


class _DrillEnvBase:
    """Construction, spaces, observations and rendering common to both APIs."""

    metadata = _METADATA

    def _setup(
        self,
        opponent: str | Team | None,
        opponent_params: Mapping[str, Any] | None,
        obs_type: ObsType,
        max_cycles: int | None,
        config: DrillConfig | Mapping[str, Any] | None,
        render_mode: str | None,
        illegal_action: IllegalAction,
        team_timeout: float | None,
    ) -> None:
        if render_mode is not None and render_mode not in _METADATA["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {_METADATA['render_modes']}, "
                f"got {render_mode!r}"
            )
        cfg = make_config(config, max_cycles)
        self._core = DrillCore(
            opponent, opponent_params, cfg, obs_type, illegal_action, team_timeout=team_timeout
        )
        self.config = cfg
        self.render_mode = render_mode
        self.possible_agents = [PLAYER_NAMES[i] for i in self._core.agent_indices]
        self._index = {name: PLAYER_NAMES.index(name) for name in self.possible_agents}
        attacker_space, defender_space = action_spaces()
        mask_spaces = {
            n: spaces.Box(0, 1, shape=(s.n,), dtype=np.int8)
            for n, s in (("attacker", attacker_space), ("defender", defender_space))
        }
        self._action_spaces = {
            name: attacker_space if i < 2 else defender_space for name, i in self._index.items()
        }
        self._observation_spaces = {
            name: spaces.Dict(
                {
                    "observation": self._core.obs_box,
                    "action_mask": mask_spaces["attacker" if i < 2 else "defender"],
                }
            )
            for name, i in self._index.items()
        }
        self._renderer = None

    def observation_space(self, agent: str) -> spaces.Space:
        """``Dict(observation=Box, action_mask=Box(int8))``; the same object every call."""
        return self._observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Space:
        """``Discrete(5)`` for attackers, ``Discrete(3)`` for defenders; the same object."""
        return self._action_spaces[agent]

    def _observation(self, agent: str) -> dict[str, np.ndarray]:
        i = self._index[agent]
        return {"observation": self._core.observe(i), "action_mask": self._core.mask(i)}

    def _outcome_info(self) -> dict[str, Any]:
        drill = self._core.drill
        if drill.outcome is None:
            return {}
        return {"outcome": drill.outcome, "cycles": drill.state.cycle}

    def render(self) -> np.ndarray | None:
        """Draw the current cycle (see :mod:`soccer_drill.render`)."""
        if self.render_mode is None:
            return None
        if self._renderer is None:
            from soccer_drill.render import Renderer

            self._renderer = Renderer(self.config, self.render_mode, self.metadata["render_fps"])
        return self._renderer.draw(self._core.drill.state, self._core.drill.outcome)

    def close(self) -> None:
        """Close the window, if any."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    @property
    def drill_state(self):
        """The current :class:`~soccer_drill.state.DrillState` (positions, holder, cycle)."""
        return self._core.drill.state

    @property
    def outcome(self) -> str | None:
        """``None`` while the episode runs, then its outcome."""
        return self._core.drill.outcome


class raw_env(_DrillEnvBase, AECEnv, EzPickle):
    """The 2v2 soccer drill of the ILPSS paper, as a PettingZoo AEC environment.

    Two attackers try to carry the ball across the goal line (the bottom edge of a
    35 m x 35 m region); two defenders try to win it. Bodies are pymunk circles;
    one cycle is 0.1 s of simulated time, advanced after every agent has acted.

    ## Agents

    ``attacker_0``, ``attacker_1``, ``defender_0``, ``defender_1``: every player
    that no scripted team drives. With ``opponent="<team id>"`` the defenders are
    scripted and only the attackers are agents. All agents act once per cycle, in
    that order.

    ## Action space

    | agent | space | actions |
    |-------|-------|---------|
    | attacker | ``Discrete(5)`` | 0 HOLD, 1 PASS, 2 DRIBBLE (ball holder only), 3 GET_OPEN, 4 GO_TO_BALL (off the ball only) |
    | defender | ``Discrete(3)`` | 0 INTERCEPT, 1 MARK, 2 GUARD_LINE (always legal) |

    Illegal actions are masked (``observation["action_mask"]``, int8); stepping a
    masked action raises ``ValueError`` naming the agent, the action and the legal
    ones, unless ``illegal_action="default"``.

    ## Observation space

    ``Dict(observation=Box, action_mask=Box(0, 1, (n,), int8))``. With
    ``obs_type="features"`` the observation is the paper's 9 features from the
    agent's point of view (table in :mod:`soccer_drill.features`); with
    ``"kinematic"`` it is a 26-value egocentric vector of positions, velocities
    and possession flags.

    ## Rewards

    Zero until the last cycle. Then, for the attackers:

    | outcome | reward |
    |---------|--------|
    | success (an attacker in possession takes the ball over the goal line) | 1.0 at the line centre, falling linearly to 0.5 at its ends |
    | interception (a defender gains possession) | -1 |
    | out (the ball leaves the region) | -1 |
    | timeout (``max_cycles`` cycles pass) | -1 |

    Defenders receive the negation (zero-sum). All values are configurable in
    :class:`~soccer_drill.config.DrillConfig`.

    ## Episode end

    Success, interception and out terminate; timeout truncates. The outcome is judged
    after each cycle in that order (interception, success, out, timeout), so a defender
    who wins the ball on the last cycle makes it an interception, not a timeout. Every agent then
    has ``terminations`` (or ``truncations``) set, receives ``infos[agent] ==
    {"outcome": ..., "cycles": ...}``, must be stepped with ``None`` and is
    removed, so ``agents`` is empty at the end.

    ## Arguments

    | argument | default | meaning |
    |----------|---------|---------|
    | ``opponent`` | ``None`` | team id (see ``soccer-drill-teams``), a ``Team`` instance, or ``None`` (defenders are agents) |
    | ``opponent_params`` | ``None`` | keyword parameters of the team factory |
    | ``obs_type`` | ``"features"`` | ``"features"`` or ``"kinematic"`` |
    | ``max_cycles`` | ``None`` | overrides ``config.max_cycles`` (default 100) |
    | ``config`` | ``None`` | a ``DrillConfig`` or a dict of its fields |
    | ``render_mode`` | ``None`` | ``"human"`` (a window) or ``"rgb_array"`` (off-screen) |
    | ``illegal_action`` | ``"raise"`` | ``"raise"`` or ``"default"`` (replace masked actions by the role's default) |
    | ``team_timeout`` | ``1.0`` | seconds each ``reset``/``act`` call of the scripted team may take before it is stopped with ``TeamError`` naming it; ``None``: no bound (e.g. to debug a team). See ``soccer_drill.teams.TeamDriver`` |

    ``env(...)`` returns this class: the order and bounds checks of PettingZoo's
    standard wrappers are built in (cheaply), so no wrapper chain is added.
    """

    def __init__(
        self,
        opponent: str | Team | None = None,
        opponent_params: Mapping[str, Any] | None = None,
        obs_type: ObsType = "features",
        max_cycles: int | None = None,
        config: DrillConfig | Mapping[str, Any] | None = None,
        render_mode: str | None = None,
        illegal_action: IllegalAction = "raise",
        team_timeout: float | None = DEFAULT_TEAM_TIMEOUT,
    ) -> None:
        EzPickle.__init__(
            self, opponent, opponent_params, obs_type, max_cycles, config, render_mode,
            illegal_action, team_timeout,
        )
        AECEnv.__init__(self)
        self._setup(
            opponent, opponent_params, obs_type, max_cycles, config, render_mode, illegal_action,
            team_timeout,
        )
        self._has_reset = False
        self.agents: list[str] = []

    def reset(self, seed: int | None = None, options: dict | None = None) -> None:
        """Start an episode; ``seed`` reseeds the drill (see the class docstring)."""
        self._core.seed(seed)
        self._core.reset()
        self.agents = self.possible_agents[:]
        self.rewards = dict.fromkeys(self.agents, 0.0)
        self._cumulative_rewards = dict.fromkeys(self.agents, 0.0)
        self.terminations = dict.fromkeys(self.agents, False)
        self.truncations = dict.fromkeys(self.agents, False)
        self.infos = {agent: {} for agent in self.agents}
        self._commands: list = [None] * 4
        self._selector = AgentSelector(self.agents)
        self.agent_selection = self._selector.next()
        self._has_reset = True
        if self.render_mode == "human":
            self.render()

    def observe(self, agent: str) -> dict[str, np.ndarray]:
        """The observation dict (features and action mask) of ``agent``."""
        if not self._has_reset:
            raise RuntimeError("observe() called before reset()")
        return self._observation(agent)

    def step(self, action: int | None) -> None:
        """Act for the selected agent (AEC) or for all live agents (parallel); see the class docstring."""
        if not self._has_reset:
            raise RuntimeError("step() called before reset()")
        agent = self.agent_selection
        if not self.agents:
            raise RuntimeError("step() called after the episode ended; call reset()")
        if self.terminations[agent] or self.truncations[agent]:
            if action is not None:
                raise ValueError(
                    f"{agent!r} is done (the episode ended); it must be stepped with None, "
                    f"got {action!r}"
                )
            self._was_dead_step(action)
            return
        index = self._index[agent]
        self._commands[index] = self._core.command_for(agent, index, action)
        self._cumulative_rewards[agent] = 0.0
        if self._selector.is_last():
            self._core.advance(self._commands)
            self._commands = [None] * 4
            drill = self._core.drill
            if drill.outcome is not None:
                reward = drill.attacker_reward
                info = self._outcome_info()
                done = drill.outcome != "timeout"
                for name in self.agents:
                    self.rewards[name] = reward if self._index[name] < 2 else -reward
                    self.terminations[name] = done
                    self.truncations[name] = not done
                    self.infos[name] = dict(info)
            if self.render_mode == "human":
                self.render()
        else:
            self._clear_rewards()
        self.agent_selection = self._selector.next()
        self._accumulate_rewards()


def env(**kwargs: Any) -> raw_env:
    """The AEC drill as users should call it (checks built in; see :class:`raw_env`)."""
    return raw_env(**kwargs)


class parallel_env(_DrillEnvBase, ParallelEnv, EzPickle):
    """The drill as a PettingZoo parallel environment: all agents act each cycle.

    Spaces, rewards, episode end and arguments are those of :class:`raw_env`.
    ``step`` takes one action per live agent; a missing, extra, out-of-range or
    masked action raises ``ValueError`` naming the agent. After the step that ends
    the episode, ``agents`` is empty.
    """

    def __init__(
        self,
        opponent: str | Team | None = None,
        opponent_params: Mapping[str, Any] | None = None,
        obs_type: ObsType = "features",
        max_cycles: int | None = None,
        config: DrillConfig | Mapping[str, Any] | None = None,
        render_mode: str | None = None,
        illegal_action: IllegalAction = "raise",
        team_timeout: float | None = DEFAULT_TEAM_TIMEOUT,
    ) -> None:
        EzPickle.__init__(
            self, opponent, opponent_params, obs_type, max_cycles, config, render_mode,
            illegal_action, team_timeout,
        )
        self._setup(
            opponent, opponent_params, obs_type, max_cycles, config, render_mode, illegal_action,
            team_timeout,
        )
        self.agents: list[str] = []
        self._has_reset = False

    def reset(
        self, seed: int | None = None, options: dict | None = None
    ) -> tuple[dict[str, dict], dict[str, dict]]:
        """Start an episode; ``seed`` reseeds the drill (see the class docstring)."""
        self._core.seed(seed)
        self._core.reset()
        self.agents = self.possible_agents[:]
        self._has_reset = True
        if self.render_mode == "human":
            self.render()
        return {a: self._observation(a) for a in self.agents}, {a: {} for a in self.agents}

    def step(self, actions: Mapping[str, int]):
        """Act for the selected agent (AEC) or for all live agents (parallel); see the class docstring."""
        if not self._has_reset:
            raise RuntimeError("step() called before reset()")
        if not self.agents:
            raise RuntimeError("step() called after the episode ended; call reset()")
        if not isinstance(actions, Mapping) or set(actions) != set(self.agents):
            got = sorted(actions) if isinstance(actions, Mapping) else type(actions).__name__
            raise ValueError(
                f"actions must be a mapping with one action per live agent {self.agents}, "
                f"got {got}"
            )
        commands: list = [None] * 4
        for agent in self.agents:
            index = self._index[agent]
            commands[index] = self._core.command_for(agent, index, actions[agent])
        self._core.advance(commands)
        drill = self._core.drill
        agents = self.agents
        obs = {a: self._observation(a) for a in agents}
        if drill.outcome is None:
            zeros = dict.fromkeys(agents, 0.0)
            falses = dict.fromkeys(agents, False)
            result = obs, zeros, falses, dict(falses), {a: {} for a in agents}
        else:
            reward = drill.attacker_reward
            done = drill.outcome != "timeout"
            rewards = {a: reward if self._index[a] < 2 else -reward for a in agents}
            info = self._outcome_info()
            result = (
                obs, rewards, dict.fromkeys(agents, done), dict.fromkeys(agents, not done),
                {a: dict(info) for a in agents},
            )
            self.agents = []
        if self.render_mode == "human":
            self.render()
        return result
