"""The SMDP episode: what a learner needs from an environment, and what an episode did.

Every learner of :mod:`ilpss` (:class:`~ilpss.smdp.SmdpLearner`,
:class:`~ilpss.baselines.PrqLearner`) stands on this module.

The environment contract
------------------------
Any Gymnasium environment with a 1-D ``Box`` observation of ``n_features`` values and a
``Discrete(n_primitive)`` action space (:func:`check_env`). Each observation is used as a
finite float64 copy (:func:`observation`). One ``step`` may last several cycles:
``info["duration"]``, an int >= 1, taken as 1 when absent (:func:`step_duration`). An
episode *succeeds* when its last ``info["outcome"]`` is ``"success"``, or, for an
environment that reports no outcome, when it terminated (not truncated) with a positive
last reward.

The episode log
---------------
An :class:`EpisodeLog` is filled while the episode runs: every decision state
(:meth:`~EpisodeLog.visit`), every choice (:meth:`~EpisodeLog.choose`), every step's
reward and duration (:meth:`~EpisodeLog.step`), every option run; it then makes the
:class:`EpisodeResult` (:meth:`~EpisodeLog.result`). :class:`EpisodicLearner` gives
``train`` and ``evaluate`` to any learner with a ``run_episode``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ilpss.tiles import box_bounds
from soccer_drill.constraints import Real, check, is_int

__all__ = [
    "DecisionLimitError",
    "EpisodeLog",
    "EpisodeResult",
    "EpisodicLearner",
    "check_env",
    "observation",
    "options_used",
    "step_duration",
]


@dataclass(frozen=True)
class OptionRun:
    """One execution of an option within an episode."""

    option_id: int
    start_decision: int  # index into EpisodeResult.trace of its first decision
    n_decisions: int
    cycles: int
    ended_by_episode: bool  # the episode ended while it ran (rather than K(s) stopping it)
    explored: bool  # it was started by an exploratory (random) choice
    interrupted: bool = False  # stopped because a primitive was worth more (interruption)


@dataclass
class EpisodeResult:
    """Summary of one episode of a learner.

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


def options_used(
    results: Iterable[EpisodeResult], greedy_only: bool = True, min_decisions: int = 1
) -> set[int]:
    """Option ids started in ``results`` (by default only by non-exploratory choices).

    Pass the options used by greedy rollouts of the learnt policy
    (:meth:`EpisodicLearner.evaluate`) to :meth:`ilpss.options.OptionLibrary.end_trial`:
    those are the options "used by the learnt policy" of the paper's discounting rule.
    With ``min_decisions > 1`` an option counts only if its runs in ``results`` lasted
    that many decisions in all: the policy relies on it rather than starting it now and
    then.
    """
    decisions: dict[int, int] = {}
    for res in results:
        for run in res.option_runs:
            if not (greedy_only and run.explored):
                decisions[run.option_id] = decisions.get(run.option_id, 0) + run.n_decisions
    return {oid for oid, n in decisions.items() if n >= min_decisions}


# ------------------------------------------------------------ the environment contract
def check_env(env: Any, n_primitive: int, n_features: int,
              bounds: tuple[np.ndarray, np.ndarray] | None = None) -> None:
    """Refuse an environment whose spaces are not ``Discrete(n_primitive)`` actions and
    observations of shape ``(n_features,)`` (when it declares an observation shape), or,
    given the ``bounds`` a tile coder was made for, a bounded observation space with
    other bounds (another field or speeds: its observations would be clipped to the
    learner's ranges without a word)."""
    space = getattr(env, "action_space", None)
    n = getattr(space, "n", None)
    if space is None:
        raise ValueError(f"the environment has no action_space: give a Gymnasium "
                         f"environment (action_space Discrete({n_primitive}), reset and step), "
                         f"not {type(env).__name__} {env!r:.80}")
    if n is None or int(n) != n_primitive:
        raise ValueError(f"environment action space {space!r} is not Discrete({n_primitive})")
    shape = getattr(getattr(env, "observation_space", None), "shape", None)
    if shape is not None and tuple(shape) != (n_features,):
        raise ValueError(
            f"environment observations have shape {shape}, the tile coder expects "
            f"({n_features},)"
        )
    if bounds is None:
        return
    try:
        low, high = box_bounds(env.observation_space)
    except ValueError:  # not a bounded box: nothing to compare
        return
    differ = np.flatnonzero((low != bounds[0]) | (high != bounds[1]))
    if differ.size:
        i = int(differ[0])
        raise ValueError(
            f"environment observation bounds differ from those the learner's tile coder was "
            f"made for ({differ.size} feature(s); feature {i}: the environment's "
            f"[{low[i]:g}, {high[i]:g}], the learner's [{bounds[0][i]:g}, {bounds[1][i]:g}]); "
            "make the learner on this environment's observation space")


def observation(obs: Any, n_features: int) -> np.ndarray:
    """``obs`` as a new float64 array of shape ``(n_features,)`` (environments may reuse
    their buffers), refusing another shape and NaN or infinite values."""
    x = np.array(obs, dtype=np.float64)
    if x.shape != (n_features,):
        raise ValueError(f"observation must have shape ({n_features},), got {x.shape}")
    if not np.isfinite(x).all():
        raise ValueError(f"observation contains NaN or infinite values: {x}")
    return x


