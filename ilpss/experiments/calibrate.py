"""Calibration of the drill: every team against every fixed holder rule.

    soccer-drill-calibrate [--teams ID ...] [--episodes 500] [--out results/calibration]
                           [--no-gifs] [--sampled 20] [--sampled-episodes 100] [--workers 2]
                           [--drills 256]

For each team (by default the paper's four and ``chasers``; ``--teams`` names any
installed ones, e.g. a plugin's beside ours): success rate (95% Wilson interval),
mean reward (95% t interval) and the outcomes over seeded episodes of each fixed
holder rule of :mod:`soccer_drill.policies`; the three criteria the drill is tuned
for, with their measured figures; optionally the same for members of the parametric
family drawn by protocol C's sampler; and a small GIF of each team.
Episode ``i`` of every cell uses seed ``i``, so cells are paired and the run is
reproducible. The episodes of a cell run ``--drills`` at a time in the batched drill
(the drill's ``play_episodes``, :data:`~ilpss.experiments.drill_facts.PLAY_EPISODES`;
``--drills 1`` plays them one by one in the holder environment, the reference the batched
drill agrees with in distribution). Every
team's cells, every family member's and each team's GIF (made as soon as that team's
cells are in) are jobs of one pool of ``--workers`` processes.

The page is written to ``<out>/opponents.md`` and the GIFs to ``<out>/gifs/``; the
default folder is ``results/calibration``, never ``docs/``. This project's
``docs/opponents.md`` is regenerated with ``--episodes 500 --sampled 20 --out docs``.

The drill is reached as the rest of :mod:`ilpss` reaches it: the holder environment through
Gymnasium, the rest by the names of :mod:`ilpss.experiments.drill_facts`; the intervals are
:mod:`ilpss.metrics`'.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import time
from collections import Counter
from collections.abc import Iterator, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np

from ilpss.experiments import drill_facts
from ilpss.experiments.drill_facts import ENV_ID, PAPER_TEAMS, drill_exception, drill_object
from ilpss.experiments.registry import SAMPLERS
from ilpss.metrics import t_interval, wilson_interval
from soccer_drill.constraints import Integer, ListOf, OneOf, check
from soccer_drill.files import atomic_write_text, check_output_file

TEAMS = (*PAPER_TEAMS, "chasers")
"""Teams in the main table by default, in the paper's order, then ``chasers``."""
DEFAULT_OUT = "results/calibration"
"""Where the command writes unless told otherwise (``results/`` is not committed)."""

GIF_FPS = 8
"""GIF frame rate: 0.125 s per 0.1 s cycle, slightly slowed down, and small files."""
DEFAULT_DRILLS = 256
"""Episodes of a cell played at once in the batched drill."""
_GIF_SEARCH = 40  # seeds tried to find an episode the team's best rule wins
_OUTCOMES = ("success", "interception", "out", "timeout")


@dataclass(frozen=True)
class Cell:
    """One team against one rule."""

    team: str
    rule: str
    successes: int
    episodes: int
    mean_reward: float
    reward_low: float
    reward_high: float
    outcomes: Mapping[str, int] = field(default_factory=dict)

    @property
    def success_rate(self) -> float:
        """Share of successful episodes."""
        return self.successes / self.episodes

    @property
    def success_interval(self) -> tuple[float, float]:
        """95% Wilson score interval of the success rate."""
        return wilson_interval(self.successes, self.episodes)


def holder_rules() -> dict[str, Any]:
    """The drill's fixed holder rules, by name (:data:`~ilpss.experiments.drill_facts.HOLDER_RULES`)."""
    return drill_object(drill_facts.HOLDER_RULES)


def sample_opponents(n: int, seed: int) -> list[dict[str, Any]]:
    """``n`` members of the parametric family (protocol C's sampler)."""
    return SAMPLERS.get(drill_facts.SAMPLER)(n, seed)


