"""The batched multi-agent environment pays what the single parallel environment pays,
cycle by cycle, in every task: keepaway's seconds every cycle, the drill's reward at
its end."""

from __future__ import annotations

import numpy as np
import pytest

from soccer_drill.scenarios import parallel_env, scenario
from soccer_drill.vector import HolderVectorEnv, ParallelVectorEnv


def _play(name: str, opponent: str | None, seed: int, cycles: int) -> bool:
    """Play the single and the batched environment of scenario ``name`` on the same seed
    with the same random legal actions for at most ``cycles`` cycles, asserting every
    cycle's rewards equal; returns whether the episode ended."""
    s = scenario(name)
    single = parallel_env(name, opponent=opponent)
    vector = ParallelVectorEnv(num_envs=2, config=s.config(), opponent=opponent,
                               drills_per_space=1)
    one, _ = single.reset(seed=seed)
    vector.reset(seed=[seed, seed + 1])
    rng = np.random.default_rng(seed)
    for cycle in range(cycles):
        actions = {a: int(rng.choice(np.flatnonzero(one[a]["action_mask"])))
                   for a in single.agents}
        one, rewards, terminated, truncated, _ = single.step(actions)
        _, vrewards, vterminated, vtruncated, _ = vector.step(
            {a: np.array([actions[a], 0]) for a in vector.agents})
        for a in rewards:
            assert vrewards[a][0] == rewards[a], (name, seed, cycle, a)
            assert vterminated[a][0] == terminated[a] and vtruncated[a][0] == truncated[a]
        if not single.agents:
            return True
    return False


@pytest.mark.parametrize("name", ["keepaway_3v2", "keepaway_4v3", "drill_2v2"])
def test_the_batched_drills_pay_each_cycle_what_the_single_one_pays(name: str) -> None:
    s = scenario(name)
    for seed in range(3):  # whole episodes: their last cycle's pay is compared too
        assert _play(name, s.opponent, seed, s.config().max_cycles + 1)


def test_every_agent_is_paid_the_same_with_no_scripted_team() -> None:
    """Keepers and takers both agents: the takers are paid the keepers' seconds negated."""
    _play("keepaway_3v2", None, 4, 40)


def test_a_keepaway_episode_pays_its_length_in_the_batched_environments() -> None:
    """An episode's return is its length in seconds, in the multi-agent and the holder's
    batched environments alike."""
    s = scenario("keepaway_3v2")
    cfg = s.config()
    vector = ParallelVectorEnv(num_envs=3, config=cfg, opponent=s.opponent)
    obs, _ = vector.reset(seed=5)
    returns, done = np.zeros(3), np.zeros(3, dtype=bool)
    cycles = np.zeros(3, dtype=int)
    while not done.all():
        actions = {a: np.argmax(obs[a]["action_mask"], axis=1) for a in vector.agents}
        obs, rewards, terminated, truncated, infos = vector.step(actions)
        returns += np.where(done, 0.0, rewards["attacker_0"])
        ended = ~done & (terminated["attacker_0"] | truncated["attacker_0"])
        cycles[ended] = infos["cycles"][ended]
        done |= ended
    assert np.allclose(returns, cycles * cfg.cycle_seconds)
    holder = HolderVectorEnv(num_envs=3, config=cfg, opponent=s.opponent)
    holder.reset(seed=5)
    returns, done = np.zeros(3), np.zeros(3, dtype=bool)
    cycles = np.zeros(3, dtype=int)
    while not done.all():
        _, rewards, terminated, truncated, infos = holder.step(np.zeros(3, dtype=np.int64))
        returns += np.where(done, 0.0, rewards)
        ended = ~done & (terminated | truncated)
        cycles[ended] = infos["cycles"][ended]
        done |= ended
    assert np.allclose(returns, cycles * cfg.cycle_seconds)
