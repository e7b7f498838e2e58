"""A pre-registered confirmatory run: its family of tests, Holm across all of them, and the
pick rule applied as written.

    ilpss-confirm docs/decisive_test.json --runs results/decisive     # run (or resume), analyse
    ilpss-confirm docs/decisive_test.json --from-data docs/data/decisive_test --out page.md

The plan (:class:`~ilpss.experiments.plan.Plan`, a JSON file committed before the run) is
checked whole before anything runs, and its power is computed from its pilot figures
(:mod:`~ilpss.experiments.power`): a plan whose rule would pick a candidate with less
than its required probability, were the pilot effects true, is refused unless
``--force``. The command then runs (or resumes) each protocol's experiment into
``<runs>/protocol_<p>``, keeps the per-seed numbers of every run finished as the plan
says (``<runs>/seed_data``, or ``--data``: :class:`~ilpss.experiments.seed_data.SeedData`;
the committed copy is what the page in ``docs/`` is recomputed from) and writes one page:

* every test of the family on the primary endpoint (the total-reward gain, paired by
  seed): the estimate with its 95% interval, the t-test's p-value and the sign-flip
  permutation test's beside it, and the p-value Holm-adjusted across the *whole* family;
* the secondary endpoints and the plan's reported comparisons with plain, *unadjusted*
  intervals (marked so);
* the pick, by the plan's rule.

``--analyse-only`` runs nothing; like every analysis it refuses run folders whose
configuration is not the plan's or whose planned seeds are not all finished, and the page
says which seeds it used. The results must come from one code
(:mod:`~ilpss.experiments.provenance`). The folder of runs records the plan it is made
for (``<runs>/plan.json``, at its first use), so a plan edited after its runs is refused
rather than analysed as if committed before them; the page names the plan by its
file and the SHA-256 of its canonical JSON.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import zlib
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ilpss import metrics
from ilpss._io import FolderInUseError, atomic_write_bytes, canonical_json, json_differences
from ilpss.experiments.checkpoints import StorageError
from ilpss.experiments.drill_facts import TEAM_ERROR, drill_exception
from ilpss.experiments.executor import stop_on_sigterm, stopped_in_one_line
from ilpss.experiments.outputs import check_out_file, description
from ilpss.experiments.plan import PRIMARY, Plan, Qualify, TestSpec
from ilpss.experiments.power import PowerReport, plan_power, power_lines
from ilpss.experiments.provenance import check_one_code, code_line
from ilpss.experiments.report_stats import threshold_for, windows
from ilpss.experiments.report_text import interval_text
from ilpss.experiments.run import JobError, run_experiment
from ilpss.experiments.seed_data import SeedData, data_paths, seed_ranges
from soccer_drill.files import read_digested_json, write_digested_json

__all__ = ["analyse", "main", "pick"]


@dataclass(frozen=True)
class Comparison:
    """One comparison in one protocol: a test of the family, or a reported comparison."""

    protocol: str
    method: str
    against: str
    estimates: dict[str, metrics.MetricEstimate]
    adjusted: float = float("nan")
    """The primary endpoint's p-value, Holm-adjusted across the whole family."""
    name: str = ""
    margin: float = 0.0
    alternative: str = "two-sided"
    p: float = float("nan")
    """The t-test's p-value of the test (one-sided against the margin, or two-sided)."""
    p_flip: float = float("nan")
    """The sign-flip permutation test's p-value of the same hypothesis."""
    in_family: bool = True
    alpha: float = 0.05

    @property
    def gain(self) -> metrics.MetricEstimate:
        return self.estimates[PRIMARY]

    @property
    def shown(self) -> bool:
        """Whether the test is shown after Holm's adjustment (a one-sided test: the gain
        is above the margin)."""
        return self.in_family and self.adjusted < self.alpha


def pick(plan: Plan, tests: Sequence[Comparison]) -> tuple[str, list[str]]:
    """The method the plan's rule picks, and the lines that say why."""
    return plan.rule.pick(plan, [t for t in tests if t.in_family])


# ---------------------------------------------------------------------- analysis
def check_data(plan: Plan, data: SeedData) -> None:
    """Refuse per-seed numbers that are not the plan's runs: another configuration, or a
    planned seed missing (``ValueError`` naming the protocol and what differs)."""
    for protocol in plan.protocols:
        if protocol not in data.configs:
            raise ValueError(f"protocol {protocol}: no results (the data hold "
                             f"{sorted(data.configs)})")
        diffs = json_differences(data.configs[protocol].results_record(),
                                 plan.config(protocol).results_record(), "config")
        if diffs:
            raise ValueError(f"protocol {protocol}: the results come from another "
                             f"configuration than the plan's ({'; '.join(diffs)})")
        missing = sorted(set(plan.config(protocol).seeds) - set(data.seeds(protocol)))
        if missing:
            raise ValueError(f"protocol {protocol}: planned seeds {seed_ranges(missing)} are "
                             "not finished")


