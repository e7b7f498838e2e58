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

With an empty library, PRQ-learning is SMDP Q-learning: a :class:`PrqLearner` then makes
the same updates and, with the same seed, the same random draws as
``SmdpLearner(method="q")`` (except the unused choice that the latter draws at a
bootstrapped truncation).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np

from ilpss.policy import FrozenPolicy, LinearPolicy, greedy_choice
from ilpss.smdp import EpisodeResult, SmdpLearner
from ilpss.tiles import KEEPAWAY_ALPHA, TileCoder

__all__ = ["PrqLearner"]


def _real(name: str, value: object, low: float, high: float = math.inf) -> float:
    """``value`` as a float in ``[low, high]``, or a clear error."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__}")
    v = float(value)
    if not (math.isfinite(v) and low <= v <= high):
        raise ValueError(f"{name} must be finite and in [{low}, {high}], got {value}")
    return v


class PrqLearner:
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
    alpha : float, default 0.125
        Step size, divided by the number of active tiles (keepaway).
    epsilon : float, default 0.01
        Exploration of the epsilon-greedy choices on the new Q.
    gamma : float, default 1.0
        Discount per cycle; a step of duration ``d`` is discounted by ``gamma ** d``.
    psi : float, default 1.0
        Probability ``psi_0`` of following the reused policy at the first decision.
    upsilon : float, default 0.95
        Decay of ``psi_h`` per decision within a reuse episode.
    tau0 : float, default 0.0
        Initial temperature of the policy choice (0: uniform).
    delta_tau : float, default 0.05
        Increase of ``tau`` after every training episode.
    initial_value : float, default 0.0
        Initial value of every Q(s, a).
    bootstrap_on_truncation : bool, default False
        Bootstrap from the last state of a truncated episode (default: terminal).
    seed : int or numpy.random.Generator, optional
        Source of every random draw (policy choice, pi-reuse, exploration, ties).
    max_decisions : int, default 100_000
        Safety bound on the steps of one episode (an error beyond it).

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
    >>> learner = PrqLearner(3, coder, [old_policy], gamma=0.9, seed=0)  # doctest: +SKIP
    >>> curve = learner.train(env, 500, seed=1)  # doctest: +SKIP
    >>> learner.selection_probabilities()  # doctest: +SKIP
    """

    def __init__(
        self,
        n_primitive: int,
        tile_coder: TileCoder,
        past_policies: Iterable[FrozenPolicy],
        *,
        alpha: float = KEEPAWAY_ALPHA,
        epsilon: float = 0.01,
        gamma: float = 1.0,
        psi: float = 1.0,
        upsilon: float = 0.95,
        tau0: float = 0.0,
        delta_tau: float = 0.05,
        initial_value: float = 0.0,
        bootstrap_on_truncation: bool = False,
        seed: int | np.random.Generator | None = None,
        max_decisions: int = 100_000,
    ) -> None:
        alpha = _real("alpha", alpha, 0.0)
        epsilon = _real("epsilon", epsilon, 0.0, 1.0)
        gamma = _real("gamma", gamma, 0.0, 1.0)
        self.psi = _real("psi", psi, 0.0, 1.0)
        self.upsilon = _real("upsilon", upsilon, 0.0, 1.0)
        self.tau0 = _real("tau0", tau0, 0.0)
        self.delta_tau = _real("delta_tau", delta_tau, 0.0)
        initial_value = _real("initial_value", initial_value, -math.inf)
        if isinstance(max_decisions, bool) or not isinstance(max_decisions, int | np.integer):
            raise TypeError("max_decisions must be an int")
        if max_decisions < 1:
            raise ValueError(f"max_decisions must be >= 1, got {max_decisions}")
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        # The SMDP Q-learner supplies the Q function, its update, the environment
        # checks and the greedy evaluation; it shares our generator.
        self._smdp = SmdpLearner(
            n_primitive,
            tile_coder,
            alpha=alpha,
            epsilon=epsilon,
            gamma=gamma,
            method="q",
            bootstrap_on_truncation=bootstrap_on_truncation,
            initial_value=initial_value,
            seed=rng,
            max_decisions=int(max_decisions),
        )
        self.rng = rng
        self.n_primitive = self._smdp.n_primitive
        self.tile_coder = tile_coder
        self.past_policies = self._check_policies(past_policies)
        n = len(self.past_policies)
        self.reuse_gains = np.zeros(n + 1)
        self.reuse_counts = np.zeros(n + 1, dtype=np.int64)
        self.tau = self.tau0
        self.reused: list[int] = []
        self.followed_past: list[bool] = []
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

    # ------------------------------------------------------------- properties
    @property
    def q(self) -> LinearPolicy:
        """The new action values ``Q`` (policy ``Pi_Omega``)."""
        return self._smdp.q

    @property
    def alpha(self) -> float:
        """Step size, spread over the active tiles."""
        return self._smdp.alpha

    @property
    def epsilon(self) -> float:
        """Exploration rate."""
        return self._smdp.epsilon

    @property
    def gamma(self) -> float:
        """Discount per cycle."""
        return self._smdp.gamma

    @property
    def bootstrap_on_truncation(self) -> bool:
        """Whether a timeout bootstraps from the next state."""
        return self._smdp.bootstrap_on_truncation

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
        action, explored = self._smdp._choose(q, self._mask, self.epsilon)
        return action, explored, False

    # --------------------------------------------------------------- episodes
    def run_episode(
        self, env: Any, learn: bool = True, *, seed: int | None = None
    ) -> EpisodeResult:
        """Run one episode on a Gymnasium environment.

        Parameters
        ----------
        env : gymnasium.Env
            ``Box`` observations of shape (n_features,), ``Discrete(n_primitive)``
            actions.
        learn : bool, default True
            A PRQ-learning episode (choose a policy, pi-reuse or epsilon-greedy, update
            Q, the gains and ``tau``). Otherwise a greedy rollout of the new Q without
            reuse that changes nothing.
        seed : int, optional
            Passed to ``env.reset``.

        Returns
        -------
        EpisodeResult
            ``choices`` are the primitive actions taken, ``explored`` marks the random
            (epsilon) ones; no options are ever run.
        """
        if not learn:
            res = self._smdp.run_episode(env, learn=False, seed=seed)
            self.followed_past = [False] * res.decisions
            return res
        self._smdp._check_env(env)
        k = self._select()
        res = self._reuse_episode(env, self.past_policies[k] if k >= 0 else None, seed)
        self.reuse_gains[k] = (self.reuse_gains[k] * self.reuse_counts[k] + res.total_reward) / (
            self.reuse_counts[k] + 1
        )
        self.reuse_counts[k] += 1
        self.tau += self.delta_tau
        self.reused.append(k)
        return res

    def _reuse_episode(
        self, env: Any, past: FrozenPolicy | None, seed: int | None
    ) -> EpisodeResult:
        """pi-reuse of ``past`` (epsilon-greedy on Q when None) with Q-learning updates."""
        smdp = self._smdp
        coder = self.tile_coder
        gamma = self.gamma
        psi_h = self.psi if past is not None else 0.0
        obs, _ = env.reset(seed=seed)
        s = smdp._observation(obs)
        active = coder.active(s)
        q = self.q.q_from_tiles(active)
        trace: list[np.ndarray] = []
        choices: list[int] = []
        explored_flags: list[bool] = []
        followed: list[bool] = []
        total_reward = discounted_return = last_reward = 0.0
        cycles = 0
        info: dict[str, Any] = {}
        terminated = truncated = False

        action, explored, follow = self._decide(active, q, past, psi_h)
        while True:
            if len(trace) >= smdp.max_decisions:
                raise RuntimeError(f"episode exceeded max_decisions={smdp.max_decisions}")
            trace.append(s)
            choices.append(action)
            explored_flags.append(explored)
            followed.append(follow)
            obs, reward, terminated, truncated, info = env.step(action)
            reward = float(reward)
            d = smdp._duration(info)
            ended = bool(terminated or truncated)
            bootstrap_end = bool(truncated and not terminated and self.bootstrap_on_truncation)
            next_s = smdp._observation(obs) if (not ended or bootstrap_end) else None
            discounted_return += gamma**cycles * reward
            total_reward += reward
            last_reward = reward
            cycles += d
            if next_s is None:
                smdp._update(active, action, reward)
                break
            next_active = coder.active(next_s)
            q = self.q.q_from_tiles(next_active)
            if not ended:  # choose at s' with the values before this step's update
                psi_h *= self.upsilon
                next_action, explored, follow = self._decide(next_active, q, past, psi_h)
            smdp._update(active, action, reward + gamma**d * float(q.max()))
            if ended:
                break
            s, active, action = next_s, next_active, next_action

        self.followed_past = followed
        outcome = info.get("outcome")
        if outcome is not None:
            success = outcome == "success"
        else:
            success = bool(terminated and not truncated and last_reward > 0)
        return EpisodeResult(
            total_reward=total_reward,
            discounted_return=discounted_return,
            cycles=cycles,
            decisions=len(trace),
            outcome=outcome,
            success=success,
            terminated=bool(terminated),
            truncated=bool(truncated),
            trace=np.array(trace, dtype=np.float64).reshape(len(trace), coder.n_features),
            final_observation=np.asarray(obs, dtype=np.float64),
            choices=choices,
            explored=explored_flags,
        )

    def train(
        self,
        env: Any,
        n_episodes: int,
        *,
        seed: int | None = None,
        callback: Callable[[int, EpisodeResult], None] | None = None,
    ) -> list[EpisodeResult]:
        """Learn for ``n_episodes`` episodes; ``seed`` seeds the first ``env.reset`` only.

        ``callback(i, result)`` is called after each episode.
        """
        if n_episodes < 0:
            raise ValueError("n_episodes must be >= 0")
        results = []
        for i in range(n_episodes):
            res = self.run_episode(env, learn=True, seed=seed if i == 0 else None)
            results.append(res)
            if callback is not None:
                callback(i, res)
        return results

    def evaluate(self, env: Any, n: int, *, seed: int | None = None) -> list[EpisodeResult]:
        """``n`` greedy rollouts of the new Q, without reuse or learning."""
        if n < 0:
            raise ValueError("n must be >= 0")
        return [self.run_episode(env, learn=False, seed=seed if i == 0 else None) for i in range(n)]

    def __repr__(self) -> str:
        return (
            f"PrqLearner(n_primitive={self.n_primitive}, n_past={len(self.past_policies)}, "
            f"tau={self.tau:g}, episodes={len(self.reused)})"
        )
