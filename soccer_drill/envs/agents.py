"""The drill as PettingZoo AEC and parallel environments: one drill of a
:class:`~soccer_drill.envs.core.BatchCore`, which the batched environments run too."""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping
from types import MappingProxyType
from typing import Any, Literal, TypeVar

import numpy as np
from gymnasium import spaces
from pettingzoo import AECEnv, ParallelEnv
from pettingzoo.utils.env import AECIterable

from soccer_drill.commands import BALL_SKILLS, DEFENDER_ACTIONS, Skill
from soccer_drill.config import DrillConfig
from soccer_drill.constraints import Integer, OneOf, checked, is_int
from soccer_drill.envs.core import (
    ATTACKER_SKILLS,
    DEFENDER_DEFAULT,
    DEFENDER_MASK,
    DEFENDER_SKILLS,
    HOLDER_DEFAULT,
    HOLDER_MASK,
    ILLEGAL_ACTION,
    OFF_BALL_MASK,
    SEED,
    AttackerActions,
    BatchCore,
    IllegalAction,
    Observation,
    ObsType,
    action_list,
    check_reset_options,
    make_config,
    masked_action,
    not_reset,
    observation,
    out_of_range,
    resolve_shared_spaces,
)
from soccer_drill.envs.pickling import Pickled
from soccer_drill.interruptions import short_repr
from soccer_drill.rendering.scene import FrameStyle, Scene
from soccer_drill.rendering.screen import RENDER_MODES, HeaderTexts, Screen, frames_per_second
from soccer_drill.rules.arrays import OUTCOME_NAMES, Outcome
from soccer_drill.rules.features import GLOBAL_STATE
from soccer_drill.rules.motion import ranked_teammate
from soccer_drill.rules.task_rules import cycle_reward
from soccer_drill.teams.registry import DEFAULT_TEAM_TIMEOUT, Team

ObsFormat = Literal["dict", "flat"]
OBS_FORMAT = OneOf(("dict", "flat"))

_METADATA = {
    "render_modes": list(RENDER_MODES),
    "name": "soccer_drill_v0",
    "is_parallelizable": True,
    "render_fps": 10,  # per instance: 1 / cycle_seconds
}
_RUNNING = int(Outcome.RUNNING)  # read once: an enum member's lookup costs about 1 us
_ROLE_FLAG = (np.zeros(1, dtype=np.float32), np.ones(1, dtype=np.float32))  # defender, attacker
_ONE = np.zeros(1, dtype=np.int64)  # the single environment's one drill
_ACTIVE = np.ones(1, dtype=bool)
_T = TypeVar("_T")
for _array in (_ONE, _ACTIVE):
    _array.flags.writeable = False
# The same masks as tuples of bools, for checking an action (indexing a tuple is cheaper).
_HOLDER_LEGAL = tuple(bool(x) for x in HOLDER_MASK)
_OFF_BALL_LEGAL = tuple(bool(x) for x in OFF_BALL_MASK)


def _legal_skills(skills: np.ndarray, legal: tuple[bool, ...]) -> tuple[int | None, ...]:
    """Per action index, its skill value if the mask allows it, else ``None``."""
    return tuple(int(skills[a]) if ok and a < len(skills) else None for a, ok in enumerate(legal))


# command_for's shortcut for a legal action: the skill of each action index, by role.
_HOLDER_SKILLS = _legal_skills(ATTACKER_SKILLS, _HOLDER_LEGAL)
_OFF_BALL_SKILLS = _legal_skills(ATTACKER_SKILLS, _OFF_BALL_LEGAL)


