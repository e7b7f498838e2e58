"""The pre-check of the region stream: fixed holder rules against its sources and compositions.

    python -m ilpss.experiments.region_check [--episodes 500] [--workers 2] [--out docs/regions.md]

For each pure source team, every fixed rule of the drill (``soccer_drill.policies``); for
each candidate composition (an ``opponents.regions.RegionTeam`` of two sources), every
fixed rule and the hand-composed rules ``opponents.regions.RegionRule``
``i|j`` (``i`` the best rule against the source played above the region's threshold,
``j`` the best against the source played below) and ``j|i``. Each cell plays the
episodes of seeds ``0..episodes-1``: success rate with a 95% Wilson interval, mean
reward with a 95% t interval. A composition is kept as a target when the paired
difference (same seeds) of ``i|j`` and the best single rule has a 95% t interval above
zero. For ``i|j`` the page also gives where its decisions fall (the share of episodes
deciding above, below, in both) and what each region's rule adds: ``i|j`` against
``i`` everywhere (only episodes that decide below can differ) and against ``j``
everywhere.

Episodes run in ``HolderEnv``, the reference drill, where an episode is a function of
its seed and the actions alone: so two rules that act alike until the holder first
decides below play the same episode until then (the page checks it). The cells are
shared among ``--workers`` processes. ``docs/regions.md`` is regenerated with
``--episodes 500 --out docs/regions.md``.

The drill and its region teams are reached by the names of
:mod:`ilpss.experiments.drill_facts` (the holder environment through Gymnasium); the
intervals are :mod:`ilpss.metrics`'.
"""

from __future__ import annotations

import argparse
import os
import time
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import gymnasium
import numpy as np

from ilpss.experiments import drill_facts
from ilpss.experiments.calibrate import holder_rules
from ilpss.experiments.drill_facts import ENV_ID, drill_object
from ilpss.metrics import t_interval as _t_interval
from ilpss.metrics import wilson_interval
from soccer_drill.files import atomic_write_text, check_output_file

HolderPolicy = Callable[[np.ndarray, np.random.Generator], int]
Region = drill_object(drill_facts.REGION)
RegionTeam = drill_object(drill_facts.REGION_TEAM)
RegionRule = drill_object(drill_facts.REGION_RULE)
SOURCES = drill_facts.REGION_SOURCES
NEAR = Region("dist_goal", 12.0)
"""Below: the holder is within 12 m of the goal line (as ``opponents.region_stream.NEAR``)."""
LEFT = Region("lateral", 0.0)
"""Below: the holder is in the left half (as ``opponents.region_stream.LEFT``)."""

OUTCOMES = ("success", "interception", "out", "timeout")


@dataclass(frozen=True)
class Candidate:
    """A composition to judge: the source played above the region and the one below.

    ``registered`` names a team id that must be this composition (checked); otherwise
    the composition is built as a :class:`RegionTeam` of the two sources. ``extra`` are
    further composed rules ``(above rule, below rule)`` to tabulate.
    """

    label: str
    above: str
    below: str
    region: Region
    registered: bool = False
    extra: tuple[tuple[str, str], ...] = ()

    def team(self) -> RegionTeam:
        """The composition as a team (the registered one, if it is registered)."""
        built = RegionTeam(self.above, self.below, self.region)
        if not self.registered:
            return built
        team = drill_object(drill_facts.MAKE_TEAM)(self.label)
        if not isinstance(team, RegionTeam) or team.params() != built.params():
            raise ValueError(f"team {self.label!r} is not the composition {built!r}")
        return team


CHECK_SOURCES: tuple[str, ...] = (*SOURCES, "goal_guards", "interceptors_cover",
                                  "interceptor_guard")
