"""SMDP Sarsa(lambda) / Watkins's Q(lambda) over primitive actions and kernel options.

The learner follows keepaway's (Stone, Sutton and Kuhlmann 2005): a linear action-value
function over one-dimensional tilings (:mod:`ilpss.tiles`), epsilon-greedy choice with
random tie-breaking, and SMDP updates in which one environment ``step`` may span several
cycles. Defaults are keepaway's: ``alpha = 0.125`` spread over the active tiles,
``epsilon = 0.01``, ``gamma = 1``.

It talks to the environment only through the Gymnasium API, with the contract of
:mod:`ilpss.episode`: any environment with a 1-D ``Box`` observation and a
``Discrete(n)`` action space works. ``info["duration"]`` (the number of cycles the step
took, an int >= 1) is used when present and taken as 1 otherwise; ``info["outcome"]``
is reported when present.

Update rule
-----------
A *choice* ``c`` is either a primitive action or an option from an
:class:`~ilpss.options.OptionLibrary`. It is made at decision state ``s`` and lasts until
the next choice point ``s'``: one step for a primitive, all the steps until the option
terminates for an option (see :mod:`ilpss.options` for its semantics). Over those
steps, with rewards ``r_1 .. r_n`` and durations ``d_1 .. d_n``,

    R = sum_i gamma ** (d_1 + ... + d_{i-1}) * r_i,      D = d_1 + ... + d_n,
    Sarsa:       Q(s, c) += alpha / n_active * (R + gamma ** D * Q(s', c') - Q(s, c)),
    Q-learning:  Q(s, c) += alpha / n_active * (R + gamma ** D * max_{c' avail} Q(s', c')
                                                  - Q(s, c)),

where ``c'`` is the choice made at ``s'`` among the primitives and the options whose
initiation was sampled there. At the end of an episode the target is ``R`` alone. A
truncated episode (time limit) is treated as terminal by default, because the drill pays
its failure reward at the time limit, which makes the limit part of the task; pass
``bootstrap_on_truncation=True`` for environments where truncation is not.

With ``trace_decay = lambda > 0`` the error ``delta`` of each choice point's update is
also applied to the weights of earlier choice points of the episode, in proportion to
their eligibility (Sarsa(lambda); Watkins's Q(lambda) for ``method="q"``, whose traces
are cut after an exploratory choice). Traces are keepaway's *replacing* traces on
tiles: the active tiles of a choice point get eligibility 1 for the choice made and 0
for the other choices; after a choice of duration ``D`` every eligibility is multiplied
by ``gamma ** D * lambda`` and dropped below 0.01. With ``lambda = 0`` this is the
one-step update above; a positive ``lambda`` carries the drill's end-of-episode reward
back along the ~15 decisions of an episode at once.

With ``intra_option=True`` every primitive step also updates, one step at a time, the
primitive action taken and every *other* offered option whose policy would have taken
the same action at that state (intra-option Q-learning, Sutton, Precup and Singh 1999):
``Q(s, o) += step * (r + gamma ** d * U(s', o) - Q(s, o))`` with
``U(s', o) = K_o(s') Q(s', o) + (1 - K_o(s')) max_c Q(s', c)``. The choice that is
running still gets its SMDP update.

Handing control back to the primitives
--------------------------------------
Three switches, all off by default (the paper's method), let a learner follow its
options first and hand control to the primitives as these learn:

* ``option_bonus = b > 0``: in learning episode ``e`` (0-based) the options' values get
  a bonus ``b_e = b * max(0, 1 - e / option_bonus_episodes)`` when the learner chooses,
  so that it follows the options it trusts less than it trusts untried primitives, and
  less and less so. The Q-learning target is then the value (without the bonus) of the
  choice the bonus-greedy policy makes at ``s'``: the learner evaluates the policy it
  follows. Greedy rollouts (``learn=False``) have no bonus.
* ``interruption=True``: a running option stops at a decision state where the best
  primitive is worth more than the option plus the bonus (interruption, Sutton, Precup
  and Singh 1999, section 5), besides its own termination condition.
* ``intra_option_primitives=True``: while an option runs, the primitive it takes gets
  the one-step Q-learning update of each step (the primitive half of ``intra_option``):
  the primitives learn from the options' experience before they take over.

Reproducibility: every random draw (exploration, tie-breaking, option initiation and
termination) comes from one :class:`numpy.random.Generator` seeded by ``seed``; with
the same environment seed, the same learner seed gives the same learning curve.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ilpss.episode import (
    EpisodeLog,
    EpisodeResult,
    EpisodicLearner,
    OptionRun,
    check_env,
    observation,
    step_duration,
    step_reward,
)
from ilpss.options import OptionLibrary
from ilpss.policy import EPSILON, FrozenPolicy, LinearPolicy, epsilon_greedy_choice
from ilpss.tiles import KEEPAWAY_ALPHA, TILE_CONSTRAINTS, TileCoder, box_bounds
from ilpss.traces import DivergedError, ReplacingTraces, td_update
from soccer_drill.constraints import (
    Bool,
    Integer,
    ListOf,
    NoneOr,
    OneOf,
    Real,
    check_fields,
    from_json,
)

__all__ = [
    "KEEPAWAY",
    "SMDP_CONSTRAINTS",
    "LearnerConfig",
    "SmdpLearner",
]

SMDP_CONSTRAINTS = {
    # Spread over the active tiles, so 1 moves a value all the way to its target; beyond
    # 1 every update overshoots, and with traces the values diverge.
    "alpha": Real(0.0, 1.0, low_open=True),
    "epsilon": EPSILON,
    "gamma": Real(0.0, 1.0),
    "method": OneOf(("sarsa", "q")),
    "intra_option": Bool(),
    "intra_option_primitives": Bool(),
    "interruption": Bool(),
    "option_bonus": Real(0.0, 100.0),
    "option_bonus_episodes": Integer(1, 1_000_000),
    "bootstrap_on_truncation": Bool(),
    # Far beyond any return; 1e308 would overflow the first update.
    "initial_value": Real(-1e6, 1e6),
    "option_initial_value": NoneOr(Real(-1e6, 1e6)),
    "option_values": OneOf(("constant", "policy", "policy_primitives")),
    "step_targets": OneOf(("every_choice", "available_choices", "primitive_choices")),
    "value_bounds": NoneOr(ListOf(Real(-1e6, 1e6), min_len=2, max_len=2)),
    "option_traces": OneOf(("kept", "cut")),
    "trace_decay": Real(0.0, 1.0),
    "max_decisions": Integer(1),
}
"""What each setting of an SMDP learner allows (the fields of :class:`LearnerConfig`)."""
LEARNER_CONSTRAINTS = {
    **SMDP_CONSTRAINTS,
    "n_tilings": TILE_CONSTRAINTS["n_tilings"],
    "tile_widths": NoneOr(ListOf(TILE_CONSTRAINTS["width"], min_len=1)),
}
"""What each field of :class:`LearnerConfig` allows: :data:`SMDP_CONSTRAINTS` and the tile
coder's (:data:`~ilpss.tiles.TILE_CONSTRAINTS`)."""


