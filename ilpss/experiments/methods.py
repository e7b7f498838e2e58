"""Methods: what a job runs on its stream, and what it records of each.

A :class:`Method` has a name, a label for reports, the methods whose learners it reuses
(``reuses``), and :meth:`~Method.run`, which runs it on one job and returns its entry of
``result.json`` (``"curves"``: one learning curve per target task, and any series).
Methods are registered by name in :data:`METHODS`; a configuration names them in
``ExperimentConfig.methods``.

* :class:`LifelongMethod`: the lifelong learner (Algorithm 1) with a variant of the
  lifelong configuration, over the whole stream, checkpointed after every trial and
  resumed from its checkpoint. ILPSS, learning anew, whole past policies as options and
  ILPSS without discounting are four of them.
* :class:`PrqMethod`: PRQ-learning on every target, reusing the policies that learning
  anew learnt on the earlier tasks.
* :class:`FineTuneMethod`: a learner on every target that starts from the values of a
  policy learning anew learnt on the sources.
* :class:`CrossSizeMethod`: the same, its sources learnt in a drill of another size and
  carried over by an inter-task mapping (``transfer_2v2``: from the paper's 2 v 2).
"""

from __future__ import annotations

import copy
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any, Protocol

from ilpss._io import json_differences
from ilpss.baselines import PrqConfig, PrqLearner
from ilpss.experiments import drill_facts
from ilpss.experiments.checkpoints import CheckpointStore, is_uri
from ilpss.experiments.cross_size import keepaway_mapping
from ilpss.experiments.folder import checkpoint_key
from ilpss.experiments.protocols import Stream, make_env
from ilpss.lifelong import (
    LifelongConfig,
    LifelongLearner,
    TrialRecord,
    choice_seed,
    handing_back,
    trial_seeds,
)
from ilpss.policy import FrozenPolicy
from ilpss.reuse import (
    BestOfPast,
    LatestPast,
    StartRule,
    learn_with,
)
from ilpss.smdp import EpisodeResult, SmdpLearner
from ilpss.statewise import StatewiseStart
from ilpss.tiles import TileCoder
from ilpss.transfer import map_policy
from soccer_drill.constraints import Constraint, Integer, Real, Text, check
from soccer_drill.registry import Registry

__all__ = [
    "METHODS",
    "FineTuneMethod",
    "Job",
    "LifelongMethod",
    "Method",
    "MethodSettings",
    "PrqMethod",
    "lifelong_entry",
    "register_method",
]


class MethodSettings(Protocol):
    """What a method reads of an experiment's configuration
    (:class:`~ilpss.experiments.config.ExperimentConfig`, a layer above this module)."""

    env_id: str
    lifelong: LifelongConfig
    prq: PrqConfig
    reward_range: tuple[float, float]

    @property
    def drill(self) -> drill_facts.HolderDrill | None: ...

    def results_record(self) -> dict[str, Any]: ...


@dataclass
class Job:
    """One (seed, stream) job: what its methods run on, and the learners they leave."""

    cfg: MethodSettings
    seed: int
    stream_index: int
    stream: Stream
    store: CheckpointStore
    """Where the lifelong methods' checkpoints are kept (:mod:`~ilpss.experiments.checkpoints`)."""
    token: str | None = None
    """The run's claim on ``store``, checked before every checkpoint (``None``: unclaimed)."""
    learners: dict[str, LifelongLearner] = field(default_factory=dict)
    """The lifelong learners of the methods run so far, by method name. In a stream whose
    targets share their start it is the learner after the sources, so its policies are
    the ones every target follows (``policies[:t]`` holds no other target's)."""
    resumed: dict[str, int] = field(default_factory=dict)
    """Per lifelong method, the trials found done in its checkpoints."""

    @property
    def targets(self) -> range:
        """Indices of the tasks whose learning curves are compared."""
        return range(self.stream.first_target, len(self.stream.tasks))

    def tasks_before(self, t: int) -> int:
        """How many tasks precede task ``t`` in its learner's history: all earlier ones,
        or only the sources when the stream's targets all start after them."""
        first = self.stream.first_target
        return first if self.stream.shared_start and t >= first else t