"""The pure teams: the stream's sources, and paper teams 2, 3 and 4, each composed far from
the line with ``contain_cover`` near it."""
CANDIDATES: tuple[Candidate, ...] = (
    Candidate("press_far_guard_near", "interceptors_press", "goal_guards", NEAR,
              extra=(("late_pass", "dribble"),)),
    Candidate("press_far_contain_near", "interceptors_press", "contain_cover", NEAR, True),
    Candidate("contain_far_press_near", "contain_cover", "interceptors_press", NEAR),
    Candidate("contain_left_press_right", "interceptors_press", "contain_cover", LEFT, True),
    Candidate("press_left_contain_right", "contain_cover", "interceptors_press", LEFT, True),
    # The sharp test's candidates: every episode starts far and nearly all reach near, so
    # a change of behaviour within the episode is needed. The other paper teams far from
    # the line, then the press at two more boundaries.
    Candidate("cover_far_contain_near", "interceptors_cover", "contain_cover", NEAR),
    Candidate("guard_far_contain_near", "interceptor_guard", "contain_cover", NEAR),
    Candidate("guards_far_contain_near", "goal_guards", "contain_cover", NEAR),
    Candidate("press_far_contain_near_9", "interceptors_press", "contain_cover",
              Region("dist_goal", 9.0), True),
    Candidate("press_far_contain_near_15", "interceptors_press", "contain_cover",
              Region("dist_goal", 15.0), True),
)
"""The compositions judged, in the page's order (the registered ones are the targets)."""


@dataclass(frozen=True)
class Play:
    """One team against one rule: per episode (seed order) its reward, outcome and
    decisions above and below the region it was counted for (zeros without one)."""

    team: str
    rule: str
    rewards: np.ndarray
    outcomes: tuple[str, ...]
    above: np.ndarray
    below: np.ndarray

    @property
    def episodes(self) -> int:
        """Episodes played."""
        return len(self.rewards)

    @property
    def successes(self) -> int:
        """Episodes ending in success."""
        return sum(o == "success" for o in self.outcomes)

    def success_text(self) -> str:
        """``71.2% [67.1%, 75.0%]``: the rate and its 95% Wilson interval."""
        lo, hi = wilson_interval(self.successes, self.episodes)
        return f"{self.successes / self.episodes:.1%} [{lo:.1%}, {hi:.1%}]"

    def reward_text(self) -> str:
        """``+0.412 [+0.330, +0.494]``: the mean reward and its 95% t interval."""
        return _mean_text(self.rewards)


def t_interval(values: np.ndarray) -> tuple[float, float, float]:
    """Mean and 95% Student t interval of ``values`` (the per-episode paired differences;
    the bounds NaN for fewer than two)."""
    if len(values) < 2:
        return float(np.mean(values)), float("nan"), float("nan")
    mean, low, high = _t_interval(values)
    return float(mean), float(low), float(high)


def _mean_text(values: np.ndarray) -> str:
    mean, lo, hi = t_interval(values)
    return f"{mean:+.3f} [{lo:+.3f}, {hi:+.3f}]"


@dataclass(frozen=True)
class EpisodeChoice:
    """One rule for the whole episode: ``above``'s or ``below``'s, by the region of the
    episode's first decision (what choosing one source policy per episode can do)."""

    above: str
    below: str
    region: Region

    @property
    def name(self) -> str:
        """``"<above>|<below> once"``."""
        return f"{self.above}|{self.below} once"

    def for_episode(self, first: np.ndarray) -> HolderPolicy:
        """The rule of the episode whose first observation is ``first``."""
        return holder_rules()[self.below if self.region.observed_below(first) else self.above]


