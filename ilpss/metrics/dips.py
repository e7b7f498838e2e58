"""The handover: how far a trailing mean falls below its earlier maximum, and how long it
lies below the baseline's."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ilpss.metrics._validation import FloatArray, _as_floats, _check_count, _check_real
from ilpss.metrics.curves import smooth


def largest_dip(curves: ArrayLike, window: int) -> FloatArray:
    """How far each curve's trailing mean falls below its earlier maximum: per row, the
    largest ``max(m[u] for u <= t) - m[t]`` over ``t``, where ``m`` is the trailing mean
    over ``window`` episodes from the first full window on (episode ``window``, so that
    no early few-episode mean counts as a maximum). 0 for a curve whose trailing mean
    never falls. A 1-D curve gives a 0-D array.

    A learner that starts high and then collapses before it recovers (a head start
    handed over too early) has a large dip even when its total reward is good.
    """
    arr = _as_floats(curves, "curves")
    if arr.ndim not in (1, 2) or arr.shape[-1] == 0:
        raise ValueError(f"curves: give one curve or rows of curves, not empty; got shape "
                         f"{arr.shape}")
    m = smooth(arr, _check_count(window, "window", arr.shape[-1]), edges="valid")
    return np.max(np.maximum.accumulate(m, axis=-1) - m, axis=-1)


BELOW_MARGIN = 0.05
"""How far below the baseline's trailing mean a trailing mean must lie to count as below
it (:func:`episodes_below`)."""


def episodes_below(curves: ArrayLike, baseline: ArrayLike, window: int,
                   margin: float = BELOW_MARGIN) -> FloatArray:
    """Per row, the episodes (from the first full window on) at which the trailing mean
    over ``window`` episodes of ``curves`` lies more than ``margin`` below that of the
    paired ``baseline`` row: how long a method does worse than learning anew."""
    t, b = _as_floats(curves, "curves"), _as_floats(baseline, "baseline")
    margin = _check_real(margin, "margin")
    if t.shape != b.shape:
        raise ValueError(f"curves and baseline must have the same shape, got {t.shape} and "
                         f"{b.shape}")
    window = _check_count(window, "window", t.shape[-1])
    below = smooth(t, window, edges="valid") < smooth(b, window, edges="valid") - margin
    return below.sum(axis=-1).astype(np.float64)