class Method:
    """What a method provides; subclass it and register an instance.

    Attributes
    ----------
    name : str
        Its name in configurations.
    label : str
        How reports call it.
    reuses : tuple of str
        Methods whose learners :meth:`run` needs (they run first in every job).
    """

    name = ""
    label = ""
    reuses: tuple[str, ...] = ()
    ablates: tuple[str, str] | None = None
    """``(method, what)``: this method is ``method`` without ``what`` (e.g. discounting);
    reports compare the two, paired by seed, when both ran."""
    series: Mapping[str, Constraint] = {}
    """The series its entry of ``result.json`` holds beside ``"curves"``, one value per
    task of the stream, each with the constraint of its values: what :meth:`run` records
    and what a resume checks, the same declaration."""

    def run(self, job: Job) -> dict[str, Any]:  # pragma: no cover - interface
        """Run on ``job``; return this method's entry of the job's ``result.json``."""
        raise NotImplementedError


@dataclass(frozen=True)
class LifelongMethod(Method):
    """The lifelong learner with ``changes`` to the lifelong configuration."""

    name: str
    label: str
    changes: Callable[[LifelongConfig], dict[str, Any]] = lambda base: {}
    """The fields of the base configuration this method replaces (a function of it)."""
    reuses: tuple[str, ...] = ()
    ablates: tuple[str, str] | None = None
    series: Mapping[str, Constraint] = field(default_factory=lambda: dict(LIFELONG_SERIES))

    def __post_init__(self) -> None:
        # Checked when the method is made: a wrong field failed only inside every job.
        check(f"method {self.name!r}: label", self.label, Text())
        if not callable(self.changes):
            raise TypeError(f"method {self.name!r}: changes is a function of the base "
                            f"LifelongConfig giving the fields it replaces, not "
                            f"{type(self.changes).__name__} {self.changes!r:.60}")

    def config(self, base: LifelongConfig) -> LifelongConfig:
        """This method's lifelong configuration."""
        changes = self.changes(base)
        unknown = sorted(set(changes) - {f.name for f in fields(base)})
        if unknown:
            raise ValueError(f"method {self.name!r}: its changes name {unknown}, not fields of "
                             f"LifelongConfig ({sorted(f.name for f in fields(base))})")
        return replace(base, **changes)

    def run(self, job: Job) -> dict[str, Any]:
        learner, records = run_lifelong(job, self.name, self.config(job.cfg.lifelong))
        job.learners[self.name] = learner
        return lifelong_entry(records, job.targets)


@dataclass(frozen=True)
class _Guarded:
    """A store whose every write first checks the run's token (``None``: unclaimed)."""

    store: CheckpointStore
    token: str | None

    def save(self, key: str, learner: LifelongLearner) -> None:
        if self.token is not None:
            self.store.check(self.token)
        self.store.save(key, learner)


