"""Experiment configuration: a frozen dataclass, saved as JSON beside every result."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, replace
from typing import Any, Literal

from ilpss.baselines import PrqConfig
from ilpss.experiments import drill_facts
from ilpss.experiments.executor import EXECUTOR
from ilpss.experiments.methods import METHODS, LifelongMethod
from ilpss.experiments.oracles import REUSE_SCENARIOS
from ilpss.experiments.protocols import PROTOCOLS, Stream
from ilpss.experiments.registry import SAMPLERS, check_env_id
from ilpss.lifelong import LIFELONG_CONSTRAINTS, LearnerConfig, LifelongConfig
from ilpss.reuse import EmKernels
from soccer_drill.constraints import (
    Integer,
    ListOf,
    Name,
    NoneOr,
    Text,
    check,
    check_fields,
    from_json,
)

__all__ = ["ExperimentConfig"]

RUN_ONLY_FIELDS = ("executor", "workers", "storage")
"""Fields of :class:`ExperimentConfig` that say where jobs run and keep their checkpoints,
not what they compute."""
RECORDED_IF_SET = {"targets": [], "baseline": "scratch", "featured": None,
                   "scenario": drill_facts.SCENARIO,
                   "lifelong.learner.step_targets": "every_choice",
                   "lifelong.learner.value_bounds": None,
                   "lifelong.learner.option_traces": "kept"}
"""Fields (dotted paths into nested configurations) that results and checkpoints record
only when they differ from their default (as JSON), so that the records of runs made
before the field existed stay the records of the same configuration: a field is added
with the default that computes what was computed before."""

EXPERIMENT_CONSTRAINTS = {
    # Upper bounds far above any useful value: each seed, stream, opponent and worker
    # costs memory (and a worker a process) before the first episode.
    "n_seeds": Integer(1, 100_000),
    "first_seed": Integer(0, 2**32 - 1),
    "methods": ListOf(Name(), min_len=1, unique=True),
    "teams": ListOf(Text(), min_len=1),
    "targets": ListOf(Text(), max_len=1000),
    "n_shuffles": Integer(0, 1000),
    "stream_length": Integer(1, 10_000),
    "sampler_team": Text(),
    "executor": EXECUTOR,
    "workers": Integer(1, 1024),
    "storage": NoneOr(Text()),
    "baseline": NoneOr(Name()),
    "featured": NoneOr(Name()),
    "scenario": Name(),
}
"""What the plain fields of :class:`ExperimentConfig` allow (the protocol, methods,
environment and sampler are names looked up in their registries, the scenario among the
drill's)."""


TRAIN_EPISODES = Integer(1, LIFELONG_CONSTRAINTS["train_episodes"].high)
"""An experiment's learning episodes per task: at least one (its reports are learning
curves), whereas a lifelong learner also allows trials without learning."""


@dataclass(frozen=True)
class ExperimentConfig:
    """Everything that defines a run of a protocol.

    The defaults reproduce the paper's Figure 3 (protocol A) with 30 seeds.
    """

    protocol: str = "A"
    """A registered protocol (:data:`~ilpss.experiments.protocols.PROTOCOLS`). A: teams
    1-3 then the held-out team 4. B: every team held out in turn, in the given order and
    in ``n_shuffles`` shuffled orders. C: a long stream of teams from the parametric
    family. A field of :data:`~ilpss.experiments.protocols.PROTOCOL_FIELDS` that the
    protocol does not read must keep its default."""
    n_seeds: int = 30
    """Independent repetitions (paired across methods)."""
    first_seed: int = 0
    """Seeds are ``first_seed .. first_seed + n_seeds - 1``."""
    methods: tuple[str, ...] = ("ilpss", "scratch", "whole_policies", "prq", "ilpss_plus",
                                "whole_policies_plus", "finetune", "finetune_best", "ilpss_ft",
                                "whole_policies_ft", "finetune_bounded", "finetune_chained",
                                "finetune_chained_bounded", "finetune_best_recent")
    """Registered methods to run (:data:`~ilpss.experiments.methods.METHODS`): by default
    the paper's, the transfer baselines a reviewer asks for first and their controls (the
    same learner with bounded values, chained starts, a choice among the recent sources
    only)."""
    env_id: str = drill_facts.ENV_ID
    """Gymnasium id of the environment (see :func:`~ilpss.experiments.registry.check_env_id`).
    Left at a scenario's holder, it is :attr:`scenario`'s."""
    teams: tuple[str, ...] = drill_facts.PAPER_TEAMS
    """Protocols A and B: the teams; in A the last one is held out (unless ``targets``
    are given: then all of them are sources)."""
    targets: tuple[str, ...] = ()
    """Protocol A: the held-out teams, each learnt after all of ``teams`` from the same
    state (the sources are learnt once per seed and method); results, curves and
    verdicts per target, and pooled over them. Empty: the last of ``teams`` is the one
    target (the paper's)."""
    n_shuffles: int = 1
    """Protocol B: shuffled source orders per held-out team (besides the given one)."""
    stream_length: int = 20
    """Protocol C: opponents in the stream."""
    sampler: str = drill_facts.SAMPLER
    """Protocol C: the name of a registered sampler (``sampler(n, seed) -> list of
    parameter dicts``; see :mod:`ilpss.experiments.registry`)."""
    sampler_team: str = drill_facts.SAMPLER_TEAM
    """Protocol C: the team id that takes the sampled parameters."""
    lifelong: LifelongConfig = field(
        default_factory=lambda: LifelongConfig(
            train_episodes=300, learner=LearnerConfig(tile_widths=drill_facts.TILE_WIDTHS)
        )
    )
    """The lifelong learner's configuration (shared by every method)."""
    prq: PrqConfig = field(default_factory=PrqConfig)
    """PRQ-learning's reuse settings (its learning settings are ``lifelong.learner``'s)."""
    executor: Literal["local", "ray"] = "local"
    """Where seeds run: local processes or a Ray cluster."""
    workers: int = 2
    """Parallel jobs: local processes, or the most Ray tasks in flight at once."""
    storage: str | None = None
    """Where the lifelong checkpoints go: ``None``, the run folder; else a path or a URI
    (``s3://bucket/prefix``, ``gs://...``, ``file:///...``, as Ray's ``storage_path``)
    that every node of a cluster can reach (:mod:`ilpss.experiments.checkpoints`)."""
    baseline: str | None = "scratch"
    """The method every report compares the others with (learning anew); it must be one
    of :attr:`methods`. ``None``: a run without a report, compared with another run's
    baseline by ``ilpss-compare`` (an ablation)."""
    featured: str | None = None
    """The method whose kernels, GIF and per-opponent head start the reports show; it must
    be one of :attr:`methods`. ``None``: the first of :attr:`methods` whose options have
    kernels fitted by EM (ILPSS's), if any (:attr:`featured_method`)."""
    scenario: str = drill_facts.SCENARIO
    """The drill played (``drill_2v2``, the paper's; ``drill_1v1``, ``drill_3v2``,
    ``drill_3v3``: :func:`~ilpss.experiments.drill_facts.scenario_names`). Its holder
    becomes :attr:`env_id`, and its keepaway tile widths the learner's, where those are
    left at a scenario's (:func:`~ilpss.experiments.drill_facts.holder_drill`); the
    protocols, methods and ways of reusing past policies made for the 2v2 drill alone
    (protocols R, S and L, the oracles' regions) refuse another. Recorded in results only
    when it is not the paper's."""

    def __post_init__(self) -> None:
        # Every field is checked here, with its name and what is allowed, because configs
        # come from JSON files (``--config``) and a bad value found later would surface
        # mid-run as an unrelated error, after ``config.json`` was written.
        for name in ("methods", "teams", "targets"):  # JSON gives lists
            if isinstance(getattr(self, name), list):
                object.__setattr__(self, name, tuple(getattr(self, name)))
        PROTOCOLS.check("ExperimentConfig.protocol", self.protocol)
        check_fields("ExperimentConfig", self, EXPERIMENT_CONSTRAINTS)
        last = self.first_seed + self.n_seeds - 1  # every seed within the bound, not the first
        if last > EXPERIMENT_CONSTRAINTS["first_seed"].high:
            raise ValueError(
                f"ExperimentConfig: the seeds {self.first_seed} .. {last} go past "
                f"{EXPERIMENT_CONSTRAINTS['first_seed'].high:,}, the largest seed; lower "
                "first_seed or n_seeds")
        self._take_scenario()
        for method in self.methods:
            METHODS.check("ExperimentConfig.methods", method)
            missing = [m for m in METHODS.get(method).reuses if m not in self.methods]
            if missing:
                raise ValueError(
                    f"method {method!r} reuses the learners of {missing}: add them to "
                    "ExperimentConfig.methods"
                )
        check_env_id("ExperimentConfig.env_id", self.env_id)
        # A name, never code; the protocols that draw from it check it is registered.
        SAMPLERS.check("ExperimentConfig.sampler", self.sampler, registered=False)
        for name, kind in (("lifelong", LifelongConfig), ("prq", PrqConfig)):
            if not isinstance(getattr(self, name), kind):
                raise ValueError(
                    f"ExperimentConfig.{name} must be a {kind.__name__} (from_dict takes a "
                    f"dict), got {type(getattr(self, name)).__name__}"
                )
        self._check_reuse_is_each_methods()
        # LifelongConfig allows 0 (trials without learning), but an experiment reports
        # learning curves: without an episode it would run every job, then fail.
        check("ExperimentConfig.lifelong.train_episodes", self.lifelong.train_episodes,
              TRAIN_EPISODES)
        for role in ("baseline", "featured"):
            name = getattr(self, role)
            if name is not None and name not in self.methods:
                raise ValueError(
                    f"ExperimentConfig.{role}: method {name!r} is not among the methods "
                    f"{list(self.methods)}; add it to ExperimentConfig.methods"
                    + (", or set baseline to null for a run without a report (compared "
                       "with ilpss-compare)" if role == "baseline" else "")
                )
        protocol = PROTOCOLS.get(self.protocol)
        if self.targets and not protocol.takes_targets:
            raise ValueError(
                f"ExperimentConfig.targets: protocol {self.protocol} takes no targets (its "
                f"streams say which tasks are targets), got {self.targets!r}"
            )
        protocol.check(self)
        if protocol.scenarios is not None and self.scenario not in protocol.scenarios:
            raise ValueError(
                f"ExperimentConfig.scenario: protocol {self.protocol} is made for "
                f"{' and '.join(protocol.scenarios)} only (its teams and regions are that "
                f"drill's), got {self.scenario!r}; choose scenario "
                f"{protocol.scenarios[0]!r}, or protocol A, B or C")
        self._check_methods_play_scenario()
        self._check_bounded_methods_know_the_returns()

    def _check_reuse_is_each_methods(self) -> None:
        """The way of reusing past policies is each method's own (``ilpss`` and its
        variants take the default, ILPSS's kernels): one set for the whole run would make
        them another method under their names."""
        default = LifelongConfig().options
        given = self.lifelong.options
        if given == default:
            return
        base = replace(self.lifelong, options=default)
        named = [name for name in METHODS.names() if isinstance(METHODS.get(name), LifelongMethod)
                 and METHODS.get(name).config(base).options == given]
        raise ValueError(
            f"ExperimentConfig.lifelong.options: each method sets its own way of reusing "
            f"past policies, so the run's must stay {default!r} (ILPSS's, which 'ilpss' and "
            f"its variants take as theirs), got {given!r}; choose a method that reuses them "
            f"so in ExperimentConfig.methods (--methods): {named or 'none is registered'}"
        )

    def _take_scenario(self) -> None:
        """:attr:`scenario`'s holder as the environment and its tile widths as the
        learner's, where those are left at a scenario's; refuse a scenario that is not the
        drill's, and an environment or widths that belong to another scenario."""
        try:
            drill = drill_facts.holder_drill(self.scenario)
        except ValueError as exc:
            raise ValueError(f"ExperimentConfig.{exc}") from None
        scenarios = [drill_facts.holder_drill(n) for n in drill_facts.scenario_names()]
        if self.env_id in {s.env_id for s in scenarios}:
            object.__setattr__(self, "env_id", drill.env_id)
        elif self.scenario != drill_facts.SCENARIO:
            raise ValueError(
                f"ExperimentConfig.env_id {self.env_id!r} is not the drill's: a scenario "
                f"other than the paper's needs its holder, {drill.env_id!r} (leave env_id "
                f"at its default), got scenario {self.scenario!r}")
        learner = self.lifelong.learner if isinstance(self.lifelong, LifelongConfig) else None
        if learner is None or drill_facts.drill_of_env(self.env_id) is None:
            return
        widths = learner.tile_widths
        if widths in {s.tile_widths for s in scenarios}:
            widths = drill.tile_widths
        if self.scenario != drill_facts.SCENARIO and widths is not None and \
                len(widths) != len(drill.feature_names):  # (2v2: refused by the tile coder)
            raise ValueError(
                f"ExperimentConfig.lifelong.learner.tile_widths: scenario {self.scenario!r} "
                f"has {len(drill.feature_names)} features ({', '.join(drill.feature_names)}), "
                f"got {len(widths)} widths; leave them at the default for keepaway's")
        if widths != learner.tile_widths:
            object.__setattr__(self, "lifelong", replace(
                self.lifelong, learner=replace(learner, tile_widths=widths)))

    def _check_methods_play_scenario(self) -> None:
        """Refuse a lifelong method whose way of reusing past policies is made for
        another drill (the oracles' regions are the 2v2 drill's features)."""
        for name in self.methods:
            method = METHODS.get(name)
            if not isinstance(method, LifelongMethod):
                continue
            options = method.config(self.lifelong).options
            allowed = REUSE_SCENARIOS.get(options)
            if allowed is not None and self.scenario not in allowed:
                raise ValueError(
                    f"ExperimentConfig.methods: {name!r} reuses past policies by "
                    f"{options!r}, whose regions are made for {' and '.join(allowed)} only, "
                    f"and the scenario is {self.scenario!r}; leave it out, or play "
                    f"scenario {allowed[0]!r}")

    def _check_bounded_methods_know_the_returns(self) -> None:
        """Refuse a method that bounds its learner's values by the drill's returns (its own
        ``value_bounds``, not the base learner's) in an environment whose returns this run
        does not know: there it would clip every target to the drill's range silently."""
        if self.drill is not None:
            return
        base = self.lifelong.learner.value_bounds
        for name in self.methods:
            method = METHODS.get(name)
            bounds = (method.config(self.lifelong).learner.value_bounds
                      if isinstance(method, LifelongMethod)
                      else getattr(method, "value_bounds", None))
            if bounds is not None and bounds != base:
                raise ValueError(
                    f"ExperimentConfig.methods: {name!r} bounds its learner's values by the "
                    f"drill's episode returns [{bounds[0]:g}, {bounds[1]:g}], and env_id "
                    f"{self.env_id!r} is not one of the drill's scenarios, whose returns "
                    "this run does not know; leave it out (the methods without 'bounded' "
                    "in their name learn with lifelong.learner.value_bounds, which may "
                    "give your environment's range)")

    @property
    def unreportable(self) -> str | None:
        """Why ``write_report`` cannot report this run (``None``: it can): it compares every
        method with the baseline, and its transfer ratio and time to threshold measure the
        curves from the drill's lowest episode reward."""
        if self.baseline is None:
            return ("a report compares every method with the run's baseline, and this run "
                    "has none (ExperimentConfig.baseline is null): compare it with "
                    "ilpss-compare instead")
        if self.drill is None:
            return (f"a report's transfer ratio and time to threshold measure the curves from "
                    f"the drill's lowest episode reward (-1), and env_id {self.env_id!r} is "
                    "not one of the drill's scenarios: its results are kept; compare them "
                    "with ilpss.metrics.compare, giving your environment's lowest episode "
                    "reward as floor")
        return None

    @property
    def drill(self) -> drill_facts.HolderDrill | None:
        """What ``ilpss`` knows of this run's drill (``None``: another environment)."""
        return drill_facts.drill_of_env(self.env_id)

    @property
    def reward_range(self) -> tuple[float, float]:
        """The range of an episode's total reward in this run's environment (another
        environment than the drill's: any number)."""
        drill = self.drill
        return (-math.inf, math.inf) if drill is None else drill.episode_reward

    @property
    def featured_method(self) -> str | None:
        """:attr:`featured`, or the first of :attr:`methods` whose options have kernels
        fitted by EM (``None`` if there is none)."""
        if self.featured is not None:
            return self.featured
        for name in self.methods:
            method = METHODS.get(name)
            if isinstance(method, LifelongMethod) and \
                    isinstance(method.config(self.lifelong).reuse.regions, EmKernels):
                return name
        return None

    @property
    def seeds(self) -> range:
        """The seeds of this run."""
        return range(self.first_seed, self.first_seed + self.n_seeds)

    def streams(self, seed: int) -> list[Stream]:
        """The task streams of this protocol for one seed."""
        return PROTOCOLS.get(self.protocol).streams(self, seed)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict."""
        return asdict(self)

    def results_record(self) -> dict[str, Any]:
        """The fields that decide the results, as JSON values: every field but
        :data:`RUN_ONLY_FIELDS` (where jobs run changes nothing), and those of
        :data:`RECORDED_IF_SET` only when set. Every result and checkpoint of a run
        records this, and a resume compares it."""
        values = json.loads(json.dumps(self.to_dict()))
        for name in RUN_ONLY_FIELDS:
            del values[name]
        for path, default in RECORDED_IF_SET.items():
            *parents, name = path.split(".")
            holder = values
            for parent in parents:
                holder = holder[parent]
            if holder[name] == default:
                del holder[name]
        return values

    def to_json(self) -> str:
        """Pretty JSON of :meth:`to_dict`, keys sorted."""
        return json.dumps(self.to_dict(), indent=2, sort_keys=True)

    @classmethod
    def from_dict(cls, values: Mapping[str, Any]) -> ExperimentConfig:
        """Inverse of :meth:`to_dict`; unknown keys and ill-typed values are refused by name.

        The nested objects may be partial: what they leave out is this class's default
        (``{"lifelong": {"train_episodes": 50}}`` keeps the drill's tile widths), exactly
        as with :meth:`with_overrides` and the command line's ``--set``.

        Raises:
            ValueError: ``values`` is not a mapping, has unknown keys, or a field is invalid
                (the message names the field and what it allows).
        """
        if isinstance(values, Mapping):
            if "code" in values:  # a run's config.json records the code that ran it
                raise ValueError(
                    "ExperimentConfig: 'code' is not a field but a run's record of the code "
                    "that ran it: read a run's config.json with ilpss.experiments.run."
                    "read_config, or leave the key out")
            values = dict(values)
            defaults = cls()
            for name in ("lifelong", "prq"):
                if isinstance(values.get(name), Mapping):
                    values[name] = _merged(getattr(defaults, name).to_dict(), values[name], name)
        return from_json(cls, values, nested={"lifelong": LifelongConfig, "prq": PrqConfig})

    def with_overrides(self, **changes: Any) -> ExperimentConfig:
        """A copy with some fields changed; ``lifelong`` and ``prq`` take a dict of the
        fields to change, nested as in :meth:`to_dict` (``{"learner": {"alpha": 0.5}}``)."""
        for name in ("lifelong", "prq"):
            if isinstance(changes.get(name), Mapping):
                merged = _merged(getattr(self, name).to_dict(), changes[name], name)
                changes[name] = type(getattr(self, name)).from_dict(merged)
        return replace(self, **changes)


def _merged(base: dict[str, Any], changes: Mapping[str, Any], where: str) -> dict[str, Any]:
    """``base`` with ``changes`` applied, nested objects merged key by key."""
    out = dict(base)
    for key, value in changes.items():
        if isinstance(value, Mapping) and isinstance(base.get(key), dict):
            out[key] = _merged(base[key], value, f"{where}.{key}")
        else:
            out[key] = value
    return out
