"""Figures, tables and verdicts of an experiment, written as ``report.md`` in its folder."""

from __future__ import annotations

import io
import math
import os
import shlex
import sys
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ilpss import metrics
from ilpss._io import atomic_write_bytes
from ilpss.experiments.config import ExperimentConfig
from ilpss.plots import plot_learning_curves

JUMPSTART_EPISODES = 20
"""Jumpstart: mean reward over the first this many learning episodes."""
ASYMPTOTE_EPISODES = 50
"""Asymptotic performance: mean reward over the last this many learning episodes."""
SMOOTHING = 20
"""Moving-average window of the plotted curves and of time to threshold."""
THRESHOLD_SHARE = 0.9
"""Time to threshold: the threshold is this share of the way from the floor (-1) to the
baseline's mean asymptotic performance."""
LABELS = {
    "ilpss": "ILPSS (kernel options)",
    "scratch": "learning anew",
    "whole_policies": "whole past policies as options",
    "prq": "PRQ-learning (policy reuse)",
    "ilpss_no_discount": "ILPSS without discounting",
}


def collect(results: list[dict[str, Any]]) -> dict[str, dict[str, dict[int, np.ndarray]]]:
    """``{stream: {method: {task index: curves (n_seeds, episodes)}}}``, seeds in order."""
    table: dict = defaultdict(lambda: defaultdict(lambda: defaultdict(list)))
    for res in sorted(results, key=lambda r: (r["stream_index"], r["seed"])):
        for method, data in res["methods"].items():
            for t, curve in data["curves"].items():
                table[res["stream"]][method][int(t)].append(curve)
    return {
        s: {m: {t: np.asarray(c, dtype=float) for t, c in tasks.items()} for m, tasks in ms.items()}
        for s, ms in table.items()
    }


def windows(n_episodes: int) -> tuple[int, int, int]:
    """(jumpstart, asymptote, smoothing) episode counts, shortened for short curves."""
    return (min(JUMPSTART_EPISODES, n_episodes), min(ASYMPTOTE_EPISODES, n_episodes),
            min(SMOOTHING, n_episodes))


def threshold_for(baseline: np.ndarray) -> float:
    """The time-to-threshold level (see :data:`THRESHOLD_SHARE`)."""
    _, last, _ = windows(baseline.shape[1])
    asym = float(np.mean(baseline[:, -last:]))
    return -1.0 + THRESHOLD_SHARE * (asym + 1.0)


def compare_to_scratch(curves: dict[str, np.ndarray], seed: int = 0) -> dict[str, dict]:
    """Taylor & Stone metrics of every method against learning anew."""
    base = curves["scratch"]
    threshold = threshold_for(base)
    first, last, window = windows(base.shape[1])
    out = {}
    for method, c in curves.items():
        if method == "scratch":
            continue
        out[method] = metrics.compare(
            c, base, first=first, last=last, threshold=threshold, window=window, seed=seed
        )
    return out


def target_curves(methods: dict[str, dict[int, np.ndarray]]) -> dict[str, np.ndarray]:
    """Protocols A and B: each method's curves ``(n_seeds, episodes)`` on the stream's
    single target (the held-out team)."""
    (target,) = sorted(next(iter(methods.values())))
    return {m: by_task[target] for m, by_task in methods.items()}


def comparable(curves: dict[str, np.ndarray]) -> bool:
    """Whether the metrics against learning anew are defined (it ran, on 2 seeds or more)."""
    return "scratch" in curves and len(curves["scratch"]) >= 2


def stream_estimates(table: dict) -> dict[str, dict[str, dict[str, metrics.MetricEstimate]]]:
    """Protocols A and B: ``{stream: {method: metrics against learning anew}}`` on each
    stream's held-out target (``{}`` for a stream where they are undefined, see
    :func:`comparable`). ``table`` is the output of :func:`collect`."""
    out = {}
    for stream, methods in table.items():
        curves = target_curves(methods)
        out[stream] = compare_to_scratch(curves) if comparable(curves) else {}
    return out