def play(
    label: str, opponent: str | RegionTeam, rule: str | RegionRule | EpisodeChoice,
    episodes: int, region: Region | None = None,
) -> Play:
    """``rule`` against ``opponent`` in ``HolderEnv`` for seeds ``0..episodes-1``, the rule
    drawing from ``default_rng(seed)``; each episode's decisions are counted above and
    below ``region`` if one is given."""
    policy = holder_rules()[rule] if isinstance(rule, str) else rule
    env = gymnasium.make(ENV_ID, opponent=opponent)
    rewards, outcomes = np.zeros(episodes), []
    counts = np.zeros((episodes, 2), dtype=int)  # decisions above, below
    for seed in range(episodes):
        obs, info = env.reset(seed=seed)
        rng, done = np.random.default_rng(seed), False
        if isinstance(rule, EpisodeChoice):
            policy = rule.for_episode(obs)
        while not done:
            if region is not None:
                counts[seed, int(region.observed_below(obs))] += 1
            obs, reward, term, trunc, info = env.step(policy(obs, rng))
            rewards[seed] += reward
            done = term or trunc
        outcomes.append(info["outcome"])
    env.close()
    name = rule if isinstance(rule, str) else rule.name
    return Play(label, name, rewards, tuple(outcomes), counts[:, 0], counts[:, 1])


def _play(job: tuple) -> Play:
    return play(*job)


def _run(jobs: list[tuple], workers: int) -> list[Play]:
    if workers <= 1:
        return [_play(job) for job in jobs]
    with ProcessPoolExecutor(workers) as pool:
        return list(pool.map(_play, jobs))


def best_rule(plays: Mapping[str, Play]) -> str:
    """The rule of highest mean reward (ties: the first)."""
    return max(plays, key=lambda r: plays[r].rewards.mean())


@dataclass(frozen=True)
class Judged:
    """A candidate with its cells and the figures of the verdict."""

    candidate: Candidate
    singles: dict[str, Play]
    composed: dict[str, Play]
    above_rule: str
    below_rule: str
    once: Play | None = None
    """``i|j once``: one of the two rules per episode, by its first decision's region."""

    @property
    def composed_rule(self) -> str:
        """``i|j``: the best rule against each region's source, in its region."""
        return f"{self.above_rule}|{self.below_rule}"

    @property
    def composed_play(self) -> Play:
        """The cells of ``i|j`` (``i`` itself when both sources have the same best rule)."""
        return self.composed.get(self.composed_rule, self.singles[self.above_rule])

    @property
    def best_single(self) -> str:
        """The single rule of highest mean reward on the composition."""
        return best_rule(self.singles)

    def difference(self, other: Play) -> tuple[float, float, float]:
        """``i|j`` less ``other``, paired by seed: mean and 95% t interval."""
        return t_interval(self.composed_play.rewards - other.rewards)

    @property
    def kept(self) -> bool:
        """The composed rule beats the best single rule by an interval above zero."""
        return self.difference(self.singles[self.best_single])[1] > 0.0

    @property
    def within_episode(self) -> bool:
        """Kept, and one of its two rules per episode (by the region of the first decision)
        gets less than half of the composed rule's gain over the best single rule, and is
        beaten by it by an interval above zero: the gain needs a change of behaviour
        within the episode, not only the right source for the episode."""
        if not self.kept or self.once is None:
            return False
        best = self.singles[self.best_single].rewards.mean()
        gain = self.composed_play.rewards.mean() - best
        return (self.once.rewards.mean() - best < 0.5 * gain
                and self.difference(self.once)[1] > 0.0)

    @property
    def verdict(self) -> str:
        """``target, within episodes``, ``target`` or ``not a target``."""
        if self.within_episode:
            return "target, within episodes"
        return "target" if self.kept else "not a target"


def judge(
    episodes: int, workers: int = 2,
) -> tuple[dict[str, dict[str, Play]], list[Judged]]:
    """Every cell of the page: the sources' and each candidate's."""
    rules = list(holder_rules())
    source_plays = _run([(s, s, r, episodes) for s in CHECK_SOURCES for r in rules], workers)
    sources: dict[str, dict[str, Play]] = {s: {} for s in CHECK_SOURCES}
    for p in source_plays:
        sources[p.team][p.rule] = p
    best = {s: best_rule(plays) for s, plays in sources.items()}
    jobs, plan = [], []
    for c in CANDIDATES:
        built = c.team()  # a registered id is checked to be the composition it is said to be
        team = c.label if c.registered else built
        i, j = best[c.above], best[c.below]
        pairs = list(dict.fromkeys([(i, j), (j, i), *c.extra]))
        pairs = [(a, b) for a, b in pairs if a != b]
        cells: list[str | RegionRule | EpisodeChoice] = [
            *rules, *(RegionRule(a, b, c.region) for a, b in pairs),
            *([EpisodeChoice(i, j, c.region)] if i != j else []),
        ]
        jobs += [(c.label, team, rule, episodes, c.region) for rule in cells]
        plan.append((c, len(rules), len(pairs), i, j))
    plays = iter(_run(jobs, workers))
    judged = []
    for c, n_single, n_pairs, i, j in plan:
        singles = {p.rule: p for p in (next(plays) for _ in range(n_single))}
        composed = {p.rule: p for p in (next(plays) for _ in range(n_pairs))}
        judged.append(Judged(c, singles, composed, i, j, next(plays) if i != j else None))
    return sources, judged


