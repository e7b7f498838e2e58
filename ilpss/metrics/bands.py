"""Pointwise bootstrap bands of the mean learning curve over seeds, for plotting."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ilpss.metrics._validation import FloatArray, _as_curves
from ilpss.metrics.inference import _check_boot, _resample_counts

#: Replicates of the seed-mean curve processed at once (bounds memory to
#: ``chunk * n_episodes`` floats).
_MAX_CHUNK_ELEMENTS = 2_000_000


def mean_curve_band(
    curves: ArrayLike, n_boot: int = 2000, confidence: float = 0.95, seed: int = 0
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Mean learning curve over seeds with a pointwise percentile-bootstrap band.

    Each replicate resamples seeds (rows) with replacement once, for all episodes at
    once; ``low``/``high`` are the per-episode percentiles of the replicate means. The
    band is pointwise (not simultaneous over episodes).

    Parameters
    ----------
    curves : array_like, shape (n_seeds, n_episodes)
        One learning curve per seed, finite, ``n_seeds >= 2``.
    n_boot : int
        Bootstrap replicates (default 2000).
    confidence : float
        Coverage in ``(0, 1)`` (default 0.95).
    seed : int
        Seed of the resampling; same seed, same band.

    Returns
    -------
    mean, low, high : ndarray, shape (n_episodes,)

    Raises
    ------
    ValueError
        Non-finite/empty input, wrong shape, fewer than 2 seeds, bad ``n_boot`` or
        ``confidence``.
    """
    arr = _as_curves(curves)
    n_seeds, n_eps = arr.shape
    n_boot, confidence = _check_boot(n_boot, n_seeds, confidence)
    weights = _resample_counts(n_seeds, n_boot, seed) / n_seeds
    alpha = 1.0 - confidence
    low = np.empty(n_eps)
    high = np.empty(n_eps)
    step = max(1, _MAX_CHUNK_ELEMENTS // n_boot)
    for start in range(0, n_eps, step):  # chunk over episodes to bound memory
        cols = slice(start, start + step)
        reps = weights @ arr[:, cols]  # (n_boot, chunk): replicate mean curves
        low[cols], high[cols] = np.quantile(reps, [alpha / 2.0, 1.0 - alpha / 2.0], axis=0)
    return arr.mean(axis=0), low, high