def spec_label(params: Mapping[str, Any]) -> str:
    """A family member's short label (:data:`~ilpss.experiments.drill_facts.SAMPLE_LABEL`)."""
    return drill_object(drill_facts.SAMPLE_LABEL)(params)


def evaluate(
    team: str,
    rule: str,
    episodes: int,
    first_seed: int = 0,
    params: Mapping[str, Any] | None = None,
    label: str | None = None,
    drills: int = DEFAULT_DRILLS,
) -> Cell:
    """Play ``episodes`` seeded episodes of ``rule`` against ``team`` (with ``params``),
    ``drills`` at a time in the batched drill (1: one by one in ``HolderEnv``)."""
    return evaluate_rules(team, [rule], episodes, first_seed, params, label, drills)[0]


def evaluate_rules(
    team: str,
    rules: Sequence[str],
    episodes: int,
    first_seed: int = 0,
    params: Mapping[str, Any] | None = None,
    label: str | None = None,
    drills: int = DEFAULT_DRILLS,
) -> list[Cell]:
    """The cells of every rule of ``rules`` against ``team``: seeds ``first_seed`` to
    ``first_seed + episodes - 1`` for each. With ``drills > 1`` every rule's episodes
    share one batch of ``drills`` drills (the drill's ``play_episodes``, a rule per
    episode), so the batch stays full until the last few episodes of all the rules, not
    of each; with 1, one by one in the holder environment. Arguments out of range, and
    rules the drill does not have, are refused naming them (``ValueError``)."""
    known = holder_rules()
    check("evaluate_rules rules", rules, ListOf(OneOf(tuple(known)), min_len=1))
    check("evaluate_rules episodes", episodes, Integer(1))
    check("evaluate_rules first_seed", first_seed, Integer(0, 2**32 - 1))
    check("evaluate_rules drills", drills, Integer(1))
    seeds = list(range(first_seed, first_seed + episodes))
    if drills > 1:
        venv = gymnasium.make_vec(ENV_ID, num_envs=min(drills, episodes * len(rules)),
                                  vectorization_mode="vector_entry_point", opponent=team,
                                  opponent_params=params)
        policies = [known[r] for r in rules for _ in seeds]
        played = drill_object(drill_facts.PLAY_EPISODES)(venv, policies, seeds * len(rules))
        return [
            _cell(label or team, rule, played[k * episodes:(k + 1) * episodes])
            for k, rule in enumerate(rules)
        ]
    env = gymnasium.make(ENV_ID, opponent=team, opponent_params=params)
    cells = []
    for rule in rules:
        policy = known[rule]
        rng = np.random.default_rng(first_seed)
        played = []
        for seed in seeds:
            obs, info = env.reset(seed=seed)
            done, total = False, 0.0
            while not done:
                obs, reward, term, trunc, info = env.step(policy(obs, rng))
                total += reward
                done = term or trunc
            played.append((total, info["outcome"]))
        cells.append(_cell(label or team, rule, played))
    env.close()
    return cells


def _cell(team: str, rule: str, played: Sequence[tuple[float, str]]) -> Cell:
    rewards = np.array([total for total, _ in played], dtype=float)
    outcomes = Counter(outcome for _, outcome in played)
    episodes = len(rewards)
    mean, low, high = (float(x) for x in t_interval(rewards)) if episodes > 1 else (
        float(rewards.mean()), float("nan"), float("nan"))
    return Cell(
        team, rule, outcomes["success"], episodes, mean, low, high,
        {k: outcomes[k] for k in _OUTCOMES},
    )


def _evaluate(args: tuple) -> list[Cell]:
    return evaluate_rules(*args)


def calibrate(
    episodes: int,
    teams: Sequence[str] = TEAMS,
    workers: int = 2,
    rules: Sequence[str] | None = None,
    drills: int = DEFAULT_DRILLS,
) -> dict[tuple[str, str], Cell]:
    """Every (team, rule) cell, in ``workers`` processes (1: in this process)."""
    rules = list(rules or holder_rules())
    return _run([(t, rules, episodes, 0, None, None, drills) for t in teams], workers)


