"""Simulated coverage of the 95% intervals of ``ilpss.metrics``, old and new.

Data sets of paired learning curves with known population values are drawn from a
learning-curve model; on each, the intervals that the reports use now (Student t on the
per-seed values or paired differences, Fieller for ratios of means) and the paired
percentile bootstrap they used before are computed, and the share of data sets whose
interval contains the true value is reported, at 10 and 30 seeds. The alternatives that
were considered are shown too: a bootstrap-t (studentised bootstrap) and an
expanded-percentile bootstrap (Hesterberg 2015) for the mean-type metrics, a t interval on
the log ratio (delta method) and an expanded-percentile bootstrap for the ratios.

The curve model (300 episodes, rewards with per-episode noise, not clipped): learning
anew rises from -1 to a per-seed level ``A ~ N(0.3, 0.1)`` with a per-seed time constant
``tau ~ U(40, 80)``; transfer follows the same seed's curve plus a head start
``h * exp(-e / tau)`` with ``h ~ N(0.4, 0.2)``. *Symmetric*: every seed so. *Skewed (20 %
negative transfer)*: each seed with probability 0.2 learns three times slower and starts
0.2 lower instead. True values: the population means of the per-seed metrics (jumpstart,
total-reward gain) and ratios of population means (transfer ratio, restricted mean time
to threshold), by Monte Carlo on 200,000 seeds. The threshold is fixed at 90 % of the way
from -1 to the mean level, on a 20-episode trailing mean.

Run from the repository root (about a minute on one core)::

    python benchmarks/interval_coverage.py --output docs/interval_coverage.md
"""

from __future__ import annotations

import argparse
import platform
import shlex
import sys
import time
from pathlib import Path

import numpy as np
from scipy import stats

from ilpss import metrics

N_EPS, FIRST, WINDOW, FLOOR = 300, 20, 20, -6.0
THRESHOLD = -1.0 + 0.9 * 1.3
NOISE = 0.5
METRICS = ("jumpstart", "total-reward gain", "transfer ratio", "time-to-threshold ratio")


def draw(rng: np.random.Generator, n: int, skewed: bool) -> tuple[np.ndarray, np.ndarray]:
    """``n`` paired seeds: (transfer, baseline) curves of shape ``(n, N_EPS)``."""
    e = np.arange(1, N_EPS + 1, dtype=float)
    level = rng.normal(0.3, 0.1, size=(n, 1))
    tau = rng.uniform(40, 80, size=(n, 1))
    head = rng.normal(0.4, 0.2, size=(n, 1))
    tau_t = tau
    if skewed:
        negative = rng.random((n, 1)) < 0.2
        tau_t = np.where(negative, 3 * tau, tau)
        head = np.where(negative, -0.2, head)
    base = -1 + (1 + level) * (1 - np.exp(-e / tau))
    transfer = -1 + (1 + level) * (1 - np.exp(-e / tau_t)) + head * np.exp(-e / tau)
    return (transfer + NOISE * rng.standard_normal((n, N_EPS)),
            base + NOISE * rng.standard_normal((n, N_EPS)))


def per_seed(t: np.ndarray, b: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray | None]]:
    """Per-seed values of every metric: ``(values, None)`` for means of differences,
    ``(numerator, denominator)`` for ratios of means; leading axes are data sets."""
    shape = t.shape
    flat_t, flat_b = t.reshape(-1, N_EPS), b.reshape(-1, N_EPS)
    times_t = metrics.threshold_times(flat_t, THRESHOLD, WINDOW)[0].reshape(shape[:-1])
    times_b = metrics.threshold_times(flat_b, THRESHOLD, WINDOW)[0].reshape(shape[:-1])
    return {
        "jumpstart": (t[..., :FIRST].mean(-1) - b[..., :FIRST].mean(-1), None),
        "total-reward gain": (t.sum(-1) - b.sum(-1), None),
        "transfer ratio": ((t - FLOOR).sum(-1), (b - FLOOR).sum(-1)),
        "time-to-threshold ratio": (times_t, times_b),
    }