# ---------------------------------------------------------------------- the page
def _side(region: Region) -> tuple[str, str]:
    if region.feature == "dist_goal":
        return (f"farther than {region.threshold:g} m from the goal line",
                f"within {region.threshold:g} m of it")
    if region.threshold == 0.0:
        return "the right half", "the left half"
    return f"right of x - size/2 = {region.threshold:g}", "left of it"


def _region_row(c: Candidate, status: str) -> str:
    r = c.region
    above, below = _side(r)
    return (f"| `{c.label}` | {status} | `{c.above}` {above} | `{c.below}` {below} | "
            f"{r.index} (`{r.feature}`) | `obs[{r.index}] <= {r.threshold:g}` |")


def _source_table(sources: Mapping[str, Mapping[str, Play]]) -> list[str]:
    lines = [
        "| rule | " + " | ".join(f"`{s}` success | `{s}` mean reward" for s in sources) + " |",
        "|---|" + "---:|---:|" * len(sources),
    ]
    best = {s: best_rule(plays) for s, plays in sources.items()}
    for rule in holder_rules():
        row = []
        for s, plays in sources.items():
            p = plays[rule]
            reward = p.reward_text()
            row += [p.success_text(), f"**{reward}**" if rule == best[s] else reward]
        lines.append(f"| `{rule}` | " + " | ".join(row) + " |")
    return lines


def _cell(name: str) -> str:
    """``name`` as code in a table cell (a composed rule's ``|`` escaped)."""
    escaped = name.replace("|", "\\|")
    return f"`{escaped}`"


def _share(mask: np.ndarray) -> str:
    return f"{mask.mean():.0%}"


