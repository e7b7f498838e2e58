"""The results page of the reference command: one table and one figure per setting.

Every figure comes from the kept results; nothing is typed in. Beside each team: the best
fixed holder rule on the same held-out episodes (evaluated by the command) and the
tile-coded SMDP learner's final row of ``docs/learning.md`` (its own budget and
episodes, quoted as that page gives it).

Statistics: per training seed, the greedy success over the evaluation episodes with a
Wilson interval and the mean reward with a t interval over the episodes; per team, the
mean over seeds of each with a t interval over seeds (the seed is the unit), and how many
seeds learned (:class:`~ilpss.reference.settings.EvalSettings`). The transfer row takes
``ilpss.metrics``' jumpstart, total reward and final performance per seed, paired by
seed, with t intervals over seeds.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ilpss._io import save_figure
from ilpss.metrics import (
    asymptotic_performance,
    jumpstart,
    t_interval,
    total_reward,
    wilson_interval,
)
from ilpss.reference.jobs import SELF_PLAY, Job
from ilpss.reference.settings import EvalSettings, HolderSetting, TransferSetting

__all__: list[str] = []


def learning_md_rows(path: Path) -> dict[str, tuple[str, str]]:
    """The tile-coded learner's ``(mean reward, success)`` cells by team, read from the
    table of ``docs/learning.md`` (empty if the page is missing or has no such table)."""
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except OSError:
        return {}
    out = {}
    for line in lines:
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 10 and cells[1].startswith(("+", "-")) and "%" in cells[2]:
            out[cells[0]] = (cells[1], cells[2])
    return out


def _ci(m: float, lo: float, hi: float, pct: bool = False, digits: int = 3) -> str:
    if any(math.isnan(x) for x in (m, lo, hi)):
        return f"{m:.1%}" if pct else f"{m:+.{digits}f}"
    if pct:
        return f"{m:.1%} [{lo:.1%}, {hi:.1%}]"
    return f"{m:+.{digits}f} [{lo:+.{digits}f}, {hi:+.{digits}f}]"


def _over_seeds(values: Sequence[float], pct: bool = False,
                within: tuple[float, float] = (-math.inf, math.inf), digits: int = 3) -> str:
    """The mean over seeds with its 95% t interval, the interval cut to ``within`` (what
    the values can be: a seed that learned and one that did not make a wide interval)."""
    v = np.asarray(values, float)
    if v.size < 2:
        return _ci(float(v.mean()), math.nan, math.nan, pct, digits)
    m, lo, hi = (float(x) for x in t_interval(v))
    return _ci(m, max(lo, within[0]), min(hi, within[1]), pct, digits)


def _over_episodes(rewards: Sequence[float], within: tuple[float, float]) -> str:
    """The mean reward over episodes with its 95% t interval, cut to ``within``."""
    m, lo, hi = (float(x) for x in t_interval(np.asarray(rewards, float)))
    return _ci(m, max(lo, within[0]), min(hi, within[1]))


SHARE = (0.0, 1.0)
"""The range of a success rate."""


def _reward_range(job: Job) -> tuple[float, float]:
    """The range of an episode's reward in ``job``: the drill's [-1, 1], lower where the
    holder's reward option makes a timeout cost more."""
    holder = getattr(job.setting, "holder", job.setting)
    option = getattr(holder, "reward", None)
    low = min(-1.0, option.timeout_reward) if option is not None and option.active else -1.0
    return low, 1.0


def _success(rewards: Sequence[float]) -> tuple[float, str]:
    wins = int((np.asarray(rewards) > 0).sum())
    lo, hi = wilson_interval(wins, len(rewards))
    return wins / len(rewards), _ci(wins / len(rewards), lo, hi, pct=True)


def _figure(name: str, by_team: Mapping[str, list[list[list[float]]]], path: Path) -> None:
    """Success rate per rollout against environment steps and wall time, a thin line per
    seed and the mean over seeds in bold, one colour per team."""
    fig = Figure(figsize=(11, 4))
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, 2, sharey=True)
    for k, (team, curves) in enumerate(by_team.items()):
        colour = f"C{k}"
        for curve in curves:
            c = np.asarray(curve, float)
            axes[0].plot(c[:, 0], c[:, 3], color=colour, lw=0.5, alpha=0.4)
            axes[1].plot(c[:, 1] / 60, c[:, 3], color=colour, lw=0.5, alpha=0.4)
        n = min(len(c) for c in curves)
        rates = np.array([np.asarray(c, float)[:n, 3] for c in curves])
        seen = np.isfinite(rates).sum(axis=0)  # the seeds with an episode in that rollout
        mean = np.where(seen > 0, np.nansum(rates, axis=0) / np.maximum(seen, 1), np.nan)
        steps = np.asarray(curves[0], float)[:n, 0]
        minutes = np.mean([np.asarray(c, float)[:n, 1] for c in curves], axis=0) / 60
        axes[0].plot(steps, mean, color=colour, lw=2, label=team)
        axes[1].plot(minutes, mean, color=colour, lw=2)
    axes[0].set(xlabel="environment steps", ylabel="training success rate", ylim=(-0.02, 1.02),
                title=f"{name}: against steps")
    axes[1].set(xlabel="wall time (minutes, one core per seed)", title=f"{name}: against time")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)


