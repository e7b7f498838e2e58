"""Baselines for the ILPSS experiments: probabilistic policy reuse (PRQ-learning).

:class:`PrqLearner` implements PRQ-learning with the pi-reuse exploration strategy of
Fernández and Veloso (2006), "Probabilistic policy reuse in a reinforcement learning
agent", AAMAS, pp. 720-727, on the same footing as :class:`ilpss.smdp.SmdpLearner`
(linear tile coding, SMDP durations, one seeded generator), so that it can be compared
with ILPSS under the same budget.

Algorithm
---------
The agent has a library ``L = {Pi_1 .. Pi_n}`` of past policies (frozen linear
action-value functions over primitive actions, greedy) and learns a new action-value
function ``Q`` (policy ``Pi_Omega``) over the same tile coder. It keeps one gain ``W_j``
and one count ``U_j`` per policy of ``L`` and for ``Pi_Omega`` (all 0 at the start), and
a temperature ``tau = tau0``. Every training episode:

1. Choose the policy to follow, ``Pi_k``, among ``Pi_1 .. Pi_n, Pi_Omega`` with
   probability ``P(Pi_j) = exp(tau W_j) / sum_p exp(tau W_p)``.
2. If ``Pi_k = Pi_Omega``: an epsilon-greedy episode on ``Q``. Otherwise a *pi-reuse*
   episode with ``Pi_k``: at decision ``h = 0, 1, ...`` take ``Pi_k``'s greedy action
   with probability ``psi_h``, else an epsilon-greedy action on ``Q``; ``psi_0 = psi``
   and ``psi_{h+1} = psi_h * upsilon``.
3. Whatever the behaviour, every step ``(s, a, r, s')`` of duration ``d`` cycles updates
   ``Q`` by SMDP Q-learning (off-policy, as in PRQ-learning)::

       Q(s, a) += alpha / n_active * (r + gamma ** d * max_a' Q(s', a') - Q(s, a))

   with target ``r`` alone when the episode ends (a time limit is terminal unless
   ``bootstrap_on_truncation``), where ``n_active`` is the number of active tiles.
   With ``trace_decay = lambda > 0`` the base learner is Watkins's Q(lambda) with the
   replacing traces of :mod:`ilpss.traces` (the learner of
   :class:`~ilpss.smdp.SmdpLearner`), cut after an exploratory action and after the
   reused policy's action wherever ``Q`` prefers another (Watkins's rule: the traces
   follow the greedy policy of ``Q`` only).
4. With ``R`` the episode's total reward: ``W_k <- (W_k U_k + R) / (U_k + 1)``,
   ``U_k <- U_k + 1``; then ``tau <- tau + delta_tau``.

As ``tau`` grows the choice concentrates on the policy with the largest average reward:
a useful past policy is reused often early on (its exploration bias speeds up
learning), a useless one is soon abandoned, and ``Pi_Omega`` takes over once ``Q``
is better than every past policy.

Departures from the paper
-------------------------
* SMDP steps: a step lasts ``info["duration"]`` cycles (1 when absent) and is
  discounted by ``gamma ** duration``; the paper's steps all last one unit.
* Linear tile coding (:mod:`ilpss.tiles`, keepaway's step size spread over the active
  tiles) instead of a Q table; past policies are :class:`~ilpss.policy.FrozenPolicy`
  objects over the same coder, and their greedy ties are broken at random.
* The gain ``R`` of an episode is its undiscounted total reward; the paper uses the
  return discounted per step, which is the same for ``gamma = 1`` (keepaway's and the
  drill's setting).
* Episodes end when the environment ends them, not after a fixed horizon ``H``.
* Evaluation (``learn=False``, :meth:`PrqLearner.evaluate`) is greedy on ``Q`` with
  no reuse and changes nothing.
* Eligibility traces (``trace_decay``) are an option, so that PRQ-learning can be given
  the same base learner as the other methods it is compared with.

With an empty library, PRQ-learning is SMDP Q-learning: a :class:`PrqLearner` then makes
the same updates and, with the same seed, the same random draws as
``SmdpLearner(method="q")`` with the same ``trace_decay`` (except the unused choice that the latter draws at a
bootstrapped truncation). Both learners stand on the episode seam of
:mod:`ilpss.episode`; greedy rollouts are :class:`~ilpss.smdp.SmdpLearner`'s, from the
learnt values (:meth:`SmdpLearner.from_policy`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

from ilpss.episode import (
    EpisodeLog,
    EpisodeResult,
    EpisodicLearner,
    check_env,
    observation,
    step_duration,
    step_reward,
)
from ilpss.policy import FrozenPolicy, LinearPolicy, epsilon_greedy_choice, greedy_choice
from ilpss.smdp import SMDP_CONSTRAINTS, LearnerConfig, SmdpLearner
from ilpss.tiles import TileCoder
from ilpss.traces import DivergedError, ReplacingTraces, td_update
from soccer_drill.constraints import NoneOr, Real, check_fields, from_json

__all__ = ["PrqConfig", "PrqLearner"]

PRQ_CONSTRAINTS = {
    "psi": Real(0.0, 1.0),
    "upsilon": Real(0.0, 1.0),
    "tau0": Real(0.0),
    "delta_tau": Real(0.0),
    "trace_decay": NoneOr(SMDP_CONSTRAINTS["trace_decay"]),
}
"""What each reuse setting of PRQ-learning allows."""


@dataclass(frozen=True)
class PrqConfig:
    """The reuse settings of PRQ-learning (:class:`PrqLearner`); its base learner takes
    the learning settings of :class:`~ilpss.lifelong.LearnerConfig`."""

    psi: float = 1.0
    """Probability ``psi_0`` of following the reused policy at the first decision."""
    upsilon: float = 0.95
    """Decay of ``psi_h`` per decision within a reuse episode."""
    tau0: float = 0.0
    """Initial temperature of the choice of the policy to follow (0: uniform)."""
    delta_tau: float = 0.05
    """Growth of the temperature after every training episode."""
    trace_decay: float | None = None
    """``lambda`` of its base learner's traces; ``None``: the learner's own
    (``LearnerConfig.trace_decay``), so that every method has the same base learner;
    0: the paper's one-step Q-learning."""

    def __post_init__(self) -> None:
        check_fields("PrqConfig", self, PRQ_CONSTRAINTS)

    @classmethod
    def from_dict(cls, values: Mapping[str, Any]) -> PrqConfig:
        """Inverse of :meth:`to_dict`; unknown keys are refused by name."""
        return from_json(cls, values)

    def to_dict(self) -> dict[str, float | None]:
        """A JSON-ready dict of the fields."""
        return asdict(self)

    def trace_decay_for(self, learner: LearnerConfig) -> float:
        """The ``lambda`` PRQ-learning uses with the base learner ``learner``: this
        configuration's :attr:`trace_decay`, or the learner's where it is ``None``."""
        return learner.trace_decay if self.trace_decay is None else self.trace_decay


