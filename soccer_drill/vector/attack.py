"""Scripted attacking sides of the batched multi-agent drill: the fixed holder rules playing
both attackers, so that the defenders can be the agents.

An attack is found by id in :data:`ATTACKS`, a :class:`~soccer_drill.registry.Registry`
of the entry-point group ``soccer_drill.attacks`` (the way defending teams are found in
``soccer_drill.opponents``); the entry point's value is a factory taking no argument and
returning an object with the two methods of :class:`HolderRuleAttack`, ``reset(drills,
seeds)`` and ``decide(drills, features) -> actions``::

    [project.entry-points."soccer_drill.attacks"]
    my_attack = "my_package.attacks:my_attack"

``ParallelVectorEnv(attack="early_pass")`` plays one: the attackers are scripted and the
defenders are the agents, in a drill of any size (``config``).

The built-in attacks play the drill's holder rules on the drill's holder features, so
keepaway (``DrillConfig(task="keepaway")``), whose holder observes keepaway's state
variables and has no dribble, refuses them; give it an attack object, for instance its
hand-coded keeper (:func:`~soccer_drill.keepaway_policies.keeper_policy`)::

    class HandCodedKeepers:
        def __init__(self, keepers, takers):
            self.policy = keeper_policy("hand_coded", keepers, takers)
            self.rngs = {}  # each drill's generator, renewed at its resets

        def reset(self, drills, seeds):
            self.rngs.update((i, np.random.default_rng(s)) for i, s in zip(drills.tolist(), seeds))

        def decide(self, drills, features):
            return np.array([self.policy(f, self.rngs[i])
                             for i, f in zip(drills.tolist(), features)])

    ParallelVectorEnv(num_envs=8, config={"task": "keepaway", "attackers": 3,
                      "defenders": 2, "field_size": 20.0}, attack=HandCodedKeepers(3, 2))

An action the holder of the task does not have (a DRIBBLE in keepaway, an index past
the passes) is refused naming the attack, the drill and the cycle.

| id | the holder's rule (:mod:`soccer_drill.policies`) |
|---|---|
| ``late_pass``, ``early_pass``, ``shield_pass``, ``keepaway``, ``lane``, ``pass_first``, ``dribble``, ``hold``, ``random`` | that rule, in every episode |
| ``mixed_rules`` | one of the seven rules that ever score (all but ``hold`` and ``random``), drawn per episode |

An attack only decides the holder's actions; :class:`ScriptedAttack` plays them through
the holder loop of the holder environment
(:class:`~soccer_drill.envs.holder.HolderLoop`): the attacker holding the ball decides on
the holder's features (the paper's 9 in the 2v2 drill); a HOLD or DRIBBLE lasts
``decision_cycles`` cycles (4, ``HolderEnv``'s default) and a PASS one kick, each cut
short when the holder loses the ball; the other attackers, and all of them while the ball
is loose, run the support behaviour. The attack draws from generators seeded from the
drill's own at each reset (the seeds a scripted team would get), so an episode is a
function of the drill's seed and the defenders' actions.
"""

from __future__ import annotations

import hashlib
import inspect
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from soccer_drill.constraints import Constraint, ListOf, Name, OneOf, check, checked
from soccer_drill.envs.core import BatchCore
from soccer_drill.envs.holder import HolderLoop
from soccer_drill.interruptions import delivered_by_signal, short_repr
from soccer_drill.policies import HOLDER_POLICIES
from soccer_drill.registry import Registry

__all__ = ["ATTACKS", "HolderRuleAttack"]

ATTACK_GROUP = "soccer_drill.attacks"
"""The entry-point group of the scripted attacks."""
ATTACKS = Registry(ATTACK_GROUP, "attack", label="id", names=Name(dots=False),
                   calls="an attack factory")
"""Every scripted attack, by id (built-in ones: the module table)."""
SCORING_RULES = ("late_pass", "early_pass", "shield_pass", "keepaway", "lane", "pass_first",
                 "dribble")
"""The fixed holder rules that ever score (``hold`` never does, ``random`` seldom)."""
_RULES = ListOf(OneOf(tuple(HOLDER_POLICIES)), min_len=1)
DECISION_CYCLES = 4
"""The cycles a scripted HOLD or DRIBBLE lasts: ``HolderEnv``'s default."""