def calibrate_family(
    n: int,
    seed: int,
    episodes: int,
    workers: int = 2,
    rules: Sequence[str] | None = None,
    drills: int = DEFAULT_DRILLS,
) -> tuple[dict[tuple[str, str], Cell], dict[str, dict[str, Any]]]:
    """Cells for ``n`` members of the parametric family, labelled ``p00``, ``p01``, ..."""
    rules = list(rules or holder_rules())
    members = {f"p{i:02d}": params for i, params in enumerate(sample_opponents(n, seed))}
    jobs = [("parametric", rules, episodes, 0, params, label, drills)
            for label, params in members.items()]
    return _run(jobs, workers), members


def calibrate_all(
    episodes: int,
    teams: Sequence[str] = TEAMS,
    sampled: int = 0,
    sampled_episodes: int = 100,
    workers: int = 2,
    drills: int = DEFAULT_DRILLS,
    gif_dir: str | os.PathLike[str] | None = None,
) -> tuple[
    dict[tuple[str, str], Cell],
    tuple[dict[tuple[str, str], Cell], dict[str, dict[str, Any]]] | None,
    dict[str, tuple[str, int, str]],
]:
    """What ``soccer-drill-calibrate`` computes, in one pool of ``workers`` processes.

    The cells of every rule against each of ``teams`` (as :func:`calibrate`), of
    ``sampled`` members of the parametric family (as :func:`calibrate_family`, seed 0;
    none if 0) and, with ``gif_dir``, each team's GIF (:func:`write_team_gif` of its
    best rule, ``gif_dir/<team>.gif``), started as soon as that team's cells are in. The
    jobs share the pool, so no worker idles while another finishes its share of one
    part (the teams' cells, the family's, the GIFs). Returns the teams' cells, the
    family's ``(cells, members)`` (or ``None``) and per team ``(best rule, seed,
    outcome)`` of its GIF.
    """
    rules = list(holder_rules())
    members = {f"p{i:02d}": params for i, params in enumerate(sample_opponents(sampled, 0))}
    team_jobs = [(t, rules, episodes, 0, None, None, drills) for t in teams]
    family_jobs = [("parametric", rules, sampled_episodes, 0, params, label, drills)
                   for label, params in members.items()]
    gifs: dict[str, tuple[str, int, str]] = {}

    def best_of(cells: list[Cell]) -> str:
        return best_rules({(c.team, c.rule): c for c in cells})[cells[0].team]

    if workers <= 1:
        team_done = [_evaluate(job) for job in team_jobs]
        family_done = [_evaluate(job) for job in family_jobs]
        if gif_dir is not None:
            for team, cells in zip(teams, team_done, strict=True):
                rule = best_of(cells)
                gifs[team] = (rule, *write_team_gif(team, rule, Path(gif_dir) / f"{team}.gif"))
    else:
        with ProcessPoolExecutor(workers) as pool, _cancelled_on_error(pool):
            team_futures = {pool.submit(_evaluate, job): job[0] for job in team_jobs}
            family_futures = [pool.submit(_evaluate, job) for job in family_jobs]
            gif_futures = {}
            for future in as_completed(team_futures):
                team = team_futures[future]
                if gif_dir is not None:
                    rule = best_of(future.result())
                    gif_futures[team] = (rule, pool.submit(
                        write_team_gif, team, rule, Path(gif_dir) / f"{team}.gif"))
            team_done = [f.result() for f in team_futures]
            family_done = [f.result() for f in family_futures]
            gifs = {t: (rule, *future.result()) for t, (rule, future) in gif_futures.items()}
    cells = {(c.team, c.rule): c for done in team_done for c in done}
    family = (
        ({(c.team, c.rule): c for done in family_done for c in done}, members) if sampled else None
    )
    return cells, family, gifs


