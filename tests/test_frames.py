"""A frame explains itself: the roles and sides, the holder and its decision, the team,
the time left, the goal line's pay and the outcome; each part can be turned off; the
players drawn are the drill's, however many; nothing is drawn or built without rendering."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import soccer_drill
from soccer_drill.config import DrillConfig
from soccer_drill.rendering import draw
from soccer_drill.rendering.scene import FrameStyle, Scene
from soccer_drill.state import DrillState
from soccer_drill.vector.holder import HolderVectorEnv


def _episode(action: int, seed: int = 0, team: str = "goal_guards"):
    """A holder episode taking ``action`` throughout: (env, scene after the first step,
    its decider's index, the last step's reward)."""
    env = soccer_drill.HolderEnv(opponent=team, render_mode="rgb_array")
    _, info = env.reset(seed=seed)
    decider = soccer_drill.state.PLAYER_NAMES.index(info["holder"])
    assert env.scene.choice is None  # nothing decided yet
    _, reward, terminated, truncated, _ = env.step(action)
    first = env.scene
    while not (terminated or truncated):
        _, reward, terminated, truncated, _ = env.step(action)
    return env, first, decider, reward


def test_the_holder_env_scene_names_the_team_the_decision_and_the_outcome():
    env, first, decider, reward = _episode(2)
    assert (first.team, first.choice, first.chooser) == ("goal_guards", "DRIBBLE", decider)
    env.policy_name = "always dribble"
    end = env.scene
    assert end.outcome in ("success", "interception", "out", "timeout")
    assert end.reward == reward and end.policy == "always dribble"


def test_the_agent_env_scene_shows_the_holders_ball_skill():
    env = soccer_drill.parallel_env(opponent="chasers", render_mode="rgb_array")
    env.reset(seed=0)
    holder = env.drill_state.holder
    actions = {a: 3 for a in env.agents}  # GET_OPEN for the attacker off the ball
    actions[soccer_drill.state.PLAYER_NAMES[holder]] = 1  # PASS
    env.step(actions)
    scene = env.scene
    assert env.drill_state.holder == -1  # the ball travels
    assert scene.team == "chasers" and (scene.chooser, scene.choice) == (holder, "PASS")
    env.reset(seed=0)
    actions[soccer_drill.state.PLAYER_NAMES[holder]] = 0  # HOLD
    env.step(actions)
    assert (env.scene.chooser, env.scene.choice) == (holder, "HOLD")


def _pixel(frame, renderer, xy, dx=0, dy=0):
    x, y = renderer._px(*xy)
    return tuple(int(v) for v in frame[y + dy, x + dx])


def test_players_wear_their_sides_colour_and_the_holder_its_ring():
    env = soccer_drill.HolderEnv(opponent="chasers", render_mode="rgb_array")
    env.reset(seed=0)
    frame, state = env.render(), env.drill_state
    renderer = draw.Renderer(env.config, "rgb_array")
    r = renderer.disc
    for i, name in enumerate(soccer_drill.state.PLAYER_NAMES):
        side = draw.SIDE_COLOURS[draw.side_of(name)]
        edges = [_pixel(frame, renderer, state.pos[i], dx, dy)
                 for dx, dy in ((r - 2, 0), (2 - r, 0), (0, r - 2), (0, 2 - r))]
        assert edges.count(side) >= 2, name  # the ball may cover one side
    assert _pixel(frame, renderer, state.pos[state.holder], dx=r + 4) == draw._HOLDER


def test_roles_are_read_from_the_players_names():
    assert draw.roles(soccer_drill.state.PLAYER_NAMES) == ("A1", "A2", "D1", "D2")
    assert draw.roles(("attacker_0", "attacker_1", "attacker_2", "defender_0")) == (
        "A1", "A2", "A3", "D1")


def test_a_drill_of_another_size_is_drawn_with_its_players():
    players = ("attacker_0", "attacker_1", "attacker_2", "defender_0", "defender_1")
    pos = ((5.0, 30.0), (15.0, 30.0), (25.0, 30.0), (10.0, 5.0), (20.0, 5.0), (15.0, 29.0))
    state = DrillState(pos=pos, vel=((0.0, 0.0),) * 6, holder=1, cycle=3)
    renderer = draw.Renderer(DrillConfig(), "rgb_array", players=players)
    frame = renderer.draw(state, Scene(team="three_v_two"))
    r = renderer.disc
    assert _pixel(frame, renderer, pos[2], dy=r - 2) == draw.SIDE_COLOURS["attacker"]
    assert _pixel(frame, renderer, pos[4], dy=r - 2) == draw.SIDE_COLOURS["defender"]
    assert _pixel(frame, renderer, pos[1], dx=r + 4) == draw._HOLDER


PARTS = [f.name for f in dataclasses.fields(FrameStyle) if f.name != "width"]


@pytest.mark.parametrize("part", PARTS)
def test_each_part_can_be_turned_off(part):
    env, _, _, _ = _episode(2, seed=1)
    state, scene = env.drill_state, env.scene._replace(policy="p", caption="c")
    frames = []
    for style in (FrameStyle(), FrameStyle(**{part: 0 if part == "trails" else False})):
        renderer = draw.Renderer(env.config, "rgb_array", style=style)
        for cycle in range(max(0, state.cycle - 3), state.cycle):  # something to trail
            renderer.draw(state._replace(cycle=cycle, pos=tuple(
                (x + 0.3 * (state.cycle - cycle), y) for x, y in state.pos)), scene)
        frames.append(renderer.draw(state, scene))
    on, off = frames
    if on.shape == off.shape:
        assert not np.array_equal(on, off)
    else:  # the header and the legend are strips of their own
        assert part in ("header", "legend") and off.shape[0] < on.shape[0]


def test_the_end_banner_is_drawn_in_the_outcomes_colour():
    env, _, _, _ = _episode(2, seed=1)
    frame = env.render()
    outcome = env.scene.outcome
    colour = draw._OUTCOME_COLOURS.get(outcome, draw._FAILED)
    middle = frame[draw.HEADER + 200:draw.HEADER + 440]
    assert (middle == colour).all(axis=2).sum() > 200


def test_batched_frames_explain_themselves_too():
    env = HolderVectorEnv(2, opponent="chasers", render_mode="rgb_array")
    env.reset(seed=0)
    frames = env.render()
    assert len(frames) == 2 and frames[0].shape == (draw.HEADER + 640 + draw.LEGEND, 640, 3)
    plain = draw.Renderer(env.config, "rgb_array").draw(env._core.batch.state_of(0))
    assert not np.array_equal(frames[0][:draw.HEADER], plain[:draw.HEADER])  # the team
    env.close()


def test_without_rendering_no_scene_is_built(monkeypatch):
    import soccer_drill.envs.holder as holder

    def refuse(*args, **kwargs):
        raise AssertionError("a scene was built")

    monkeypatch.setattr(holder, "Scene", refuse)
    env = soccer_drill.HolderEnv(opponent="chasers")
    env.reset(seed=0)
    done = False
    while not done:
        *_, terminated, truncated, _ = env.step(0)
        done = terminated or truncated
    drawing = soccer_drill.HolderEnv(opponent="chasers", render_mode="rgb_array_list")
    with pytest.raises(AssertionError, match="a scene was built"):
        drawing.reset(seed=0)


def test_gymnasiums_vector_rendering_wrappers_take_the_batched_drills_frame_rate(monkeypatch):
    import gymnasium as gym
    from gymnasium.wrappers.vector import HumanRendering

    from soccer_drill.vector import ParallelVectorEnv

    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    config = {"cycle_seconds": 0.05}  # 20 frames a second: one frame a cycle is true speed
    single = gym.make("soccer_drill/Holder-v0", config=config).metadata["render_fps"]
    for mode in ("vector_entry_point", "sync"):
        envs = gym.make_vec("soccer_drill/Holder-v0", num_envs=2, vectorization_mode=mode,
                            render_mode="rgb_array", config=config)
        assert envs.metadata["render_fps"] == single == 20
    HumanRendering(envs)  # refused without render_fps (drawing needs opencv, not a test extra)
    agents = ParallelVectorEnv(num_envs=2, config=config)
    assert agents.metadata["render_fps"] == soccer_drill.parallel_env(config=config).metadata["render_fps"]


def test_a_long_header_is_fitted_to_the_frame(monkeypatch):
    # before, a long policy label ran off the frame ("... values bounded, trac")
    drawn = []
    original = draw.Renderer._text

    def text(self, words, at, font=None, *args, **kwargs):
        width = original(self, words, at, font, *args, **kwargs)
        drawn.append((words, at[0] + width))
        return width

    monkeypatch.setattr(draw.Renderer, "_text", text)
    env = soccer_drill.HolderEnv(opponent="goal_guards", render_mode="rgb_array")
    env.reset(seed=0)
    env.policy_name = ("whole past policies, ILPSS-FT's settings, values bounded, tracing "
                       "the options it learnt, greedy")
    frame = env.render()
    header = [(words, right) for words, right in drawn if words.startswith("team ")]
    assert header and header[-1][0].endswith("...") and "policy whole past" in header[-1][0]
    assert all(right <= frame.shape[1] - 8 for _, right in drawn)
    env.policy_name = "pass_first"  # a short one is drawn whole, as before
    drawn.clear()
    env.render()
    assert any(words == "team goal_guards   policy pass_first" for words, _ in drawn)
