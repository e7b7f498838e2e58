"""Small synthetic SMDPs and kernel-model test doubles for the ``ilpss`` learner tests.

``ZoneCorridor`` is a Gymnasium environment whose optimal policy is known by hand:

* The state is the position ``x`` in ``[0, 9)``; the goal is ``x >= 9``. Episodes start
  at ``x ~ U(0, start_high)``.
* Three zones of three cells each: A = [0, 3), B = [3, 6), C = [6, 9). In every zone
  one action is *fast* (moves +1 in 1 cycle), one is *slow* (moves +1 in 3 cycles) and
  one is *fatal* (the episode ends: reward -1, outcome ``"interception"``):

  ======  ======  ======  ======
  zone    fast    slow    fatal
  ======  ======  ======  ======
  A       0       1       2
  B       1       2       0
  C       2       0       1
  ======  ======  ======  ======

* Every step costs ``cost * duration``; reaching the goal pays +1 (outcome
  ``"success"``); after ``max_cycles`` cycles the episode is truncated with -1
  (``"timeout"``). ``info["duration"]`` is the number of cycles of the step.

With per-cycle discount ``gamma < 1`` the optimal policy takes the fast action of the
current zone: after a fast or a slow step the agent is in the same next cell, but the
slow step costs more and its future is discounted by ``gamma**3`` instead of ``gamma``.
With ``n = 8 - floor(x)`` cells to go after this one, the optimal value is
``V*(x) = gamma**n - cost * (1 - gamma**(n + 1)) / (1 - gamma)`` (:func:`optimal_value`).
Only correct handling of the durations separates fast from slow when ``cost = 0``.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable

import gymnasium as gym
import numpy as np

from ilpss._io import load_npz, save_npz_atomic
from ilpss.policy import FrozenPolicy
from ilpss.tiles import TileCoder

FAST = {0: 0, 1: 1, 2: 2}  # zone -> fast action
SLOW = {0: 1, 1: 2, 2: 0}
FATAL = {0: 2, 1: 0, 2: 1}
LENGTH = 9.0


def zone(x: float) -> int:
    """Zone index (0 = A, 1 = B, 2 = C) of position ``x``."""
    return min(int(x // 3.0), 2)


def optimal_action(x: float) -> int:
    """The fast action of ``x``'s zone."""
    return FAST[zone(x)]


def optimal_value(x: float, gamma: float, cost: float) -> float:
    """Optimal return (discounted per cycle) from position ``x`` (closed form)."""
    n = 8 - int(np.floor(x))
    if gamma == 1.0:
        return 1.0 - cost * (n + 1)
    return gamma**n - cost * (1.0 - gamma ** (n + 1)) / (1.0 - gamma)


class ZoneCorridor(gym.Env):
    """The corridor SMDP described in the module docstring.

    Parameters
    ----------
    cost : float, default 0.05
        Reward per cycle spent (negative).
    start_high : float, default 9.0
        Starts are uniform on ``[0, start_high)``.
    max_cycles : int, default 60
    n_features : int, default 1
        Extra features (beyond ``x``) are uniform noise in [0, 1], to give the
        observation the drill's 9 dimensions in benchmarks.
    step_cost_s : float, default 0.0
        Busy-wait per step (seconds), to imitate an expensive simulator.
    """

    metadata = {"render_modes": []}  # noqa: RUF012 - Gymnasium's convention

    def __init__(
        self,
        cost: float = 0.05,
        start_high: float = LENGTH,
        max_cycles: int = 60,
        n_features: int = 1,
        step_cost_s: float = 0.0,
    ) -> None:
        low = np.zeros(n_features)
        high = np.ones(n_features)
        high[0] = LENGTH
        self.observation_space = gym.spaces.Box(low, high, dtype=np.float64)
        self.action_space = gym.spaces.Discrete(3)
        self.cost = cost
        self.start_high = start_high
        self.max_cycles = max_cycles
        self.n_features = n_features
        self.step_cost_s = step_cost_s
        self.x = 0.0
        self.cycles = 0

    def _obs(self) -> np.ndarray:
        obs = np.empty(self.n_features)
        obs[0] = self.x
        if self.n_features > 1:
            obs[1:] = self.np_random.random(self.n_features - 1)
        return obs

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.x = float(self.np_random.uniform(0.0, self.start_high))
        self.cycles = 0
        return self._obs(), {}

    def step(self, action: int):
        if not self.action_space.contains(action):
            raise ValueError(f"invalid action {action!r}")
        if self.step_cost_s > 0:
            _busy_wait(self.step_cost_s)
        z = zone(self.x)
        if action == FATAL[z]:
            self.cycles += 1
            return self._obs(), -1.0, True, False, {"duration": 1, "outcome": "interception"}
        duration = 1 if action == FAST[z] else 3
        self.x += 1.0
        self.cycles += duration
        reward = -self.cost * duration
        if self.x >= LENGTH:
            return (
                self._obs(),
                reward + 1.0,
                True,
                False,
                {"duration": duration, "outcome": "success"},
            )
        if self.cycles >= self.max_cycles:
            return (
                self._obs(),
                reward - 1.0,
                False,
                True,
                {"duration": duration, "outcome": "timeout"},
            )
        return self._obs(), reward, False, False, {"duration": duration, "outcome": None}