def run_lifelong(
    job: Job, method: str, config: LifelongConfig
) -> tuple[LifelongLearner, list[TrialRecord]]:
    """One lifelong method over the job's stream, resuming from its checkpoints (which
    must come from this very job: a checkpoint of another configuration is refused).

    Returns the learner and one trial record per task of the stream. In a stream whose
    targets all start from the state after its sources (``Stream.shared_start``, with
    two targets or more), the learner is the one after the sources, the targets' records
    come from each target's own checkpoint, and a resumed job relearns neither the
    sources nor a finished target.
    """
    cfg, stream = job.cfg, job.stream
    store = _Guarded(job.store, job.token)
    key = checkpoint_key(job.seed, job.stream_index, method)
    env0 = make_env(cfg.env_id, stream.tasks[0])
    space = env0.observation_space
    provenance = {"experiment": cfg.results_record(), "method": method, "seed": job.seed,
                  "stream": stream.name, "tasks": [t.name for t in stream.tasks]}
    branches = stream.shared_start and len(job.targets) > 1
    main_line = stream.first_target if branches else len(stream.tasks)
    learner = _restore(job.store, key, space, provenance, cfg.reward_range,
                       range(1, main_line + 1))
    resumed = 0 if learner is None else learner.n_trials
    if learner is None:
        learner = LifelongLearner(config, space, int(env0.action_space.n), job.seed,
                                  provenance=provenance)
    for t in range(learner.n_trials, main_line):
        task = stream.tasks[t]
        learner.run_trial(make_env(cfg.env_id, task), task.name)
        store.save(key, learner)
    sources = list(learner.records)
    records = list(sources)
    if branches:
        for t in job.targets:
            target_key = checkpoint_key(job.seed, job.stream_index, method, t)
            mine = {**provenance, "target": t}
            branch = _restore(job.store, target_key, space, mine, cfg.reward_range,
                              range(main_line + 1, main_line + 2))
            if branch is not None and branch.records[:main_line] != sources:
                raise ValueError(
                    f"{job.store.location}: the checkpoint {target_key} does not start from "
                    f"the state after the sources in {key}; delete it to run the target again"
                )
            if branch is None:
                branch = copy.deepcopy(learner)  # the state after the sources
                branch.provenance = mine
                task = stream.tasks[t]
                branch.run_trial(make_env(cfg.env_id, task), task.name)
                store.save(target_key, branch)
            else:
                resumed += 1
            records.append(branch.records[-1])
    job.resumed[method] = resumed
    return learner, records


class CheckpointRefused(ValueError):
    """A kept checkpoint a job cannot resume (damaged, another run's, of another job),
    refused the same way at every resume: its message says which folder to delete."""


def _restore(
    store: CheckpointStore, key: str, space: Any, provenance: dict, reward_range: tuple,
    trials: range,
) -> LifelongLearner | None:
    """The checkpoint at ``key``, if there is one, refused (``ValueError`` naming the
    field) if another configuration or job wrote it, if the number of its trials is not
    in ``trials``, if its rewards are ones the environment cannot have paid, or if it is
    damaged (a file truncated, edited or gone): each message says how to go on."""
    where = f"{store.location}/{key}" if is_uri(store.location) else os.fspath(
        Path(store.location) / key)
    hint = ("delete that folder to run this method of the job again, unless it is "
            "another run's (a storage shared by two runs: give this one a storage of its own)")
    try:
        learner = store.restore(key, space)
    except ValueError as exc:  # a resume reads it the same way every time: say what helps
        raise CheckpointRefused(f"{where}: the checkpoint cannot be resumed: {exc}; {hint}") from exc
    if learner is None:
        return None
    if learner.provenance is None:
        raise CheckpointRefused(f"{where}: the checkpoint records no provenance; {hint}")
    diffs = json_differences(learner.provenance, provenance)
    if diffs:
        raise CheckpointRefused(
            f"{where}: the checkpoint comes from another run ({'; '.join(diffs)}); {hint}"
        )
    if learner.n_trials not in trials:
        raise CheckpointRefused(f"{where}: the checkpoint holds {learner.n_trials} trials, this job "
                         f"checkpoints {trials.start} to {trials.stop - 1} there; {hint}")
    low, high = reward_range
    for i, record in enumerate(learner.records):
        if not all(low <= r <= high for r in record.rewards):
            raise CheckpointRefused(
                f"{where}: records[{i}].rewards lie outside the environment's range "
                f"[{low:g}, {high:g}]; {hint}"
            )
    return learner


LIFELONG_SERIES: dict[str, Constraint] = {
    "library_size": Integer(0),
    "options_offered": Integer(0),
    "options_used": Integer(0),
    "rollout_success_rate": Real(0.0, 1.0),
}
"""A lifelong method's series, one value per task of the stream (from its trial records)."""


def lifelong_entry(records: Sequence[TrialRecord], targets: Iterable[int]) -> dict[str, Any]:
    """A lifelong method's entry of ``result.json``: the curves on the targets and, per
    task, the library size, options offered and used, and rollout success."""
    return {
        "curves": {str(t): list(records[t].rewards) for t in targets},
        "library_size": [r.library_size for r in records],
        "options_offered": [r.options_offered for r in records],
        "options_used": [len(r.options_used) for r in records],
        "rollout_success_rate": [r.rollout_success_rate for r in records],
    }


