"""The region-use figure reads: one row per method and side, names at full length, none
running into another or off the figure (the bars were vertical, their names overlapping)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from ilpss.experiments.region_use import OWN, RegionUse, bars_figure, page, target_trials


def test_every_method_and_side_has_a_row_of_its_own_inside_the_figure():
    methods = ["assigned_regions_ft_bounded_cut_primitives", "true_regions_ft_bounded_cut_primitives",
               "ilpss_ft_bounded_cut_primitives", "whole_policies_ft_bounded_cut"]
    use = RegionUse("press_far_contain_near", "contain_cover", "interceptors_press",
                    {(True, "contain_cover"): 3, (True, OWN): 1, (False, "interceptors_press"): 2,
                     (False, "contain_cover"): 1, (False, OWN): 5}, "dist_goal")
    fig = bars_figure({m: [use] for m in methods})
    renderer = fig.canvas.get_renderer()
    fig.draw(renderer)
    (ax,) = fig.axes
    ticks = [t for t in ax.get_yticklabels() if t.get_text()]
    assert [t.get_text() for t in ticks] == [
        f"{m}, dist_goal {side} the threshold" for m in methods for side in ("above", "at or below")]
    boxes = [t.get_window_extent(renderer) for t in ticks]
    for a, b in itertools.pairwise(boxes):
        assert not a.overlaps(b)
    width, height = fig.bbox.width, fig.bbox.height
    assert all(b.x0 >= 0 and b.x1 <= width and b.y0 >= 0 and b.y1 <= height for b in boxes)
    # the far side's bar of each method: 2 of 8 by the right source, 1 by another, 5 own
    bars = list(ax.patches)
    widths = np.array([p.get_width() for p in bars]).reshape(3, -1)  # parts x rows
    np.testing.assert_allclose(widths[:, 0], [2 / 8, 1 / 8, 5 / 8])


def test_targets_split_by_different_features_are_rows_of_their_own():
    # before, protocol R's targets split by distance to goal and by side were pooled into
    # one "far side"/"near side" pair of rows
    def use(target, split, right_below):
        return RegionUse(target, "a", "b", {(True, "a"): right_below, (True, OWN): 4 - right_below,
                                            (False, "b"): 4}, split)

    uses = {"ilpss": [use("near", "dist_goal", 4), use("left", "lateral", 0)]}
    text = page(uses, "ilpss-region-use run", None)
    rows = [line for line in text.splitlines() if line.startswith("| `ilpss`")]
    assert rows == [
        "| `ilpss` | `dist_goal` above the threshold | 4 | 100% | 0% | 0% |",
        "| `ilpss` | `dist_goal` at or below the threshold | 4 | 100% | 0% | 0% |",
        "| `ilpss` | `lateral` above the threshold | 4 | 100% | 0% | 0% |",
        "| `ilpss` | `lateral` at or below the threshold | 4 | 0% | 0% | 100% |",
    ]


@pytest.mark.parametrize("protocol", ["R", "S"])
def test_every_target_of_a_stream_is_read_at_its_own_trial(protocol):
    # before, a target whose checkpoint holds the sources and itself (targets starting
    # from the sources) was skipped unless it was the first: its trial was read as its
    # index in the stream, which its checkpoint does not hold
    from ilpss.experiments.run import ExperimentConfig

    stream = ExperimentConfig(protocol=protocol, n_seeds=2).streams(0)[0]
    found = target_trials(stream)
    assert [t for t, _, _ in found] == list(range(stream.first_target, len(stream.tasks)))
    assert len(found) > 1 and stream.shared_start
    assert {trial for _, trial, _ in found} == {stream.first_target}
    assert [branch for t, _, branch in found] == [t for t, _, _ in found]
