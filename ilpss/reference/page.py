"""The results page of the reference command, and the per-seed numbers it is made from.

The command turns its kept results into a *summary* (:func:`summarise`): every training
seed's rewards on the held-out episodes, the best fixed rule's on the same episodes,
budgets and wall times, as plain JSON. The page's tables are a function of that summary
alone (:func:`tables`), so that the summary, saved compressed beside the page
(:func:`save_summary`), recomputes them (:func:`load_summary`; the test
``tests/test_reference_page.py`` checks the shipped page against it). The figures are
drawn from the learning curves, which the summary does not hold.

Statistics (``ilpss.metrics``):

- *learned*: a seed whose greedy success is at least ``learned_fraction`` (0.9) times
  the best fixed rule's on the same episodes; outcomes are bimodal (a seed learns or it
  does not), so the counts are the summary, with the seeds' median and range.
- against the rule, **paired by episode**: on each of the evaluation episodes, the
  seeds' mean success (and reward) minus the rule's, with a 95% t interval over the
  episodes (the episode is the unit: the same starts for the learner and the rule),
  unadjusted; beside it the success difference's two-sided t-test p, Holm-adjusted over
  every such comparison on the page (each setting and team against its rule), the one
  figure that says "ahead of the rule" or "behind it" for the page as a whole.
- the defenders: the best scripted attack's success against them (the highest over the
  attacks, per seed), beside what the best fixed rule scores against the paper's teams.
- self-play: its attackers against the teams and its defenders against the attacks,
  beside the same networks untrained, seed by seed; and the cross-play table of its
  checkpoints (the attackers' success, mean over seeds).
- the transfer row: ``ilpss.metrics``' jumpstart, total reward and final performance per
  seed, paired by seed, with t intervals over seeds.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ilpss._io import load_gzip_record, save_figure, save_gzip_record
from ilpss.metrics import (
    asymptotic_performance,
    holm,
    jumpstart,
    t_interval,
    t_test_pvalue,
    total_reward,
    wilson_interval,
)
from ilpss.reference.jobs import SELF_PLAY, Job
from ilpss.reference.settings import (
    EvalSettings,
    HolderSetting,
    MarlSetting,
    SelfPlaySetting,
    TransferSetting,
)

__all__: list[str] = []

SUMMARY_SCHEMA = "ilpss.reference_summary/1"
MAX_SUMMARY_BYTES = 64 * 2**20
"""The largest summary file read (compressed)."""
DIGITS = 4
"""Rewards are kept to this many decimals in the summary (the drill pays -1, or 0.5 to 1
along the goal line)."""


def learning_md_rows(path: Path | None) -> dict[str, tuple[str, str]]:
    """The tile-coded learner's ``(mean reward, success)`` cells by team, read from the
    table of ``docs/learning.md`` (empty without a page)."""
    if path is None:
        return {}
    lines = path.read_text(encoding="utf-8").splitlines()
    out = {}
    for line in lines:
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 10 and cells[1].startswith(("+", "-")) and "%" in cells[2]:
            out[cells[0]] = (cells[1], cells[2])
    return out


# ----------------------------------------------------------------------------- summary
def _r(rewards: Sequence[float]) -> list[float]:
    return [round(float(x), DIGITS) for x in rewards]


def _section_type(setting: Any) -> str:
    if isinstance(setting, HolderSetting):
        return "holder"
    if isinstance(setting, TransferSetting):
        return "transfer"
    if isinstance(setting, SelfPlaySetting):
        return "self_play"
    return "defenders" if setting.side == "defenders" else "attackers"


def _minutes(curve: list[list[Any]]) -> float:
    return round(float(curve[-1][1]) / 60, 2)


def _run(job: Job, result: dict[str, Any], kind: str) -> dict[str, Any]:
    """One seed's numbers for the summary."""
    if kind == "transfer":
        w = job.setting.window
        ft, an = result["fine_tuned"]["curve"], result["anew"]["curve"]
        return {"seed": job.seed, "jumpstart": jumpstart(ft, an, w),
                "total": total_reward(ft) - total_reward(an),
                "final": asymptotic_performance(ft, w) - asymptotic_performance(an, w),
                "fine_tuned": _r(result["fine_tuned"]["eval"]), "anew": _r(result["anew"]["eval"]),
                "minutes": round(float(result["source_seconds"]) / 60, 2)}
    run = {"seed": job.seed, "team": job.team, "steps": int(result["curve"][-1][0]),
           "minutes": _minutes(result["curve"])}
    for part in ("eval", "stochastic", "untrained_eval", "defence", "untrained_defence"):
        if part in result:
            run[part] = {k: _r(v) for k, v in result[part].items()}
    for part in ("crossplay", "kept"):
        if part in result:
            run[part] = result[part]
    return run


