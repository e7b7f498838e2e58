"""The oracle arms of the region streams: options offered from a target's true regions.

A region-composed target (:data:`~ilpss.experiments.drill_facts.TEAM_COMPOSITION`) plays one
source's behaviour on one side of a split of one feature and another source's on the
other. The oracles' kernels are given regions, the same after every trial
(:data:`GIVEN_REGIONS`): one that holds every state, and both sides of each known split
(:data:`~ilpss.experiments.drill_facts.REGION_SPLITS`,
:data:`~ilpss.experiments.drill_facts.SHARP_SPLITS`). On a task that is not region-composed (a
source) they offer the active options of the region that holds every state: whole past
policies, as ``whole_policies_finetune`` does. On a target they offer only the options of
its own split:

=====================  ==============================================================
offer rule             what a target's learner is offered
=====================  ==============================================================
:class:`TrueRegions`   both sides of the target's split, each with every past policy:
                       the regions known, which policy to run in each learnt
:class:`TrueRegions`   both sides, each with the past policy of the source the target
(``assigned=True``)    plays there (the latest trial of that source): the
                       hand-composed policy as options, the assignment known too
=====================  ==============================================================

So the two oracles offer what whole past policies offer everywhere but on the targets,
and differ from each other only in the assignment.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ilpss.experiments import drill_facts
from ilpss.kernels import RegionKernels
from ilpss.options import OptionLibrary
from ilpss.reuse import GivenRegions, LatestPast, Reuse

__all__ = [
    "ASSIGNED_REGIONS_FINETUNE",
    "ORACLE_REGIONS_FINETUNE",
    "TRUE_REGIONS_FINETUNE",
    "TrueRegions",
]


@dataclass(frozen=True)
class TrueRegions:
    """Offer a region-composed target the options of its own split (see the module
    docstring); ``assigned``: only the right source's policy on each side.
    ``composition`` names the function that says what a task is composed of (``"module:
    attribute"``, as :data:`~ilpss.experiments.drill_facts.TEAM_COMPOSITION`)."""

    assigned: bool = False
    composition: str = drill_facts.TEAM_COMPOSITION
    everywhere: int = 0
    """The position of the given region that holds every state."""

    def offer(self, library: OptionLibrary, past: Sequence[str], task: str) -> OptionLibrary:
        model = library.kernel_model
        if not isinstance(model, RegionKernels):
            raise ValueError(f"the oracle's offer needs given regions (RegionKernels), the "
                             f"library's kernels are a {type(model).__name__}")
        known = drill_facts.drill_object(self.composition)(task)
        if known is None:
            return library.only([(k, p) for k, p in zip(
                library.option_kernel.tolist(), library.option_policy.tolist(), strict=True)
                if k == self.everywhere])
        feature, threshold, team_below, team_above = known
        pairs = []
        for below, team in ((True, team_below), (False, team_above)):
            side = np.flatnonzero((model.features == feature) & (model.thresholds == threshold)
                                  & (model.below == below))
            if side.size == 0:
                given = list(zip(model.features.tolist(), model.thresholds.tolist(), strict=True))
                raise ValueError(f"target {task!r} splits feature {feature} at {threshold:g}, "
                                 f"which is not among the given regions {given}")
            if not self.assigned:
                pairs += [(int(side[0]), p) for p in range(len(library.policies))]
                continue
            trials = [i for i, name in enumerate(past) if name == team]
            if not trials:
                raise ValueError(f"target {task!r} plays {team!r} on one side, but no past "
                                 f"task is {team!r} (past tasks: {list(past)})")
            pairs.append((int(side[0]), trials[-1]))
        return library.only(pairs)


_SPLITS = (*drill_facts.REGION_SPLITS, *drill_facts.SHARP_SPLITS)
EVERYWHERE = (drill_facts.GOAL_DISTANCE, 1e9, True)
"""A region that holds every state (no distance reaches 1e9 m)."""
GIVEN_REGIONS = GivenRegions((EVERYWHERE, *((feature, threshold, below)
                                            for feature, threshold in _SPLITS
                                            for below in (True, False))))
"""The oracles' kernels: every state, then both sides of each known split."""

# The reuses are declared as entry points of the group ``ilpss.reuses`` (pyproject.toml),
# so that ``LifelongConfig(options=...)`` accepts their names whatever was imported first
# (this module is higher than :mod:`ilpss.reuse`, which may not import it).
ORACLE_REGIONS_FINETUNE = Reuse(
    "oracle_regions_finetune",
    GivenRegions(tuple((feature, threshold, below) for feature, threshold in drill_facts.REGION_SPLITS
                       for below in (True, False))),
    LatestPast(),
)
"""Protocol R's oracle arm, as it was first run: both sides of R's splits, every one offered
on every task."""
TRUE_REGIONS_FINETUNE = Reuse("true_regions_finetune", GIVEN_REGIONS, LatestPast(),
                              TrueRegions())
"""The sharp test's oracle: a target offered both sides of its own split."""
ASSIGNED_REGIONS_FINETUNE = Reuse("assigned_regions_finetune", GIVEN_REGIONS, LatestPast(),
                                  TrueRegions(assigned=True))
"""The sharp test's oracle that knows the assignment too: each side offers the policy of the
source played there."""

REUSE_SCENARIOS = {reuse.name: (drill_facts.SCENARIO,) for reuse in (
    ORACLE_REGIONS_FINETUNE, TRUE_REGIONS_FINETUNE, ASSIGNED_REGIONS_FINETUNE)}
"""The drills each oracle's reuse is made for, by its name: their regions split the 2v2
drill's features (an experiment of another scenario refuses them)."""
