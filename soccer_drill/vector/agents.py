"""Many drills as one batched multi-agent environment: ``parallel_env`` with a leading batch
axis, over the :class:`~soccer_drill.envs.core.BatchCore` of the single environments."""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces

from soccer_drill.commands import DEFENDER_ACTIONS
from soccer_drill.config import DrillConfig
from soccer_drill.constraints import Integer, checked, is_int
from soccer_drill.drill.spaces import DRILLS_PER_SPACE
from soccer_drill.envs.core import (
    DEFENDER_DEFAULT,
    DEFENDER_MASK,
    DEFENDER_SKILLS,
    HOLDER_DEFAULT,
    ILLEGAL_ACTION,
    AttackerActions,
    BatchCore,
    IllegalAction,
    Observation,
    ObsType,
    action_list,
    check_reset_options,
    check_seed,
    make_config,
    masked_action,
    observation,
    out_of_range,
    resolve_shared_spaces,
)
from soccer_drill.envs.pickling import Pickled, claimed
from soccer_drill.rendering.batch import BatchRenderer, check_render_mode
from soccer_drill.rendering.screen import frames_per_second
from soccer_drill.rules.arrays import OUTCOME_NAMES, Outcome
from soccer_drill.rules.features import GLOBAL_STATE
from soccer_drill.rules.motion import ranked_teammate
from soccer_drill.rules.task_rules import cycle_reward
from soccer_drill.teams.registry import DEFAULT_TEAM_TIMEOUT, Team
from soccer_drill.vector.attack import HolderRuleAttack, ScriptedAttack, make_attack
from soccer_drill.vector.memory import check_frames_fit, check_frames_memory, check_num_envs

_OUTCOMES = np.array(OUTCOME_NAMES, dtype=object)