def pool(curve_sets: Sequence[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """Per method, each seed's curve averaged over several comparisons (streams, targets).

    Rows must be the same seeds in every set (as :func:`collect` gives them). Metrics that
    are linear in the curve (jumpstart, asymptotic performance, total reward and their
    gains) of the pooled curves equal the per-seed averages of the per-comparison metrics,
    and the bootstrap over seeds keeps each seed's comparisons together. Time to
    threshold and the transfer ratio are those of the pooled curves.
    """
    methods = list(curve_sets[0])
    return {m: np.mean([cs[m] for cs in curve_sets], axis=0) for m in methods}


def held_out_team(stream: str) -> str:
    """The held-out team of a protocol A or B stream label (``held_out=X[,shuffle=k]``)."""
    return stream.split(",")[0].removeprefix("held_out=")


def mean_difference(
    a: np.ndarray, b: np.ndarray, *, n_boot: int = 10000, confidence: float = 0.95,
    seed: int = 0,
) -> tuple[float, float, float]:
    """Mean over seeds of ``a - b`` (paired by seed) with a percentile-bootstrap interval:
    ``(value, low, high)``."""
    d = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    rng = np.random.default_rng(seed)
    reps = d[rng.integers(0, len(d), size=(n_boot, len(d)))].mean(axis=1)
    alpha = 1.0 - confidence
    low, high = np.quantile(reps, [alpha / 2, 1 - alpha / 2])
    return float(d.mean()), float(low), float(high)


def verdict(estimates: dict[str, Any]) -> str:
    """One honest sentence on the jumpstart and the time to threshold."""
    js = estimates["jumpstart"]
    if js.low > 0:
        head = f"a head start: jumpstart {js.value:+.3f} with its whole 95% interval above zero"
    elif js.high < 0:
        head = f"a worse start: jumpstart {js.value:+.3f}, whole 95% interval below zero"
    else:
        head = (f"no demonstrated head start: jumpstart {js.value:+.3f}, 95% interval "
                f"[{js.low:+.3f}, {js.high:+.3f}] contains zero")
    ratio = estimates.get("time_to_threshold_ratio")
    if ratio is not None and math.isfinite(ratio.value):
        tail = (f"; time to threshold {ratio.value:.2f}x that of learning anew "
                f"({'at most half: aim met' if ratio.high <= 0.5 else 'aim of at most half not shown'})")
    else:
        tail = "; time to threshold undefined (a method never reached the threshold)"
    return head + tail


def metrics_note() -> str:
    """The paragraph defining the metrics and intervals of every report."""
    return (
        f"Metrics (Taylor & Stone 2009), each against learning anew with the same seeds: "
        f"jumpstart over the first {JUMPSTART_EPISODES} episodes, asymptotic performance "
        f"over the last {ASYMPTOTE_EPISODES}, total reward (area), transfer ratio "
        f"(areas above the floor -1), time to threshold ({THRESHOLD_SHARE:.0%} of the way "
        f"from -1 to the baseline's asymptote, on a {SMOOTHING}-episode moving average). "
        "Intervals: 95% paired percentile bootstrap over seeds."
    )


def _figure(curves: dict[str, np.ndarray], path: Path, title: str) -> Path:
    named = {f"{LABELS.get(m, m)}": c for m, c in curves.items()}
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
            if len(sm) >= 2:
                mean, low, high = metrics.mean_curve_band(sm, seed=0)
                ax.fill_between(xs, low, high, color=f"C{i}", alpha=0.2, linewidth=0)
            else:
                mean = sm.mean(axis=0)
            (handles[method],) = ax.plot(xs, mean, color=f"C{i}", linewidth=1.3)
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
    fig.suptitle(f"Learning against each held-out team ({n_seeds} seeds)", fontsize=11)
    fig.legend(list(handles.values()), [LABELS.get(m, m) for m in handles],
               loc="outside lower center", ncols=min(len(handles), 4), fontsize=8)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, buf.getvalue())
    return path


def write_report(
    cfg: ExperimentConfig, results: list[dict[str, Any]], out_dir: str | os.PathLike[str],
    command: str | None = None,
) -> Path:
    """Write ``report.md`` with figures into ``out_dir``; return its path.

    ``command`` is the command line written in the report; by default the current one
    when it is ``ilpss-experiment``, else "(from Python)".
    """
    out = Path(out_dir)
    table = collect(results)
    if command is None:
        command = "ilpss-experiment " + " ".join(shlex.quote(a) for a in sys.argv[1:]) \
            if Path(sys.argv[0]).name == "ilpss-experiment" else "(from Python)"
    lines = [
        f"# Protocol {cfg.protocol}: {cfg.n_seeds} seeds, "
        f"{cfg.lifelong.train_episodes} learning episodes per opponent",
        "",
        f"Command: `{command}`; configuration: [`config.json`](config.json).",
        "",
        metrics_note(),
        "",
    ]
    if cfg.protocol in ("A", "B"):
        estimates = stream_estimates(table)
        for s, (stream, methods) in enumerate(table.items()):
            curves = target_curves(methods)
            fig = _figure(curves, out / f"curves_{s:02d}.png",
                          f"{stream}: learning against the held-out opponent")
            lines += [f"## {stream}", "", f"![learning curves]({fig.name})", ""]
            if "scratch" in curves and not comparable(curves):
                lines += ["Transfer metrics need at least 2 seeds.", ""]
            for method, est in estimates[stream].items():
                lines += [f"### {LABELS.get(method, method)} vs learning anew", "",
                          f"**Verdict:** {verdict(est)}.", "",
                          metrics.format_metrics_markdown(est), ""]
    else:
        (methods,) = table.values()
        jumpstarts = stream_jumpstarts(methods)
        sizes = library_sizes(results)
        plot_stream(jumpstarts, sizes, out / "stream.png")
        lines += ["## Jumpstart on each new opponent of the stream", "",
                  *protocol_c_lines(jumpstarts, sizes, "stream.png")]
    path = out / "report.md"
    atomic_write_bytes(path, "\n".join(lines).encode())
    return path


def stream_jumpstarts(
    methods: dict[str, dict[int, np.ndarray]], method: str = "ilpss"
) -> list[tuple[int, metrics.MetricEstimate]]:
    """Protocol C: ``(task index, jumpstart of method against learning anew)`` on every
    target of the stream (none with fewer than 2 seeds)."""
    out: list[tuple[int, metrics.MetricEstimate]] = []
    if len(methods["scratch"][min(methods["scratch"])]) < 2:
        return out
    for t in sorted(methods[method]):
        first, last, window = windows(methods["scratch"][t].shape[1])
        est = metrics.compare(methods[method][t], methods["scratch"][t], first=first,
                              last=last, threshold=None, window=window)
        out.append((t, est["jumpstart"]))
    return out


def library_sizes(results: list[dict[str, Any]]) -> dict[str, np.ndarray]:
    """Protocol C: ``{method: active options after each trial, (n_seeds, n_trials)}`` of
    ILPSS with and without discounting, seeds in order."""
    sizes: dict[str, list] = defaultdict(list)
    for res in sorted(results, key=lambda r: (r["stream_index"], r["seed"])):
        for method in ("ilpss", "ilpss_no_discount"):
            if method in res["methods"]:
                sizes[method].append(res["methods"][method]["library_size"])
    return {m: np.asarray(runs, dtype=float) for m, runs in sizes.items()}


def plot_stream(
    jumpstarts: list[tuple[int, metrics.MetricEstimate]], sizes: dict[str, np.ndarray],
    path: str | os.PathLike[str],
) -> Path:
    """Protocol C: jumpstart on each new opponent, and the library's size over the stream."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    tasks = [t for t, _ in jumpstarts]
    values = [js.value for _, js in jumpstarts]
    lows = [js.low for _, js in jumpstarts]
    highs = [js.high for _, js in jumpstarts]
    fig = Figure(figsize=(11, 4))
    FigureCanvasAgg(fig)
    ax1, ax2 = fig.subplots(1, 2)
    ax1.errorbar(tasks, values, yerr=[np.subtract(values, lows), np.subtract(highs, values)],
                 fmt="o-", capsize=3)
    ax1.axhline(0, color="grey", lw=1)
    ax1.set_xlabel("opponent index in the stream")
    ax1.set_ylabel("jumpstart (first episodes)")
    for method, runs in sizes.items():
        mean = runs.mean(axis=0)
        ax2.plot(np.arange(1, len(mean) + 1), mean, marker="o", label=LABELS[method])
    ax2.set_xlabel("trials completed")
    ax2.set_ylabel("active options (mean over seeds)")
    ax2.legend()
    fig.tight_layout()
    path = Path(path)
    tmp = path.with_name(f".{path.stem}.tmp.png")
    fig.savefig(tmp, dpi=120)
    os.replace(tmp, path)
    return path


def protocol_c_lines(
    jumpstarts: list[tuple[int, metrics.MetricEstimate]], sizes: dict[str, np.ndarray],
    figure: str,
) -> list[str]:
    """Protocol C's figure link, jumpstart table and final library sizes, as markdown."""
    rows = ["| opponent | jumpstart (ILPSS - anew) | 95% CI |", "|---|---:|---|"]
    rows += [f"| {t} | {js.value:+.3f} | [{js.low:+.3f}, {js.high:+.3f}] |"
             for t, js in jumpstarts]
    if not jumpstarts:
        rows = ["Transfer metrics need at least 2 seeds."]
    lines = [f"![stream]({figure})", "", *rows, ""]
    for method, runs in sizes.items():
        final = runs[:, -1]
        lines.append(f"- {LABELS[method]}: {final.mean():.1f} active options after the last "
                     f"trial (min {final.min():.0f}, max {final.max():.0f} over seeds).")
    return lines
