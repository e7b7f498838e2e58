"""Figures, tables and verdicts of an experiment, written as ``report.md`` in its folder."""

from __future__ import annotations

import math
import os
import shlex
import sys
from collections import defaultdict
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


def _figure(curves: dict[str, np.ndarray], path: Path, title: str) -> Path:
    named = {f"{LABELS.get(m, m)}": c for m, c in curves.items()}
    window = windows(next(iter(curves.values())).shape[1])[2]
    plot_learning_curves(named, path, title=title, window=window, ylabel="reward per episode")
    return path


def write_report(
    cfg: ExperimentConfig, results: list[dict[str, Any]], out_dir: str | os.PathLike[str]
) -> Path:
    """Write ``report.md`` with figures into ``out_dir``; return its path."""
    out = Path(out_dir)
    table = collect(results)
    command = "ilpss-experiment " + " ".join(shlex.quote(a) for a in sys.argv[1:]) \
        if Path(sys.argv[0]).name == "ilpss-experiment" else "(from Python)"
    lines = [
        f"# Protocol {cfg.protocol}: {cfg.n_seeds} seeds, "
        f"{cfg.lifelong.train_episodes} learning episodes per opponent",
        "",
        f"Command: `{command}`; configuration: [`config.json`](config.json).",
        "",
        f"Metrics (Taylor & Stone 2009), each against learning anew with the same seeds: "
        f"jumpstart over the first {JUMPSTART_EPISODES} episodes, asymptotic performance "
        f"over the last {ASYMPTOTE_EPISODES}, total reward (area), transfer ratio "
        f"(areas above the floor -1), time to threshold ({THRESHOLD_SHARE:.0%} of the way "
        f"from -1 to the baseline's asymptote, on a {SMOOTHING}-episode moving average). "
        "Intervals: 95% paired percentile bootstrap over seeds.",
        "",
    ]
    if cfg.protocol in ("A", "B"):
        for s, (stream, methods) in enumerate(table.items()):
            (target,) = sorted(next(iter(methods.values())))
            curves = {m: by_task[target] for m, by_task in methods.items()}
            fig = _figure(curves, out / f"curves_{s:02d}.png",
                          f"{stream}: learning against the held-out opponent")
            lines += [f"## {stream}", "", f"![learning curves]({fig.name})", ""]
            if "scratch" in curves and len(curves["scratch"]) < 2:
                lines += ["Transfer metrics need at least 2 seeds.", ""]
            elif "scratch" in curves:
                for method, est in compare_to_scratch(curves).items():
                    lines += [f"### {LABELS.get(method, method)} vs learning anew", "",
                              f"**Verdict:** {verdict(est)}.", "",
                              metrics.format_metrics_markdown(est), ""]
    else:
        lines += _protocol_c(table, out, results)
    path = out / "report.md"
    atomic_write_bytes(path, "\n".join(lines).encode())
    return path


def _protocol_c(table: dict, out: Path, results: list[dict[str, Any]]) -> list[str]:
    """Jumpstart on every new opponent, and the option library's size over the stream."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    (methods,) = table.values()
    lines = ["## Jumpstart on each new opponent of the stream", ""]
    rows = ["| opponent | jumpstart (ILPSS - anew) | 95% CI |", "|---|---:|---|"]
    values, lows, highs, tasks = [], [], [], sorted(methods["ilpss"])
    for t in tasks:
        first, last, window = windows(methods["scratch"][t].shape[1])
        est = metrics.compare(methods["ilpss"][t], methods["scratch"][t], first=first,
                              last=last, threshold=None, window=window)
        js = est["jumpstart"]
        values.append(js.value)
        lows.append(js.low)
        highs.append(js.high)
        rows.append(f"| {t} | {js.value:+.3f} | [{js.low:+.3f}, {js.high:+.3f}] |")
    sizes: dict[str, list] = defaultdict(list)
    for res in results:
        for method in ("ilpss", "ilpss_no_discount"):
            if method in res["methods"]:
                sizes[method].append(res["methods"][method]["library_size"])
    fig = Figure(figsize=(11, 4))
    FigureCanvasAgg(fig)
    ax1, ax2 = fig.subplots(1, 2)
    ax1.errorbar(tasks, values, yerr=[np.subtract(values, lows), np.subtract(highs, values)],
                 fmt="o-", capsize=3)
    ax1.axhline(0, color="grey", lw=1)
    ax1.set_xlabel("opponent index in the stream")
    ax1.set_ylabel("jumpstart (first episodes)")
    for method, runs in sizes.items():
        mean = np.mean(np.asarray(runs, dtype=float), axis=0)
        ax2.plot(np.arange(1, len(mean) + 1), mean, marker="o", label=LABELS[method])
    ax2.set_xlabel("trials completed")
    ax2.set_ylabel("active options (mean over seeds)")
    ax2.legend()
    fig.tight_layout()
    tmp = out / ".stream.tmp.png"
    fig.savefig(tmp, dpi=120)
    os.replace(tmp, out / "stream.png")
    lines += ["![stream](stream.png)", "", *rows, ""]
    for method, runs in sizes.items():
        final = np.asarray(runs, dtype=float)[:, -1]
        lines.append(f"- {LABELS[method]}: {final.mean():.1f} active options after the last "
                     f"trial (min {final.min():.0f}, max {final.max():.0f} over seeds).")
    return lines
