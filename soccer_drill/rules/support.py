"""The fixed stochastic support behaviour of an attacker that is not an agent.

It chases a loose ball it is nearer to (or its mate may not take yet), otherwise gets
open: it runs to its support spot moved by a random offset (normal, :data:`OFFSET_STD` m
per axis), redrawn every :data:`RESAMPLE_CYCLES` cycles, so the teammate is not perfectly
predictable but the episode stays seeded. Each drill draws from its own generator, given
at the episode's start (:class:`SupportDraws`); every supported attacker draws from it,
in index order, each a new offset.
"""

from __future__ import annotations

import numpy as np

from soccer_drill.commands import Skill
from soccer_drill.rules.compiled import compiled, hypot
from soccer_drill.rules.motion import support_spot

RESAMPLE_CYCLES = 10
"""How often the support spot's random offset changes."""
OFFSET_STD = 2.0
"""Standard deviation of the offset per axis, metres."""
BLOCK = 64
_GO_TO_BALL, _MOVE_TO = int(Skill.GO_TO_BALL), int(Skill.MOVE_TO)  # as compiled code stores them
"""Standard normals drawn from a drill's generator at a time."""

SUPPORT = np.dtype([
    ("offset", np.float64, (2,)),
    ("normals", np.float64, (BLOCK,)),
    ("next", np.int64),
])
"""One drill's support draws: the offset now, its generator's normals drawn ahead, and the
next one to use (:data:`BLOCK`: none left)."""


@compiled
def support_target(state, player, offset_x, offset_y, size, attackers):
    """The support behaviour's ``(skill, x, y)`` for attacker ``player`` of one drill:
    ``GO_TO_BALL`` for a loose ball it is no farther from than each teammate that may
    take it (a passer locked out may not), else ``MOVE_TO`` its support spot moved by
    the offset."""
    pos = state.pos
    if state.holder < 0:
        ball = pos.shape[0] - 1
        bx, by = pos[ball, 0], pos[ball, 1]
        mine = hypot(pos[player, 0] - bx, pos[player, 1] - by)
        nearest = True
        for mate in range(attackers):
            if mate == player or (state.passer == mate and state.cycle < state.lockout_until):
                continue
            if not mine <= hypot(pos[mate, 0] - bx, pos[mate, 1] - by):
                nearest = False
        if nearest:
            return _GO_TO_BALL, 0.0, 0.0
    x, y = support_spot(pos, player, size, attackers)
    x, y = x + offset_x, y + offset_y
    lo, hi = 1.0, size - 1.0  # each clamp min(max(v, lo), hi), as the builtins compare
    return (_MOVE_TO, (lo if x < lo else hi if x > hi else x),
            (lo if y < lo else hi if y > hi else y))


@compiled
def support_commands(state, cycle, supporting, support, start, size):
    """The support behaviour's commands for attacker ``k`` of drill ``i`` wherever
    ``supporting[i, k]``, into ``cycle[i]``'s command of ``k``, for drills ``start``
    onwards. At a resample cycle each supported attacker first draws the offset's two
    normals from ``support[i]``.

    Returns -1 when done, or the first drill whose normals run out before its draws
    (nothing of it changed): refill it (:meth:`SupportDraws.refill`) and call again from
    there.
    """
    attackers = supporting.shape[1]
    for i in range(start, state.shape[0]):
        count = 0
        for k in range(attackers):
            if supporting[i, k]:
                count += 1
        if count == 0:
            continue
        s, c, d = state[i], cycle[i], support[i]
        resample = s.cycle % RESAMPLE_CYCLES == 0
        if resample and d.next + 2 * count > BLOCK:
            return i
        for k in range(attackers):
            if not supporting[i, k]:
                continue
            if resample:
                d.offset[0] = OFFSET_STD * d.normals[d.next]
                d.offset[1] = OFFSET_STD * d.normals[d.next + 1]
                d.next += 2
            skill, x, y = support_target(s, k, d.offset[0], d.offset[1], size, attackers)
            c.skill[k] = skill
            c.target[k, 0] = x
            c.target[k, 1] = y
            c.speed[k] = 1.0
    return -1


class SupportDraws:
    """The support behaviour's draws in ``n`` drills: each drill's generator, made at its
    first draw from the seed given at the episode's start (most episodes of a drill
    with agents for attackers never draw, and a generator costs about 15 us to make),
    its normals drawn :data:`BLOCK` at a time, in order."""

    def __init__(self, n: int) -> None:
        self.records = np.zeros(n, dtype=SUPPORT)
        self.records["next"] = BLOCK
        self._generators: list[np.random.Generator | int | None] = [None] * n

    def seed(self, drills: np.ndarray, seeds: list[int]) -> None:
        """A new episode in ``drills``: no offset yet, draws from ``default_rng(seed)``."""
        for i, seed in zip(drills.tolist(), seeds, strict=True):
            self._generators[i] = seed
        self.records["offset"][drills] = 0.0
        self.records["next"][drills] = BLOCK

    def refill(self, i: int) -> None:
        """Drill ``i``'s unused normals moved to the front, the rest drawn anew."""
        g = self._generators[i]
        if g is None:
            raise RuntimeError(f"drill {i}: no support generator; reset the drill first")
        if not isinstance(g, np.random.Generator):
            g = self._generators[i] = np.random.default_rng(g)
        record = self.records[i]
        normals, used = record["normals"], int(record["next"])
        left = BLOCK - used
        normals[:left] = normals[used:].copy()
        g.standard_normal(out=normals[left:])
        record["next"] = 0

    def commands(self, state: np.ndarray, cycle: np.ndarray, supporting: np.ndarray,
                 size: float) -> None:
        """:func:`support_commands` of every drill, refilling whose normals run out."""
        self.finish(state, cycle, supporting, size,
                    support_commands(state, cycle, supporting, self.records, 0, size))

    def finish(self, state: np.ndarray, cycle: np.ndarray, supporting: np.ndarray,
               size: float, start: int) -> None:
        """:func:`support_commands` from drill ``start`` on (what a call of it returned:
        -1, none left), refilling whose normals run out."""
        while start >= 0:
            self.refill(start)
            start = support_commands(state, cycle, supporting, self.records, start, size)
