"""Ways of reusing past policies: what a lifelong learner offers its learner at a new task.

A :class:`Reuse` is named by ``LifelongConfig.options`` and answers, for the lifelong loop
(:class:`~ilpss.lifelong.LifelongLearner`), the two questions in which reuse methods
differ; the loop itself knows no method by name:

===============================  ============================================================
question                         answered by
===============================  ============================================================
the regions of the options, and  :attr:`Reuse.regions`, a :class:`Regions`: the kernel model
whether there are options        refitted after every trial on all bags of states (EM for
                                 ILPSS, one kernel over everything for whole policies,
                                 ``None``: no options); the option library built from it
                                 and the past policies is what is kept between trials, with
                                 the policies and the bags (a checkpoint reads the model
                                 back with :meth:`Regions.load`)
the values the new learner       :attr:`Reuse.start`, a :class:`StartRule`: nothing (values
starts from, and any episodes    from the learner's initial value), the latest past policy's
it spends on the task choosing   values (fine-tuning), or the values of the past policy that
                                 does best in a few greedy episodes on the task; the episodes
                                 spent choosing are charged to the task's budget (never more
                                 than it) and are the first points of its learning curve
===============================  ============================================================

The registrations (:data:`REUSES`; more with :func:`register_reuse` or the entry-point
group ``ilpss.reuses``):

====================  ====================================  =================================
name                  regions                               start
====================  ====================================  =================================
``kernels``           shared-kernel EM (the paper)          fresh
``whole_policies``    one region everywhere (ablation)      fresh
``none``              no options (learning anew)            fresh
``finetune_latest``   no options                            the latest past policy
``finetune_best``     no options                            the best past policy on the task,
                                                            10 greedy episodes each (charged;
                                                            the latest that fit the budget)
``kernels_finetune``  shared-kernel EM                      the latest past policy
``whole_policies_     one region everywhere                 the latest past policy
finetune``
====================  ====================================  =================================

The oracles' reuses (``oracle_regions_finetune``, ``true_regions_finetune``,
``assigned_regions_finetune``) need the drill's regions, which this module does not
know: :mod:`ilpss.experiments.oracles` holds them, and ``pyproject.toml`` declares them in
the entry-point group, so that their names are registered whatever was imported first.

A start rule also serves methods outside the lifelong loop (the fine-tuning baselines of
:mod:`ilpss.experiments.methods` start from the policies that learning anew learnt).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from ilpss.episode import EpisodeResult
from ilpss.kernels import RegionKernels, SharedKernelModel, UniformKernel
from ilpss.options import OptionLibrary
from ilpss.policy import FrozenPolicy
from ilpss.smdp import SmdpLearner
from soccer_drill.constraints import Integer, check
from soccer_drill.registry import Registry

__all__ = [
    "REUSES",
    "BestOfPast",
    "EmKernels",
    "Fresh",
    "GivenRegions",
    "KernelSettings",
    "LatestPast",
    "OfferRule",
    "Regions",
    "Reuse",
    "StartRule",
    "Uniform",
    "learn_with",
    "register_reuse",
]


# ---------------------------------------------------------------------- regions
class KernelSettings(Protocol):
    """What fitting the regions reads of the lifelong configuration
    (:class:`~ilpss.lifelong.LifelongConfig`, a layer above this module)."""

    n_kernels: int
    kernel_reg_covar: float
    kernel_max_iter: int
    kernel_n_init: int


class Regions(Protocol):
    """How the regions of the options are made after every trial."""

    model_name: str
    """The class name of the kernel model it builds, as checkpoints record it."""

    def fit(self, bags: Sequence[np.ndarray], n_features: int, config: KernelSettings,
            seed: int) -> Any | None:
        """The kernel model over all bags of states so far, or ``None`` to keep the
        options as they are (too few states to fit)."""
        ...

    def load(self, path: Path) -> Any:
        """The kernel model that a checkpoint saved at ``path`` (one that :meth:`fit`
        built)."""
        ...


@dataclass(frozen=True)
class EmKernels:
    """ILPSS's regions: ``n_kernels`` Gaussian kernels shared by every task, fitted by EM
    on all bags of states (:class:`~ilpss.kernels.SharedKernelModel`)."""

    model_name: str = "SharedKernelModel"

    def fit(self, bags: Sequence[np.ndarray], n_features: int, config: KernelSettings,
            seed: int) -> SharedKernelModel | None:
        if sum(len(b) for b in bags) < config.n_kernels * 2:
            return None  # too few successful states to fit: keep the options we have
        return SharedKernelModel(
            config.n_kernels, reg_covar=config.kernel_reg_covar,
            max_iter=config.kernel_max_iter, n_init=config.kernel_n_init, random_state=seed,
        ).fit(bags)

    def load(self, path: Path) -> SharedKernelModel:
        return SharedKernelModel.load(path)


@dataclass(frozen=True)
class Uniform:
    """One region over the whole state space: every past policy becomes an option that
    starts anywhere and runs as the whole policy would (the ablation without kernels)."""

    model_name: str = "UniformKernel"

    def fit(self, bags: Sequence[np.ndarray], n_features: int, config: KernelSettings,
            seed: int) -> UniformKernel:
        return UniformKernel(n_features)

    def load(self, path: Path) -> UniformKernel:
        return UniformKernel.load(path)


@dataclass(frozen=True)
class GivenRegions:
    """Regions that are given rather than fitted (:class:`~ilpss.kernels.RegionKernels`):
    each as a ``(feature index, threshold, below)`` triple, the same after every trial.
    The oracle arm of a stream whose regions are known."""

    regions: tuple[tuple[int, float, bool], ...]
    model_name: str = "RegionKernels"

    def fit(self, bags: Sequence[np.ndarray], n_features: int, config: KernelSettings,
            seed: int) -> RegionKernels:
        features, thresholds, below = zip(*self.regions, strict=True)
        return RegionKernels(n_features, features, thresholds, below)

    def load(self, path: Path) -> RegionKernels:
        return RegionKernels.load(path)


# ---------------------------------------------------------------------- starts
class StartRule(Protocol):
    """The values a new learner starts from, chosen among the past policies."""

    def start(self, learner: SmdpLearner, policies: Sequence[FrozenPolicy], env: Any,
              seed: int, *, budget: int | None = None) -> list[EpisodeResult]:
        """Set ``learner``'s initial values from ``policies``; return the episodes spent
        on ``env`` to choose (charged to the task's budget: the first points of its
        curve), seeded from ``seed``: at most ``budget`` of them (``None``: no bound)."""
        ...


@dataclass(frozen=True)
class Fresh:
    """Start from the learner's own initial values (the paper, learning anew)."""

    def start(self, learner: SmdpLearner, policies: Sequence[FrozenPolicy], env: Any,
              seed: int, *, budget: int | None = None) -> list[EpisodeResult]:
        return []


