"""Transfer of action values between tasks of different state and action spaces, by an
inter-task mapping (Taylor, Stone and Liu 2007, "Transfer learning via inter-task mappings
for temporal difference learning", JMLR 8).

An inter-task mapping says, for every state variable of the target task, the variable of
the source task it is most like (``features``), and for every action of the target task
the source action most like it (``actions``). With keepaway's one-dimensional tilings
(:class:`~ilpss.tiles.TileCoder`) the action value is a sum over the variables of the
weights of their active tiles, so the source's values are carried over as Taylor and
Stone's ``rho_CMAC`` does: each tile of target variable ``j`` for action ``a`` takes the
weight of the same tile of source variable ``features[j]`` for action ``actions[a]``. A
variable and the one it is mapped to must be tiled alike (the same range, width and
number of tilings), so that "the same tile" covers the same values.

With more target variables than source ones, the copied variables count again: at a
target state whose variables equal those they are mapped to, each action's value is its
mapped action's value in the source plus the copied variables' weights, which may change
which action is greedy. The values are a start that learning corrects, as in Taylor and
Stone's transfer; where the source's values do not depend on the variables copied more
than once, the greedy actions are exactly the mapped ones (``tests/test_ilpss_sizes.py``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ilpss.policy import FrozenPolicy
from ilpss.tiles import TileCoder


def map_policy(
    policy: FrozenPolicy, coder: TileCoder, features: Sequence[int], actions: Sequence[int],
) -> FrozenPolicy:
    """``policy`` (of a source task) carried to a target task over ``coder``: the target's
    variable ``j`` takes the weights of the source's variable ``features[j]``, its action
    ``a`` those of the source's action ``actions[a]`` (every target action a primitive;
    the source policy's options are not carried).

    Raises
    ------
    ValueError
        A mapping of the wrong length or naming a variable or action the source lacks, or
        a variable tiled otherwise than the one it is mapped to (the message names both).
    """
    source = policy.tile_coder
    features = [int(f) for f in features]
    actions = [int(a) for a in actions]
    if len(features) != coder.n_features:
        raise ValueError(f"the mapping names {len(features)} variables, the target has "
                         f"{coder.n_features}")
    if not actions:
        raise ValueError("the mapping names no target action")
    for j, f in enumerate(features):
        if not 0 <= f < source.n_features:
            raise ValueError(f"target variable {j} is mapped to source variable {f}, and the "
                             f"source has {source.n_features}")
        tiled = (source.low[f], source.high[f], source.widths[f], source.n_tilings)
        here = (coder.low[j], coder.high[j], coder.widths[j], coder.n_tilings)
        if tiled != here:
            raise ValueError(
                f"target variable {j} (range [{here[0]:g}, {here[1]:g}], width {here[2]:g}, "
                f"{here[3]} tilings) is mapped to source variable {f}, tiled otherwise "
                f"(range [{tiled[0]:g}, {tiled[1]:g}], width {tiled[2]:g}, {tiled[3]} tilings)")
    for a, b in enumerate(actions):
        if not 0 <= b < policy.n_primitive:
            raise ValueError(f"target action {a} is mapped to source action {b}, and the source "
                             f"has {policy.n_primitive} primitive actions")
    weights = np.empty((len(actions), coder.n_weights))
    mapped = policy.weights[actions]  # one row per target action
    for j, f in enumerate(features):
        weights[:, coder.feature_tiles(j)] = mapped[:, source.feature_tiles(f)]
    return FrozenPolicy(coder, len(actions), (), weights)