def truth(rng: np.random.Generator, skewed: bool, n: int = 200_000) -> dict[str, float]:
    """Population values, by Monte Carlo."""
    sums: dict[str, list[float]] = {}
    for _ in range(n // 10_000):
        for key, (a, d) in per_seed(*draw(rng, 10_000, skewed)).items():
            acc = sums.setdefault(key, [0.0, 0.0])
            acc[0] += a.sum()
            acc[1] += 0.0 if d is None else d.sum()
    return {k: (a / n if k in METRICS[:2] else a / d) for k, (a, d) in sums.items()}


def bootstrap_t(x: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Studentised bootstrap interval of the mean along the last axis."""
    n = x.shape[-1]
    mean, se = x.mean(-1), x.std(-1, ddof=1) / np.sqrt(n)
    m_b = x @ weights.T
    sd_b = np.sqrt(np.maximum((x**2) @ weights.T - m_b**2, 0.0) * n / (n - 1))
    with np.errstate(divide="ignore", invalid="ignore"):
        t_b = (m_b - mean[..., None]) / (sd_b / np.sqrt(n))
    t_b = np.where(sd_b > 0, t_b, 0.0)
    q_lo, q_hi = np.quantile(t_b, [0.025, 0.975], axis=-1)
    return mean - q_hi * se, mean - q_lo * se


def expanded_levels(n: int) -> tuple[float, float]:
    """Percentile levels of the expanded-percentile bootstrap (Hesterberg 2015): the tail
    ``Phi(-sqrt(n / (n - 1)) t(n-1))`` instead of 0.025."""
    tail = stats.norm.cdf(-np.sqrt(n / (n - 1)) * stats.t.ppf(0.975, n - 1))
    return float(tail), float(1.0 - tail)


def log_t(num: np.ndarray, den: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """t interval on the log of a ratio of paired means, delta-method standard error."""
    n = num.shape[-1]
    m_n, m_d = num.mean(-1), den.mean(-1)
    lin = num / m_n[..., None] - den / m_d[..., None]  # linearised log ratio per seed
    half = stats.t.ppf(0.975, n - 1) * lin.std(-1, ddof=1) / np.sqrt(n)
    ratio = m_n / m_d
    return ratio * np.exp(-half), ratio * np.exp(half)


def coverage(n_sets: int, n_seeds: int, skewed: bool, true: dict[str, float], seed: int,
             n_boot: int) -> dict[str, dict[str, float]]:
    """Coverage of every interval on ``n_sets`` data sets of ``n_seeds`` seeds."""
    rng = np.random.default_rng(seed)
    idx = np.random.default_rng(seed + 1).integers(0, n_seeds, size=(n_boot, n_seeds))
    weights = np.zeros((n_boot, n_seeds))
    np.add.at(weights, (np.arange(n_boot)[:, None], idx), 1.0 / n_seeds)
    hits: dict[str, dict[str, int]] = {k: {} for k in METRICS}
    for start in range(0, n_sets, 250):
        size = min(250, n_sets - start)
        t, b = draw(rng, size * n_seeds, skewed)
        values = per_seed(t.reshape(size, n_seeds, N_EPS), b.reshape(size, n_seeds, N_EPS))
        for key, (a, d) in values.items():
            v = true[key]
            if d is None:
                reps = a @ weights.T
                intervals = {
                    "percentile bootstrap (old)": np.quantile(reps, [0.025, 0.975], axis=-1),
                    "Student t (new)": metrics.t_interval(a)[1:],
                    "bootstrap-t": bootstrap_t(a, weights),
                    "expanded percentile": np.quantile(reps, expanded_levels(n_seeds), axis=-1),
                }
            else:
                reps = (a @ weights.T) / (d @ weights.T)
                intervals = {
                    "percentile bootstrap (old)": np.quantile(reps, [0.025, 0.975], axis=-1),
                    "Fieller (new)": metrics.fieller_interval(a, d)[1:],
                    "t on the log ratio": log_t(a, d),
                    "expanded percentile": np.quantile(reps, expanded_levels(n_seeds), axis=-1),
                }
            for name, (low, high) in intervals.items():
                hits[key][name] = hits[key].get(name, 0) + int(np.sum((low <= v) & (v <= high)))
    return {k: {name: h / n_sets for name, h in row.items()} for k, row in hits.items()}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sets", type=int, default=2000, help="data sets per cell (default 2000)")
    p.add_argument("--boot", type=int, default=2000, help="bootstrap replicates (default 2000)")
    p.add_argument("--output", default=None, help="markdown file to write")
    args = p.parse_args(argv)
    if args.output:
        from ilpss.experiments.outputs import check_out_file

        try:  # before the simulations, not after them
            check_out_file(args.output, "--output")
        except ValueError as exc:
            p.error(str(exc))
    start = time.perf_counter()
    lines = [
        "# Simulated coverage of the 95% intervals",
        "",
        f"Command: `python benchmarks/interval_coverage.py {shlex.join(sys.argv[1:])}`".rstrip()
        + f" (Python {platform.python_version()}, numpy {np.__version__}).",
        "",
        "Share of simulated data sets whose 95% interval contains the true value "
        f"({args.sets} data sets per cell, so a standard error of about "
        f"{np.sqrt(0.95 * 0.05 / args.sets):.3f} around 0.95; {args.boot} bootstrap "
        "replicates). The model and the true values are described in the script's "
        "docstring; [`statistics.md`](statistics.md) says what follows from the table.",
        "",
        "| data | seeds | metric | percentile bootstrap (old) | new (Student t / Fieller) "
        "| bootstrap-t | expanded percentile | t on the log ratio |",
        "|---|---:|---|---:|---:|---:|---:|---:|",
    ]
    columns = ("percentile bootstrap (old)", "new", "bootstrap-t", "expanded percentile",
               "t on the log ratio")
    truths = []
    for skewed in (False, True):
        true = truth(np.random.default_rng(123 + skewed), skewed)
        label = "skewed (20 % negative transfer)" if skewed else "symmetric"
        for n_seeds in (10, 30):
            cov = coverage(args.sets, n_seeds, skewed, true, 1000 * n_seeds + skewed,
                           args.boot)
            for key in METRICS:
                row = {("new" if "(new)" in name else name): c for name, c in cov[key].items()}
                cells = [f"{row[c]:.3f}" if c in row else "" for c in columns]
                lines.append(f"| {label} | {n_seeds} | {key} | " + " | ".join(cells) + " |")
        truths.append(f"{label}: " + ", ".join(f"{k} {v:.4g}" for k, v in true.items()))
    lines += ["", "True values: " + "; ".join(truths) + ".", "",
              f"Wall time: {time.perf_counter() - start:.0f} s.", ""]
    text = "\n".join(lines)
    if args.output:
        from ilpss._io import atomic_write_bytes

        atomic_write_bytes(Path(args.output), text.encode())
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