class PrqMethod(Method):
    """PRQ-learning on every target, reusing the policies learnt anew on earlier tasks."""

    name = "prq"
    label = "PRQ-learning (policy reuse)"
    reuses = ("scratch",)

    def run(self, job: Job) -> dict[str, Any]:
        scratch = job.learners["scratch"]
        cfg = job.cfg
        lc = cfg.lifelong.learner
        curves = {}
        for t in job.targets:
            learner_seed, env_seed, _, _ = trial_seeds(job.seed, job.tasks_before(t))
            prq = PrqLearner(scratch.n_primitive, scratch.tile_coder, scratch.policies[:t],
                             lc, cfg.prq, seed=learner_seed)
            env = make_env(cfg.env_id, job.stream.tasks[t])
            results = prq.train(env, cfg.lifelong.train_episodes, seed=env_seed)
            curves[str(t)] = [float(r.total_reward) for r in results]
        return {"curves": curves}


@dataclass(frozen=True)
class FineTuneMethod(Method):
    """Fine-tuning on every target: a learner with the base learner's settings starts from
    the values of a source policy that learning anew learnt (chosen by ``start``; any
    episodes it spends choosing on the target are charged to the target's budget and are
    the first points of its curve), then learns."""

    name: str
    label: str
    start: StartRule = field(default_factory=LatestPast)
    """How the source policy is chosen."""
    value_bounds: tuple[float, float] | None = None
    """The learner's ``value_bounds`` (``None``: the base configuration's): the control of
    the methods whose targets are clipped, with the same base learner but no option."""
    reuses: tuple[str, ...] = ("scratch",)

    def run(self, job: Job) -> dict[str, Any]:
        scratch = job.learners["scratch"]
        curves = {}
        for t in job.targets:
            _, results = self.learn_target(job.cfg, job.seed, scratch, job.tasks_before(t),
                                           make_env(job.cfg.env_id, job.stream.tasks[t]))
            curves[str(t)] = [float(r.total_reward) for r in results]
        return {"curves": curves}

    def learn_target(
        self, cfg: MethodSettings, seed: int, scratch: LifelongLearner, before: int,
        env: Any,
    ) -> tuple[SmdpLearner, list[EpisodeResult]]:
        """Fine-tune on one target, the job's seed ``seed`` and ``before`` tasks before it,
        from the policies of learning anew's learner ``scratch``: the learner it leaves and
        its episodes (a function of these arguments alone, so it can be played again)."""
        # Only a start that reads the sources' bags of states is handed them.
        bags = scratch.bags[:before] if getattr(self.start, "uses_bags", False) else None
        return fine_tune(cfg, seed, before, env, scratch.n_primitive, scratch.tile_coder,
                         scratch.policies[:before], self.start, self.value_bounds, bags)


def fine_tune(
    cfg: MethodSettings, seed: int, before: int, env: Any, n_primitive: int,
    tile_coder: TileCoder, policies: Sequence[FrozenPolicy], start: StartRule,
    value_bounds: tuple[float, float] | None = None,
    bags: Sequence[Any] | None = None,
) -> tuple[SmdpLearner, list[EpisodeResult]]:
    """A learner with the base learner's settings (``value_bounds`` replaced unless
    ``None``) on one target, seeded as learning anew's learner of the task after
    ``before`` others is, its values chosen by ``start`` among ``policies``, then learning
    for the rest of the budget: the learner it leaves and its episodes."""
    learner_seed, env_seed, _, _ = trial_seeds(seed, before)
    config = cfg.lifelong.learner
    if value_bounds is not None:
        config = replace(config, value_bounds=value_bounds)
    learner = SmdpLearner(n_primitive, tile_coder, None, config, seed=learner_seed)
    results = learn_with(start, learner, policies, env, cfg.lifelong.train_episodes,
                         seed=env_seed, choice_seed=choice_seed(seed, before), bags=bags)
    return learner, results


