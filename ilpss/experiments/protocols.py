"""Protocols: which task instances a lifelong learner meets, in which order, per seed.

A :class:`Protocol` gives the streams of a configuration for one seed
(:meth:`~Protocol.streams`), refuses a configuration it cannot run
(:meth:`~Protocol.check`) and says what its streams are (:meth:`~Protocol.describe`).
Protocols are registered by name in :data:`PROTOCOLS` (``A``, ``B``, ``C``, ``R``, ``S``,
``L`` here; more with :func:`register_protocol` or the entry-point group ``ilpss.protocols``), and the
configuration and the runner only dispatch to them: a new protocol needs no change
anywhere else. How a protocol's results are presented is the reports' business
(:mod:`ilpss.experiments.report` and :mod:`ilpss.experiments.sections`, keyed by the
protocol's name), not the protocol's.
"""

from __future__ import annotations

import dataclasses
import typing
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

from ilpss.experiments import drill_facts
from ilpss.experiments.registry import SAMPLERS
from soccer_drill.registry import Registry

__all__ = [
    "Protocol",
    "Stream",
    "StreamSettings",
    "Task",
    "make_env",
    "register_protocol",
]


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
    shared_start: bool = False
    """Whether every target starts from the learner's state after the tasks before
    ``first_target`` (the sources), rather than after the targets before it too."""


def team_task(team: str) -> Task:
    """The task of playing against the team with id ``team``."""
    if not isinstance(team, str) or not team.strip():
        raise ValueError(f"a team id must be a non-empty string, got {team!r}")
    return Task(team, {"opponent": team})


def make_env(env_id: str, task: Task) -> gym.Env:
    """The task's environment (Gymnasium's env checker off: it only slows learning)."""
    return gym.make(env_id, disable_env_checker=True, **task.env_kwargs)


PROTOCOL_FIELDS = ("teams", "targets", "n_shuffles", "stream_length", "sampler", "sampler_team")
"""The fields of ``ExperimentConfig`` that say what a protocol's streams are. Each built-in
protocol reads some of them and refuses a value other than the default in the others:
such a value would be recorded in ``config.json`` and in the report's command, yet
change nothing."""


class StreamSettings(typing.Protocol):
    """What a protocol reads of an experiment's configuration
    (:class:`~ilpss.experiments.config.ExperimentConfig`, a layer above this module): its
    name and the :data:`PROTOCOL_FIELDS`."""

    protocol: str
    teams: tuple[str, ...]
    targets: tuple[str, ...]
    n_shuffles: int
    stream_length: int
    sampler: str
    sampler_team: str


def refuse_unused(cfg: StreamSettings, reads: Iterable[str], why: str) -> None:
    """Refuse a field of :data:`PROTOCOL_FIELDS` outside ``reads`` that differs from its
    default (``ValueError`` naming it, ``why`` it is unused and its default)."""
    defaults = {f.name: f.default for f in dataclasses.fields(cfg)}
    for name in PROTOCOL_FIELDS:
        value = getattr(cfg, name)
        if name not in reads and value != defaults[name]:
            raise ValueError(
                f"ExperimentConfig.{name}: protocol {cfg.protocol} does not use it ({why}), "
                f"got {value!r}; leave it at its default {defaults[name]!r}"
            )


class Protocol:
    """What a protocol provides; subclass it and register an instance.

    Attributes
    ----------
    name : str
        Its name in configurations (``ExperimentConfig.protocol``).
    title : str
        A heading for reports.
    """

    name = ""
    title = ""
    takes_targets = False
    """Whether the protocol reads ``ExperimentConfig.targets`` (others refuse them)."""
    scenarios: tuple[str, ...] | None = None
    """The drills (``ExperimentConfig.scenario``) it is made for; ``None``: any."""

    def check(self, cfg: StreamSettings) -> None:
        """Refuse a configuration this protocol cannot run (``ValueError`` naming the
        field); the default accepts any."""

    def streams(self, cfg: StreamSettings, seed: int) -> list[Stream]:  # pragma: no cover
        """The streams of one seed (the same for every call with the same arguments)."""
        raise NotImplementedError

    def describe(self, cfg: StreamSettings) -> str:
        """What the protocol's streams are with ``cfg``, in a sentence (for the results
        page, which adds the methods)."""
        return f"{self.title[:1].upper()}{self.title[1:]}."


def _teams(teams: tuple[str, ...]) -> str:
    return ", ".join(f"`{t}`" for t in teams)


def _check_teams(cfg: StreamSettings, distinct: bool) -> None:
    if len(cfg.teams) < 2:
        raise ValueError(
            f"protocol {cfg.protocol} needs at least 2 teams in ExperimentConfig.teams, "
            f"got {cfg.teams!r}"
        )
    if distinct and len(set(cfg.teams)) != len(cfg.teams):
        raise ValueError(
            f"protocol {cfg.protocol} holds out each team in turn: ExperimentConfig.teams "
            f"must not repeat a team, got {cfg.teams!r}"
        )


