"""A pre-registered confirmatory run: its family of comparisons, Holm across all of them,
and the pick rule applied as written.

    ilpss-confirm docs/confirmatory.json --runs results/confirm --out results/confirm/confirm.md

The plan (a JSON file, :class:`Plan`) is committed before the run. It names the methods,
each protocol's configuration (seeds never used before), the comparisons (a method
against another, paired by seed, on the primary endpoint, in every protocol), the
secondary endpoints, the margin and the pick rule's candidates. The command runs (or
resumes) each protocol's experiment into ``<runs>/protocol_<p>``, then writes one page:

* every comparison in every protocol, on the primary endpoint (the total-reward gain,
  95% t interval over the paired seeds, p-value Holm-adjusted across the *whole* family:
  every comparison in every protocol), and the secondary endpoints as plain intervals;
* the pick, by :func:`pick`: a candidate *qualifies* against a set of methods when, in
  every protocol, its gain over each of them has a lower bound above the margin, and in
  at least one protocol its gain over all of them is above zero after Holm's adjustment.
  The first qualifying candidate (in the plan's order, simplest first) against the
  controls is picked, and a later candidate replaces it only if it qualifies against it
  too; with none, the first control that qualifies against the fallback, else the
  fallback.

The results must come from one code (:mod:`~ilpss.experiments.provenance`).
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ilpss import metrics
from ilpss._io import atomic_write_bytes, read_json
from ilpss.experiments.compare import target_curves
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.methods import METHODS
from ilpss.experiments.protocols import PROTOCOLS
from ilpss.experiments.provenance import check_one_code, code_line
from ilpss.experiments.report_stats import threshold_for, windows
from ilpss.experiments.report_text import interval_text
from ilpss.experiments.run import run_experiment
from soccer_drill.constraints import ListOf, Name, OneOf, Real, Text, check_fields, check_keys

__all__ = ["Plan", "analyse", "main", "pick"]

PRIMARY = "total_reward_gain"


@dataclass(frozen=True)
class Plan:
    """A confirmatory run, as written down before it (the fields of the plan's JSON)."""

    methods: tuple[str, ...]
    """Every method the run learns (registered names)."""
    protocols: Mapping[str, Mapping[str, Any]]
    """Per protocol, the ``ExperimentConfig`` fields of its run (seeds, streams); the
    methods are :attr:`methods`, the baseline learning anew."""
    comparisons: tuple[tuple[str, str], ...]
    """``(method, against)`` pairs, each tested on the primary endpoint in every protocol:
    together, the family Holm's adjustment is taken over."""
    candidates: tuple[str, ...]
    """Methods that can be picked, simplest first."""
    controls: tuple[str, ...]
    """What a candidate must qualify against."""
    fallback: str
    """The pick when nothing qualifies."""
    margin: float = -15.0
    """The lowest lower bound of a gain that counts as no loss."""
    secondary: tuple[str, ...] = ("jumpstart", "final_gain", "largest_dip_gain",
                                  "time_to_threshold_ratio")
    """Metrics reported for every comparison, with plain intervals; not in the rule."""
    alpha: float = 0.05
    title: str = "The confirmatory run"
    """The page's heading."""

    def __post_init__(self) -> None:
        names = ListOf(Name(), min_len=1, unique=True)
        check_fields("Plan", self, {"methods": names, "candidates": names, "controls": names,
                                    "margin": Real(-1e6, 0.0), "alpha": Real(0.0, 0.5),
                                    "secondary": ListOf(OneOf(tuple(metrics.METRIC))),
                                    "title": Text()})
        for name in self.methods:
            METHODS.get(name)  # an unknown method: KeyError naming the known ones
        for field in ("candidates", "controls"):
            unknown = [m for m in getattr(self, field) if m not in self.methods]
            if unknown:
                raise ValueError(f"Plan.{field}: {unknown} are not among Plan.methods")
        if self.fallback not in self.controls:
            raise ValueError(f"Plan.fallback {self.fallback!r} must be one of Plan.controls")
        for method, against in self.comparisons:
            if method not in self.methods or against not in self.methods or method == against:
                raise ValueError(f"Plan.comparisons: ({method!r}, {against!r}) must pair two "
                                 "different methods of Plan.methods")
        for protocol in self.protocols:
            PROTOCOLS.get(protocol)

    @classmethod
    def read(cls, path: Path) -> Plan:
        """The plan in ``path`` (errors name the file)."""
        values = read_json(path)
        fields = ("methods", "protocols", "comparisons", "candidates", "controls", "fallback",
                  "margin", "secondary", "alpha", "title")
        try:
            if not isinstance(values, dict):
                raise ValueError("the plan must be a JSON object")
            check_keys("the plan", values, fields,
                       required=("methods", "protocols", "comparisons", "candidates",
                                 "controls", "fallback"))
            lists = {k: tuple(values[k]) for k in ("methods", "candidates", "controls",
                                                   "secondary") if k in values}
            pairs = tuple(tuple(pair) for pair in values["comparisons"])
            if any(len(pair) != 2 for pair in pairs):
                raise ValueError("comparisons must be [method, against] pairs")
            return cls(**{**values, **lists, "comparisons": pairs})
        except (ValueError, TypeError, KeyError) as exc:
            raise ValueError(f"{path}: {exc}") from exc

    def config(self, protocol: str) -> ExperimentConfig:
        """The configuration of one protocol's run."""
        return ExperimentConfig(protocol=protocol).with_overrides(
            **{**self.protocols[protocol], "methods": self.methods, "baseline": "scratch"})


@dataclass(frozen=True)
class Comparison:
    """One comparison in one protocol."""

    protocol: str
    method: str
    against: str
    estimates: dict[str, metrics.MetricEstimate]
    adjusted: float = float("nan")
    """The primary endpoint's p-value, Holm-adjusted across the whole family."""

    @property
    def gain(self) -> metrics.MetricEstimate:
        return self.estimates[PRIMARY]

    def mirrored(self) -> Comparison:
        """The same comparison the other way round (``against`` less ``method``): the
        primary gain negated with its interval, the same adjusted p-value."""
        g = self.gain
        gain = dataclasses.replace(g, value=-g.value, low=-g.high, high=-g.low)
        return Comparison(self.protocol, self.against, self.method, {PRIMARY: gain},
                          self.adjusted)


def analyse(plan: Plan, folders: Mapping[str, Path], *,
            allow_mixed_code: bool = False) -> tuple[list[Comparison], list[dict]]:
    """Every comparison of ``plan`` in every protocol (run folders ``folders``), the
    primary p-values Holm-adjusted together; and the code of each result read."""
    tests, codes = [], {}
    for protocol, folder in folders.items():
        found: dict[str, tuple[dict, str]] = {}
        by_method = {m: target_curves(folder, m, found) for m in plan.methods}
        codes.update(found)
        seeds = sorted(set.intersection(*(set(c) for c in by_method.values())))
        if len(seeds) < 2:
            raise ValueError(f"{folder}: need at least 2 seeds finished by every method, "
                             f"got {seeds}")
        curves = {m: np.array([c[s][0] for s in seeds]) for m, c in by_method.items()}
        for method, against in plan.comparisons:
            base = curves[against]
            first, last, window = windows(base.shape[1])
            estimates = metrics.compare(curves[method], base, first=first, last=last,
                                        threshold=threshold_for(base), window=window)
            tests.append(Comparison(protocol, method, against, estimates))
    check_one_code(codes, allow=allow_mixed_code)
    adjusted = metrics.holm([t.gain.p_value for t in tests])
    tests = [Comparison(t.protocol, t.method, t.against, t.estimates, float(p))
             for t, p in zip(tests, adjusted, strict=True)]
    return tests, [code for code, _ in codes.values()]


def qualifies(tests: Sequence[Comparison], method: str, against: Sequence[str], margin: float,
              alpha: float) -> bool:
    """Whether ``method`` gains over every one of ``against`` with a lower bound above
    ``margin`` in every protocol, and above zero after Holm's adjustment over all of
    them in at least one protocol (the comparisons must be in the family, either way
    round)."""
    protocols = sorted({t.protocol for t in tests})
    # A comparison written the other way round is the same paired test, mirrored.
    mine = {(t.protocol, t.method): t.mirrored() for t in tests if t.against == method}
    mine.update({(t.protocol, t.against): t for t in tests if t.method == method})
    missing = [(p, a) for p in protocols for a in against if (p, a) not in mine]
    if missing:
        raise ValueError(f"the plan's comparisons lack {method} against {missing}")
    no_loss = all(mine[p, a].gain.low > margin for p in protocols for a in against)
    shown = any(all(mine[p, a].gain.value > 0 and mine[p, a].adjusted < alpha for a in against)
                for p in protocols)
    return no_loss and shown


def pick(plan: Plan, tests: Sequence[Comparison]) -> tuple[str, list[str]]:
    """The method the rule picks, and the lines that say why."""
    said = []
    others = [c for c in plan.controls if c != plan.fallback]
    chosen = None
    for candidate in plan.candidates:
        ok = qualifies(tests, candidate, plan.controls, plan.margin, plan.alpha)
        said.append(f"- `{candidate}` against {', '.join(f'`{c}`' for c in plan.controls)}: "
                    f"{'qualifies' if ok else 'does not qualify'}.")
        if ok and chosen is None:
            chosen = candidate
        elif ok and qualifies(tests, candidate, [chosen], plan.margin, plan.alpha):
            said.append(f"- `{candidate}` qualifies against `{chosen}` too, and replaces it.")
            chosen = candidate
    if chosen is None:
        for control in others:
            ok = qualifies(tests, control, [plan.fallback], plan.margin, plan.alpha)
            said.append(f"- `{control}` against `{plan.fallback}`: "
                        f"{'qualifies' if ok else 'does not qualify'}.")
            if ok:
                chosen = control
                break
    return (plan.fallback if chosen is None else chosen), said


def page(plan: Plan, tests: Sequence[Comparison], codes: Sequence[dict]) -> list[str]:
    """The confirmatory page: the family's table, the secondary endpoints, the pick."""
    head = ["protocol", "method", "against", f"{metrics.METRIC[PRIMARY].label} [95% CI]",
            "p (Holm, whole family)",
            *(metrics.METRIC[e].label for e in plan.secondary)]
    lines = [
        f"# {plan.title}", "",
        code_line({"code": c} for c in codes), "",
        f"{len(tests)} tests in the family ({len(plan.comparisons)} comparisons x "
        f"{len(plan.protocols)} protocols), Holm-adjusted together; margin "
        f"{plan.margin:g}, alpha {plan.alpha:g}. Secondary endpoints: plain 95% intervals, "
        "not in the rule.", "",
        "| " + " | ".join(head) + " |", "|" + "---|" * len(head),
    ]
    for t in tests:
        cells = [t.protocol, f"`{t.method}`", f"`{t.against}`",
                 interval_text(t.gain, metrics.METRIC[PRIMARY].fmt), f"{t.adjusted:.2g}",
                 *(interval_text(t.estimates[e], metrics.METRIC[e].fmt)
                   for e in plan.secondary)]
        lines.append("| " + " | ".join(cells) + " |")
    chosen, said = pick(plan, tests)
    return [*lines, "", f"**The rule picks `{chosen}`.**", "", *said]


def main(argv: Sequence[str] | None = None) -> int:
    """Run (or resume) the plan's protocols and write the confirmatory page."""
    p = argparse.ArgumentParser(prog="ilpss-confirm", description=__doc__.splitlines()[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog=__doc__)
    p.add_argument("plan", help="the plan (JSON), committed before the run")
    p.add_argument("--runs", required=True, help="folder of the protocols' run folders")
    p.add_argument("--out", help="the page to write (default: <runs>/confirm.md)")
    p.add_argument("--analyse-only", action="store_true",
                   help="run nothing: analyse the finished runs")
    p.add_argument("--allow-mixed-code", action="store_true",
                   help="analyse results made by different code (the page names each)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    args = p.parse_args(argv)
    try:
        plan = Plan.read(Path(args.plan))
        folders = {protocol: Path(args.runs) / f"protocol_{protocol.lower()}"
                   for protocol in plan.protocols}
        if not args.analyse_only:
            for protocol, folder in folders.items():
                run_experiment(plan.config(protocol), folder, progress=not args.quiet,
                               allow_mixed_code=args.allow_mixed_code)
        tests, codes = analyse(plan, folders, allow_mixed_code=args.allow_mixed_code)
        out = Path(args.out) if args.out else Path(args.runs) / "confirm.md"
        atomic_write_bytes(out, ("\n".join(page(plan, tests, codes)) + "\n").encode())
    except (ValueError, KeyError, OSError) as exc:
        p.exit(1, f"{p.prog}: error: {exc}\n")
    print(f"confirmatory page: {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