@dataclass(frozen=True)
class CrossSizeMethod(Method):
    """Transfer across drill sizes: learning anew on the sources in the drill
    ``source_scenario`` (the same seeds, budget and learner as learning anew in this
    drill), then on every target a learner of this drill that starts from the latest
    source policy carried over by the inter-task mapping
    (:func:`~ilpss.experiments.cross_size.keepaway_mapping`, :func:`~ilpss.transfer.map_policy`)
    and learns. Everything else is fine-tuning's (:func:`fine_tune`): against learning anew
    in this drill, only the start differs; against fine-tuning from the latest source,
    only the drill the sources were learnt in. The source trials are not charged to the
    target (they are the sources' learning, as fine-tuning's are learning anew's) and are
    kept in no checkpoint: a job stopped before its result is written learns them again."""

    name: str
    label: str
    source_scenario: str = drill_facts.SCENARIO
    """The drill (``ExperimentConfig.scenario``'s names) the sources are learnt in."""
    value_bounds: tuple[float, float] | None = None
    reuses: tuple[str, ...] = ("scratch",)

    def run(self, job: Job) -> dict[str, Any]:
        cfg = job.cfg
        target_drill = cfg.drill
        if target_drill is None:
            raise ValueError(f"method {self.name!r} maps the drill's features; the "
                             f"environment {cfg.env_id!r} is not a scenario of the drill")
        source_drill = drill_facts.holder_drill(self.source_scenario)
        mapping = keepaway_mapping(source_drill, target_drill)
        scratch = job.learners["scratch"]  # this drill's tile coder and actions
        sources = self.learn_sources(job, source_drill)
        curves = {}
        for t in job.targets:
            before = job.tasks_before(t)
            mapped = [map_policy(sources.policies[before - 1], scratch.tile_coder,
                                 mapping.features, mapping.actions)] if before else []
            _, results = fine_tune(cfg, job.seed, before,
                                   make_env(cfg.env_id, job.stream.tasks[t]),
                                   scratch.n_primitive, scratch.tile_coder, mapped,
                                   LatestPast(), self.value_bounds)
            curves[str(t)] = [float(r.total_reward) for r in results]
        return {"curves": curves}

    def learn_sources(self, job: Job, drill: drill_facts.HolderDrill) -> LifelongLearner:
        """Learning anew on the tasks before the job's targets, in ``drill``: the
        lifelong learner of method ``scratch`` of a run of that drill with this seed."""
        cfg, stream = job.cfg, job.stream
        sources = max(job.tasks_before(t) for t in job.targets)
        config = replace(cfg.lifelong, options="none", learner=replace(
            cfg.lifelong.learner, tile_widths=drill.tile_widths))
        env0 = make_env(drill.env_id, stream.tasks[0])
        learner = LifelongLearner(config, env0.observation_space, int(env0.action_space.n),
                                  job.seed)
        for task in stream.tasks[:sources]:
            learner.run_trial(make_env(drill.env_id, task), task.name)
        return learner


def _plus(base: LifelongConfig) -> dict[str, Any]:
    """The fields that :func:`~ilpss.lifelong.handing_back` changes (ILPSS+)."""
    plus = handing_back(base)
    return {"kernel_reg_covar": plus.kernel_reg_covar, "learner": plus.learner,
            "library": plus.library}


def _fine_tuned(base: LifelongConfig, options: str, step_targets: str = "every_choice",
                option_values: str = "policy",
                value_bounds: tuple[float, float] | None = None,
                option_traces: str | None = None) -> dict[str, Any]:
    """ILPSS-FT's fields: ILPSS+'s regions and library, a start from the latest past
    policy's values (``options``: its reuse), options valued from their own policies,
    handed back by value (interruption) rather than by a fading bonus; ``step_targets``:
    what the steps inside an option bootstrap from; ``option_values``: from which of a
    policy's values its option's start; ``value_bounds``: the range its targets are
    clipped into; ``option_traces``: whether an option's choice keeps the traces
    (``None``, for both: the base configuration's)."""
    plus = handing_back(base)
    bounds = base.learner.value_bounds if value_bounds is None else value_bounds
    traces = base.learner.option_traces if option_traces is None else option_traces
    return {"options": options, "kernel_reg_covar": plus.kernel_reg_covar,
            "library": plus.library,
            "learner": replace(base.learner, option_values=option_values, interruption=True,
                               intra_option_primitives=True, step_targets=step_targets,
                               value_bounds=bounds, option_traces=traces)}


