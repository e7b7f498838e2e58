"""Compare finished runs against one baseline, paired by seed: ablations in one table.

    ilpss-compare --baseline results/protocol_a:scratch \\
        "ILPSS=results/protocol_a:ilpss" "K = 1=results/variant_k1:ilpss"

Each run is ``LABEL=FOLDER:METHOD`` (a folder written by ``ilpss-experiment``), with a
label of its own. Runs are compared on the targets of every stream (each seed's curves
averaged over them, when there are several: protocol A with targets, R, and B's held-out
teams, pooled as the reports pool them) over the seeds whose every stream every run and
the baseline finished, with :func:`ilpss.metrics.compare` (Student t intervals over the
paired seeds, Fieller for the time ratio) on the headline metrics of every report
(:func:`ilpss.metrics.headline_metrics`), using the windows and threshold of the
experiment reports (:mod:`ilpss.experiments.report`). The jumpstart and total-reward
gain of all runs form one family: their p-values are Holm-adjusted across the runs. The
run with the largest value of each is named with a simultaneous interval (Bonferroni
over the runs), which stays valid after picking the largest; the plain intervals do not.
Runs with the same seeds meet the same opponents with the same environment and learner
seeds, so an ablation run with one method can be compared with the baseline of another
run. The runs must agree with the baseline on the streams (tasks, targets, environment
and budget) on every seed they share, else the comparison is refused; the table is printed
as markdown. Labels and folders may hold ``=``: an item is split where a run folder
follows, and refused if that is ambiguous.
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ilpss import metrics
from ilpss._io import json_differences
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.folder import RunFolder
from ilpss.experiments.provenance import check_one_code, code_line
from ilpss.experiments.report_stats import PRIMARY_FAMILY, threshold_for, windows
from ilpss.experiments.report_text import interval_text
from ilpss.experiments.run import load_result, read_config


def _parse(spec: str) -> tuple[Path, str]:
    folder, sep, method = spec.rpartition(":")
    if not sep or not folder or not method:
        raise ValueError(f"expected FOLDER:METHOD, got {spec!r}")
    return Path(folder), method


def split_run(item: str) -> tuple[str, Path, str]:
    """``LABEL=FOLDER:METHOD`` as ``(label, folder, method)``.

    Labels and folders may both hold ``=`` (``K = 1=results/alpha=0.5:ilpss``), so the
    item is split at the ``=`` after which a run folder (one with a ``config.json``)
    follows; where none or several splits name one, the item is refused as ambiguous
    rather than read from a folder it did not mean.
    """
    candidates = []
    for i, char in enumerate(item):
        if char != "=":
            continue
        label, spec = item[:i], item[i + 1:]
        folder, sep, method = spec.rpartition(":")
        if label and sep and folder and method and (Path(folder) / "config.json").is_file():
            candidates.append((label, Path(folder), method))
    if len(candidates) == 1:
        return candidates[0]
    if not candidates:
        raise ValueError(f"expected LABEL=FOLDER:METHOD with FOLDER a run folder (holding "
                         f"config.json), got {item!r}")
    shown = ", ".join(f"{os.fspath(f)!r}" for _, f, _ in candidates)
    raise ValueError(f"{item!r} is ambiguous: it can be read with the run folders {shown}; "
                     "rename a folder or the label")


def _streams_of(cfg: ExperimentConfig, seed: int) -> dict[str, Any]:
    """What must agree between two runs compared seed by seed: every stream's targets
    after the same tasks, the same budget and environment."""
    return {"protocol": cfg.protocol, "env_id": cfg.env_id,
            "train_episodes": cfg.lifelong.train_episodes,
            "streams": {f"stream_{i:02d}": {"tasks": [t.name for t in stream.tasks],
                                             "task_settings": [t.env_kwargs
                                                               for t in stream.tasks],
                                             "first_target": stream.first_target,
                                             "shared_start": stream.shared_start}
                        for i, stream in enumerate(cfg.streams(seed))}}


def target_curves(
    folder: Path, method: str, codes: dict[str, tuple[dict, str]] | None = None,
) -> dict[int, tuple[list[float], list[dict]]]:
    """``{seed: (curve on the targets of every stream, averaged over them, that method's
    result on each stream)}``, for the seeds whose every stream is finished; the code of
    every result read is added to ``codes`` (by its digest: the code and a file)."""
    return _target_curves(folder, method, codes)[0]


def _target_curves(
    folder: Path, method: str, codes: dict[str, tuple[dict, str]] | None = None,
) -> tuple[dict[int, tuple[list[float], list[dict]]], dict[int, dict[str, Any]]]:
    """:func:`target_curves` and, per seed, what it was compared on (:func:`_streams_of`);
    the code of every result read is added to ``codes`` (by its digest: the code and the
    first file that had it)."""
    run = RunFolder(folder)
    config = run.config
    if not config.is_file():
        raise ValueError(f"{folder}: no config.json (not a folder written by ilpss-experiment)")
    cfg = read_config(config)
    out, streams = {}, {}
    for seed in run.finished_seeds(stream_index=0):
        seed_streams = cfg.streams(seed)
        paths = [run.result(seed, i) for i in range(len(seed_streams))]
        if not all(path.is_file() for path in paths):
            continue  # a seed is compared once every one of its streams is finished
        curves, data = [], []
        for i, (path, stream) in enumerate(zip(paths, seed_streams, strict=True)):
            result = load_result(path, cfg, seed, i, stream)  # checked, clear errors
            if codes is not None:
                codes.setdefault(result["code"]["source_digest"], (result["code"], str(path)))
            if method not in result["methods"]:
                raise ValueError(
                    f"{path}: no method {method!r}; it has {sorted(result['methods'])}")
            entry = result["methods"][method]
            curves += [entry["curves"][t] for t in sorted(entry["curves"], key=int)]
            data.append(entry)
        out[seed] = (np.mean(curves, axis=0).tolist(), data)
        streams[seed] = _streams_of(cfg, seed)
    if not out:
        raise ValueError(f"{folder}: no seed with every stream finished "
                         "(seed_*/stream_*/result.json)")
    return out, streams


def compare_runs(baseline: tuple[Path, str], runs: dict[str, tuple[Path, str]], *,
                 allow_mixed_code: bool = False) -> list[str]:
    """The markdown table comparing every run with the baseline, and the best of them.

    Raises
    ------
    ValueError
        If a run's stream differs from the baseline's on a seed both finished (other
        tasks, target, environment or budget): its curves would not be paired.
    MixedCodeError
        If the results compared were made by different code (naming two of them), unless
        ``allow_mixed_code``: then the table's note names every code.
    """
    codes: dict[str, tuple[dict, str]] = {}
    base, loaded = _paired_runs(baseline, runs, codes)
    check_one_code(codes, allow=allow_mixed_code)
    seeds = sorted(set(base).intersection(*(set(r) for r in loaded.values())))
    if len(seeds) < 2:
        raise ValueError(f"need at least 2 seeds finished by every run, got {seeds}")
    b = np.array([base[s][0] for s in seeds], dtype=float)
    first, last, window = windows(b.shape[1])
    threshold = threshold_for(b)
    estimates, used, gains = {}, {}, {}
    for label, by_seed in loaded.items():
        c = np.array([by_seed[s][0] for s in seeds], dtype=float)
        if c.shape != b.shape:
            raise ValueError(f"{label}: curves of shape {c.shape}, baseline {b.shape}")
        estimates[label] = metrics.compare(c, b, first=first, last=last, threshold=threshold,
                                           window=window)
        gains[label] = metrics.per_seed_gains(c, b, first=first, last=last)
        used[label] = np.mean([np.mean([entry.get("options_used", [0])[-1]
                                        for entry in by_seed[s][1]]) for s in seeds])
    k = len(estimates)
    lines = [
        f"Baseline `{baseline[0]}:{baseline[1]}`; {len(seeds)} paired seeds; jumpstart over the "
        f"first {first} episodes, final performance within the budget over the last {last}; "
        "95% Student t intervals over the paired seeds (Fieller for the time ratio, of the "
        "restricted mean times to threshold, censored at the budget). p: the paired t-test, "
        f"Holm-adjusted across the {k} runs x {len(FAMILY.metrics)} endpoints (jumpstart, "
        "total-reward gain).",
        "",
        code_line({"code": code} for code, _ in codes.values()),
        "",
        *_table(estimates, used),
        "",
    ]
    return lines + _best_lines(estimates, gains)


FAMILY = PRIMARY_FAMILY
"""The tests ``ilpss-compare`` adjusts together: every run against the baseline on these
endpoints."""


def _paired_runs(baseline: tuple[Path, str], runs: dict[str, tuple[Path, str]],
                 codes: dict[str, tuple[dict, str]]) -> tuple[dict, dict]:
    """The baseline's and every run's target curves by seed (their codes into ``codes``),
    refusing a run whose stream differs from the baseline's on a seed both finished."""
    base, base_streams = _target_curves(*baseline, codes)
    loaded = {}
    for label, spec in runs.items():
        loaded[label], streams = _target_curves(*spec, codes)
        for seed in sorted(set(streams) & set(base_streams)):
            diffs = json_differences(base_streams[seed], streams[seed])
            if diffs:
                raise ValueError(
                    f"{label} ({spec[0]}) does not learn what the baseline ({baseline[0]}) "
                    f"learns on seed {seed}: {'; '.join(diffs[:3])} (baseline first); only "
                    "runs of the same stream, target and budget can be paired by seed"
                )
    return base, loaded


