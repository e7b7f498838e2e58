"""Frames are ``FrameStyle.width`` pixels wide whatever the field, and show everything
within the walls."""

from __future__ import annotations

import pytest

import soccer_drill
from soccer_drill.config import DrillConfig
from soccer_drill.rendering.draw import HEADER, LEGEND, Renderer
from soccer_drill.rendering.scene import MIN_WIDTH, FrameStyle


def _frame(config, style=None):
    env = soccer_drill.HolderEnv(config=config, render_mode="rgb_array", render_style=style)
    env.reset(seed=0)
    return env.render()


def test_the_default_frame_is_640_pixels_wide_with_a_header_and_a_legend():
    assert _frame(DrillConfig()).shape == (HEADER + 640 + LEGEND, 640, 3)


def test_the_largest_field_is_drawn_at_the_frames_width():
    config = DrillConfig(field_size=1000.0, attacker_starts=((100.0, 900.0), (900.0, 900.0)),
                         defender_starts=((300.0, 200.0), (600.0, 200.0)))
    height, width, _ = _frame(config).shape
    assert width == 640 and height == HEADER + 640 + LEGEND


def test_a_frame_without_header_and_legend_is_the_field_alone():
    style = FrameStyle(width=700, header=False, legend=False)
    assert _frame(DrillConfig(), style).shape == (700, 700, 3)


@pytest.mark.parametrize("width", [MIN_WIDTH - 1, 0, 600.5, True])
def test_a_frame_narrower_than_the_minimum_is_refused(width):
    with pytest.raises(ValueError, match=r"FrameStyle\.width must be"):
        FrameStyle(width=width)


def test_far_walls_are_inside_the_frame():
    config = DrillConfig(wall_margin=50.0)
    renderer = Renderer(config, "rgb_array")
    frame = _frame(config)
    assert frame.shape == (renderer.size[1], renderer.size[0], 3)
    for corner in ((-50.0, -50.0), (85.0, 85.0)):  # the walls' corners, 50 m out
        x, y = renderer._px(*corner)
        assert 0 <= x < frame.shape[1] and HEADER <= y < frame.shape[0] - LEGEND


@pytest.mark.parametrize("style", [{"width": 700}, "wide", 640])
def test_a_render_style_that_is_not_a_frame_style_is_refused(style):
    with pytest.raises(ValueError, match=r"render_style must be None or a "
                                         r"soccer_drill\.rendering\.scene\.FrameStyle"):
        soccer_drill.HolderEnv(render_mode="rgb_array", render_style=style)
