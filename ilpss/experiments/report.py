"""Figures, tables and verdicts of an experiment, written as ``report.md`` in its folder.

:func:`write_report` writes the head of the page and the body that :data:`REPORT_BODIES`
holds for the run's protocol (:func:`register_report_body`): :func:`held_out_sections`
(one held-out target per stream: A, and B pooled), :func:`several_targets_sections` (A
with several targets), :func:`parametric_stream_sections` (a long stream: C), and
:func:`target_sections` (any stream, every target: the body of a protocol that registers
none). The reports know no method by name: they compare every method with the run's
baseline (``ExperimentConfig.baseline``) and every transfer method with every other, on
the metrics of :data:`ilpss.metrics.METRICS`, and show the kernels of its featured method
(``ExperimentConfig.featured_method``).
"""

from __future__ import annotations

import math
import os
import shlex
import sys
from collections import defaultdict
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ilpss import metrics
from ilpss._io import atomic_write_bytes, save_figure
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.methods import METHODS, LifelongMethod
from ilpss.experiments.provenance import code_line
from ilpss.plots import plot_learning_curves, plot_score_profiles

JUMPSTART_EPISODES = 20
"""Jumpstart: mean reward over the first this many learning episodes."""
FINAL_EPISODES = 50
"""Final performance within the budget: mean reward over the last this many learning
episodes (not an asymptote: the learner may still be improving)."""
SMOOTHING = 20
"""Moving-average window of the plotted curves and of time to threshold."""
THRESHOLD_SHARE = 0.9
"""Time to threshold: the threshold is this share of the way from the floor (-1) to the
baseline's mean final performance."""
PRIMARY = ("jumpstart", "total_reward_gain")
"""The primary endpoints of every protocol, per method against the baseline (pooled over
the protocol's comparisons); their p-values are Holm-adjusted across methods and endpoints.
Everything else (final performance, time to threshold, the dips, per-stream and
per-opponent rows) is descriptive, and the method-against-method comparisons are their
own family, Holm-adjusted within it."""
ALPHA = 0.05
"""Family-wise error rate of the primary endpoints."""


def label(method: str) -> str:
    """How reports call a method: its registered label, else its name."""
    return METHODS.get(method).label if method in METHODS else method


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
    """(jumpstart, final performance, smoothing) episode counts, shortened for short curves."""
    return (min(JUMPSTART_EPISODES, n_episodes), min(FINAL_EPISODES, n_episodes),
            min(SMOOTHING, n_episodes))


def threshold_for(baseline: np.ndarray) -> float:
    """The time-to-threshold level (see :data:`THRESHOLD_SHARE`)."""
    _, last, _ = windows(baseline.shape[1])
    asym = float(np.mean(baseline[:, -last:]))
    return -1.0 + THRESHOLD_SHARE * (asym + 1.0)


def compare_to_baseline(curves: dict[str, np.ndarray], baseline: str,
                        seed: int = 0) -> dict[str, dict]:
    """Taylor & Stone metrics of every method against ``baseline`` (time to threshold
    over full windows; the warm start, :func:`ilpss.metrics.threshold_times`' warmup, is
    its own column)."""
    base = curves[baseline]
    threshold = threshold_for(base)
    first, last, window = windows(base.shape[1])
    return {method: metrics.compare(c, base, first=first, last=last, threshold=threshold,
                                    window=window, seed=seed)
            for method, c in curves.items() if method != baseline}


def target_curves(methods: dict[str, dict[int, np.ndarray]]) -> dict[str, np.ndarray]:
    """Protocols A and B: each method's curves ``(n_seeds, episodes)`` on the stream's
    single target (the held-out team)."""
    (target,) = sorted(next(iter(methods.values())))
    return {m: by_task[target] for m, by_task in methods.items()}


def comparable(curves: dict[str, np.ndarray], baseline: str) -> bool:
    """Whether the metrics against the baseline are defined (it ran, on 2 seeds or more)."""
    return baseline in curves and len(curves[baseline]) >= 2


def stream_estimates(
    table: dict, baseline: str
) -> dict[str, dict[str, dict[str, metrics.MetricEstimate]]]:
    """Protocols A and B: ``{stream: {method: metrics against the baseline}}`` on each
    stream's held-out target (``{}`` for a stream where they are undefined, see
    :func:`comparable`). ``table`` is the output of :func:`collect`."""
    out = {}
    for stream, methods in table.items():
        curves = target_curves(methods)
        out[stream] = compare_to_baseline(curves, baseline) if comparable(curves, baseline) \
            else {}
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


def holm_primary(estimates: dict[str, dict[str, metrics.MetricEstimate]]) -> dict[str, dict]:
    """``{method: {endpoint: Holm-adjusted p}}`` for the :data:`PRIMARY` endpoints of every
    method, adjusted as one family (methods x endpoints)."""
    keys = [(m, e) for m in estimates for e in PRIMARY]
    adjusted = metrics.holm([estimates[m][e].p_value for m, e in keys])
    out: dict[str, dict] = {m: {} for m in estimates}
    for (m, e), p in zip(keys, adjusted, strict=True):
        out[m][e] = float(p)
    return out


def _signed(x: float, spec: str) -> str:
    return "n/a" if math.isnan(x) else ("inf" if x == math.inf else "-inf" if x == -math.inf
                                        else format(x, spec))


def interval_text(est: metrics.MetricEstimate, spec: str) -> str:
    """``value [low, high]`` of an estimate, with ``inf`` and ``n/a`` spelt out."""
    return f"{_signed(est.value, spec)} [{_signed(est.low, spec)}, {_signed(est.high, spec)}]"