class _DrillEnvBase(HeaderTexts, Pickled):
    """Construction, spaces, observations, action checks, state and rendering common to
    both APIs: one drill of a :class:`~soccer_drill.envs.core.BatchCore`."""

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
        obs_format: ObsFormat,
        shared_spaces: bool | None,
        render_style: FrameStyle | None,
    ) -> None:
        cfg = make_config(config, max_cycles)
        self.metadata = {**_METADATA, "render_fps": frames_per_second(cfg)}  # a frame a cycle
        self._screen = Screen(cfg, render_mode, self.metadata["render_fps"], self._scene,
                              render_style, cfg.player_names)
        self.obs_format = checked("obs_format", obs_format, OBS_FORMAT)
        self.illegal_action = checked("illegal_action", illegal_action, ILLEGAL_ACTION)
        shared_spaces = resolve_shared_spaces(shared_spaces, opponent)
        self._observe = observation(obs_type, cfg)
        self._core = BatchCore(1, opponent, opponent_params, cfg, team_timeout, False, None)
        self._batch = self._core.batch
        self.config = cfg
        self._paid = cycle_reward(cfg)  # the attackers' pay per cycle: keepaway's seconds
        self.render_mode = render_mode
        self.shared_spaces = shared_spaces
        self._flat = obs_format == "flat"
        names, attackers = cfg.player_names, cfg.attackers
        self._attackers = attackers
        actions = self._actions = AttackerActions(attackers)
        self._holder_legal = tuple(bool(x) for x in actions.holder_mask)
        self._off_ball_legal = tuple(bool(x) for x in actions.off_ball_mask)
        self._holder_skills = _legal_skills(actions.skills, self._holder_legal)
        self._off_ball_skills = _legal_skills(actions.skills, self._off_ball_legal)
        self._ranks = tuple(int(r) for r in actions.ranks)
        indices = range(attackers) if opponent is not None else range(cfg.players)
        self.possible_agents = [names[i] for i in indices]
        self._index = {name: names.index(name) for name in self.possible_agents}
        # Every agent's observation in one call: one row per agent (_plain).
        self._agent_players = np.array(list(self._index.values()), dtype=np.int64)
        self._agent_drills = np.zeros(len(self._agent_players), dtype=np.int64)
        for array in (self._agent_players, self._agent_drills):
            array.flags.writeable = False
        self._agent_row = {i: row for row, i in enumerate(self._index.values())}
        # Per agent in order: (name, player, its row of every agent's observation), for
        # the parallel step's loops over every agent (one lookup instead of three each).
        self._agent_rows = tuple((name, i, row) for row, (name, i) in
                                 enumerate(self._index.items()))
        self._seen: np.ndarray | None = None
        self._seen_at = -1  # the drill's steps when _seen was computed
        self._make_spaces(actions, shared_spaces)
        self._features = self._with_role if shared_spaces else self._plain
        self._observation = self._flat_observation if self._flat else self._dict_observation
        self._state = Observation(GLOBAL_STATE, cfg)
        self.state_space = self._state.box
        self.replaced: tuple[int, int] | None = None
        self._has_reset = False
        self._busy_init()

    def _make_spaces(self, actions: AttackerActions, shared_spaces: bool) -> None:
        """Each agent's action and observation space, and the defenders' legal actions."""
        attackers = self._attackers
        box = self._observe.box
        if shared_spaces:  # a trailing role flag tells one shared policy which side it plays
            box = spaces.Box(
                np.append(box.low, 0.0).astype(np.float32),
                np.append(box.high, 1.0).astype(np.float32),
                dtype=np.float32,
            )
        self._defender_mask = actions.shared_defender_mask if shared_spaces else DEFENDER_MASK
        self._defender_legal = tuple(bool(x) for x in self._defender_mask)
        self._defender_skills = _legal_skills(DEFENDER_SKILLS, self._defender_legal)
        self._action_spaces: dict[str, spaces.Discrete] = {}
        self._observation_spaces: dict[str, spaces.Space] = {}
        for name, i in self._index.items():
            n = len(actions.names) if i < attackers or shared_spaces else len(DEFENDER_ACTIONS)
            self._action_spaces[name] = spaces.Discrete(n)
            self._observation_spaces[name] = (
                spaces.Box(box.low, box.high, dtype=np.float32)
                if self._flat
                else spaces.Dict(
                    {
                        "observation": spaces.Box(box.low, box.high, dtype=np.float32),
                        "action_mask": spaces.Box(0, 1, shape=(n,), dtype=np.int8),
                    }
                )
            )

    def __copy__(self):
        """An independent copy continuing the episode (see Copies in :class:`raw_env`)."""
        return copy.deepcopy(self)

    @property
    def observation_spaces(self) -> Mapping[str, spaces.Space]:
        """Every agent's observation space by agent, read-only: the attribute PettingZoo's
        base classes declare, for clients that read it rather than call
        :meth:`observation_space`."""
        return MappingProxyType(self._observation_spaces)

    @property
    def action_spaces(self) -> Mapping[str, spaces.Space]:
        """Every agent's action space by agent, read-only (as :attr:`observation_spaces`)."""
        return MappingProxyType(self._action_spaces)

    def observation_space(self, agent: str) -> spaces.Space:
        """The agent's observation space (see the class docstring); the same object every call."""
        try:
            return self._observation_spaces[agent]
        except (KeyError, TypeError):
            raise self._unknown(agent) from None

    def action_space(self, agent: str) -> spaces.Space:
        """The agent's ``Discrete`` action space (see the class docstring); the same object."""
        try:
            return self._action_spaces[agent]
        except (KeyError, TypeError):
            raise self._unknown(agent) from None

    def _unknown(self, agent: object) -> KeyError:
        """A ``KeyError`` (as a mapping's) naming ``agent`` and the environment's agents."""
        return KeyError(f"{short_repr(agent)} is not an agent of this environment; its agents "
                        f"are {list(self.possible_agents)}")

    def _checked_index(self, agent: object) -> int:
        """The player index of ``agent``, or :meth:`_unknown`'s error."""
        try:
            return self._index[agent]
        except (KeyError, TypeError):
            raise self._unknown(agent) from None

    # ---------------------------------------------------------- observations
    def _plain(self, i: int) -> np.ndarray:
        """Player ``i``'s observation, a new array: a row of every agent's, computed in
        one call once per state of the drill (``BatchDrill.steps``: a cycle, a reset)."""
        return self._every_row()[self._agent_row[i]].copy()

    def _every_row(self) -> np.ndarray:
        """Every agent's observation row of the drill's current state, computed in one
        compiled call at the first need after each cycle or reset (shared: copy a row
        before handing it out)."""
        batch = self._batch
        if self._seen_at != batch.steps:
            self._seen = self._observe.again(batch.state, self._agent_drills,
                                             self._agent_players)
            self._seen_at = batch.steps
        return self._seen

    def _every_observation(self) -> dict[str, Any]:
        """Every agent's observation of the drill's state (every agent is live: the
        parallel step's): one compiled call for all rows, then each row copied into an
        array of its own, and the masks chosen by one read of the holder."""
        if self.shared_spaces:  # the role flag: per agent
            return {a: self._observation(a) for a in self.agents}
        # One copy of every row, each agent handed its own row of it (rows in the
        # agents' order): no agent's array shares memory with another's or the drill's.
        fresh = self._every_row().copy()
        if self._flat:
            return {a: row for (a, _, _), row in zip(self._agent_rows, fresh, strict=True)}
        holder, attackers, actions = int(self._batch.holder[0]), self._attackers, self._actions
        holding, off_ball, defending = (actions.holder_mask, actions.off_ball_mask,
                                        self._defender_mask)
        return {a: {"observation": row,
                    "action_mask": (defending if i >= attackers
                                    else holding if i == holder else off_ball)}
                for (a, i, _), row in zip(self._agent_rows, fresh, strict=True)}

    def _with_role(self, i: int) -> np.ndarray:
        return np.concatenate((self._plain(i), _ROLE_FLAG[i < self._attackers]))

    def _mask(self, i: int) -> np.ndarray:
        if i >= self._attackers:
            return self._defender_mask
        actions = self._actions
        return actions.holder_mask if self._batch.holder[0] == i else actions.off_ball_mask

    def _dict_observation(self, agent: str) -> dict[str, np.ndarray]:
        i = self._index[agent]
        return {"observation": self._features(i), "action_mask": self._mask(i)}

    def _flat_observation(self, agent: str) -> np.ndarray:
        return self._features(self._index[agent])

    def _begin_episode(self, seed: int | None, start: Callable[[], _T]) -> _T:
        """Reseed (``None``: continue the generator) and reset the drill; every agent is
        live; then ``start()``, the API's own start of an episode, whose result it returns.
        A seed that is not ``None`` or an integer >= 0 is refused before anything changes
        (NumPy would take a list as a seed sequence, and word a bad one in its own terms);
        a reset stopped part-way (a Ctrl-C) leaves the environment asking for another
        (:meth:`~soccer_drill.envs.core.BatchCore.changing`)."""
        seed = checked("seed", seed, SEED)

        def begin() -> _T:
            self._core.seed(None if seed is None else [seed])
            self._core.reset(_ONE)
            self.agents = self.possible_agents[:]
            self._has_reset = True
            return start()

        return self._core.changing(f"{type(self).__name__}.reset()", begin, every_drill=True)

    def _require_reset(self, method: str) -> None:
        if not self._has_reset:
            raise not_reset(method)

    def action_mask(self, agent: str) -> np.ndarray:
        """The current action mask of ``agent`` (int8, 1 = legal; read-only)."""
        self._require_reset("action_mask")
        return self._mask(self._checked_index(agent))

    # --------------------------------------------------------------- actions
    def _command(self, agent: str, index: int, action: object) -> None:
        """Check ``action`` of ``agent`` and set it as player ``index``'s command (a masked
        action replaced by the role's default, said in :attr:`replaced`, or refused)."""
        holds = self._batch.holder[0] == index
        attackers, actions = self._attackers, self._actions
        if type(action) is int:  # the common case: a legal plain int
            if index >= attackers:
                legal = self._defender_skills
            else:
                legal = self._holder_skills if holds else self._off_ball_skills
            if 0 <= action < len(legal) and (skill := legal[action]) is not None:
                self._batch.skill[0, index] = skill
                if attackers > 2 and index < attackers:  # as below: the pass's receiver
                    rank = self._ranks[action]
                    self._batch.receiver[0, index] = ranked_teammate(
                        self._batch.pos[0], index, attackers, rank) if rank > 0 else -1
                return
        n = (len(actions.names) if self.shared_spaces or index < attackers
             else len(DEFENDER_ACTIONS))
        if type(action) is not int:
            if isinstance(action, np.ndarray) and action.shape == ():
                action = action.item()
            if not is_int(action):
                raise TypeError(
                    f"action for {agent!r} must be {Integer(0, n - 1).describe()} "
                    f"({action_list(index, n, attackers)}), got {action!r} of type "
                    f"{type(action).__name__}"
                )
        a = int(action)  # type: ignore[call-overload]
        if not 0 <= a < n:
            raise ValueError(out_of_range(agent, index, n, a, attackers))
        if index >= attackers:
            legal_now = self._defender_legal
        else:
            legal_now = self._holder_legal if holds else self._off_ball_legal
        if not legal_now[a]:
            if self.illegal_action == "raise":
                raise ValueError(masked_action(agent, index, n, a, int(self._batch.cycle[0]),
                                               self._mask(index), attackers))
            given = a
            a = ((HOLDER_DEFAULT if holds else actions.off_ball_default) if index < attackers
                 else DEFENDER_DEFAULT)
            self.replaced = (given, a)
        if index >= attackers:
            self._batch.skill[0, index] = DEFENDER_SKILLS[a]
            return
        self._batch.skill[0, index] = actions.skills[a]
        rank = int(actions.ranks[a])
        if attackers > 2:  # a pass to the teammate of its rank now (-1: none, or the nearest)
            self._batch.receiver[0, index] = ranked_teammate(self._batch.pos[0], index,
                                                             attackers, rank) if rank > 0 else -1

    def _step_info(self, agent: str, replaced: tuple[int, int] | None) -> dict[str, Any]:
        """An agent's info while the episode runs: the replaced action, the flat mask."""
        info: dict[str, Any] = {}
        if replaced is not None:
            info["illegal_action"], info["action_taken"] = replaced
        if self._flat:
            info["action_mask"] = self._mask(self._index[agent])
        return info

    def _outcome_info(self) -> dict[str, Any]:
        code = self._batch.outcome[0]
        if code == _RUNNING:
            return {}
        return {"outcome": OUTCOME_NAMES[code], "cycles": int(self._batch.cycle[0])}

    def state(self) -> np.ndarray:
        """The whole drill as ``6 p + 5`` float32 values with ``p`` players (29 in the 2v2
        drill; layout in the class docstring), for critics."""
        self._require_reset("state")
        return self._state(self._batch.state, _ONE, _ONE)[0]

    def render(self) -> np.ndarray | list[np.ndarray] | None:
        """The current frame, the frames since the last call, or ``None`` (see Rendering)."""
        if self.render_mode is None:
            return None
        self._require_reset("render")
        return self._screen.render(self._batch.state_of(0))

    def _after_cycle(self) -> None:
        """A cycle has run: what the render mode does with it (a window, a kept frame)."""
        self._screen.after_cycle(self._batch.state_of(0))

    def close(self) -> None:
        """Close the window, if any."""
        self._screen.close()

    @property
    def scene(self):
        """What a frame shows besides the bodies (a
        :class:`~soccer_drill.rendering.scene.Scene`): the team, the holder's ball skill
        this cycle (PASS over the passer while the ball travels), the outcome and the reward once the episode ends."""
        self._require_reset("scene")
        return self._screen.scene()

    def _scene(self) -> Scene:
        batch, team = self._batch, self._core.team
        code, holder = int(batch.outcome[0]), int(batch.holder[0])
        chooser, choice = -1, None
        passer = int(batch.passer[0])
        if holder >= 0 and batch.cycle[0] > 0 and int(batch.skill[0, holder]) in BALL_SKILLS:
            chooser, choice = holder, Skill(int(batch.skill[0, holder])).name
        elif holder < 0 and passer >= 0:  # a pass on its way: over its passer
            chooser, choice = passer, Skill.PASS.name
        return Scene(team=None if team is None else team.name, chooser=chooser, choice=choice,
                     outcome=OUTCOME_NAMES[code],
                     reward=None if code == _RUNNING else float(batch.attacker_reward[0]))

    @property
    def drill_state(self):
        """The current :class:`~soccer_drill.state.DrillState` (positions, holder, cycle)."""
        self._require_reset("drill_state")
        return self._batch.state_of(0)

    @property
    def outcome(self) -> str | None:
        """``None`` while the episode runs, then its outcome."""
        return OUTCOME_NAMES[self._batch.outcome[0]]

    @property
    def np_random(self) -> np.random.Generator:
        """The drill's generator (seeded by ``reset(seed=...)``), as PettingZoo's own
        environments expose theirs: wrappers that draw from it (SuperSuit's
        ``frame_skip_v0``) then follow the environment's seed."""
        return self._core.generators[0]