class HolderRuleAttack:
    """Both attackers of every drill of a batch, scripted by fixed holder rules.

    Parameters
    ----------
    rules : sequence of str
        Names of :data:`~soccer_drill.policies.HOLDER_POLICIES`; each episode plays one,
        drawn uniformly from the drill's attack generator (always the one, if one is given).
    """

    def __init__(self, rules: Sequence[str]) -> None:
        self.rules = tuple(checked("rules", rules, _RULES, "the fixed holder rules of "
                                   "soccer_drill.policies.HOLDER_POLICIES"))
        self.policies = tuple(HOLDER_POLICIES[r] for r in rules)
        self.rule: dict[int, int] = {}
        """The index into :attr:`rules` each drill's episode plays."""
        self.generators: dict[int, np.random.Generator] = {}

    def reset(self, drills: np.ndarray, seeds: Sequence[int]) -> None:
        """A new episode in ``drills``: each draws its rule from a generator of its seed."""
        for i, seed in zip(drills.tolist(), seeds, strict=True):
            rng = np.random.default_rng(seed)
            self.generators[i] = rng
            self.rule[i] = int(rng.integers(len(self.policies))) if len(self.policies) > 1 else 0

    def decide(self, drills: np.ndarray, features: np.ndarray) -> np.ndarray:
        """The action of the holder of each of ``drills`` (an index of the holder's actions
        at the drill's size: 0 HOLD, 1 PASS, 2 DRIBBLE in the 2v2 drill), whose holder
        features (the paper's 9 in the 2v2 drill) are the rows of ``features``."""
        out = np.zeros(len(drills), dtype=np.int64)
        for k, i in enumerate(drills.tolist()):
            out[k] = self.policies[self.rule[i]](features[k], self.generators[i])
        return out


class ScriptedAttack:
    """An attack playing both attackers of a core's drills through the holder loop.

    Parameters
    ----------
    attack
        The attack (``reset`` and ``decide``, as :class:`HolderRuleAttack`), already given
        to ``core`` (``BatchCore(..., attack=attack)``), which seeds it at each reset.
    core
        The drills, with the support behaviour (``support=True``).
    decision_cycles
        The cycles a HOLD or DRIBBLE lasts.
    name
        The attack in errors (its id, or its class's name; default: the class's name).
        What its ``decide`` raises, or an action out of range, is said naming it, the
        cycle and the drills deciding.
    """

    def __init__(self, attack: Any, core: BatchCore,
                 decision_cycles: int = DECISION_CYCLES, name: str | None = None) -> None:
        self.attack = attack
        self.name = type(attack).__name__ if name is None else name
        task = core.config.task
        if isinstance(attack, HolderRuleAttack) and task != "drill":
            raise ValueError(
                f"attack {self.name!r} plays the drill's fixed holder rules, which read the "
                f"drill's holder features; {task}'s holder has observations and actions of "
                f"its own: give {task} an attack object of your own (reset and decide; "
                "soccer_drill.vector.attack's docstring shows one playing keepaway's "
                "hand-coded keeper)")
        self.loop = HolderLoop(core, decision_cycles)

    def _decide(self, drills: np.ndarray, features: np.ndarray) -> np.ndarray:
        cycle = int(self.loop.core.batch.cycle[drills[0]])
        where = f"at cycle {cycle} of drills {drills.tolist()}"
        try:
            actions = np.asarray(self.attack.decide(drills, features))
        except Exception as exc:
            if delivered_by_signal(exc):
                raise
            raise RuntimeError(f"attack {self.name!r} raised in decide() {where}: "
                               f"{short_repr(exc)}") from exc
        if actions.shape != drills.shape:
            raise ValueError(f"attack {self.name!r}: decide() {where} returned shape "
                             f"{actions.shape}, expected one action per drill {drills.shape}")
        return actions

    def restart(self, drills: np.ndarray) -> None:
        """A new episode in each of ``drills`` (the core's reset, which seeds the attack)."""
        self.loop.restart(drills)

    def cycle(self, active: np.ndarray) -> None:
        """One cycle of the ``active`` drills, the defenders' commands already set: a new
        decision where an attacker holds the ball with no action running, then the loop's
        cycle (the holder's skill, the support behaviour, the physics)."""
        loop, batch = self.loop, self.loop.core.batch
        deciding = np.flatnonzero(active & ~loop.running)
        if len(deciding):
            features = loop.observe(batch.state, deciding, batch.holder[deciding])
            actions = self._decide(deciding, features)
            checked = np.zeros(len(deciding), dtype=np.int64)
            for k, (i, action) in enumerate(zip(deciding.tolist(), actions.tolist(),
                                                strict=True)):
                try:
                    checked[k] = self.loop.check_action(action)  # the task's actions
                except ValueError as error:
                    raise ValueError(f"drill {i}: attack {self.name!r} decided "
                                     f"{action!r} at cycle {int(batch.cycle[i])}; "
                                     f"{error}") from None
            loop.begin(deciding, checked)
        loop.cycle()


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


@dataclass(frozen=True)
class _AttackObject(Constraint):
    """An object with an attack's methods, ``reset`` and ``decide``."""

    def allows(self, value: object) -> bool:
        return not isinstance(value, str) and all(
            callable(getattr(value, method, None)) for method in ("reset", "decide"))

    def describe(self) -> str:
        return "an object with reset(drills, seeds) and decide(drills, features)"


def make_attack(attack: object) -> Any:
    """The attack registered as ``attack`` (an id of :data:`ATTACKS`), or ``attack`` itself
    if it has ``reset`` and ``decide``."""
    if isinstance(attack, str):
        ATTACKS.check("attack", attack)
        return ATTACKS.get(attack)()
    check("attack (an attack id is a string)", attack, _AttackObject())
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
