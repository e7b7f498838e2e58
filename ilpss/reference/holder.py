"""PPO and MaskablePPO on the holder, with Stable-Baselines3: train, evaluate, transfer.

The environment stack, bottom to top: ``soccer_drill.vector.sb3.HolderSB3VecEnv`` (the batched
holder as an SB3 ``VecEnv``), ``VecMonitor`` (the drill's episode rewards, for the
learning curve), :class:`TimeoutWrapper` (the timeout as a terminal end, and the
setting's :class:`~ilpss.reference.settings.RewardOption` when it is active) and
``VecNormalize``
(observations only). The greedy evaluation plays the single holder environment
(``gymnasium.make``) on the held-out episode seeds, the episodes the fixed rules are
evaluated on, with the observation statistics frozen.
"""

from __future__ import annotations

import time
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from sb3_contrib import MaskablePPO
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import VecEnvWrapper, VecMonitor, VecNormalize

from ilpss.experiments.drill_facts import ENV_ID, HOLDER_SB3_VEC_ENV, drill_object
from ilpss.reference.settings import HolderSetting, RewardOption, TransferSetting

__all__ = ["evaluate", "train", "transfer"]

"""The batched holder as an SB3 ``VecEnv``, looked up by name (``ilpss`` imports no drill
module directly)."""
MAX_DECISIONS = 1_000
"""More decisions than any holder episode takes (the timeout ends one within 100
cycles): a bound on the steps of a budget given in episodes."""


class TimeoutWrapper(VecEnvWrapper):
    """The drill's timeout as the learner takes it: a terminal end when ``terminal``
    (``TimeLimit.truncated`` cleared, so that SB3 does not bootstrap the value there),
    and paid ``option.timeout_reward`` instead of the drill's -1 when that is set."""

    def __init__(self, venv: Any, option: RewardOption, terminal: bool) -> None:
        super().__init__(venv)
        self.option, self.terminal = option, terminal

    def reset(self) -> np.ndarray:
        return self.venv.reset()

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        obs, rewards, dones, infos = self.venv.step_wait()
        for i in np.flatnonzero(dones).tolist():
            if infos[i].get("outcome") != "timeout":
                continue
            if self.option.timeout_reward is not None:
                rewards[i] = self.option.timeout_reward
            if self.terminal:
                infos[i]["TimeLimit.truncated"] = False
        return obs, rewards, dones, infos


class Curve(BaseCallback):
    """The learning curve: one row per rollout, ``[steps, seconds, mean reward, success
    rate, episodes]`` over the episodes that ended in it (the drill's reward; ``None``
    where none ended), and every episode's reward in order when ``keep_episodes``.
    Stops learning after ``max_episodes`` episodes, if given."""

    def __init__(self, max_episodes: int | None = None, keep_episodes: bool = False,
                 progress: Any = None) -> None:
        super().__init__()
        self.max_episodes, self.keep_episodes = max_episodes, keep_episodes
        self.progress = progress  # progress(steps done), after each rollout
        self.rows: list[list[float]] = []
        self.episodes: list[float] = []
        self._ended: list[float] = []
        self._count = 0
        self._start = time.perf_counter()

    def _on_step(self) -> bool:
        for info in self.locals["infos"]:
            if "episode" in info:
                if self.max_episodes is not None and self._count >= self.max_episodes:
                    break
                self._ended.append(float(info["episode"]["r"]))
                self._count += 1
        return self.max_episodes is None or self._count < self.max_episodes

    def _on_rollout_end(self) -> None:
        self._flush()
        if self.progress is not None:
            self.progress(self.num_timesteps)

    def _on_training_end(self) -> None:
        self._flush()

    def _flush(self) -> None:
        if not self._ended and self.rows and self.rows[-1][0] == self.num_timesteps:
            return
        r = np.asarray(self._ended)
        self.rows.append([float(self.num_timesteps), time.perf_counter() - self._start,
                          float(r.mean()) if r.size else None,
                          float((r > 0).mean()) if r.size else None, float(r.size)])
        if self.keep_episodes:
            self.episodes += self._ended
        self._ended = []


def _venv(team: str, setting: HolderSetting, seed: int,
          obs_rms: Any = None) -> VecNormalize | Any:
    """The training stack against ``team``, its drills seeded ``seed, seed + 1, ...``."""
    venv = drill_object(HOLDER_SB3_VEC_ENV)(setting.ppo.n_envs, opponent=team)
    venv.seed(seed)
    venv = VecMonitor(venv)
    if setting.reward.active or setting.timeout_terminal:
        venv = TimeoutWrapper(venv, setting.reward, setting.timeout_terminal)
    if setting.normalize_obs:
        venv = VecNormalize(venv, norm_obs=True, norm_reward=False, gamma=setting.ppo.gamma)
        if obs_rms is not None:  # fine-tuning: the statistics learnt so far
            venv.obs_rms = obs_rms.copy()
    return venv


