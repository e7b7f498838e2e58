"""Experiment configuration: frozen dataclasses, saved as JSON beside every result."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields, replace
from typing import Any, Literal

import numpy as np

from ilpss.experiments.registry import SAMPLERS, check_env_id
from ilpss.lifelong import LearnerConfig, LifelongConfig

PAPER_TEAMS = ("interceptors_press", "interceptors_cover", "interceptor_guard", "goal_guards")
"""The paper's four opponent teams, in its order (ids of the ``opponents`` package)."""
DRILL_ENV_ID = "soccer_drill:soccer_drill/Holder-v0"
"""The holder environment, imported by ``gymnasium.make`` (``ilpss`` never imports it)."""
EPISODE_REWARD_RANGES = {DRILL_ENV_ID: (-1.0, 1.0), "soccer_drill/Holder-v0": (-1.0, 1.0)}
"""Range of an episode's total reward, per environment id: the drill pays one reward in
[-1, 1] when the episode ends. Other environments: any finite number."""
DRILL_TILE_WIDTHS = (3.0, 3.0, 3.0, 3.0, 10.0, 3.0, 3.0, 3.0, 10.0)
"""Keepaway's tile widths for the drill's 9 features: 3 m for distances, 10 degrees for angles."""
METHODS = ("ilpss", "scratch", "whole_policies", "prq", "ilpss_no_discount")
"""Every method the runner knows."""
Protocol = Literal["A", "B", "C"]
RUN_ONLY_FIELDS = ("executor", "workers")
"""Fields of :class:`ExperimentConfig` that say where seeds run, not what they compute."""


@dataclass(frozen=True)
class Task:
    """One task instance: an opponent team for the drill."""

    name: str
    """A label for tables and plots."""
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    """Keyword arguments of ``gymnasium.make`` (e.g. ``opponent``, ``opponent_params``)."""


@dataclass(frozen=True)
class Stream:
    """An ordered sequence of task instances; methods are compared on the targets."""

    name: str
    """A label, e.g. ``"held_out=goal_guards"``."""
    tasks: tuple[Task, ...]
    """The instances in the order the lifelong learner meets them."""
    first_target: int
    """Index of the first task whose learning curves are compared."""