def summarise(jobs: Sequence[Job], results: Sequence[dict[str, Any]],
              rules: Mapping[str, Mapping[str, list[float]]],
              tile: Mapping[str, tuple[str, str]], ev: EvalSettings, paper_teams: Sequence[str],
              ) -> dict[str, Any]:
    """Every number the page's tables need, as plain JSON: per setting its budget and
    every seed's evaluation rewards; per team the best fixed rule (by mean reward) and
    its rewards on the same episodes; the tile-coded learner's cells."""
    best = {}
    for team, by_rule in rules.items():
        name = max(by_rule, key=lambda n: (np.mean(by_rule[n]), n))
        best[team] = {"rule": name, "rewards": _r(by_rule[name])}
    sections = []
    for name in dict.fromkeys(j.name for j in jobs):
        mine = [(j, r) for j, r in zip(jobs, results, strict=True) if j.name == name]
        setting = mine[0][0].setting
        kind = _section_type(setting)
        section = {"name": name, "type": kind, "runs": [_run(j, r, kind) for j, r in mine]}
        if kind == "transfer":
            section.update(sources=list(mine[0][0].teams), target=mine[0][0].team,
                           source_steps=setting.source_steps,
                           target_episodes=setting.target_episodes, window=setting.window)
        else:
            section["budget"] = setting.ppo.steps
        if kind in ("defenders", "self_play"):
            section["attacks"] = list(mine[0][0].attacks)
        if kind == "self_play":
            section["crossplay_episodes"] = setting.crossplay_episodes
        sections.append(section)
    return {"evaluation": {"episodes": ev.episodes, "learned_fraction": ev.learned_fraction},
            "paper_teams": list(paper_teams), "rules": best,
            "tile": {t: list(v) for t, v in tile.items()}, "sections": sections}


def save_summary(summary: dict[str, Any], path: Path) -> None:
    """Write ``summary`` as a gzip-compressed JSON record (schema, SHA-256), atomically."""
    save_gzip_record({"schema": SUMMARY_SCHEMA, "summary": summary}, path)


def load_summary(path: Path) -> dict[str, Any]:
    """The summary saved by :func:`save_summary`; ``ValueError`` naming the file if it is
    not one (not gzip, not JSON, another schema, or changed after it was saved)."""
    return load_gzip_record(path, SUMMARY_SCHEMA, MAX_SUMMARY_BYTES, "summary")["summary"]


# ----------------------------------------------------------------------------- statistics
def _pct(x: float) -> str:
    return f"{x:.1%}"


def _ci(m: float, lo: float, hi: float, pct: bool = False, digits: int = 3) -> str:
    if pct:
        return f"{m:+.1%} [{lo:+.1%}, {hi:+.1%}]" if m < 0 or lo < 0 else \
            f"{m:.1%} [{lo:.1%}, {hi:.1%}]"
    return f"{m:+.{digits}f} [{lo:+.{digits}f}, {hi:+.{digits}f}]"


def _signed_pct(m: float, lo: float, hi: float) -> str:
    return f"{100 * m:+.1f} [{100 * lo:+.1f}, {100 * hi:+.1f}] points"


def _over(values: Sequence[float], pct: bool = False, digits: int = 3) -> str:
    """The mean of ``values`` with its 95% t interval (the mean alone for one value); a
    share's (``pct``) interval is clipped to 0-100%, the values it can take."""
    v = np.asarray(values, float)
    if v.size < 2 or np.ptp(v) == 0:
        return _pct(float(v.mean())) if pct else f"{float(v.mean()):+.{digits}f}"
    m, lo, hi = (float(x) for x in t_interval(v))
    if pct:
        lo, hi = max(lo, 0.0), min(hi, 1.0)
    return _ci(m, lo, hi, pct, digits)