class PrqLearner(EpisodicLearner):
    """PRQ-learning with pi-reuse (Fernández and Veloso 2006) over tile-coded SMDPs.

    See the module docstring for the algorithm.

    Parameters
    ----------
    n_primitive : int
        Number of primitive actions (the environment's ``Discrete(n)``).
    tile_coder : TileCoder
        Coder of the new Q; every past policy must use an equal coder.
    past_policies : iterable of FrozenPolicy
        The library ``Pi_1 .. Pi_n`` (may be empty). Their choices must be primitive
        actions only; a :class:`~ilpss.policy.LinearPolicy` is frozen (copied).
    config : LearnerConfig, default LearnerConfig()
        The base learner's settings, the same as every other method's: its step size,
        exploration, discount, initial value, ``trace_decay`` (unless ``reuse`` sets one),
        truncation and decision bound. PRQ-learning is Q-learning: ``config.method`` must
        be ``"q"``; the option settings do not apply (it reuses whole policies).
    reuse : PrqConfig, default PrqConfig()
        The reuse settings.
    seed : int or numpy.random.Generator, optional
        Source of every random draw (policy choice, pi-reuse, exploration, ties).

    Watkins's Q(lambda) with replacing traces (:mod:`ilpss.traces`) cuts its traces
    after an exploratory action and after the reused policy's action where Q prefers
    another; ``lambda = 0`` is the paper's one-step Q-learning.

    Attributes
    ----------
    q : LinearPolicy
        The new action values (``Pi_Omega``).
    past_policies : tuple of FrozenPolicy
    reuse_gains : numpy.ndarray, shape (n + 1,)
        ``W``: entry ``j < n`` for past policy ``j``, the last entry (index ``-1``) for
        ``Pi_Omega``.
    reuse_counts : numpy.ndarray of int, shape (n + 1,)
        ``U``, in the same order.
    tau : float
        Current temperature.
    reused : list of int
        Index of the policy each training episode followed, ``-1`` for ``Pi_Omega``.
    followed_past : list of bool
        For the last episode run, whether each decision followed the reused policy.

    Examples
    --------
    The settings go through the configurations (``env`` a Gymnasium environment with
    ``Discrete`` actions, ``old_policy`` a past policy over the same tile coder):

    >>> config = LearnerConfig(gamma=0.9)  # doctest: +SKIP
    >>> coder = config.tile_coder(env.observation_space)  # doctest: +SKIP
    >>> learner = PrqLearner(env.action_space.n, coder, [old_policy], config,
    ...                      PrqConfig(upsilon=0.9), seed=0)  # doctest: +SKIP
    >>> curve = learner.train(env, 500, seed=1)  # doctest: +SKIP
    >>> learner.selection_probabilities()  # doctest: +SKIP
    """

    def __init__(
        self,
        n_primitive: int,
        tile_coder: TileCoder,
        past_policies: Iterable[FrozenPolicy],
        config: LearnerConfig | None = None,
        reuse: PrqConfig | None = None,
        *,
        seed: int | np.random.Generator | None = None,
    ) -> None:
        config = LearnerConfig() if config is None else config
        reuse = PrqConfig() if reuse is None else reuse
        if not isinstance(config, LearnerConfig):
            raise TypeError(f"config must be a LearnerConfig, got {type(config).__name__}")
        if not isinstance(reuse, PrqConfig):
            raise TypeError(f"reuse must be a PrqConfig, got {type(reuse).__name__}")
        if config.method != "q":
            raise ValueError(f"PRQ-learning is Q-learning: config.method must be 'q', got "
                             f"{config.method!r}")
        if not isinstance(tile_coder, TileCoder):
            raise TypeError(f"tile_coder must be a TileCoder, got {type(tile_coder).__name__}")
        self.config, self.reuse = config, reuse
        self.q = LinearPolicy(tile_coder, n_primitive, (), initial_value=config.initial_value)
        self.n_primitive = self.q.n_primitive
        self.tile_coder = tile_coder
        self.trace_decay = reuse.trace_decay_for(config)
        self.rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        self.past_policies = self._check_policies(past_policies)
        n = len(self.past_policies)
        self.reuse_gains = np.zeros(n + 1)
        self.reuse_counts = np.zeros(n + 1, dtype=np.int64)
        self.tau = reuse.tau0
        self.reused: list[int] = []
        self.followed_past: list[bool] = []
        self._step = config.alpha / tile_coder.n_active
        self._mask = np.ones(self.n_primitive, dtype=bool)

    def _check_policies(self, policies: Iterable[FrozenPolicy]) -> tuple[FrozenPolicy, ...]:
        if isinstance(policies, FrozenPolicy | LinearPolicy):
            raise TypeError("past_policies must be a sequence of policies, not one policy")
        out = []
        for i, p in enumerate(policies):
            if isinstance(p, LinearPolicy):
                p = p.freeze()
            if not isinstance(p, FrozenPolicy):
                raise TypeError(f"past policy {i} must be a FrozenPolicy, got {type(p).__name__}")
            if p.option_ids:
                raise ValueError(
                    f"past policy {i} chooses options {p.option_ids}; PRQ-learning reuses "
                    "policies over primitive actions only"
                )
            if p.n_primitive != self.n_primitive:
                raise ValueError(
                    f"past policy {i} has {p.n_primitive} primitive actions, "
                    f"expected {self.n_primitive}"
                )
            if p.tile_coder != self.tile_coder:
                raise ValueError(
                    f"past policy {i} uses a different tile coder ({p.tile_coder!r}) from "
                    f"the learner's ({self.tile_coder!r})"
                )
            out.append(p)
        return tuple(out)

    def freeze(self) -> FrozenPolicy:
        """Immutable snapshot of the new policy (e.g. for the next task's library)."""
        return self.q.freeze()

    def selection_probabilities(self) -> np.ndarray:
        """Current ``P(Pi_j) = exp(tau W_j) / sum_p exp(tau W_p)``, shape (n + 1,).

        Same order as :attr:`reuse_gains` (``Pi_Omega`` last).
        """
        z = self.tau * self.reuse_gains
        p = np.exp(z - z.max())  # shifted: no overflow when tau grows large
        return p / p.sum()

    def _select(self) -> int:
        """Draw the policy to follow: a library index, or -1 for ``Pi_Omega``."""
        n = len(self.past_policies)
        if n == 0:
            return -1  # nothing to choose: no draw
        cdf = np.cumsum(self.selection_probabilities())
        j = min(int(np.searchsorted(cdf, self.rng.random(), side="right")), n)
        return -1 if j == n else j

    def _decide(
        self, active: np.ndarray, q: np.ndarray, past: FrozenPolicy | None, psi_h: float
    ) -> tuple[int, bool, bool]:
        """pi-reuse choice: ``(action, explored, followed the past policy)``."""
        if past is not None and psi_h > 0.0 and self.rng.random() < psi_h:
            return greedy_choice(past.q_from_tiles(active), self.rng), False, True
        action, explored = epsilon_greedy_choice(q, self.rng, self.config.epsilon, self._mask)
        return action, explored, False

    # --------------------------------------------------------------- episodes
    def _update(self, traces: ReplacingTraces | None, active: np.ndarray, action: int,
                target: float, decay: float, cut: bool) -> None:
        try:
            td_update(self.q, traces, active, action, target, self._step, decay, cut)
        except DivergedError as exc:
            raise DivergedError(
                f"PRQ-learning diverged: {exc}; the step size (alpha={self.config.alpha:g}) or the "
                "initial value is too large for this environment's rewards "
                "(LearnerConfig.alpha, .initial_value)"
            ) from None

    def run_episode(
        self, env: Any, learn: bool = True, *, seed: int | None = None
    ) -> EpisodeResult:
        """One episode on ``env`` (the contract of :mod:`ilpss.episode`; ``seed`` is
        passed to ``env.reset``).

        With ``learn`` (the default), a PRQ-learning episode: choose a policy, pi-reuse or
        epsilon-greedy, update Q, the gains and ``tau``. Otherwise a greedy rollout of
        the new Q, without reuse, that changes nothing. In the result, ``choices`` are
        the primitive actions taken and ``explored`` marks the random (epsilon) ones; no
        options are ever run.
        """
        if not learn:
            greedy = SmdpLearner.from_policy(self.q, None, replace(self.config, epsilon=0.0),
                                             seed=self.rng)
            res = greedy.run_episode(env, learn=False, seed=seed)
            self.followed_past = [False] * res.decisions
            return res
        check_env(env, self.n_primitive, self.tile_coder.n_features)
        k = self._select()
        res = self._reuse_episode(env, self.past_policies[k] if k >= 0 else None, seed)
        self.reuse_gains[k] = (self.reuse_gains[k] * self.reuse_counts[k] + res.total_reward) / (
            self.reuse_counts[k] + 1
        )
        self.reuse_counts[k] += 1
        self.tau += self.reuse.delta_tau
        self.reused.append(k)
        return res

    def _reuse_episode(
        self, env: Any, past: FrozenPolicy | None, seed: int | None
    ) -> EpisodeResult:
        """pi-reuse of ``past`` (epsilon-greedy on Q when None) with Q-learning updates."""
        coder = self.tile_coder
        n_features = coder.n_features
        psi_h = self.reuse.psi if past is not None else 0.0
        obs, _ = env.reset(seed=seed)
        s = observation(obs, n_features)
        active = coder.active(s)
        q = self.q.q_from_tiles(active)
        log = EpisodeLog(self.config.gamma, n_features, self.config.max_decisions)
        traces = ReplacingTraces(self.q) if self.trace_decay > 0.0 else None
        followed: list[bool] = []
        action, explored, follow = self._decide(active, q, past, psi_h)
        while True:
            log.visit(s)
            log.choose(action, explored)
            followed.append(follow)
            obs, reward, terminated, truncated, info = env.step(action)
            reward = step_reward(reward)
            d = step_duration(info)
            ended = bool(terminated or truncated)
            bootstrap_end = bool(truncated and not terminated and self.config.bootstrap_on_truncation)
            next_s = observation(obs, n_features) if (not ended or bootstrap_end) else None
            log.step(obs, reward, d, terminated, truncated, info)
            if next_s is None:
                self._update(traces, active, action, reward, 0.0, True)
                break
            next_active = coder.active(next_s)
            q = self.q.q_from_tiles(next_active)
            if not ended:  # choose at s' with the values before this step's update
                psi_h *= self.reuse.upsilon
                next_action, explored, follow = self._decide(next_active, q, past, psi_h)
            # Watkins's Q(lambda): the traces are cut after an exploratory action (as in
            # SmdpLearner) and after the reused policy's action where Q prefers another.
            cut = ended or explored or (follow and q[next_action] < q.max())
            self._update(traces, active, action, reward + self.config.gamma**d * float(q.max()),
                         self.config.gamma**d * self.trace_decay, cut)
            if ended:
                break
            s, active, action = next_s, next_active, next_action
        self.followed_past = followed
        return log.result()

    def __repr__(self) -> str:
        return (
            f"PrqLearner(n_primitive={self.n_primitive}, n_past={len(self.past_policies)}, "
            f"tau={self.tau:g}, episodes={len(self.reused)})"
        )