def _budget(job: Job, seeds: int) -> str:
    """The section's budget and seeds, as its settings record them."""
    s = job.setting
    unit = "decisions" if isinstance(s, HolderSetting) else "environment steps"
    return (f"Budget: {s.ppo.steps:,} {unit} per training seed; {seeds} training seeds "
            f"(0 to {seeds - 1}); evaluation on the held-out episode seeds.")


def _unlearned(learned: Mapping[str, tuple[int, int]]) -> str:
    """Where a seed failed to learn in the budget, said with the counts."""
    failed = {t: (k, n) for t, (k, n) in learned.items() if k < n}
    if not learned:
        return "No fixed rule on these teams: no seed is counted as learned or not."
    if not failed:
        return "Every training seed learned against every team in the budget."
    return ("Not learned in the budget: " + "; ".join(
        f"`{t}` in {n - k} of {n} seeds" for t, (k, n) in failed.items())
        + " (the thin lines of the figure are the seeds' curves).")


def _section(name: str, jobs: list[Job], results: list[dict[str, Any]],
             rules: Mapping[str, Mapping[str, list[float]]], tile: Mapping[str, tuple[str, str]],
             ev: EvalSettings, figure: str) -> list[str]:
    teams = list(dict.fromkeys(t for r in results for t in r["eval"]))
    seeds = len({j.seed for j in jobs})
    learned_by_team: dict[str, tuple[int, int]] = {}
    lines = [f"## `{name}`", "", _budget(jobs[0], seeds), "", f"![{name}]({figure})", "",
             "| team | seeds learned | greedy success, mean over seeds [95% t, within "
             "0-100%] | greedy mean reward [95% t, within the reward's range] | best fixed "
             "rule: success [Wilson] | rule: mean reward [95% t] | tile-coded SMDP "
             "(docs/learning.md): reward | success |",
             "|---|---|---|---|---|---|---|---|"]
    detail = ["", "| team | seed | success [95% Wilson] | mean reward [95% t] | steps | "
              "training minutes |", "|---|---|---|---|---|---|"]
    for team in teams:
        rows = [(j, r) for j, r in zip(jobs, results, strict=True) if team in r["eval"]]
        succ = [_success(r["eval"][team])[0] for _, r in rows]
        mean = [float(np.mean(r["eval"][team])) for _, r in rows]
        best = rule_cells = None
        if rules.get(team):
            best = max(rules[team], key=lambda n: np.mean(rules[team][n]))
            rule_success, rule_cells = _success(rules[team][best])
            learned = sum(s >= ev.learned_fraction * rule_success for s in succ)
            learned_by_team[team] = (learned, len(rows))
            rule_reward = _over_episodes(rules[team][best], (-1.0, 1.0))
        else:
            learned = None
        tr, ts = tile.get(team, ("n/a", "n/a"))
        count = "n/a" if learned is None else f"{learned} of {len(rows)}"
        lines.append(f"| {team} | {count} | {_over_seeds(succ, True, SHARE)} | "
                     f"{_over_seeds(mean, within=_reward_range(rows[0][0]))} | "
                     + (f"{best}: {rule_cells} | {rule_reward}" if best else "n/a | n/a")
                     + f" | {tr} | {ts} |")
        for j, r in rows:
            last = r["curve"][-1]
            reward = _over_episodes(r["eval"][team], _reward_range(j))
            detail.append(f"| {team} | {j.seed} | {_success(r['eval'][team])[1]} | {reward} | "
                          f"{int(last[0])} | {last[1] / 60:.1f} |")
    return [*lines, "", _unlearned(learned_by_team), *detail, ""]


