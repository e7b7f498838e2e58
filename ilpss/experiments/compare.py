"""Compare finished runs against one baseline, paired by seed: ablations in one table.

    ilpss-compare --baseline results/protocol_a:scratch \\
        "ILPSS=results/protocol_a:ilpss" "K = 1=results/variant_k1:ilpss"

Each run is ``LABEL=FOLDER:METHOD`` (a folder written by ``ilpss-experiment``). Runs are
compared on the first target task of stream 0 over the seeds that every run and the
baseline finished, with :func:`ilpss.metrics.compare` (paired percentile bootstrap):
jumpstart, total-reward gain, asymptotic gain and time-to-threshold ratio, using the
windows and threshold of the experiment reports (:mod:`ilpss.experiments.report`).
Runs with the same seeds meet the same opponents with the same environment and learner
seeds, so an ablation run with one method can be compared with the baseline of another
run. The configurations must agree on the stream; the table is printed as markdown.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ilpss import metrics
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.report import threshold_for, windows
from ilpss.experiments.run import load_result


def _parse(spec: str) -> tuple[Path, str]:
    folder, sep, method = spec.rpartition(":")
    if not sep or not folder or not method:
        raise ValueError(f"expected FOLDER:METHOD, got {spec!r}")
    return Path(folder), method


def target_curves(folder: Path, method: str) -> dict[int, tuple[list[float], dict]]:
    """``{seed: (curve on the first target of stream 0, that method's result)}``."""
    config = folder / "config.json"
    if not config.is_file():
        raise ValueError(f"{folder}: no config.json (not a folder written by ilpss-experiment)")
    cfg = ExperimentConfig.from_dict(json.loads(config.read_text()))
    out = {}
    for path in sorted(folder.glob("seed_*/stream_00/result.json")):
        seed = int(path.parent.parent.name.removeprefix("seed_"))
        result = load_result(path, cfg, seed, 0, cfg.streams(seed)[0])  # checked, clear errors
        if method not in result["methods"]:
            raise ValueError(f"{path}: no method {method!r}; it has {sorted(result['methods'])}")
        data = result["methods"][method]
        out[int(result["seed"])] = (data["curves"][str(result["first_target"])], data)
    if not out:
        raise ValueError(f"{folder}: no finished seeds (seed_*/stream_00/result.json)")
    return out


def compare_runs(baseline: tuple[Path, str], runs: dict[str, tuple[Path, str]]) -> list[str]:
    """The markdown table comparing every run with the baseline."""
    base = target_curves(*baseline)
    loaded = {label: target_curves(*spec) for label, spec in runs.items()}
    seeds = sorted(set(base).intersection(*(set(r) for r in loaded.values())))
    if len(seeds) < 2:
        raise ValueError(f"need at least 2 seeds finished by every run, got {seeds}")
    b = np.array([base[s][0] for s in seeds], dtype=float)
    first, last, window = windows(b.shape[1])
    threshold = threshold_for(b)
    lines = [
        f"Baseline `{baseline[0]}:{baseline[1]}`; {len(seeds)} paired seeds; jumpstart over the "
        f"first {first} episodes, asymptote over the last {last}; 95% paired bootstrap intervals.",
        "",
        "| run | jumpstart | total-reward gain | asymptotic gain | time to threshold (ratio) "
        "| options used by the greedy policy at the target |",
        "|---|---|---|---|---|---|",
    ]
    for label, by_seed in loaded.items():
        c = np.array([by_seed[s][0] for s in seeds], dtype=float)
        if c.shape != b.shape:
            raise ValueError(f"{label}: curves of shape {c.shape}, baseline {b.shape}")
        est = metrics.compare(c, b, first=first, last=last, threshold=threshold, window=window)
        used = [by_seed[s][1].get("options_used", [0])[-1] for s in seeds]
        cells = [f"{e.value:+.3g} [{e.low:+.3g}, {e.high:+.3g}]" for e in
                 (est["jumpstart"], est["total_reward_gain"], est["asymptotic_gain"])]
        ratio = est["time_to_threshold_ratio"]
        cells.append(f"{ratio.value:.2f} [{ratio.low:.2f}, {ratio.high:.2f}]")
        lines.append(f"| {label} | " + " | ".join(cells) + f" | {np.mean(used):.1f} |")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    """Print the comparison table."""
    p = argparse.ArgumentParser(prog="ilpss-compare", description=__doc__.splitlines()[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog=__doc__)
    p.add_argument("--baseline", required=True, help="FOLDER:METHOD, e.g. results/protocol_a:scratch")
    p.add_argument("runs", nargs="+", help="LABEL=FOLDER:METHOD")
    args = p.parse_args(argv)
    try:
        runs = {}
        for item in args.runs:
            label, sep, spec = item.rpartition("=")  # labels may hold "=" (K = 1)
            if not sep:
                raise ValueError(f"expected LABEL=FOLDER:METHOD, got {item!r}")
            runs[label] = _parse(spec)
        print("\n".join(compare_runs(_parse(args.baseline), runs)))
    except (ValueError, OSError, KeyError) as exc:
        p.error(str(exc))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
