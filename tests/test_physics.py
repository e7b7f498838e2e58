"""Physical invariants over many seeded episodes, and every way an episode can end."""

from __future__ import annotations

import math

import numpy as np
import pytest

import soccer_drill
from soccer_drill.commands import Command, Skill
from soccer_drill.config import DrillConfig
from soccer_drill.state import BALL

EPS = 1e-6


def _check_invariants(state, cfg: DrillConfig, outcome: str | None) -> None:
    caps = (cfg.attacker_speed,) * 2 + (cfg.defender_speed,) * 2 + (cfg.ball_max_speed,)
    for i, ((vx, vy), cap) in enumerate(zip(state.vel, caps, strict=True)):
        assert math.hypot(vx, vy) <= cap + EPS, f"body {i} exceeds its speed cap"
    lo, hi = -cfg.wall_margin, cfg.field_size + cfg.wall_margin
    for i in range(4):
        x, y = state.pos[i]
        assert lo - EPS <= x <= hi + EPS and lo - EPS <= y <= hi + EPS, f"player {i} left"
    bx, by = state.pos[BALL]
    inside = 0 <= bx <= cfg.field_size and 0 <= by <= cfg.field_size
    assert inside or outcome in ("out", "success"), "the ball left without ending the episode"
    if state.holder >= 0:
        assert state.distance(state.holder, BALL) <= cfg.control_radius + EPS


@pytest.mark.parametrize("opponent", [None, "chasers"])
def test_invariants_over_many_random_episodes(opponent):
    env = soccer_drill.parallel_env(opponent=opponent)
    cfg = env.config
    rng = np.random.default_rng(1)
    outcomes, holders = set(), 0
    for episode in range(60):
        obs, _ = env.reset(seed=episode)
        _check_invariants(env.drill_state, cfg, None)
        while env.agents:
            actions = {a: int(rng.choice(np.flatnonzero(obs[a]["action_mask"])))
                       for a in env.agents}
            obs, rewards, term, trunc, infos = env.step(actions)
            state = env.drill_state
            _check_invariants(state, cfg, env.outcome)
            holders += state.holder >= 0
            for agent, o in obs.items():
                assert env.observation_space(agent).contains(o)
        outcomes.add(env.outcome)
        # Zero-sum rewards, paid once, matching the outcome.
        paid = float(env._core.batch.attacker_reward[0])
        for agent, r in rewards.items():
            assert r == (paid if agent.startswith("attacker") else -paid)
            assert term[agent] == (env.outcome != "timeout") != trunc[agent]
    assert outcomes <= {"success", "interception", "out", "timeout"} and holders > 0


class _Statues:
    """Defenders that stand still where they are (a test team)."""

    def reset(self, view, rng):
        self.players = view.players
        self.home = {p: tuple(view.positions[2 + k]) for k, p in enumerate(view.players)}

    def act(self, view):
        return {p: Command(Skill.MOVE_TO, self.home[p]) for p in self.players}


def _play(config: DrillConfig, action: int, opponent=None, seed: int = 0):
    env = soccer_drill.HolderEnv(opponent=opponent or _Statues(), config=config)
    env.reset(seed=seed)
    while True:
        _, reward, term, trunc, info = env.step(action)
        if term or trunc:
            return info["outcome"], reward, term, trunc


def test_success_when_unopposed_dribble_crosses_the_line():
    cfg = DrillConfig(defender_starts=((1.0, 34.0), (34.0, 34.0)))
    outcome, reward, term, trunc = _play(cfg, action=2)
    assert (outcome, term, trunc) == ("success", True, False)
    assert cfg.reward_success_edge <= reward <= cfg.reward_success_centre


def test_interception_when_a_defender_stands_on_the_ball():
    cfg = DrillConfig(
        attacker_starts=((15.5, 20.0), (19.5, 20.0)),  # whoever gets the ball ...
        defender_starts=((15.5, 18.6), (19.5, 18.6)),  # ... has a defender on it
        start_jitter=0.0, tackle_probability=1.0,
    )
    outcome, reward, term, _ = _play(cfg, action=0, opponent="chasers")
    assert (outcome, reward, term) == ("interception", cfg.reward_failure, True)


def test_out_when_an_uncontrollable_pass_rolls_away():
    cfg = DrillConfig(pass_arrival_speed=20.0, control_speed=1.0, ball_damping=1.0,
                      defender_starts=((1.0, 20.0), (34.0, 20.0)))
    outcome, reward, term, _ = _play(cfg, action=1)
    assert (outcome, reward, term) == ("out", cfg.reward_failure, True)


def test_timeout_truncates():
    cfg = DrillConfig(max_cycles=15, defender_starts=((1.0, 2.0), (34.0, 2.0)))
    outcome, reward, term, trunc = _play(cfg, action=0)
    assert (outcome, reward, term, trunc) == ("timeout", cfg.reward_timeout, False, True)


def test_success_reward_falls_from_centre_to_edge():
    cfg = DrillConfig()
    assert cfg.success_reward(17.5) == pytest.approx(1.0)
    assert cfg.success_reward(0.0) == pytest.approx(0.5)
    assert cfg.success_reward(35.0) == pytest.approx(0.5)
    assert cfg.success_reward(8.75) == pytest.approx(0.75)


def test_pass_moves_possession_between_attackers():
    env = soccer_drill.HolderEnv(opponent=_Statues(),
                                 config=DrillConfig(defender_starts=((1.0, 2.0), (34.0, 2.0))))
    changes = 0
    for seed in range(10):
        env.reset(seed=seed)
        before = env.drill_state.holder
        _, _, term, trunc, info = env.step(1)
        if not (term or trunc):
            changes += env.drill_state.holder != before
            assert info["duration"] > 1
    assert changes >= 8


def test_the_ball_moves_on_the_arrays_exactly_as_pymunk_moves_it_in_the_single_drill():
    """The rules move the ball on arrays (the batched drill has no ball body); the single
    drill keeps it a body of its space as well, and both agree to the bit, the sign of a
    zero included, over passes, dribbles and loose balls."""
    from one_drill import OneDrill as Drill

    drill, rng = Drill(), np.random.default_rng(3)
    skills = [Skill.PASS, Skill.DRIBBLE, Skill.HOLD, Skill.GO_TO_BALL]
    checked = passes = 0
    for _ in range(40):
        state = drill.reset(rng)
        while drill.outcome is None:
            holder = state.holder
            commands = [Command(Skill.GET_OPEN), Command(Skill.GET_OPEN),
                        Command(Skill.INTERCEPT), Command(Skill.MARK)]
            if holder in (0, 1):
                commands[holder] = Command(skills[int(rng.integers(len(skills) - 1))])
                passes += commands[holder].skill is Skill.PASS
            state = drill.step(commands, rng)
            ball = drill.physics._bodies[4]
            got = np.array([*ball.position, *ball.velocity])
            assert got.tobytes() == np.array([*state.pos[4], *state.vel[4]]).tobytes()
            checked += 1
    assert checked > 500 and passes > 10