def _effect(est: metrics.MetricEstimate, adjusted: float | None, up: str, down: str,
            none: str) -> str:
    """The word for a difference: shown by its (Holm-adjusted, when given) test, or not."""
    p = est.p_value if adjusted is None else adjusted
    if math.isnan(p) or p >= ALPHA:
        return none
    return up if est.value > 0 else down


def time_text(est: dict[str, metrics.MetricEstimate]) -> str:
    """Time to threshold in words: censored per seed, with the shares that reach it.

    "Never" (no seed of the method reaches the threshold while the baseline does) is a
    clear negative result and is said so; "neither reaches it" leaves the time undefined.
    """
    reached_t, reached_b = est["threshold_reached_transfer"], est["threshold_reached_baseline"]
    n = reached_t.n
    kt, kb = round(reached_t.value * n), round(reached_b.value * n)
    shares = f"{kt} of {n} seeds reach the threshold, {kb} of {n} of the baseline"
    if kt == 0 and kb == 0:
        return ("time to threshold undefined: neither the method nor the baseline reaches "
                "the threshold within the budget on any seed")
    if kt == 0:
        return (f"time to threshold: never within the budget (no seed reaches the "
                f"threshold, while {kb} of {n} of the baseline do), a clear negative result")

    def median(e: metrics.MetricEstimate) -> str:
        return "beyond the budget" if e.value == math.inf else f"{e.value:.0f} episodes"

    ratio = est["time_to_threshold_ratio"]
    aim = "at most half: aim met" if ratio.high <= 0.5 else "aim of at most half not shown"
    return (f"time to threshold (restricted mean, censored at the budget) "
            f"{interval_text(ratio, '.2f')} times that of the baseline ({aim}); {shares}; "
            f"Kaplan-Meier medians {median(est['median_time_to_threshold_transfer'])} and "
            f"{median(est['median_time_to_threshold_baseline'])}")


def verdict(estimates: dict[str, metrics.MetricEstimate],
            adjusted: dict[str, float] | None = None, episodes: int | None = None) -> str:
    """One sentence on the jumpstart, the total-reward gain, the final performance and
    the time to threshold.

    With ``adjusted`` (Holm-adjusted p-values of the :data:`PRIMARY` endpoints) the
    jumpstart and total-reward gain are judged by them; without, by their unadjusted
    tests (descriptive rows). Final performance is always judged unadjusted.
    """
    js, gain, final = (estimates["jumpstart"], estimates["total_reward_gain"],
                       estimates["final_gain"])

    def p_text(key: str) -> str:
        if adjusted is None:
            return f"p = {estimates[key].p_value:.2g}"
        return f"Holm-adjusted p = {adjusted[key]:.2g}"

    over = f" over {episodes} episodes" if episodes else ""
    parts = [
        _effect(js, None if adjusted is None else adjusted["jumpstart"], "a head start",
                "a worse start", "no demonstrated head start")
        + f": jumpstart {interval_text(js, '+.3f')} ({p_text('jumpstart')})",
        _effect(gain, None if adjusted is None else adjusted["total_reward_gain"],
                "more total reward", "less total reward", "no demonstrated total-reward gain")
        + f": total-reward gain {interval_text(gain, '+.1f')}{over} "
        f"({p_text('total_reward_gain')})",
        _effect(final, None, "a higher final performance", "a lower final performance",
                "no demonstrated change in final performance")
        + f" within the budget: {interval_text(final, '+.3f')}",
    ]
    if "time_to_threshold_ratio" in estimates:
        parts.append(time_text(estimates))
    return "; ".join(parts)


def verdict_lines(estimates: dict[str, dict[str, metrics.MetricEstimate]],
                  episodes: int, pooled: str = "") -> list[str]:
    """The primary verdicts: one bullet per method, Holm-adjusted across the methods."""
    adjusted = holm_primary(estimates)
    n = len(estimates) * len(PRIMARY)
    lines = [f"Primary endpoints{pooled}: per method, the jumpstart and the total-reward gain "
             f"against the baseline, {n} tests in one family with Holm's adjustment "
             f"(family-wise error {ALPHA:g}). Intervals are unadjusted 95% intervals; final "
             "performance and time to threshold are descriptive.", ""]
    for method, est in estimates.items():
        lines.append(f"- **{label(method)}** vs the baseline: "
                     f"{verdict(est, adjusted[method], episodes)}.")
    return lines


def doc_reference(name: str, folder: str | os.PathLike[str] | None = None) -> str:
    """A reference to the repository's page ``docs/<name>`` from a file written into
    ``folder``: a link if the page is there beside it (the repository's ``docs/``), else
    the page's place in the repository as plain text, which a run folder copied anywhere
    keeps right."""
    if folder is not None and (Path(folder) / name).is_file():
        return f"[`{name}`]({name})"
    return f"`docs/{name}` in the repository"


def metrics_note(n_episodes: int | None = None,
                 folder: str | os.PathLike[str] | None = None) -> str:
    """The paragraph defining the metrics and intervals of every report; with
    ``n_episodes`` (the curves' length), its windows as :func:`windows` shortens them;
    ``folder`` is where the paragraph is written (see :func:`doc_reference`)."""
    first, last, smoothing = (windows(n_episodes) if n_episodes is not None else
                              (JUMPSTART_EPISODES, FINAL_EPISODES, SMOOTHING))
    return (
        f"Metrics (Taylor & Stone 2009), each against the baseline with the same seeds, "
        f"counting only the episodes on the target task (the source tasks' episodes are not "
        f"charged to transfer: weak-transfer accounting): jumpstart over the first "
        f"{first} episodes; final performance within the budget, the mean of "
        f"the last {last} (not an asymptote: the learners may still be "
        f"improving); total reward (area); transfer ratio (areas above the floor -1); time "
        f"to threshold ({THRESHOLD_SHARE:.0%} of the way from -1 to the baseline's final "
        f"performance, on a {smoothing}-episode trailing mean), taken per seed and censored "
        "at the budget, summarised by the restricted mean time, the Kaplan-Meier median and "
        "the share of seeds that reach it. Intervals: 95%, over seeds (the seed is the unit; "
        "differences are paired by seed): Student t for means and differences, Fieller for "
        "ratios of means, Wilson for shares, order statistics for medians; why these "
        f"intervals, and their simulated coverage, is in {doc_reference('statistics.md', folder)}."
    )