def _success(rewards: Sequence[float]) -> float:
    return float((np.asarray(rewards) > 0).mean())


def _wilson(rewards: Sequence[float]) -> str:
    wins = int((np.asarray(rewards) > 0).sum())
    lo, hi = wilson_interval(wins, len(rewards))
    return f"{wins / len(rewards):.1%} [{lo:.1%}, {hi:.1%}]"


def _median_range(values: Sequence[float]) -> str:
    v = np.asarray(values, float)
    return f"{np.median(v):.1%} [{v.min():.1%}, {v.max():.1%}]"


def _episode_differences(learnt: np.ndarray, rule: np.ndarray, success: bool) -> np.ndarray:
    """The seeds' mean minus the rule on each episode (success or reward)."""
    if success:
        learnt, rule = (learnt > 0).astype(float), (rule > 0).astype(float)
    return learnt.mean(axis=0) - rule


def _paired(learnt: np.ndarray, rule: np.ndarray, success: bool) -> tuple[float, float, float]:
    """The seeds' mean minus the rule on each episode (success or reward), its mean and
    95% t interval over the episodes."""
    diff = _episode_differences(learnt, rule, success)
    if np.ptp(diff) == 0:
        return float(diff.mean()), float(diff.mean()), float(diff.mean())
    m, lo, hi = (float(x) for x in t_interval(diff))
    return m, lo, hi


def _counted(k: int, n: int) -> str:
    return f"**{k} of {n}**" if k == n else f"{k} of {n}"


# ----------------------------------------------------------------------------- tables
def _against_rules(summary: dict[str, Any]) -> dict[tuple[str, str], float]:
    """The Holm-adjusted p of every learner-against-its-rule success comparison on the
    page, by (section name, team): one family, the two-sided paired t-test over episodes."""
    keys, p_values = [], []
    for section in summary["sections"]:
        if section["type"] not in ("holder", "attackers"):
            continue
        for team in dict.fromkeys(r["team"] for r in section["runs"]):
            rule = summary["rules"].get(team)
            if rule is None:
                continue
            greedy = np.array([r["eval"][team] for r in section["runs"] if r["team"] == team],
                              float)
            diff = _episode_differences(greedy, np.asarray(rule["rewards"], float), True)
            keys.append((section["name"], team))
            p_values.append(float(t_test_pvalue(diff)))
    return dict(zip(keys, holm(np.array(p_values, float)) if keys else [], strict=True))


