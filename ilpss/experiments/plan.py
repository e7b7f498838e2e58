"""A pre-registered plan: what a confirmatory run learns, which tests form its family, the
rule that picks a method from them, and the pilot figures its power rests on.

A plan is a JSON file committed before its run. :meth:`Plan.read` checks all of it before
anything runs (every protocol's configuration built, every test's methods run in its
protocol, every test the rule reads in the family), so that a mistake costs a message,
not hours of runs.

Two forms are read:

* ``"schema": "ilpss.plan/2"`` (the current form). Per protocol, its configuration and
  its own methods. The *family* is a list of named one-sided tests, each of one method
  against another in one protocol on the primary endpoint (the total-reward gain, paired
  by seed), against a *margin*: ``0`` tests a gain; a negative margin tests no loss
  beyond it (non-inferiority). Each test carries the pilot figures (effect and standard
  deviation of the per-seed differences on development seeds) that its power is computed
  from (:mod:`~ilpss.experiments.power`). The rule (:class:`RequiredTests`) picks the
  first candidate whose required tests are all *shown*: Holm-adjusted one-sided p below
  ``alpha`` across the family. ``reported`` comparisons are shown on the page with
  unadjusted intervals, outside the family.
* The first form (no ``schema``), in which every comparison is tested in every protocol,
  two-sided, and the rule (:class:`Qualify`) asks a candidate for a lower bound above a
  margin against every control everywhere and a gain shown somewhere. The confirmatory
  run and the sharp test were planned so; their plans are read as they were run.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from ilpss import metrics
from ilpss._io import read_json
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.methods import METHODS
from ilpss.experiments.protocols import PROTOCOLS
from ilpss.metrics.inference import ALTERNATIVES
from soccer_drill.constraints import (
    Integer,
    JsonObject,
    ListOf,
    Name,
    OneOf,
    Real,
    Text,
    check,
    check_fields,
    check_keys,
)

__all__ = ["Plan"]

PRIMARY = "total_reward_gain"
SCHEMA = "ilpss.plan/2"
TITLE = Text(one_line=True, max_len=200)
METHOD_NAMES = ListOf(Name(), min_len=1, unique=True, kinds=(list,))
P_VALUES = ("t", "sign_flip")
"""Which p-value the rule reads: Student t, or the sign-flip permutation test."""


@dataclass(frozen=True)
class Pilot:
    """A test's figures on development seeds: the mean and standard deviation of the
    per-seed differences, and how many seeds gave them."""

    effect: float
    sd: float
    seeds: int

    def __post_init__(self) -> None:
        check_fields("Pilot", self, {"effect": Real(-1e6, 1e6), "sd": Real(0.0, 1e6, True),
                                     "seeds": Integer(2, 100_000)})


@dataclass(frozen=True)
class TestSpec:
    """One test of the family: ``method`` against ``against`` in ``protocol``, on the
    primary endpoint, paired by seed."""

    __test__ = False  # not a test class to pytest, whatever its name

    name: str
    protocol: str
    method: str
    against: str
    margin: float = 0.0
    """The null hypothesis is "the gain is at most ``margin``": 0 tests a gain, a negative
    margin no loss beyond it."""
    alternative: str = "greater"
    """``"greater"`` (one-sided, the current form) or ``"two-sided"`` (the first form)."""
    pilot: Pilot | None = None
    group: str = "main"
    """The family of tests Holm's adjustment is taken over (a plan may hold several: one
    for its pick rule, one for a question the rule does not read)."""

    def __post_init__(self) -> None:
        check_fields("TestSpec", self, {"name": Text(one_line=True, max_len=100),
                                        "group": Name(),
                                        "margin": Real(-1e6, 0.0),
                                        "alternative": OneOf(ALTERNATIVES)})
        if self.method == self.against:
            raise ValueError(f"test {self.name!r}: a method against itself ({self.method!r})")

    @property
    def kind(self) -> str:
        """In words: a gain, no loss beyond the margin, or a difference."""
        if self.alternative == "two-sided":
            return "difference"
        return "gain" if self.margin == 0 else f"no loss beyond {self.margin:g}"


class TestOutcome(Protocol):
    """What a rule reads of a test's outcome (:class:`~ilpss.experiments.confirm.Comparison`,
    or a simulated one)."""

    protocol: str
    method: str
    against: str
    adjusted: float

    @property
    def gain(self) -> metrics.MetricEstimate: ...


@dataclass(frozen=True)
class RequiredTests:
    """The first candidate whose every required test is shown (Holm-adjusted p below the
    plan's alpha) is picked; with none, the fallback."""

    candidates: tuple[tuple[str, tuple[str, ...]], ...]
    """``(method, names of the family's tests it requires)``, in the order tried."""
    fallback: str

    def check(self, plan: Plan) -> None:
        names = {t.name for t in plan.family}
        every = plan.every_method()
        for method, requires in self.candidates:
            if method not in every:
                raise ValueError(f"rule: candidate {method!r} is run in no protocol")
            if not requires:
                raise ValueError(f"rule: candidate {method!r} requires no test: a rule that "
                                 "picks it whatever the run says is not a test of it")
            unknown = [r for r in requires if r not in names]
            if unknown:
                raise ValueError(f"rule: candidate {method!r} requires {unknown}, which are not "
                                 f"tests of the family {sorted(names)}")
        if self.fallback not in every:
            raise ValueError(f"rule: the fallback {self.fallback!r} is run in no protocol")

    def pick_from(self, shown: Mapping[str, bool]) -> str:
        """The method picked when the family's tests are shown as ``shown`` (by name)."""
        for method, requires in self.candidates:
            if all(shown[r] for r in requires):
                return method
        return self.fallback

    def pick(self, plan: Plan, outcomes: Sequence[Any]) -> tuple[str, list[str]]:
        shown = {o.name: o.shown for o in outcomes if o.in_family}
        said = []
        for method, requires in self.candidates:
            missing = [r for r in requires if not shown[r]]
            said.append(f"- `{method}`: " + ("every required test is shown." if not missing
                                             else f"not shown: {', '.join(missing)}."))
        return self.pick_from(shown), said

    def to_json(self) -> dict[str, Any]:
        return {"candidates": [{"method": m, "requires": list(r)} for m, r in self.candidates],
                "fallback": self.fallback}


@dataclass(frozen=True)
class Qualify:
    """The first form's rule: a candidate *qualifies* against a set of methods when, in
    every protocol, its gain over each of them has a lower bound above ``margin``, and in
    at least one protocol its gain over every one of them is above zero after the
    family's Holm adjustment. The first qualifying candidate against the controls is
    picked, and a later candidate replaces it only if it qualifies against it too; with
    none, the first control that qualifies against the fallback, else the fallback."""

    candidates: tuple[str, ...]
    controls: tuple[str, ...]
    fallback: str
    margin: float = -15.0

    def check(self, plan: Plan) -> None:
        every = plan.every_method()
        for name in ("candidates", "controls"):
            unknown = [m for m in getattr(self, name) if m not in every]
            if unknown:
                raise ValueError(f"Plan.{name}: {unknown} are not among Plan.methods")
        check("Plan.fallback (one of Plan.controls)", self.fallback, OneOf(self.controls))
        check("Plan.margin", self.margin, Real(-1e6, 0.0))
        pairs = {(t.method, t.against) for t in plan.family}
        pairs |= {(a, m) for m, a in pairs}
        needed = [(c, k) for c in self.candidates for k in self.controls if c != k]
        needed += [(k, self.fallback) for k in self.controls if k != self.fallback]
        missing = [p for p in needed if p not in pairs]
        if missing:
            raise ValueError(f"Plan.comparisons lack {missing}, which the pick rule reads")

    def qualifies(self, outcomes: Sequence[TestOutcome], method: str,
                  against: Sequence[str], alpha: float) -> bool:
        """Whether ``method`` qualifies against ``against`` (see the class docstring)."""
        protocols = sorted({t.protocol for t in outcomes})
        mine: dict[tuple[str, str], Any] = {}
        for t in outcomes:
            if t.against == method:  # the same paired test, mirrored
                mine[t.protocol, t.method] = _Mirrored(t)
            elif t.method == method:
                mine[t.protocol, t.against] = t
        missing = [(p, a) for p in protocols for a in against if (p, a) not in mine]
        if missing:
            raise ValueError(f"the plan's comparisons lack {method} against {missing}")
        no_loss = all(mine[p, a].gain.low > self.margin for p in protocols for a in against)
        shown = any(all(mine[p, a].gain.value > 0 and mine[p, a].adjusted < alpha
                        for a in against) for p in protocols)
        return no_loss and shown

    def pick(self, plan: Plan, outcomes: Sequence[TestOutcome]) -> tuple[str, list[str]]:
        said = []
        chosen = None
        for candidate in self.candidates:
            ok = self.qualifies(outcomes, candidate, self.controls, plan.alpha)
            said.append(f"- `{candidate}` against {', '.join(f'`{c}`' for c in self.controls)}: "
                        f"{'qualifies' if ok else 'does not qualify'}.")
            if ok and chosen is None:
                chosen = candidate
            elif ok and self.qualifies(outcomes, candidate, [chosen], plan.alpha):
                said.append(f"- `{candidate}` qualifies against `{chosen}` too, and replaces it.")
                chosen = candidate
        if chosen is None:
            for control in (c for c in self.controls if c != self.fallback):
                ok = self.qualifies(outcomes, control, [self.fallback], plan.alpha)
                said.append(f"- `{control}` against `{self.fallback}`: "
                            f"{'qualifies' if ok else 'does not qualify'}.")
                if ok:
                    chosen = control
                    break
        return (self.fallback if chosen is None else chosen), said


@dataclass(frozen=True)
class _Mirrored:
    """A test read the other way round: the gain negated with its interval."""

    outcome: Any

    @property
    def gain(self) -> metrics.MetricEstimate:
        g = self.outcome.gain
        return metrics.MetricEstimate(g.name, -g.value, -g.high, -g.low, g.n, g.definition,
                                      g.confidence, g.interval, g.p_value)

    @property
    def adjusted(self) -> float:
        return self.outcome.adjusted


PLAN_SEEDS = Integer(2)
"""A plan protocol's seeds: its tests are intervals over seeds, which need two."""


@dataclass(frozen=True)
class ProtocolRun:
    """One protocol of a plan: the fields of its ``ExperimentConfig`` and its methods."""

    protocol: str
    settings: Mapping[str, Any]
    methods: tuple[str, ...]
    baseline: str = "scratch"

    def config(self) -> ExperimentConfig:
        """The configuration of this protocol's run (checked)."""
        return ExperimentConfig(protocol=self.protocol).with_overrides(
            **{**self.settings, "methods": self.methods, "baseline": self.baseline})


@dataclass(frozen=True)
class Plan:
    """A confirmatory run, as written down before it."""

    title: str
    runs: Mapping[str, ProtocolRun]
    family: tuple[TestSpec, ...]
    rule: RequiredTests | Qualify
    alpha: float = 0.05
    secondary: tuple[str, ...] = ("jumpstart", "final_gain", "largest_dip_gain",
                                  "time_to_threshold_ratio")
    reported: tuple[tuple[str, str], ...] = ()
    """Comparisons shown on the page beside the family, with unadjusted intervals."""
    p_value: str = "t"
    required_power: float = 0.8
    """The least probability, at the pilot effects, that the rule picks each candidate;
    a plan below it is refused unless forced."""
    form: int = 2
    baseline: str = "scratch"
    extra: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        check_fields("Plan", self, {
            "title": TITLE, "alpha": Real(0.0, 0.5, True),
            "secondary": ListOf(OneOf(tuple(metrics.METRIC))),
            "p_value": OneOf(P_VALUES), "required_power": Real(0.0, 1.0)})
        if not self.runs:
            raise ValueError("Plan.protocols must name at least one protocol")
        names = [t.name for t in self.family]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ValueError(f"Plan.tests: test names must be distinct, {twice} repeat")
        for t in self.family:
            run = self.runs.get(t.protocol)
            if run is None:
                raise ValueError(f"test {t.name!r}: protocol {t.protocol!r} is not among the "
                                 f"plan's protocols {sorted(self.runs)}")
            for m in (t.method, t.against):
                if m not in run.methods:
                    raise ValueError(f"test {t.name!r}: method {m!r} is not run in protocol "
                                     f"{t.protocol} (its methods: {list(run.methods)})")
        for m, a in self.reported:
            if not any(m in r.methods and a in r.methods for r in self.runs.values()):
                raise ValueError(f"Plan.reported: no protocol runs both {m!r} and {a!r}")
        self.rule.check(self)

    # ------------------------------------------------------------------ reading
    @classmethod
    def read(cls, path: Path) -> Plan:
        """The plan in ``path``, checked whole (errors name the file)."""
        values = read_json(path)  # its errors name the file already
        try:
            return cls.from_json(values)
        except (ValueError, TypeError, KeyError) as exc:
            raise ValueError(f"{path}: {exc}") from exc

    @classmethod
    def from_json(cls, values: Any) -> Plan:
        """The plan that the JSON value ``values`` writes down, checked whole."""
        check("the plan", values, JsonObject())
        if "schema" in values:
            if values["schema"] != SCHEMA:
                raise ValueError(f"schema {values['schema']!r} is not {SCHEMA!r}")
            return cls._from_v2(values)
        return cls._from_v1(values)

    @classmethod
    def _from_v2(cls, values: dict[str, Any]) -> Plan:
        check_keys("the plan", values, ("schema", "title", "protocols", "tests", "rule",
                                        "reported", "alpha", "p_value", "secondary",
                                        "required_power", "baseline"),
                   required=("schema", "title", "protocols", "tests", "rule"))
        baseline = values.get("baseline", "scratch")
        runs = _runs(values["protocols"], None, baseline)
        family = tuple(_test(i, t) for i, t in enumerate(_list(values["tests"], "tests")))
        rule_values = values["rule"]
        check("rule", rule_values, JsonObject("candidates and fallback"))
        check_keys("rule", rule_values, ("candidates", "fallback"))
        candidates = []
        for i, c in enumerate(_list(rule_values["candidates"], "rule.candidates")):
            check(f"rule.candidates[{i}]", c, JsonObject())
            check_keys(f"rule.candidates[{i}]", c, ("method", "requires"))
            check(f"rule.candidates[{i}].requires", c["requires"],
                  ListOf(Text(one_line=True), min_len=1, unique=True, kinds=(list,)))
            candidates.append((c["method"], tuple(c["requires"])))
        rule = RequiredTests(tuple(candidates), rule_values["fallback"])
        reported = tuple(_pair(p, f"reported[{i}] (pairs [method, against])")
                         for i, p in enumerate(_list(values.get("reported", []), "reported")))
        return cls(title=values["title"], runs=runs, family=family, rule=rule,
                   alpha=values.get("alpha", 0.025),
                   secondary=tuple(_list(values.get("secondary", []), "secondary")),
                   reported=reported, p_value=values.get("p_value", "t"),
                   required_power=values.get("required_power", 0.8), form=2,
                   baseline=baseline)

    @classmethod
    def _from_v1(cls, values: dict[str, Any]) -> Plan:
        check_keys("the plan", values, ("methods", "protocols", "comparisons", "candidates",
                                        "controls", "fallback", "margin", "secondary", "alpha",
                                        "title"),
                   required=("methods", "protocols", "comparisons", "candidates", "controls",
                             "fallback"))
        check("Plan.methods", values["methods"], METHOD_NAMES)
        for name in ("candidates", "controls"):
            check(f"Plan.{name}", values[name], METHOD_NAMES)
        methods = tuple(values["methods"])
        runs = _runs(values["protocols"], methods, "scratch")
        pairs = [_pair(p, f"comparisons[{i}] (pairs [method, against])")
                 for i, p in enumerate(_list(values["comparisons"], "comparisons"))]
        family = tuple(TestSpec(f"{p}: {m} - {a}", p, m, a, alternative="two-sided")
                       for p in runs for m, a in pairs)
        rule = Qualify(tuple(values["candidates"]), tuple(values["controls"]),
                       values["fallback"], values.get("margin", -15.0))
        return cls(title=values.get("title", "The confirmatory run"), runs=runs,
                   family=family, rule=rule, alpha=values.get("alpha", 0.05),
                   secondary=tuple(_list(values.get("secondary", list(cls.secondary)),
                                         "secondary")),
                   form=1, required_power=0.0)

    # ------------------------------------------------------------------ views
    @property
    def protocols(self) -> tuple[str, ...]:
        """The protocols, in the plan's order."""
        return tuple(self.runs)

    def every_method(self) -> tuple[str, ...]:
        """Every method run in some protocol, in first-met order."""
        seen: dict[str, None] = {}
        for run in self.runs.values():
            seen.update(dict.fromkeys(run.methods))
        return tuple(seen)

    @property
    def methods(self) -> tuple[str, ...]:
        return self.every_method()

    def groups(self) -> dict[str, list[TestSpec]]:
        """The families of tests, each adjusted by Holm on its own, in first-met order."""
        out: dict[str, list[TestSpec]] = {}
        for t in self.family:
            out.setdefault(t.group, []).append(t)
        return out

    @property
    def fallback(self) -> str:
        """What the rule picks when no candidate qualifies."""
        return self.rule.fallback

    @property
    def comparisons(self) -> tuple[tuple[str, str], ...]:
        """The distinct ``(method, against)`` pairs of the family."""
        return tuple(dict.fromkeys((t.method, t.against) for t in self.family))

    def config(self, protocol: str) -> ExperimentConfig:
        """The configuration of one protocol's run."""
        return self.runs[protocol].config()


def _list(value: Any, where: str) -> list:
    if not isinstance(value, list):
        raise ValueError(f"{where} must be a list, got {type(value).__name__}")
    return value


def _pair(value: Any, where: str) -> tuple[str, str]:
    check(where, value, ListOf(Name(), min_len=2, max_len=2, kinds=(list,)))
    if value[0] == value[1]:
        raise ValueError(f"{where}: ({value[0]!r}, {value[1]!r}) must pair two different "
                         "methods")
    return value[0], value[1]


def _runs(protocols: Any, methods: tuple[str, ...] | None,
          baseline: str) -> dict[str, ProtocolRun]:
    """Every protocol's run, its configuration built (so checked) here."""
    check("protocols", protocols, JsonObject("protocols by name", min_len=1))
    runs = {}
    for name, settings in protocols.items():
        PROTOCOLS.get(name)  # unknown: KeyError naming the known ones
        where = f"protocols.{name}"
        check(where, settings, JsonObject("ExperimentConfig fields"))
        settings = dict(settings)
        if settings.pop("protocol", name) != name:
            raise ValueError(f"{where}: holds protocol {protocols[name]['protocol']!r}; a "
                             "protocol's entry runs that protocol (leave 'protocol' out)")
        own = settings.pop("methods", None)
        if methods is not None and own is not None:
            raise ValueError(f"{where}: methods are the plan's (Plan.methods) in this form")
        run_methods = methods if own is None else own
        if run_methods is None:
            raise ValueError(f"{where}: name its methods")
        check(f"{where}.methods", list(run_methods) if isinstance(run_methods, tuple)
              else run_methods, METHOD_NAMES)
        for m in run_methods:
            METHODS.get(m)  # unknown: KeyError naming the known ones
        if baseline not in run_methods:
            raise ValueError(f"{where}.methods must include the baseline {baseline!r}")
        if "storage" in settings:  # a data file never leads a write outside its folder
            raise ValueError(f"{where}.storage: where checkpoints are written is not a plan's "
                             "to say; a plan's runs keep them in their run folders")
        allowed = {f for f in ExperimentConfig.__dataclass_fields__} - {"methods",
                                                                       "baseline", "protocol"}
        check_keys(where, settings, allowed, required=())
        run = ProtocolRun(name, settings, tuple(run_methods), baseline)
        try:
            cfg = run.config()
            cfg.streams(cfg.first_seed)  # the protocol's own checks, before any run
            # the tests are intervals over seeds: with one, the run would end unanalysed
            check("n_seeds", cfg.n_seeds, PLAN_SEEDS)
        except (ValueError, TypeError) as exc:
            raise ValueError(f"{where}: {exc}") from exc
        runs[name] = run
    return runs


def _test(i: int, values: Any) -> TestSpec:
    where = f"tests[{i}]"
    check(where, values, JsonObject())
    check_keys(where, values, ("name", "family", "protocol", "method", "against", "margin",
                               "pilot"),
               required=("name", "protocol", "method", "against", "pilot"))
    pilot = values["pilot"]
    check(f"{where}.pilot", pilot, JsonObject("effect, sd and seeds"))
    check_keys(f"{where}.pilot", pilot, ("effect", "sd", "seeds"))
    try:
        return TestSpec(values["name"], values["protocol"], values["method"],
                        values["against"], values.get("margin", 0.0), "greater",
                        Pilot(**pilot), values.get("family", "main"))
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from exc
