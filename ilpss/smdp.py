"""SMDP Sarsa(0) / Q-learning over primitive actions and kernel options.

The learner follows keepaway's (Stone, Sutton and Kuhlmann 2005): a linear action-value
function over one-dimensional tilings (:mod:`ilpss.tiles`), epsilon-greedy choice with
random tie-breaking, and SMDP updates in which one environment ``step`` may span several
cycles. Defaults are keepaway's: ``alpha = 0.125`` spread over the active tiles,
``epsilon = 0.01``, ``gamma = 1``.

It talks to the environment only through the Gymnasium API: any environment with a 1-D
``Box`` observation and a ``Discrete(n)`` action space works. ``info["duration"]`` (the
number of cycles the step took, an int >= 1) is used when present and taken as 1
otherwise; ``info["outcome"]`` is reported when present.

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

Reproducibility: every random draw (exploration, tie-breaking, option initiation and
termination) comes from one :class:`numpy.random.Generator` seeded by ``seed``; with
the same environment seed, the same learner seed gives the same learning curve.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ilpss.options import OptionLibrary
from ilpss.policy import FrozenPolicy, LinearPolicy, greedy_choice
from ilpss.tiles import KEEPAWAY_ALPHA, TileCoder

__all__ = ["EpisodeResult", "OptionRun", "SmdpLearner", "options_used"]

_MIN_TRACE = 0.01  # eligibilities below this are dropped (keepaway's cut-off)


@dataclass(frozen=True)
class OptionRun:
    """One execution of an option within an episode."""

    option_id: int
    start_decision: int  # index into EpisodeResult.trace of its first decision
    n_decisions: int
    cycles: int
    ended_by_episode: bool  # the episode ended while it ran (rather than K(s) stopping it)
    explored: bool  # it was started by an exploratory (random) choice


@dataclass
class EpisodeResult:
    """Summary of one episode run by :meth:`SmdpLearner.run_episode`.

    Attributes
    ----------
    total_reward : float
        Undiscounted sum of rewards.
    discounted_return : float
        ``sum_i gamma ** (cycles before step i) * r_i`` with the learner's ``gamma``.
    cycles : int
        Sum of step durations.
    decisions : int
        Number of environment steps (decisions of the agent, inside options included).
    outcome : str or None
        ``info["outcome"]`` of the last step, if the environment reports it.
    success : bool
        ``outcome == "success"`` when an outcome is reported, else terminated (not
        truncated) with a positive last reward.
    terminated, truncated : bool
    trace : numpy.ndarray, shape (decisions, n_features)
        The states at which the agent decided (the ILPSS trace; the final observation
        is in ``final_observation``).
    final_observation : numpy.ndarray
    choices : list of int
        The learner's choice indices, one per choice point (an option counts once).
    options_chosen : list of int
        Option ids started, in order.
    option_runs : list of OptionRun
    explored : list of bool
        Whether each choice was an exploratory (random) one.
    """

    total_reward: float
    discounted_return: float
    cycles: int
    decisions: int
    outcome: str | None
    success: bool
    terminated: bool
    truncated: bool
    trace: np.ndarray
    final_observation: np.ndarray
    choices: list[int] = field(default_factory=list)
    options_chosen: list[int] = field(default_factory=list)
    option_runs: list[OptionRun] = field(default_factory=list)
    explored: list[bool] = field(default_factory=list)


def options_used(results: Iterable[EpisodeResult], greedy_only: bool = True) -> set[int]:
    """Option ids started in ``results`` (by default only by non-exploratory choices).

    Pass the options used by greedy rollouts of the learnt policy
    (:meth:`SmdpLearner.evaluate`) to :meth:`OptionLibrary.end_trial`: those are the
    options "used by the learnt policy" of the paper's discounting rule.
    """
    return {
        run.option_id
        for res in results
        for run in res.option_runs
        if not (greedy_only and run.explored)
    }


class SmdpLearner:
    """SMDP Sarsa(0) (or Q-learning) with linear tile coding over primitives and options.

    Parameters
    ----------
    n_primitive : int
        Number of primitive actions (the environment's ``Discrete(n)``).
    tile_coder : TileCoder
    library : OptionLibrary, optional
        Options to offer: its active options at construction, in its order. An offered
        option that the library later deactivates is never available.
    alpha : float, default 0.125
        Step size, divided by the number of active tiles (keepaway).
    epsilon : float, default 0.01
    gamma : float, default 1.0
        Discount per cycle; a step of duration ``d`` is discounted by ``gamma ** d``.
    method : {"sarsa", "q"}, default "sarsa"
    intra_option : bool, default False
        Also apply intra-option updates (see the module docstring).
    bootstrap_on_truncation : bool, default False
    initial_value : float, default 0.0
        Initial value of every Q(s, c).
    option_initial_value : float, optional
        Initial value of every option's Q(s, o) (default: ``initial_value``). Above
        ``initial_value`` the learner tries the options before the primitives: the
        paper's "search for a solution first in the policy subspace spanned by
        behaviours that proved useful in the past".
    trace_decay : float, default 0.0
        ``lambda`` of eligibility traces over choice points (0: one-step SMDP updates).
        See the module docstring.
    seed : int or numpy.random.Generator, optional
    max_decisions : int, default 100_000
        Safety bound on the steps of one episode (an error beyond it).
    """

    def __init__(
        self,
        n_primitive: int,
        tile_coder: TileCoder,
        library: OptionLibrary | None = None,
        *,
        alpha: float = KEEPAWAY_ALPHA,
        epsilon: float = 0.01,
        gamma: float = 1.0,
        method: str = "sarsa",
        intra_option: bool = False,
        bootstrap_on_truncation: bool = False,
        initial_value: float = 0.0,
        option_initial_value: float | None = None,
        trace_decay: float = 0.0,
        seed: int | np.random.Generator | None = None,
        max_decisions: int = 100_000,
    ) -> None:
        if not isinstance(tile_coder, TileCoder):
            raise TypeError(f"tile_coder must be a TileCoder, got {type(tile_coder).__name__}")
        if not (math.isfinite(alpha) and alpha > 0):
            raise ValueError(f"alpha must be positive, got {alpha}")
        if not 0.0 <= epsilon <= 1.0:
            raise ValueError(f"epsilon must be in [0, 1], got {epsilon}")
        if not 0.0 <= gamma <= 1.0:
            raise ValueError(f"gamma must be in [0, 1], got {gamma}")
        if not (isinstance(trace_decay, int | float) and 0.0 <= trace_decay <= 1.0):
            raise ValueError(f"trace_decay must be in [0, 1], got {trace_decay!r}")
        if method not in ("sarsa", "q"):
            raise ValueError(f"method must be 'sarsa' or 'q', got {method!r}")
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
        self.q = LinearPolicy(tile_coder, n_primitive, option_ids, initial_value=initial_value)
        if option_initial_value is not None:
            if not math.isfinite(option_initial_value):
                raise ValueError(f"option_initial_value must be finite, got {option_initial_value}")
            self.q.weights[n_primitive:] = option_initial_value / tile_coder.n_active
        self.tile_coder = tile_coder
        self.library = library
        self.n_primitive = int(n_primitive)
        self.alpha = float(alpha)
        self.epsilon = float(epsilon)
        self.gamma = float(gamma)
        self.method = method
        self.intra_option = bool(intra_option)
        self.bootstrap_on_truncation = bool(bootstrap_on_truncation)
        self.trace_decay = float(trace_decay)
        self.max_decisions = int(max_decisions)
        self.rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        self._step = self.alpha / tile_coder.n_active
        self._live_rows: set[int] = set()  # rows of the episode's traces that are non-zero
        self._lib_version: tuple[int, int] | None = None
        self._lib_pos = np.zeros(0, dtype=np.int64)
        self._lib_ok = np.zeros(0, dtype=bool)

    # ---------------------------------------------------------------- helpers
    @classmethod
    def from_policy(
        cls,
        policy: FrozenPolicy | LinearPolicy,
        library: OptionLibrary | None = None,
        **kwargs: Any,
    ) -> SmdpLearner:
        """A learner that starts from ``policy``'s weights and option ids.

        Useful to roll out a saved policy (``run_episode(env, learn=False)``) or to
        continue learning it. Its option ids must be known to ``library``.
        """
        if policy.option_ids and library is None:
            raise ValueError("this policy chooses options; pass the library that issued them")
        learner = cls(policy.n_primitive, policy.tile_coder, library, **kwargs)
        if library is not None:
            for oid in policy.option_ids:
                library.policy_of(oid)  # KeyError for ids the library never issued
        learner.q = LinearPolicy(
            policy.tile_coder, policy.n_primitive, policy.option_ids, policy.weights
        )
        return learner

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
        if not self._lib_ok.any():  # every offered option was pruned or retired
            mask[self.n_primitive :] = False
            return mask, membership
        m = lib.membership(state) if membership is None else membership
        avail = lib.available(state, self.rng, membership=m)
        mask[self.n_primitive :] = self._lib_ok & avail[self._lib_pos]
        return mask, m

    def _choose(self, q: np.ndarray, mask: np.ndarray, epsilon: float) -> tuple[int, bool]:
        if epsilon > 0.0 and self.rng.random() < epsilon:
            allowed = np.flatnonzero(mask)
            return int(allowed[self.rng.integers(allowed.shape[0])]), True
        return greedy_choice(q, self.rng, mask), False

    def _bootstrap(self, q: np.ndarray, mask: np.ndarray, choice: int) -> float:
        if self.method == "q":
            return float(np.max(np.where(mask, q, -np.inf)))
        return float(q[choice])

    def _check_env(self, env: Any) -> None:
        space = getattr(env, "action_space", None)
        n = getattr(space, "n", None)
        if n is None or int(n) != self.n_primitive:
            raise ValueError(
                f"environment action space {space!r} is not Discrete({self.n_primitive})"
            )
        obs_space = getattr(env, "observation_space", None)
        shape = getattr(obs_space, "shape", None)
        if shape is not None and tuple(shape) != (self.tile_coder.n_features,):
            raise ValueError(
                f"environment observations have shape {shape}, the tile coder expects "
                f"({self.tile_coder.n_features},)"
            )

    def _observation(self, obs: Any) -> np.ndarray:
        x = np.array(obs, dtype=np.float64)  # a copy: envs may reuse their buffers
        if x.shape != (self.tile_coder.n_features,):
            raise ValueError(
                f"observation must have shape ({self.tile_coder.n_features},), got {x.shape}"
            )
        if not np.isfinite(x).all():
            raise ValueError(f"observation contains NaN or infinite values: {x}")
        return x

    @staticmethod
    def _duration(info: dict[str, Any]) -> int:
        d = info.get("duration", 1)
        if isinstance(d, bool) or not isinstance(d, int | np.integer) or d < 1:
            raise ValueError(f"info['duration'] must be an int >= 1, got {d!r}")
        return int(d)

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
        q_next = None
        m_next = None
        if next_state is not None:
            q_next = self.q.q_values(next_state)
            if self.option_ids:
                m_next = self.library.membership(next_state)  # type: ignore[union-attr]
        disc = self.gamma**duration
        targets: dict[int, float] = {}
        if action != running:
            targets[action] = reward + (0.0 if q_next is None else disc * float(q_next.max()))
        if self.option_ids and m is not None:
            lib = self.library
            assert lib is not None
            tiles = {self.tile_coder: s_active}
            by_policy: dict[int, int] = {}
            for j, oid in enumerate(self.option_ids):
                c = self.n_primitive + j
                if c == running or not self._lib_ok[j]:
                    continue
                k = lib.option_kernel[self._lib_pos[j]]
                if m[k] <= 0.0:
                    continue
                pid = lib.policy_of(oid)
                if pid not in by_policy:
                    by_policy[pid] = lib.act(oid, s, self.rng, tiles)
                if by_policy[pid] != action:
                    continue
                if q_next is None:
                    targets[c] = reward
                else:
                    assert m_next is not None
                    beta_cont = m_next[k] ** lib.continuation_exponent
                    u = beta_cont * q_next[c] + (1.0 - beta_cont) * q_next.max()
                    targets[c] = reward + disc * float(u)
        if targets:
            q_now = self.q.q_from_tiles(s_active)
            for c, target in targets.items():
                self.q.update(s_active, c, self._step * (target - q_now[c]))

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
        self._check_env(env)
        epsilon = self.epsilon if (learn if explore is None else explore) else 0.0
        lib = self.library
        n_prim = self.n_primitive
        obs, _ = env.reset(seed=seed)
        s = self._observation(obs)
        trace: list[np.ndarray] = []
        choices: list[int] = []
        explored_flags: list[bool] = []
        options_chosen: list[int] = []
        runs: list[OptionRun] = []
        total_reward = 0.0
        discounted_return = 0.0
        last_reward = 0.0
        cycles = 0
        info: dict[str, Any] = {}
        terminated = truncated = False
        # One eligibility per weight, only when lambda > 0.
        traces = np.zeros_like(self.q.weights) if self.trace_decay > 0.0 else None
        self._live_rows.clear()  # rows of `traces` with a non-zero eligibility

        active = self.tile_coder.active(s)
        mask, m = self._choice_mask(s)
        choice, explored = self._choose(self.q.q_from_tiles(active), mask, epsilon)
        while True:
            # A choice point: `choice` was made at `s` (tiles `active`).
            start_active = active
            choices.append(choice)
            explored_flags.append(explored)
            option_id = self.q.option_ids[choice - n_prim] if choice >= n_prim else None
            if option_id is not None:
                assert lib is not None
                options_chosen.append(option_id)
                lib.record_use(option_id)
            run_start, run_cycles = len(trace), 0
            ret, disc = 0.0, 1.0  # discounted return of this choice, gamma ** duration
            while True:  # the steps of this choice
                if len(trace) >= self.max_decisions:
                    raise RuntimeError(f"episode exceeded max_decisions={self.max_decisions}")
                trace.append(s)
                if option_id is None:
                    action = choice
                else:
                    action = lib.act(option_id, s, self.rng, {self.tile_coder: active})  # type: ignore[union-attr]
                obs, reward, terminated, truncated, info = env.step(action)
                reward = float(reward)
                d = self._duration(info)
                ended = bool(terminated or truncated)
                bootstrap_end = bool(truncated and not terminated and self.bootstrap_on_truncation)
                next_s = self._observation(obs) if (not ended or bootstrap_end) else None
                if learn and self.intra_option:
                    self._intra_option_update(active, s, m, action, choice, reward, d, next_s)
                ret += disc * reward
                disc *= self.gamma**d
                discounted_return += self.gamma**cycles * reward
                total_reward += reward
                last_reward = reward
                cycles += d
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
            if option_id is not None:
                runs.append(
                    OptionRun(
                        option_id, run_start, len(trace) - run_start, run_cycles, ended, explored
                    )
                )
            if ended and not bootstrap_end:
                if learn:
                    self._td_update(traces, start_active, choice, ret, 0.0, True)
                break
            # Next choice point at s (or, for a bootstrapped truncation, the final state).
            if ended:
                s = next_s  # type: ignore[assignment]
                active = self.tile_coder.active(s)
                m = None
            q = self.q.q_from_tiles(active)
            if m is None:
                mask, m = self._choice_mask(s)
            else:  # membership already computed for the termination draw
                mask, _ = self._choice_mask(s, m)
            next_choice, explored = self._choose(q, mask, epsilon)
            if learn:
                target = ret + disc * self._bootstrap(q, mask, next_choice)
                # Watkins's Q(lambda): an exploratory choice cuts the traces.
                cut = self.method == "q" and explored
                self._td_update(traces, start_active, choice, target, disc * self.trace_decay, cut)
            if ended:
                break
            choice = next_choice

        outcome = info.get("outcome")
        if outcome is not None:
            success = outcome == "success"
        else:
            success = bool(terminated and not truncated and last_reward > 0)
        d_feat = self.tile_coder.n_features
        return EpisodeResult(
            total_reward=total_reward,
            discounted_return=discounted_return,
            cycles=cycles,
            decisions=len(trace),
            outcome=outcome,
            success=success,
            terminated=bool(terminated),
            truncated=bool(truncated),
            trace=np.array(trace, dtype=np.float64).reshape(len(trace), d_feat),
            final_observation=np.asarray(obs, dtype=np.float64),
            choices=choices,
            options_chosen=options_chosen,
            option_runs=runs,
            explored=explored_flags,
        )

    def _update(self, active: np.ndarray, choice: int, target: float) -> None:
        """Move Q(s, choice) toward ``target`` (Q recomputed: earlier updates may share tiles)."""
        current = float(np.take(self.q.weights[choice], active).sum())
        self.q.update(active, choice, self._step * (target - current))

    def _td_update(
        self, traces: np.ndarray | None, active: np.ndarray, choice: int, target: float,
        decay: float, cut: bool,
    ) -> None:
        """The update of one choice point, spread back along the eligibility traces.

        ``traces`` holds one replacing trace per weight (``None`` when ``lambda = 0``);
        ``decay`` is ``gamma ** D * lambda`` for the choice's duration ``D``; ``cut``
        clears the traces afterwards (episode end, or an exploratory choice next in
        Q-learning).
        """
        if traces is None:
            self._update(active, choice, target)
            return
        delta = target - float(np.take(self.q.weights[choice], active).sum())
        # Replacing traces on tiles (keepaway): the tiles of this state get eligibility 1
        # for this choice and 0 for the others, so tiles shared by successive states
        # are not counted twice (accumulating traces would multiply the step size).
        live = self._live_rows
        for row in live:
            traces[row, active] = 0.0
        traces[choice, active] = 1.0
        live.add(choice)
        step = self._step * delta
        for row in live:  # only rows with eligible tiles: other rows would add zeros
            self.q.weights[row] += step * traces[row]
        if cut:
            for row in live:
                traces[row] = 0.0
            live.clear()
            return
        for row in list(live):
            e = traces[row]
            e *= decay
            e[e < _MIN_TRACE] = 0.0
            if not e.any():
                live.discard(row)

    def train(
        self,
        env: Any,
        n_episodes: int,
        *,
        seed: int | None = None,
        callback: Callable[[int, EpisodeResult], None] | None = None,
    ) -> list[EpisodeResult]:
        """Learn for ``n_episodes`` episodes; ``seed`` seeds the first ``env.reset``."""
        if n_episodes < 0:
            raise ValueError("n_episodes must be >= 0")
        results = []
        for i in range(n_episodes):
            res = self.run_episode(env, learn=True, seed=seed if i == 0 else None)
            results.append(res)
            if callback is not None:
                callback(i, res)
        return results

    def evaluate(
        self, env: Any, n_episodes: int, *, seed: int | None = None
    ) -> list[EpisodeResult]:
        """Greedy rollouts without learning (e.g. to collect traces of the learnt policy)."""
        return [
            self.run_episode(env, learn=False, seed=seed if i == 0 else None)
            for i in range(n_episodes)
        ]
