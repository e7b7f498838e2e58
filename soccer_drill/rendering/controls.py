"""What the player of ``soccer-drill-play`` controls: one adapter per kind of control, found
by name in :data:`CONTROLS`, each driving its environment for the one play loop of
:mod:`soccer_drill.rendering.play`.

| control | environment | you decide | the other attackers |
|---|---|---|---|
| ``holder`` (default) | ``HolderEnv``, the holder's SMDP | for whichever attacker holds the ball: HOLD, a PASS per teammate, DRIBBLE | the support behaviour |
| ``attacker`` | the scenario's PettingZoo drill (``soccer_drill.scenarios.parallel_env``) | for one attacker agent, on the ball and off it: its actions, those its action mask allows now | a scripted attack's holder rule on the ball (``soccer_drill.attacks``); off the ball, chasing a loose ball no free mate is nearer to, else GET_OPEN |

Either plays any named scenario (:mod:`soccer_drill.scenarios`: the paper's 2v2 drill by
default, 1v1, 3v2, 3v3).

In both a decision lasts ``decision_cycles`` cycles (HOLD, DRIBBLE, and off the ball
GET_OPEN, GO_TO_BALL) or one kick (PASS), cut short when it can no longer go on: in the
holder's SMDP when the holder loses the ball, with ``attacker`` control whenever your
attacker's action mask changes (it gains or loses the ball). The drill then waits for your
next key. A key whose action is masked now is refused with a message naming the legal
ones, and the drill goes on waiting.

An adapter has ``env`` (rendering in a window: its ``caption``, ``policy_name`` and
``score_text`` are drawn in the header), ``keys`` (key code to action), ``title`` (the
window's title: whom you play and the keys), and ``start(seed)``, ``prompt()``,
``refusal(action)`` and ``act(action)`` (:class:`Control`).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple, Protocol

import numpy as np

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import pygame  # after the prompt is hidden

from soccer_drill.commands import (
    SKILL_LETTERS,
    Skill,
    action_letters,
    attacker_action_names,
    attacker_action_skills,
    holder_action_names,
)
from soccer_drill.config import DrillConfig
from soccer_drill.constraints import NoneOr, OneOf, Text, check_fields, checked
from soccer_drill.envs.holder import DECISION_CYCLES, check_holder_action
from soccer_drill.rendering.draw import roles
from soccer_drill.rules.features import holder_feature_indices
from soccer_drill.scenarios import SCENARIOS, holder_env, parallel_env, scenario
from soccer_drill.state import DrillState
from soccer_drill.teams.registry import TEAMS
from soccer_drill.vector.attack import ATTACKS, make_attack

SKILL_KEYS = {skill: ord(letter) for skill, letter in SKILL_LETTERS.items()}
"""The key code of each action's skill letter (:data:`~soccer_drill.commands.SKILL_LETTERS`:
pygame's codes of letters and digits are their characters' code points)."""
DEFAULT_ATTACK = "late_pass"
"""The scripted attack playing the other attackers by default: the one fixed holder rule
that succeeds in at least 70% of episodes against each of the four paper teams
(``docs/opponents.md``)."""
_LABEL = NoneOr(Text())
_ONE = np.zeros(1, dtype=np.int64)  # an attack's one drill


@dataclass(frozen=True)
class PlaySetup:
    """What a session of ``soccer-drill-play`` plays.

    | field | default | meaning |
    |---|---|---|
    | ``team`` | ``"goal_guards"`` | the defending team's id (``soccer-drill-teams`` lists them) |
    | ``scenario`` | ``"drill_2v2"`` | a name of :data:`~soccer_drill.scenarios.SCENARIOS`: the drill's size |
    | ``control`` | ``"holder"`` | a name of :data:`CONTROLS`: ``"holder"`` or ``"attacker"`` |
    | ``player`` | ``None`` | ``attacker`` control: the agent you play, one of the drill's ``possible_agents`` (``None``: the first, ``attacker_0``) |
    | ``attack`` | ``None`` | ``attacker`` control: the id of the scripted attack (``soccer_drill.attacks``) playing the other attackers (``None``: :data:`DEFAULT_ATTACK`) |
    | ``decision_cycles`` | 4 | the cycles a decision lasts, at most (a PASS: one kick) |
    """

    team: str = "goal_guards"
    control: str = "holder"
    scenario: str = "drill_2v2"
    player: str | None = None
    attack: str | None = None
    decision_cycles: int = 4

    def __post_init__(self) -> None:
        check_fields("PlaySetup", self, {
            "control": OneOf(tuple(CONTROLS)), "scenario": OneOf(tuple(SCENARIOS)),
            "player": _LABEL, "attack": _LABEL,
            "decision_cycles": DECISION_CYCLES,
        })
        TEAMS.check("PlaySetup.team", self.team)
        if self.attack is not None:
            ATTACKS.check("PlaySetup.attack", self.attack)


class Ended(NamedTuple):
    """How an episode ended: its outcome and the attackers' reward."""

    outcome: str
    reward: float