# ---------------------------------------------------------------- pooled comparisons
def pooled_estimates(curve_sets: Sequence[dict[str, np.ndarray]],
                     baseline: str) -> dict[str, dict]:
    """Every method against the baseline on each seed's curves averaged over several
    comparisons (:func:`pool`): the primary comparison of protocols B and C."""
    return compare_to_baseline(pool(curve_sets), baseline)


ENDPOINT_LABELS = {"jumpstart": "jumpstart", "total_reward_gain": "total-reward gain"}


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


def seed_improvements(
    curve_sets: Sequence[dict[str, np.ndarray]], baseline: str,
) -> dict[str, dict[str, metrics.ImprovementTest]]:
    """``{method: {endpoint: paired probability of improvement over seeds}}`` on each
    seed's pooled curves: the seed, not the run, is the unit of the sign and Wilcoxon
    tests."""
    pooled = pool(curve_sets)
    first, last, _ = windows(pooled[baseline].shape[1])
    out = {}
    for method, c in pooled.items():
        if method != baseline:
            gains = metrics.per_seed_gains(c, pooled[baseline], first=first, last=last)
            out[method] = {e: metrics.improvement_test(gains[e]) for e in PRIMARY}
    return out


def pooled_lines(curve_sets: Sequence[dict[str, np.ndarray]], baseline: str, episodes: int,
                 what: str, figure: Path, figure_link: str) -> list[str]:
    """Protocols B and C: the primary verdicts on the pooled curves, the headline table,
    the dips, the methods against each other, the seeds on which each method is ahead,
    and the score distributions over runs (written to ``figure``)."""
    estimates = pooled_estimates(curve_sets, baseline)
    n_seeds = len(curve_sets[0][baseline])
    lines = [
        f"Pooled over {what}: each seed's learning curves are averaged over them, and the "
        "metrics are computed on these pooled curves, over seeds. The pooled jumpstart and "
        "total-reward gain are the per-seed averages of the per-comparison values; the "
        "pooled time to threshold is taken on each seed's pooled curve, censored at the "
        "budget.", "",
        *verdict_lines(estimates, episodes, pooled=" (pooled)"), "",
        *headline_table(estimates, "pooled"), "",
        *dip_lines(pool(curve_sets), baseline),
        *pairwise_lines(pool(curve_sets), baseline),
        "Paired probability of improvement: the share of seeds on which the method's pooled "
        "value beats the baseline's (ties count one half), with a two-sided sign test and "
        f"a Wilcoxon signed-rank test over the {n_seeds} seeds (descriptive):", "",
    ]
    for method, tests in seed_improvements(curve_sets, baseline).items():
        cells = []
        for e in PRIMARY:
            t = tests[e]
            sign = "n/a" if math.isnan(t.sign_p) else f"{t.sign_p:.2g}"
            wil = "n/a" if math.isnan(t.wilcoxon_p) else f"{t.wilcoxon_p:.2g}"
            cells.append(f"{ENDPOINT_LABELS[e]} ahead on {t.better} of {t.n} seeds, behind on "
                         f"{t.worse} (probability {t.probability:.2f}; sign test p = {sign}, "
                         f"Wilcoxon p = {wil})")
        lines.append(f"- {label(method)}: " + "; ".join(cells) + ".")
    scores = run_scores(curve_sets, baseline)
    n_runs = len(next(iter(next(iter(scores.values())).values())))
    plot_score_profiles(scores, figure, title=f"Score distributions over {n_runs} runs "
                        f"({n_seeds} seeds x {len(curve_sets)}), against the baseline")
    lines += ["", f"![score distributions]({figure_link})", "",
              f"Score distributions over the {n_runs} runs (one per seed and comparison): "
              "for each value on the x axis, the share of runs whose score is larger. A curve "
              "that lies above another everywhere dominates it; its height at 0 is the share "
              "of runs where the method beats the baseline. The runs of a seed are not "
              "independent, so the tests above are over seeds.", ""]
    return lines


def team_streams(table: dict) -> dict[str, list[str]]:
    """Protocol B: ``{held-out team: its streams (one per source order)}``."""
    out: dict[str, list[str]] = defaultdict(list)
    for stream in table:
        out[held_out_team(stream)].append(stream)
    return dict(out)


def baseline_shared_across_orders(table: dict, baseline: str) -> bool:
    """Protocol B: whether the baseline's curves against each held-out team are the same
    in all of that team's source orders (a baseline that never sees the sources)."""
    for streams in team_streams(table).values():
        ref = target_curves(table[streams[0]]).get(baseline)
        for s in streams[1:]:
            other = target_curves(table[s]).get(baseline)
            if ref is None or other is None or not np.array_equal(ref, other):
                return False
    return True


