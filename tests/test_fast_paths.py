"""The hot path's shortcuts give what the plain code gives, bit for bit, or fail loudly."""

from __future__ import annotations

import math

import numpy as np
import pytest

import soccer_drill
from soccer_drill.config import DrillConfig, fewest_substeps
from soccer_drill.drill.drills import BatchDrill
from soccer_drill.drill.spaces import DrillSpace, check_batch_order
from soccer_drill.rules.arrays import roll_tuples as _roll_table
from soccer_drill.rules.features import _clip_into
from soccer_drill.rules.motion import HEADINGS as _HEADINGS
from soccer_drill.rules.motion import unit as _unit
from soccer_drill.skills import (
    ball_interception_point,
    dribble_heading,
    shield_direction,
    support_spot,
)
from soccer_drill.state import DrillState


def _clipped(values: list[float], low: list[float], high: list[float]) -> np.ndarray:
    """The observation rules' clip of each value into its bounds, as float32."""
    out = np.empty(len(values), dtype=np.float32)
    low64, high64 = np.array(low, dtype=np.float64), np.array(high, dtype=np.float64)
    for k, value in enumerate(values):
        _clip_into(out, k, float(value), low64, high64)
    return out


def test_the_clip_is_numpys_bit_for_bit_with_nan_signed_zeros_and_equal_bounds():
    rng = np.random.default_rng(0)
    for _ in range(3000):
        values = rng.normal(size=9) * rng.choice([1e-40, 1e-3, 1.0, 1e3])
        values[rng.random(9) < 0.1] = 0.0
        values[rng.random(9) < 0.1] *= -0.0
        values[rng.random(9) < 0.05] = np.nan
        low = rng.normal(size=9).astype(np.float32)
        high = (low + np.abs(rng.normal(size=9))).astype(np.float32)
        low[rng.random(9) < 0.2] = 0.0
        same = rng.random(9) < 0.1
        high[same] = low[same]
        expected = np.clip(np.array(values, dtype=np.float32), low, high)
        got = _clipped(values.tolist(), low.tolist(), high.tolist())
        assert got.dtype == np.float32 and got.tobytes() == expected.tobytes()


def test_values_inside_their_bounds_keep_their_bits_and_one_outside_is_clipped():
    low, high = [-1.0, 0.0, 0.0], [1.0, 2.0, 3.0]
    low32, high32 = np.array(low, dtype=np.float32), np.array(high, dtype=np.float32)
    inside = [-0.0, 1e-300, 2.9999999]  # a negative zero, an underflow to float32's zero
    expected = np.clip(np.array(inside, dtype=np.float32), low32, high32)
    assert _clipped(inside, low, high).tobytes() == expected.tobytes()
    for k, outside in enumerate((-1.5, -0.0, 3.5)):  # -0.0 is not inside [0, 2]: made +0.0
        values = inside.copy()
        values[k] = outside
        expected = np.clip(np.array(values, dtype=np.float32), low32, high32)
        assert _clipped(values, low, high).tobytes() == expected.tobytes()
    nan = [0.5, float("nan"), 1.0]
    assert _clipped(nan, low, high).tobytes() == np.clip(
        np.array(nan, dtype=np.float32), low32, high32).tobytes()


def test_a_batched_read_in_another_order_is_refused_by_name():
    physics = DrillSpace(DrillConfig())
    check_batch_order(physics.space, physics._bodies)  # as built
    with pytest.raises(RuntimeError, match=r"pymunk .*batch API lists the space's bodies in "
                       r"an unexpected order; this pymunk version is not supported"):
        check_batch_order(physics.space, physics._bodies[::-1])