class Control(Protocol):
    """What the play loop asks of a kind of control (see the module docstring)."""

    env: Any
    keys: Mapping[int, int]
    title: str

    def start(self, seed: int) -> None:
        """Begin an episode on ``seed``."""

    def prompt(self) -> str:
        """What to press now."""

    def refusal(self, action: int) -> str | None:
        """Why ``action`` may not be taken now (``None``: it may)."""

    def act(self, action: int) -> Ended | None:
        """Take ``action``; run the drill until the next decision (``None``) or the end."""


def action_keys(actions: Sequence[Skill]) -> dict[int, int]:
    """Key code to action index for a space of ``actions`` (their skills, in index order):
    :func:`~soccer_drill.commands.action_letters`, as pygame's key codes."""
    return {ord(key): i for key, i in action_letters(actions).items()}


def key_text(actions: Sequence[Skill], names: Sequence[str],
             which: Sequence[int] | None = None) -> str:
    """``"H hold, P pass, ..."``: the key of each of ``actions`` (those of ``which`` only),
    its letter if it has one, else its digit, and its name (``names``, in index order)."""
    letters = {i: code for code, i in action_keys(actions).items()
               if code in SKILL_KEYS.values()}
    which = range(len(actions)) if which is None else which
    return ", ".join(
        f"{pygame.key.name(letters[i]).upper() if i in letters else i + 1} "
        f"{names[i].lower().replace('_', ' ')}" for i in which)


class HolderControl:
    """You decide for the ball holder in ``HolderEnv``; every decision is always legal."""

    def __init__(self, setup: PlaySetup) -> None:
        if setup.player is not None or setup.attack is not None:
            raise ValueError(
                "player and attack apply to control 'attacker' only (control 'holder' "
                "decides for whichever attacker holds the ball; the support behaviour "
                f"moves the other), got player={setup.player!r}, attack={setup.attack!r}")
        self.env = holder_env(setup.scenario, opponent=setup.team, render_mode="human",
                              decision_cycles=setup.decision_cycles)
        self.env.policy_name = "you (keyboard)"
        attackers = scenario(setup.scenario).attackers
        names = holder_action_names(attackers)
        actions = attacker_action_skills(attackers)[:len(names)]
        self.keys = action_keys(actions)
        self._prompt = f"your move: {key_text(actions, names)}"
        self.title = (f"soccer-drill-play: you decide for the ball holder against "
                      f"{setup.team} ({key_text(actions, names)}; Esc stops)")

    def start(self, seed: int) -> None:
        self.env.reset(seed=seed)

    def prompt(self) -> str:
        return self._prompt

    def refusal(self, action: int) -> str | None:
        return None

    def act(self, action: int) -> Ended | None:
        _, reward, terminated, truncated, info = self.env.step(action)
        return Ended(info["outcome"], float(reward)) if terminated or truncated else None


class RuleAttacker:
    """An attacker agent of the PettingZoo drill played by a scripted attack.

    Holding the ball with no decision running, it asks the attack (``decide`` on the
    holder's features, as :class:`~soccer_drill.vector.attack.ScriptedAttack` does) and
    keeps the decision ``decision_cycles`` cycles (a PASS: one), cut short when it loses
    the ball. Off the ball it chases a loose ball when no other attacker that may take it
    (not the passer while locked out) is nearer, else takes GET_OPEN: the support
    behaviour's choice (:mod:`soccer_drill.rules.support`) in the agent's actions.

    Parameters
    ----------
    attack
        An attack (``reset(drills, seeds)``, ``decide(drills, features)``), for one drill.
    agent
        The agent it plays.
    config
        The drill's :class:`~soccer_drill.config.DrillConfig` (its players and size).
    decision_cycles
        The cycles a HOLD or DRIBBLE lasts.
    """

    def __init__(self, attack: Any, agent: str, config: DrillConfig,
                 decision_cycles: int) -> None:
        self.attack, self.agent, self.decision_cycles = attack, agent, decision_cycles
        names, self.attackers = config.player_names, config.attackers
        self.index = names.index(agent)
        self.others = tuple(i for i in range(self.attackers) if i != self.index)
        self.skills = attacker_action_skills(self.attackers)
        self.holder_view = holder_feature_indices(config)
        self.action, self.left = 0, 0

    def reset(self, seed: int) -> None:
        """A new episode: the attack draws from a generator of ``seed``."""
        self.attack.reset(_ONE, [seed])
        self.action, self.left = 0, 0

    def act(self, observation: np.ndarray, state: DrillState) -> int:
        """The action this cycle, given the agent's features (``obs_type="features"``)
        and the drill's state."""
        if state.holder != self.index:
            self.left = 0
            wanted = Skill.GO_TO_BALL if self._chases(state) else Skill.GET_OPEN
            return self.skills.index(wanted)
        if self.left == 0:
            features = np.asarray(observation)[self.holder_view]
            decided = np.asarray(self.attack.decide(_ONE, features[None, :]))
            if decided.shape != (1,):
                raise ValueError(f"attack {self.attack!r}: decide() returned shape "
                                 f"{decided.shape}, expected (1,): one action for one drill")
            self.action = check_holder_action(decided[0], self.attackers)
            self.left = 1 if self.skills[self.action] is Skill.PASS else self.decision_cycles
        self.left -= 1
        return self.action

    def _chases(self, state: DrillState) -> bool:
        if state.holder >= 0:
            return False
        mine = state.distance(self.index, len(state.pos) - 1)
        return not any(state.distance(i, len(state.pos) - 1) < mine for i in self.others
                       if not (i == state.passer and state.cycle < state.lockout_until))