def _attackers_table(section: dict[str, Any], summary: dict[str, Any],
                     adjusted: Mapping[tuple[str, str], float]) -> list[str]:
    """Learned counts, greedy and stochastic success, and the paired differences against
    the best fixed rule (with the page's Holm-adjusted p), team by team."""
    frac = summary["evaluation"]["learned_fraction"]
    rules, tile = summary["rules"], summary["tile"]
    lines = [f"| team | seeds learned (greedy >= {frac:g} x rule) | greedy success, median "
             "[min, max] over seeds | greedy success, mean [95% t over seeds, within 0-100%] | stochastic "
             "success, mean | best fixed rule: success [Wilson] | success minus the rule, "
             "paired by episode [95% t, unadjusted] | the same: Holm-adjusted p (every "
             "comparison on the page) | reward minus the rule, paired by episode [95% t, "
             "unadjusted] | tile-coded SMDP: success |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    teams = list(dict.fromkeys(r["team"] for r in section["runs"]))
    for team in teams:
        runs = [r for r in section["runs"] if r["team"] == team]
        greedy = np.array([r["eval"][team] for r in runs], float)
        succ = [_success(g) for g in greedy]
        stoch = ([_success(r["stochastic"][team]) for r in runs]
                 if all("stochastic" in r for r in runs) else None)
        rule = rules.get(team)
        if rule is None:
            count = paired_s = holm_p = paired_r = rule_cell = "n/a"
        else:
            rr = np.asarray(rule["rewards"], float)
            target = frac * _success(rr)
            count = _counted(sum(s >= target for s in succ), len(runs))
            rule_cell = f"{rule['rule']}: {_wilson(rr)}"
            paired_s = _signed_pct(*_paired(greedy, rr, True))
            holm_p = f"{adjusted[section['name'], team]:.2g}"
            paired_r = _ci(*_paired(greedy, rr, False))
        lines.append(f"| {team} | {count} | {_median_range(succ)} | {_over(succ, True)} | "
                     f"{_over(stoch, True) if stoch else 'n/a'} | {rule_cell} | {paired_s} | "
                     f"{holm_p} | {paired_r} | {tile.get(team, ['n/a', 'n/a'])[1]} |")
    return lines


def _seed_table(section: dict[str, Any]) -> list[str]:
    lines = ["| team | seed | greedy success [Wilson] | greedy mean reward | stochastic success "
             "| steps | training minutes |", "|---|---|---|---|---|---|---|"]
    for r in section["runs"]:
        g = r["eval"][r["team"]]
        st = _wilson(r["stochastic"][r["team"]]) if "stochastic" in r else "n/a"
        lines.append(f"| {r['team']} | {r['seed']} | {_wilson(g)} | {np.mean(g):+.3f} | {st} | "
                     f"{r['steps']} | {r['minutes']:.1f} |")
    return lines


def _allowed(summary: dict[str, Any]) -> tuple[float, str]:
    """The least that the best fixed rule scores against a paper team, and that team."""
    found = [(_success(summary["rules"][t]["rewards"]), t) for t in summary["paper_teams"]
             if t in summary["rules"]]
    return min(found) if found else (math.nan, "n/a")


def _best_attack(defence: Mapping[str, list[float]]) -> tuple[float, str]:
    return max((_success(v), a) for a, v in defence.items())


def _defenders_table(section: dict[str, Any], summary: dict[str, Any], part: str = "eval",
                     untrained: str | None = None) -> list[str]:
    """Per seed: the best scripted attack's success against the learnt defenders (and
    against the same networks untrained, for self-play), and how many seeds hold it below
    what the paper's teams allow."""
    allowed, team = _allowed(summary)
    runs = section["runs"]
    best = [_best_attack(r[part]) for r in runs]
    held = sum(s < allowed for s, _ in best)
    attacks = section["attacks"]
    better = ""
    if untrained is not None:
        n_better = sum(s < _best_attack(r[untrained])[0] for r, (s, _) in zip(runs, best, strict=True))
        better = (" The trained defenders do better than the same networks untrained (the "
                  f"best attack scores less against them) in {_counted(n_better, len(runs))} "
                  "seeds.")
    lines = [f"The paper's teams allow the best fixed rule at least {_pct(allowed)} success "
             f"(against `{team}`); a seed *holds* when the best of the {len(attacks)} "
             f"scripted attacks scores less against its greedy defenders: "
             f"{_counted(held, len(runs))} seeds hold.{better}", "",
             "| attack | success against the defenders, mean [95% t over seeds, within 0-100%] | median [min, "
             "max] | stochastic defenders |" if part == "eval" and "stochastic" in runs[0] else
             "| attack | success against the defenders, mean [95% t over seeds, within 0-100%] | median [min, "
             "max] | untrained |",
             "|---|---|---|---|"]
    for attack in attacks:
        succ = [_success(r[part][attack]) for r in runs]
        if untrained is not None:
            other = _over([_success(r[untrained][attack]) for r in runs], True)
        elif "stochastic" in runs[0]:
            other = _over([_success(r["stochastic"][attack]) for r in runs], True)
        else:
            other = "n/a"
        lines.append(f"| {attack} | {_over(succ, True)} | {_median_range(succ)} | {other} |")
    lines += ["", "| seed | best attack against the defenders | its success | "
              + ("untrained: best attack's success | " if untrained else "")
              + "held |", "|---|---|---|" + ("---|" if untrained else "") + "---|"]
    for r, (s, a) in zip(runs, best, strict=True):
        cells = f"| {r['seed']} | {a} | {_pct(s)} | "
        if untrained:
            cells += f"{_pct(_best_attack(r[untrained])[0])} | "
        lines.append(cells + ("yes" if s < allowed else "no") + " |")
    return lines


def _self_play_tables(section: dict[str, Any], summary: dict[str, Any]) -> list[str]:
    runs = section["runs"]
    teams = [t for t in runs[0]["eval"] if t != SELF_PLAY]
    lines = ["Its attackers against the scripted teams (greedy), beside the same networks "
             "untrained; *better* counts the seeds whose trained attackers score more than "
             "their untrained ones.", "",
             "| team | trained: success, mean [95% t, within 0-100%] | untrained | better in | best fixed rule |",
             "|---|---|---|---|---|"]
    for team in [*teams, SELF_PLAY]:
        trained = [_success(r["eval"][team]) for r in runs]
        before = [_success(r["untrained_eval"][team]) for r in runs]
        better = sum(a > b for a, b in zip(trained, before, strict=True))
        rule = summary["rules"].get(team)
        label = "its own defenders" if team == SELF_PLAY else team
        lines.append(f"| {label} | {_over(trained, True)} | {_over(before, True)} | "
                     f"{_counted(better, len(runs))} seeds | "
                     f"{rule['rule'] + ': ' + _wilson(rule['rewards']) if rule else 'n/a'} |")
    lines += ["", "Its defenders against the scripted attacks (greedy), beside the same "
              "networks untrained:", ""]
    lines += _defenders_table(section, summary, "defence", "untrained_defence")
    lines += ["", *self_play_seed_table(section)]
    k = len(runs[0]["crossplay"])
    m = np.mean([np.asarray(r["crossplay"], float) for r in runs], axis=0)
    lines += ["", f"Cross-play: the attackers' success (mean over seeds) with the attackers "
              f"of checkpoint *i* (rows) against the defenders of checkpoint *j* (columns); "
              f"checkpoint 0 is untrained, {k - 1} the trained networks.", "",
              "| attackers \\ defenders | " + " | ".join(str(j) for j in range(k)) + " |",
              "|---|" + "---|" * k]
    n = section["crossplay_episodes"]
    for i in range(k):
        lines.append(f"| {i} | " + " | ".join(_pct(m[i, j] / n) for j in range(k)) + " |")
    return lines


def self_play_seed_table(section: dict[str, Any]) -> list[str]:
    """Self-play seed by seed: its attackers against the scripted teams and its defenders
    against the scripted attacks, each beside the same networks untrained (greedy)."""
    kept = "kept" in section["runs"][0]
    lines = ["Seed by seed: the attackers' mean success over the scripted teams, the teams "
             "on which they score more than untrained, the best scripted attack's success "
             "against the defenders, and whether it is lower than against them untrained"
             + ("; the checkpoints kept as trained (attackers, defenders; the last is "
                f"{len(section['runs'][0]['crossplay']) - 1})." if kept else "."), "",
             "| seed | attackers: mean success, trained (untrained) | teams better | "
             "defenders: best attack's success, trained (untrained) | defenders better |"
             + (" checkpoints kept |" if kept else ""),
             "|---|---|---|---|---|" + ("---|" if kept else "")]
    for r in section["runs"]:
        teams = [t for t in r["eval"] if t != SELF_PLAY]
        trained = [_success(r["eval"][t]) for t in teams]
        before = [_success(r["untrained_eval"][t]) for t in teams]
        better = sum(a > b for a, b in zip(trained, before, strict=True))
        best, best_before = _best_attack(r["defence"])[0], _best_attack(r["untrained_defence"])[0]
        lines.append(f"| {r['seed']} | {_pct(float(np.mean(trained)))} "
                     f"({_pct(float(np.mean(before)))}) | {better} of {len(teams)} | "
                     f"{_pct(best)} ({_pct(best_before)}) | "
                     f"{'yes' if best < best_before else 'no'} |"
                     + (f" {r['kept'][0]}, {r['kept'][1]} |" if kept else ""))
    return lines


def _transfer_table(section: dict[str, Any]) -> list[str]:
    runs = section["runs"]
    w = section["window"]
    return [
        f"Sources {', '.join(f'`{t}`' for t in section['sources'])} in order "
        f"({section['source_steps']:,} decisions each), then the held-out `{section['target']}` "
        f"for {section['target_episodes']:,} episodes; fine-tuned from the sources' policy (and "
        "its observation statistics) against learning anew, paired by seed. Jumpstart: first "
        f"{w} episodes; final: last {w}; total: over the {section['target_episodes']:,} "
        f"episodes. {len(runs)} training seeds.", "",
        "| target | seeds | jumpstart [95% t] | total reward gain [95% t] | final gain [95% t] "
        "| greedy success, fine-tuned [95% t, within 0-100%] | greedy success, anew |",
        "|---|---|---|---|---|---|---|",
        f"| {section['target']} | {len(runs)} | {_over([r['jumpstart'] for r in runs])} | "
        f"{_over([r['total'] for r in runs], digits=1)} | {_over([r['final'] for r in runs])} | "
        f"{_over([_success(r['fine_tuned']) for r in runs], True)} | "
        f"{_over([_success(r['anew']) for r in runs], True)} |"]


def _budget_line(section: dict[str, Any]) -> str:
    runs = section["runs"]
    seeds = sorted({r["seed"] for r in runs})
    minutes = [r["minutes"] for r in runs]
    unit = "decisions" if section["type"] == "holder" else "environment steps"
    return (f"Budget: {section['budget']:,} {unit} per training seed; {len(seeds)} training "
            f"seeds ({seeds[0]} to {seeds[-1]}); training minutes per seed, median "
            f"{np.median(minutes):.1f} [{min(minutes):.1f}, {max(minutes):.1f}] on one core.")


def tables(summary: dict[str, Any]) -> dict[str, list[str]]:
    """Each section's tables, by setting name: a function of the summary alone."""
    out, adjusted = {}, _against_rules(summary)
    for section in summary["sections"]:
        kind = section["type"]
        if kind == "transfer":
            out[section["name"]] = _transfer_table(section)
            continue
        lines = [_budget_line(section), ""]
        if kind in ("holder", "attackers"):
            lines += [*_attackers_table(section, summary, adjusted), "", *_seed_table(section)]
        elif kind == "defenders":
            lines += _defenders_table(section, summary)
        else:
            lines += _self_play_tables(section, summary)
        out[section["name"]] = lines
    return out


# ----------------------------------------------------------------------------- figures
def _figure(name: str, by_team: Mapping[str, list[list[list[float]]]], path: Path) -> None:
    """Success rate per rollout against environment steps and wall time, a thin line per
    seed and the mean over seeds in bold, one colour per team."""
    fig = Figure(figsize=(11, 4))
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, 2, sharey=True)
    for k, (team, curves) in enumerate(by_team.items()):
        colour = f"C{k % 10}"
        for curve in curves:
            c = np.asarray(curve, float)
            axes[0].plot(c[:, 0], c[:, 3], color=colour, lw=0.5, alpha=0.4)
            axes[1].plot(c[:, 1] / 60, c[:, 3], color=colour, lw=0.5, alpha=0.4)
        n = min(len(c) for c in curves)
        rates = np.array([np.asarray(c, float)[:n, 3] for c in curves])
        seen = np.isfinite(rates).sum(axis=0)
        mean = np.where(seen > 0, np.nansum(rates, axis=0) / np.maximum(seen, 1), np.nan)
        steps = np.asarray(curves[0], float)[:n, 0]
        minutes = np.mean([np.asarray(c, float)[:n, 1] for c in curves], axis=0) / 60
        axes[0].plot(steps, mean, color=colour, lw=2, label=team)
        axes[1].plot(minutes, mean, color=colour, lw=2)
    axes[0].set(xlabel="environment steps", ylabel="training success rate (attackers)",
                ylim=(-0.02, 1.02), title=f"{name}: against steps")
    axes[1].set(xlabel="wall time (minutes, one core per seed)", title=f"{name}: against time")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)


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