def _table(estimates: dict[str, dict[str, metrics.MetricEstimate]],
           used: dict[str, float]) -> list[str]:
    """Every run against the baseline on the headline metrics, the endpoints of
    :data:`FAMILY` with their Holm-adjusted p-values."""
    keys = [(label, e) for label in estimates for e in FAMILY.metrics]
    adjusted = dict(zip(keys, metrics.holm([estimates[k][e].p_value for k, e in keys]),
                        strict=True))
    columns = metrics.headline_metrics()
    tested = set(FAMILY.metrics)
    head = [c for m in columns for c in (m.label, *(["p (Holm)"] if m.name in tested else []))]
    lines = [
        "| run | " + " | ".join(head) + " | seeds reaching the threshold | options used by "
        "the greedy policy at the target |",
        "|---|" + "".join("---:|" if c == "p (Holm)" else "---|" for c in head) + "---:|---:|",
    ]
    for label, est in estimates.items():
        n = est["jumpstart"].n
        reached = round(est["threshold_reached_transfer"].value * n)
        cells = [c for m in columns for c in (
            interval_text(est[m.name], m.fmt),
            *([f"{adjusted[label, m.name]:.2g}"] if m.name in tested else []))]
        cells.append(f"{reached}/{n}")
        lines.append(f"| {_cell(label)} | " + " | ".join(cells) + f" | {used[label]:.1f} |")
    return lines