def structure_b(table: dict, baseline: str) -> str:
    """Protocol B: what its streams are, and what they are not."""
    teams = team_streams(table)
    orders = sorted({len(s) for s in teams.values()})
    k = orders[0] if len(orders) == 1 else f"{orders[0]}-{orders[-1]}"
    text = f"The {len(table)} streams are {len(teams)} held-out teams x {k} source orders. "
    if baseline_shared_across_orders(table, baseline):
        text += (f"The baseline does not depend on the source order: its curves against a "
                 f"team are identical in the team's {k} orders (checked on the result files). "
                 f"So the streams of a team share their baseline and their seeds; they are "
                 f"{k} looks at one team, not {k} independent confirmations.")
    else:
        text += ("The baseline's curves differ between the source orders of a team, yet the "
                 "orders of a team share their seeds, so they are not independent "
                 "confirmations.")
    return text + (" Per-stream rows are descriptive: they are neither adjusted for "
                   "multiplicity nor counted as confirmations; the primary endpoints are "
                   "the pooled ones.")


def stream_trend(
    methods: dict[str, dict[int, np.ndarray]], method: str, baseline: str
) -> tuple[float, float, float, float, int] | None:
    """Protocol C: does ``method``'s jumpstart grow along the stream? One trend test.

    Per seed, the least-squares slope of its jumpstart on each new opponent against the
    opponent's index (:func:`ilpss.metrics.trend_slopes`); then the mean slope with a
    Student t interval and t-test over seeds, which treats the seed (its whole stream,
    sharing one library) as the unit. Returns ``(slope, low, high, p, n_seeds)`` per
    opponent, or ``None`` with fewer than 2 seeds or 2 opponents.
    """
    targets = sorted(methods[method])
    if len(targets) < 2 or len(methods[baseline][targets[0]]) < 2:
        return None
    per_target = []
    for t in targets:
        first, last, _ = windows(methods[baseline][t].shape[1])
        gains = metrics.per_seed_gains(methods[method][t], methods[baseline][t],
                                       first=first, last=last)
        per_target.append(gains["jumpstart"])
    slopes = metrics.trend_slopes(np.stack(per_target, axis=1), np.asarray(targets, float))
    value, low, high = metrics.t_interval(slopes)
    return float(value), float(low), float(high), float(metrics.t_test_pvalue(slopes)), \
        len(slopes)


def trend_line(trend: tuple[float, float, float, float, int] | None, label: str) -> str:
    """Protocol C's trend test in words."""
    if trend is None:
        return "- The trend along the stream needs at least 2 seeds and 2 opponents."
    value, low, high, p, n = trend
    said = ("grows" if low > 0 else "shrinks" if high < 0 else "shows no demonstrated trend")
    return (f"- **Along the stream**, the jumpstart of {label} {said}: slope "
            f"{value:+.4f} per opponent, 95% interval [{low:+.4f}, {high:+.4f}], p = {p:.2g} "
            f"(one test: each seed's least-squares slope over the opponents, t over the {n} "
            "seeds, so a seed's opponents count as one cluster).")


def _figure(curves: dict[str, np.ndarray], path: Path, title: str) -> Path:
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
    fig.legend(list(handles.values()), [label(m) for m in handles],
               loc="outside lower center", ncols=min(len(handles), 4), fontsize=8)
    return save_figure(fig, path, dpi=110)


def write_report(
    cfg: ExperimentConfig, results: list[dict[str, Any]], out_dir: str | os.PathLike[str],
    command: str | None = None,
) -> Path:
    """Write ``report.md`` with figures into ``out_dir``; return its path.

    ``command`` is the command line written in the report; by default the current one
    when it is ``ilpss-experiment``, else "(from Python)".
    """
    out = Path(out_dir)
    if command is None:
        command = "ilpss-experiment " + " ".join(shlex.quote(a) for a in sys.argv[1:]) \
            if Path(sys.argv[0]).name == "ilpss-experiment" else "(from Python)"
    lines = [
        f"# Protocol {cfg.protocol}: {cfg.n_seeds} seeds, "
        f"{cfg.lifelong.train_episodes} learning episodes per opponent",
        "",
        f"Command: `{command}`; configuration: [`config.json`](config.json).",
        "",
        code_line(results),
        "",
        metrics_note(cfg.lifelong.train_episodes, out),
        "",
    ]
    if cfg.baseline is None:
        raise ValueError("a report compares every method with the run's baseline, and this "
                         "run has none (ExperimentConfig.baseline is null): compare it with "
                         "ilpss-compare instead")
    lines += report_body(cfg, results, out)
    lines += success_lines(results)
    path = out / "report.md"
    atomic_write_bytes(path, "\n".join(lines).encode())
    return path


def success_rates(curves: np.ndarray) -> tuple[float, float]:
    """Share of successful episodes (reward above 0: the drill pays at least 0.5 for a
    success and -1 otherwise) over the first and over the last episodes of
    :func:`windows`, pooled over the seeds of ``curves`` (n_seeds, episodes)."""
    first, last, _ = windows(curves.shape[1])
    won = curves > 0
    return float(won[:, :first].mean()), float(won[:, -last:].mean())


def success_lines(results: list[dict[str, Any]]) -> list[str]:
    """Per target (stream and task) and method, the success rate early and late in
    learning it: the reward curves say how well, this says how often."""
    table = collect(results)
    names: dict[str, set[tuple[str, ...]]] = defaultdict(set)
    for res in results:
        names[res["stream"]].add(tuple(res["tasks"]))
    methods = list(next(iter(table.values())))
    rows, episodes = [], 0
    for stream, by_method in table.items():
        (tasks,) = names[stream] if len(names[stream]) == 1 else (None,)
        for t in sorted(next(iter(by_method.values()))):
            cells = []
            for m in methods:
                curves = by_method.get(m, {}).get(t)
                if curves is None:
                    cells.append("-")
                    continue
                early, late = success_rates(curves)
                episodes = curves.shape[1]
                cells.append(f"{100 * early:.0f} % -> {100 * late:.0f} %")
            # Protocol C draws each seed's opponents: a task index names no one team.
            target = f"`{tasks[t]}`" if tasks else f"opponent {t} (drawn per seed)"
            rows.append(f"| {stream} | {target} | " + " | ".join(cells) + " |")
    first, last, _ = windows(episodes)
    return ["## Success rate on each target (descriptive)", "",
            f"Share of episodes that end in a success, over the first {first} and the last "
            f"{last} episodes of learning the target, all seeds pooled (first -> last).", "",
            "| stream | target | " + " | ".join(label(m) for m in methods) + " |",
            "|---|---|" + "---:|" * len(methods), *rows, ""]


