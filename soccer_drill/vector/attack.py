"""Scripted attacking sides of the batched multi-agent drill: the fixed holder rules playing
both attackers, so that the defenders can be the agents.

An attack is found by id in :data:`ATTACKS`, a :class:`~soccer_drill.registry.Registry`
of the entry-point group ``soccer_drill.attacks`` (the way defending teams are found in
``soccer_drill.opponents``); the entry point's value is a factory taking no argument and
returning an object with the methods of :class:`HolderRuleAttack` (``bind``, ``reset``,
``before_cycle``, ``after_cycle``)::

    [project.entry-points."soccer_drill.attacks"]
    my_attack = "my_package.attacks:my_attack"

``ParallelVectorEnv(attack="early_pass")`` plays one: the two attackers are scripted and
the defenders are the agents.

| id | the holder's rule (:mod:`soccer_drill.policies`) |
|---|---|
| ``late_pass``, ``early_pass``, ``shield_pass``, ``keepaway``, ``lane``, ``pass_first``, ``dribble``, ``hold``, ``random`` | that rule, in every episode |
| ``mixed_rules`` | one of the seven rules that ever score (all but ``hold`` and ``random``), drawn per episode |

Each attack plays as the holder environment does (``HolderEnv.step``): the attacker
holding the ball decides by the rule on its 9 features; a HOLD or DRIBBLE lasts
``decision_cycles`` cycles (4, ``HolderEnv``'s default) and a PASS one kick, each cut
short when the holder loses the ball; the other attacker, and both while the ball is
loose, run the support behaviour of :class:`~soccer_drill.rules.support.SupportPlayer`.
The rule and the support player draw from generators seeded from the drill's own at each
reset, so an episode is a function of the drill's seed and the defenders' actions.
"""

from __future__ import annotations

import hashlib
import inspect
from collections.abc import Sequence
from typing import Any

import numpy as np

from soccer_drill.constraints import Name
from soccer_drill.policies import HOLDER_POLICIES
from soccer_drill.registry import Registry
from soccer_drill.rules.features import batch_features, feature_bounds
from soccer_drill.skills import HOLDER_ACTIONS

__all__ = ["ATTACKS", "ATTACK_GROUP", "SCORING_RULES", "HolderRuleAttack", "attack_code",
           "make_attack"]

ATTACK_GROUP = "soccer_drill.attacks"
"""The entry-point group of the scripted attacks."""
ATTACKS = Registry(ATTACK_GROUP, "attack", label="id", names=Name(dots=False),
                   calls="an attack factory")
"""Every scripted attack, by id (built-in ones: the module table)."""
SCORING_RULES = ("late_pass", "early_pass", "shield_pass", "keepaway", "lane", "pass_first",
                 "dribble")
"""The fixed holder rules that ever score (``hold`` never does, ``random`` seldom)."""
DECISION_CYCLES = 4
"""The cycles a scripted HOLD or DRIBBLE lasts: ``HolderEnv``'s default."""

_HOLDER_SKILLS = np.array([int(s) for s in HOLDER_ACTIONS])
_PASS = 1


