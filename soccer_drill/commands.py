"""What a player is told each cycle: a :class:`Skill`, as a :class:`Command`.

One vocabulary for every reader: agents' actions, the support player, scripted teams and
the compiled rules, which compare a command's skill with the members of :class:`Skill`
(an ``IntEnum``, so compiled code reads it as the integer it is). The drill turns a
command into a desired velocity and, for the ball holder, a ball action
(:mod:`soccer_drill.rules.motion`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from soccer_drill.interruptions import QuietIntEnum


class Skill(QuietIntEnum):
    """Every skill a player can be commanded to execute for one cycle."""

    HOLD = 0
    """Holder: shield the ball, keeping the body between it and the nearest defender."""
    PASS = 1
    """Holder: kick the ball to the teammate (noisy, aimed to arrive slowly)."""
    DRIBBLE = 2
    """Holder: run toward the goal line with the ball, steering around defenders."""
    GET_OPEN = 3
    """Off-ball: move to a support spot beside and ahead of the ball, away from defenders."""
    GO_TO_BALL = 4
    """Off-ball: run to the earliest reachable point on the ball's path."""
    INTERCEPT = 5
    """Defender: run to the ball (or to where a rolling ball can be reached first)."""
    MARK = 6
    """Defender: stand in the passing lane between the ball and the free attacker."""
    GUARD_LINE = 7
    """Defender: guard the goal line, level with the ball, 2.5 metres up."""
    MOVE_TO = 8
    """Anyone: run to ``Command.target``."""


BALL_SKILLS = frozenset({Skill.HOLD, Skill.PASS, Skill.DRIBBLE})
"""Skills only the attacker holding the ball may use."""
SCRIPTED_SKILLS: tuple[Skill, ...] = tuple(s for s in Skill if s not in BALL_SKILLS)
"""The skills a scripted team may command: any but the holder's ball skills."""

ATTACKER_ACTIONS: tuple[Skill, ...] = (
    Skill.HOLD, Skill.PASS, Skill.DRIBBLE, Skill.GET_OPEN, Skill.GO_TO_BALL,
)
"""An attacker agent's discrete actions, in index order."""
DEFENDER_ACTIONS: tuple[Skill, ...] = (Skill.INTERCEPT, Skill.MARK, Skill.GUARD_LINE)
"""A defender agent's discrete actions, in index order."""
HOLDER_ACTIONS: tuple[Skill, ...] = (Skill.HOLD, Skill.PASS, Skill.DRIBBLE)
"""The ball holder's actions, the paper's three basic options: action ``a`` is the skill
of value ``a`` (so a fixed holder rule may return ``Skill.PASS`` for action 1)."""
assert all(int(skill) == a for a, skill in enumerate(HOLDER_ACTIONS))


def pass_names(attackers: int) -> tuple[str, ...]:
    """The names of the passes of a drill with ``attackers`` attackers, one per teammate,
    nearest first: ``("PASS",)`` with one teammate, ``("PASS_1", "PASS_2", ...)`` with
    more, none with none."""
    if attackers == 2:
        return ("PASS",)
    return tuple(f"PASS_{k}" for k in range(1, attackers))


def holder_action_names(attackers: int) -> tuple[str, ...]:
    """The ball holder's actions in a drill with ``attackers`` attackers, in index order:
    ``HOLD``, one pass per teammate (nearest first), ``DRIBBLE`` (the paper's three,
    :data:`HOLDER_ACTIONS`, with two attackers; ``HOLD, DRIBBLE`` with one)."""
    return ("HOLD", *pass_names(attackers), "DRIBBLE")


def attacker_action_names(attackers: int) -> tuple[str, ...]:
    """An attacker agent's actions in a drill with ``attackers`` attackers: the holder's
    (:func:`holder_action_names`), then ``GET_OPEN`` and ``GO_TO_BALL``
    (:data:`ATTACKER_ACTIONS` with two attackers)."""
    return (*holder_action_names(attackers), "GET_OPEN", "GO_TO_BALL")


def attacker_action_skills(attackers: int) -> tuple[Skill, ...]:
    """The skill of each of an attacker agent's actions (:func:`attacker_action_names`):
    every pass is ``PASS``, to the teammate of its rank."""
    return (Skill.HOLD, *(Skill.PASS,) * (attackers - 1), Skill.DRIBBLE, Skill.GET_OPEN,
            Skill.GO_TO_BALL)


SKILL_LETTERS = {Skill.HOLD: "h", Skill.PASS: "p", Skill.DRIBBLE: "d", Skill.GET_OPEN: "g",
                 Skill.GO_TO_BALL: "b"}
"""The letter key of each action's skill, for the first action with that skill (``p`` is
the pass to the nearest teammate); action ``i`` of a space is also digit ``i + 1``."""


def action_letters(actions: Sequence[Skill]) -> dict[str, int]:
    """Key (a letter or a digit) to action index for a space of ``actions`` (their skills,
    in index order): each skill's letter (:data:`SKILL_LETTERS`) for its first action, and
    digit ``i + 1`` for action ``i``; the keys of ``soccer-drill-play``."""
    keys: dict[str, int] = {}
    for i, skill in enumerate(actions):
        keys.setdefault(SKILL_LETTERS[skill], i)
    keys.update({str(i + 1): i for i in range(len(actions))})
    return keys


@dataclass(frozen=True, slots=True)
class Command:
    """What one player does for one cycle.

    Parameters
    ----------
    skill
        The skill to execute.
    target
        ``(x, y)`` in metres; required for ``MOVE_TO``, ignored otherwise.
    speed
        Fraction of the player's top speed to use, in ``(0, 1]``.
    """

    skill: Skill
    target: tuple[float, float] | None = None
    speed: float = 1.0