def held_out_sections(
    cfg: ExperimentConfig, results: list[dict[str, Any]], out: Path, *, pooled: bool
) -> list[str]:
    """The body of the report of protocols whose every stream has one target (the
    held-out team): per stream its curves and the metrics of every method against
    the baseline, with verdicts; with ``pooled`` (several streams, as in B) the verdicts
    are on the curves pooled over the streams, and the per-stream ones descriptive."""
    table = collect(results)
    episodes, baseline = cfg.lifelong.train_episodes, cfg.baseline
    estimates = stream_estimates(table, baseline)
    lines: list[str] = []
    if pooled and all(estimates.values()):
        lines += ["## Pooled over the streams (primary)", "", structure_b(table, baseline), "",
                  *pooled_lines([target_curves(m) for m in table.values()], baseline, episodes,
                                f"the {len(table)} streams", out / "profiles.png",
                                "profiles.png")]
    for s, (stream, methods) in enumerate(table.items()):
        curves = target_curves(methods)
        fig = _figure(curves, out / f"curves_{s:02d}.png",
                      f"{stream}: learning against the held-out opponent")
        lines += [f"## {stream}", "", f"![learning curves]({fig.name})", ""]
        if baseline in curves and not comparable(curves, baseline):
            lines += ["Transfer metrics need at least 2 seeds.", ""]
        elif not pooled and estimates[stream]:
            lines += ["### Verdicts", "", *verdict_lines(estimates[stream], episodes), "",
                      *headline_table(estimates[stream], "one stream"), "",
                      *dip_lines(curves, baseline), *pairwise_lines(curves, baseline)]
        for method, est in estimates[stream].items():
            lines += [f"### {label(method)} vs the baseline", ""]
            if pooled:
                lines += [f"Descriptive (one stream, unadjusted): {verdict(est)}.", ""]
            lines += [metrics.format_metrics_markdown(est), ""]
    return lines


def parametric_stream_sections(
    cfg: ExperimentConfig, results: list[dict[str, Any]], out: Path
) -> list[str]:
    """The body of the report of a long stream whose every task from the second on is a
    target (protocol C): the verdicts pooled over the targets, the trend of the head
    start along the stream, and the jumpstart and library size on each new opponent."""
    (methods,) = collect(results).values()
    episodes, baseline, featured = cfg.lifelong.train_episodes, cfg.baseline, cfg.featured_method
    jumpstarts = stream_jumpstarts(methods, featured, baseline) if featured else []
    sizes = library_sizes(cfg, results)
    plot_stream(jumpstarts, sizes, out / "stream.png")
    lines: list[str] = []
    targets = sorted(methods[baseline])
    if len(methods[baseline][targets[0]]) >= 2:
        lines += ["## Pooled over the opponents (primary)", "",
                  *pooled_lines([{m: methods[m][t] for m in methods} for t in targets],
                                baseline, episodes,
                                f"the {len(targets)} opponents after the first",
                                out / "profiles.png", "profiles.png"),
                  *[trend_line(stream_trend(methods, m, baseline), label(m))
                    for m in methods if m != baseline], ""]
    return [*lines, "## Jumpstart on each new opponent of the stream (descriptive)", "",
            *protocol_c_lines(jumpstarts, sizes, "stream.png", featured)]


def several_targets_sections(
    cfg: ExperimentConfig, results: list[dict[str, Any]], out: Path
) -> list[str]:
    """The body of the report of a stream with several targets that all start from the
    state after its sources (protocol A with ``targets``): the primary verdicts on each
    seed's curves pooled over the targets, the seeds on which each method is ahead and
    the score distributions, a descriptive row per target; then per target its curves and
    the metrics of every method against the baseline (descriptive, unadjusted)."""
    ((_, methods),) = collect(results).items()
    names = results[0]["tasks"]
    episodes, baseline = cfg.lifelong.train_episodes, cfg.baseline
    per_target = per_target_curves(methods)
    lines: list[str] = []
    if all(comparable(c, baseline) for c in per_target.values()):
        estimates = {t: compare_to_baseline(c, baseline) for t, c in per_target.items()}
        lines += ["## Pooled over the targets (primary)", "", structure_targets(len(per_target)),
                  "", *pooled_lines(list(per_target.values()), baseline, episodes,
                                    f"the {len(per_target)} targets", out / "profiles.png",
                                    "profiles.png"),
                  *target_tables(estimates, names), *per_target_dips(per_target, names, baseline)]
    for t, curves in per_target.items():
        lines += descriptive_lines(curves, baseline, out / f"curves_00_{t:02d}.png",
                                   f"{names[t]}: learning against the held-out opponent",
                                   f"Target `{names[t]}`", "one target, unadjusted")
    return lines


def descriptive_lines(curves: dict[str, np.ndarray], baseline: str, figure: Path, title: str,
                      heading: str, scope: str) -> list[str]:
    """One comparison's section: its curves (written to ``figure``), the headline table,
    the dips, the methods against each other and, per method, the verdict and every
    metric against the baseline, marked descriptive (``scope``)."""
    fig = _figure(curves, figure, title)
    lines = [f"## {heading}", "", f"![learning curves]({fig.name})", ""]
    if not comparable(curves, baseline):
        return [*lines, "Transfer metrics need the baseline on at least 2 seeds.", ""]
    estimates = compare_to_baseline(curves, baseline)
    lines += [*headline_table(estimates, scope), "", *dip_lines(curves, baseline),
              *pairwise_lines(curves, baseline)]
    for method, est in estimates.items():
        lines += [f"### {label(method)} vs the baseline", "",
                  f"Descriptive ({scope}): {verdict(est)}.", "",
                  metrics.format_metrics_markdown(est), ""]
    return lines