class HeldOutTeam(Protocol):
    """A: teams 1-3 in order, then the held-out team 4 (the paper's Figure 3).

    With ``ExperimentConfig.targets``, every team of ``teams`` is a source and each
    target is learnt after all of them, from the same state: one stream per seed whose
    sources are learnt once, the targets' curves compared per target and pooled.
    """

    name = "A"
    title = "the paper's Figure 3"
    takes_targets = True

    def check(self, cfg: StreamSettings) -> None:
        refuse_unused(cfg, ("teams", "targets"), "it reads teams and targets")
        if not cfg.targets:
            _check_teams(cfg, distinct=False)
            return
        _check_targets(cfg)

    def sources_and_targets(self, cfg: StreamSettings) -> tuple[tuple[str, ...],
                                                                  tuple[str, ...]]:
        """The source teams and the target teams of ``cfg``."""
        if cfg.targets:
            return cfg.teams, cfg.targets
        return cfg.teams[:-1], cfg.teams[-1:]

    def streams(self, cfg: StreamSettings, seed: int) -> list[Stream]:
        sources, targets = self.sources_and_targets(cfg)
        tasks = tuple(team_task(t) for t in (*sources, *targets))
        return [Stream(f"held_out={'+'.join(targets)}", tasks, len(sources),
                       shared_start=True)]

    def describe(self, cfg: StreamSettings) -> str:
        sources, targets = self.sources_and_targets(cfg)
        against = (f"the held-out team `{targets[0]}`" if len(targets) == 1 else
                   f"each of the held-out teams {_teams(targets)}, every one from the state "
                   "after the sources")
        return (f"Opponent teams {_teams(sources)} in sequence, with extraction after "
                f"each; then against {against}.")


def _check_targets(cfg: StreamSettings) -> None:
    """Targets given: distinct, and none of them also a source."""
    if len(set(cfg.targets)) != len(cfg.targets):
        raise ValueError(f"ExperimentConfig.targets must not repeat a team, got {cfg.targets!r}")
    both = [t for t in cfg.targets if t in cfg.teams]
    if both:
        raise ValueError(
            f"ExperimentConfig.targets: {both} are also sources; with targets, "
            f"ExperimentConfig.teams lists the sources only (e.g. --teams "
            f"{' '.join(t for t in cfg.teams if t not in both)} --targets "
            f"{' '.join(cfg.targets)})"
        )


class RegionStream(HeldOutTeam):
    """R: targets composed by region. The sources are pure behaviours, the targets
    teams that play one source's behaviour in one region of the field and another's in
    another, each learnt from the state after the sources
    (:data:`~ilpss.experiments.drill_facts.REGION_SOURCES`,
    :data:`~ilpss.experiments.drill_facts.REGION_TARGETS`); ``teams`` and ``targets`` replace
    both when ``targets`` are given."""

    name = "R"
    # Not "a stream where regions matter": one fixed rule per episode gets 89-94% of the
    # composed rule's gain on two of its three targets (docs/regions.md).
    title = "targets composed by region"
    scenarios = (drill_facts.SCENARIO,)  # its teams split the 2v2 drill's features

    def check(self, cfg: StreamSettings) -> None:
        if cfg.targets:
            super().check(cfg)
        else:  # its own sources and targets, unless targets replace both
            refuse_unused(cfg, (), "without targets it plays its own sources and targets; "
                          "teams are read only with targets")

    def sources_and_targets(self, cfg: StreamSettings) -> tuple[tuple[str, ...],
                                                                  tuple[str, ...]]:
        if cfg.targets:
            return cfg.teams, cfg.targets
        return drill_facts.REGION_SOURCES, drill_facts.REGION_TARGETS

    def describe(self, cfg: StreamSettings) -> str:
        sources, targets = self.sources_and_targets(cfg)
        return (f"Sources {_teams(sources)}, pure behaviours, in sequence; then each of the "
                f"targets {_teams(targets)}, which play one source's behaviour in one region "
                "of the field and another's in another, every one from the state after the "
                "sources.")


class SharpRegionTest(RegionStream):
    """S: the sharp test of regions. The sources are the paper's four teams and the
    contain (:data:`~ilpss.experiments.drill_facts.SHARP_SOURCES`), the targets teams that play
    one paper team far from the goal line and the contain near it
    (:data:`~ilpss.experiments.drill_facts.SHARP_TARGETS`): every episode starts far and most
    reach near, so the gain needs a change of behaviour within the episode, and each
    target needs a different source far from the line. Each target is learnt from the
    state after the sources; ``teams`` and ``targets`` replace both when ``targets`` are
    given."""

    name = "S"
    title = "regions within an episode (the sharp test)"

    def sources_and_targets(self, cfg: StreamSettings) -> tuple[tuple[str, ...],
                                                                  tuple[str, ...]]:
        if cfg.targets:
            return cfg.teams, cfg.targets
        return drill_facts.SHARP_SOURCES, drill_facts.SHARP_TARGETS