def _transfer_figure(job_results: list[tuple[Job, dict[str, Any]]], window: int,
                     path: Path) -> None:
    """The target's learning curves, fine-tuned and anew: the reward per episode averaged
    over ``window`` episodes, a thin line per seed and the mean over seeds in bold."""
    fig = Figure(figsize=(7, 4))
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    kernel = np.ones(window) / window
    for colour, arm in (("C0", "fine_tuned"), ("C1", "anew")):
        smooth = np.array([np.convolve(np.asarray(r[arm]["curve"], float), kernel, "valid")
                           for _, r in job_results])
        x = np.arange(window, window + smooth.shape[1])
        for row in smooth:
            ax.plot(x, row, color=colour, lw=0.5, alpha=0.4)
        ax.plot(x, smooth.mean(axis=0), color=colour, lw=2, label=arm.replace("_", "-"))
    ax.set(xlabel="target episodes", ylabel=f"reward per episode (mean of {window})",
           ylim=(-1.02, 1.02), title=f"transfer to {job_results[0][0].team}")
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)


def _transfer(job_results: list[tuple[Job, dict[str, Any]]], setting: TransferSetting,
              figure: str) -> list[str]:
    w = setting.window
    js, tot, fin, fa, aa = [], [], [], [], []
    for _, r in job_results:
        ft, an = r["fine_tuned"]["curve"], r["anew"]["curve"]
        js.append(jumpstart(ft, an, w))
        tot.append(total_reward(ft) - total_reward(an))
        fin.append(asymptotic_performance(ft, w) - asymptotic_performance(an, w))
        fa.append(_success(r["fine_tuned"]["eval"])[0])
        aa.append(_success(r["anew"]["eval"])[0])
    job = job_results[0][0]
    return [
        "## `transfer`", "",
        f"Sources {', '.join(f'`{t}`' for t in job.teams)} in order "
        f"({setting.source_steps:,} decisions each), then the held-out `{job.team}` for "
        f"{setting.target_episodes:,} episodes; fine-tuned from the sources' policy (and its "
        "observation statistics) against learning anew, paired by seed. Jumpstart: first "
        f"{w} episodes; final: last {w}; total: over the {setting.target_episodes:,} episodes. "
        f"{len(js)} training seeds (0 to {len(js) - 1}).",
        "", f"![transfer]({figure})", "",
        "| target | seeds | jumpstart [95% t] | total reward gain [95% t] | final gain [95% t] "
        "| greedy success, fine-tuned [95% t, within 0-100%] | greedy success, anew |",
        "|---|---|---|---|---|---|---|",
        f"| {job.team} | {len(js)} | {_over_seeds(js)} | {_over_seeds(tot, digits=1)} | "
        f"{_over_seeds(fin)} | {_over_seeds(fa, True, SHARE)} | "
        f"{_over_seeds(aa, True, SHARE)} |", ""]


def write_page(command: str, code: str, took: str, jobs: list[Job],
               results: list[dict[str, Any]], rules: Mapping[str, Mapping[str, list[float]]],
               tile: Mapping[str, tuple[str, str]], ev: EvalSettings, figures: Path,
               page: Path) -> str:
    """The page's markdown, its figures saved into ``figures`` (linked relative to
    ``page``)."""
    lines = [
        "# Reference deep-RL results for the drill", "",
        f"Command: `{command}` ({took}).", "", code, "",
        f"Evaluation: the greedy policy of each training seed on {ev.episodes} held-out "
        "episode seeds (the same for every seed, setting and fixed rule). A seed *learned* "
        f"when its greedy success is at least {ev.learned_fraction:g} times the best fixed "
        f"rule's on the same episodes. Self-play's `{SELF_PLAY}` row: its attackers against "
        "its own defenders. Curves: training success per rollout (the drill's reward, "
        "before any reward option). Settings: `ilpss/reference/settings.py`, recorded whole "
        "in every kept result.", ""]
    names = list(dict.fromkeys(j.name for j in jobs))
    for name in names:
        mine = [(j, r) for j, r in zip(jobs, results, strict=True) if j.name == name]
        path = figures / f"reference_{name}.png"
        try:
            link = path.resolve().relative_to(page.resolve().parent).as_posix()
        except ValueError:
            link = path.resolve().as_posix()
        setting = mine[0][0].setting
        if isinstance(setting, TransferSetting):
            _transfer_figure(mine, setting.window, path)
            lines += _transfer(mine, setting, link)
            continue
        by_team: dict[str, list] = {}
        for j, r in mine:
            by_team.setdefault(j.team or SELF_PLAY, []).append(r["curve"])
        _figure(name, by_team, path)
        lines += _section(name, [j for j, _ in mine], [r for _, r in mine], rules, tile, ev, link)
    return "\n".join(lines) + "\n"