def test_a_drill_with_its_batch_buffer_pickles_and_continues_identically():
    import pickle

    from soccer_drill.commands import Skill

    cfg = DrillConfig()
    drill, rng = BatchDrill(1, cfg, physics=DrillSpace(cfg)), np.random.default_rng(0)
    one, active = np.zeros(1, dtype=np.int64), np.ones(1, dtype=bool)
    drill.reset(one, [rng])
    drill.skill[0] = [Skill.GET_OPEN, Skill.GET_OPEN, Skill.INTERCEPT, Skill.INTERCEPT]
    copy, copy_rng = pickle.loads(pickle.dumps((drill, rng)))
    for _ in range(30):
        if drill.outcome[0]:
            break
        drill.step(active, [rng])
        copy.step(active, [copy_rng])
        assert drill.state.tobytes() == copy.state.tobytes()


def _scanned_interception_point(state, player, vmax, cfg):
    """The interception point by trying every point of the roll table in turn."""
    bx, by = state.pos[4]
    bvx, bvy = state.vel[4]
    px, py = state.pos[player]
    times, travels, _, _ = _roll_table(cfg.ball_damping, cfg.cycle_seconds)
    x = y = 0.0
    for t, travelled in zip(times, travels, strict=True):
        x, y = bx + bvx * travelled, by + bvy * travelled
        r = vmax * t + cfg.control_radius
        if (x - px) ** 2 + (y - py) ** 2 <= r * r:
            return x, y
    return x, y


@pytest.mark.parametrize("damping", [1e-9, 0.05, 0.4, 0.9, 1.0])
@pytest.mark.parametrize("cycle", [0.01, 0.1, 0.5])
def test_the_interception_search_finds_the_point_a_full_scan_finds(damping, cycle):
    # Long cycles need more sub-steps and a lower control speed than the defaults'.
    cfg = DrillConfig(ball_damping=damping, cycle_seconds=cycle,
                      substeps=max(10, fewest_substeps(6.0, cycle, 0.5)),
                      control_speed=min(9.0, 2.0 / cycle))
    times, travels, _, _ = _roll_table(damping, cycle)
    rng = np.random.default_rng(0)
    for _ in range(1500):
        ball, player = rng.uniform(-5, 40, size=2), rng.uniform(-5, 40, size=2)
        speed = float(rng.choice([1.5, 3.0, 10.0, cfg.ball_max_speed, 100.0]))  # rolling
        angle = rng.uniform(0, 2 * math.pi)
        velocity = (speed * math.cos(angle), speed * math.sin(angle))
        vmax = float(rng.choice([0.0, 1e-3, 1.0, 5.0, 20.0]))
        if rng.random() < 0.5:  # a player placed exactly at the reach of one point
            k = int(rng.integers(len(times)))
            r = vmax * times[k] + cfg.control_radius
            px = ball[0] + velocity[0] * travels[k] + r * math.cos(angle + 1.0)
            py = ball[1] + velocity[1] * travels[k] + r * math.sin(angle + 1.0)
            player = (px, py)
        pos = ((float(player[0]), float(player[1])), (0.0, 0.0), (0.0, 0.0), (0.0, 0.0),
               (float(ball[0]), float(ball[1])))
        state = DrillState(pos, ((0.0, 0.0),) * 4 + (velocity,), -1, 0)
        assert (ball_interception_point(state, 0, vmax, cfg)
                == _scanned_interception_point(state, 0, vmax, cfg))


def _support_spot_by_min_and_max(state, player, cfg):
    size = cfg.field_size
    bx, by = state.pos[4]
    side = 1.0 if state.pos[player][0] >= bx else -1.0
    if not 3.0 <= bx + side * 11.0 <= size - 3.0:
        side = -side
    tx = min(max(bx + side * 11.0, 2.0), size - 2.0)
    ty = min(max(by - 3.0, 2.0), size - 2.0)
    for d in state.opponents_of(player):
        dx, dy = tx - state.pos[d][0], ty - state.pos[d][1]
        dist = math.hypot(dx, dy)
        if dist < 5.0:
            ux, uy = _unit(dx, dy)
            tx, ty = tx + ux * (5.0 - dist), ty + uy * (5.0 - dist)
    return min(max(tx, 1.0), size - 1.0), min(max(ty, 1.0), size - 1.0)


