"""The batched drill against the single one: success rates of every rule against every team.

    python -m ilpss.experiments.agreement [--episodes 500] [--teams ID ...] [--rules NAME ...]

For every fixed holder rule of the drill and every registered team, ``--episodes`` seeded
episodes (seeds 0..episodes-1) in the holder environment (the reference) and in the
batched drill (its ``play_episodes``), and whether the
two success rates agree: Newcombe's 95% interval of their difference holds 0 (and,
stricter, each rate lies within the other's 95% Wilson interval, which a rate of 0 can
fail against 1 success in 500). Prints a table and exits non-zero if any cell disagrees.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ilpss.experiments import drill_facts
from ilpss.experiments.calibrate import evaluate, holder_rules
from ilpss.experiments.drill_facts import drill_object
from ilpss.metrics import wilson_interval


@dataclass(frozen=True)
class Agreement:
    """One (team, rule) cell: successes of the single and the batched drill."""

    team: str
    rule: str
    single: int
    batched: int
    episodes: int

    @property
    def difference_interval(self) -> tuple[float, float]:
        """Newcombe's 95% interval of ``batched - single`` success rates (Wilson-based)."""
        n = self.episodes
        p1, p2 = self.single / n, self.batched / n
        l1, u1 = wilson_interval(self.single, n)
        l2, u2 = wilson_interval(self.batched, n)
        d = p2 - p1
        return (d - math.sqrt((p2 - l2) ** 2 + (u1 - p1) ** 2),
                d + math.sqrt((u2 - p2) ** 2 + (p1 - l1) ** 2))

    @property
    def agrees(self) -> bool:
        """The 95% interval of the difference of the two rates holds 0."""
        lo, hi = self.difference_interval
        return lo <= 0.0 <= hi

    @property
    def within_each_other(self) -> bool:
        """The stricter check: each rate within the other's 95% Wilson interval."""
        n = self.episodes
        l1, u1 = wilson_interval(self.single, n)
        l2, u2 = wilson_interval(self.batched, n)
        return l1 <= self.batched / n <= u1 and l2 <= self.single / n <= u2


def agreement(
    episodes: int, teams: Sequence[str], rules: Sequence[str], drills: int = 64
) -> list[Agreement]:
    """Every (team, rule) cell in both drills, same seeds."""
    out = []
    for team in teams:
        for rule in rules:
            single = evaluate(team, rule, episodes, drills=1).successes
            batched = evaluate(team, rule, episodes, drills=drills).successes
            out.append(Agreement(team, rule, single, batched, episodes))
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Print the table; 0 if every cell agrees."""
    parser = argparse.ArgumentParser(prog="python -m ilpss.experiments.agreement", description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=500)
    parser.add_argument("--teams", nargs="+", default=None, help="default: every registered team")
    parser.add_argument("--rules", nargs="+", default=list(holder_rules()))
    parser.add_argument("--drills", type=int, default=64)
    args = parser.parse_args(argv)
    teams = args.teams or drill_object(drill_facts.TEAM_IDS)()
    cells = agreement(args.episodes, teams, args.rules, args.drills)
    print("| team | rule | single | batched | difference [95% CI] | agree |")
    print("|---|---|---:|---:|---|---|")
    for c in cells:
        lo, hi = c.difference_interval
        n = c.episodes
        print(f"| {c.team} | {c.rule} | {c.single / n:.1%} | {c.batched / n:.1%} | "
              f"{(c.batched - c.single) / n:+.1%} [{lo:+.1%}, {hi:+.1%}] | {'yes' if c.agrees else 'NO'} |")
    bad = [c for c in cells if not c.agrees]
    diffs = np.array([(c.batched - c.single) / c.episodes for c in cells])
    strict = sum(c.within_each_other for c in cells)
    print(f"\n{len(cells) - len(bad)}/{len(cells)} cells agree ({strict} also within each other's "
          f"intervals); mean difference {diffs.mean():+.2%}, "
          f"largest {np.abs(diffs).max():.1%}")
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
