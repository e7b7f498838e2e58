"""Frames stay a bounded size whatever the field, and show everything within the walls."""

from __future__ import annotations

import soccer_drill
from soccer_drill.config import DrillConfig
from soccer_drill.rendering.draw import MAX_SIDE, Renderer


def _frame(config):
    env = soccer_drill.HolderEnv(config=config, render_mode="rgb_array")
    env.reset(seed=0)
    return env.render()


def test_the_default_field_is_drawn_at_twelve_pixels_a_metre():
    assert _frame(DrillConfig()).shape == (492, 468, 3)  # (35 + 2 * 2) m * 12, and the caption


def test_the_largest_field_is_drawn_within_max_side_pixels():
    config = DrillConfig(field_size=1000.0, attacker_starts=((100.0, 900.0), (900.0, 900.0)),
                         defender_starts=((300.0, 200.0), (600.0, 200.0)))
    height, width, _ = _frame(config).shape
    assert width == MAX_SIDE and height == MAX_SIDE + 24


def test_far_walls_are_inside_the_frame():
    config = DrillConfig(wall_margin=50.0)
    renderer = Renderer(config, "rgb_array")
    frame = _frame(config)
    assert frame.shape == (renderer.size[1], renderer.size[0], 3)
    for corner in ((-50.0, -50.0), (85.0, 85.0)):  # the walls' corners, 50 m out
        x, y = renderer._px(*corner)
        assert 0 <= x < frame.shape[1] and 24 <= y < frame.shape[0]