@dataclass(frozen=True)
class LearnerConfig:
    """The SMDP learner's settings, passed whole to :class:`SmdpLearner` (and, for its base
    learner, to :class:`~ilpss.baselines.PrqLearner`).

    The defaults are the project's learner: keepaway's tile coding, step size and
    exploration, with Watkins's Q(lambda) and optimistic initial values instead of
    one-step Sarsa. On the drill, one-step Sarsa and Q-learning rise and then collapse,
    while Q(0.9) with replacing traces learns within a few hundred episodes and stays up
    (the sweep is in ``docs/learning_sweep.md``). :data:`KEEPAWAY` is keepaway's own
    SMDP Sarsa(0) with values starting at 0.
    """

    alpha: float = KEEPAWAY_ALPHA
    """Step size, spread over the active tiles (1 moves a value all the way to its target)."""
    epsilon: float = 0.01
    """Exploration rate of epsilon-greedy."""
    gamma: float = 1.0
    """Discount per cycle; a step of ``d`` cycles is discounted by ``gamma ** d``."""
    method: str = "q"
    """``"sarsa"`` or ``"q"`` (Q-learning; Watkins's Q(lambda) with traces)."""
    intra_option: bool = False
    """Also apply intra-option updates (see the module docstring)."""
    intra_option_primitives: bool = False
    """While an option runs, give the primitive it takes the one-step Q-learning update of
    each step, so the primitives learn from the options' experience (the paper: false)."""
    interruption: bool = False
    """Stop a running option where the best primitive is worth more than it (plus the
    bonus); the paper: false, options stop only by their kernel."""
    option_bonus: float = 0.0
    """Bonus of the options' values when the learner chooses, in its first learning
    episode, fading linearly to 0 over ``option_bonus_episodes``: options first, then
    the primitives as they learn (the paper: 0)."""
    option_bonus_episodes: int = 1
    """Learning episodes over which the option bonus fades to 0."""
    initial_value: float = 1.0
    """Initial action value of every choice (1.0, the best reward: optimistic)."""
    option_initial_value: float | None = None
    """Initial value of every option's Q (``None``: ``initial_value``). Above
    ``initial_value`` the learner tries the options before the primitives: the paper's
    "search for a solution first in the policy subspace spanned by behaviours that proved
    useful in the past"."""
    option_values: str = "constant"
    """Where each option's values start: ``"constant"`` (the paper: everywhere
    ``option_initial_value``) or ``"policy"``: from the values of the option's own past
    policy, tile by tile the largest of its choices' weights, so that an option starts
    at (a little above) what its policy expected to earn from each state, and the learner
    takes it where that beats the primitives and learns its value on the task.
    ``"policy_primitives"``: the same over the policy's primitive actions only. A past
    policy that chose options holds their values too, and a tile-wise maximum over those
    inherits every earlier start's excess over the greedy value, task after task."""
    step_targets: str = "every_choice"
    """What the one-step targets of the steps inside an option (``intra_option`` and
    ``intra_option_primitives``) bootstrap from at the next state: ``"every_choice"`` (as
    before: the largest value of any of the learner's choices) or ``"available_choices"``
    (the primitives and the options that the library makes available there, sampled as
    at a choice point, which is what the choice point's own target reads) or
    ``"primitive_choices"`` (the primitives only: no option's value, and no draw of the
    learner's random numbers). With regions,
    an option's values outside its region are never corrected, because it is never taken
    there; bootstrapping from them carries whatever they started at into the primitives,
    and along a stream of fine-tuned starts (each task starting from the last one's
    values) that excess grows with every task."""
    value_bounds: tuple[float, float] | None = None
    """``(low, high)``: every target the learner updates towards (a choice point's and
    the steps' inside an option) is clipped into this range, the range of the returns
    its environment can pay, and an option valued from its policy (``option_values``)
    starts with each tile's weight clipped into its share of the range (``low`` and
    ``high`` over the active tiles), so that its start lies within it too; ``None`` (the
    paper): targets and starts as they come. An option that starts above what its policy
    earns (a tile-wise maximum of its values) passes the excess to the choices that
    bootstrap from it, and along a stream of fine-tuned starts each task inherits the
    last one's excess."""
    option_traces: str = "kept"
    """``"kept"`` (the paper): an option's choice is traced like any other, so its TD
    error also updates the choices made before it; ``"cut"``: the traces are cleared
    before an option is chosen, so its TD error updates its own value only. An option
    valued from its policy starts where that policy's values say, and the large errors
    of correcting that start then reach the primitives chosen before it."""
    trace_decay: float = 0.9
    """``lambda`` of the replacing eligibility traces (0: one-step updates)."""
    bootstrap_on_truncation: bool = False
    """Bootstrap from the last state of a truncated episode (default: truncation is
    terminal: the drill pays its failure reward at its time limit)."""
    max_decisions: int = 100_000
    """Safety bound on the decisions of one episode (an error beyond it)."""
    n_tilings: int = 32
    """One-dimensional tilings per feature."""
    tile_widths: tuple[float, ...] | None = None
    """Tile width per feature, in its units; ``None``: a tenth of each feature's range."""

    def __post_init__(self) -> None:
        # Checked here, by name: configurations come from JSON files, and a bad value
        # would otherwise only be refused at the first trial.
        check_fields("LearnerConfig", self, LEARNER_CONSTRAINTS)
        if self.tile_widths is not None:  # JSON gives lists, and ints for whole numbers
            object.__setattr__(self, "tile_widths", tuple(float(w) for w in self.tile_widths))
        if self.value_bounds is not None:
            low, high = (float(v) for v in self.value_bounds)
            if not low < high:
                raise ValueError(f"LearnerConfig.value_bounds must be (low, high) with low < "
                                 f"high, got {list(self.value_bounds)}")
            object.__setattr__(self, "value_bounds", (low, high))

    @classmethod
    def from_dict(cls, values: Mapping[str, Any]) -> LearnerConfig:
        """Inverse of ``dataclasses.asdict``; unknown keys are refused by name."""
        return from_json(cls, values)

    def tile_coder(self, observation_space: Any) -> TileCoder:
        """The tile coder of these settings over a 1-D ``Box`` observation space.

        Raises
        ------
        ValueError
            The space is not such a box (the message names it), or the widths do not fit
            it (one per feature, at most :data:`~ilpss.tiles.MAX_WEIGHTS` tiles in all;
            the message names the field).
        """
        low, _ = box_bounds(observation_space)  # the space's fault, not these settings'
        if self.tile_widths is not None and len(self.tile_widths) != len(low):
            raise ValueError(
                f"LearnerConfig.tile_widths / n_tilings: widths must have {len(low)} entries, "
                f"one per feature of the observation space {observation_space!r}, got "
                f"{len(self.tile_widths)}"
            )
        widths = None if self.tile_widths is None else np.asarray(self.tile_widths, dtype=float)
        try:
            return TileCoder.from_space(observation_space, widths, self.n_tilings)
        except ValueError as exc:
            raise ValueError(f"LearnerConfig.tile_widths / n_tilings: {exc}") from exc