def _busy_wait(seconds: float) -> None:
    import time

    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        pass


class NoDurationEnv(gym.Wrapper):
    """Strips ``duration`` and ``outcome`` from ``info`` (a plain Gymnasium env)."""

    def step(self, action: int):
        obs, r, term, trunc, _ = self.env.step(action)
        return obs, r, term, trunc, {}


# --------------------------------------------------------------------------- kernels
class FunctionKernels:
    """Test double of a fitted kernel model with given membership functions.

    Parameters
    ----------
    funcs : list of callable
        ``funcs[k](x) -> float in [0, 1]`` for a state ``x`` of shape (d,).
    means : array_like (K, d)
    covariances : array_like (K, d, d)
    return_2d : bool, default False
        Return shape (1, K) for one state (the other accepted convention).
    """

    def __init__(
        self,
        funcs: list[Callable[[np.ndarray], float]],
        means: np.ndarray,
        covariances: np.ndarray,
        return_2d: bool = False,
    ) -> None:
        self.funcs = list(funcs)
        self.means_ = np.asarray(means, dtype=np.float64)
        self.covariances_ = np.asarray(covariances, dtype=np.float64)
        self.n_components = len(self.funcs)
        self.return_2d = return_2d

    def membership(self, X: np.ndarray) -> np.ndarray:
        X = np.asarray(X, dtype=np.float64)
        if X.ndim == 1:
            m = np.array([f(X) for f in self.funcs])
            return m[None, :] if self.return_2d else m
        return np.array([[f(x) for f in self.funcs] for x in X])


class IntervalKernels:
    """Test double: kernel k has membership ``inside[k]`` on ``[a_k, b_k)`` of feature 0,
    ``outside[k]`` elsewhere; saveable (for library save/load tests)."""

    def __init__(
        self,
        intervals: list[tuple[float, float]],
        inside: float | list[float] = 0.9,
        outside: float | list[float] = 0.0,
        n_features: int = 1,
    ) -> None:
        self.intervals = np.asarray(intervals, dtype=np.float64).reshape(-1, 2)
        K = self.intervals.shape[0]
        self.inside = np.broadcast_to(np.asarray(inside, dtype=np.float64), (K,)).copy()
        self.outside = np.broadcast_to(np.asarray(outside, dtype=np.float64), (K,)).copy()
        self.n_components = K
        self.n_features = n_features
        centre = self.intervals.mean(axis=1)
        half = (self.intervals[:, 1] - self.intervals[:, 0]) / 2.0
        self.means_ = np.zeros((K, n_features))
        self.means_[:, 0] = centre
        self.covariances_ = np.tile(np.eye(n_features) * 0.1, (K, 1, 1))
        self.covariances_[:, 0, 0] = half**2

    def membership(self, X: np.ndarray) -> np.ndarray:
        X = np.asarray(X, dtype=np.float64)
        single = X.ndim == 1
        x0 = np.atleast_2d(X)[:, :1]
        inside = (x0 >= self.intervals[:, 0]) & (x0 < self.intervals[:, 1])
        m = np.where(inside, self.inside, self.outside)
        return m[0] if single else m

    def permuted(self, perm: list[int]) -> IntervalKernels:
        return IntervalKernels(
            self.intervals[perm].tolist(),
            self.inside[perm].tolist(),
            self.outside[perm].tolist(),
            self.n_features,
        )

    def save(self, path: str | os.PathLike[str]) -> None:
        save_npz_atomic(
            path,
            {"intervals": self.intervals, "inside": self.inside, "outside": self.outside},
            {"schema": "tests.interval_kernels/1", "n_features": self.n_features},
        )

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> IntervalKernels:
        arrays, meta = load_npz(
            path,
            "tests.interval_kernels/1",
            {"intervals": (("K", 2), "f"), "inside": (("K",), "f"), "outside": (("K",), "f")},
        )
        return cls(
            arrays["intervals"].tolist(),
            arrays["inside"].tolist(),
            arrays["outside"].tolist(),
            int(meta["n_features"]),
        )