class raw_env(_DrillEnvBase, AECEnv):
    """The 2v2 soccer drill of the ILPSS paper, as a PettingZoo AEC environment.

    Two attackers try to carry the ball across the goal line (the bottom edge of a
    35 m x 35 m region); two defenders try to win it. Bodies are pymunk circles;
    one cycle is 0.1 s of simulated time, advanced after every agent has acted.

    ## Agents

    ``attacker_0``, ``attacker_1``, ``defender_0``, ``defender_1``: every player
    that no scripted team drives. With ``opponent="<team id>"`` the defenders are
    scripted and only the attackers are agents. All agents act once per cycle, in
    that order.

    ## Other sizes

    With ``config=DrillConfig(attackers=A, defenders=D)`` (1 to 4 each) the agents are
    ``attacker_0 .. attacker_{A-1}`` and ``defender_0 .. defender_{D-1}``; an attacker
    has ``A + 3`` actions: ``HOLD``, a ``PASS`` to each teammate, nearest first
    (``PASS`` at 2v2, else ``PASS_1`` ...), ``DRIBBLE`` (ball holder only), ``GET_OPEN``,
    ``GO_TO_BALL`` (off the ball only); a defender its three (padded to ``A + 3`` with
    shared spaces). The features have room for the larger team on both sides (``5 max(A,
    D) - 1`` values, a slot with nobody in it reading 0), the kinematic observation ``4
    (A + D) + 10`` values (teammates, then opponents, then the ball), the full one both
    and the time left, ``state()`` ``6 (A + D) + 5`` values (:mod:`soccer_drill.rules.features`).
    Named scenarios: :mod:`soccer_drill.scenarios`.

    ## Spaces shared or per role

    Every agent has the same action and observation spaces by default, the PettingZoo
    convention that SuperSuit's vector environments, Tianshou's ``PettingZooEnv`` and
    one shared policy need: with no opponent (``shared_spaces=None`` means ``True``
    then) a defender gets the attackers' ``Discrete(5)`` with its last two actions
    always masked, and every observation ends with a role flag (1 attacker, 0
    defender); with an opponent the two attackers' spaces are identical anyway
    (``None`` means ``False``). ``shared_spaces=False`` gives the per-role spaces
    (defenders ``Discrete(3)``, no role flag), e.g. for one module per role.

    ## Action space

    | agent | space | actions |
    |-------|-------|---------|
    | attacker | ``Discrete(5)`` | 0 HOLD, 1 PASS, 2 DRIBBLE (ball holder only), 3 GET_OPEN, 4 GO_TO_BALL (off the ball only) |
    | defender (shared spaces: the default with no opponent) | ``Discrete(5)`` | 0 INTERCEPT, 1 MARK, 2 GUARD_LINE (always legal); 3 and 4 always masked |
    | defender, ``shared_spaces=False`` | ``Discrete(3)`` | 0-2 as above |

    ## Illegal (masked) actions

    The action mask (``observation["action_mask"]``, or ``infos[agent]["action_mask"]``
    and :meth:`action_mask` with ``obs_format="flat"``; int8, 1 = legal) says which
    actions are legal now. With the default ``illegal_action="default"`` a masked
    action is replaced by the role's default action (HOLD for the holder, GET_OPEN off
    the ball, INTERCEPT for a defender) and the replacement is reported:
    ``infos[agent]`` then holds ``"illegal_action"`` (the action given) and
    ``"action_taken"`` (the action applied). In the AEC API that info stays until the
    agent's next turn, so ``last()`` shows it; in the parallel API it is in the infos
    ``step`` returns. With ``illegal_action="raise"`` a masked action raises
    ``ValueError`` naming the agent, the action, the legal ones and this option.

    Why replacement is the default: PettingZoo's own tests (``parallel_seed_test``,
    ``max_cycles_test``) and the usual training pipelines (SuperSuit's vector
    environments feeding Stable-Baselines3) sample actions without masks, and they must
    run unmodified. Ending the episode with a penalty, as PettingZoo's classic board
    games do (``TerminateIllegalWrapper``), would cut every such episode short in its
    first cycle (``max_cycles_test`` fails); an error stops them outright. Replacing the
    action keeps the episode's physics meaningful and the substitution visible.

    ## Observation space

    | ``obs_format`` | observation | action mask |
    |----------------|-------------|-------------|
    | ``"dict"`` (default) | ``Dict(observation=Box, action_mask=Box(0, 1, (n,), int8))`` | in the observation |
    | ``"flat"`` | the ``Box`` alone (for SB3's ``MlpPolicy``, SuperSuit) | ``infos[agent]["action_mask"]`` (current at the agent's turn) and ``action_mask(agent)`` |

    | ``obs_type`` | ``Box`` | what it holds |
    |--------------|---------|---------------|
    | ``"features"`` (default) | ``(9,)`` | the paper's 9 features from the agent's point of view (table in :mod:`soccer_drill.rules.features`): distances and passing and dribbling lanes; no ball, no possession |
    | ``"kinematic"`` | ``(26,)`` | self's position and velocity; mate's, opponents' and the ball's relative to self (a relative velocity clipped at the larger of the ball's and a player's top speed: :func:`~soccer_drill.rules.features.kinematic_bounds`); flags: self, mate or an opponent holds the ball, the ball is loose, self is an attacker, self may not take the ball back yet |
    | ``"full"`` | ``(36,)`` | ``"kinematic"``, then the 9 features, then the time left (``1 - cycle / max_cycles``) |

    Which one to learn from (MAPPO on the attackers, development seed 1000, 1,000,000
    steps, greedy success on 200 held-out episodes; ``docs/reference_rl.md``):

    | ``obs_type`` | against ``interceptors_press`` | against ``goal_guards`` |
    |--------------|-------------------------------|-------------------------|
    | ``"features"`` | 54% | |
    | ``"kinematic"`` | | 57.5-60% |
    | ``"full"`` | 96% | 65.5% (87% at 2,000,000 steps) |

    The 9 features hold no ball and no possession, so an off-ball attacker cannot see a
    loose ball; the kinematic vector holds the passing lanes only implicitly. The default stays
    the paper's features, so that the recorded episodes and the holder's view are
    unchanged; multi-agent learners should ask for ``obs_type="full"``. With shared
    spaces (the default with no opponent) one more value ends each observation: 1 for
    an attacker, 0 for a defender, so that one shared policy knows which side it plays.

    PettingZoo's ``api_test`` warns "Observation is not a NumPy array" and
    "Observation space for each agent probably should be gymnasium.spaces.box or
    gymnasium.spaces.discrete" for the default ``Dict`` observation, as for
    PettingZoo's classic games; ``obs_format="flat"`` removes both. With
    ``shared_spaces=False`` and defenders as agents it also warns "Agents have
    different observation space sizes" (their masks have 3 entries, the attackers' 5).

    ## Global state

    ``state()`` returns the whole drill, ``6 p + 5`` float32 values with ``p`` players
    (29 in the 2v2 drill) in ``state_space`` (positions and velocities of the players and
    the ball in field coordinates, holder and passer flags, elapsed fraction of
    ``max_cycles``; layout in
    :func:`soccer_drill.rules.features.global_state_into`), for centralised critics.

    ## Rewards

    Zero until the last cycle. Then, for the attackers:

    | outcome | reward |
    |---------|--------|
    | success (an attacker in possession takes the ball over the goal line) | 1.0 at the line centre, falling linearly to 0.5 at its ends |
    | interception (a defender gains possession) | -1 |
    | out (the ball leaves the region) | -1 |
    | timeout (``max_cycles`` cycles pass) | -1 |

    Defenders receive the negation (zero-sum). All values are configurable in
    :class:`~soccer_drill.config.DrillConfig`. In keepaway (``DrillConfig(task=
    "keepaway")``) every cycle pays the attackers (the keepers) its ``cycle_seconds`` and
    the defenders (the takers) its negation, and the end pays nothing more: an episode's
    return is its length; the agents keep the drill's actions (a keeper may dribble).

    ## Episode end

    Success, interception and out terminate; timeout truncates. The outcome is judged
    after each cycle in that order (interception, success, out, timeout), so a defender
    who wins the ball on the last cycle makes it an interception, not a timeout. Every agent then
    has ``terminations`` (or ``truncations``) set, receives ``infos[agent]`` with
    ``"outcome"`` and ``"cycles"``, must be stepped with ``None`` and is
    removed, so ``agents`` is empty at the end.

    ## Seeding

    ``reset(seed=s)`` makes the episode a function of ``s`` and the actions alone:
    observations, rewards, terminations, truncations and infos are bit-identical to
    those of a fresh environment's ``reset(seed=s)`` with the same actions, whatever
    episodes ran before (the physics space is rebuilt on every reset), for every team that
    draws only from the generator it is given (a team drawing from ``np.random`` or
    ``random`` makes its episodes depend on those too).
    ``reset()`` without a seed continues the environment's generator, so a sequence of
    episodes after one seeded reset is reproducible too. The scripted team and the
    support player draw from their own generators, seeded from the drill's at each
    reset, so a team's draws never change the physics noise. Rendering changes nothing.

    ## Copies

    ``copy.deepcopy``, ``copy.copy`` and ``pickle`` all give an independent environment
    that continues the episode where the original is: the same drill state, agents,
    turn, generators and team, so the same actions give bit-identical steps in both,
    and stepping one never moves the other (``copy.copy`` copies deeply too: a copy
    sharing the physics engine would be two environments stepping one drill). A copy
    of an environment never reset is one never reset. Windows and renderers are not
    copied: a copy draws with its own. The scripted team is copied with the rest, so a
    ``Team`` instance given as ``opponent`` must be picklable for ``pickle``. A pickle is
    for the code that made it: another version of ``soccer_drill`` refuses it, naming
    both.

    ## Rendering

    | ``render_mode`` | ``render()`` returns |
    |-----------------|----------------------|
    | ``"rgb_array"`` | the current frame, ``(H, W, 3)`` uint8 (in the AEC API the same frame at every turn of a cycle) |
    | ``"rgb_array_list"`` | every frame since the last ``render()`` (or ``reset``): one per cycle, so a video written at ``metadata["render_fps"]`` plays at true speed |
    | ``"human"`` | ``None``; a window shows every cycle at ``metadata["render_fps"]`` frames per second |

    A frame shows the team, :attr:`policy_name`, :attr:`score_text` and :attr:`caption` if
    set, the cycle and the time left, each player's role, the holder
    and the ball skill it was given, short trails, the goal line shaded by its reward, a
    legend and, at the end, the outcome and the reward (:attr:`scene` holds these facts;
    ``render_style``, a :class:`~soccer_drill.rendering.scene.FrameStyle`, turns each part
    off). ``metadata["render_fps"]`` is ``1 / cycle_seconds`` (10 by default): one frame per
    cycle is true speed. Calling ``render()`` in ``"rgb_array"`` mode after every AEC
    turn gives one frame per agent and cycle; ``"rgb_array_list"`` gives one per cycle
    whichever API and however often ``render()`` is called.

    ## Threads

    One environment must be stepped by one thread at a time: a ``step`` or ``reset``
    that starts while another thread is inside one raises ``RuntimeError`` (the
    physics engine is not thread-safe). Separate environments in separate threads are
    fine.

    A ``step`` or ``reset`` stopped part-way (a Ctrl-C, a team's error) may leave the
    drill part-way through a cycle or a reset: every later ``step`` then raises
    ``RuntimeError`` naming that call and saying to call ``reset()``, which brings the
    drill back as in a new environment. A call refused while its arguments are checked
    changes nothing.

    ## Arguments

    | argument | default | meaning |
    |----------|---------|---------|
    | ``opponent`` | ``None`` | team id (see ``soccer-drill-teams``), a ``Team`` instance, or ``None`` (defenders are agents); an instance another live environment plays already is copied (``copy.deepcopy``), so that each environment plays its own |
    | ``opponent_params`` | ``None`` | keyword parameters of the team factory (with a team id; refused with an instance) |
    | ``obs_type`` | ``"features"`` | a kind of observation of ``soccer_drill.rules.features.OBSERVATION_TYPES``: ``"features"``, ``"kinematic"`` or ``"full"`` (see Observation space) |
    | ``max_cycles`` | ``None`` | overrides ``config.max_cycles`` (default 100) |
    | ``config`` | ``None`` | a ``DrillConfig`` or a dict of its fields |
    | ``render_mode`` | ``None`` | ``"human"``, ``"rgb_array"`` or ``"rgb_array_list"`` (see Rendering) |
    | ``render_style`` | ``None`` | what a frame draws, a ``FrameStyle`` (``None``: everything, 640 pixels wide) |
    | ``illegal_action`` | ``"default"`` | ``"default"`` (replace a masked action by the role's default, reported in infos) or ``"raise"`` (a masked action is an error) |
    | ``team_timeout`` | ``1.0`` | seconds of CPU time each ``reset``/``act`` call of the scripted team may take before it is stopped with ``TeamError`` naming it (time spent waiting, e.g. on a loaded machine, is not counted); ``None``: no bound. See ``soccer_drill.teams.driver.TeamDriver`` |
    | ``obs_format`` | ``"dict"`` | ``"dict"`` (observation and mask together) or ``"flat"`` (a ``Box``; the mask in infos and ``action_mask()``) |
    | ``shared_spaces`` | ``None`` | ``None``: identical spaces for every agent (``True`` with no opponent, ``False`` with one, whose attackers' spaces are identical anyway); ``True``: always a role flag and ``A + 3`` actions (5 in the 2v2 drill); ``False``: per-role spaces (see Spaces shared or per role) |

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
        illegal_action: IllegalAction = "default",
        team_timeout: float | None = DEFAULT_TEAM_TIMEOUT,
        obs_format: ObsFormat = "dict",
        shared_spaces: bool | None = None,
        render_style: FrameStyle | None = None,
    ) -> None:
        AECEnv.__init__(self)
        self._setup(
            opponent, opponent_params, obs_type, max_cycles, config, render_mode, illegal_action,
            team_timeout, obs_format, shared_spaces, render_style,
        )
        self.agents: list[str] = []

    def reset(self, seed: int | None = None, options: dict | None = None) -> None:
        """Start an episode; ``seed`` reseeds the drill (see Seeding in the class docstring).
        ``options``: ``None`` or a dict, whose keys it ignores (it takes none; PettingZoo's
        API test passes some)."""
        check_reset_options(options, None, "raw_env.reset")
        with self._claim("reset"):
            self._begin_episode(seed, self._first_turn)
        if self._screen.each_cycle:
            self._screen.start(self._batch.state_of(0))

    def _first_turn(self) -> None:
        """The new episode's rewards, ends and infos, and the first agent's turn."""
        self.rewards = dict.fromkeys(self.agents, 0.0)
        self._cumulative_rewards = dict.fromkeys(self.agents, 0.0)
        self.terminations = dict.fromkeys(self.agents, False)
        self.truncations = dict.fromkeys(self.agents, False)
        self.infos = {agent: self._step_info(agent, None) for agent in self.agents}
        self._reported: set[str] = set()  # agents whose info reports a replaced action
        # The turn order (PettingZoo's AgentSelector, as a lookup): every live agent
        # in order, the cycle advancing after the last.
        order = self.agents
        self._next_agent = dict(zip(order, order[1:] + order[:1], strict=True))
        self._last_agent = order[-1]
        self.agent_selection = order[0]

    def agent_iter(self, max_iter: int = 2**63) -> AECIterable:
        """The agents in turn until every one is done (or ``max_iter`` turns), as
        ``AECEnv.agent_iter``; before the first ``reset()``, ``RuntimeError`` (as
        PettingZoo's ``OrderEnforcingWrapper`` refuses it) rather than no turn at all."""
        if not self._has_reset:
            raise not_reset("agent_iter")
        return super().agent_iter(max_iter)

    def observe(self, agent: str) -> dict[str, np.ndarray] | np.ndarray:
        """The observation of ``agent`` (see the class docstring)."""
        if not self._has_reset:
            raise not_reset("observe")
        self._checked_index(agent)
        return self._observation(agent)

    def last(self, observe: bool = True):
        """``(observation, reward, termination, truncation, info)`` of the selected agent."""
        if not self._has_reset:
            raise not_reset("last")
        if not self.agents:  # every agent has been stepped out: nothing is selected
            raise RuntimeError("last() called after the episode ended (every agent is done); "
                               "call reset() to start the next one")
        agent = self.agent_selection
        return (
            self._observation(agent) if observe else None,  # observe() without its check
            self._cumulative_rewards[agent],
            self.terminations[agent],
            self.truncations[agent],
            self.infos[agent],
        )

    def action_mask(self, agent: str | None = None) -> np.ndarray:
        """The current action mask of ``agent`` (default: the selected agent; int8, read-only)."""
        if not self._has_reset:
            raise not_reset("action_mask")
        return super().action_mask(self.agent_selection if agent is None else agent)

    def step(self, action: int | None) -> None:
        """Act for the selected agent; the cycle advances after the last one (see the class docstring)."""
        with self._claim("step"):
            self._step(action)

    def _step(self, action: int | None) -> None:
        if not self._has_reset:
            raise not_reset("step")
        agent = self.agent_selection
        if not self.agents:
            raise RuntimeError("step() called after the episode ended; call reset()")
        self._core.check_usable()  # refused before the action changes anything
        if self.terminations[agent] or self.truncations[agent]:
            if action is not None:
                raise ValueError(
                    f"{agent!r} is done (the episode ended); it must be stepped with None, "
                    f"got {action!r}"
                )
            self._was_dead_step(action)
            return
        self._command(agent, self._index[agent], action)
        if self.replaced is not None:
            self.infos[agent] = self._step_info(agent, self.replaced)
            self._reported.add(agent)
            self.replaced = None
        elif agent in self._reported:  # its previous action was replaced; this one is not
            self.infos[agent] = self._step_info(agent, None)
            self._reported.discard(agent)
        self._cumulative_rewards[agent] = 0.0
        if self._paid:  # a step pays only when it ends a cycle (keepaway's seconds)
            self._clear_rewards()
        if agent == self._last_agent:
            self._core.changing("raw_env.step()", self._end_cycle)
            if self._screen.each_cycle:
                self._after_cycle()
        self.agent_selection = self._next_agent[agent]

    def _end_cycle(self) -> None:
        """The cycle every agent has acted in: run, and its rewards, ends and infos set."""
        self._core.advance(_ACTIVE, _ONE)
        if self._paid:  # keepaway: every cycle pays its seconds, the takers lose them
            for name in self.agents:
                self.rewards[name] = (self._paid if self._index[name] < self._attackers
                                      else -self._paid)
        if self._batch.outcome[0] != _RUNNING:
            reward = float(self._batch.attacker_reward[0])
            if self._paid:
                reward += self._paid
            info = self._outcome_info()
            done = info["outcome"] != "timeout"
            for name in self.agents:
                self.rewards[name] = (reward if self._index[name] < self._attackers
                                      else -reward)
                self.terminations[name] = done
                self.truncations[name] = not done
                self.infos[name] = {**self.infos[name], **info}
            # The only cycle with rewards: before it they are all zero, so clearing
            # and accumulating them on every step would change nothing.
            self._accumulate_rewards()
        elif self._paid:
            self._accumulate_rewards()
        if self._flat:  # masks change with possession (also in the cycle that ends it)
            for name in self.agents:
                self.infos[name]["action_mask"] = self._mask(self._index[name])


def env(**kwargs: Any) -> raw_env:
    """The AEC drill as users should call it (checks built in; see :class:`raw_env`)."""
    return raw_env(**kwargs)


class parallel_env(_DrillEnvBase, ParallelEnv):
    """The drill as a PettingZoo parallel environment: all agents act each cycle.

    Spaces, illegal actions, rewards, episode end, global state, seeding, copies,
    rendering, threads and arguments are those of :class:`raw_env`. ``step`` takes one action per live agent;
    a missing, extra or out-of-range action raises ``ValueError`` naming the agent, and
    a masked one is replaced (reported in the returned infos) or raises, as
    ``illegal_action`` says. After the step that ends the episode, ``agents`` is empty.
    """

    def __init__(
        self,
        opponent: str | Team | None = None,
        opponent_params: Mapping[str, Any] | None = None,
        obs_type: ObsType = "features",
        max_cycles: int | None = None,
        config: DrillConfig | Mapping[str, Any] | None = None,
        render_mode: str | None = None,
        illegal_action: IllegalAction = "default",
        team_timeout: float | None = DEFAULT_TEAM_TIMEOUT,
        obs_format: ObsFormat = "dict",
        shared_spaces: bool | None = None,
        render_style: FrameStyle | None = None,
    ) -> None:
        self._setup(
            opponent, opponent_params, obs_type, max_cycles, config, render_mode, illegal_action,
            team_timeout, obs_format, shared_spaces, render_style,
        )
        self.agents: list[str] = []

    def reset(
        self, seed: int | None = None, options: dict | None = None
    ) -> tuple[dict[str, Any], dict[str, dict]]:
        """Start an episode; ``seed`` reseeds the drill (see Seeding in :class:`raw_env`).
        ``options``: ``None`` or a dict, whose keys it ignores (it takes none; PettingZoo's
        API test passes some)."""
        check_reset_options(options, None, "parallel_env.reset")
        with self._claim("reset"):
            result = self._begin_episode(seed, lambda: (
                {a: self._observation(a) for a in self.agents},
                {a: self._step_info(a, None) for a in self.agents},
            ))
        if self._screen.each_cycle:
            self._screen.start(self._batch.state_of(0))
        return result

    def step(self, actions: Mapping[str, int]):
        """One cycle with one action per live agent (see the class docstring)."""
        with self._claim("step"):
            result = self._step(actions)
        if self._screen.each_cycle:
            self._after_cycle()
        return result

    def _step(self, actions: Mapping[str, int]):
        if not self._has_reset:
            raise not_reset("step")
        self._core.check_usable()  # a call stopped part-way, or the team's error
        if not self.agents:
            raise RuntimeError("step() called after the episode ended; call reset()")
        if not (type(actions) is dict or isinstance(actions, Mapping)) or (
            actions.keys() != set(self.agents)  # a keys view compares as a set
        ):
            got = sorted(actions) if isinstance(actions, Mapping) else type(actions).__name__
            raise ValueError(
                f"actions must be a mapping with one action per live agent {self.agents}, "
                f"got {got}"
            )
        replaced: dict[str, tuple[int, int]] = {}
        batch, attackers = self._batch, self._attackers
        skill, holder = batch.skill, int(batch.holder[0])
        legal_holding, legal_off_ball, legal_defending = (
            self._holder_skills, self._off_ball_skills, self._defender_skills)
        ranks = self._ranks
        for agent, i, _ in self._agent_rows:
            action = actions[agent]
            # _command's shortcut for a legal plain int, inlined: one loop over the
            # agents with what they share read once
            if type(action) is int:
                legal = (legal_defending if i >= attackers
                         else legal_holding if i == holder else legal_off_ball)
                if 0 <= action < len(legal) and (chosen := legal[action]) is not None:
                    skill[0, i] = chosen
                    if attackers > 2 and i < attackers:  # a pass's receiver by rank now
                        rank = ranks[action]
                        batch.receiver[0, i] = ranked_teammate(
                            batch.pos[0], i, attackers, rank) if rank > 0 else -1
                    continue
            self._command(agent, i, action)
            if self.replaced is not None:
                replaced[agent], self.replaced = self.replaced, None
        return self._core.changing("parallel_env.step()", lambda: self._cycle(replaced))

    def _cycle(self, replaced: dict[str, tuple[int, int]]):
        """The cycle of the actions set: run, and what ``step`` returns."""
        self._core.advance(_ACTIVE, _ONE)
        agents = self.agents
        obs = self._every_observation()
        if replaced or self._flat:
            infos = {a: self._step_info(a, replaced.get(a)) for a in agents}
        else:
            infos = {a: {} for a in agents}
        paid = self._paid  # keepaway's seconds per cycle; 0 in the drill
        if self._batch.outcome[0] == _RUNNING:
            pays = ({a: paid if self._index[a] < self._attackers else -paid for a in agents}
                    if paid else dict.fromkeys(agents, 0.0))  # (never a -0.0 in the drill)
            falses = dict.fromkeys(agents, False)
            return obs, pays, falses, dict(falses), infos
        reward = float(self._batch.attacker_reward[0])
        if paid:
            reward += paid
        info = self._outcome_info()
        done = info["outcome"] != "timeout"
        rewards = {a: reward if self._index[a] < self._attackers else -reward for a in agents}
        for a in agents:
            infos[a].update(info)
        self.agents = []
        return obs, rewards, dict.fromkeys(agents, done), dict.fromkeys(agents, not done), infos
