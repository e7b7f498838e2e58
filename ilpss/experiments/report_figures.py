"""The figures of a report: learning curves of one comparison, protocol B's panels per
held-out team, the score distributions over runs and protocol C's stream. Each is written
with :func:`ilpss._io.save_figure`."""

from __future__ import annotations

import math
import os
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ilpss import metrics
from ilpss._io import save_figure
from ilpss.experiments.report_stats import (
    PRIMARY,
    held_out_team,
    pool,
    target_curves,
    windows,
)
from ilpss.experiments.report_text import ENDPOINT_LABELS, counted, label
from ilpss.plots import curve_style, legend_below, plot_learning_curves


def plot_comparison(curves: dict[str, np.ndarray], path: Path, title: str) -> Path:
    named = {f"{label(m)}": c for m, c in curves.items()}
    window = windows(next(iter(curves.values())).shape[1])[2]
    plot_learning_curves(named, path, title=title, window=window, ylabel="reward per episode")
    return path


def plot_held_out_panels(
    table: dict, teams: Sequence[str], path: str | os.PathLike[str]
) -> Path:
    """Protocol B: one panel per held-out team (in ``teams``' order), each method's curve
    against it averaged per seed over the source orders, mean over seeds with a 95%
    bootstrap band; one legend for all panels. Written atomically."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    ncols = 1 if len(teams) == 1 else 2
    nrows = math.ceil(len(teams) / ncols)
    fig = Figure(figsize=(5.5 * ncols, 3.6 * nrows), layout="constrained")
    FigureCanvasAgg(fig)
    axes = np.atleast_1d(fig.subplots(nrows, ncols, sharex=True, sharey=True)).ravel()
    handles: dict[str, Any] = {}
    for ax, team in zip(axes, teams, strict=False):
        streams = [s for s in table if held_out_team(s) == team]
        curves = pool([target_curves(table[s]) for s in streams])
        for i, (method, c) in enumerate(curves.items()):
            window = windows(c.shape[1])[2]
            sm = metrics.smooth(c, window)
            xs = np.arange(1, sm.shape[1] + 1)
            colour, style = curve_style(i)
            if len(sm) >= 2:
                mean, low, high = metrics.mean_curve_band(sm, seed=0)
                ax.fill_between(xs, low, high, color=colour, alpha=0.2, linewidth=0)
            else:
                mean = sm.mean(axis=0)
            (handles[method],) = ax.plot(xs, mean, color=colour, linestyle=style, linewidth=1.3)
        ax.set_title(f"held out: {team} ({len(streams)} source order"
                     f"{'s' if len(streams) != 1 else ''})", fontsize=10)
        ax.grid(True, alpha=0.3)
    for i, ax in enumerate(axes):
        if i >= len(teams):
            ax.set_visible(False)
        elif i + ncols >= len(teams):  # nothing drawn below this panel: label its x axis
            ax.xaxis.set_tick_params(labelbottom=True)
            ax.set_xlabel("episode")
    for ax in axes[::ncols]:
        ax.set_ylabel(f"reward (trailing mean over {window})")
    n_seeds = len(next(iter(curves.values())))
    fig.suptitle(f"Learning against each held-out team ({counted(n_seeds, 'seed')})",
                 fontsize=11)
    legend_below(fig, list(handles.values()), [label(m) for m in handles], most_columns=4)
    return save_figure(fig, path, dpi=110)


def run_scores(curve_sets: Sequence[dict[str, np.ndarray]],
               baseline: str) -> dict[str, dict[str, np.ndarray]]:
    """``{endpoint label: {method label: per-run value}}`` of the :data:`PRIMARY`
    endpoints, one value per seed and comparison (stream or opponent), every method
    against the baseline. For pictures: runs of one seed are not independent."""
    out: dict[str, dict[str, list]] = {ENDPOINT_LABELS[e]: defaultdict(list) for e in PRIMARY}
    for curves in curve_sets:
        first, last, _ = windows(curves[baseline].shape[1])
        for method, c in curves.items():
            if method == baseline:
                continue
            gains = metrics.per_seed_gains(c, curves[baseline], first=first, last=last)
            for e in PRIMARY:
                out[ENDPOINT_LABELS[e]][label(method)].append(gains[e])
    return {e: {m: np.concatenate(v) for m, v in ms.items()} for e, ms in out.items()}


def plot_stream(
    jumpstarts: list[tuple[int, metrics.MetricEstimate]], sizes: dict[str, np.ndarray],
    path: str | os.PathLike[str], featured: str | None = None, baseline: str | None = None,
) -> Path:
    """Protocol C: the featured method's jumpstart over the baseline on each new opponent
    (95% t interval over seeds, unadjusted), and each method's library size over the
    stream, each panel titled with what it shows and the legend below the axes."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    tasks = [t for t, _ in jumpstarts]
    values = [js.value for _, js in jumpstarts]
    lows = [js.low for _, js in jumpstarts]
    highs = [js.high for _, js in jumpstarts]
    fig = Figure(figsize=(11, 4), layout="constrained")
    FigureCanvasAgg(fig)
    ax1, ax2 = fig.subplots(1, 2)
    ax1.errorbar(tasks, values, yerr=[np.subtract(values, lows), np.subtract(highs, values)],
                 fmt="o-", capsize=3)
    ax1.axhline(0, color="grey", lw=1)
    ax1.set_xlabel("opponent index in the stream")
    ax1.set_ylabel("jumpstart (first episodes)")
    if featured and baseline:
        ax1.set_title(f"{label(featured)} against {label(baseline)}:\njumpstart on each new "
                      "opponent (95% t over seeds, unadjusted)", fontsize=9)
    handles, names = [], []
    for i, (method, runs) in enumerate(sizes.items()):
        mean = runs.mean(axis=0)
        colour, style = curve_style(i)
        (line,) = ax2.plot(np.arange(1, len(mean) + 1), mean, marker="o", markersize=3,
                           color=colour, linestyle=style)
        handles.append(line)
        names.append(label(method))
    ax2.set_xlabel("trials completed")
    ax2.set_ylabel("active options (mean over seeds)")
    ax2.set_title("the option library's size over the stream", fontsize=9)
    if handles:
        legend_below(fig, handles, names, most_columns=3)
    return save_figure(fig, path, dpi=120)
