"""One behaviour for copies of the environments, single and batched: ``copy.deepcopy``,
``copy.copy`` and ``pickle`` give an independent environment that continues the episode."""

from __future__ import annotations

import copy
import pickle
import threading

import gymnasium as gym
import numpy as np
import pytest

import soccer_drill
from soccer_drill import scenarios
from soccer_drill.vector import HolderVectorEnv
from soccer_drill.vector.agents import ParallelVectorEnv

COPIES = {
    "deepcopy": copy.deepcopy,
    "copy": copy.copy,
    "pickle": lambda env: pickle.loads(pickle.dumps(env)),
}
MAKERS = {
    "aec": lambda **kw: soccer_drill.env(**kw),
    "parallel": lambda **kw: soccer_drill.parallel_env(**kw),
    "holder": lambda **kw: soccer_drill.HolderEnv(**{"opponent": "goal_guards", **kw}),
}


def _pick(rng: np.random.Generator, mask: np.ndarray) -> int:
    return int(rng.choice(np.flatnonzero(mask)))


def _rest(kind: str, env, seed: int) -> list:
    """Play the rest of the episode with actions drawn from ``seed``; what it returned."""
    rng = np.random.default_rng(seed)
    seen = []
    if kind == "aec":
        for agent in env.agent_iter():
            obs, reward, term, trunc, info = env.last()
            seen.append((agent, obs["observation"].tobytes(), reward, term, trunc, dict(info),
                         env.drill_state))
            env.step(None if term or trunc else _pick(rng, obs["action_mask"]))
    elif kind == "parallel":
        while env.agents:
            actions = {a: _pick(rng, env.action_mask(a)) for a in env.agents}
            obs, rewards, terms, truncs, infos = env.step(actions)
            seen.append(({a: o["observation"].tobytes() for a, o in obs.items()}, rewards, terms,
                         truncs, infos, env.drill_state))
    else:
        done = False
        while not done:
            obs, reward, term, trunc, info = env.step(int(rng.integers(3)))
            seen.append((obs.tobytes(), reward, term, trunc, info, env.drill_state))
            done = term or trunc
    return seen


def _start(kind: str, env, seed: int, steps: int) -> None:
    """Reset with ``seed`` and play ``steps`` steps (turns in the AEC API) into the episode."""
    rng = np.random.default_rng(seed + 1)
    env.reset(seed=seed)
    for _ in range(steps):
        if kind == "aec":
            env.step(_pick(rng, env.action_mask()))
        elif kind == "parallel":
            env.step({a: _pick(rng, env.action_mask(a)) for a in env.agents})
        else:
            env.step(0)  # HOLD: the episode goes on


@pytest.mark.parametrize("how", list(COPIES))
@pytest.mark.parametrize("kind", list(MAKERS))
@pytest.mark.parametrize("opponent", [None, "goal_guards"])
def test_a_copy_continues_the_episode_bit_for_bit_and_on_its_own(kind, how, opponent):
    if kind == "holder" and opponent is None:
        pytest.skip("the holder always has a scripted opponent")
    kwargs = {} if kind == "holder" else {"opponent": opponent}
    for seed in (3, 11):
        original = MAKERS[kind](**kwargs)
        _start(kind, original, seed, steps=5)
        before = original.drill_state
        duplicate = COPIES[how](original)
        assert duplicate.drill_state == before and duplicate is not original
        copied = _rest(kind, duplicate, seed)
        assert original.drill_state == before  # stepping the copy never moved the original
        assert _rest(kind, original, seed) == copied
        assert len(copied) > 1


SCENARIO_MAKERS = {
    "aec": scenarios.env,
    "parallel": scenarios.parallel_env,
    "holder": scenarios.holder_env,
}


def _start_for(kind: str, env, seed: int, cycles: int) -> None:
    """Reset with ``seed`` and play random legal actions (the holder: HOLD) for about
    ``cycles`` cycles, the episode still running."""
    rng = np.random.default_rng(seed + 1)
    env.reset(seed=seed)
    while env.drill_state.cycle < cycles:
        if kind == "aec":
            env.step(_pick(rng, env.action_mask()))
        elif kind == "parallel":
            env.step({a: _pick(rng, env.action_mask(a)) for a in env.agents})
        else:
            _, _, term, trunc, _ = env.step(0)
            assert not (term or trunc)


@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
@pytest.mark.parametrize("kind", list(SCENARIO_MAKERS))
@pytest.mark.parametrize("name", ["drill_3v3", "keepaway_4v3"])
def test_a_copy_late_in_a_crowded_episode_continues_bit_for_bit(name, kind, how):
    # Players in contact with more than one body at once: a space whose spatial index were
    # built anew (pymunk's copy) would solve those contacts in another order, and the
    # copy's floats would part from the original's within a few cycles.
    for cycles in (12, 40):
        original = SCENARIO_MAKERS[kind](name)
        _start_for(kind, original, 1, cycles)
        before = original.drill_state
        duplicate = COPIES[how](original)
        copied = _rest(kind, duplicate, 2)
        assert original.drill_state == before
        assert _rest(kind, original, 2) == copied


