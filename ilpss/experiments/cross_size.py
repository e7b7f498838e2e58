"""The inter-task mapping between drills of different sizes (keepaway's, after Taylor,
Stone and Liu 2007).

The holder's features at every size are keepaway's (``drill_facts.HolderDrill``), one
kind per block, teammates and opponents each ranked by distance:

=====================  ============================  ==================================
kind                   per                           the target's k-th is mapped to
=====================  ============================  ==================================
``dist_mate``          teammate                      the source's ``min(k, m_source)``-th
``dist_opp``           opponent                      the source's ``min(k, d_source)``-th
``mate_dist_opp``      teammate                      as ``dist_mate``
``pass_angle``         teammate                      as ``dist_mate``
``dist_goal``,         the holder                    itself
``lateral``
``mate_dist_goal``     teammate                      as ``dist_mate``
``dribble_angle``      the holder                    itself
=====================  ============================  ==================================

A novel teammate (or opponent), farther than any the source had, is mapped to the
farthest one the source had, the most similar old one: Taylor and Stone map keepaway's
fourth keeper to the third and the third taker to the second when going from 3 v 2 to
4 v 3. The actions likewise: ``HOLD`` to ``HOLD``, ``DRIBBLE`` to ``DRIBBLE``, the pass
to the k-th nearest teammate to the pass to the source's ``min(k, m_source)``-th. From
2 v 2 to 3 v 2 both teammates' variables are the one teammate's, and both passes the one
pass.
"""

from __future__ import annotations

from dataclasses import dataclass

from ilpss.experiments.drill_facts import HolderDrill


@dataclass(frozen=True)
class InterTaskMapping:
    """For every variable and action of the target, the source's it is mapped to."""

    features: tuple[int, ...]
    """Target variable ``j`` is the source's ``features[j]``."""
    actions: tuple[int, ...]
    """Target action ``a`` is the source's ``actions[a]``."""

    def table(self, source: HolderDrill, target: HolderDrill) -> list[str]:
        """The mapping as markdown rows: target name, source name."""
        rows = ["| target (" + target.scenario + ") | source (" + source.scenario + ") |",
                "|---|---|"]
        rows += [f"| `{target.feature_names[j]}` | `{source.feature_names[f]}` |"
                 for j, f in enumerate(self.features)]
        rows += [f"| action `{target.action_names[a]}` | action `{source.action_names[b]}` |"
                 for a, b in enumerate(self.actions)]
        return rows


def keepaway_slots(mates: int, opponents: int) -> list[tuple[str, int]]:
    """``(kind, rank)`` of every feature of a holder with ``mates`` teammates and
    ``opponents`` opponents, by index (rank 1 is the nearest; 0 for the holder's own)."""
    by_mate = range(1, mates + 1)
    return [*(("dist_mate", k) for k in by_mate),
            *(("dist_opp", k) for k in range(1, opponents + 1)),
            *(("mate_dist_opp", k) for k in by_mate),
            *(("pass_angle", k) for k in by_mate),
            ("dist_goal", 0), ("lateral", 0),
            *(("mate_dist_goal", k) for k in by_mate),
            ("dribble_angle", 0)]


def keepaway_mapping(source: HolderDrill, target: HolderDrill) -> InterTaskMapping:
    """The mapping of the module's table from ``source``'s holder to ``target``'s.

    Raises
    ------
    ValueError
        The target has teammates and the source none (a pass or a teammate's variable
        would have nothing to be mapped to).
    """
    if target.teammates and not source.teammates:
        raise ValueError(
            f"{target.scenario}'s holder has {target.teammates} teammate(s) and "
            f"{source.scenario}'s none: its passes and teammates' variables have nothing to "
            "be mapped to; transfer from a drill with 2 attackers or more")
    slots = keepaway_slots(source.teammates, source.opponents)
    for drill in (source, target):  # the layout the drill's features follow
        if len(keepaway_slots(drill.teammates, drill.opponents)) != len(drill.feature_names):
            raise ValueError(f"{drill.scenario}'s holder has {len(drill.feature_names)} "
                             "features, not keepaway's 4 m + d + 3")
    index = {slot: i for i, slot in enumerate(slots)}
    features = []
    for kind, rank in keepaway_slots(target.teammates, target.opponents):
        most = source.opponents if kind == "dist_opp" else source.teammates
        features.append(index[kind, min(rank, most)])
    passes = [min(k, source.teammates) for k in range(1, target.teammates + 1)]
    actions = (0, *passes, source.teammates + 1)
    return InterTaskMapping(tuple(features), actions)
