"""Video at true speed: one frame per 0.1 s cycle in every environment, ``render_fps``
saying so, and a written video as long as the episode."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import soccer_drill


def _first_legal(mask: np.ndarray) -> int:
    return int(np.flatnonzero(mask)[0])


def _aec_episode(env, seed: int, render_every_turn: bool = False) -> tuple[list, int]:
    env.reset(seed=seed)
    frames = list(env.render())
    for _agent in env.agent_iter():
        obs, _, term, trunc, info = env.last()
        env.step(None if term or trunc else _first_legal(obs["action_mask"]))
        if render_every_turn:
            frames += env.render()
    frames += env.render()
    return frames, info["cycles"]


@pytest.mark.parametrize("opponent", [None, "chasers"])
def test_aec_rgb_array_list_gives_one_frame_per_cycle(opponent):
    env = soccer_drill.env(opponent=opponent, render_mode="rgb_array_list")
    reference = soccer_drill.env(opponent=opponent, render_mode="rgb_array")
    frames, cycles = _aec_episode(env, seed=4)
    again, _ = _aec_episode(env, seed=4, render_every_turn=True)  # however often render() is called
    assert len(frames) == len(again) == cycles + 1  # the reset's frame, then one per cycle
    # The frames are the cycles' own: those rgb_array draws once per cycle.
    reference.reset(seed=4)
    drawn = [reference.render()]
    for agent in reference.agent_iter():
        obs, _, term, trunc, _ = reference.last()
        reference.step(None if term or trunc else _first_legal(obs["action_mask"]))
        if agent == reference.possible_agents[-1] and not (term or trunc):  # a cycle ran
            drawn.append(reference.render())
    assert len(drawn) == len(frames)
    for a, b, c in zip(frames, again, drawn, strict=True):
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(a, c)


def test_parallel_rgb_array_list_gives_one_frame_per_cycle():
    env = soccer_drill.parallel_env(render_mode="rgb_array_list")
    obs, _ = env.reset(seed=2)
    frames = env.render()
    assert len(frames) == 1 and env.render() == []
    while env.agents:
        obs, _, _, _, infos = env.step({a: _first_legal(obs[a]["action_mask"]) for a in env.agents})
        new = env.render()
        assert len(new) == 1
        frames += new
    assert len(frames) == next(iter(infos.values()))["cycles"] + 1


@pytest.mark.parametrize("make", [soccer_drill.env, soccer_drill.parallel_env, soccer_drill.HolderEnv])
def test_render_fps_is_one_frame_per_cycle(make):
    assert make().metadata["render_fps"] == 10
    env = make(config={"cycle_seconds": 0.05}, render_mode="rgb_array_list")
    assert env.metadata["render_fps"] == 20
    assert "rgb_array_list" in env.metadata["render_modes"]
    assert make(config={"cycle_seconds": 0.03}).metadata["render_fps"] == pytest.approx(100 / 3)


def test_the_holder_offers_action_masks_for_maskable_ppo():
    env = gym.make("soccer_drill/Holder-v0")
    env.reset(seed=0)
    mask = env.unwrapped.action_masks()
    assert mask.dtype == bool and mask.tolist() == [True, True, True]
    assert env.get_wrapper_attr("action_masks")().all()  # as SB3's vector envs call it


def _duration(path) -> float:
    from moviepy import VideoFileClip

    with VideoFileClip(str(path)) as clip:
        return clip.duration


# moviepy sums its frames' times in floats and may drop the last frame (60 frames at 10
# fps give a 5.9 s video): a video is as long as its frames, give or take that one frame.
ONE_FRAME = 0.1 + 1e-6


@pytest.mark.integrations
def test_record_video_of_a_holder_episode_lasts_as_long_as_the_episode(tmp_path):
    from soccer_drill.rendering.video import RecordVideo

    env = RecordVideo(gym.make("soccer_drill/Holder-v0", render_mode="rgb_array_list"),
                      str(tmp_path / "ours"), name_prefix="holder")
    plain = gym.wrappers.RecordVideo(
        gym.make("soccer_drill/Holder-v0", render_mode="rgb_array_list"),
        str(tmp_path / "gymnasium"), name_prefix="holder")
    for recorder in (env, plain):
        recorder.reset(seed=0)
        steps, done = 0, False
        while not done:
            _, _, terminated, truncated, info = recorder.step(1)
            steps += 1
            done = terminated or truncated
        recorder.close()
    seconds = (info["cycles"] + 1) / 10  # the reset's frame, then one per 0.1 s cycle
    assert steps < info["cycles"]  # steps last several cycles
    assert _duration(tmp_path / "ours" / "holder-episode-0.mp4") == pytest.approx(seconds, abs=ONE_FRAME)
    # Gymnasium's own keeps one frame per step: the video is that much shorter.
    short = _duration(tmp_path / "gymnasium" / "holder-episode-0.mp4")
    assert short == pytest.approx((steps + 1) / 10, abs=ONE_FRAME)
    with pytest.raises(ValueError, match="render_mode='rgb_array_list'"):
        RecordVideo(gym.make("soccer_drill/Holder-v0", render_mode="rgb_array"), str(tmp_path))


@pytest.mark.integrations
def test_an_aec_video_written_at_render_fps_lasts_as_long_as_the_episode(tmp_path):
    from gymnasium.utils.save_video import save_video

    env = soccer_drill.env(opponent="chasers", render_mode="rgb_array_list")
    frames, cycles = _aec_episode(env, seed=1, render_every_turn=True)
    save_video(frames, str(tmp_path), fps=env.metadata["render_fps"], name_prefix="aec")
    assert _duration(tmp_path / "aec-episode-0.mp4") == pytest.approx((cycles + 1) / 10, abs=ONE_FRAME)