def _candidate_section(j: Judged) -> list[str]:
    c = j.candidate
    composed = j.composed_play
    best_single = j.singles[j.best_single]
    lines = [
        f"### `{c.label}`",
        "",
        f"`{c.above}` above, `{c.below}` below; the best rule against `{c.above}` is "
        f"`{j.above_rule}`, against `{c.below}` `{j.below_rule}`, so the composed rule is "
        f"`{j.composed_rule}` (`RegionRule(\"{j.above_rule}\", \"{j.below_rule}\", "
        f"Region(\"{c.region.feature}\", {c.region.threshold:g}))`)"
        + (": the same rule in both regions, nothing to compose." if j.above_rule == j.below_rule
           else "."),
        "",
        "| rule | success [95% CI] | mean reward [95% CI] | outcomes s/i/o/t |",
        "|---|---|---|---|",
    ]
    once = {j.once.rule: j.once} if j.once is not None else {}
    for name, p in (*j.singles.items(), *j.composed.items(), *once.items()):
        counts = Counter(p.outcomes)
        outs = "/".join(str(counts.get(k, 0)) for k in OUTCOMES)
        reward = p.reward_text()
        if name in (j.best_single, j.composed_rule):
            reward = f"**{reward}**"
        lines.append(f"| {_cell(name)} | {p.success_text()} | {reward} | {outs} |")
    mean, lo, hi = j.difference(best_single)
    verdict = "**kept as a target**" if j.kept else "**not a target**"
    above, below = composed.above > 0, composed.below > 0
    if j.above_rule == j.below_rule:
        return [*lines, ""]
    only_above, only_below = j.singles[j.above_rule], j.singles[j.below_rule]
    lines += [
        "",
        f"- `{j.composed_rule}` less the best single rule `{j.best_single}`, paired by seed: "
        f"{mean:+.3f} [{lo:+.3f}, {hi:+.3f}] -> {verdict}.",
        f"- Where `{j.composed_rule}` decides: in {_share(above)} of the episodes at least once "
        f"above, in {_share(below)} below, in {_share(above & below)} both.",
    ]
    gain = composed.rewards - only_above.rewards
    same = bool(np.all(gain[~below] == 0.0))
    m, lo, hi = t_interval(gain)
    among = f"{gain[below].mean():+.3f} among them" if below.any() else "none did"
    lines.append(
        f"- What the rule below adds: `{j.composed_rule}` less `{j.above_rule}` everywhere "
        f"{m:+.3f} [{lo:+.3f}, {hi:+.3f}]; only the {_share(below)} of episodes that decide "
        f"below can differ ({among}; the others are the same episodes: "
        f"{'checked' if same else 'NOT so, which they should be'})."
    )
    m, lo, hi = t_interval(composed.rewards - only_below.rewards)
    lines.append(
        f"- What the rule above adds: `{j.composed_rule}` less `{j.below_rule}` everywhere "
        f"{m:+.3f} [{lo:+.3f}, {hi:+.3f}]."
    )
    if j.once is not None:
        m, lo, hi = t_interval(composed.rewards - j.once.rewards)
        lines.append(
            f"- One of the two rules per episode, by the region of its first decision "
            f"(`{j.once.rule}`): {j.once.rewards.mean():+.3f}; `{j.composed_rule}` less it "
            f"{m:+.3f} [{lo:+.3f}, {hi:+.3f}], what switching within the episode adds."
        )
    return [*lines, ""]


def _figures(judged: Sequence[Judged]) -> dict[str, Judged]:
    return {j.candidate.label: j for j in judged}


def _once_text(j: Judged) -> str:
    return "-" if j.once is None else f"{j.once.rewards.mean():+.3f}"


def _diff_text(j: Judged, other: str) -> str:
    mean, lo, hi = j.difference(j.singles[other])
    return f"{mean:+.3f} [{lo:+.3f}, {hi:+.3f}]"


def _using(judged: Sequence[Judged]) -> list[str]:
    """How the learning side reads the stream (figures from ``judged``)."""
    kept = [j for j in judged if j.candidate.registered and j.kept]
    lines = [
        "## Using the stream",
        "",
        "- Sources: `opponents.region_stream.SOURCES` "
        f"({', '.join(f'`{s}`' for s in SOURCES)}); targets: "
        "`opponents.region_stream.TARGETS` (the registered compositions; the summary says "
        "which the pre-check keeps). In a configuration: `HolderEnv(opponent=\"<id>\")`.",
        "- The true region of a target, for an oracle: the feature index and threshold of "
        "the table above (`soccer_drill.make_team(id).params()[\"region\"]` gives it as "
        "JSON). Both thresholds (12 and 0) are exact in float32, so `obs[5] <= 12` and "
        "`obs[6] <= 0` on the observation are exactly the team's test.",
        "- The hand-composed fixed rule of a target: "
        "`opponents.regions.RegionRule(above_rule, below_rule, region)`, called as "
        "`rule(obs, rng)` like the rules of `soccer_drill.policies`.",
    ]
    for j in kept:
        composed = j.composed_play
        both = (composed.above > 0) & (composed.below > 0)
        best = j.singles[j.best_single].rewards.mean()
        line = (f"- `{j.candidate.label}`: {_share(both)} of the episodes of "
                f"`{j.composed_rule}` decide in both regions")
        gain = composed.rewards.mean() - best
        if j.once is not None and gain > 0:
            share = (j.once.rewards.mean() - best) / gain
            line += (f"; one of its two rules per episode, chosen by the first decision's "
                     f"region, gets {share:.0%} of its gain over `{j.best_single}` "
                     f"({j.once.rewards.mean():+.3f} against {composed.rewards.mean():+.3f} "
                     f"and {best:+.3f})")
        lines.append(line + ".")
    lines += [
        "",
        "So the left/right targets ask mostly which source to reuse in an episode (the "
        "holder's starting half mostly decides which behaviour it meets), and "
        "`press_far_contain_near` (every episode starts far, nearly all reach near) asks "
        "for a change of behaviour within the episode.",
        "",
    ]
    return lines