@pytest.mark.parametrize("how", list(COPIES))
@pytest.mark.parametrize("kind", list(MAKERS))
def test_a_copy_of_an_environment_never_reset_is_never_reset(kind, how):
    duplicate = COPIES[how](MAKERS[kind]())
    with pytest.raises(RuntimeError, match=r"called before reset\(\)"):
        duplicate.drill_state  # noqa: B018
    duplicate.reset(seed=0)


@pytest.mark.parametrize("how", list(COPIES))
@pytest.mark.parametrize("kind", list(MAKERS))
def test_a_rendering_environment_copies_with_its_frames_but_not_its_renderers(kind, how):
    original = MAKERS[kind](render_mode="rgb_array_list")
    _start(kind, original, 0, steps=2)
    duplicate = COPIES[how](original)
    frames, copied = original.render(), duplicate.render()
    assert len(frames) == len(copied) > 0
    for a, b in zip(frames, copied, strict=True):
        np.testing.assert_array_equal(a, b)
    _start(kind, duplicate, 0, steps=4)  # a cycle at least, in the AEC API too
    assert len(duplicate.render()) >= 2  # it draws with a renderer of its own
    duplicate.close()
    original.close()


@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
def test_through_gym_make_only_copy_copy_shares_the_environment_as_the_docstring_says(how):
    env = gym.make("soccer_drill/Holder-v0")
    env.reset(seed=5)
    env.step(0)
    assert copy.copy(env).unwrapped is env.unwrapped  # Gymnasium's wrappers, copied shallowly
    assert "copies shallowly" in soccer_drill.HolderEnv.__doc__
    duplicate = COPIES[how](env)
    assert duplicate.unwrapped is not env.unwrapped
    copied = _rest("holder", duplicate.unwrapped, 5)
    assert _rest("holder", env.unwrapped, 5) == copied and len(copied) > 1


BATCHED = {
    "holder vector": lambda: HolderVectorEnv(num_envs=5, opponent="goal_guards", drills_per_space=2),
    "parallel vector": lambda: ParallelVectorEnv(num_envs=4, opponent="goal_guards"),
}


def _batched_steps(env, seed: int, steps: int) -> list:
    """``steps`` steps of random legal actions drawn from ``seed``; what they returned."""
    rng = np.random.default_rng(seed)
    seen = []
    for _ in range(steps):
        if isinstance(env, HolderVectorEnv):
            obs, rewards, terms, truncs, infos = env.step(rng.integers(3, size=env.num_envs))
            seen.append((obs.tobytes(), rewards.tobytes(), terms.tobytes(), truncs.tobytes(),
                         infos["cycles"].tobytes()))
        else:
            actions = {a: np.array([_pick(rng, m) for m in masks])
                       for a, masks in env.action_masks().items()}
            obs, rewards, terms, truncs, _ = env.step(actions)
            seen.append(({a: o["observation"].tobytes() for a, o in obs.items()},
                         {a: r.tobytes() for a, r in rewards.items()}, env.state().tobytes()))
    return seen


@pytest.mark.parametrize("how", list(COPIES))
@pytest.mark.parametrize("kind", list(BATCHED))
def test_a_copy_of_a_batched_environment_continues_bit_for_bit_and_on_its_own(kind, how):
    original = BATCHED[kind]()
    original.reset(seed=3)
    _batched_steps(original, 4, 5)
    duplicate = COPIES[how](original)
    assert duplicate is not original
    copied = _batched_steps(duplicate, 7, 30)
    # The original, not moved by the copy's steps, plays the same from where it was copied.
    assert _batched_steps(original, 7, 30) == copied


@pytest.mark.parametrize("how", list(COPIES))
@pytest.mark.parametrize("kind", [HolderVectorEnv, ParallelVectorEnv])
def test_a_batched_environment_that_has_drawn_copies_and_draws_on_its_own(kind, how):
    """The renderer's pygame fonts and surfaces are not copied (before: "cannot pickle
    'pygame.font.Font' object" once a frame had been drawn); the copy draws anew, the
    same frames as the original."""
    original = kind(num_envs=2, opponent="goal_guards", render_mode="rgb_array")
    original.reset(seed=3)
    _batched_steps(original, 4, 2)
    original.render()
    duplicate = COPIES[how](original)
    for a, b in zip(original.render(), duplicate.render(), strict=True):
        np.testing.assert_array_equal(a, b)
    assert _batched_steps(duplicate, 7, 5) == _batched_steps(original, 7, 5)
    for a, b in zip(original.render(), duplicate.render(), strict=True):
        np.testing.assert_array_equal(a, b)
    duplicate.close()
    original.close()


