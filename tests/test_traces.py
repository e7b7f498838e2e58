"""Tests of ilpss.traces: sparse replacing traces give the dense rule's numbers."""

from __future__ import annotations

import numpy as np
import pytest

from ilpss.policy import LinearPolicy
from ilpss.tiles import TileCoder
from ilpss.traces import MIN_TRACE, ReplacingTraces


def dense_update(weights, traces, active, choice, target, step, decay, cut):
    """The rule of the module docstring, on dense arrays (one eligibility per weight)."""
    delta = target - float(np.take(weights[choice], active).sum())
    traces[:, active] = 0.0
    traces[choice, active] = 1.0
    weights += step * delta * traces
    if cut:
        traces[:] = 0.0
        return
    traces *= decay
    traces[traces < MIN_TRACE] = 0.0


@pytest.mark.parametrize("n_choices", [3, 40])
def test_sparse_traces_give_the_dense_numbers_bit_for_bit(n_choices: int) -> None:
    coder = TileCoder([0.0, 0.0], [10.0, 5.0], [1.0, 0.5], n_tilings=8)
    rng = np.random.default_rng(n_choices)
    start = rng.normal(size=(n_choices, coder.n_weights)) / coder.n_active
    q = LinearPolicy(coder, 3, tuple(range(n_choices - 3)), weights=start)
    weights, dense = start.copy(), np.zeros_like(start)
    traces = ReplacingTraces(q)
    x = np.array([5.0, 2.5])
    for t in range(400):
        x = np.clip(x + rng.normal(0.0, 0.4, 2), 0.0, [10.0, 5.0])  # nearby states share tiles
        active = coder.active(x)
        choice = int(rng.integers(n_choices))
        target, decay, cut = float(rng.normal()), float(rng.choice([0.9, 0.5, 0.0])), \
            bool(rng.random() < 0.05)
        traces.update(active, choice, target, 0.1 / coder.n_active, decay, cut)
        dense_update(weights, dense, active, choice, target, 0.1 / coder.n_active, decay, cut)
        assert q.weights.tobytes() == weights.tobytes(), f"step {t}"
        for c in range(n_choices):
            assert traces.eligibility(c).tobytes() == dense[c].tobytes(), f"step {t}"
        assert set(traces.rows) == set(np.flatnonzero(dense.any(axis=1)))


def test_a_non_finite_update_is_applied_densely() -> None:
    coder = TileCoder([0.0], [10.0], [1.0], n_tilings=4)
    q = LinearPolicy(coder, 3)
    traces = ReplacingTraces(q)
    traces.update(coder.active([2.0]), 0, 1.0, 0.1, 0.9, False)
    with np.errstate(invalid="ignore"):  # inf * 0, as in the dense rule
        traces.update(coder.active([7.0]), 1, np.inf, 0.1, 0.9, False)
    assert np.isnan(q.weights[0]).any() and np.isinf(q.weights[1]).any()  # as the dense rule
    assert (q.weights[2] == 0.0).all()  # a choice without eligible tiles is left alone