def _history(judged: Sequence[Judged]) -> list[str]:
    """What it took to find compositions that pass (figures from ``judged``)."""
    by = _figures(judged)
    lines = ["## How the compositions were found", ""]
    guard = by.get("press_far_guard_near")
    if guard is not None and ("late_pass", "dribble") in guard.candidate.extra:
        lines += [
            "1. The paper's teams first: `press_far_guard_near` (the press far from the "
            f"line, `goal_guards` near it). The sources' best rules give `{guard.composed_rule}`"
            f", {_diff_text(guard, guard.best_single)} against the best single rule "
            f"`{guard.best_single}`: nothing to compose, since `late_pass` succeeds in at "
            "least 70% of the episodes against each of the paper's teams (`docs/opponents.md`)"
            ". A composition does beat it (`late_pass|dribble`, "
            f"{_composed_less(guard, 'late_pass|dribble', guard.best_single)}), but not one "
            "of the sources' best rules, and a learner composes what it learnt on the sources.",
        ]
    lines += [
        "2. So a second behaviour whose best rule fails against the press, and against "
        "which the press's best rule fails. Lane markers that punish passes are not it: "
        "the fixed rules read the passing lane (features 3 and 4) and do not pass into a "
        "marked one, so against `cover` teams at full speed `late_pass`, `early_pass` and "
        "`dribble` score alike (`interceptors_cover` in `docs/opponents.md`). An exploration of the family's two-interceptor settings "
        "(50 random settings: `cover` or `screen`, speeds 0.6-1.0, reaction delays 0-3, "
        "marker fraction, screen distance, chasing loose balls; 100 episodes and six rules "
        "each; not part of this command) found the slow `cover` teams with a close marker "
        "turning the ranking round: `lane` best and `late_pass` among the worst. "
        "`contain_cover` is such a setting, rounded (speed 0.7, marker fraction 0.2).",
        "3. The threshold of `press_far_contain_near`, 12 m, was chosen among 9, 12 and "
        "15 m in 200-episode runs of the same comparison (+0.25, +0.29 and +0.20, each "
        "+-0.07-0.08); the figures above are the 500-episode ones.",
    ]
    reverse = by.get("contain_far_press_near")
    if reverse is not None:
        composed = reverse.composed_play
        below = composed.below > 0
        gain = composed.rewards - reverse.singles[reverse.above_rule].rewards
        lines.append(
            "4. The mirror of the depth split, `contain_far_press_near`, fails: "
            f"`{reverse.composed_rule}` less `{reverse.best_single}` "
            f"{_diff_text(reverse, reverse.best_single)}. Once `lane` has beaten the contain "
            f"far from the line, it also meets the press near the line better than "
            f"`{reverse.below_rule}` does (among the {_share(below)} of episodes that decide near, "
            f"{gain[below].mean():+.3f} for switching to `{reverse.below_rule}`): the press's "
            "best rule in its own drill is not its best response where the contain leaves "
            "the ball. Hence the second and third targets split the field into left and "
            "right halves instead." + _lateral_note(by)
        )
    lines += _sharp_note(by)
    return [*lines, ""]