def analyse(plan: Plan, data: SeedData, *, allow_mixed_code: bool = False) -> list[Comparison]:
    """Every test of the family (p-values Holm-adjusted together) and every reported
    comparison, from the per-seed numbers ``data`` (checked with :func:`check_data`)."""
    check_data(plan, data)
    codes = {c["source_digest"]: (c, "the per-seed data") for c in data.codes()}
    check_one_code(codes, allow=allow_mixed_code)
    curves = {p: {m: _matrix(data, p, m) for m in plan.runs[p].methods} for p in plan.protocols}
    reads_flip = plan.p_value == "sign_flip"
    out = []
    for specs in plan.groups().values():  # Holm within each family of tests
        tests = [_compare(curves, spec, plan) for spec in specs]
        adjusted = metrics.holm([t.p_flip if reads_flip else t.p for t in tests])
        out += [_replace(t, adjusted=float(a)) for t, a in zip(tests, adjusted, strict=True)]
    for method, against in plan.reported:
        for protocol in plan.protocols:
            if {method, against} <= set(plan.runs[protocol].methods):
                spec = TestSpec(f"{protocol}: {method} - {against}", protocol, method,
                                against, alternative="two-sided")
                out.append(_replace(_compare(curves, spec, plan), in_family=False))
    return out


def _matrix(data: SeedData, protocol: str, method: str) -> np.ndarray:
    by_seed = data.seed_curves(protocol, method)
    return np.array([by_seed[s] for s in sorted(by_seed)])


def _compare(curves: dict, spec: TestSpec, plan: Plan) -> Comparison:
    ours, base = curves[spec.protocol][spec.method], curves[spec.protocol][spec.against]
    first, last, window = windows(base.shape[1])
    estimates = metrics.compare(ours, base, first=first, last=last,
                                threshold=threshold_for(base), window=window)
    diffs = ours.sum(axis=1) - base.sum(axis=1)
    # A resampling seed of the test's own: the same page from the same numbers.
    flip_seed = zlib.crc32(spec.name.encode())
    return Comparison(
        spec.protocol, spec.method, spec.against, estimates, name=spec.name,
        margin=spec.margin, alternative=spec.alternative,
        p=float(metrics.t_test_pvalue(diffs, spec.margin, spec.alternative)),
        p_flip=metrics.sign_flip_pvalue(diffs, spec.margin, spec.alternative, seed=flip_seed),
        alpha=plan.alpha)


def _replace(c: Comparison, **changes: object) -> Comparison:
    return replace(c, **changes)


# ---------------------------------------------------------------------- the page
def page(plan: Plan, tests: Sequence[Comparison], data: SeedData,
         power: PowerReport | None = None) -> list[str]:
    """The confirmatory page: the seeds, the family's table, the secondary endpoints and
    reported comparisons (unadjusted), the pick."""
    family = [t for t in tests if t.in_family]
    seeds = "; ".join(f"{p}: {len(data.seeds(p))} seeds ({seed_ranges(data.seeds(p))})"
                      for p in plan.protocols)
    lines = [f"# {plan.title}", "", code_line({"code": c} for c in data.codes()), "",
             f"Seeds used (every planned seed finished): {seeds}.", ""]
    lines += _family_lines(plan, family)
    if plan.secondary and not isinstance(plan.rule, Qualify):  # the first form: columns
        lines += ["", "Secondary endpoints of the family's comparisons (plain 95% intervals, "
                  "**unadjusted**, not in the rule):", ""]
        head = ["protocol", "method", "against", *(metrics.METRIC[e].label
                                                  for e in plan.secondary)]
        lines += _table(head, [[t.protocol, f"`{t.method}`", f"`{t.against}`",
                                *(interval_text(t.estimates[e], metrics.METRIC[e].fmt)
                                  for e in plan.secondary)] for t in family])
    reported = [t for t in tests if not t.in_family]
    if reported:
        lines += ["", "Reported comparisons, outside the family (95% intervals and two-sided "
                  "p-values **unadjusted**):", ""]
        head = ["protocol", "method", "against", f"{metrics.METRIC[PRIMARY].label} [95% CI]",
                "p (t)", "p (sign-flip)", *(metrics.METRIC[e].label for e in plan.secondary)]
        lines += _table(head, [[t.protocol, f"`{t.method}`", f"`{t.against}`",
                                interval_text(t.gain, metrics.METRIC[PRIMARY].fmt),
                                _p(t.p), _p(t.p_flip),
                                *(interval_text(t.estimates[e], metrics.METRIC[e].fmt)
                                  for e in plan.secondary)] for t in reported])
    if power is not None:
        lines += ["", *power_lines(plan, power)]
    chosen, said = pick(plan, family)
    return [*lines, "", f"**The rule picks `{chosen}`.**", "", *said]


