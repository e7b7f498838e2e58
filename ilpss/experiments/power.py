"""The power of a plan: how likely its rule is to pick each candidate if the pilot effects
are true, before a single seed of the run is spent.

    ilpss-power docs/decisive_test.json                               # from the plan's pilot figures
    ilpss-power docs/decisive_test.json --pilot-runs S=results/dev/s A=results/dev/a --write

Each test of the family states its pilot figures (:class:`~ilpss.experiments.plan.Pilot`:
the mean and standard deviation of the per-seed differences on development seeds). The
run is simulated ``sims`` times: per test, the planned number of seeds is drawn from a
normal distribution with the pilot's mean and standard deviation, the test's p-value is
computed as the run would compute it (the t-test, one-sided against the margin, or
two-sided in the first form), Holm's adjustment is applied across the family, and the
plan's rule is applied to the outcome. The report gives, per test, the probability that
it is shown and the seeds it would need alone for 80% (the t test's power, at the
Bonferroni level of the family, which Holm's first step uses), and per candidate the probability that its
requirements are met and that the rule picks it.

Tests are drawn independently. The tests a candidate requires are positively correlated
where they share seeds (the same control in one protocol), and for such tests the
probability that all are shown is at least the product of their probabilities, so the
power given here errs low.

``--pilot-runs`` (run folders) or ``--pilot-data`` (their kept per-seed numbers) computes
the pilot figures from development runs (any seeds they hold that both methods of a test
finished) and ``--write`` writes them into the plan. Runs holding any of the seeds the
plan will test are refused: a plan's power is never read off its own outcomes.
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats

from ilpss import metrics
from ilpss._io import atomic_write_bytes, read_json
from ilpss.experiments.outputs import description
from ilpss.experiments.plan import Pilot, Plan, Qualify, TestSpec
from ilpss.experiments.seed_data import SeedData
from soccer_drill.constraints import Integer, JsonObject, check, check_keys, checked

__all__: list[str] = []  # a command (ilpss-power); its entry point names main

SIMULATIONS = 20_000
TARGET = 0.8
MAX_SIMULATIONS = 1_000_000
MAX_DRAWS = 20_000_000
"""The most simulated seeds of one test (simulated runs x its protocol's seeds): its draws
are held at once, 8 bytes each (160 MB)."""
SIMS = Integer(1, MAX_SIMULATIONS)
SEEDS = Integer(2)
"""Seeds of a protocol simulated: a t test over paired differences needs at least 2."""


@dataclass(frozen=True)
class PowerReport:
    """The simulated outcome of a plan at its pilot effects."""

    seeds: Mapping[str, int]
    """Per protocol, the seeds simulated."""
    shown: Mapping[str, float]
    """Per test of the family, the probability that it is shown after Holm's adjustment."""
    qualifies: Mapping[str, float]
    """Per candidate, the probability that the rule's requirements for it are met."""
    picks: Mapping[str, float]
    """Per method the rule can pick (the fallback included), the probability it does."""
    sims: int
    supported: Mapping[str, bool]
    """Per candidate, whether its pilot effects meet its requirements (each required
    test's pilot effect above its margin): the candidates the development seeds support,
    whose power the plan must have. A candidate they do not support is one the rule should
    not pick if they are right; its power is reported, not required."""

    def below(self, required: float) -> list[str]:
        """The supported candidates whose requirements are met with less than
        ``required`` probability, in words."""
        return [f"`{m}` {p:.0%}" for m, p in self.qualifies.items()
                if p < required and self.supported.get(m, True)]


def seeds_needed(spec: TestSpec, pilot: Pilot, level: float, power: float = TARGET) -> float:
    """The seeds that ``spec`` alone needs to be shown with probability ``power`` by its
    one-sided t test at level ``level`` if its pilot effect and spread are true (the
    noncentral t's power; at least 2 seeds); ``inf`` if the effect is not above the margin.

    The normal approximation ``((z_level + z_power) sd / distance)^2`` is where the search
    starts: a t test with the spread estimated has less power than that, so it needs at
    least as many seeds (at 8 seeds it can be 10 points short of the aim)."""
    distance = pilot.effect - spec.margin
    if distance <= 0:
        return math.inf
    if pilot.sd == 0:  # no spread: any two seeds show it
        return 2.0
    shift = distance / pilot.sd
    z = stats.norm.ppf(1 - level) + stats.norm.ppf(power)
    n = max(2, math.ceil((z / shift) ** 2))
    while t_test_power(shift, n, level) < power:
        n += 1
    return float(n)


def t_test_power(shift: float, n: int, level: float) -> float:
    """The probability that a one-sided t test at level ``level`` over ``n`` paired
    differences is shown when their mean is ``shift`` standard deviations beyond the
    margin: the noncentral t's tail beyond the test's critical value."""
    df = n - 1
    return float(stats.nct.sf(stats.t.ppf(1 - level, df), df, shift * math.sqrt(n)))


def plan_power(plan: Plan, pilots: Mapping[str, Pilot] | None = None,
               seeds: Mapping[str, int] | None = None, sims: int = SIMULATIONS,
               seed: int = 0) -> PowerReport:
    """Simulate ``plan`` at its pilot effects (``pilots`` by test name replace or supply
    them; ``seeds`` by protocol replace the planned numbers)."""
    pilots = {**{t.name: t.pilot for t in plan.family if t.pilot is not None}, **(pilots or {})}
    missing = [t.name for t in plan.family if t.name not in pilots]
    if missing:
        raise ValueError(f"no pilot figures for the tests {missing}: give them in the plan or "
                         "with --pilot-runs")
    n_seeds = {p: plan.config(p).n_seeds for p in plan.protocols}
    n_seeds.update(seeds or {})
    rng = np.random.default_rng(seed)
    family = plan.family
    p_values, gains = [], []
    for spec in family:
        pilot, n = pilots[spec.name], n_seeds[spec.protocol]
        draws = rng.normal(pilot.effect, pilot.sd, size=(sims, n))
        mean, se = draws.mean(axis=1), draws.std(axis=1, ddof=1) / math.sqrt(n)
        t = (mean - spec.margin) / se
        p = stats.t.sf(t, n - 1) if spec.alternative == "greater" else \
            2 * stats.t.sf(np.abs(t), n - 1)
        p_values.append(p)
        gains.append((mean, mean - stats.t.ppf(0.975, n - 1) * se, n))
    p_values = np.array(p_values).T
    adjusted = np.empty_like(p_values)
    names = [t.name for t in family]
    for specs in plan.groups().values():  # Holm within each family of tests
        columns = [names.index(t.name) for t in specs]
        adjusted[:, columns] = holm_rows(p_values[:, columns])
    shown = adjusted < plan.alpha
    if isinstance(plan.rule, Qualify):
        qualifies, picks = _qualify_outcomes(plan, family, gains, adjusted)
        supported = dict.fromkeys(qualifies, True)
    else:
        specs = {t.name: t for t in family}
        qualifies = {m: float(np.mean(np.all(shown[:, [names.index(r) for r in req]], axis=1)))
                     for m, req in plan.rule.candidates}
        chosen = [plan.rule.pick_from(dict(zip(names, row, strict=True))) for row in shown]
        picks = _shares(chosen, [*(m for m, _ in plan.rule.candidates), plan.rule.fallback])
        supported = {m: all(pilots[r].effect > specs[r].margin for r in req)
                     for m, req in plan.rule.candidates}
    return PowerReport(n_seeds, dict(zip(names, shown.mean(axis=0).tolist(), strict=True)),
                       qualifies, picks, sims, supported)


def holm_rows(p: np.ndarray) -> np.ndarray:
    """Holm's adjustment of each row of ``p`` (simulations x tests), as
    :func:`ilpss.metrics.holm` adjusts one family."""
    m = p.shape[1]
    order = np.argsort(p, axis=1, kind="stable")
    ranked = np.take_along_axis(p, order, axis=1) * (m - np.arange(m))
    ranked = np.minimum(np.maximum.accumulate(ranked, axis=1), 1.0)
    out = np.empty_like(p)
    np.put_along_axis(out, order, ranked, axis=1)
    return out


@dataclass(frozen=True)
class _Outcome:
    protocol: str
    method: str
    against: str
    gain: metrics.MetricEstimate
    adjusted: float


def _qualify_outcomes(plan: Plan, family: Sequence[TestSpec], gains: list, adjusted: np.ndarray
                      ) -> tuple[dict[str, float], dict[str, float]]:
    """The first form's rule, applied to every simulated run (slower: object by object)."""
    rule = plan.rule
    assert isinstance(rule, Qualify)
    counts = dict.fromkeys(rule.candidates, 0)
    chosen = []
    for i in range(adjusted.shape[0]):
        outcomes = [_Outcome(t.protocol, t.method, t.against,
                             metrics.MetricEstimate("total_reward_gain", float(g[0][i]),
                                                    float(g[1][i]), math.inf, g[2], ""),
                             float(adjusted[i, k]))
                    for k, (t, g) in enumerate(zip(family, gains, strict=True))]
        for c in rule.candidates:
            counts[c] += rule.qualifies(outcomes, c, rule.controls, plan.alpha)
        chosen.append(rule.pick(plan, outcomes)[0])
    n = adjusted.shape[0]
    return ({c: k / n for c, k in counts.items()},
            _shares(chosen, [*rule.candidates, *rule.controls]))


def _shares(chosen: Sequence[str], methods: Sequence[str]) -> dict[str, float]:
    n = len(chosen)
    return {m: sum(c == m for c in chosen) / n for m in dict.fromkeys(methods)}


def power_lines(plan: Plan, report: PowerReport, pilots: Mapping[str, Pilot] | None = None
                ) -> list[str]:
    """The power of ``plan`` in markdown: per test and per candidate."""
    pilots = {**{t.name: t.pilot for t in plan.family if t.pilot is not None}, **(pilots or {})}
    head = ["test", "protocol", "null hypothesis", "pilot effect (sd, seeds)", "seeds planned",
            "P(shown)", "seeds alone for 80%"]
    lines = [f"Power at the pilot effects ({report.sims:,} simulated runs; each test's seeds "
             "drawn from a normal with its pilot mean and sd; Holm within each family):", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for t in plan.family:
        pilot = pilots[t.name]
        sides = 2 if t.alternative == "two-sided" else 1
        need = seeds_needed(t, pilot, plan.alpha / sides / len(plan.groups()[t.group]))
        null = "gain = 0" if sides == 2 else f"gain <= {t.margin:g}"
        lines.append(
            f"| {t.name} | {t.protocol} | {null} | {pilot.effect:+.1f} "
            f"({pilot.sd:.1f}, {pilot.seeds}) | {report.seeds[t.protocol]} | "
            f"{report.shown[t.name]:.0%} | {'never' if math.isinf(need) else int(need)} |")
    lines += ["", "| candidate | P(its requirements are met) | P(the rule picks it) |",
              "|---|---|---|"]
    lines += [f"| `{m}`{'' if report.supported[m] else ' (not supported by its pilot effects)'}"
              f" | {p:.0%} | {report.picks.get(m, 0.0):.0%} |"
              for m, p in report.qualifies.items()]
    others = [m for m in report.picks if m not in report.qualifies]
    lines += [f"| `{m}` ({'the rule' + chr(39) + 's fallback' if m == plan.fallback else 'a control'})"
              f" | - | {report.picks[m]:.0%} |" for m in others]
    return lines


def pilot_figures(plan: Plan, runs: Sequence[SeedData]) -> dict[str, Pilot]:
    """Each family test's pilot figures from development runs ``runs`` (several may hold
    one protocol's seeds, each some of the methods: runs with the same seeds meet the same
    opponents): the mean and standard deviation of the per-seed total-reward differences
    over the seeds both methods finished. Seeds the plan itself will test are refused: its
    power would then be read off its own outcomes."""
    out = {}
    for t in plan.family:
        ours, base = _seed_totals(runs, t.protocol, t.method), _seed_totals(runs, t.protocol,
                                                                              t.against)
        common = sorted(set(ours) & set(base))
        cfg = plan.config(t.protocol)
        planned = range(cfg.first_seed, cfg.first_seed + cfg.n_seeds)
        reused = [s for s in common if s in planned]
        if reused:
            raise ValueError(
                f"test {t.name!r}: the pilot runs of protocol {t.protocol} hold seeds "
                f"{reused[:5]}{' ...' if len(reused) > 5 else ''} of the plan's own "
                f"({planned.start} to {planned.stop - 1}): pilot figures come from other "
                "seeds (development seeds, from 1000), never from those the plan will test")
        if len(common) < 2:
            raise ValueError(f"test {t.name!r}: the pilot runs have {len(common)} seeds with "
                             "both methods, at least 2 are needed")
        d = np.array([ours[s] - base[s] for s in common])
        out[t.name] = Pilot(round(float(d.mean()), 1), round(float(d.std(ddof=1)), 1),
                            len(common))
    return out


def _seed_totals(runs: Sequence[SeedData], protocol: str, method: str) -> dict[int, float]:
    """``{seed: total reward}`` of ``method`` over every run of ``protocol`` that has it (the
    first run's where two hold the same seed)."""
    out: dict[int, float] = {}
    for run in reversed(runs):
        if protocol in run.configs and method in run.configs[protocol].methods:
            out.update({s: float(c.sum()) for s, c in run.seed_curves(protocol, method).items()})
    if not out:
        raise ValueError(f"no pilot run of protocol {protocol} has method {method!r}")
    return out


def read_pilots(path: Path) -> dict[str, Pilot]:
    """Pilot figures from a JSON file (see ``--pilot``), each checked."""
    values = read_json(path)
    try:
        if not isinstance(values, dict) or not isinstance(values.get("pilots"), dict):
            raise ValueError("expected an object with a 'pilots' object")
        check_keys("the pilot file", values, ("source", "pilots"), required=("pilots",))
        out = {}
        for name, figures in values["pilots"].items():
            check(f"pilots[{name!r}]", figures, JsonObject("effect, sd and seeds"))
            check_keys(f"pilots[{name!r}]", figures, ("effect", "sd", "seeds"))
            out[name] = Pilot(**figures)
        return out
    except (ValueError, TypeError) as exc:
        raise ValueError(f"{path}: {exc}") from exc


def _with_pilots(values: dict[str, Any], pilots: Mapping[str, Pilot]) -> dict[str, Any]:
    tests = [{**t, "pilot": {"effect": pilots[t["name"]].effect, "sd": pilots[t["name"]].sd,
                             "seeds": pilots[t["name"]].seeds}} for t in values["tests"]]
    return {**values, "tests": tests}


def main(argv: Sequence[str] | None = None) -> int:
    """Print a plan's power; exit 1 if a candidate is below the plan's required power."""
    p = _parser()
    args = p.parse_args(argv)
    try:
        sims = checked("--sims", args.sims, SIMS)
        plan = _read_plan(Path(args.plan))
    except ValueError as exc:
        p.error(str(exc))
    except OSError as exc:
        p.exit(1, f"{p.prog}: error: {exc}\n")
    try:
        seeds = _seed_counts(args.seeds, plan, sims)
    except ValueError as exc:
        p.error(str(exc))
    if args.write and (not (args.pilot or args.pilot_runs or args.pilot_data)
                       or plan.form < 2):
        p.error("--write needs --pilot-runs, --pilot-data or --pilot and a plan of the "
                "current form")
    try:
        pilots = read_pilots(Path(args.pilot)) if args.pilot else None
        if args.pilot_runs or args.pilot_data:
            runs = [SeedData.from_runs({protocol: Path(folder)}, require_all=False)
                    for protocol, folder in _pairs(args.pilot_runs, "--pilot-runs")]
            runs += [SeedData.read(stem) for stem in args.pilot_data]
            pilots = pilot_figures(plan, runs)
        report = plan_power(plan, pilots, seeds, sims=sims)
        print("\n".join(power_lines(plan, report, pilots)))
        if args.write:
            assert pilots is not None
            values = read_json(Path(args.plan))
            text = json.dumps(_with_pilots(values, pilots), indent=2) + "\n"
            atomic_write_bytes(Path(args.plan), text.encode())
            print(f"pilot figures written into {args.plan}")
    except (ValueError, KeyError, OSError) as exc:
        p.exit(1, f"{p.prog}: error: {exc}\n")
    weak = report.below(plan.required_power)
    if weak:
        print(f"below the required {plan.required_power:.0%}: {'; '.join(weak)}")
        return 1
    return 0


def _parser() -> argparse.ArgumentParser:
    """The command-line parser of ``ilpss-power``."""
    p = argparse.ArgumentParser(prog="ilpss-power",
                                description=description(__doc__),
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog=__doc__)
    p.add_argument("plan", help="the plan (JSON)")
    p.add_argument("--pilot-runs", nargs="+", default=[], metavar="PROTOCOL=FOLDER",
                   help="development run folders to compute the pilot figures from (a "
                        "protocol may be named more than once: runs of other methods on the "
                        "same seeds)")
    p.add_argument("--pilot-data", nargs="+", default=[], metavar="STEM",
                   help="per-seed numbers of development runs (STEM.csv.gz and STEM.json, "
                        "as ilpss-confirm and seed_data keep them) to compute the pilot "
                        "figures from")
    p.add_argument("--pilot", metavar="FILE",
                   help="pilot figures as JSON: {\"source\": \"where they come from\", "
                        "\"pilots\": {TEST: {\"effect\": E, \"sd\": S, \"seeds\": N}}} "
                        "(a first-form plan names its tests \"P: METHOD - AGAINST\")")
    p.add_argument("--seeds", nargs="+", default=[], metavar="PROTOCOL=N",
                   help="simulate N seeds in PROTOCOL (one of the plan's protocols) instead "
                        "of the plan's; N at least 2, as a t test needs")
    p.add_argument("--write", action="store_true",
                   help="write the pilot figures of --pilot-runs into the plan")
    p.add_argument("--sims", type=int, default=SIMULATIONS,
                   help=f"simulated runs, from 1 to {MAX_SIMULATIONS:,} (default "
                        f"{SIMULATIONS:,}); with the most seeds of a protocol, at most "
                        f"{MAX_DRAWS:,} draws per test, held in memory at once")
    return p


def _read_plan(path: Path) -> Plan:
    """The plan in ``path``; an error names the file once (:func:`read_json`'s own errors
    name it already)."""
    values = read_json(path)
    try:
        return Plan.from_json(values)
    except (ValueError, TypeError, KeyError) as exc:
        raise ValueError(f"{path}: {exc}") from exc


def _seed_counts(items: Sequence[str], plan: Plan, sims: int) -> dict[str, int]:
    """``--seeds PROTOCOL=N`` as ``{protocol: N}``, each checked against ``plan``, and the
    draws of ``sims`` runs at the most seeds checked against :data:`MAX_DRAWS`."""
    seeds: dict[str, int] = {}
    for key, value in _pairs(items, "--seeds"):
        if key not in plan.protocols:
            raise ValueError(f"--seeds {key}={value}: the plan has no protocol {key!r}; its "
                             f"protocols: {', '.join(plan.protocols)}")
        number = int(value) if value.lstrip("-").isdigit() else value
        seeds[key] = checked(f"--seeds {key}", number, SEEDS,
                             why="a t test over paired seeds needs at least 2")
    counts = {p: plan.config(p).n_seeds for p in plan.protocols} | seeds
    protocol = max(counts, key=counts.__getitem__)
    if sims * counts[protocol] > MAX_DRAWS:
        raise ValueError(
            f"--sims {sims:,} x {counts[protocol]:,} seeds (protocol {protocol}) is "
            f"{sims * counts[protocol]:,} draws per test, more than the {MAX_DRAWS:,} held "
            "in memory at once; give fewer --sims or --seeds")
    return seeds


def _pairs(items: Sequence[str], flag: str) -> list[tuple[str, str]]:
    out = []
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key or not value:
            raise ValueError(f"{flag} takes KEY=VALUE items, got {item!r}")
        out.append((key, value))
    return out


if __name__ == "__main__":
    raise SystemExit(main())