class LargeLibrarySharpTest(SharpRegionTest):
    """L: protocol S after a long stream: ``stream_length`` opponents drawn per seed by the
    sampler (as protocol C's), then S's sources, then each of S's targets from the state
    after them. The library is large when the targets come, which is where offering
    options by region could matter most."""

    name = "L"
    title = "the sharp test after a long stream (a large library)"

    def check(self, cfg: StreamSettings) -> None:
        refuse_unused(cfg, ("teams", "targets", "stream_length", "sampler", "sampler_team"),
                      "it reads the prefix's stream_length, sampler and sampler_team, and "
                      "teams with targets")
        SAMPLERS.check("ExperimentConfig.sampler", cfg.sampler)
        if cfg.targets:
            _check_targets(cfg)

    def streams(self, cfg: StreamSettings, seed: int) -> list[Stream]:
        specs = SAMPLERS.get(cfg.sampler)(cfg.stream_length, seed)
        prefix = tuple(
            Task(f"{cfg.sampler_team}_{i}", {"opponent": cfg.sampler_team, "opponent_params": p})
            for i, p in enumerate(specs)
        )
        sources, targets = self.sources_and_targets(cfg)
        tasks = (*prefix, *(team_task(t) for t in (*sources, *targets)))
        return [Stream(f"after={len(prefix)},held_out={'+'.join(targets)}", tasks,
                       len(prefix) + len(sources), shared_start=True)]

    def describe(self, cfg: StreamSettings) -> str:
        return (f"{cfg.stream_length} opponents of the `{cfg.sampler_team}` family (drawn per "
                f"seed by `{cfg.sampler}`); then the sharp test: " + super().describe(cfg))


class EveryTeamHeldOut(Protocol):
    """B: every team held out in turn, after the others in the given order and in
    ``n_shuffles`` shuffled orders drawn per seed."""

    name = "B"
    title = "every team held out in turn"

    def check(self, cfg: StreamSettings) -> None:
        refuse_unused(cfg, ("teams", "n_shuffles"), "it reads teams and n_shuffles")
        _check_teams(cfg, distinct=True)

    def streams(self, cfg: StreamSettings, seed: int) -> list[Stream]:
        rng = np.random.default_rng([seed, 0xB])
        streams = []
        for held in cfg.teams:
            sources = [t for t in cfg.teams if t != held]
            orders = [sources] + [list(rng.permutation(sources)) for _ in range(cfg.n_shuffles)]
            for k, order in enumerate(orders):
                tasks = tuple(team_task(t) for t in (*order, held))
                label = f"held_out={held}" + ("" if k == 0 else f",shuffle={k}")
                streams.append(Stream(label, tasks, len(tasks) - 1))
        return streams

    def describe(self, cfg: StreamSettings) -> str:
        return (f"Each of {_teams(cfg.teams)} is held out in turn, after the others in the "
                f"paper's order and in {cfg.n_shuffles} shuffled order(s) drawn per seed.")


class ParametricStream(Protocol):
    """C: a long stream of opponents drawn per seed by a registered sampler; every
    opponent from the second on is a target."""

    name = "C"
    title = "a long stream of parametric opponents"

    def check(self, cfg: StreamSettings) -> None:
        refuse_unused(cfg, ("stream_length", "sampler", "sampler_team"),
                      "its opponents are drawn by the sampler; it reads stream_length, "
                      "sampler and sampler_team")
        SAMPLERS.check("ExperimentConfig.sampler", cfg.sampler)

    def streams(self, cfg: StreamSettings, seed: int) -> list[Stream]:
        specs = SAMPLERS.get(cfg.sampler)(cfg.stream_length, seed)
        tasks = tuple(
            Task(f"{cfg.sampler_team}_{i}", {"opponent": cfg.sampler_team, "opponent_params": p})
            for i, p in enumerate(specs)
        )
        return [Stream("parametric_stream", tasks, 1)]

    def describe(self, cfg: StreamSettings) -> str:
        return (f"A stream of {cfg.stream_length} opponents of the `{cfg.sampler_team}` "
                f"family (drawn per seed by the sampler `{cfg.sampler}`); every opponent "
                "from the second on is a target.")


PROTOCOLS = Registry("ilpss.protocols", "protocol", Protocol)
"""Every protocol, by name."""


def register_protocol(protocol: Protocol, *, overwrite: bool = False) -> None:
    """Register ``protocol`` under its ``name`` for this process."""
    PROTOCOLS.add(protocol, overwrite=overwrite)


for _protocol in (HeldOutTeam(), EveryTeamHeldOut(), ParametricStream(), RegionStream(),
                  SharpRegionTest(), LargeLibrarySharpTest()):
    register_protocol(_protocol)