def per_target_curves(methods: dict[str, dict[int, np.ndarray]]) -> dict[int, dict[str, np.ndarray]]:
    """``{target task index: {method: curves (n_seeds, episodes)}}``, targets in order."""
    targets = sorted(next(iter(methods.values())))
    return {t: {m: by_task[t] for m, by_task in methods.items()} for t in targets}


def structure_targets(n: int) -> str:
    """Several targets after one source history: what they are, and what they are not."""
    return (f"The {n} targets all start from each seed's state after the sources, and learn "
            "with the same seeds of that trial: they share the seed's source history, so "
            f"they are {n} looks after one history, not {n} independent confirmations. "
            "Per-target rows are descriptive: they are neither adjusted for multiplicity "
            "nor counted as confirmations; the primary endpoints are the pooled ones.")


def comparison_row(name: str, est: dict[str, metrics.MetricEstimate]) -> str:
    """One row of a table against the baseline: every headline metric
    (:func:`ilpss.metrics.headline_metrics`) with its interval, and the seeds that reach
    the threshold."""
    n = est["jumpstart"].n
    reached = (f"{round(est['threshold_reached_transfer'].value * n)}/{n}, "
               f"{round(est['threshold_reached_baseline'].value * n)}/{n}")
    cells = [interval_text(est[m.name], m.fmt) for m in metrics.headline_metrics()
             if m.name in est]
    return f"| {name} | " + " | ".join(cells) + f" | {reached} |"


def comparison_head(what: str) -> list[str]:
    """The head of a table of :func:`comparison_row` rows."""
    cells = [f"{m.label} [95% CI]" for m in metrics.headline_metrics()]
    return [f"| {what} | " + " | ".join(cells) + " | seeds reaching the threshold "
            "(method, baseline) |", "|---|" + "---:|" * (len(cells) + 1)]


def headline_table(estimates: dict[str, dict[str, metrics.MetricEstimate]],
                   scope: str) -> list[str]:
    """Every method against the baseline on the headline metrics, one row each (unadjusted
    95% intervals; ``scope`` says over what)."""
    return [f"Against the baseline ({scope}; unadjusted 95% intervals over seeds; the dip "
            "and the episodes below the baseline are described under the next heading):", "",
            *comparison_head("method"),
            *[comparison_row(label(m), est) for m, est in estimates.items()]]


def _trailing(curves: np.ndarray) -> np.ndarray:
    """The seed-mean curve's trailing mean over the smoothing window (full windows)."""
    window = windows(curves.shape[1])[2]
    return metrics.smooth(curves.mean(axis=0), window, edges="valid")


def _dip_and_below(mine: np.ndarray, base: np.ndarray) -> tuple[float, int]:
    """The largest dip of the trailing mean ``mine`` and the episodes at which it lies
    more than :data:`~ilpss.metrics.BELOW_MARGIN` below the baseline's ``base``."""
    return (float(metrics.largest_dip(mine, 1)),
            int(np.sum(mine < base - metrics.BELOW_MARGIN)))


def dip_lines(curves: dict[str, np.ndarray], baseline: str) -> list[str]:
    """The handover, per method: how far the seed-mean curve's trailing mean falls below
    its earlier maximum, how many episodes it lies more than
    :data:`~ilpss.metrics.BELOW_MARGIN` below the baseline's, and the same per seed with an
    interval."""
    window = windows(curves[baseline].shape[1])[2]
    base = _trailing(curves[baseline])
    rows = []
    for method, c in curves.items():
        mine = _trailing(c)
        dip, below = _dip_and_below(mine, base)
        per_seed = metrics.largest_dip(c, window)
        value, low, high = (metrics.t_interval(per_seed) if len(per_seed) >= 2
                            else (float(per_seed.mean()), math.nan, math.nan))
        rows.append(f"| {label(method)} | {dip:.2f} | {below} | {value:.2f} "
                    f"[{_signed(low, '.2f')}, {_signed(high, '.2f')}] |")
    return [f"The handover (descriptive): the largest fall of the {window}-episode trailing "
            "mean below its earlier maximum (from the first full window on), on the seed-mean "
            "curve the figures show and per seed (mean, 95% t interval), and the episodes at "
            f"which the seed-mean trailing mean lies more than {metrics.BELOW_MARGIN:g} below "
            "the baseline's.", "",
            "| method | largest dip, seed-mean curve | episodes below the baseline | largest "
            "dip per seed [95% CI] |", "|---|---:|---:|---:|", *rows, ""]


def per_target_dips(per_target: dict[int, dict[str, np.ndarray]], names: Sequence[str],
                    baseline: str) -> list[str]:
    """Several targets: each method's seed-mean largest dip and episodes below the
    baseline on every target (a method that never collapses does not on any)."""
    methods = list(next(iter(per_target.values())))
    head = "| method | " + " | ".join(f"`{names[t]}`: dip, below" for t in per_target) + " |"
    rows = []
    for method in methods:
        cells = []
        for curves in per_target.values():
            dip, below = _dip_and_below(_trailing(curves[method]), _trailing(curves[baseline]))
            cells.append(f"{dip:.2f}, {below}")
        rows.append(f"| {label(method)} | " + " | ".join(cells) + " |")
    return ["### The handover on each target (descriptive)", "",
            "Seed-mean curves: the largest fall of the trailing mean below its earlier "
            f"maximum, and the episodes more than {metrics.BELOW_MARGIN:g} below the "
            "baseline's.", "",
            head, "|---|" + "---:|" * len(per_target), *rows, ""]