@pytest.mark.parametrize("size", [35.0, 60.0, 100.0])
def test_the_support_spot_and_a_held_balls_lead_are_what_min_and_max_give(size):
    cfg = DrillConfig(field_size=size)
    rng = np.random.default_rng(0)
    for k in range(5000):
        pos = [tuple(map(float, rng.uniform(-3, size + 3, size=2))) for _ in range(5)]
        player = int(rng.integers(2))
        if k % 4 == 0:  # an opponent near the spot, or exactly on it
            spot = _support_spot_by_min_and_max(DrillState(tuple(pos), ((0.0, 0.0),) * 5, -1, 0),
                                                player, cfg)
            pos[2 + k % 8 // 4] = spot if k % 3 == 0 else (spot[0] + 1.0, spot[1] - 2.0)
        state = DrillState(tuple(pos), ((0.0, 0.0),) * 5, -1, 0)
        assert support_spot(state, player, cfg) == _support_spot_by_min_and_max(state, player, cfg)
        # A ball held by the other side: aimed at where it will be, at most 1.5 s ahead.
        holder, vmax = 2 + k % 2, float(rng.choice([0.0, 0.1, 1.0, 5.0, 50.0]))
        vel = tuple(tuple(map(float, rng.uniform(-6, 6, size=2))) for _ in range(5))
        state = DrillState(tuple(pos), vel, holder, 0)
        (bx, by), (px, py), (hvx, hvy) = pos[4], pos[player], vel[holder]
        lead = min(math.hypot(bx - px, by - py) / vmax, 1.5) if vmax > 0 else 0.0
        assert ball_interception_point(state, player, vmax, cfg) == (bx + hvx * lead,
                                                                     by + hvy * lead)


def _dribble_heading_trying_every_candidate(state, player, cfg):
    px, py = state.pos[player]
    best, best_score = (0.0, -1.0), -math.inf
    d1, d2 = state.opponents_of(player)
    r1x, r1y = state.pos[d1][0] - px, state.pos[d1][1] - py
    r2x, r2y = state.pos[d2][0] - px, state.pos[d2][1] - py
    for hx, hy, score in _HEADINGS:
        for rx, ry in ((r1x, r1y), (r2x, r2y)):
            ahead = rx * hx + ry * hy
            if 0.0 < ahead < 12.0:
                free = 1.0 - abs(rx * hy - ry * hx) / 4.0
                score -= 2.0 * (free if free > 0.0 else 0.0) * (1.0 - ahead / 12.0)
        if not 1.0 <= px + hx * 4.0 <= cfg.field_size - 1.0:
            score -= 3.0
        if score > best_score:
            best, best_score = (hx, hy), score
    return best


def _shield_direction_by_min(state, player):
    px, py = state.pos[player]
    nearest = min(state.opponents_of(player),
                  key=lambda d: math.hypot(state.pos[d][0] - px, state.pos[d][1] - py))
    return _unit(px - state.pos[nearest][0], py - state.pos[nearest][1])


def test_dribbling_and_shielding_choose_what_trying_every_candidate_chooses():
    cfg = DrillConfig()
    rng = np.random.default_rng(0)
    for k in range(20000):
        pos = [tuple(map(float, rng.uniform(-1, 36, size=2))) for _ in range(5)]
        player = int(rng.integers(4))
        if k % 3 == 0:  # an opponent straight ahead, or both at the same distance
            ox, oy = pos[player]
            opponents = (2, 3) if player < 2 else (0, 1)
            pos[opponents[0]] = (ox + float(rng.uniform(-1, 1)), oy - float(rng.uniform(0, 12)))
            if k % 2 == 0:
                pos[opponents[1]] = (2 * ox - pos[opponents[0]][0], 2 * oy - pos[opponents[0]][1])
        if k % 5 == 0:  # on a touchline, where every heading costs the same
            pos[player] = (float(rng.choice([0.5, 34.5])), pos[player][1])
        state = DrillState(tuple(pos), ((0.0, 0.0),) * 5, player, 0)
        assert dribble_heading(state, player, cfg) == _dribble_heading_trying_every_candidate(
            state, player, cfg)
        assert shield_direction(state, player) == _shield_direction_by_min(state, player)


@pytest.mark.parametrize("shared_spaces", [False, True])
@pytest.mark.parametrize("illegal_action", ["raise", "default"])
def test_a_plain_int_action_gets_what_a_numpy_integer_gets(shared_spaces, illegal_action):
    """The shortcut for plain ints against the general path NumPy integers take."""
    env = soccer_drill.env(shared_spaces=shared_spaces, illegal_action=illegal_action)
    env.reset(seed=1)
    batch = env._core.batch
    for holder in (-1, 0, 1):
        batch.holder[0] = holder
        for index, agent in enumerate(env.possible_agents):
            for action in range(-1, 7):
                outcomes = []
                for given in (action, np.int64(action)):
                    env.replaced = None
                    batch.skill[0, index] = -1
                    try:
                        env._command(agent, index, given)
                        outcomes.append((int(batch.skill[0, index]), env.replaced))
                    except ValueError as exc:
                        outcomes.append(str(exc))
                assert outcomes[0] == outcomes[1], (holder, agent, action)


def _same_step(plain: tuple, general: tuple) -> None:
    """Two parallel steps' results are equal, observations and masks bit for bit."""
    for got, want in zip(plain, general, strict=True):
        assert got.keys() == want.keys()
        for agent in got:
            x, y = got[agent], want[agent]
            if isinstance(x, dict):
                assert x.keys() == y.keys()
                for key in x:
                    np.testing.assert_array_equal(x[key], y[key])
            elif isinstance(x, np.ndarray):
                np.testing.assert_array_equal(x, y)
            else:
                assert x == y and type(x) is type(y), (agent, x, y)


@pytest.mark.parametrize("size", [(2, 2), (3, 2)])
@pytest.mark.parametrize("opponent", ["chasers", None])
@pytest.mark.parametrize("obs_format", ["dict", "flat"])
@pytest.mark.parametrize("illegal_action", ["raise", "default"])
def test_the_parallel_steps_plain_int_loop_gets_what_numpy_integers_get(
        size, opponent, obs_format, illegal_action):
    """The parallel step's loop over plain-int actions (the shortcut, inlined) against
    the general path NumPy integers take: the same commands, the same refusals and
    replacements, the same observations, rewards and infos, episode after episode."""
    attackers, defenders = size
    cfg = DrillConfig(attackers=attackers, defenders=defenders)
    envs = [soccer_drill.parallel_env(config=cfg, opponent=opponent, obs_format=obs_format,
                                      illegal_action=illegal_action) for _ in range(2)]
    rng = np.random.default_rng(5)
    refused = replaced = 0
    for episode in range(3):
        results = [env.reset(seed=episode) for env in envs]
        _same_step(*results)
        while envs[0].agents:
            assert envs[1].agents == envs[0].agents
            n = {a: envs[0].action_space(a).n for a in envs[0].agents}
            actions = {a: int(rng.integers(-1, n[a] + 1)) if rng.random() < 0.1
                       else int(rng.integers(n[a])) for a in envs[0].agents}
            outcomes = []
            for env, kind in zip(envs, (int, np.int64), strict=True):
                try:
                    outcomes.append(env.step({a: kind(x) for a, x in actions.items()}))
                except ValueError as exc:
                    outcomes.append(str(exc))
            if isinstance(outcomes[0], str):
                assert outcomes[0] == outcomes[1]
                refused += 1
                continue
            assert not isinstance(outcomes[1], str), outcomes[1]
            _same_step(*outcomes)
            replaced += any("illegal_action" in info for info in outcomes[0][4].values())
            for name in ("skill", "receiver"):
                np.testing.assert_array_equal(getattr(envs[0]._core.batch, name),
                                              getattr(envs[1]._core.batch, name))
    assert refused > 0  # out of range, and masked under "raise"
    if illegal_action == "default":
        assert replaced > 0