@dataclass(frozen=True)
class LatestPast:
    """Fine-tuning: start from the primitives' values of the latest past policy (none
    yet: fresh), spending no episode."""

    def start(self, learner: SmdpLearner, policies: Sequence[FrozenPolicy], env: Any,
              seed: int, *, budget: int | None = None) -> list[EpisodeResult]:
        if policies:
            learner.start_from(policies[-1])
        return []


@dataclass(frozen=True)
class BestOfPast:
    """Fine-tuning from the past policy that does best on the task: each past policy is
    run greedily for ``episodes`` episodes on the same episode seeds, and the learner
    starts from the one with the highest mean reward (ties: the latest). Those
    ``episodes x len(policies)`` episodes are charged to the task's budget.

    The choice never spends more than the budget: when it holds fewer than
    ``episodes x len(policies)`` episodes, only the latest ``budget // episodes`` past
    policies are tried, and the best of those is chosen (each tried policy's episodes
    are the same as when all are tried); when not even one can be tried, the learner
    starts from the latest past policy, spending nothing (as :class:`LatestPast`).

    ``recent`` bounds the choice to the latest ``recent`` past policies (``None``: all of
    them), so that its cost does not grow with the length of the stream: on a stream of
    20 opponents, 10 episodes for each of 19 sources would spend 190 of the target's
    episodes choosing."""

    episodes: int = 10
    recent: int | None = None

    def __post_init__(self) -> None:
        check("BestOfPast.episodes", self.episodes, Integer(1, 10_000))
        if self.recent is not None:
            check("BestOfPast.recent", self.recent, Integer(1, 10_000))

    def start(self, learner: SmdpLearner, policies: Sequence[FrozenPolicy], env: Any,
              seed: int, *, budget: int | None = None) -> list[EpisodeResult]:
        if not policies:
            return []
        n = len(policies) if self.recent is None else min(len(policies), self.recent)
        if budget is not None:
            check("BestOfPast budget", budget, Integer(0))
            n = min(n, budget // self.episodes)
        if n == 0:
            learner.start_from(policies[-1])
            return []
        greedy = replace(learner.config, epsilon=0.0)
        spent: list[EpisodeResult] = []
        means = {}
        # Policy k's runner and episodes depend on k alone, so a shorter list of tries
        # plays exactly what the full list would for the same policies.
        for k in range(len(policies) - n, len(policies)):
            runner = SmdpLearner.from_policy(policies[k], None, greedy, seed=[seed, k])
            episodes = runner.evaluate(env, self.episodes, seed=seed)
            spent += episodes
            means[k] = np.mean([e.total_reward for e in episodes])
        best = max(means, key=lambda k: (means[k], k))
        learner.start_from(policies[best])
        return spent


def learn_with(
    start: StartRule, learner: SmdpLearner, policies: Sequence[FrozenPolicy], env: Any,
    episodes: int, *, seed: int | None, choice_seed: int,
    callback: Callable[[int, EpisodeResult], None] | None = None,
    bags: Sequence[np.ndarray] | None = None,
) -> list[EpisodeResult]:
    """``episodes`` episodes on ``env``: first those ``start`` spends choosing the
    learner's initial values among ``policies`` (greedy, seeded by ``choice_seed``, at
    most ``episodes``: the rule is given the budget, and ``bags``, the past policies'
    bags of states, if it declares ``uses_bags``), then learning for the rest of the
    budget (the first reset seeded by ``seed``, so the learning episodes are the same
    ones with or without a choice before them).

    Raises
    ------
    ValueError
        If ``start`` played more episodes than the budget (they would be played on the
        task without being charged).
    """
    check("learn_with episodes (the budget)", episodes, Integer(0))
    if getattr(start, "uses_bags", False):  # a rule that reads the sources' bags of states
        spent = start.start(learner, policies, env, choice_seed, budget=episodes, bags=bags)
    elif _takes_budget(start):
        spent = start.start(learner, policies, env, choice_seed, budget=episodes)
    else:  # a rule written before start rules were given their budget
        spent = start.start(learner, policies, env, choice_seed)
    if len(spent) > episodes:
        raise ValueError(
            f"the start rule {start!r} played {len(spent)} episodes choosing, more than the "
            f"budget of {episodes}; a start rule must stop at its budget"
        )
    return spent + learner.train(env, episodes - len(spent), seed=seed, callback=callback)


def _takes_budget(start: StartRule) -> bool:
    try:
        parameters = inspect.signature(start.start).parameters.values()
    except (TypeError, ValueError):  # no signature to read: the protocol's is assumed
        return True
    return any(p.name == "budget" or p.kind is p.VAR_KEYWORD for p in parameters)


# ---------------------------------------------------------------------- offers
class OfferRule(Protocol):
    """Which of the library's options a task's learner is offered (an oracle's knowledge
    of the task; without a rule, every active option)."""

    def offer(self, library: OptionLibrary, past: Sequence[str], task: str) -> OptionLibrary:
        """The library offered on the task named ``task``, after the tasks named ``past``
        (``past[i]`` is the task of policy ``i``)."""
        ...


# ---------------------------------------------------------------------- reuse
@dataclass(frozen=True)
class Reuse:
    """One way of reusing past policies (see the module docstring).

    Attributes
    ----------
    name : str
        Its name in ``LifelongConfig.options``.
    regions : Regions or None
        How the options' regions are refitted after every trial; ``None``: no options.
    start : StartRule
        The values the learner of a new task starts from.
    offer : OfferRule or None
        Which options a task's learner is offered (``None``: every active option).
    """

    name: str
    regions: Regions | None
    start: StartRule = Fresh()
    offer: OfferRule | None = None

    def __post_init__(self) -> None:
        # Checked when the reuse is made: a wrong part failed only inside every job,
        # after its sources had trained.
        parts = (("regions", self.regions, ("fit", "load"), "a Regions (fit, load, model_name) "
                  "or None", True),
                 ("start", self.start, ("start",), "a StartRule (start)", False),
                 ("offer", self.offer, ("offer",), "an OfferRule (offer) or None", True))
        for field_name, part, methods, what, optional in parts:
            if part is None and optional:
                continue
            named = field_name != "regions" or isinstance(getattr(part, "model_name", None), str)
            if not (named and all(callable(getattr(part, m, None)) for m in methods)):
                raise TypeError(f"reuse {self.name!r}: {field_name} is {what}, not "
                                f"{type(part).__name__} {part!r:.60}")

    @property
    def offers_options(self) -> bool:
        """Whether a new task's learner is offered options."""
        return self.regions is not None

    @property
    def model_name(self) -> str | None:
        """The kernel model its checkpoints hold (``None``: none)."""
        return None if self.regions is None else self.regions.model_name


REUSES = Registry("ilpss.reuses", "reuse", Reuse)
"""Every way of reusing past policies, by name (``LifelongConfig.options``)."""


def register_reuse(reuse: Reuse, *, overwrite: bool = False) -> None:
    """Register ``reuse`` under its ``name`` for this process."""
    REUSES.add(reuse, overwrite=overwrite)


for _reuse in (
    Reuse("kernels", EmKernels()),
    Reuse("whole_policies", Uniform()),
    Reuse("none", None),
    Reuse("finetune_latest", None, LatestPast()),
    Reuse("finetune_best", None, BestOfPast()),
    Reuse("kernels_finetune", EmKernels(), LatestPast()),
    Reuse("whole_policies_finetune", Uniform(), LatestPast()),
):
    register_reuse(_reuse)