class ParallelVectorEnv(Pickled):
    """``num_envs`` drills as one multi-agent environment, every array with a leading batch axis.

    The drill of :func:`soccer_drill.parallel_env` (its docstring is the reference of the
    game), batched: the same agents, actions, masks, observations, rewards and episode
    end, each a ``(num_envs, ...)`` array per agent. With ``opponent`` a team id the
    agents are the two attackers and the team drives the defenders (batched when it has
    a batched ``act``: :mod:`soccer_drill.teams.kit`); with ``attack`` an attack id the
    attackers are scripted (:mod:`soccer_drill.vector.attack`: the fixed holder rules
    playing both attackers, as the holder environment plays them) and the agents are the
    two defenders; with neither all four players are agents.

    ## Spaces (per agent; batched values add a leading ``num_envs`` axis)

    | agent | action space | actions | observation |
    |---|---|---|---|
    | attacker | ``Discrete(5)`` | 0 HOLD, 1 PASS, 2 DRIBBLE (holder only), 3 GET_OPEN, 4 GO_TO_BALL (off the ball only) | ``Box(9,)`` features, ``Box(26,)`` with ``obs_type="kinematic"``, ``Box(36,)`` with ``"full"`` |
    | defender | ``Discrete(3)`` | 0 INTERCEPT, 1 MARK, 2 GUARD_LINE (always legal) | the same, from the defender's side |
    | defender, ``shared_spaces=True`` | ``Discrete(5)`` | 0-2 as above; 3 and 4 always masked | the same |

    Drills of other sizes (``config=DrillConfig(attackers=A, defenders=D)``): the agents,
    actions and observations of ``raw_env``'s "Other sizes".

    ``observation_space(agent)`` (a ``Dict`` of ``"observation"`` and ``"action_mask"``,
    as ``parallel_env``'s) and ``action_space(agent)`` are one drill's spaces. With
    shared spaces (as ``parallel_env``'s, the default with no opponent) every agent has the same spaces, and
    one more value ends every observation: 1 for an attacker, 0 for a defender.
    ``state()`` is every drill's :func:`~soccer_drill.rules.features.global_state_into` (``6 p + 5``
    values with ``p`` players: 29 in the 2v2 drill, the layout of ``parallel_env``'s
    ``state()``): ``(num_envs, 6 p + 5)`` float32 in
    ``state_space`` batched (``state_space`` is one drill's ``Box``).

    ## Calls

    | call | returns |
    |---|---|
    | ``reset(seed=None)`` | ``(observations, infos)`` |
    | ``state()`` | ``(num_envs, 6 p + 5)`` float32 (``p`` players: 29 in the 2v2 drill): every drill's global state |
    | ``render()`` | with ``render_mode="rgb_array"``: a tuple of ``num_envs`` frames ``(H, W, 3)`` uint8, one per drill (as ``SyncVectorEnv.render``); else ``None`` |
    | ``step(actions)`` | ``(observations, rewards, terminations, truncations, infos)`` |
    | ``action_masks()`` | ``{agent: (num_envs, n) int8}``, 1 = legal now |

    ``actions`` is ``{agent: (num_envs,) ints}``. ``observations[agent]`` is
    ``{"observation": (num_envs, d) float32, "action_mask": (num_envs, n) int8}``;
    ``rewards[agent]`` ``(num_envs,)`` float64; ``terminations[agent]`` and
    ``truncations[agent]`` ``(num_envs,)`` bool. ``infos`` holds per-drill arrays:
    ``"outcome"`` (object: ``None`` or the outcome), ``"cycles"`` (int) and, per agent,
    ``infos["illegal_action"][agent]`` and ``infos["action_taken"][agent]`` (int, -1
    where the action was legal).

    ## Rewards and episode end

    As ``parallel_env``'s, cycle by cycle: in the drill zero until a drill's last cycle,
    then the attackers get the attackers' reward and the defenders its negative; in
    keepaway (``DrillConfig(task="keepaway")``) every cycle a drill plays pays the
    attackers (the keepers) the task's pay per cycle (``cycle_seconds``) and the
    defenders its negative, and the end nothing more. ``terminations`` on success, interception or out,
    ``truncations`` on timeout, for every agent of that drill.

    ## Autoreset

    As Gymnasium's ``NEXT_STEP``: a drill whose episode ended at step ``t`` is reset at
    step ``t + 1`` (its actions ignored): it returns its first observation, reward 0 and
    no termination.

    ## Illegal actions

    ``illegal_action="default"`` (default, as ``parallel_env``) replaces a masked action by
    the role's default (HOLD for the holder, GET_OPEN off the ball, INTERCEPT for a
    defender with shared spaces) and reports it in
    ``infos``; ``"raise"`` raises ``ValueError`` naming the drill, the agent, the action
    and the legal ones, before any drill moves. An action out of range always raises
    ``ValueError``, and actions not of an integer dtype (floats, bools) ``TypeError``, as
    ``parallel_env``'s ``step`` does, naming the drill.

    ## Interruptions

    As :class:`~soccer_drill.vector.holder.HolderVectorEnv`'s: a ``reset`` or ``step`` stopped
    part-way (a Ctrl-C, a team's error) makes every later ``step`` raise ``RuntimeError``
    saying to call ``reset()``, which brings every drill back as in a new environment.

    ## Seeding

    As :class:`~soccer_drill.vector.holder.HolderVectorEnv`: ``reset(seed=s)`` starts drill
    ``i`` from the generator of a single environment's ``reset(seed=s + i)`` and
    rebuilds the physics, so the batch's episodes are a function of ``s`` and the
    actions; a list gives one seed per drill (exactly ``num_envs``, each ``None``: keep
    its stream, or an integer); ``reset()`` and autoresets continue each drill's stream.
    A seed is a Python or NumPy integer ``>= 0``, not a bool; anything else raises
    ``ValueError`` before any drill is reset. Episodes agree with the single
    environment's in distribution, not bit for bit (shared physics spaces; see
    ``HolderVectorEnv``).

    ## Arguments

    | argument | default | meaning |
    |---|---|---|
    | ``num_envs`` | ``1`` | number of drills |
    | ``opponent`` | ``None`` | team id, ``Team`` instance, or ``None`` (the defenders are agents) |
    | ``opponent_params`` | ``None`` | keyword parameters of the team factory (with a team id; refused with an instance) |
    | ``obs_type`` | ``"features"`` | as ``parallel_env``'s: ``"features"``, ``"kinematic"`` or ``"full"`` |
    | ``max_cycles`` | ``None`` | overrides ``config.max_cycles`` |
    | ``config`` | ``None`` | a ``DrillConfig`` or a dict of its fields |
    | ``illegal_action`` | ``"default"`` | ``"default"`` or ``"raise"`` |
    | ``team_timeout`` | ``1.0`` | CPU seconds one batched team call may take (a team without a batched ``act``: each drill's copy, each call) |
    | ``drills_per_space`` | ``64`` | drills sharing one pymunk space |
    | ``shared_spaces`` | ``None`` | as ``parallel_env``'s: ``None`` is ``True`` with no opponent (every agent has the same action and observation spaces), ``False`` with one; ``False``: per-role spaces |
    | ``render_mode`` | ``None`` | ``None`` or ``"rgb_array"`` (see Calls); ``metadata["render_fps"]`` is ``parallel_env``'s, ``1 / cycle_seconds`` |
    | ``attack`` | ``None`` | an attack id of :data:`~soccer_drill.vector.attack.ATTACKS` (or an attack object): scripted attackers, the defenders as agents; not with ``opponent`` |
    """

    metadata: ClassVar[dict] = {"render_modes": ["rgb_array"], "name": "soccer_drill_vector_v0"}

    def __init__(
        self,
        num_envs: int = 1,
        opponent: str | Team | None = None,
        opponent_params: Mapping[str, Any] | None = None,
        obs_type: ObsType = "features",
        max_cycles: int | None = None,
        config: DrillConfig | Mapping[str, Any] | None = None,
        illegal_action: IllegalAction = "default",
        team_timeout: float | None = DEFAULT_TEAM_TIMEOUT,
        drills_per_space: int = DRILLS_PER_SPACE,
        shared_spaces: bool | None = None,
        render_mode: str | None = None,
        attack: str | HolderRuleAttack | None = None,
    ) -> None:
        n = check_num_envs(num_envs)
        drills_per_space = checked("drills_per_space", drills_per_space, Integer(1))
        if attack is not None and opponent is not None:
            raise ValueError("give a scripted attack or a scripted opponent team, not both: "
                             f"got attack={attack!r} and opponent={opponent!r}")
        scripted = None if attack is None else make_attack(attack)
        shared_spaces = resolve_shared_spaces(shared_spaces, opponent if attack is None else scripted)
        self.render_mode = check_render_mode(render_mode, type(self).__name__)
        self.illegal_action = checked("illegal_action", illegal_action, ILLEGAL_ACTION)
        self.config = make_config(config, max_cycles)
        self.metadata = {**self.metadata, "render_fps": frames_per_second(self.config)}
        self._observe = observation(obs_type, self.config)
        self.num_envs, self.obs_type = n, obs_type
        if self.render_mode is not None:  # before any drill is built
            check_frames_fit(n, self.config)
        self._core = BatchCore(
            n, opponent, opponent_params, self.config, team_timeout, attack is not None,
            drills_per_space, scripted,
        )
        self._attack = None if scripted is None else ScriptedAttack(
            scripted, self._core, name=attack if isinstance(attack, str) else None)
        cfg = self.config
        attackers, names = cfg.attackers, cfg.player_names
        self._attackers, self._actions = attackers, AttackerActions(attackers)
        indices = (tuple(range(attackers)) if opponent is not None
                   else tuple(range(attackers, cfg.players)) if attack is not None
                   else tuple(range(cfg.players)))
        self.possible_agents = [names[i] for i in indices]
        self.agents = list(self.possible_agents)
        self._index = {a: names.index(a) for a in self.possible_agents}
        self._indices = tuple(self._index.values())
        k = len(indices)  # every agent of every drill in one pass
        self._rows = np.repeat(np.arange(n), k)
        self._players = np.tile(np.array(indices, dtype=np.int64), n)
        box = self._observe.box
        bounds = (box.low, box.high)
        self.shared_spaces = shared_spaces
        if shared_spaces:  # a trailing role flag tells one shared policy which side it plays
            bounds = (np.append(bounds[0], 0.0).astype(np.float32),
                      np.append(bounds[1], 1.0).astype(np.float32))
            self._role = np.array([1.0 if i < attackers else 0.0 for i in self._indices],
                                  dtype=np.float32)
        self._obs_box = spaces.Box(*bounds, dtype=np.float32)
        self._defender_mask = (self._actions.shared_defender_mask if shared_spaces
                               else DEFENDER_MASK)
        self._spaces = {
            a: spaces.Discrete(len(self._actions.names) if i < attackers or shared_spaces
                               else len(DEFENDER_ACTIONS))
            for a, i in self._index.items()
        }
        # One drill's observation, as ``parallel_env``'s dict observations are spaced.
        self._observation_spaces = {
            a: spaces.Dict({"observation": self._obs_box,
                            "action_mask": spaces.Box(0, 1, shape=(space.n,), dtype=np.int8)})
            for a, space in self._spaces.items()
        }
        self._state = Observation(GLOBAL_STATE, self.config)
        self.state_space = self._state.box
        team = self._core.team
        self._renderer = (BatchRenderer(self.config, check_frames_memory,
                                        None if team is None else team.name)
                          if self.render_mode else None)
        self._paid = cycle_reward(self.config)  # the attackers' pay per cycle: keepaway's seconds
        self._autoreset = np.zeros(n, dtype=bool)
        self._has_reset = False
        self._busy_init()

    def __copy__(self) -> ParallelVectorEnv:
        """An independent copy continuing every drill's episode, as ``copy.deepcopy``
        and ``pickle`` give (the single environments' ``copy.copy`` does the same)."""
        return copy.deepcopy(self)

    @property
    def num_agents(self) -> int:
        """How many agents act in every drill (PettingZoo's ``ParallelEnv.num_agents``)."""
        return len(self.agents)

    @property
    def max_num_agents(self) -> int:
        """How many agents there can be (PettingZoo's ``max_num_agents``)."""
        return len(self.possible_agents)

    def observation_space(self, agent: str) -> spaces.Dict:
        """One drill's observation space of ``agent``: ``Dict`` of ``"observation"`` (the
        features ``Box``) and ``"action_mask"``, as ``parallel_env``'s and as every
        drill's row of the observations returned."""
        self._check_agent(agent)
        return self._observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Discrete:
        """One drill's action space of ``agent``."""
        self._check_agent(agent)
        return self._spaces[agent]

    def _check_agent(self, agent: str) -> None:
        if agent not in self._spaces:  # KeyError, as parallel_env's spaces
            raise KeyError(f"unknown agent {agent!r}; the agents are {self.possible_agents}")

    # -------------------------------------------------------------- episodes
    @claimed
    def reset(
        self, seed: int | Sequence[int | None] | None = None, options: dict | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Start an episode in every drill (see Seeding)."""
        # a reset of every drill: no option changes it (HolderVectorEnv has reset_mask)
        check_reset_options(options, (), "ParallelVectorEnv.reset")
        core = self._core
        seeds = check_seed(seed, self.num_envs)

        def none() -> np.ndarray:  # an array of each agent's own
            return np.full(self.num_envs, -1)

        def reset() -> tuple[dict[str, Any], dict[str, Any]]:
            core.seed(seeds)
            self._restart(core.every)
            self._autoreset[:] = False
            self._has_reset = True
            return self._observations(), self._infos({a: none() for a in self.agents},
                                                     {a: none() for a in self.agents})

        return core.changing("ParallelVectorEnv.reset()", reset, every_drill=True)

    def action_masks(self) -> dict[str, np.ndarray]:
        """``{agent: (num_envs, n) int8}``: the legal actions of each drill now."""
        if not self._has_reset:  # no drill has started: there is no holder to read
            raise RuntimeError("action_masks() called before reset(); call reset() first")
        holder = self._core.batch.holder
        out = {}
        for agent, i in self._index.items():
            if i >= self._attackers:
                out[agent] = np.broadcast_to(self._defender_mask, (self.num_envs, len(self._defender_mask))).copy()
            else:
                out[agent] = np.where((holder == i)[:, None], self._actions.holder_mask,
                                      self._actions.off_ball_mask)
        return out

    def _observations(self) -> dict[str, Any]:
        masks = self.action_masks()
        n, k = self.num_envs, len(self._indices)
        every = self._observe(self._core.batch.state, self._rows, self._players).reshape(n, k, -1)
        if self.shared_spaces:
            every = np.concatenate(
                (every, np.broadcast_to(self._role[:, None], (n, k, 1))), axis=2)
        return {agent: {"observation": every[:, j], "action_mask": masks[agent]}
                for j, agent in enumerate(self._index)}

    def _infos(self, illegal: dict, taken: dict) -> dict[str, Any]:
        b = self._core.batch
        return {
            "outcome": _OUTCOMES[b.outcome], "cycles": b.cycle.copy(),
            "illegal_action": illegal, "action_taken": taken,
        }

    def _commands(self, actions: Mapping[str, Any], stepping: np.ndarray) -> tuple[dict, dict]:
        """Check every drill's actions (nothing changes on an error), then set the commands."""
        if not isinstance(actions, Mapping) or set(actions) != set(self.agents):
            got = (f"keys {', '.join(sorted(map(repr, actions)))}" if isinstance(actions, Mapping)
                   else type(actions).__name__)
            raise ValueError(f"actions must be a mapping of every agent {self.agents} (and no "
                             f"other key) to ({self.num_envs},) integers, got {got}")
        b = self._core.batch
        attackers, table = self._attackers, self._actions
        checked_actions, illegal, taken = {}, {}, {}
        for agent, i in self._index.items():
            a = np.asarray(actions[agent])
            n_actions = self._spaces[agent].n
            if a.shape != (self.num_envs,):
                raise ValueError(
                    f"actions[{agent!r}] must be an integer array of shape ({self.num_envs},), "
                    f"got {a.dtype} of shape {a.shape}"
                )
            if a.dtype.kind not in "iu":  # TypeError, as parallel_env's step for 2.0 or True
                d = next((j for j, x in enumerate(a.tolist()) if not is_int(x)), 0)
                raise TypeError(
                    f"drill {d}: action for {agent!r} must be "
                    f"{Integer(0, n_actions - 1).describe()} "
                    f"({action_list(i, n_actions, attackers)}), got "
                    f"{a[d]!r} (actions of dtype {a.dtype}; an integer dtype is needed)"
                )
            # One test of the range (a negative action is a large unsigned one).
            if np.count_nonzero(stepping & (a.astype(np.uint64, copy=False) >= n_actions)):
                d = int(np.nonzero(stepping & ((a < 0) | (a >= n_actions)))[0][0])
                raise ValueError(
                    f"drill {d}: {out_of_range(agent, i, n_actions, int(a[d]), attackers)}")
            legal = is_legal(a, b.holder, i, attackers)
            masked = np.nonzero(stepping & ~legal)[0]
            given = np.full(self.num_envs, -1)
            done = np.full(self.num_envs, -1)
            if len(masked):
                masks = self.action_masks()
                if self.illegal_action == "raise":
                    d = int(masked[0])
                    why = masked_action(agent, i, n_actions, int(a[d]), int(b.cycle[d]),
                                        masks[agent][d], attackers)
                    raise ValueError(f"drill {d}: {why}")
                given[masked] = a[masked]
                a = a.copy()
                a[masked] = (
                    np.where(b.holder[masked] == i, HOLDER_DEFAULT, table.off_ball_default)
                    if i < attackers else DEFENDER_DEFAULT
                )
                done[masked] = a[masked]
            if not stepping.all():  # a drill being reset ignores its action, whatever it is
                a = np.where(stepping, a, 0)
            checked_actions[agent], illegal[agent], taken[agent] = a, given, done
        for agent, i in self._index.items():
            chosen = checked_actions[agent]
            b.skill[:, i] = (table.skills if i < attackers else DEFENDER_SKILLS)[chosen]
            b.speed[:, i] = 1.0
            if i < attackers and attackers > 2:  # each pass to the teammate of its rank now
                b.receiver[:, i] = ranked_teammates(b.pos, i, attackers, table.ranks[chosen])
        return illegal, taken

    @claimed
    def step(self, actions: Mapping[str, Any]):
        """One cycle of every drill (drills ended at the last step are reset instead)."""
        if not self._has_reset:
            raise RuntimeError("step() called before reset(); call reset() first")
        core, b = self._core, self._core.batch
        core.check_usable()
        stepping = ~self._autoreset
        illegal, taken = self._commands(actions, stepping)

        def step():
            resetting = np.nonzero(self._autoreset)[0]
            if len(resetting):
                self._restart(resetting)
            if self._attack is None:
                core.advance(stepping)
            else:
                self._attack.cycle(stepping)
            ended = stepping & (b.outcome != Outcome.RUNNING)
            reward = np.where(ended, b.attacker_reward, 0.0)
            if self._paid:  # keepaway: every cycle a drill plays pays its seconds
                reward = reward + np.where(stepping, self._paid, 0.0)
            truncated = ended & (b.outcome == Outcome.TIMEOUT)
            terminated = ended & ~truncated
            self._autoreset = ended
            rewards = {a: (reward.copy() if i < self._attackers else 0.0 - reward)  # never a -0.0
                       for a, i in self._index.items()}
            return (
                self._observations(), rewards,
                {a: terminated.copy() for a in self.agents},
                {a: truncated.copy() for a in self.agents},
                self._infos(illegal, taken),
            )

        return core.changing("ParallelVectorEnv.step()", step)

    def _restart(self, drills: np.ndarray) -> None:
        """A new episode in ``drills`` (through the scripted attack's loop, if any)."""
        if self._attack is None:
            self._core.reset(drills)
        else:
            self._attack.restart(drills)

    def state(self) -> np.ndarray:
        """Every drill's global state: ``(num_envs, 6 p + 5)`` float32 with ``p`` players, 29
        in the 2v2 drill (see the class docstring)."""
        if not self._has_reset:
            raise RuntimeError("state() called before reset(); call reset() first")
        return self._state(self._core.batch.state, self._core.every, self._core.every)

    def render(self) -> tuple[np.ndarray, ...] | None:
        """One frame per drill with ``render_mode="rgb_array"`` (else ``None``)."""
        if self._renderer is None:
            return None
        return self._renderer.frames(self._core.batch, self._has_reset)

    def close(self) -> None:
        """Let go of the renderer, if any."""
        if self._renderer is not None:
            self._renderer.close()


def is_legal(actions: np.ndarray, holder: np.ndarray, index: int,
             attackers: int = 2) -> np.ndarray:
    """Whether each drill's action (in range) is legal for player ``index``, as the
    action masks say, without making the masks: an attacker may take a ball action
    (``0 .. attackers``: 0-2 in the 2v2 drill) exactly when it holds the ball, a defender
    any of its three actions."""
    if index < attackers:
        return (actions <= attackers) == (holder == index)
    return actions < 3


def ranked_teammates(pos: np.ndarray, player: int, attackers: int,
                     ranks: np.ndarray) -> np.ndarray:
    """In each drill, ``player``'s teammate of ``ranks[i]`` by distance, or -1 (a rank of
    0, the nearest, or none: the drill's own choice at the kick)."""
    out = np.full(len(ranks), -1, dtype=np.int64)
    for i in np.flatnonzero(ranks > 0).tolist():
        out[i] = ranked_teammate(pos[i], player, attackers, int(ranks[i]))
    return out