# ----------------------------------------------------------------------------- page
_INTROS = {
    "holder": "The holder (SB3's learner on `soccer_drill/Holder-v0`, one decision per "
              "holder option) against each team.",
    "attackers": "The two attackers of the parallel drill, one shared policy, against each "
                 "scripted team; greedy and stochastic (sampled) evaluation.",
    "defenders": "The two defenders of the parallel drill, one shared policy, trained against "
                 "scripted attacks (the fixed holder rules playing both attackers).",
    "self_play": "Both sides learn together against a pool of their past checkpoints "
                 "(fictitious self-play).",
    "transfer": "",
}


def write_page(command: str, code: str, took: str, jobs: list[Job],
               results: list[dict[str, Any]], summary: dict[str, Any], figures: Path,
               page: Path) -> str:
    """The page's markdown (its tables from ``summary``), its figures saved into
    ``figures`` (linked relative to ``page``)."""
    ev = summary["evaluation"]
    lines = [
        "# Reference deep-RL results for the drill", "",
        f"Command: `{command}` ({took}).", "", code, "",
        f"Evaluation: each training seed's policy on {ev['episodes']} held-out episode seeds "
        "(the same for every seed, setting and fixed rule), greedy unless said. A seed "
        f"*learned* when its greedy success is at least {ev['learned_fraction']:g} times the "
        "best fixed rule's on the same episodes (the best rule by mean reward). Differences "
        "against the rule are paired by episode, their intervals unadjusted; the success "
        "differences' p-values are Holm-adjusted over every comparison with a rule on the "
        "page. Curves: training success per rollout (the "
        "drill's reward, before any reward option). Settings: `ilpss/reference/settings.py`, "
        "recorded whole in every kept result. The per-seed numbers behind every table are in "
        "the summary file beside this page (`load_summary`, `tables`).", ""]
    by_name = tables(summary)
    for name in dict.fromkeys(j.name for j in jobs):
        mine = [(j, r) for j, r in zip(jobs, results, strict=True) if j.name == name]
        path = figures / f"reference_{name}.png"
        try:
            link = path.resolve().relative_to(page.resolve().parent).as_posix()
        except ValueError:
            link = path.resolve().as_posix()
        setting = mine[0][0].setting
        kind = _section_type(setting)
        if isinstance(setting, TransferSetting):
            _transfer_figure(mine, setting.window, path)
        else:
            by_team: dict[str, list] = {}
            for j, r in mine:
                by_team.setdefault(j.team or SELF_PLAY, []).append(r["curve"])
            _figure(name, by_team, path)
        lines += [f"## `{name}`", "", _INTROS[kind] + _described(setting), "",
                  f"![{name}]({link})", "", *by_name[name], ""]
    return "\n".join(lines) + "\n"


