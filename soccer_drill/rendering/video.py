"""Videos at true speed from the holder environment, whose steps last several cycles."""

from __future__ import annotations

from typing import Any

import gymnasium as gym


class RecordVideo(gym.wrappers.RecordVideo):
    """Gymnasium's ``RecordVideo``, with its arguments, keeping every frame of a step.

    Gymnasium's wrapper keeps one frame per ``step`` (with ``render_mode="rgb_array_list"``
    the last of the list), which suits environments whose step is one frame. A step of
    :class:`~soccer_drill.envs.holder.HolderEnv` lasts as many 0.1 s cycles as the decision
    took, so that video plays faster than the drill ran: a 4.4 s episode of 11 decisions
    gives a 1.1 s video. This wrapper keeps every frame the environment drew (one per
    cycle with ``"rgb_array_list"``), and the video is written at the environment's
    ``render_fps`` (one frame per cycle), so it lasts as long as the episode::

        env = soccer_drill.rendering.video.RecordVideo(
            gym.make("soccer_drill/Holder-v0", render_mode="rgb_array_list"), "videos")

    ``video_length`` counts frames (cycles), not steps. The frames go into the video
    only: ``render()`` returns those drawn since the last step, not the ones recorded.
    Needs moviepy, as Gymnasium's.
    """

    def __init__(self, env: gym.Env, video_folder: str, **kwargs: Any) -> None:
        if env.render_mode != "rgb_array_list":
            raise ValueError(
                "soccer_drill.rendering.video.RecordVideo needs an environment made with "
                f"render_mode='rgb_array_list' (every cycle's frame), got {env.render_mode!r}"
            )
        super().__init__(env, video_folder, **kwargs)

    def _capture_frame(self) -> None:
        """Every frame since the last capture, where Gymnasium's keeps the last one."""
        self.recorded_frames.extend(self.env.render())