def _model(setting: HolderSetting, venv: Any, seed: int) -> PPO:
    p = setting.ppo
    algo = PPO if setting.algo == "ppo" else MaskablePPO
    return algo("MlpPolicy", venv, n_steps=p.n_steps, batch_size=p.batch_size,
                n_epochs=p.n_epochs, learning_rate=p.learning_rate, gamma=p.gamma,
                gae_lambda=p.gae_lambda, clip_range=p.clip_range, ent_coef=p.ent_coef,
                vf_coef=p.vf_coef, max_grad_norm=p.max_grad_norm,
                policy_kwargs={"net_arch": list(p.net_arch)}, seed=seed, device="cpu",
                verbose=0)


def _train_seed(seed: int, stage: int = 0) -> int:
    """The first episode seed of a training stack: far from the evaluation seeds."""
    return 1_000_000 * (seed + 1) + 10_000 * stage


def train(team: str, setting: HolderSetting, seed: int, progress: Any = None
          ) -> tuple[Any, Any, list[list[float]]]:
    """Learn against ``team`` for ``setting.ppo.steps`` decisions. Returns the model, its
    training stack (for the observation statistics) and the learning curve;
    ``progress(steps done, budget)`` is called after each rollout."""
    torch.set_num_threads(1)
    venv = _venv(team, setting, _train_seed(seed))
    model = _model(setting, venv, seed)
    curve = Curve(progress=None if progress is None else
                  (lambda done: progress(done, setting.ppo.steps)))
    model.learn(total_timesteps=setting.ppo.steps, callback=curve)
    return model, venv, curve.rows


def evaluate(model: Any, venv: Any, team: str, episodes: int, first_seed: int) -> list[float]:
    """The greedy policy's reward on ``episodes`` episodes of the single holder
    environment against ``team``, seeded ``first_seed, first_seed + 1, ...``."""
    env = gym.make(ENV_ID, opponent=team, disable_env_checker=True)
    maskable = isinstance(model, MaskablePPO)
    normalize = venv.normalize_obs if isinstance(venv, VecNormalize) else (lambda o: o)
    rewards = []
    for i in range(episodes):
        obs, _ = env.reset(seed=first_seed + i)
        done, total = False, 0.0
        while not done:
            kwargs = {"action_masks": env.unwrapped.action_masks()} if maskable else {}
            action, _ = model.predict(normalize(obs[None]), deterministic=True, **kwargs)
            obs, r, term, trunc, _ = env.step(int(action[0]))
            total += float(r)
            done = term or trunc
        rewards.append(total)
    env.close()
    return rewards


def transfer(sources: tuple[str, ...], target: str, setting: TransferSetting, seed: int,
             episodes: int, first_seed: int) -> dict[str, Any]:
    """Fine-tuning against learning anew on ``target`` (protocol A's order: the sources in
    turn, then the target). Each arm's record: the target's learning curve, one reward per
    episode for ``setting.target_episodes`` episodes, and its greedy evaluation."""
    torch.set_num_threads(1)
    h = setting.holder
    start = time.perf_counter()
    venv = _venv(sources[0], h, _train_seed(seed))
    model = _model(h, venv, seed)
    for k, team in enumerate(sources):
        if k:
            venv = _venv(team, h, _train_seed(seed, k), getattr(venv, "obs_rms", None))
            model.set_env(venv)
        model.learn(total_timesteps=setting.source_steps, reset_num_timesteps=False)
    source_seconds = time.perf_counter() - start
    out: dict[str, Any] = {"source_seconds": source_seconds}
    for arm in ("fine_tuned", "anew"):
        stage = len(sources)
        if arm == "fine_tuned":
            venv = _venv(target, h, _train_seed(seed, stage), getattr(venv, "obs_rms", None))
            model.set_env(venv)
        else:
            venv = _venv(target, h, _train_seed(seed, stage))
            model = _model(h, venv, seed)
        curve = Curve(max_episodes=setting.target_episodes, keep_episodes=True)
        model.learn(total_timesteps=setting.target_episodes * MAX_DECISIONS, callback=curve,
                    reset_num_timesteps=True)
        if len(curve.episodes) != setting.target_episodes:
            raise RuntimeError(f"{arm}: {len(curve.episodes)} target episodes, expected "
                               f"{setting.target_episodes}")
        out[arm] = {"curve": curve.episodes, "rows": curve.rows,
                    "eval": evaluate(model, venv, target, episodes, first_seed)}
    return out