def _family_lines(plan: Plan, family: Sequence[Comparison]) -> list[str]:
    if isinstance(plan.rule, Qualify):
        lines = [f"{len(family)} tests in the family ({len(plan.comparisons)} comparisons x "
                 f"{len(plan.protocols)} protocols), two-sided, Holm-adjusted together; margin "
                 f"{plan.rule.margin:g}, alpha {plan.alpha:g}. Secondary endpoints: plain 95% "
                 "intervals, **unadjusted**, not in the rule.", ""]
        head = ["protocol", "method", "against", f"{metrics.METRIC[PRIMARY].label} [95% CI]",
                "p (Holm, whole family)", "p (t)", "p (sign-flip)",
                *(metrics.METRIC[e].label for e in plan.secondary)]
        return lines + _table(head, [[t.protocol, f"`{t.method}`", f"`{t.against}`",
                                      interval_text(t.gain, metrics.METRIC[PRIMARY].fmt),
                                      f"{t.adjusted:.2g}", _p(t.p), _p(t.p_flip),
                                      *(interval_text(t.estimates[e], metrics.METRIC[e].fmt)
                                        for e in plan.secondary)]
                                     for t in family])
    reads = "Student t" if plan.p_value == "t" else "sign-flip permutation"
    sizes = ", ".join(f"`{g}` {len(ts)}" for g, ts in plan.groups().items())
    lines = [f"{len(family)} one-sided tests in {len(plan.groups())} famil"
             f"{'y' if len(plan.groups()) == 1 else 'ies'} ({sizes}), each family "
             f"Holm-adjusted on its own on the {reads} p-values; a test is *shown* when its "
             f"adjusted p is below {plan.alpha:g} (for a gain: the simultaneous lower bound "
             "above 0; for no loss: above the margin).", ""]
    head = ["test", "family", "protocol", "method", "against", "null hypothesis",
            f"{metrics.METRIC[PRIMARY].label} [95% CI]", "p (t)", "p (sign-flip)",
            "p (Holm)", "shown", "pilot effect (sd)"]
    specs = {s.name: s for s in plan.family}
    rows = []
    for t in family:
        pilot = specs[t.name].pilot
        rows.append([t.name, f"`{specs[t.name].group}`", t.protocol, f"`{t.method}`",
                     f"`{t.against}`",
                     f"gain <= {t.margin:g}",
                     interval_text(t.gain, metrics.METRIC[PRIMARY].fmt), _p(t.p),
                     _p(t.p_flip), _p(t.adjusted), "**yes**" if t.shown else "no",
                     "-" if pilot is None else f"{pilot.effect:+.1f} ({pilot.sd:.1f})"])
    return lines + _table(head, rows)