def worst_target_dips(per_target: dict[int, dict[str, np.ndarray]], names: Sequence[str],
                      baseline: str) -> list[str]:
    """Many targets: each method's largest seed-mean dip and most episodes below the
    baseline over all of them, with the target where each occurs (a method that never
    collapses does not on any; a table per target would be too wide to read)."""
    methods = list(next(iter(per_target.values())))
    rows = []
    for method in methods:
        found = {t: _dip_and_below(_trailing(curves[method]), _trailing(curves[baseline]))
                 for t, curves in per_target.items()}
        deepest = max(found, key=lambda t: found[t][0])
        longest = max(found, key=lambda t: found[t][1])
        rows.append(f"| {label(method)} | {found[deepest][0]:.2f} (`{names[deepest]}`) | "
                    f"{found[longest][1]} (`{names[longest]}`) |")
    return ["### The handover on the worst target (descriptive)", "",
            f"Seed-mean curves on each of the {len(per_target)} targets: the largest fall of "
            "the trailing mean below its earlier maximum, and the most episodes more than "
            f"{metrics.BELOW_MARGIN:g} below the baseline's, over all targets, with the "
            "target where each occurs.", "",
            "| method | largest dip on any target | most episodes below the baseline on any "
            "target |", "|---|---:|---:|", *rows, ""]


def pairwise_estimates(
    curves: dict[str, np.ndarray], baseline: str
) -> dict[tuple[str, str], dict[str, tuple[float, float, float, float]]]:
    """Every transfer method against every other, paired by seed, on the pairwise metrics
    (:func:`ilpss.metrics.pairwise_metrics`): ``{(a, b): {metric: (value, low, high, Holm
    p)}}``, the p-values Holm-adjusted within this family (all pairs and metrics)."""
    methods = [m for m in curves if m != baseline]
    n_eps = curves[baseline].shape[1]
    first, last, window = windows(n_eps)
    pairs = [(a, b) for i, a in enumerate(methods) for b in methods[i + 1:]]
    raw: dict[tuple[str, str], dict[str, tuple[float, float, float, float]]] = {}
    for a, b in pairs:
        paired = metrics.Paired(curves[a], curves[b], first=first, last=last, window=window)
        raw[a, b] = {}
        for m in metrics.pairwise_metrics():
            diff = m.values(paired)
            value, low, high = metrics.t_interval(diff)
            raw[a, b][m.name] = (value, low, high, float(metrics.t_test_pvalue(diff)))
    keys = [(pair, m) for pair in raw for m in raw[pair]]
    adjusted = metrics.holm([raw[pair][m][3] for pair, m in keys]) if keys else []
    for (pair, m), p in zip(keys, adjusted, strict=True):
        value, low, high, _ = raw[pair][m]
        raw[pair][m] = (value, low, high, float(p))
    return raw


def pairwise_lines(curves: dict[str, np.ndarray], baseline: str) -> list[str]:
    """The transfer methods against each other (:func:`pairwise_estimates`), as a table,
    and the metrics on which one method beats every other by a Holm-adjusted test."""
    if len(curves[baseline]) < 2 or len(curves) < 3:
        return []
    pairs = pairwise_estimates(curves, baseline)
    compared = metrics.pairwise_metrics()
    rows = []
    for (a, b), est in pairs.items():
        cells = [f"{interval_text(_Estimate(*est[m.name][:3]), m.fmt)} "
                 f"(p = {est[m.name][3]:.2g})" for m in compared]
        rows.append(f"| {label(a)} - {label(b)} | " + " | ".join(cells) + " |")
    best = []
    methods = [m for m in curves if m != baseline]
    for m in compared:
        for a in methods:
            wins = [_beats(pairs, a, b, m) for b in methods if b != a]
            if wins and all(wins):
                best.append(f"**{label(a)}** is the best on {m.label}: it beats every other "
                            "transfer method, each difference above zero with a Holm-adjusted "
                            f"p below {ALPHA:g}.")
    said = best or ["No transfer method beats every other on any of these metrics by a "
                    "Holm-adjusted test: no method is shown to be the best."]
    return ["Method against method (descriptive family of its own): the paired difference "
            "over seeds (the first named minus the second), 95% t interval, and the p-value "
            f"Holm-adjusted across the {len(pairs)} pairs x {len(compared)} metrics.", "",
            "| methods | " + " | ".join(f"{m.label} [95% CI]" for m in compared) + " |",
            "|---|" + "---:|" * len(compared), *rows, "", *[f"- {t}" for t in said], ""]


@dataclass(frozen=True)
class _Estimate:
    """A value and its interval, for :func:`interval_text`."""

    value: float
    low: float
    high: float


def _beats(pairs: dict, a: str, b: str, metric: metrics.Metric) -> bool:
    """Whether ``a`` beats ``b`` on ``metric`` (its sign of better) by a Holm-adjusted
    test, whichever way round the pair was stored."""
    if (a, b) in pairs:
        value, _, _, p = pairs[a, b][metric.name]
    else:
        value, _, _, p = pairs[b, a][metric.name]
        value = -value
    return p < ALPHA and value * metric.better > 0


def target_tables(estimates: dict[int, dict[str, dict[str, metrics.MetricEstimate]]],
                  names: Sequence[str]) -> list[str]:
    """Per method, a descriptive row per target (``{target: {method: metrics}}``)."""
    lines: list[str] = []
    for method in next(iter(estimates.values())):
        lines += [f"### {label(method)} vs the baseline, per target (descriptive)", "",
                  *comparison_head("target"),
                  *[comparison_row(f"`{names[t]}`", est[method]) for t, est in estimates.items()],
                  ""]
    n = next(iter(next(iter(estimates.values())).values()))["jumpstart"].n
    return [*lines, f"Unadjusted 95% intervals over the {n} seeds of each of the "
            f"{len(estimates)} targets; the pooled rows are the verdicts above.", ""]