def _sharp_note(by: Mapping[str, Judged]) -> list[str]:
    """The search for the sharp test's targets: a change within the episode needed."""
    tried = [by[c] for c in ("cover_far_contain_near", "guard_far_contain_near",
                             "guards_far_contain_near") if c in by]
    kept = [j for j in by.values() if j.within_episode]
    if not tried and not kept:
        return []
    said = "; ".join(f"`{j.candidate.label}` {_diff_text(j, j.best_single)} against "
                     f"`{j.best_single}`" for j in tried)
    return [
        "5. The sharp test of regions needs targets whose gain needs a change of behaviour "
        "within the episode: one of the two rules per episode (by the first decision's "
        "region) gets less than half of the composed rule's gain and is beaten by it. The "
        "left/right targets do not (they get most of it per episode). The other paper teams "
        "far from the line with the contain near it, so that each target would need a "
        f"different source far, were tried first and fail: {said} (the composed rule is "
        "not better than the best single rule).",
        "6. Kept as needing the change within the episode: "
        + ", ".join(f"`{j.candidate.label}` (composed less one rule per episode "
                    f"{_once_diff(j)})"
                    for j in kept)
        + ": the press far from the line and the contain near it, at three boundaries "
        "(`opponents.region_stream.SHARP_TARGETS`).",
    ]


def _once_diff(j: Judged) -> str:
    mean, lo, hi = j.difference(j.once)
    return f"{mean:+.3f} [{lo:+.3f}, {hi:+.3f}]"


def _lateral_note(by: Mapping[str, Judged]) -> str:
    lateral = [j for j in by.values() if j.candidate.region.feature == "lateral" and j.kept]
    if not lateral:
        return ""
    scores = ", ".join(f"{j.composed_play.rewards.mean():+.2f}" for j in lateral)
    return (f" There the composed rules score {scores}, about what each source's best rule "
            "scores on its own source (the sources' table).")


def _composed_less(j: Judged, composed: str, single: str) -> str:
    mean, lo, hi = t_interval(j.composed[composed].rewards - j.singles[single].rewards)
    return f"{mean:+.3f} [{lo:+.3f}, {hi:+.3f}] over `{single}`"


def write_page(
    sources: Mapping[str, Mapping[str, Play]],
    judged: Sequence[Judged],
    episodes: int,
    path: str | os.PathLike[str],
    command: str,
    timing: str = "",
) -> Path:
    """Write the pre-check page (``docs/regions.md``)."""
    lines = [
        "# Targets composed by region: teams and the pre-check",
        "",
        "Generated by",
        "",
        "```bash",
        command,
        "```",
        "",
        f"{timing} Every cell plays the episodes of seeds 0..{episodes - 1} in `HolderEnv`, "
        "where an episode is a function of its seed and the actions: all rules meet the "
        "same starts, and differences are paired by seed. Success with a 95% Wilson interval; mean reward and paired "
        "differences with 95% t intervals; outcomes are success / interception / out / "
        "timeout.",
        "",
    ]
    lines += _teams_section(judged)
    lines += _summary_section(judged)
    lines += [
        "",
        "## The sources",
        "",
        "Every fixed rule against each pure team; the best (highest mean reward) in bold.",
        "",
        *_source_table(sources),
        "",
        "## The compositions",
        "",
    ]
    for j in judged:
        lines += _candidate_section(j)
    lines += _using(judged) + _history(judged)
    return atomic_write_text(path, "\n".join(lines).rstrip() + "\n")