def _table(head: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    return ["| " + " | ".join(head) + " |", "|" + "---|" * len(head),
            *("| " + " | ".join(row) + " |" for row in rows)]


def _p(p: float) -> str:
    return "n/a" if math.isnan(p) else f"{p:.2g}"


# ---------------------------------------------------------------------- command
PLAN_RECORD = "plan.json"
"""The plan a folder of runs was made for (``<runs>/plan.json``: the plan and its digest)."""


def plan_digest(plan_path: Path) -> str:
    """The SHA-256 of the plan's JSON, canonical (keys sorted, no spaces): what the page
    and the runs' record name it by."""
    plan = json.loads(plan_path.read_bytes())
    return hashlib.sha256(canonical_json(plan).encode()).hexdigest()


def bind_plan(runs: Path, plan_path: Path) -> None:
    """Record in ``runs`` the plan its runs are made for, the first time; refuse another
    plan after (a plan edited after its runs, or another plan's, would be analysed as if
    it had been committed before them).

    Raises
    ------
    ValueError
        The plan differs from the one recorded: where, and what to do.
    """
    plan = json.loads(plan_path.read_bytes())
    record = runs / PLAN_RECORD
    if not record.exists():
        runs.mkdir(parents=True, exist_ok=True)
        write_digested_json(record, {"schema_version": 1, "plan": plan,
                                     "sha256": plan_digest(plan_path)})
        return
    kept = read_digested_json(record, 1)
    if kept["plan"] != plan:
        changes = "; ".join(json_differences(kept["plan"], plan)[:5])
        raise ValueError(f"{plan_path}: not the plan the runs in {runs} were made for "
                         f"({record}: sha256 {str(kept['sha256'])[:12]}...); it differs: "
                         f"{changes} (a plan is fixed before its runs: give the plan they "
                         "were made for, or another --runs folder)")


def _outside(path: Path, folders: dict[str, Path], flag: str) -> Path:
    """``path``, unless it is inside one of the protocols' run ``folders`` (whose files
    the runs and their resumption read)."""
    for folder in folders.values():
        if path.resolve().is_relative_to(folder.resolve()):
            raise ValueError(f"{flag} {path}: inside the run folder {folder}, whose files "
                             "the runs keep; write outside it")
    return path


def main(argv: Sequence[str] | None = None) -> int:
    """Run (or resume) the plan's protocols and write the confirmatory page."""
    with stopped_in_one_line("ilpss-confirm"):  # Ctrl-C or SIGTERM: one line, 130 or 143
        return _main(argv)


def _main(argv: Sequence[str] | None) -> int:
    p = argparse.ArgumentParser(prog="ilpss-confirm", description=description(__doc__),
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog=__doc__)
    p.add_argument("plan", help="the plan (JSON), committed before the run")
    p.add_argument("--runs", help="folder of the protocols' run folders (run or resumed "
                                  "unless --analyse-only)")
    p.add_argument("--from-data", metavar="STEM",
                   help="analyse the committed per-seed numbers STEM.csv.gz and STEM.json "
                        "instead of run folders (nothing is run)")
    p.add_argument("--data", metavar="STEM",
                   help="where to keep the per-seed numbers of the runs (default: "
                        "<runs>/seed_data)")
    p.add_argument("--out", help="the page to write (default: <runs>/confirm.md, or "
                                 "STEM.md with --from-data)")
    p.add_argument("--analyse-only", action="store_true",
                   help="run nothing: analyse the finished runs")
    p.add_argument("--force", action="store_true",
                   help="run a plan whose power is below its required_power")
    p.add_argument("--allow-mixed-code", action="store_true",
                   help="analyse results made by different code (the page names each)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    args = p.parse_args(argv)
    if (args.runs is None) == (args.from_data is None):
        p.error("give exactly one of --runs and --from-data")
    try:
        plan = Plan.read(Path(args.plan))
        power = None
        if plan.form >= 2:
            power = plan_power(plan)
            weak = power.below(plan.required_power)
            if weak and not args.force and args.from_data is None and not args.analyse_only:
                p.exit(1, f"{p.prog}: error: the plan's power is below its required "
                          f"{plan.required_power:.0%}: " + "; ".join(weak) +
                          " (--force runs it anyway)\n")
        if args.from_data is not None:
            out = check_out_file(args.out or args.from_data + ".md", "--out", ".md",
                                 [args.plan, *data_paths(args.from_data)])
            data = SeedData.read(args.from_data)
        else:
            runs = Path(args.runs)
            if args.analyse_only and not runs.is_dir():  # nothing to analyse: make nothing
                raise ValueError(f"--runs {runs}: no such folder of runs to analyse "
                                 "(--analyse-only runs nothing)")
            folders = {protocol: runs / f"protocol_{protocol.lower()}"
                       for protocol in plan.protocols}
            # every output checked before any run: none may be the plan or a run's file
            out = _outside(check_out_file(args.out or runs / "confirm.md", "--out", ".md",
                                          [args.plan]), folders, "--out")
            stem = args.data if args.data else runs / "seed_data"
            for path in data_paths(stem):
                _outside(check_out_file(path, "--data", inputs=[args.plan, runs / PLAN_RECORD]),
                         folders, "--data")
            bind_plan(runs, Path(args.plan))
            if not args.analyse_only:
                stop_on_sigterm()
                for protocol, folder in folders.items():
                    run_experiment(plan.config(protocol), folder, progress=not args.quiet,
                                   allow_mixed_code=args.allow_mixed_code)
            data = SeedData.from_runs(folders)
            check_data(plan, data)
            data.write(stem)
        tests = analyse(plan, data, allow_mixed_code=args.allow_mixed_code)
        lines = page(plan, tests, data, power)
        lines[1:1] = ["", f"Plan: `{Path(args.plan).name}` (sha256 of its canonical JSON "
                          f"`{plan_digest(Path(args.plan))[:16]}`)."]
        atomic_write_bytes(out, ("\n".join(lines) + "\n").encode())
    except (ValueError, KeyError, OSError, FolderInUseError, StorageError, JobError,
            drill_exception(TEAM_ERROR)) as exc:
        # a bad plan or file, a full disk, another run's folder, a failed job (the finished
        # ones kept), a team that fails to load
        p.exit(1, f"{p.prog}: error: {exc}\n")
    print(f"confirmatory page: {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
