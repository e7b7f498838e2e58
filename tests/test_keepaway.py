"""Keepaway on the drill's physics: its episode end, reward, state variables, takers and
fixed keepers."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from opponents.takers import plan_into
from soccer_drill import DrillConfig, Skill
from soccer_drill.drill.drills import BatchDrill
from soccer_drill.keepaway_policies import (
    KEEPER_POLICIES,
    hand_coded,
    keepaway_layout,
    keeper_policy,
)
from soccer_drill.rules.arrays import Outcome, rule_parameters
from soccer_drill.rules.keepaway import keepaway_bounds, keepaway_state_into, state_size
from soccer_drill.scenarios import holder_env, holder_vector_env, scenario
from soccer_drill.state import DrillState
from soccer_drill.vector.holder import play_episodes

KEEPAWAY_3V2 = scenario("keepaway_3v2").config()
DOCS = Path(__file__).resolve().parents[1] / "docs"


def _one_cycle(cfg: DrillConfig, pos, vel, holder: int) -> int:
    """The outcome after one cycle of a drill put in the state given, everyone standing."""
    batch = BatchDrill(1, cfg)
    batch.reset(np.zeros(1, dtype=np.int64), [np.random.default_rng(0)])
    players = cfg.players
    state = DrillState(tuple(map(tuple, pos)), tuple(map(tuple, vel)), holder, 0, -1, 0)
    batch.set_state(0, state)
    batch.physics.renew(np.zeros(1, dtype=np.int64), batch.pos)
    batch.skill[0] = [int(Skill.MOVE_TO)] * players
    batch.target[0] = np.asarray(pos)[:players]
    batch.step(np.ones(1, dtype=bool), [np.random.default_rng(0)])
    return int(batch.outcome[0])


def test_the_episode_ends_when_a_taker_reaches_a_loose_ball():
    pos = [(15, 15), (5, 15), (15, 5), (10.0, 10.0), (3, 3), (10.3, 10.0)]
    assert _one_cycle(KEEPAWAY_3V2, pos, [(0, 0)] * 6, -1) == Outcome.INTERCEPTION


def test_the_episode_ends_when_the_ball_leaves_the_region_even_over_the_drills_goal_line():
    far = [(15, 15), (5, 15), (15, 10), (3, 17), (5, 17)]
    out_bottom = [*far, (10.0, 0.2)]
    vel = [(0, 0)] * 5 + [(0.0, -5.0)]
    assert _one_cycle(KEEPAWAY_3V2, out_bottom, vel, -1) == Outcome.OUT
    # A keeper carrying it over y = 0 is out too, where the drill's attacker scores.
    carried = [(15, 15), (5, 15), (10.0, 0.2), (3, 17), (5, 17), (10.0, -0.3)]
    assert _one_cycle(KEEPAWAY_3V2, carried, [(0, 0)] * 6, 2) == Outcome.OUT
    drill = DrillConfig(attackers=3, defenders=2, field_size=20.0,
                        defender_starts=((5.0, 5.0), (15.0, 5.0)))
    assert _one_cycle(drill, carried, [(0, 0)] * 6, 2) == Outcome.SUCCESS


def test_each_step_pays_the_seconds_it_lasted_and_an_episode_its_length():
    env = holder_env("keepaway_3v2")
    obs, _ = env.reset(seed=7)
    rng, total, done = np.random.default_rng(0), 0.0, False
    while not done:
        obs, reward, terminated, truncated, info = env.step(hand_coded(obs, rng))
        assert reward == pytest.approx(0.1 * info["duration"])
        total += reward
        done = terminated or truncated
    assert info["outcome"] in ("interception", "out", "timeout")
    assert total == pytest.approx(0.1 * info["cycles"])
    assert env.action_names == ("HOLD", "PASS_1", "PASS_2")
    assert env.observation_space.shape == (13,)


def test_the_same_seed_plays_the_same_episode_after_others():
    def episode(env, seed):
        obs, _ = env.reset(seed=seed)
        rng, seen, done = np.random.default_rng(seed), [obs], False
        while not done:
            obs, reward, terminated, truncated, info = env.step(KEEPER_POLICIES["random"](obs, rng))
            seen += [obs, reward, info["cycles"]]
            done = terminated or truncated
        return seen

    env = holder_env("keepaway_3v2")
    first = episode(env, 3)
    episode(env, 4)
    again = episode(env, 3)
    assert len(first) == len(again)
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))


def test_the_state_variables_are_keepaways():
    cfg = KEEPAWAY_3V2
    k1, k2, k3, t1, t2 = (10.0, 10.0), (16.0, 10.0), (10.0, 2.0), (12.0, 11.0), (4.0, 4.0)
    pos = np.array([k3, k1, k2, t2, t1, (10.5, 10.0)])  # K1 is keeper 1; index order mixed
    low, high = (b.astype(np.float64) for b in keepaway_bounds(cfg))
    out = np.empty(state_size(3, 2), np.float32)
    keepaway_state_into(out, pos, 1, rule_parameters(cfg), low, high)
    d = math.dist
    c = (10.0, 10.0)

    def angle(a, b):  # at K1, between a and b
        u, v = np.subtract(a, k1), np.subtract(b, k1)
        return math.degrees(math.acos(np.dot(u, v) / (np.linalg.norm(u) * np.linalg.norm(v))))

    expected = [d(k1, c), d(k1, k2), d(k1, k3), d(k1, t1), d(k1, t2), d(k2, c), d(k3, c),
                d(t1, c), d(t2, c), min(d(k2, t1), d(k2, t2)), min(d(k3, t1), d(k3, t2)),
                min(angle(k2, t1), angle(k2, t2)), min(angle(k3, t1), angle(k3, t2))]
    assert out == pytest.approx(np.array(expected, dtype=np.float32), abs=1e-4)
    assert keepaway_layout(out) == (3, 2) and keepaway_layout(np.zeros(19)) == (4, 3)


def test_the_two_takers_nearest_the_ball_go_for_it_and_the_third_blocks_the_most_open_keeper():
    ball = (10.0, 10.0)
    keepers = [(10.0, 10.5), (25.0, 10.0), (10.0, 25.0), (3.0, 3.0)]
    takers = [(12.0, 10.0), (14.0, 10.0), (20.0, 20.0)]  # the third is farthest
    pos = np.array([*keepers, *takers, ball])
    skill, target = np.zeros(3, np.int64), np.zeros((3, 2))
    plan_into(skill, target, pos, 4)
    assert skill.tolist() == [int(Skill.INTERCEPT)] * 2 + [int(Skill.MOVE_TO)]
    # Keeper 1's lane is blocked by the two chasers; keepers 2 and 3 are open, and keeper
    # 3's nearest taker makes the wider angle at the ball: the marker stands 4 m from it
    # toward the ball.
    assert target[2] == pytest.approx(np.array((3.0, 3.0)) + 4.0 * np.array((7.0, 7.0))
                                      / math.hypot(7.0, 7.0))


def test_the_hand_coded_keeper_holds_the_ball_longer_than_random_and_always_hold():
    env = holder_vector_env("keepaway_3v2", num_envs=20)
    seeds = list(range(1000, 1040))
    mean = {name: np.mean([t for t, _ in play_episodes(env, KEEPER_POLICIES[name], seeds)])
            for name in ("hand_coded", "random", "hold")}
    assert mean["hand_coded"] > mean["random"] + 1.0
    assert mean["hand_coded"] > mean["hold"] + 1.0


def test_a_keeper_action_out_of_range_is_refused_naming_keepaways_actions():
    env = holder_env("keepaway_3v2")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"0=HOLD, 1=PASS_1, 2=PASS_2\), got 3"):
        env.step(3)


def test_the_drill_keeps_its_defaults_and_a_task_is_checked():
    assert DrillConfig().task == "drill"
    assert DrillConfig().attacker_starts == ((4.0, 31.0), (31.0, 31.0))
    with pytest.raises(ValueError, match=r"DrillConfig.task must be 'drill' or 'keepaway', got 'football'"):
        DrillConfig(task="football")


@pytest.mark.slow
def test_the_keepaway_page_is_written_from_kept_per_seed_records(tmp_path):
    import hashlib
    import json

    from ilpss.experiments import keepaway

    args = ["--scenario", "keepaway_3v2", "--seeds", "1000-1001", "--episodes", "3",
            "--eval-episodes", "2", "--runs", str(tmp_path / "runs"), "--out", str(tmp_path),
            "--set", "initial_value=10.0"]
    keepaway.main(args)
    kept = json.loads((tmp_path / "data" / "keepaway_3v2.json").read_text())
    assert kept["sha256"] == hashlib.sha256(
        json.dumps(kept["record"], sort_keys=True).encode()).hexdigest()
    record = kept["record"]
    assert record["schema_version"] == 1 and record["meta"]["seeds"] == [1000, 1001]
    assert all(len(v) == 2 and min(v) > 0 for v in record["per_seed"].values())
    page = (tmp_path / "keepaway.md").read_text()
    assert "--set initial_value=10.0" in page and "| hand_coded |" in page
    # the command the page gives is the one run (before: --runs results/keepaway --out docs)
    assert f"--runs {tmp_path / 'runs'} " in page and page.count(f"--out {tmp_path}\n") == 1
    records = sorted((tmp_path / "runs").rglob("seed_*.json"))
    assert len(records) == 2
    before = [r.stat().st_mtime_ns for r in records]
    keepaway.main(args)  # a rerun reads the kept records
    assert [r.stat().st_mtime_ns for r in records] == before
    # a kept seed changed by hand is refused, naming it (before, read as it was)
    records[0].write_text(records[0].read_text().replace('"seed": 1000', '"seed": 7'))
    with pytest.raises(SystemExit) as exit_info:
        keepaway.main(args)
    assert exit_info.value.code == 1


def test_one_seed_is_refused_before_the_kept_numbers_are_touched(tmp_path, capsys):
    # before, --seeds 0 learnt, replaced the kept 10-seed numbers with one seed's, then
    # failed making the page (which needs two seeds): the numbers were lost
    import shutil

    from ilpss.experiments import keepaway

    (tmp_path / "data").mkdir()
    shutil.copy(DOCS / "data" / "keepaway_3v2.json", tmp_path / "data")
    before = (tmp_path / "data" / "keepaway_3v2.json").read_bytes()
    for seeds, said in (("0", "at least 2 seeds"), ("x-3", "got 'x-3'")):
        with pytest.raises(SystemExit) as exit_info:
            keepaway.main(["--seeds", seeds, "--episodes", "2", "--runs", str(tmp_path / "r"),
                           "--out", str(tmp_path)])
        assert exit_info.value.code == 2 and said in capsys.readouterr().err
    assert (tmp_path / "data" / "keepaway_3v2.json").read_bytes() == before
    assert not (tmp_path / "r").exists()


def test_damaged_kept_numbers_are_one_line_naming_the_file(tmp_path, capsys):
    # before, a truncated or edited file ended in a JSONDecodeError or ValueError traceback
    from ilpss.experiments import keepaway

    (tmp_path / "data").mkdir()
    kept = tmp_path / "data" / "keepaway_3v2.json"
    whole = (DOCS / "data" / "keepaway_3v2.json").read_text()
    for damaged, said in ((whole[:300], "not the JSON of a kept record"),
                          (whole.replace("3.7", "3.8", 1), "its sha256 does not match"),
                          ("[1]", "not a kept record")):
        kept.write_text(damaged)
        with pytest.raises(SystemExit) as exit_info:
            keepaway.main(["--from-data", str(tmp_path)])
        err = capsys.readouterr().err
        assert exit_info.value.code == 1 and str(kept) in err and said in err
        assert "Traceback" not in err


@pytest.mark.parametrize(("keepers", "takers"), [(2, 3), (2, 4), (3, 3), (3, 4), (3, 2), (4, 3)])
def test_a_keeper_policy_made_for_a_size_reads_that_sizes_observation(keepers, takers):
    # before, the policies read the size from the observation's length alone: at 2v4 (13
    # values, as 3v2) they read it as 3v2, and at 2v3 or 3v3 they chose passes that the
    # environment does not have
    from soccer_drill import HolderEnv

    env = HolderEnv(config=DrillConfig(task="keepaway", attackers=keepers, defenders=takers))
    for name in KEEPER_POLICIES:
        policy, rng = keeper_policy(name, keepers, takers), np.random.default_rng(0)
        for seed in range(2):
            obs, _ = env.reset(seed=seed)
            while True:
                action = policy(obs, rng)
                assert env.action_space.contains(action)
                obs, _, terminated, truncated, _ = env.step(action)
                if terminated or truncated:
                    break
    if takers < keepers:  # keepaway's own sizes: the same decisions as read from the length
        rng = np.random.default_rng(1)
        for _ in range(50):
            obs = env.observation_space.sample()
            assert keeper_policy("hand_coded", keepers, takers)(obs, rng) == hand_coded(obs, rng)
    with pytest.raises(ValueError, match=r"not the state variables of keepaway 3v2 \(13\)"):
        keeper_policy("hold", 3, 2)(np.zeros(19), np.random.default_rng(0))


def test_the_keeper_policies_play_a_lone_keeper_by_holding():
    # before, keeper_policy refused one keeper, a keepaway size the drill makes
    from soccer_drill import HolderEnv

    env = HolderEnv(config=DrillConfig(task="keepaway", attackers=1, defenders=2))
    assert env.action_names == ("HOLD",)
    for name in KEEPER_POLICIES:
        policy, rng = keeper_policy(name, 1, 2), np.random.default_rng(0)
        obs, _ = env.reset(seed=0)
        assert policy(obs, rng) == 0
    with pytest.raises(ValueError, match=r"keepers must be an integer in \[1, 4\], got 0"):
        keeper_policy("hold", 0, 2)