def _teams_section(judged: Sequence[Judged]) -> list[str]:
    """The teams, and how each composition's region reads on the holder's features."""
    lines = [
        "## The teams",
        "",
        "| id | what it does |",
        "|---|---|",
        "| `interceptors_press` | source: paper team 1, both defenders press the ball "
        "(`opponents/paper.py`) |",
        "| `contain_cover` | source: paper team 2's `cover` at 70% of the top speed with the "
        "marker at 20% of the way from the free attacker to the ball; the slow presser "
        "waits in the holder's path (`opponents/region_stream.py`) |",
        "| `press_far_contain_near`, `contain_left_press_right`, `press_left_contain_right` "
        "| targets: `RegionTeam`s of the two sources (`opponents/regions.py`, "
        "`opponents/region_stream.py`) |",
        "| `press_far_contain_near_9`, `press_far_contain_near_15` | the sharp test's targets "
        "with `press_far_contain_near`: the same composition at 9 and 15 m |",
        "| `interceptors_cover`, `interceptor_guard`, `goal_guards` | paper teams 2-4, "
        "composed far from the line with `contain_cover` near it (candidates) |",
        "",
        "A `RegionTeam` plays one team while the ball is above the region's threshold and "
        "the other below it, deciding each cycle at the attacker in possession (at the "
        "ball while it is loose). The test is the holder's own feature, rounded to float32 "
        "as observed, so whenever the holder decides, the team plays the behaviour of the "
        "holder's region. A holder rule, an oracle or a learner reads the region as:",
        "",
        "| composition | status | team above | team below | feature (index) | below when |",
        "|---|---|---|---|---|---|",
    ]
    for j in judged:
        status = "target" if j.candidate.registered and j.kept else (
            "registered, NOT kept" if j.candidate.registered else "rejected")
        lines.append(_region_row(j.candidate, status))
    return lines


def _summary_section(judged: Sequence[Judged]) -> list[str]:
    """The regions in code, and one row per composition: the best single rule, the composed
    rule, their paired difference and the verdict."""
    lines = [
        "",
        "In code: `opponents.region_stream.NEAR` (`Region(\"dist_goal\", 12.0)`) and "
        "`opponents.region_stream.LEFT` (`Region(\"lateral\", 0.0)`); "
        "`region.observed_below(obs)` is the test, "
        "`np.float32(obs[region.index]) <= np.float32(region.threshold)`.",
        "",
        "## Summary",
        "",
        "| composition | best single rule | composed rule | composed less best single "
        "[95% CI] | one rule per episode, by its first decision | episodes deciding above "
        "/ below / both | verdict |",
        "|---|---|---|---|---|---|---|",
    ]
    for j in judged:
        composed = j.composed_play
        mean, lo, hi = j.difference(j.singles[j.best_single])
        above, below = composed.above > 0, composed.below > 0
        lines.append(
            f"| `{j.candidate.label}` | `{j.best_single}` "
            f"{j.singles[j.best_single].rewards.mean():+.3f} | {_cell(j.composed_rule)} "
            f"{composed.rewards.mean():+.3f} | {mean:+.3f} [{lo:+.3f}, {hi:+.3f}] | "
            f"{_once_text(j)} | "
            f"{_share(above)} / {_share(below)} / {_share(above & below)} | "
            f"{j.verdict} |"
        )
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point: judge every candidate, write the page."""
    parser = argparse.ArgumentParser(
        prog="python -m ilpss.experiments.region_check", description=__doc__.splitlines()[0],
    )
    parser.add_argument("--episodes", type=int, default=500, help="episodes per cell")
    parser.add_argument("--workers", type=int, default=2, help="worker processes")
    parser.add_argument("--out", default="results/regions.md", help="the page to write")
    args = parser.parse_args(argv)
    if args.episodes < 2:
        parser.error("--episodes must be at least 2")
    if args.workers < 1:
        parser.error("--workers must be at least 1")
    try:  # before the episodes rather than after them
        check_output_file(args.out)
    except ValueError as exc:
        parser.error(f"--out: {exc}")
    start = time.perf_counter()
    sources, judged = judge(args.episodes, args.workers)
    seconds = time.perf_counter() - start
    command = f"python -m ilpss.experiments.region_check --episodes {args.episodes} --out {args.out}"
    timing = f"It took {seconds / 60:.1f} min with {args.workers} worker process(es)."
    path = write_page(sources, judged, args.episodes, args.out, command, timing)
    for j in judged:
        mean, lo, hi = j.difference(j.singles[j.best_single])
        print(f"{j.candidate.label}: {j.composed_rule} less {j.best_single} "
              f"{mean:+.3f} [{lo:+.3f}, {hi:+.3f}] -> {j.verdict}")
    print(f"wrote {path} in {seconds:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