KEEPAWAY = LearnerConfig(method="sarsa", initial_value=0.0, trace_decay=0.0)
"""Keepaway's learner (Stone, Sutton and Kuhlmann 2005): SMDP Sarsa(0), values from 0."""


@dataclass
class _ChoiceEnd:
    """How one choice (a primitive, or an option's whole run) ended."""

    ret: float  # its discounted return
    disc: float  # gamma ** its duration
    ended: bool  # the episode ended during it
    state: np.ndarray | None  # the next choice point (None: the episode is over)
    active: np.ndarray | None
    membership: np.ndarray | None  # kernel memberships at `state`, if already computed


class SmdpLearner(EpisodicLearner):
    """SMDP Sarsa / Q-learning with linear tile coding over primitives and options.

    Parameters
    ----------
    n_primitive : int
        Number of primitive actions (the environment's ``Discrete(n)``).
    tile_coder : TileCoder
    library : OptionLibrary, optional
        Options to offer: its active options at construction, in its order. An offered
        option that the library later deactivates is never available.
    config : LearnerConfig, default LearnerConfig()
        Every learning setting (its tile settings are ``tile_coder``'s business).
    seed : int or numpy.random.Generator, optional
    """

    def __init__(
        self,
        n_primitive: int,
        tile_coder: TileCoder,
        library: OptionLibrary | None = None,
        config: LearnerConfig | None = None,
        *,
        seed: int | np.random.Generator | None = None,
    ) -> None:
        if not isinstance(tile_coder, TileCoder):
            raise TypeError(f"tile_coder must be a TileCoder, got {type(tile_coder).__name__}")
        config = LearnerConfig() if config is None else config
        if not isinstance(config, LearnerConfig):
            raise TypeError(f"config must be a LearnerConfig, got {type(config).__name__}")
        if library is not None:
            if not isinstance(library, OptionLibrary):
                raise TypeError("library must be an OptionLibrary")
            if library.n_features != tile_coder.n_features:
                raise ValueError(
                    f"library kernels have {library.n_features} features, the tile coder "
                    f"{tile_coder.n_features}"
                )
            if library.n_primitive is not None and library.n_primitive != n_primitive:
                raise ValueError(
                    f"library policies have {library.n_primitive} primitive actions, "
                    f"expected {n_primitive}"
                )
        option_ids = () if library is None else tuple(int(o) for o in library.option_ids)
        self.q = LinearPolicy(tile_coder, n_primitive, option_ids,
                              initial_value=config.initial_value)
        if config.option_initial_value is not None:
            self.q.weights[n_primitive:] = config.option_initial_value / tile_coder.n_active
        if config.option_values != "constant" and library is not None:
            primitives_only = config.option_values == "policy_primitives"
            for j, oid in enumerate(option_ids):
                # A sum of tile-wise maxima: at every state at least the policy's own
                # greedy value (a linear start, so frozen policies keep it).
                policy = library.policies[library.policy_of(oid)]
                own = policy.weights[: policy.n_primitive] if primitives_only else policy.weights
                start = own.max(axis=0)
                if config.value_bounds is not None:  # every tile's share of the range
                    low, high = config.value_bounds
                    start = np.clip(start, low / tile_coder.n_active, high / tile_coder.n_active)
                self.q.weights[n_primitive + j] = start
        self.config = config
        self.tile_coder = tile_coder
        self.library = library
        self.n_primitive = int(n_primitive)
        self.learning_episodes = 0  # learning episodes run so far: the bonus's clock
        self._bonus = 0.0  # the options' bonus in the running episode
        self.rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        self._step = config.alpha / tile_coder.n_active
        self._lib_version: tuple[int, int] | None = None
        self._lib_pos = np.zeros(0, dtype=np.int64)
        self._lib_ok = np.zeros(0, dtype=bool)
        self._lib_any = self._lib_same = False

    # ---------------------------------------------------------------- helpers
    @classmethod
    def from_policy(
        cls,
        policy: FrozenPolicy | LinearPolicy,
        library: OptionLibrary | None = None,
        config: LearnerConfig | None = None,
        *,
        seed: int | np.random.Generator | None = None,
    ) -> SmdpLearner:
        """A learner that starts from ``policy``'s weights and option ids.

        Useful to roll out a saved policy (``run_episode(env, learn=False)``) or to
        continue learning it. Its option ids must be known to ``library``.
        """
        if policy.option_ids and library is None:
            raise ValueError("this policy chooses options; pass the library that issued them")
        learner = cls(policy.n_primitive, policy.tile_coder, library, config, seed=seed)
        if library is not None:
            for oid in policy.option_ids:
                library.policy_of(oid)  # KeyError for ids the library never issued
        learner.q = LinearPolicy(
            policy.tile_coder, policy.n_primitive, policy.option_ids, policy.weights
        )
        return learner

    def start_from(self, policy: FrozenPolicy | LinearPolicy) -> None:
        """Start from ``policy``'s values (fine-tuning): those of the primitive actions,
        and of every option this learner offers that ``policy`` chose too (the same
        option id); the other options' values are left as they are.

        Raises
        ------
        ValueError
            If ``policy`` has another tile coder or number of primitive actions.
        """
        if policy.tile_coder != self.tile_coder or policy.n_primitive != self.n_primitive:
            raise ValueError(
                f"cannot start from a policy of {policy.n_primitive} primitive actions over "
                f"another tile coder (this learner: {self.n_primitive} actions); the past "
                "policies must come from the same state space and actions"
            )
        self.q.weights[: self.n_primitive] = policy.weights[: policy.n_primitive]
        for oid in set(policy.option_ids) & set(self.option_ids):
            self.q.weights[self.q.choice_of_option(oid)] = \
                policy.weights[policy.choice_of_option(oid)]

    @property
    def option_ids(self) -> tuple[int, ...]:
        """Ids of the options this learner offers, in choice order."""
        return self.q.option_ids

    @property
    def n_choices(self) -> int:
        """Primitives plus offered options."""
        return self.q.n_choices

    def freeze(self) -> FrozenPolicy:
        """Immutable snapshot of the learnt policy (to add to an option library)."""
        return self.q.freeze()

    def _sync_library(self) -> None:
        """Map this learner's options to the library's current active positions."""
        lib = self.library
        assert lib is not None
        version = (id(lib), lib.version)
        if version == self._lib_version:
            return
        pos = lib.positions(self.option_ids)
        self._lib_ok = pos >= 0
        self._lib_pos = np.where(self._lib_ok, pos, 0)
        self._lib_any = bool(self._lib_ok.any())
        # Every option offered is the library's option at the same position (no
        # pruning since): its availability is the library's, as it comes.
        self._lib_same = bool(np.array_equal(pos, np.arange(len(lib))))
        self._lib_version = version

    def _choice_mask(
        self, state: np.ndarray, membership: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Allowed choices at ``state`` (initiation sampled) and the kernel memberships."""
        mask = np.ones(self.n_choices, dtype=bool)
        if not self.option_ids:
            return mask, None
        lib = self.library
        assert lib is not None
        self._sync_library()
        if not self._lib_any:  # every offered option was pruned or retired
            mask[self.n_primitive :] = False
            return mask, membership
        m = lib.membership(state) if membership is None else membership
        avail = lib.available(state, self.rng, membership=m)
        mask[self.n_primitive :] = avail if self._lib_same else self._lib_ok & avail[self._lib_pos]
        return mask, m

    def _choice_values(self, active: np.ndarray, mask: np.ndarray) -> np.ndarray:
        """The values a choice point reads: those of the allowed choices (the others are
        -inf and never read, as :meth:`_choose` and :meth:`_bootstrap` look at the
        allowed ones only), or every value when a bonus is on, whose bootstrap may read
        a value outside ``mask`` if every allowed one is -inf."""
        if self._bonus or self.n_choices == self.n_primitive:
            return self.q.q_from_tiles(active)
        allowed = np.flatnonzero(mask)
        q = np.full(self.n_choices, -np.inf)
        q[allowed] = self.q.q_from_tiles(active, allowed)
        return q

    def option_bonus_at(self, episode: int) -> float:
        """The options' bonus in learning episode ``episode`` (0-based) of this learner."""
        if not self.config.option_bonus or not self.option_ids:
            return 0.0
        return self.config.option_bonus * max(0.0, 1.0 - episode / self.config.option_bonus_episodes)

    def _behaviour_values(self, q: np.ndarray) -> np.ndarray:
        """The values the learner chooses by: the options' with this episode's bonus."""
        if not self._bonus:
            return q
        biased = q.copy()
        biased[self.n_primitive :] += self._bonus
        return biased

    def _choose(self, q: np.ndarray, mask: np.ndarray, epsilon: float) -> tuple[int, bool]:
        return epsilon_greedy_choice(self._behaviour_values(q), self.rng, epsilon, mask)

    def _bootstrap(self, q: np.ndarray, mask: np.ndarray, choice: int) -> float:
        if self.config.method != "q":
            return float(q[choice])
        if not self._bonus:
            return float(np.max(np.where(mask, q, -np.inf)))
        # The value of what the bonus-greedy policy chooses (the largest if several tie).
        biased = np.where(mask, self._behaviour_values(q), -np.inf)
        return float(np.max(np.where(biased == biased.max(), q, -np.inf)))

    def _bounded(self, target: float) -> float:
        """``target`` clipped into :attr:`LearnerConfig.value_bounds`, if set."""
        bounds = self.config.value_bounds
        return target if bounds is None else min(max(target, bounds[0]), bounds[1])

    # ------------------------------------------------------------ intra-option
    def _intra_option_update(
        self,
        s_active: np.ndarray,
        s: np.ndarray,
        m: np.ndarray | None,
        action: int,
        running: int,
        reward: float,
        duration: int,
        next_state: np.ndarray | None,
    ) -> None:
        """One-step updates of the primitive taken and of consistent options."""
        lib = self.library
        q_next = None
        cont = None
        allowed = None  # the choices a target bootstraps from (None: every one)
        best_next = 0.0
        if next_state is not None:
            q_next = self.q.q_values(next_state)
            if self.option_ids:
                assert lib is not None
                m_next = lib.membership(next_state)
                cont = lib.continuation_probabilities(m_next)[self._lib_pos]
                if self.config.step_targets == "available_choices":
                    allowed, _ = self._choice_mask(next_state, m_next)
                elif self.config.step_targets == "primitive_choices":
                    allowed = np.arange(self.n_choices) < self.n_primitive
            best_next = float(q_next.max() if allowed is None else q_next[allowed].max())
        disc = self.config.gamma**duration
        targets: dict[int, float] = {}
        if action != running:
            if q_next is None:
                targets[action] = reward
            elif self._bonus:
                every = np.ones(q_next.shape[0], dtype=bool) if allowed is None else allowed
                targets[action] = reward + disc * self._bootstrap(q_next, every, action)
            else:
                targets[action] = reward + disc * best_next
        if self.config.intra_option and self.option_ids and m is not None:
            assert lib is not None
            tiles = {self.tile_coder: s_active}
            inside = lib.memberships(m)[self._lib_pos] > 0.0
            by_policy: dict[int, int] = {}
            for j, oid in enumerate(self.option_ids):
                c = self.n_primitive + j
                if c == running or not self._lib_ok[j] or not inside[j]:
                    continue
                pid = lib.policy_of(oid)
                if pid not in by_policy:
                    by_policy[pid] = lib.act(oid, s, self.rng, tiles)
                if by_policy[pid] != action:
                    continue
                if q_next is None:
                    targets[c] = reward
                else:
                    assert cont is not None
                    u = cont[j] * q_next[c] + (1.0 - cont[j]) * best_next
                    targets[c] = reward + disc * float(u)
        if targets:
            q_now = self.q.q_from_tiles(s_active)
            for c, target in targets.items():
                self.q.update(s_active, c, self._step * (self._bounded(target) - q_now[c]))

    # --------------------------------------------------------------- episodes
    def run_episode(
        self,
        env: Any,
        learn: bool = True,
        *,
        explore: bool | None = None,
        seed: int | None = None,
    ) -> EpisodeResult:
        """Run one episode on a Gymnasium environment.

        Parameters
        ----------
        env : gymnasium.Env
            ``Box`` observations of shape (n_features,), ``Discrete(n_primitive)``
            actions.
        learn : bool, default True
            Update the action values.
        explore : bool, optional
            Use epsilon-greedy (default: same as ``learn``); otherwise greedy.
        seed : int, optional
            Passed to ``env.reset``.

        Returns
        -------
        EpisodeResult
        """
        n_features = self.tile_coder.n_features
        check_env(env, self.n_primitive, n_features)
        epsilon = self.config.epsilon if (learn if explore is None else explore) else 0.0
        self._bonus = self.option_bonus_at(self.learning_episodes) if learn else 0.0
        if learn:
            self.learning_episodes += 1
        obs, _ = env.reset(seed=seed)
        s = observation(obs, n_features)
        log = EpisodeLog(self.config.gamma, n_features, self.config.max_decisions)
        # One eligibility per weight, only when lambda > 0.
        traces = ReplacingTraces(self.q) if self.config.trace_decay > 0.0 else None
        active = self.tile_coder.active(s)
        mask, m = self._choice_mask(s)
        choice, explored = self._choose(self._choice_values(active, mask), mask, epsilon)
        while True:  # one iteration per choice point: `choice` made at `s`
            log.choose(choice, explored)
            end = self._run_choice(env, log, choice, explored, s, active, m, learn)
            if end.state is None:  # the episode is over: the target is the return alone
                if learn:
                    self._td_update(traces, active, choice, self._bounded(end.ret), 0.0, True)
                break
            mask, m = self._choice_mask(end.state, end.membership)
            q = self._choice_values(end.active, mask)
            next_choice, explored = self._choose(q, mask, epsilon)
            if learn:
                target = self._bounded(end.ret + end.disc * self._bootstrap(q, mask, next_choice))
                # Watkins's Q(lambda): an exploratory choice cuts the traces.
                cut = (self.config.method == "q" and explored) or (
                    self.config.option_traces == "cut" and next_choice >= self.n_primitive)
                self._td_update(traces, active, choice, target, end.disc * self.config.trace_decay, cut)
            if end.ended:  # a truncation bootstrapped from its last state
                break
            s, active, choice = end.state, end.active, next_choice
        return log.result()

    def _run_choice(
        self,
        env: Any,
        log: EpisodeLog,
        choice: int,
        explored: bool,
        s: np.ndarray,
        active: np.ndarray,
        m: np.ndarray | None,
        learn: bool,
    ) -> _ChoiceEnd:
        """Carry out ``choice`` from ``s``: one step for a primitive, every step until
        the option stops (or the episode ends) for an option."""
        lib = self.library
        option_id = self.q.option_ids[choice - self.n_primitive] if choice >= self.n_primitive \
            else None
        if option_id is not None:
            assert lib is not None
            log.options_chosen.append(option_id)
            lib.record_use(option_id)
        run_start, run_cycles = log.decisions, 0
        interrupted = False
        ret, disc = 0.0, 1.0  # discounted return of this choice, gamma ** duration
        while True:
            log.visit(s)
            if option_id is None:
                action = choice
            else:
                action = lib.act(option_id, s, self.rng, {self.tile_coder: active})  # type: ignore[union-attr]
            obs, reward, terminated, truncated, info = env.step(action)
            reward = step_reward(reward)
            d = step_duration(info)
            ended = bool(terminated or truncated)
            bootstrap_end = bool(truncated and not terminated and self.config.bootstrap_on_truncation)
            next_s = observation(obs, s.shape[0]) if (not ended or bootstrap_end) else None
            if learn and (
                self.config.intra_option or (self.config.intra_option_primitives and option_id is not None)
            ):
                self._intra_option_update(active, s, m, action, choice, reward, d, next_s)
            ret += disc * reward
            disc *= self.config.gamma**d
            log.step(obs, reward, d, terminated, truncated, info)
            run_cycles += d
            if ended:
                break
            s = next_s  # type: ignore[assignment]
            active = self.tile_coder.active(s)
            m = None
            if option_id is None:
                break
            m = lib.membership(s)  # type: ignore[union-attr]
            if not lib.continues(option_id, s, self.rng, membership=m):  # type: ignore[union-attr]
                break
            if self.config.interruption:
                q_here = self.q.q_from_tiles(active)
                if q_here[: self.n_primitive].max() > q_here[choice] + self._bonus:
                    interrupted = True
                    break
        if option_id is not None:
            log.option_runs.append(OptionRun(
                option_id, run_start, log.decisions - run_start, run_cycles, ended, explored,
                interrupted,
            ))
        if ended:
            if next_s is None:
                return _ChoiceEnd(ret, disc, True, None, None, None)
            return _ChoiceEnd(ret, disc, True, next_s, self.tile_coder.active(next_s), None)
        return _ChoiceEnd(ret, disc, False, s, active, m)

    def _td_update(
        self, traces: ReplacingTraces | None, active: np.ndarray, choice: int, target: float,
        decay: float, cut: bool,
    ) -> None:
        """The update of one choice point, spread back along the eligibility traces
        (:mod:`ilpss.traces`); ``decay`` is ``gamma ** D * lambda`` for the choice's
        duration ``D``; ``cut`` clears the traces afterwards (episode end, or an
        exploratory choice next in Q-learning)."""
        try:
            td_update(self.q, traces, active, choice, target, self._step, decay, cut)
        except DivergedError as exc:
            raise DivergedError(
                f"SMDP learning diverged in learning episode {self.learning_episodes}: {exc}; "
                f"the step size (alpha={self.config.alpha:g}) or the initial values are too large "
                "for this environment's rewards (LearnerConfig.alpha, .initial_value, "
                ".option_initial_value)"
            ) from None