@contextlib.contextmanager
def _cancelled_on_error(pool: ProcessPoolExecutor) -> Iterator[None]:
    """On an error, the jobs not started yet are dropped rather than run to no purpose."""
    try:
        yield
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        raise


def _run(jobs: list[tuple], workers: int) -> dict[tuple[str, str], Cell]:
    if workers <= 1:
        done = [_evaluate(job) for job in jobs]
    else:
        with ProcessPoolExecutor(workers) as pool:
            done = list(pool.map(_evaluate, jobs))
    return {(c.team, c.rule): c for cells in done for c in cells}


def _teams_and_rules(cells: Mapping[tuple[str, str], Cell]) -> tuple[list[str], list[str]]:
    teams = list(dict.fromkeys(t for t, _ in cells))
    rules = list(dict.fromkeys(r for _, r in cells))
    return teams, rules


def best_rules(cells: Mapping[tuple[str, str], Cell]) -> dict[str, str]:
    """The rule with the highest mean reward against each team (ties: the first rule)."""
    teams, rules = _teams_and_rules(cells)
    return {t: max(rules, key=lambda r: cells[(t, r)].mean_reward) for t in teams}


def criteria_teams(teams: Sequence[str]) -> list[str]:
    """The teams the criteria are judged on: ``teams``, less ``chasers`` beside
    ``interceptors_press`` (it re-implements that team as a check, so it would count twice)."""
    teams = list(teams)
    if "chasers" in teams and "interceptors_press" in teams:
        teams.remove("chasers")
    return teams


def _team_list(teams: Sequence[str]) -> str:
    if len(teams) == 1:
        return teams[0]
    return f"each of the {len(teams)} teams ({', '.join(teams)})"


def _all(n: int) -> str:
    return "both" if n == 2 else f"all {n}"


def criteria(
    cells: Mapping[tuple[str, str], Cell], teams: Sequence[str] = PAPER_TEAMS
) -> list[str]:
    """The three calibration criteria over ``teams``, each with its figures and verdict.

    The wording names the teams judged; the third criterion (the best rule differs
    between teams) needs at least two.
    """
    teams = list(teams)
    if not teams:
        raise ValueError("criteria need at least one team")
    _, all_rules = _teams_and_rules(cells)
    rules = [r for r in all_rules if r != "random"]
    if "random" not in all_rules or not rules:
        raise ValueError("criteria need the 'random' rule and at least one fixed rule")
    rate = {(t, r): cells[(t, r)].success_rate for t in teams for r in all_rules}
    against = _team_list(teams)
    # 1. Random play seldom succeeds.
    worst_random = max(teams, key=lambda t: rate[(t, "random")])
    ok1 = all(rate[(t, "random")] < 0.25 for t in teams)
    # 2. Some fixed rule succeeds in at least a third of the episodes against each team.
    top = {t: max(rules, key=lambda r: rate[(t, r)]) for t in teams}
    ok2 = all(rate[(t, top[t])] >= 1 / 3 for t in teams)
    robust = max(rules, key=lambda r: min(rate[(t, r)] for t in teams))
    robust_low = min(rate[(t, robust)] for t in teams)

    def verdict(ok: bool) -> str:
        """'met' or 'NOT met'."""
        return "**met**" if ok else "**NOT met**"

    second = (
        f"2. Some fixed rule succeeds in at least a third of episodes against {against}: "
        "the most successful rule per team is "
        + ", ".join(f"{t} {top[t]} {rate[(t, top[t])]:.1%}" for t in teams)
        + f" -> {verdict(ok2)}."
    )
    if len(teams) > 1:
        second += (
            f" A single rule does so against {_all(len(teams))}: {robust} "
            f"(lowest {robust_low:.1%}) -> {'yes' if robust_low >= 1 / 3 else 'no'}."
        )
    lines = [
        f"1. The random holder succeeds in less than a quarter of episodes against {against}: "
        + ", ".join(f"{t} {rate[(t, 'random')]:.1%}" for t in teams)
        + f" (highest: {worst_random}, Wilson upper bound "
        f"{cells[(worst_random, 'random')].success_interval[1]:.1%}) -> {verdict(ok1)}.",
        second,
    ]
    if len(teams) < 2:
        lines.append(
            "3. The ranking of the fixed rules differs between teams: not judged, it needs "
            "at least two teams."
        )
        return lines
    # 3. The rules rank differently against different teams; the best response differs.
    rankings = {t: tuple(sorted(rules, key=lambda r: -cells[(t, r)].mean_reward)) for t in teams}
    best = {t: rankings[t][0] for t in teams}
    ok3 = len(set(rankings.values())) > 1 and len(set(best.values())) > 1
    lines.append(
        f"3. The ranking of the fixed rules (by mean reward) is not the same against "
        f"{_all(len(teams))} teams: {len(set(rankings.values()))} distinct rankings, and the best "
        "rule is "
        + ", ".join(f"{best[t]} against {t}" for t in teams)
        + f" ({len(set(best.values()))} distinct best responses) -> {verdict(ok3)}."
    )
    return lines