class AttackerControl:
    """You play one attacker agent of the scenario's PettingZoo drill (every attacker is
    an agent there, the defenders the ``team``); a scripted attack plays the others."""

    def __init__(self, setup: PlaySetup) -> None:
        env = parallel_env(setup.scenario, opponent=setup.team, render_mode="human",
                           illegal_action="raise")
        agents = tuple(env.possible_agents)
        try:
            player = checked("player", agents[0] if setup.player is None else setup.player,
                             OneOf(agents), f"the agents of the drill against {setup.team}")
        except ValueError:
            env.close()
            raise
        attack = DEFAULT_ATTACK if setup.attack is None else setup.attack
        config = env.config
        self.env, self.player, self.decision_cycles = env, player, setup.decision_cycles
        self.index = config.player_names.index(player)
        self.actions = attacker_action_skills(config.attackers)
        self.names = attacker_action_names(config.attackers)
        self.keys = action_keys(self.actions)
        self.mates = {a: RuleAttacker(make_attack(attack), a, config, setup.decision_cycles)
                      for a in agents if a != player}
        role = dict(zip(config.player_names, roles(config.player_names), strict=True))
        self.role = role[player]
        mates = ", ".join(f"{role[a]} {attack}" for a in self.mates)
        env.policy_name = f"you {self.role}" + (f", {mates}" if mates else "")
        self.title = (f"soccer-drill-play: you are {self.role} ({player}) against "
                      f"{setup.team}; {self._keys()} (when legal); Esc stops")
        self._observations: dict[str, Any] = {}

    def _keys(self, which: Sequence[int] | None = None) -> str:
        return key_text(self.actions, self.names, which)

    def _mask(self) -> np.ndarray:
        return self.env.action_mask(self.player)

    def _legal(self) -> list[int]:
        return np.flatnonzero(self._mask()).tolist()

    def _where(self) -> str:
        holding = self.env.drill_state.holder == self.index
        return "holding the ball" if holding else "off the ball"

    def start(self, seed: int) -> None:
        self._observations, _ = self.env.reset(seed=seed)
        # The mates' attacks draw from the episode's seed, never from the drill's own
        # generator, whose draws are the physics noise.
        seeds = np.random.default_rng(seed).integers(2**63, size=len(self.mates)).tolist()
        for mate, mate_seed in zip(self.mates.values(), seeds, strict=True):
            mate.reset(mate_seed)

    def prompt(self) -> str:
        return f"you {self.role}, {self._where()}: {self._keys(self._legal())}"

    def refusal(self, action: int) -> str | None:
        if self._mask()[action]:
            return None
        return (f"{self.names[action]} is masked for {self.player} now "
                f"({self._where()}); legal: {self._keys(self._legal())}")

    def act(self, action: int) -> Ended | None:
        mask = self._mask().copy()
        left = 1 if self.actions[action] is Skill.PASS else self.decision_cycles
        while True:
            state = self.env.drill_state
            actions = {self.player: action}
            for agent, mate in self.mates.items():
                actions[agent] = mate.act(self._observation(agent), state)
            self._observations, rewards, _, _, infos = self.env.step(actions)
            if not self.env.agents:
                return Ended(infos[self.player]["outcome"], float(rewards[self.player]))
            left -= 1
            if left == 0 or not np.array_equal(self._mask(), mask):
                return None

    def _observation(self, agent: str) -> np.ndarray:
        obs = self._observations[agent]
        return obs["observation"] if isinstance(obs, dict) else obs


CONTROLS: dict[str, Callable[[PlaySetup], Control]] = {
    "holder": HolderControl,
    "attacker": AttackerControl,
}
"""Every kind of control, by name (``soccer-drill-play --control NAME``)."""