def _bounded_cut(base: LifelongConfig, options: str,
                 step_targets: str = "every_choice") -> dict[str, Any]:
    """:func:`_fine_tuned` with values bounded by the drill's returns (one reward an
    episode, undiscounted) and the traces cut before an option."""
    return _fine_tuned(base, options, step_targets, value_bounds=drill_facts.EPISODE_REWARD,
                       option_traces="cut")


METHODS = Registry("ilpss.methods", "method", Method)
"""Every method, by name."""


def register_method(method: Method, *, overwrite: bool = False) -> None:
    """Register ``method`` under its ``name`` for this process."""
    METHODS.add(method, overwrite=overwrite)


for _method in (
    LifelongMethod("ilpss", "ILPSS (kernel options)"),
    LifelongMethod("scratch", "learning anew", lambda base: {"options": "none"}),
    LifelongMethod("whole_policies", "whole past policies as options",
                   lambda base: {"options": "whole_policies"}),
    PrqMethod(),
    LifelongMethod("ilpss_no_discount", "ILPSS without discounting",
                   lambda base: {"library": replace(base.library, discount=1.0)},
                   ablates=("ilpss", "discounting")),
    LifelongMethod("ilpss_plus", "ILPSS+ (options first, handed back)", _plus),
    LifelongMethod("whole_policies_plus", "whole past policies, ILPSS+'s settings",
                   lambda base: {**_plus(base), "options": "whole_policies"}),
    LifelongMethod("ilpss_plus_no_discount", "ILPSS+ without discounting",
                   lambda base: {**_plus(base), "library": replace(
                       _plus(base)["library"], discount=1.0)},
                   ablates=("ilpss_plus", "discounting")),
    FineTuneMethod("finetune", "fine-tuning from the latest source", LatestPast()),
    FineTuneMethod("finetune_best", "fine-tuning from the best source (10 episodes each)",
                   BestOfPast()),
    FineTuneMethod("finetune_best_recent",
                   "fine-tuning from the best of the 3 latest sources (10 episodes each)",
                   BestOfPast(recent=3)),
    # The controls of the bounded methods: the same base learner, without options (the
    # traces' rule, kept or cut before an option, is moot without options).
    FineTuneMethod("finetune_bounded", "fine-tuning from the latest source, values bounded",
                   LatestPast(), value_bounds=drill_facts.EPISODE_REWARD),
    # The start chooses its source per state, gated by ILPSS's kernels (ilpss.statewise).
    FineTuneMethod("finetune_statewise_bounded",
                   "fine-tuning from a start that chooses its source per state (ILPSS's "
                   "kernels as the gate), values bounded", StatewiseStart(),
                   value_bounds=drill_facts.EPISODE_REWARD),
    FineTuneMethod("finetune_best_bounded",
                   "fine-tuning from the best source (10 episodes each), values bounded",
                   BestOfPast(), value_bounds=drill_facts.EPISODE_REWARD),
    # Fine-tuning that builds on itself: each task starts from the policy this method
    # learnt on the task before (the sources too), as the ILPSS-FT family's starts chain.
    LifelongMethod("finetune_chained", "fine-tuning chained (from its own latest policy)",
                   lambda base: {"options": "finetune_latest"}),
    LifelongMethod("finetune_chained_bounded",
                   "fine-tuning chained (from its own latest policy), values bounded",
                   lambda base: {"options": "finetune_latest", "learner": replace(
                       base.learner, value_bounds=drill_facts.EPISODE_REWARD)}),
    # Transfer across sizes: the sources learnt anew in the paper's 2 v 2 drill, the latest
    # policy carried to this drill by keepaway's inter-task mapping (ilpss.experiments.
    # cross_size), then learnt as fine-tuning learns.
    CrossSizeMethod("transfer_2v2", "fine-tuning from the latest source learnt at 2v2, mapped"),
    LifelongMethod("ilpss_ft", "ILPSS-FT (fine-tuned start, options valued by their policies)",
                   lambda base: _fine_tuned(base, "kernels_finetune")),
    LifelongMethod("whole_policies_ft", "whole past policies, ILPSS-FT's settings",
                   lambda base: _fine_tuned(base, "whole_policies_finetune")),
    LifelongMethod("ilpss_ft_available",
                   "ILPSS-FT, steps inside options bootstrapped from the available choices",
                   lambda base: _fine_tuned(base, "kernels_finetune", "available_choices")),
    LifelongMethod("ilpss_ft_available_primitives",
                   "ILPSS-FT, steps bootstrapped from the available choices, options valued "
                   "from their policies' primitives",
                   lambda base: _fine_tuned(base, "kernels_finetune", "available_choices",
                                            "policy_primitives")),
    # The drill pays one reward an episode, undiscounted: its returns are its episode's.
    LifelongMethod("ilpss_ft_bounded", "ILPSS-FT, targets clipped to the drill's returns",
                   lambda base: _fine_tuned(base, "kernels_finetune",
                                            value_bounds=drill_facts.EPISODE_REWARD)),
    LifelongMethod("whole_policies_ft_bounded",
                   "whole past policies, ILPSS-FT's settings, targets clipped to the "
                   "drill's returns",
                   lambda base: _fine_tuned(base, "whole_policies_finetune",
                                            value_bounds=drill_facts.EPISODE_REWARD)),
    LifelongMethod("ilpss_ft_bounded_cut",
                   "ILPSS-FT, values bounded, traces cut before an option",
                   lambda base: _bounded_cut(base, "kernels_finetune")),
    LifelongMethod("whole_policies_ft_bounded_cut",
                   "whole past policies, ILPSS-FT's settings, values bounded, traces cut "
                   "before an option",
                   lambda base: _bounded_cut(base, "whole_policies_finetune")),
    # The kernel-free method with the oracles' and the kernel method's base learner: steps
    # inside an option bootstrapped from the primitives, so that regions against no regions
    # is a comparison of one base learner.
    LifelongMethod("whole_policies_ft_bounded_cut_primitives",
                   "whole past policies, ILPSS-FT's settings, values bounded, traces cut "
                   "before an option, steps inside options bootstrapped from the primitives",
                   lambda base: _bounded_cut(base, "whole_policies_finetune",
                                             "primitive_choices")),
    LifelongMethod("ilpss_ft_bounded_cut_available",
                   "ILPSS-FT, values bounded, traces cut before an option, steps inside "
                   "options bootstrapped from the available choices",
                   lambda base: _bounded_cut(base, "kernels_finetune", "available_choices")),
    LifelongMethod("ilpss_ft_bounded_cut_primitives",
                   "ILPSS-FT, values bounded, traces cut before an option, steps inside "
                   "options bootstrapped from the primitives",
                   lambda base: _bounded_cut(base, "kernels_finetune", "primitive_choices")),
    LifelongMethod("ilpss_ft_oracle", "ILPSS-FT with the true regions as kernels (oracle)",
                   lambda base: _fine_tuned(base, "oracle_regions_finetune")),
    # The sharp test's oracles, with the kernel method's settings: the target's true
    # regions (which past policy runs in each learnt), and the regions with their sources.
    LifelongMethod("true_regions_ft_bounded_cut_primitives",
                   "the target's true regions, every past policy in each (oracle), "
                   "ILPSS-FT's settings, values bounded, traces cut, primitives' targets",
                   lambda base: _bounded_cut(base, "true_regions_finetune",
                                             "primitive_choices")),
    LifelongMethod("assigned_regions_ft_bounded_cut_primitives",
                   "the target's true regions, each with its source's policy (assignment "
                   "oracle), ILPSS-FT's settings, values bounded, traces cut, primitives' "
                   "targets",
                   lambda base: _bounded_cut(base, "assigned_regions_finetune",
                                             "primitive_choices")),
):
    register_method(_method)