def _first_line(obj: object) -> str:
    doc = (getattr(obj, "__doc__", None) or "").strip()
    return doc.splitlines()[0] if doc else ""


def _matrix(
    cells: Mapping[tuple[str, str], Cell],
    teams: Sequence[str],
    labels: Mapping[str, str] | None = None,
) -> list[str]:
    _, rules = _teams_and_rules(cells)
    labels = labels or {}
    best = best_rules(cells)
    lines = [
        "| team | " + " | ".join(rules) + " | best rule |",
        "|---|" + "---:|" * len(rules) + "---|",
    ]
    for t in teams:
        row = []
        for r in rules:
            text = f"{cells[(t, r)].success_rate:.0%}"
            row.append(f"**{text}**" if r == best[t] else text)
        name = f"{t} ({labels[t]})" if t in labels else t
        lines.append(f"| {name} | " + " | ".join(row) + f" | {best[t]} |")
    return lines


def write_markdown(
    cells: Mapping[tuple[str, str], Cell],
    episodes: int,
    path: str | os.PathLike[str],
    gifs: Mapping[str, tuple[str, str, int, str]] | Mapping[str, str],
    family: tuple[Mapping[tuple[str, str], Cell], Mapping[str, Mapping[str, Any]]] | None = None,
    command: str | None = None,
    timing: str | None = None,
) -> Path:
    """Write the calibration page (``opponents.md``): teams, rules, criteria, tables, GIFs.

    ``gifs`` maps a team to its GIF path relative to ``path`` (or to a tuple
    ``(relative path, rule, seed, outcome)``).
    """
    teams, rules = _teams_and_rules(cells)
    command = command or f"soccer-drill-calibrate --episodes {episodes}"
    lines = [
        *_page_head(command, episodes, timing),
        *_teams_section(teams),
        *_rules_section(rules),
        *_criteria_section(cells, teams),
        *_success_sections(cells, teams, rules),
        *(_family_section(*family) if family is not None else []),
        *(_gif_section(gifs, teams) if gifs else []),
    ]
    return atomic_write_text(path, "\n".join(lines).rstrip() + "\n")


def _page_head(command: str, episodes: int, timing: str | None) -> list[str]:
    """The title, the command that made the page and how its cells are played."""
    took = f" {timing}" if timing else ""
    return [
        "# Opponent teams and the calibrated drill",
        "",
        "Generated by",
        "",
        "```bash",
        command,
        "```",
        "",
        f"on the holder environment with its defaults (`HolderEnv(opponent=team)`).{took} "
        f"Every cell plays episodes with seeds 0..{episodes - 1}, so all rules meet the same "
        "starting positions. Success rate with a 95% Wilson interval; mean reward with a 95% "
        "t interval; outcomes are counts of success / interception / out / timeout.",
    ]