def constant_kernels(values: list[float], n_features: int = 1) -> FunctionKernels:
    """Kernels whose membership is a constant everywhere (for statistical tests)."""
    K = len(values)
    means = np.arange(K, dtype=np.float64)[:, None] * np.ones((K, n_features)) * 10.0
    covs = np.tile(np.eye(n_features), (K, 1, 1))
    return FunctionKernels([lambda x, v=v: v for v in values], means, covs)


class ScriptedChain(gym.Env):
    """Deterministic chain: the state is the step count ``x``; step ``i`` (from ``x = i``)
    pays ``rewards[i]`` and lasts ``durations[i]`` cycles whatever the action; the episode
    terminates after ``len(rewards)`` steps (outcome ``"success"``). For exact checks of
    the SMDP update."""

    def __init__(self, rewards: list[float], durations: list[int], n_features: int = 1) -> None:
        assert len(rewards) == len(durations)
        self.rewards = list(rewards)
        self.durations = list(durations)
        high = np.full(n_features, float(len(rewards)))
        self.observation_space = gym.spaces.Box(np.zeros(n_features), high, dtype=np.float64)
        self.action_space = gym.spaces.Discrete(3)
        self.n_features = n_features
        self.x = 0
        self.actions: list[int] = []

    def _obs(self) -> np.ndarray:
        return np.full(self.n_features, float(self.x))

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.x = 0
        self.actions = []
        return self._obs(), {}

    def step(self, action: int):
        self.actions.append(int(action))
        i = self.x
        self.x += 1
        done = self.x >= len(self.rewards)
        info = {"duration": self.durations[i], "outcome": "success" if done else None}
        return self._obs(), float(self.rewards[i]), done, False, info


# --------------------------------------------------------------------------- helpers
def read_archive(path: str | os.PathLike[str]) -> tuple[dict[str, np.ndarray], dict]:
    """Every array and the ``meta`` record of an ilpss archive, unchecked (to tamper with
    it in tests and save it back with a valid digest)."""
    with np.load(path, allow_pickle=False) as f:
        arrays = {k: f[k] for k in f.files}
    return arrays, json.loads(str(arrays.pop("__meta__")))["meta"]



Z999 = 3.29  # two-sided 99.9 % normal quantile


def binomial_ok(hits: int, n: int, p: float) -> bool:
    """Whether hits/n is within the 99.9 % normal-approximation interval of p."""
    sd = np.sqrt(p * (1 - p) / n)
    return abs(hits / n - p) <= Z999 * sd + 1e-12


def coder1() -> TileCoder:
    return TileCoder([0.0], [9.0], [1.0], n_tilings=4)


def constant_policy(
    action: int,
    option_ids: tuple[int, ...] = (),
    prefer: int | None = None,
    n_primitive: int = 3,
    coder: TileCoder | None = None,
) -> FrozenPolicy:
    """A policy whose greedy choice is ``prefer`` (a choice index) or ``action`` everywhere.

    Primitive values are 3, 2, 1 ... starting from ``action``, so the best primitive is
    ``action`` even when an option choice is preferred.
    """
    coder = coder or coder1()
    n_choices = n_primitive + len(option_ids)
    q = np.zeros(n_choices)
    for rank, a in enumerate([action] + [a for a in range(n_primitive) if a != action]):
        q[a] = 3.0 - rank
    if prefer is not None:
        q[prefer] = 10.0
    w = np.repeat(q[:, None] / coder.n_active, coder.n_weights, axis=1)
    return FrozenPolicy(coder, n_primitive, option_ids, w)
