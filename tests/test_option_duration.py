"""Kernel options last several decisions in the drill's 9 dimensions.

With ``exp(-d2/2)`` as membership a typical in-kernel state (d2 near 9) would give
K ~ 0.01 and every option would stop after one decision; the chi-square tail keeps
options alive for a few decisions along real trajectories.
"""

from __future__ import annotations

import numpy as np

from ilpss.kernels import SharedKernelModel
from soccer_drill.envs.holder import HolderEnv
from soccer_drill.policies import always_dribble, pass_first


def _traces(team: str, policy, seeds: range) -> list[np.ndarray]:
    env = HolderEnv(opponent=team)
    rng = np.random.default_rng(0)
    traces = []
    for seed in seeds:
        obs, _ = env.reset(seed=seed)
        states, done = [obs], False
        while not done:
            obs, _, term, trunc, info = env.step(policy(obs, rng))
            done = term or trunc
            if not done:
                states.append(obs)
        if info["outcome"] == "success":
            traces.append(np.asarray(states, dtype=float))
    return traces


def _mean_run(model: SharedKernelModel, traces: list[np.ndarray], membership) -> float:
    """Expected decisions an option started at each state runs for along the trajectory."""
    runs = []
    for trace in traces:
        K = membership(trace)
        for start in range(len(trace)):
            k = int(np.argmax(K[start]))
            expected, alive = 1.0, 1.0
            for later in range(start + 1, len(trace)):
                alive *= K[later, k]  # continues with probability K(s')
                expected += alive
            runs.append(expected)
    return float(np.mean(runs))


def test_options_run_for_several_decisions_along_drill_trajectories():
    bags = [np.concatenate(_traces("goal_guards", always_dribble, range(40))),
            np.concatenate(_traces("interceptor_guard", pass_first, range(60)))]
    model = SharedKernelModel(5, random_state=0).fit(bags)
    held_out = _traces("goal_guards", always_dribble, range(100, 130))
    chi2_run = _mean_run(model, held_out, model.membership)
    gauss_run = _mean_run(model, held_out, lambda X: np.exp(-model.sq_mahalanobis(X) / 2))
    assert chi2_run > 1.5, chi2_run  # measured 1.75 decisions (HOLD and DRIBBLE last 0.4 s)
    assert gauss_run < 1.1, gauss_run  # measured 1.03: exp(-d2/2) stops almost at once