def _teams_section(teams: Sequence[str]) -> list[str]:
    """The teams, one row each, and how `chasers` relates to `interceptors_press`."""
    lines = [
        "",
        "## The teams",
        "",
        "The paper's teams are settings of `opponents.parametric.ParametricTeam` and "
        "`chasers` is a minimal stand-alone team; each team's class docstring gives its full "
        "behaviour and settings. List the installed teams with `soccer-drill-teams`.",
        "",
        "| id | description |",
        "|---|---|",
        *[f"| `{t}` | {drill_object(drill_facts.TEAM_DESCRIPTION)(t)} |" for t in teams],
    ]
    if "chasers" in teams and "interceptors_press" in teams:
        lines += [
            "",
            "`chasers` is a minimal stand-alone implementation of the behaviour of "
            "`interceptors_press`; their rows agree exactly, a check of the family against "
            "independent code.",
        ]
    return lines


def _rules_section(rules: Sequence[str]) -> list[str]:
    """The fixed holder rules, one row each."""
    return [
        "",
        "## The fixed holder rules",
        "",
        "From `soccer_drill.policies`; each reads only the holder's 9 features.",
        "",
        "| rule | what it does |",
        "|---|---|",
        *[f"| `{r}` | {_first_line(holder_rules()[r])} |" for r in rules],
    ]


def _criteria_section(cells: Mapping[tuple[str, str], Cell], teams: list[str]) -> list[str]:
    """The criteria of a learnable drill, judged on the teams they apply to."""
    judged = criteria_teams(teams)
    note = (
        ["", "`chasers` is left out of the criteria: it re-implements `interceptors_press`."]
        if judged != teams else []
    )
    return ["", "## Criteria", "", *criteria(cells, judged), *note]


def _success_sections(cells: Mapping[tuple[str, str], Cell], teams: Sequence[str],
                      rules: Sequence[str]) -> list[str]:
    """The success-rate matrix and the full table of every cell."""
    lines = [
        "",
        "## Success rates",
        "",
        "Best rule (highest mean reward) in bold. Shielding (`HOLD`) cannot be tackled "
        "but does not advance: rules that shield whenever pressed (`keepaway`, `lane`) let "
        "the press run out the clock or pin the holder against a touchline, while rules "
        "that dribble until a defender is close and then pass succeed often. How close "
        "is close enough, and whether to shield when the way is blocked, differs from "
        "team to team (the last column).",
        "",
        *_matrix(cells, teams),
        "",
        "## Full table",
        "",
        "| team | rule | success rate [95% CI] | mean reward [95% CI] | outcomes s/i/o/t |",
        "|---|---|---|---|---|",
    ]
    for t in teams:
        for r in rules:
            c = cells[(t, r)]
            lo, hi = c.success_interval
            outs = "/".join(str(c.outcomes.get(k, 0)) for k in _OUTCOMES)
            lines.append(
                f"| {t} | {r} | {c.success_rate:.1%} [{lo:.1%}, {hi:.1%}] | "
                f"{c.mean_reward:+.3f} [{c.reward_low:+.3f}, {c.reward_high:+.3f}] | {outs} |"
            )
    return lines


def _family_section(fcells: Mapping[tuple[str, str], Cell],
                    members: Mapping[str, Mapping[str, Any]]) -> list[str]:
    """The parametric family's members: the best rule of each, and their parameters."""
    fteams, _ = _teams_and_rules(fcells)
    n_eps = next(iter(fcells.values())).episodes
    best = best_rules(fcells)
    return [
        "",
        "## The parametric family",
        "",
        f"{len(members)} members drawn by `opponents.sample_opponents({len(members)}, "
        f"seed=0)`, {n_eps} episodes per cell, for a lifelong stream "
        "(`HolderEnv(opponent=\"parametric\", opponent_params=params)`). Labels: I = "
        "interceptor, G = guard, then the coordination of two interceptors and `-dN` "
        "for a reaction delay of N cycles. The best rule changes from member to member: "
        f"{len(set(best.values()))} distinct best rules among {len(members)} members.",
        "",
        *_matrix(fcells, fteams, {k: spec_label(v) for k, v in members.items()}),
        "",
        "<details><summary>parameters of each member</summary>",
        "",
        "| member | label | parameters |",
        "|---|---|---|",
        *[f"| {label} | {spec_label(params)} | `{dict(params)}` |"
          for label, params in members.items()],
        "",
        "</details>",
    ]


