"""The region-use figure reads: one row per method and side, names at full length, none
running into another or off the figure (the bars were vertical, their names overlapping)."""

from __future__ import annotations

import itertools

import numpy as np

from ilpss.experiments.region_use import OWN, RegionUse, bars_figure


def test_every_method_and_side_has_a_row_of_its_own_inside_the_figure():
    methods = ["assigned_regions_ft_bounded_cut_primitives", "true_regions_ft_bounded_cut_primitives",
               "ilpss_ft_bounded_cut_primitives", "whole_policies_ft_bounded_cut"]
    use = RegionUse("press_far_contain_near", "contain_cover", "interceptors_press",
                    {(True, "contain_cover"): 3, (True, OWN): 1, (False, "interceptors_press"): 2,
                     (False, "contain_cover"): 1, (False, OWN): 5})
    fig = bars_figure({m: [use] for m in methods})
    renderer = fig.canvas.get_renderer()
    fig.draw(renderer)
    (ax,) = fig.axes
    ticks = [t for t in ax.get_yticklabels() if t.get_text()]
    assert [t.get_text() for t in ticks] == [f"{m}, {side}" for m in methods
                                                    for side in ("far side", "near side")]
    boxes = [t.get_window_extent(renderer) for t in ticks]
    for a, b in itertools.pairwise(boxes):
        assert not a.overlaps(b)
    width, height = fig.bbox.width, fig.bbox.height
    assert all(b.x0 >= 0 and b.x1 <= width and b.y0 >= 0 and b.y1 <= height for b in boxes)
    # the far side's bar of each method: 2 of 8 by the right source, 1 by another, 5 own
    bars = list(ax.patches)
    widths = np.array([p.get_width() for p in bars]).reshape(3, -1)  # parts x rows
    np.testing.assert_allclose(widths[:, 0], [2 / 8, 1 / 8, 5 / 8])
