"""Checks of the inputs of every metric: curves, counts, reals, confidence levels, floors.

Each raises :class:`ValueError` saying what was wrong and what is allowed.
"""

from __future__ import annotations

import math
import reprlib

import numpy as np
from numpy.typing import ArrayLike, NDArray

from soccer_drill.constraints import is_int, is_real

FloatArray = NDArray[np.float64]
"""The float64 arrays every metric takes and gives."""


def _as_floats(values: ArrayLike, name: str) -> FloatArray:
    """``values`` as a float64 array, if they are numbers (Python's or NumPy's, bools
    included) in a regular shape: text, ``None`` and other objects (an array of objects
    too), which NumPy would parse or keep, and rows of different lengths are refused by
    name."""
    try:
        arr = np.asarray(values)
    except ValueError:  # NumPy's "inhomogeneous shape"
        raise ValueError(f"{name}: rows of different lengths; give a regular array of "
                         "numbers") from None
    if arr.dtype.kind not in "biuf":
        raise ValueError(f"{name} holds {arr.dtype} values ({reprlib.repr(values)}); give "
                         "numbers (Python's or NumPy's)")
    return arr.astype(np.float64, copy=False)


def _as_curve(curve: ArrayLike, name: str = "curve") -> FloatArray:
    """``curve`` as a finite, non-empty 1-D float64 array, or :class:`ValueError`."""
    arr = _as_floats(curve, name)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be 1-D (one reward per episode), got shape {arr.shape}")
    if arr.size == 0:
        raise ValueError(f"{name} is empty")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return arr


def _as_curves(curves: ArrayLike, name: str = "curves") -> FloatArray:
    """``curves`` as a finite, non-empty ``(n_seeds, n_episodes)`` float64 array."""
    arr = _as_floats(curves, name)
    if arr.ndim != 2:
        raise ValueError(f"{name} must have shape (n_seeds, n_episodes), got shape {arr.shape}")
    if arr.size == 0:
        raise ValueError(f"{name} is empty (shape {arr.shape})")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return arr


def _pair(transfer: ArrayLike, baseline: ArrayLike) -> tuple[FloatArray, FloatArray]:
    t = _as_curve(transfer, "transfer")
    b = _as_curve(baseline, "baseline")
    if t.shape != b.shape:
        raise ValueError(
            f"transfer and baseline must have the same length, got {t.size} and {b.size}"
        )
    return t, b


def _check_count(value: int, name: str, length: int) -> int:
    """A positive integer ``value`` that does not exceed ``length``."""
    if not is_int(value):
        raise ValueError(f"{name} must be a positive integer, got {value!r}")
    value = int(value)
    if value < 1:
        raise ValueError(f"{name} must be >= 1, got {value}")
    if value > length:
        raise ValueError(f"{name}={value} exceeds the curve length {length}")
    return value


def _check_real(value: float, name: str) -> float:
    if not is_real(value) or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite real number, got {value!r}")
    return float(value)


def _check_confidence(confidence: float) -> float:
    confidence = _check_real(confidence, "confidence")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")
    return confidence


def _check_floor(arr: FloatArray, floor: float, name: str) -> float:
    floor = _check_real(floor, "floor")
    if np.any(arr < floor):
        raise ValueError(
            f"{name} has rewards below floor={floor} (min {arr.min()}); the floor must be "
            "the minimum possible reward"
        )
    return floor
