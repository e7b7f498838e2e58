"""The drill's compiled rules, called once with the types their callers pass.

Registered with :func:`soccer_drill.rules.compiled.warms`, so that :func:`warm_up` (which
the team driver imports from here, and calls before running a team) compiles them, or
loads them from numba's disk cache, before any time-bounded call of a team can reach
them: a team's ``act`` may call the skills' rules, and the first use of a rule compiles
it. Each module with compiled code of its own registers its own (the team driver's
checks, the holder loop, a team's plan).
"""

from __future__ import annotations

import numpy as np

from soccer_drill.commands import Command, Skill
from soccer_drill.config import DrillConfig
from soccer_drill.drill.drills import BatchDrill
from soccer_drill.drill.spaces import DrillSpace
from soccer_drill.rules.arrays import rule_parameters
from soccer_drill.rules.compiled import warm_up, warms
from soccer_drill.rules.cycle import outcome
from soccer_drill.rules.features import GLOBAL_STATE, HOLDER_FEATURES, OBSERVATION_TYPES
from soccer_drill.rules.motion import interception_points, mark_targets
from soccer_drill.skills import (
    ball_interception_point,
    dribble_heading,
    execute,
    pass_velocity,
    shield_direction,
    support_spot,
)

__all__ = ["warm_up"]


def _read_only(array: np.ndarray) -> np.ndarray:
    array = array.copy()
    array.flags.writeable = False
    return array


def _observed_with(every: np.ndarray, fixed: np.ndarray) -> list:
    """Each observation type with the ``(rows, players)`` its callers pass: the single
    environments (and every core's global state) read-only arrays, the vector
    environments writable ones, and the single holder its read-only drill with the
    players it gathers (the features, and the holder's own)."""
    single, vector, holder = (fixed, fixed), (every, every), (fixed, every)
    uses = []
    for name, kind in OBSERVATION_TYPES.items():
        uses.append((kind, (single, vector, holder) if name == "features" else (single, vector)))
    return [*uses, (HOLDER_FEATURES, (single, vector, holder)), (GLOBAL_STATE, (single,))]


@warms
def _drill_rules(config: DrillConfig | None) -> None:
    """A cycle of one drill (in its own space) and of a batch of two, every observation
    and every skill, with the arrays their callers pass (the holder loop's are its
    warmer's; the support behaviour's too)."""
    cfg, rng = config or DrillConfig(), np.random.default_rng(0)
    size = cfg.players
    for n, physics in ((1, DrillSpace(cfg)), (2, None)):
        batch = BatchDrill(n, cfg, physics=physics)
        every = np.arange(n)
        batch.reset(every, [np.random.default_rng(k) for k in range(n)])
        batch.skill[:] = [int(Skill.HOLD)] + [int(Skill.GET_OPEN)] * (cfg.attackers - 1) + [
            int(Skill.INTERCEPT)] + [int(Skill.MOVE_TO)] * (cfg.defenders - 1)
        # The drills that step: the single environments' fixed (read-only) one, the vector
        # environment's (writable) choice; each from a reset, as a one-cycle episode
        # (max_cycles=1) ends at its first step.
        for active in (_read_only(np.ones(n, dtype=bool)), np.ones(n, dtype=bool)):
            batch.reset(every, [np.random.default_rng(k) for k in range(n)])
            batch.step(active, [np.random.default_rng(k) for k in range(n)])
        params = rule_parameters(cfg)
        fixed = _read_only(every)  # the single environments' drill, a core's every drill
        for kind, uses in _observed_with(every, fixed):
            low, high = (b.astype(np.float64) for b in kind.bounds(cfg))
            out = np.empty((n, len(low)), np.float32)
            for rows, players in uses:
                kind.rule(out, batch.state, rows, players, params, low, high)
        interception_points(batch.pos, batch.vel, batch.holder, np.ones((n, size)), cfg)
        mark_targets(batch.pos, batch.holder, attackers=cfg.attackers)
        # A tackle's outcome, found outside the compiled cycle (BatchDrill's tackles).
        outcome(batch.pos[0], 0, batch.cycle[0], cfg.field_size, cfg.max_cycles, cfg.attackers,
                params[0]["goal_line"])
    state = batch.state_of(0)
    for player in range(size):
        ball_interception_point(state, player, cfg.defender_speed, cfg)
        execute(state, player, Command(Skill.INTERCEPT), cfg, rng)
    support_spot(state, 0, cfg)
    dribble_heading(state, 0, cfg)
    shield_direction(state, 0, cfg)
    if cfg.attackers > 1:
        pass_velocity(state, 0, cfg, rng)