REWARD = Real()
"""What an environment's step may return as its reward: a finite real number."""


def step_reward(reward: Any) -> float:
    """The reward one environment step returned, as a float: a finite real number
    (Python's or NumPy's, or a 0-d array of one). Anything else is refused naming it, before
    the learner uses it (a NaN would surface later as a diverged TD target)."""
    if type(reward) is float and math.isfinite(reward):  # the common case
        return reward
    if isinstance(reward, np.ndarray) and reward.shape == ():
        reward = reward.item()
    check("the reward the environment's step returned", reward, REWARD)
    return float(reward)


def step_duration(info: dict[str, Any]) -> int:
    """Cycles a step took: ``info["duration"]`` (an int >= 1), 1 when absent."""
    d = info.get("duration", 1)
    if not is_int(d) or d < 1:
        raise ValueError(f"info['duration'] must be an int >= 1, got {d!r}")
    return int(d)


# ------------------------------------------------------------------------- the log
class DecisionLimitError(RuntimeError):
    """An episode took more decisions than ``LearnerConfig.max_decisions``: a setting too
    small for the environment, which a rerun with the same settings meets again."""


class EpisodeLog:
    """What one episode did so far; :meth:`result` makes its :class:`EpisodeResult`.

    Parameters
    ----------
    gamma : float
        Discount per cycle of the learner, for ``discounted_return``.
    n_features : int
    max_decisions : int
        Safety bound on the decisions of one episode (:meth:`visit` raises beyond it).
    """

    def __init__(self, gamma: float, n_features: int, max_decisions: int) -> None:
        self.gamma = gamma
        self.n_features = n_features
        self.max_decisions = max_decisions
        self.trace: list[np.ndarray] = []
        self.choices: list[int] = []
        self.explored: list[bool] = []
        self.options_chosen: list[int] = []
        self.option_runs: list[OptionRun] = []
        self.total_reward = 0.0
        self.discounted_return = 0.0
        self.last_reward = 0.0
        self.cycles = 0
        self._last: tuple[Any, dict[str, Any], bool, bool] | None = None

    @property
    def decisions(self) -> int:
        """Decision states visited so far."""
        return len(self.trace)

    def choose(self, choice: int, explored: bool) -> None:
        """A choice point: ``choice`` was made (at random if ``explored``)."""
        self.choices.append(choice)
        self.explored.append(explored)

    def visit(self, state: np.ndarray) -> None:
        """The agent decides at ``state`` (it joins the trace)."""
        if len(self.trace) >= self.max_decisions:
            raise DecisionLimitError(
                f"episode exceeded max_decisions={self.max_decisions} (LearnerConfig."
                "max_decisions, a safety bound: it must exceed the decisions of the "
                "environment's longest episode)")
        self.trace.append(state)

    def step(
        self, obs: Any, reward: float, duration: int, terminated: bool, truncated: bool,
        info: dict[str, Any],
    ) -> None:
        """What one environment step returned (``reward`` as a float, its duration)."""
        self.discounted_return += self.gamma**self.cycles * reward
        self.total_reward += reward
        self.last_reward = reward
        self.cycles += duration
        self._last = (obs, info, terminated, truncated)

    def result(self) -> EpisodeResult:
        """The episode's :class:`EpisodeResult` (after its last step)."""
        if self._last is None:  # not an assert: python -O would drop the check
            raise RuntimeError("an episode has at least one step: call step() before result()")
        obs, info, terminated, truncated = self._last
        outcome = info.get("outcome")
        if outcome is not None:
            success = outcome == "success"
        else:
            success = bool(terminated and not truncated and self.last_reward > 0)
        n = len(self.trace)
        return EpisodeResult(
            total_reward=self.total_reward,
            discounted_return=self.discounted_return,
            cycles=self.cycles,
            decisions=n,
            outcome=outcome,
            success=success,
            terminated=bool(terminated),
            truncated=bool(truncated),
            trace=np.array(self.trace, dtype=np.float64).reshape(n, self.n_features),
            final_observation=np.asarray(obs, dtype=np.float64),
            choices=self.choices,
            options_chosen=self.options_chosen,
            option_runs=self.option_runs,
            explored=self.explored,
        )


class EpisodicLearner:
    """``train`` and ``evaluate`` for a learner that defines ``run_episode``."""

    def run_episode(
        self, env: Any, learn: bool = True, *, seed: int | None = None
    ) -> EpisodeResult:  # pragma: no cover - interface
        """One episode on ``env`` (``seed`` passed to ``env.reset``), learning if ``learn``."""
        raise NotImplementedError

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

    def evaluate(
        self, env: Any, n_episodes: int, *, seed: int | None = None
    ) -> list[EpisodeResult]:
        """Greedy episodes without learning (e.g. to collect traces of the learnt policy);
        ``seed`` seeds the first ``env.reset`` only."""
        if n_episodes < 0:
            raise ValueError("n_episodes must be >= 0")
        return [
            self.run_episode(env, learn=False, seed=seed if i == 0 else None)
            for i in range(n_episodes)
        ]
