"""The arithmetic the benchmark scripts report, on made-up measurements."""

from __future__ import annotations

import pytest
from benchmark_scripts import load_benchmark


def test_the_cost_per_cycle_splits_into_a_fixed_part_and_a_part_per_drill():
    fit = load_benchmark("bench_vector").fixed_and_marginal
    # 500 us a cycle plus 6 us a drill, given as us per drill-cycle; the single drill
    # (N = 1) takes another path and is left out.
    sizes = [1, 16, 64, 256]
    a, b = fit(sizes, [999.0] + [500.0 / n + 6.0 for n in sizes[1:]])
    assert a == pytest.approx(500.0) and b == pytest.approx(6.0)


def test_the_split_needs_two_batch_sizes():
    fit = load_benchmark("bench_vector").fixed_and_marginal
    with pytest.raises(ValueError, match="two batch sizes >= 2, got sizes \\[1, 64\\]"):
        fit([1, 64], [40.0, 12.0])


def test_the_rollouts_timer_counts_only_the_time_spent_in_step():
    gym = pytest.importorskip("gymnasium")
    timer_class = load_benchmark("bench_rollouts").StepTimer

    class Slow(gym.Env):
        observation_space = gym.spaces.Box(0.0, 1.0, (1,))
        action_space = gym.spaces.Discrete(2)

        def reset(self, *, seed=None, options=None):
            return self.observation_space.low, {}

        def step(self, action):
            x = 0
            for i in range(200_000):  # CPU time, which thread_time counts
                x += i
            return self.observation_space.low, 0.0, False, False, {}

    env = timer_class(Slow())
    env.reset()
    assert env.seconds == 0.0
    env.step(0)
    assert env.seconds > 0.0


def test_the_safety_checks_of_bench_env_are_measured():
    costs = load_benchmark("bench_env").team_check_costs(number=20, repeat=2)
    assert set(costs) == {"bound", "commands", "action"}
    assert costs["commands"] > 0.0 and costs["action"] > 0.0


def test_keepaway_endings_counts_a_ball_too_fast_for_a_keeper_it_reached():
    from soccer_drill.state import DrillState

    through = load_benchmark("keepaway_endings").through_keeper
    still = ((0.0, 0.0),) * 3

    def state(ball_at, ball_vel, passer=-1):
        return DrillState(pos=((5.0, 5.0), (10.0, 10.0), ball_at),
                          vel=((0.0, 0.0), (-3.0, 0.0), ball_vel), holder=-1, cycle=3,
                          passer=passer)

    assert through([state((10.5, 10.0), (7.0, 0.0))], 2, 1.0, 9.0)  # 10 m/s against keeper 1
    assert not through([state((10.5, 10.0), (5.0, 0.0))], 2, 1.0, 9.0)  # 8 m/s: controlled
    assert not through([state((12.0, 10.0), (20.0, 0.0))], 2, 1.0, 9.0)  # 2 m away
    assert not through([state((10.5, 10.0), (7.0, 0.0), passer=1)], 2, 1.0, 9.0)  # its passer
    assert not through([DrillState(pos=((0.0, 0.0),) * 3, vel=still, holder=0, cycle=0)],
                       2, 1.0, 9.0)