OPPONENTS_DRAWN: dict[str, Callable[[SelfPlaySetting], str]] = {
    "pfsp": lambda s: (" Opponents drawn per drill by prioritised fictitious self-play "
                       f"(`opponents=\"pfsp\"`, floor {s.pfsp_floor:g}, decay "
                       f"{s.pfsp_decay:g})."),
    "uniform": lambda s: (" Opponents drawn per rollout: the current networks or a "
                          "checkpoint drawn uniformly (`opponents=\"uniform\"`)."),
}
"""What a self-play section says of how its opponents were drawn, per
``SelfPlaySetting.opponents``."""


def _described(setting: Any) -> str:
    if isinstance(setting, SelfPlaySetting):
        drawn = OPPONENTS_DRAWN[setting.opponents](setting)
        e = setting.exploiter_drills()
        if e:
            drawn += (f" A main exploiter per side in {e} of each half's "
                      f"{setting.ppo.n_envs // 2} drills (`exploiter_share="
                      f"{setting.exploiter_share:g}`), learning against the other side's "
                      "current networks, which may draw it.")
        return _described(setting.marl) + drawn
    if not isinstance(setting, MarlSetting):
        return ""
    critic = "MAPPO (critic on `state()`)" if setting.critic == "state" else \
        "IPPO (critic on the player's observation)"
    option = (f", reward option `shaping={setting.shaping:g}`" if setting.shaping
              else ", the drill's reward")
    ids = ", agent ids as input" if setting.agent_id else ""
    return (f" {critic}, `obs_type={setting.obs_type!r}`, mask as input: "
            f"{setting.mask_input}{ids}, value normalisation: {setting.value_norm}{option}.")


def check_summary_tables(summary: dict[str, Any], page_text: str) -> list[str]:
    """The lines of ``tables(summary)`` missing from ``page_text`` (none: the page's tables
    are the summary's)."""
    have = set(page_text.splitlines())
    return [line for lines in tables(summary).values() for line in lines
            if line and line not in have]