class HolderRuleAttack:
    """Both attackers of every drill of a batch, scripted by fixed holder rules.

    Parameters
    ----------
    rules : sequence of str
        Names of :data:`~soccer_drill.policies.HOLDER_POLICIES`; each episode plays one,
        drawn uniformly from the drill's attack generator (always the one, if one is given).
    decision_cycles : int, default 4
        The cycles a HOLD or DRIBBLE lasts (a PASS is one kick).
    """

    def __init__(self, rules: Sequence[str], decision_cycles: int = DECISION_CYCLES) -> None:
        rules = tuple(rules)
        unknown = [r for r in rules if r not in HOLDER_POLICIES]
        if not rules or unknown:
            raise ValueError(f"rules must name fixed holder rules {sorted(HOLDER_POLICIES)}, "
                             f"got {list(rules)}")
        self.rules = rules
        self.policies = tuple(HOLDER_POLICIES[r] for r in rules)
        self.decision_cycles = int(decision_cycles)

    def bind(self, n: int, config: Any) -> None:
        """Make the state of ``n`` drills of ``config``: who decided, what, for how long."""
        self.config = config
        self._low, self._high = (b.astype(np.float64) for b in feature_bounds(config))
        self.rule = np.zeros(n, dtype=np.int64)  # index into self.policies, per drill
        self.in_action = np.zeros(n, dtype=bool)
        self.decider = np.zeros(n, dtype=np.int64)
        self.action = np.zeros(n, dtype=np.int64)
        self.left = np.zeros(n, dtype=np.int64)
        self.generators: list[np.random.Generator] = [np.random.default_rng(0)] * n

    def reset(self, drills: np.ndarray, seeds: Sequence[int]) -> None:
        """A new episode in ``drills``: each draws its rule from a generator of its seed."""
        for i, seed in zip(drills.tolist(), seeds, strict=True):
            rng = np.random.default_rng(seed)
            self.generators[i] = rng
            self.rule[i] = rng.integers(len(self.policies)) if len(self.policies) > 1 else 0
        self.in_action[drills] = False

    def before_cycle(self, pos: np.ndarray, holder: np.ndarray, stepping: np.ndarray,
                     skill: np.ndarray, speed: np.ndarray, supporting: np.ndarray) -> None:
        """The attackers' commands of the coming cycle of the ``stepping`` drills: a new
        decision where an attacker holds the ball with no action running, the holder's
        skill where one runs (written into ``skill`` and ``speed``), and which attackers
        the support behaviour drives (``supporting``, ``(n, 2)`` bool)."""
        deciding = np.flatnonzero(stepping & ~self.in_action & (holder >= 0) & (holder < 2))
        if len(deciding):
            who = holder[deciding]
            obs = batch_features(pos[deciding], who, self.config, self._low, self._high)
            for k, i in enumerate(deciding.tolist()):
                self.action[i] = self.policies[self.rule[i]](obs[k], self.generators[i])
            self.decider[deciding] = who
            self.left[deciding] = np.where(self.action[deciding] == _PASS, 1,
                                           self.decision_cycles)
            self.in_action[deciding] = True
        acting = stepping & self.in_action
        rows = np.flatnonzero(acting)
        skill[rows, self.decider[rows]] = _HOLDER_SKILLS[self.action[rows]]
        speed[rows, self.decider[rows]] = 1.0
        free = stepping & ~acting
        supporting[:, 0] = (acting & (self.decider == 1)) | free
        supporting[:, 1] = (acting & (self.decider == 0)) | free

    def after_cycle(self, holder: np.ndarray, ended: np.ndarray, stepping: np.ndarray) -> None:
        """A cycle has run: an action goes on while its holder keeps the ball, for the
        cycles it has left."""
        acting = stepping & self.in_action
        self.left[acting] -= 1
        self.in_action &= ~(acting & (ended | (holder != self.decider) | (self.left <= 0)))


def _attack(*rules: str) -> Any:
    def factory() -> HolderRuleAttack:
        return HolderRuleAttack(rules)
    factory.__doc__ = (f"The fixed holder rule {rules[0]!r} playing both attackers"
                       if len(rules) == 1 else
                       f"One of the fixed holder rules {list(rules)} per episode, playing "
                       "both attackers")
    factory.__qualname__ = factory.__name__ = rules[0] if len(rules) == 1 else "mixed_rules"
    return factory


late_pass = _attack("late_pass")
early_pass = _attack("early_pass")
shield_pass = _attack("shield_pass")
keepaway = _attack("keepaway")
lane = _attack("lane")
pass_first = _attack("pass_first")
dribble = _attack("dribble")
hold = _attack("hold")
random = _attack("random")
mixed_rules = _attack(*SCORING_RULES)


def make_attack(attack: str | HolderRuleAttack) -> HolderRuleAttack:
    """The attack registered as ``attack`` (an id of :data:`ATTACKS`), or ``attack`` itself."""
    if isinstance(attack, str):
        ATTACKS.check("attack", attack)
        return ATTACKS.get(attack)()
    for method in ("bind", "reset", "before_cycle", "after_cycle"):
        if not callable(getattr(attack, method, None)):
            raise TypeError(f"attack must be an attack id {ATTACKS.names()} or an object with "
                            f"bind, reset, before_cycle and after_cycle, got {attack!r}")
    return attack


def attack_code(attack: str) -> dict[str, str]:
    """What identifies the code of attack ``attack`` (as ``team_code`` does a team's):
    its factory's module and name, and the SHA-256 of that module's source file (left
    out where it cannot be read)."""
    factory = ATTACKS.get(attack)
    out = {"factory": f"{getattr(factory, '__module__', '?')}:{getattr(factory, '__qualname__', '?')}"}
    try:
        path = inspect.getsourcefile(inspect.getmodule(factory))  # type: ignore[arg-type]
        with open(path, "rb") as source:  # type: ignore[arg-type]
            out["source_sha256"] = hashlib.sha256(source.read()).hexdigest()
    except (TypeError, OSError):
        pass
    return out