def target_sections(
    cfg: ExperimentConfig, results: list[dict[str, Any]], out: Path
) -> list[str]:
    """The body of a report for any stream: per stream and target task, the curves and
    the metrics of every method against the baseline (descriptive, unadjusted)."""
    lines: list[str] = []
    for s, (stream, methods) in enumerate(collect(results).items()):
        for t in sorted(next(iter(methods.values()))):
            curves = {m: by_task[t] for m, by_task in methods.items()}
            lines += descriptive_lines(curves, cfg.baseline, out / f"curves_{s:02d}_{t:02d}.png",
                                       f"{stream}: learning on task {t}",
                                       f"{stream}, task {t}", "unadjusted")
    return lines


def stream_jumpstarts(
    methods: dict[str, dict[int, np.ndarray]], method: str, baseline: str
) -> list[tuple[int, metrics.MetricEstimate]]:
    """Protocol C: ``(task index, jumpstart of method against the baseline)`` on every
    target of the stream (none with fewer than 2 seeds)."""
    out: list[tuple[int, metrics.MetricEstimate]] = []
    if len(methods[baseline][min(methods[baseline])]) < 2:
        return out
    for t in sorted(methods[method]):
        first, last, window = windows(methods[baseline][t].shape[1])
        est = metrics.compare(methods[method][t], methods[baseline][t], first=first,
                              last=last, threshold=None, window=window)
        out.append((t, est["jumpstart"]))
    return out


def library_sizes(cfg: ExperimentConfig,
                  results: list[dict[str, Any]]) -> dict[str, np.ndarray]:
    """``{method: active options after each trial, (n_seeds, n_trials)}`` of every lifelong
    method that offers options, seeds in order."""
    sizes: dict[str, list] = defaultdict(list)
    with_options = {m for m in cfg.methods if _offers_options(m, cfg)}
    for res in sorted(results, key=lambda r: (r["stream_index"], r["seed"])):
        for method, data in res["methods"].items():
            if method in with_options:
                sizes[method].append(data["library_size"])
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
        ax2.plot(np.arange(1, len(mean) + 1), mean, marker="o", label=label(method))
    ax2.set_xlabel("trials completed")
    ax2.set_ylabel("active options (mean over seeds)")
    ax2.legend()
    fig.tight_layout()
    return save_figure(fig, path, dpi=120)


def protocol_c_lines(
    jumpstarts: list[tuple[int, metrics.MetricEstimate]], sizes: dict[str, np.ndarray],
    figure: str, featured: str | None,
) -> list[str]:
    """Protocol C's figure link, the featured method's jumpstart on each opponent and the
    final library sizes, as markdown."""
    rows = ["Per opponent, descriptive: 95% t intervals over seeds, not adjusted for the "
            f"{len(jumpstarts)} opponents; the claim that the head start grows is the one "
            "trend test above.", "",
            f"| opponent | jumpstart ({label(featured or '')} - baseline) | 95% CI |",
            "|---|---:|---|"]
    rows += [f"| {t} | {js.value:+.3f} | [{js.low:+.3f}, {js.high:+.3f}] |"
             for t, js in jumpstarts]
    if not jumpstarts:
        rows = ["Transfer metrics need at least 2 seeds." if featured else
                "No method of this run is featured (ExperimentConfig.featured)."]
    lines = [f"![stream]({figure})", "", *rows, ""]
    for method, runs in sizes.items():
        final = runs[:, -1]
        lines.append(f"- {label(method)}: {final.mean():.1f} active options after the last "
                     f"trial (min {final.min():.0f}, max {final.max():.0f} over seeds).")
    return lines


def _offers_options(method: str, cfg: ExperimentConfig) -> bool:
    """Whether ``method`` is a lifelong method whose learners are offered options."""
    entry = METHODS.get(method)
    return isinstance(entry, LifelongMethod) and entry.config(cfg.lifelong).reuse.offers_options


def _held_out_a(cfg: ExperimentConfig, results: list[dict[str, Any]], out: Path) -> list[str]:
    """Protocol A: one held-out target per stream, or several from one source history."""
    if len(results[0]["tasks"]) - results[0]["first_target"] > 1:
        return several_targets_sections(cfg, results, out)
    return held_out_sections(cfg, results, out, pooled=False)


ReportBody = Callable[[ExperimentConfig, list[dict[str, Any]], Path], list[str]]
REPORT_BODIES: dict[str, ReportBody] = {
    "A": _held_out_a,
    "B": lambda cfg, results, out: held_out_sections(cfg, results, out, pooled=True),
    "C": parametric_stream_sections,
    "R": _held_out_a,
}
"""The body of ``report.md`` per protocol name; a protocol with none gets
:func:`target_sections`."""


def register_report_body(protocol: str, body: ReportBody, *, overwrite: bool = False) -> None:
    """Write ``report.md``'s body of the protocol named ``protocol`` with ``body``."""
    if protocol in REPORT_BODIES and not overwrite:
        raise ValueError(f"protocol {protocol!r} has a report body; pass overwrite=True")
    REPORT_BODIES[protocol] = body


def report_body(cfg: ExperimentConfig, results: list[dict[str, Any]], out: Path) -> list[str]:
    """The body of ``report.md`` for ``cfg``'s protocol (its figures written into ``out``)."""
    return REPORT_BODIES.get(cfg.protocol, target_sections)(cfg, results, out)