def _cell(text: str) -> str:
    """``text`` as one markdown table cell: its ``|`` escaped, which would end the cell."""
    return text.replace("|", "\\|")


def _best_lines(estimates: dict[str, dict[str, metrics.MetricEstimate]],
                gains: dict[str, dict[str, np.ndarray]]) -> list[str]:
    """The run with the largest value of each endpoint, with a simultaneous interval (none
    with one run: there is nothing to pick)."""
    k = len(estimates)
    confidence = 1.0 - 0.05 / k
    lines = []
    for e in FAMILY.metrics if k > 1 else ():
        best = max(estimates, key=lambda label: estimates[label][e].value)
        value, low, high = metrics.t_interval(gains[best][e], confidence)
        lines.append(
            f"- Largest {e.replace('_', ' ')} of the {k} runs: **{best}**, {value:+.3g}; its "
            f"simultaneous interval (Bonferroni over the {k} runs, {confidence:.2%} t) is "
            f"[{low:+.3g}, {high:+.3g}]. Picked as the largest of {k}, its plain estimate is "
            "biased upward; that it is the best needs a confirmation run on fresh seeds.")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    """Print the comparison table."""
    p = argparse.ArgumentParser(prog="ilpss-compare", description=__doc__.splitlines()[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog=__doc__)
    p.add_argument("--baseline", required=True, help="FOLDER:METHOD, e.g. results/protocol_a:scratch")
    p.add_argument("runs", nargs="+", help="LABEL=FOLDER:METHOD")
    p.add_argument("--allow-mixed-code", action="store_true",
                   help="compare results made by different code (refused otherwise); the "
                   "table's note names every version of the code")
    args = p.parse_args(argv)
    try:
        runs, items = {}, {}
        for item in args.runs:
            label, folder, method = split_run(item)
            if label in runs:
                # A second entry would replace the first one's row and shrink the Holm
                # family without a word.
                raise ValueError(
                    f"the label {label!r} is given twice ({items[label]!r} and {item!r}); "
                    "every run needs a label of its own (it names the run's row)")
            runs[label], items[label] = (folder, method), item
        print("\n".join(compare_runs(_parse(args.baseline), runs,
                                     allow_mixed_code=args.allow_mixed_code)))
    except (ValueError, OSError, KeyError) as exc:
        p.error(str(exc))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