def _gif_section(gifs: Mapping[str, tuple[str, str, int, str]] | Mapping[str, str],
                 teams: Sequence[str]) -> list[str]:
    """A GIF of each team that has one, with the rule, seed and outcome it shows."""
    lines = ["", "## What the teams look like", ""]
    for t in teams:
        if t not in gifs:
            continue
        entry = gifs[t]
        if isinstance(entry, str):
            lines += [f"### {t}", "", f"![{t}]({entry})", ""]
        else:
            rel, rule, seed, outcome = entry
            lines += [
                f"### {t}",
                "",
                f"Holder rule `{rule}` (the best against this team), seed {seed}: {outcome}.",
                "",
                f"![{t}]({rel})",
                "",
            ]
    return lines


def write_team_gif(team: str, rule: str, path: str | os.PathLike[str]) -> tuple[int, str]:
    """A GIF of ``rule`` against ``team``: the first seed (from 1) that ``rule`` wins.

    Returns ``(seed, outcome)``. Frames are kept as rendered; at ``GIF_FPS`` and at
    most ``max_cycles`` frames, a GIF is well under 1 MB.
    """
    env = gymnasium.make(ENV_ID, opponent=team)
    policy = holder_rules()[rule]
    chosen = 1
    try:
        for seed in range(1, _GIF_SEARCH + 1):
            obs, info = env.reset(seed=seed)
            rng = np.random.default_rng(seed)
            done = False
            while not done:
                obs, _, term, trunc, info = env.step(policy(obs, rng))
                done = term or trunc
            if info["outcome"] == "success":
                chosen = seed
                break
    finally:
        env.close()
    info = drill_object(drill_facts.EPISODE_GIF)(path, team=team, seed=chosen, policy=policy,
                                                 fps=GIF_FPS)
    return chosen, info["outcome"]


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point ``soccer-drill-calibrate``."""
    parser = _parser()
    args = parser.parse_args(argv)
    teams, out_dir = _checked(parser, args)
    start = time.perf_counter()
    try:
        cells, family, made = calibrate_all(
            args.episodes, teams, args.sampled, args.sampled_episodes, args.workers, args.drills,
            None if args.no_gifs else out_dir / "gifs",
        )
    except drill_exception(drill_facts.TEAM_ERROR) as exc:  # a team that fails: its error in one line, not a traceback
        print(f"soccer-drill-calibrate: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:  # Ctrl-C: one line and the shell's status for SIGINT
        kept = ("" if args.no_gifs else
                f"the GIFs already written in {out_dir / 'gifs'} are kept; ")
        print(f"soccer-drill-calibrate: stopped by Ctrl-C (SIGINT); {kept}"
              f"{out_dir / 'opponents.md'} is not written", file=sys.stderr)
        return 130
    gifs = {team: (f"gifs/{team}.gif", rule, seed, outcome)
            for team, (rule, seed, outcome) in made.items()}
    seconds = time.perf_counter() - start
    path = write_markdown(
        cells, args.episodes, out_dir / "opponents.md", gifs, family,
        _command_line(args, teams), _timing(args, seconds)
    )
    for line in criteria(cells, criteria_teams(teams)):
        print(line)
    print(f"wrote {path} in {seconds:.0f} s")
    return 0


def _parser() -> argparse.ArgumentParser:
    """The arguments of ``soccer-drill-calibrate``."""
    parser = argparse.ArgumentParser(
        prog="soccer-drill-calibrate", description=__doc__.splitlines()[0]
    )
    parser.add_argument(
        "--teams", nargs="+", default=list(TEAMS), metavar="ID",
        help=f"team ids to calibrate (default: {' '.join(TEAMS)})",
    )
    parser.add_argument("--episodes", type=int, default=500,
                        help="episodes per cell, at least 2 (default %(default)s)")
    parser.add_argument("--workers", type=int, default=2,
                        help="worker processes (default %(default)s; 1: in this process)")
    parser.add_argument(
        "--out", default=DEFAULT_OUT,
        help=f"folder for opponents.md and gifs/ (default: {DEFAULT_OUT})",
    )
    parser.add_argument("--no-gifs", action="store_true", help="write no GIFs")
    parser.add_argument(
        "--sampled", type=int, default=0,
        help="also tabulate this many members of the parametric family (seed 0; default "
        "%(default)s: none)",
    )
    parser.add_argument("--sampled-episodes", type=int, default=100,
                        help="episodes per family cell, at least 2 (default %(default)s)")
    parser.add_argument(
        "--drills", type=int, default=DEFAULT_DRILLS,
        help=f"episodes of a cell played at once in the batched drill (default {DEFAULT_DRILLS}; "
        "1: one by one in HolderEnv)",
    )
    return parser


def _checked(parser: argparse.ArgumentParser, args: argparse.Namespace) -> tuple[list[str], Path]:
    """The teams (without repeats) and the output folder, every argument checked and every
    file the command will write checked before the episodes (``parser.error`` otherwise)."""
    if args.episodes < 2 or (args.sampled and args.sampled_episodes < 2):
        parser.error("--episodes and --sampled-episodes must be at least 2")
    if args.sampled < 0:
        parser.error("--sampled must be >= 0")
    if args.drills < 1:
        parser.error("--drills must be >= 1")
    if args.workers < 1:
        parser.error(f"--workers must be >= 1 (1: in this process), got {args.workers}")
    known = drill_object(drill_facts.TEAM_IDS)()
    unknown = [t for t in args.teams if t not in known]
    if unknown:
        parser.error(f"unknown team(s) {unknown}; installed teams: {known}")
    teams = list(dict.fromkeys(args.teams))
    out_dir = Path(args.out)
    if not args.out or out_dir.is_file():
        parser.error(f"--out must name a folder (opponents.md and gifs/ go in it), got {args.out!r}")
    try:  # every file it will write, before the episodes rather than after them
        for path in [out_dir / "opponents.md"] + (
                [] if args.no_gifs else [out_dir / "gifs" / f"{t}.gif" for t in teams]):
            check_output_file(path)
    except ValueError as exc:
        parser.error(f"--out {args.out}: {exc}")
    return teams, out_dir


def _command_line(args: argparse.Namespace, teams: list[str]) -> str:
    """The command that makes the same page, for the page's head."""
    command = "soccer-drill-calibrate"
    if teams != list(TEAMS):
        command += " --teams " + " ".join(teams)
    command += f" --episodes {args.episodes}"
    if args.sampled:
        command += f" --sampled {args.sampled} --sampled-episodes {args.sampled_episodes}"
    if args.no_gifs:
        command += " --no-gifs"
    if args.drills != DEFAULT_DRILLS:
        command += f" --drills {args.drills}"
    command += f" --out {args.out}"
    return command


def _timing(args: argparse.Namespace, seconds: float) -> str:
    """How long the calibration took, and how its episodes ran."""
    timing = f"It took {seconds / 60:.1f} min with {args.workers} worker process(es)."
    if args.drills > 1:
        timing += (
            f" Each team's episodes (every rule's) ran {args.drills} at a time in the batched "
            "drill (`soccer_drill.vector.holder.play_episodes`), which agrees with `HolderEnv` in "
            "distribution (`python -m ilpss.experiments.agreement`)."
        )
    return timing


if __name__ == "__main__":
    raise SystemExit(main())