@dataclass(frozen=True)
class ExperimentConfig:
    """Everything that defines a run of protocol A, B or C.

    The defaults reproduce the paper's Figure 3 (protocol A) with 30 seeds.
    """

    protocol: Protocol = "A"
    """A: teams 1-3 then the held-out team 4. B: every team held out in turn, in the
    paper's order and in ``n_shuffles`` shuffled orders. C: a long stream of teams from
    the parametric family."""
    n_seeds: int = 30
    """Independent repetitions (paired across methods)."""
    first_seed: int = 0
    """Seeds are ``first_seed .. first_seed + n_seeds - 1``."""
    methods: tuple[str, ...] = ("ilpss", "scratch", "whole_policies", "prq")
    """Methods to run; see :data:`METHODS`."""
    env_id: str = DRILL_ENV_ID
    """Gymnasium id of the holder environment."""
    teams: tuple[str, ...] = PAPER_TEAMS
    """Protocols A and B: the teams; in A the last one is held out."""
    n_shuffles: int = 1
    """Protocol B: shuffled source orders per held-out team (besides the paper's)."""
    stream_length: int = 20
    """Protocol C: opponents in the stream."""
    sampler: str = "parametric"
    """Protocol C: the name of a registered sampler (``sampler(n, seed) -> list of
    parameter dicts``; see :mod:`ilpss.experiments.registry`)."""
    sampler_team: str = "parametric"
    """Protocol C: the team id that takes the sampled parameters."""
    lifelong: LifelongConfig = field(
        default_factory=lambda: LifelongConfig(
            train_episodes=300, learner=LearnerConfig(tile_widths=DRILL_TILE_WIDTHS)
        )
    )
    """The lifelong learner's configuration (shared by every method)."""
    prq_psi: float = 1.0
    """PRQ-learning: initial probability of following the reused policy."""
    prq_upsilon: float = 0.95
    """PRQ-learning: per-decision decay of that probability."""
    prq_delta_tau: float = 0.05
    """PRQ-learning: growth of the softmax temperature per episode."""
    executor: Literal["local", "ray"] = "local"
    """Where seeds run: local processes or a Ray cluster."""
    workers: int = 2
    """Parallel seeds."""

    def __post_init__(self) -> None:
        # Every field is checked here, with its name and what is allowed, because configs
        # come from JSON files (``--config``) and a bad value found later would surface
        # mid-run as an unrelated error, after ``config.json`` was written.
        if self.protocol not in ("A", "B", "C"):
            raise ValueError(
                f"ExperimentConfig.protocol must be 'A', 'B' or 'C', got {self.protocol!r}"
            )
        _check_names("methods", self.methods)
        unknown = sorted(set(self.methods) - set(METHODS))
        if unknown or not self.methods:
            raise ValueError(
                f"unknown method(s) {unknown} in ExperimentConfig.methods (which must name "
                f"at least one); allowed: {list(METHODS)}"
            )
        if len(set(self.methods)) != len(self.methods):
            raise ValueError(
                f"ExperimentConfig.methods must not repeat a method, got {self.methods!r}"
            )
        if "prq" in self.methods and "scratch" not in self.methods:
            raise ValueError("method 'prq' reuses the policies of 'scratch': add 'scratch'")
        # Upper bounds far above any useful value: each seed, stream, opponent and worker
        # costs memory (and a worker a process) before the first episode.
        for name, low, high in (("n_seeds", 1, 100_000), ("workers", 1, 1024),
                                ("stream_length", 1, 10_000), ("first_seed", 0, 2**32 - 1),
                                ("n_shuffles", 0, 1000)):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or not low <= value <= high:
                raise ValueError(
                    f"ExperimentConfig.{name} must be an integer in [{low:,}, {high:,}], "
                    f"got {value!r}"
                )
        check_env_id("ExperimentConfig.env_id", self.env_id)
        # Team ids are only checked for form: ``ilpss`` never imports the drill, so an
        # unknown id is refused by the environment, whose error names it and the known ones.
        _check_names("teams", self.teams)
        if self.protocol in ("A", "B") and len(self.teams) < 2:
            raise ValueError(
                f"protocols A and B need at least 2 teams in ExperimentConfig.teams, "
                f"got {self.teams!r}"
            )
        if self.protocol == "B" and len(set(self.teams)) != len(self.teams):
            raise ValueError(
                f"protocol B holds out each team in turn: ExperimentConfig.teams must not "
                f"repeat a team, got {self.teams!r}"
            )
        # A name, never code; only protocol C draws from it, so only C needs it registered.
        SAMPLERS.check("ExperimentConfig.sampler", self.sampler, registered=self.protocol == "C")
        if not isinstance(self.sampler_team, str) or not self.sampler_team.strip():
            raise ValueError(
                f"ExperimentConfig.sampler_team must be a team id (a non-empty string), "
                f"got {self.sampler_team!r}"
            )
        if not isinstance(self.lifelong, LifelongConfig):
            raise ValueError(
                "ExperimentConfig.lifelong must be a LifelongConfig (from_dict takes a dict), "
                f"got {type(self.lifelong).__name__}"
            )
        # The ranges PrqLearner accepts (ilpss.baselines): checked now, not at the first target.
        _check_real("prq_psi", self.prq_psi, 0.0, 1.0)
        _check_real("prq_upsilon", self.prq_upsilon, 0.0, 1.0)
        _check_real("prq_delta_tau", self.prq_delta_tau, 0.0, math.inf)
        if self.executor not in ("local", "ray"):
            raise ValueError(
                f"ExperimentConfig.executor must be 'local' or 'ray', got {self.executor!r}"
            )

    @property
    def reward_range(self) -> tuple[float, float]:
        """The range of an episode's total reward in this run's environment."""
        return EPISODE_REWARD_RANGES.get(self.env_id, (-math.inf, math.inf))

    @property
    def seeds(self) -> range:
        """The seeds of this run."""
        return range(self.first_seed, self.first_seed + self.n_seeds)

    def streams(self, seed: int) -> list[Stream]:
        """The task streams of this protocol for one seed."""
        if self.protocol == "A":
            tasks = tuple(_team(t) for t in self.teams)
            return [Stream(f"held_out={self.teams[-1]}", tasks, len(tasks) - 1)]
        if self.protocol == "B":
            rng = np.random.default_rng([seed, 0xB])
            streams = []
            for held in self.teams:
                sources = [t for t in self.teams if t != held]
                orders = [sources] + [list(rng.permutation(sources)) for _ in range(self.n_shuffles)]
                for k, order in enumerate(orders):
                    tasks = tuple(_team(t) for t in (*order, held))
                    label = f"held_out={held}" + ("" if k == 0 else f",shuffle={k}")
                    streams.append(Stream(label, tasks, len(tasks) - 1))
            return streams
        specs = SAMPLERS.get(self.sampler)(self.stream_length, seed)
        tasks = tuple(
            Task(f"{self.sampler_team}_{i}", {"opponent": self.sampler_team, "opponent_params": p})
            for i, p in enumerate(specs)
        )
        return [Stream("parametric_stream", tasks, 1)]

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict."""
        return asdict(self)

    def results_record(self) -> dict[str, Any]:
        """The fields that decide the results, as JSON values: every field but
        ``executor`` and ``workers`` (where seeds run changes nothing). Every result and
        checkpoint of a run records this, and a resume compares it."""
        values = self.to_dict()
        for name in RUN_ONLY_FIELDS:
            del values[name]
        return json.loads(json.dumps(values))

    def to_json(self) -> str:
        """Pretty JSON of :meth:`to_dict`, keys sorted."""
        return json.dumps(self.to_dict(), indent=2, sort_keys=True)

    @classmethod
    def from_dict(cls, values: Mapping[str, Any]) -> ExperimentConfig:
        """Inverse of :meth:`to_dict`; unknown keys and ill-typed values are refused by name.

        Raises:
            ValueError: ``values`` is not a mapping, has unknown keys, or a field is invalid
                (the message names the field and what it allows).
        """
        if not isinstance(values, Mapping):
            raise ValueError(
                f"an ExperimentConfig must be a JSON object (a dict of its fields), "
                f"got {type(values).__name__}"
            )
        values = dict(values)
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(values) - known)
        if unknown:
            raise ValueError(
                f"unknown ExperimentConfig field(s) {unknown}; allowed: {sorted(known)}"
            )
        if "lifelong" in values:
            lifelong = values["lifelong"]
            if not isinstance(lifelong, Mapping):
                raise ValueError(
                    "ExperimentConfig.lifelong must be a JSON object of LifelongConfig fields, "
                    f"got {type(lifelong).__name__}"
                )
            try:
                values["lifelong"] = LifelongConfig.from_dict(dict(lifelong))
            except (TypeError, ValueError) as exc:
                raise ValueError(f"ExperimentConfig.lifelong: {exc}") from exc
        for name in ("methods", "teams"):
            if name in values:
                # A string would become a tuple of its letters; say so instead.
                if not isinstance(values[name], list | tuple):
                    raise ValueError(
                        f"ExperimentConfig.{name} must be a list of strings, "
                        f"got {values[name]!r}"
                    )
                values[name] = tuple(values[name])
        return cls(**values)

    def with_overrides(self, **changes: Any) -> ExperimentConfig:
        """A copy with some fields changed (``lifelong`` takes a dict of its fields)."""
        if isinstance(changes.get("lifelong"), dict):
            changes["lifelong"] = LifelongConfig.from_dict(
                {**self.lifelong.to_dict(), **changes["lifelong"]}
            )
        return replace(self, **changes)


def _team(team: str) -> Task:
    """The task of playing against the team with id ``team``."""
    if not isinstance(team, str) or not team.strip():
        raise ValueError(f"a team id must be a non-empty string, got {team!r}")
    return Task(team, {"opponent": team})


def _check_names(name: str, values: object) -> None:
    """``values`` is a tuple of non-empty strings (method names, team ids)."""
    if not isinstance(values, tuple) or not all(
        isinstance(v, str) and v.strip() for v in values
    ):
        raise ValueError(
            f"ExperimentConfig.{name} must be a tuple of non-empty strings, got {values!r}"
        )


def _check_real(name: str, value: object, low: float, high: float) -> None:
    """``value`` is a finite real number (not a bool or a string) in ``[low, high]``."""
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not (math.isfinite(value) and low <= value <= high)
    ):
        shown = f"in [{low:g}, {high:g}]" if math.isfinite(high) else f">= {low:g}"
        raise ValueError(
            f"ExperimentConfig.{name} must be a finite number {shown}, got {value!r}"
        )
