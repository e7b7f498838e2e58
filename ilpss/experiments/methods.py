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
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

from ilpss.baselines import PrqLearner
from ilpss.experiments.checkpoints import CheckpointStore, run_lifelong
from ilpss.experiments.protocols import Stream, make_env
from ilpss.experiments.registry import Registry
from ilpss.lifelong import (
    LifelongConfig,
    LifelongLearner,
    TrialRecord,
    handing_back,
    trial_seeds,
)

if TYPE_CHECKING:
    from ilpss.experiments.config import ExperimentConfig

__all__ = [
    "METHODS",
    "Job",
    "LifelongMethod",
    "Method",
    "PrqMethod",
    "lifelong_entry",
    "register_method",
]


@dataclass
class Job:
    """One (seed, stream) job: what its methods run on, and the learners they leave."""

    cfg: ExperimentConfig
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

    def config(self, base: LifelongConfig) -> LifelongConfig:
        """This method's lifelong configuration."""
        return replace(base, **self.changes(base))

    def run(self, job: Job) -> dict[str, Any]:
        learner, records = run_lifelong(job, self.name, self.config(job.cfg.lifelong))
        job.learners[self.name] = learner
        return lifelong_entry(records, job.targets)


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


def _plus(base: LifelongConfig) -> dict[str, Any]:
    """The fields that :func:`~ilpss.lifelong.handing_back` changes (ILPSS+)."""
    plus = handing_back(base)
    return {"kernel_reg_covar": plus.kernel_reg_covar, "learner": plus.learner,
            "library": plus.library}


METHODS = Registry("ilpss.methods", "method")
"""Every method, by name."""


def register_method(method: Method, *, overwrite: bool = False) -> None:
    """Register ``method`` under its ``name`` for this process."""
    if not isinstance(method, Method):
        raise TypeError(f"a method must be a Method, got {type(method).__name__}")
    METHODS.register(method.name, method, overwrite=overwrite)


for _method in (
    LifelongMethod("ilpss", "ILPSS (kernel options)"),
    LifelongMethod("scratch", "learning anew", lambda base: {"options": "none"}),
    LifelongMethod("whole_policies", "whole past policies as options",
                   lambda base: {"options": "whole_policies"}),
    PrqMethod(),
    LifelongMethod("ilpss_no_discount", "ILPSS without discounting",
                   lambda base: {"library": replace(base.library, discount=1.0)}),
    LifelongMethod("ilpss_plus", "ILPSS+ (options first, handed back)", _plus),
    LifelongMethod("whole_policies_plus", "whole past policies, ILPSS+'s settings",
                   lambda base: {**_plus(base), "options": "whole_policies"}),
    LifelongMethod("ilpss_plus_no_discount", "ILPSS+ without discounting",
                   lambda base: {**_plus(base), "library": replace(
                       _plus(base)["library"], discount=1.0)}),
):
    register_method(_method)
