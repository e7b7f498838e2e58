"""The drill's compiled rules, called once with the types their callers pass.

Registered with :func:`soccer_drill.rules.compiled.warms`, so that :func:`warm_up` (which
:class:`~soccer_drill.teams.TeamDriver` calls before running a team) compiles them, or
loads them from numba's disk cache, before any time-bounded call of a team can reach
them: a team's ``act`` may call the skills' rules, and the first use of a rule compiles
it.
"""

from __future__ import annotations

import numpy as np

from soccer_drill.config import DrillConfig
from soccer_drill.drill import BatchDrill, Drill
from soccer_drill.rules.compiled import warm_up, warms
from soccer_drill.rules.cycle import outcome
from soccer_drill.rules.features import (
    batch_features,
    batch_full,
    batch_global_state,
    batch_kinematics,
    feature_bounds,
    features,
    full_bounds,
    full_observation,
    global_state,
    kinematic_bounds,
    kinematics,
    players_features,
    state_bounds,
)
from soccer_drill.rules.motion import interception_points, mark_targets
from soccer_drill.rules.support import SupportPlayer, support_commands_of_drills
from soccer_drill.skills import (
    Command,
    Skill,
    ball_interception_point,
    dribble_heading,
    pass_velocity,
    shield_direction,
    support_spot,
)

__all__ = ["warm_up"]


@warms
def _drill_rules() -> None:
    """One cycle of a drill and of a batch of two, every observation and every skill."""
    cfg, rng = DrillConfig(), np.random.default_rng(0)
    drill = Drill(cfg)
    state = drill.reset(rng)
    drill.step([Command(Skill.HOLD), Command(Skill.GET_OPEN), Command(Skill.INTERCEPT),
                Command(Skill.MOVE_TO, (1.0, 1.0))], rng)
    for player in range(4):
        ball_interception_point(state, player, cfg.defender_speed, cfg)
    support_spot(state, 0, cfg)
    dribble_heading(state, 0, cfg)
    shield_direction(state, 0)
    pass_velocity(state, 0, cfg, rng)
    support = SupportPlayer()
    support.reset(rng)
    support.command(state, 1, cfg)
    bounds = {name: tuple(b.astype(np.float64) for b in make(cfg)) for name, make in (
        ("features", feature_bounds), ("kinematic", kinematic_bounds), ("full", full_bounds),
        ("state", state_bounds))}
    features(state, 0, cfg, *bounds["features"])
    kinematics(state, 0, *bounds["kinematic"])
    full_observation(state, 0, cfg, *bounds["full"])
    global_state(state, cfg, *bounds["state"])

    batch = BatchDrill(2, cfg)
    drills = np.arange(2)
    batch.reset(drills, [np.random.default_rng(1), np.random.default_rng(2)])
    skill = np.full((2, 4), int(Skill.INTERCEPT), dtype=np.int64)
    target, speed = np.zeros((2, 4, 2)), np.ones((2, 4))
    supporting = np.ones((2, 2), dtype=bool)
    support_commands_of_drills(skill, target, speed, supporting, batch.pos, batch.holder,
                               batch.cycle, batch.passer, batch.lockout_until,
                               np.zeros((2, 2, 2)), cfg.field_size)
    batch.step(np.ones(2, dtype=bool), skill, target, speed,
               [np.random.default_rng(3), np.random.default_rng(4)])
    outcome(batch.pos[0], 0, batch.cycle[0], cfg.field_size, cfg.max_cycles)  # after a tackle
    locked = np.where(batch.cycle < batch.lockout_until, batch.passer, -1)
    batch_features(batch.pos, batch.holder.clip(0, 1), cfg, *bounds["features"])
    players_features(batch.pos, (0, 1), cfg, *bounds["features"])
    batch_kinematics(batch.pos, batch.vel, batch.holder, locked, 0, *bounds["kinematic"])
    batch_full(batch.pos, batch.vel, batch.holder, locked, batch.cycle, 0, cfg, *bounds["full"])
    batch_global_state(batch.pos, batch.vel, batch.holder, locked, batch.cycle, cfg,
                       *bounds["state"])
    interception_points(batch.pos, batch.vel, batch.holder, speed, cfg)
    mark_targets(batch.pos, batch.holder)