@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
def test_a_copy_of_one_batched_drill_late_in_a_crowded_episode_continues_bit_for_bit(how):
    # One drill is in the single drill's own space, which a copy replays (the class
    # docstring's Copies: shared spaces are pymunk's copies, bit for bit only until
    # contacts happen at once).
    config = scenarios.scenario("keepaway_4v3").config()
    original = ParallelVectorEnv(num_envs=1, config=config, opponent="keepaway_takers")
    original.reset(seed=3)
    _batched_steps(original, 4, 30)
    duplicate = COPIES[how](original)
    copied = _batched_steps(duplicate, 7, 40)
    assert _batched_steps(original, 7, 40) == copied


def _compiled_signatures() -> dict[str, int]:
    import sys

    import numba

    return {f"{name}.{key}": len(value.signatures)
            for name, module in list(sys.modules.items())
            if name.startswith(("soccer_drill", "opponents")) and module is not None
            for key, value in vars(module).items() if isinstance(value, numba.core.registry.CPUDispatcher)}


@pytest.mark.parametrize("clone", [copy.deepcopy, lambda env: pickle.loads(pickle.dumps(env))])
def test_a_copy_runs_the_rules_compiled_for_the_original(clone):
    """A copy's arrays are writable where the original's are read-only (the shared
    configuration arrays, a team's settings): they are made read-only again, or the rules
    would be compiled anew for them, inside a team's time-bounded call."""
    from soccer_drill.rules.compiled import COMPILED

    if not COMPILED:
        pytest.skip("the rules run as plain Python")
    env = soccer_drill.env(opponent="goal_guards")
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(8):
        env.step(_pick(rng, env.last()[0]["action_mask"]))
    before = _compiled_signatures()
    copied = clone(env)
    for _ in range(8):
        obs, _, term, trunc, _ = copied.last()
        copied.step(None if term or trunc else _pick(rng, obs["action_mask"]))
    assert _compiled_signatures() == before


@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
def test_through_gymnasiums_vector_wrappers_only_copy_copy_shares_the_batch_as_said(how):
    from gymnasium.wrappers.vector import RecordEpisodeStatistics

    env = RecordEpisodeStatistics(BATCHED["holder vector"]())
    env.reset(seed=3)
    assert copy.copy(env).unwrapped is env.unwrapped  # Gymnasium's wrappers, copied shallowly
    assert "copied shallowly" in HolderVectorEnv.__doc__
    duplicate = COPIES[how](env)
    assert duplicate.unwrapped is not env.unwrapped
    copied = _batched_steps(duplicate.unwrapped, 7, 10)
    assert _batched_steps(env.unwrapped, 7, 10) == copied


class _Homes:
    """A team of one drill with an episode in its attributes: homes drawn at each reset."""

    def reset(self, view, rng):
        self.players = view.players
        self.homes = {p: (float(rng.uniform(5, 30)), float(rng.uniform(2, 10)))
                      for p in view.players}

    def act(self, view):
        return {p: soccer_drill.Command(soccer_drill.Skill.MOVE_TO, self.homes[p])
                for p in self.players}


def _holder_episode(env, seed, actions):
    observations = [env.reset(seed=seed)[0]]
    for action in actions:
        obs, _, terminated, truncated, _ = env.step(action)
        observations.append(obs)
        if terminated or truncated:
            break
    return np.array(observations)


def test_one_team_instance_given_to_two_environments_plays_each_ones_episodes():
    actions = [2, 0, 2, 1, 2, 2]
    alone = [_holder_episode(soccer_drill.HolderEnv(opponent=_Homes()), s, actions)
             for s in (1, 2)]
    team = _Homes()
    first, second = (soccer_drill.HolderEnv(opponent=team) for _ in range(2))
    assert first.loop.core.team.team is team  # the first plays the instance itself
    observations = [[first.reset(seed=1)[0]], [second.reset(seed=2)[0]]]
    for action in actions[:len(alone[0]) - 1]:  # stepped in turn
        observations[0].append(first.step(action)[0])
        if len(observations[1]) < len(alone[1]):
            observations[1].append(second.step(action)[0])
    for got, want in zip(observations, alone, strict=True):
        np.testing.assert_array_equal(np.array(got), want)
    # Gymnasium's sync vector environment passes one instance to every environment.
    envs = gym.make_vec("soccer_drill/Holder-v0", num_envs=2, vectorization_mode="sync",
                        opponent=_Homes())
    obs, _ = envs.reset(seed=[1, 2])
    for step in range(3):
        for k in range(2):
            np.testing.assert_array_equal(obs[k], alone[k][step])
        obs = envs.step(np.array([actions[step]] * 2))[0]


def test_a_shared_team_instance_that_cannot_be_copied_is_refused_saying_why():
    team = _Homes()
    team.lock = threading.Lock()  # copy.deepcopy cannot copy a lock
    first = soccer_drill.HolderEnv(opponent=team)
    with pytest.raises(TypeError, match=r"played by another environment \(or drill\) already"):
        soccer_drill.HolderEnv(opponent=team)
    first.reset(seed=0)
    del first  # gone: the next environment plays the instance itself, as the first did
    second = soccer_drill.HolderEnv(opponent=team)
    assert second.loop.core.team.team is team
    second.reset(seed=0)
