"""Learning-curve and score-distribution figures (matplotlib, Agg canvas, no display).

The figure is drawn on a :class:`matplotlib.figure.Figure` with an explicit
:class:`~matplotlib.backends.backend_agg.FigureCanvasAgg`; pyplot and the global backend
are never touched, so importing this module is safe in headless jobs and in processes
that use another backend. Files are written atomically (temporary file in the
destination directory, then :func:`os.replace`, via :func:`ilpss._io.save_figure`).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from ilpss._io import save_figure
from ilpss.metrics import mean_curve_band, smooth

__all__ = ["plot_learning_curves"]


LEGEND_INSIDE_AT_MOST = 5
"""Curves whose legend fits inside the axes; with more it goes below them."""
LEGEND_ROW_INCHES = 0.2
"""The height a row of the legend below the axes adds to the figure (a title is a row,
and one more row is its margin)."""


def _x_for(name: str, n: int, x: Mapping[str, ArrayLike] | ArrayLike | None) -> np.ndarray:
    """x coordinates of method ``name``: 1..n by default, else from ``x``."""
    if x is None:
        return np.arange(1, n + 1, dtype=float)
    xs = x.get(name) if isinstance(x, Mapping) else x
    if xs is None:
        raise ValueError(f"x has no entry for method {name!r}")
    xs = np.asarray(xs, dtype=float)
    if xs.shape != (n,) or not np.all(np.isfinite(xs)):
        raise ValueError(f"x for method {name!r} must be {n} finite values, got shape {xs.shape}")
    return xs


def plot_learning_curves(
    curves: Mapping[str, ArrayLike],
    path: str | os.PathLike[str],
    *,
    title: str,
    xlabel: str = "episode",
    ylabel: str = "mean reward",
    window: int = 1,
    band: bool = True,
    markers: Mapping[str, float] | None = None,
    x: Mapping[str, ArrayLike] | ArrayLike | None = None,
    n_boot: int = 2000,
    confidence: float = 0.95,
    seed: int = 0,
    dpi: int = 150,
) -> Path:
    """Plot mean learning curves over seeds with bootstrap bands and save a PNG.

    Each seed's curve is first smoothed by a trailing mean over ``window`` episodes
    (:func:`ilpss.metrics.smooth`, expanding edges); then the mean over seeds is drawn with
    a pointwise percentile-bootstrap band (:func:`ilpss.metrics.mean_curve_band`, resampling
    seeds). One colour per method; the legend gives each method's number of seeds.

    Parameters
    ----------
    curves : mapping of str to array_like
        Method name -> rewards of shape ``(n_seeds, n_episodes)`` (a 1-D array is one
        seed). Methods may have different lengths. Insertion order sets colours and legend.
    path : str or os.PathLike
        Destination PNG; missing parent directories are created. Written atomically.
    title, xlabel, ylabel : str
        Labels. When ``window > 1`` the y label gets the suffix
        ``"(trailing mean over W)"``.
    window : int
        Trailing-mean window (default 1: no smoothing).
    band : bool
        Draw the bootstrap band (default True; skipped for single-seed methods).
    markers : mapping of str to float, optional
        Labelled vertical reference lines, label -> x position (e.g. where the opponent
        changes or an option library is extracted).
    x : array_like or mapping of str to array_like, optional
        x coordinates, e.g. the episode numbers of evaluation points; a single array is
        used for every method. Default: ``1..n_episodes``.
    n_boot, confidence, seed : int, float, int
        Bootstrap replicates, band coverage and resampling seed (deterministic output).
    dpi : int
        Resolution of the PNG.

    Returns
    -------
    pathlib.Path
        The written file.

    Raises
    ------
    ValueError
        No methods, invalid curves (NaN, empty, wrong ndim), ``window`` longer than a
        curve, or ``x`` of the wrong length.
    """
    if not curves:
        raise ValueError("curves is empty: nothing to plot")
    path = Path(path)
    crowded = len(curves) > LEGEND_INSIDE_AT_MOST
    fig = Figure(figsize=(7.0, 4.5), layout="constrained")
    FigureCanvasAgg(fig)  # explicit Agg canvas: no display, no pyplot state
    ax = fig.add_subplot()
    for i, (name, raw) in enumerate(curves.items()):
        _draw_mean_curve(ax, i, name, raw, window=window, band=band, x=x, crowded=crowded,
                         n_boot=n_boot, confidence=confidence, seed=seed)
    for label, pos in (markers or {}).items():
        _draw_marker(ax, label, pos)
    ax.set_title(title)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel + (f" (trailing mean over {window})" if window > 1 else ""))
    ax.grid(True, alpha=0.3)
    _legend(fig, ax, f"mean, {confidence * 100:g}% bootstrap band" if band else "mean", crowded)
    return save_figure(fig, path, format="png", dpi=dpi)


def _legend(fig: Figure, ax, title: str, crowded: bool) -> None:
    """The legend inside the axes, or below them when ``crowded``."""
    if crowded:
        legend_below(fig, *ax.get_legend_handles_labels(), title=title, most_columns=2)
    else:
        ax.legend(title=title, fontsize=8, title_fontsize=8, loc="best")


def legend_below(fig: Figure, handles: list, labels: list[str], *, title: str | None = None,
                 most_columns: int = 2) -> None:
    """One legend below the axes of ``fig`` (constrained layout), in as many columns (at
    most ``most_columns``) as fit the figure's width, so long method names are never cut
    off at its edges; the figure grows by the legend's rows, so the axes keep their size."""
    height = fig.get_figheight()
    for ncols in range(min(most_columns, len(labels)), 0, -1):
        legend = fig.legend(handles, labels, title=title, fontsize=8, title_fontsize=8,
                            loc="outside lower center", ncols=ncols)
        rows = -(-len(labels) // ncols) + (title is not None)
        fig.set_figheight(height + LEGEND_ROW_INCHES * (rows + 1))
        fits = legend.get_window_extent(fig.canvas.get_renderer()).width <= fig.bbox.width
        if fits or ncols == 1:
            return
        legend.remove()


def curve_style(i: int) -> tuple[str, str]:
    """The colour and line style of the ``i``-th curve of a figure: ten colours, then the
    same colours dashed, then dotted, so no two of 30 curves look alike."""
    return _PALETTE[i % len(_PALETTE)], _STYLES[(i // len(_PALETTE)) % len(_STYLES)]


_PALETTE = tuple(f"C{i}" for i in range(10))
_STYLES = ("-", "--", ":")


def _draw_mean_curve(ax, i: int, name: str, raw: ArrayLike, *, window: int, band: bool,
                     x: Mapping[str, ArrayLike] | ArrayLike | None, crowded: bool,
                     n_boot: int, confidence: float, seed: int) -> None:
    """The ``i``-th method's smoothed mean curve over seeds, with its band when asked and
    it has 2 seeds or more (:func:`plot_learning_curves`)."""
    arr = np.asarray(raw, dtype=float)
    if arr.ndim == 1:
        arr = arr[None, :]
    sm = smooth(arr, window)  # validates: 2-D, finite, non-empty, window <= n
    n_seeds, n_eps = sm.shape
    xs = _x_for(name, n_eps, x)
    colour, style = curve_style(i)
    label = f"{name} (n={n_seeds} seed{'s' if n_seeds != 1 else ''})"
    if band and n_seeds >= 2:
        mean, low, high = mean_curve_band(sm, n_boot=n_boot, confidence=confidence, seed=seed)
        ax.fill_between(xs, low, high, color=colour, alpha=0.1 if crowded else 0.2,
                        linewidth=0)
    else:
        mean = sm.mean(axis=0)
    ax.plot(xs, mean, color=colour, linestyle=style, linewidth=1.5, label=label)


def _draw_marker(ax, label: str, pos: float) -> None:
    """A labelled vertical reference line at ``pos`` (:func:`plot_learning_curves`)."""
    ax.axvline(pos, color="0.4", linestyle="--", linewidth=0.8)
    ax.annotate(label, xy=(pos, 1.0), xycoords=("data", "axes fraction"), xytext=(-2, -4),
                textcoords="offset points", rotation=90, ha="right", va="top", fontsize=8,
                color="0.3")


def plot_score_profiles(
    scores: Mapping[str, Mapping[str, ArrayLike]],
    path: str | os.PathLike[str],
    *,
    title: str,
    dpi: int = 120,
) -> Path:
    """Score distributions (performance profiles), one panel per score, one curve per method.

    Each curve is ``x -> share of runs whose score exceeds x`` (the complement of the
    empirical distribution function, Agarwal et al. 2021), drawn as a step function, with a
    vertical line at 0: a curve above another over the whole range dominates it, and the
    height of a curve at 0 is the share of runs where the method beat the baseline. The
    runs of one seed are not independent; tests belong on seed-level values.

    Parameters
    ----------
    scores : mapping of str to mapping of str to array_like
        Panel title (e.g. ``"jumpstart"``) -> method name -> 1-D per-run scores, finite,
        non-empty. Method order sets colours and line styles; the same method keeps its
        look in every panel. With more than five methods one legend for all panels goes
        below them (:func:`legend_below`), where it hides no curve.
    path : str or os.PathLike
        Destination PNG; missing parent directories are created. Written atomically.
    title : str
        Figure title.
    dpi : int
        Resolution of the PNG.

    Returns
    -------
    pathlib.Path
        The written file.

    Raises
    ------
    ValueError
        No panels, a panel without methods, or scores that are empty, not 1-D or not finite.
    """
    if not scores or any(not methods for methods in scores.values()):
        raise ValueError("scores must map at least one panel to at least one method's scores")
    styles: dict[str, tuple[str, str]] = {}
    for methods in scores.values():
        for name in methods:
            styles.setdefault(name, curve_style(len(styles)))
    fig = Figure(figsize=(5.0 * len(scores), 3.8), layout="constrained")
    FigureCanvasAgg(fig)
    axes = np.atleast_1d(fig.subplots(1, len(scores)))
    for ax, (panel, methods) in zip(axes, scores.items(), strict=True):
        for name, raw in methods.items():
            values = np.asarray(raw, dtype=float)
            if values.ndim != 1 or values.size == 0 or not np.all(np.isfinite(values)):
                raise ValueError(f"scores[{panel!r}][{name!r}] must be non-empty, 1-D and finite")
            xs = np.sort(values)
            share = 1.0 - np.arange(1, xs.size + 1) / xs.size  # share of runs > xs[i]
            colour, style = styles[name]
            ax.step(np.concatenate([[xs[0]], xs]), np.concatenate([[1.0], share]),
                    where="post", color=colour, linestyle=style, linewidth=1.5,
                    label=f"{name} ({xs.size} runs)")
        ax.axvline(0.0, color="0.4", linestyle="--", linewidth=0.8)
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel(f"{panel} (method - baseline, per run)")
        ax.set_ylabel("share of runs with a larger score")
        ax.grid(True, alpha=0.3)
    if len(styles) > LEGEND_INSIDE_AT_MOST:  # one legend for the panels, below them
        entries: dict[str, Any] = {}  # label -> handle, each method once, in order
        for ax in axes:
            for handle, name in zip(*ax.get_legend_handles_labels(), strict=True):
                entries.setdefault(name, handle)
        legend_below(fig, list(entries.values()), list(entries), most_columns=len(scores) + 1)
    else:
        for ax in axes:
            ax.legend(fontsize=8, loc="lower left")
    fig.suptitle(title, fontsize=11)
    return save_figure(fig, path, format="png", dpi=dpi)
