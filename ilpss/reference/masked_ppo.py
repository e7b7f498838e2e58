"""A shared-policy masked PPO on the batched parallel drill, in one file (CleanRL style).

One actor-critic for every learning agent of ``soccer_drill.vector.ParallelVectorEnv``
(the two attackers against a team, or all four players in self-play, where the last
feature tells attacker from defender). Read top to bottom: the network, the rollout,
the advantages, the update, the greedy evaluation.

The drill's conventions this follows:

- ``observations[agent]`` is ``{"observation": (num_envs, d), "action_mask": (num_envs, 5)}``;
  a masked action gets no probability (its logit is set to a large negative number), so
  no masked action is ever taken.
- Autoreset is Gymnasium's ``NEXT_STEP``: the step after a drill's episode ends only
  resets it (actions ignored, reward 0). That step is not a decision: it is left out of
  the loss (``valid``), and the episode's last step is terminal (no bootstrap: a timeout
  is one of the drill's outcomes, paid -1).
- Observations are scaled to [-1, 1] by the observation space's bounds (the raw
  features go up to 180), so no running statistics are needed.

``steps`` counts environment steps: calls of ``step`` times drills, as SB3 counts a
``VecEnv``'s steps (however many agents act in a drill's step).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch import nn
from torch.distributions import Categorical

from ilpss.reference.settings import PPOConfig

__all__ = ["Agent", "evaluate", "train"]

MASKED = -1e8
"""The logit of a masked action."""


# ----------------------------------------------------------------------------- network
def _layer(n_in: int, n_out: int, gain: float = np.sqrt(2)) -> nn.Linear:
    layer = nn.Linear(n_in, n_out)
    nn.init.orthogonal_(layer.weight, gain)
    nn.init.constant_(layer.bias, 0.0)
    return layer


def _mlp(n_in: int, widths: tuple[int, ...], n_out: int, out_gain: float) -> nn.Sequential:
    layers: list[nn.Module] = []
    for width in widths:
        layers += [_layer(n_in, width), nn.Tanh()]
        n_in = width
    return nn.Sequential(*layers, _layer(n_in, n_out, out_gain))


class Agent(nn.Module):
    """Separate actor and critic MLPs (tanh), as CleanRL's PPO; observations scaled by the
    space's bounds."""

    def __init__(self, low: np.ndarray, high: np.ndarray, n_actions: int,
                 net_arch: tuple[int, ...]) -> None:
        super().__init__()
        self.register_buffer("low", torch.as_tensor(low, dtype=torch.float32))
        self.register_buffer("span", torch.as_tensor(np.maximum(high - low, 1e-6),
                                                     dtype=torch.float32))
        self.critic = _mlp(len(low), net_arch, 1, 1.0)
        self.actor = _mlp(len(low), net_arch, n_actions, 0.01)

    def scale(self, obs: torch.Tensor) -> torch.Tensor:
        return 2.0 * (obs - self.low) / self.span - 1.0

    def value(self, obs: torch.Tensor) -> torch.Tensor:
        return self.critic(self.scale(obs)).squeeze(-1)

    def dist(self, obs: torch.Tensor, mask: torch.Tensor) -> Categorical:
        logits = self.actor(self.scale(obs))
        return Categorical(logits=torch.where(mask, logits, torch.full_like(logits, MASKED)))


# ----------------------------------------------------------------------------- helpers
def _stack(observations: dict[str, Any], agents: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Every agent's observations and masks as ``(num_envs * n_agents, ...)`` rows, drill
    by drill (row ``e * n_agents + k`` is agent ``k`` of drill ``e``)."""
    obs = np.stack([observations[a]["observation"] for a in agents], axis=1)
    mask = np.stack([observations[a]["action_mask"] for a in agents], axis=1)
    return obs.reshape(-1, obs.shape[-1]), mask.reshape(-1, mask.shape[-1]).astype(bool)


def _actions(rows: np.ndarray, agents: list[str], n_envs: int) -> dict[str, np.ndarray]:
    per = rows.reshape(n_envs, len(agents))
    return {a: per[:, k].astype(np.int64) for k, a in enumerate(agents)}


# ----------------------------------------------------------------------------- training
@dataclass
class _Rollout:
    """One rollout of every agent row, ``(n_steps, rows)`` each (``obs`` and ``mask`` with
    a last axis of features and actions); ``valid`` marks the decisions (not the steps
    that only reset a drill)."""

    obs: np.ndarray
    mask: np.ndarray
    act: np.ndarray
    logp: np.ndarray
    val: np.ndarray
    rew: np.ndarray
    done: np.ndarray
    valid: np.ndarray

    @classmethod
    def empty(cls, n_steps: int, rows: int, n_features: int, n_actions: int) -> _Rollout:
        def zeros(dtype: Any, *last: int) -> np.ndarray:
            return np.zeros((n_steps, rows, *last), dtype)
        return cls(zeros(np.float32, n_features), zeros(bool, n_actions), zeros(np.int64),
                   zeros(np.float32), zeros(np.float32), zeros(np.float32), zeros(np.float32),
                   zeros(bool))


class _Drills:
    """Where the drills are between rollouts: the agents' rows and masks, and which drills'
    next step only resets them."""

    def __init__(self, env: Any, agents: list[str], observations: dict[str, Any]) -> None:
        self.env, self.agents = env, agents
        self.obs, self.mask = _stack(observations, agents)
        self.resetting = np.zeros(env.num_envs, bool)

    def collect(self, agent: Agent, buf: _Rollout, reward_agent: str) -> list[float]:
        """Fill ``buf`` with one rollout; the ``reward_agent``'s rewards of the episodes
        that ended in it."""
        env, agents, n_agents, ended = self.env, self.agents, len(self.agents), []
        for t in range(len(buf.act)):
            with torch.no_grad():
                o, m = torch.as_tensor(self.obs), torch.as_tensor(self.mask)
                dist = agent.dist(o, m)
                action = dist.sample()
                buf.logp[t], buf.val[t] = dist.log_prob(action).numpy(), agent.value(o).numpy()
            buf.obs[t], buf.mask[t], buf.act[t] = self.obs, self.mask, action.numpy()
            buf.valid[t] = np.repeat(~self.resetting, n_agents)
            observations, rewards, term, trunc, _ = env.step(
                _actions(buf.act[t], agents, env.num_envs))
            done = term[agents[0]] | trunc[agents[0]]
            buf.rew[t] = np.stack([rewards[a] for a in agents], axis=1).reshape(-1)
            buf.done[t] = np.repeat(done, n_agents)
            ended += rewards[reward_agent][done].tolist()
            self.resetting = done
            self.obs, self.mask = _stack(observations, agents)
        return ended


def _advantages(buf: _Rollout, next_value: np.ndarray, cfg: PPOConfig
                ) -> tuple[np.ndarray, np.ndarray]:
    """GAE advantages and returns (an episode's last step is terminal)."""
    adv = np.zeros_like(buf.rew)
    last = np.zeros(buf.rew.shape[1], np.float32)
    n_steps = len(buf.rew)
    for t in reversed(range(n_steps)):
        following = next_value if t == n_steps - 1 else buf.val[t + 1]
        going_on = 1.0 - buf.done[t]
        delta = buf.rew[t] + cfg.gamma * following * going_on - buf.val[t]
        last = delta + cfg.gamma * cfg.gae_lambda * going_on * last
        adv[t] = last
    return adv, adv + buf.val


def _update(agent: Agent, optimizer: torch.optim.Optimizer, buf: _Rollout, adv: np.ndarray,
            ret: np.ndarray, cfg: PPOConfig, rng: np.random.Generator, n_minibatches: int
            ) -> None:
    """PPO's clipped update, on the decisions only."""
    keep = buf.valid.reshape(-1)

    def flat(a: np.ndarray) -> torch.Tensor:
        return torch.as_tensor(a.reshape(-1, *a.shape[2:])[keep])

    b_obs, b_mask, b_act, b_logp = flat(buf.obs), flat(buf.mask), flat(buf.act), flat(buf.logp)
    b_adv, b_ret = flat(adv), flat(ret)
    for _epoch in range(cfg.n_epochs):
        for idx in np.array_split(rng.permutation(len(b_act)), n_minibatches):
            if len(idx) < 2:
                continue
            i = torch.as_tensor(idx)
            dist = agent.dist(b_obs[i], b_mask[i])
            ratio = torch.exp(dist.log_prob(b_act[i]) - b_logp[i])
            a = b_adv[i]
            a = (a - a.mean()) / (a.std() + 1e-8)
            policy_loss = torch.max(-a * ratio, -a * torch.clamp(
                ratio, 1 - cfg.clip_range, 1 + cfg.clip_range)).mean()
            value_loss = 0.5 * ((agent.value(b_obs[i]) - b_ret[i]) ** 2).mean()
            loss = policy_loss - cfg.ent_coef * dist.entropy().mean() + cfg.vf_coef * value_loss
            optimizer.zero_grad()
            loss.backward()
            nn.utils.clip_grad_norm_(agent.parameters(), cfg.max_grad_norm)
            optimizer.step()


def train(env: Any, cfg: PPOConfig, seed: int, reward_agent: str = "attacker_0"
          ) -> tuple[Agent, list[list[float]]]:
    """Train one shared policy for every agent of ``env`` (a ``ParallelVectorEnv`` of
    ``cfg.n_envs`` drills) for ``cfg.steps`` environment steps.

    Returns the agent and its learning curve: one row per update, ``[steps, seconds,
    mean reward, success rate, episodes]`` over the episodes that ended in its rollout
    (``reward_agent``'s reward: the attackers'), ``None`` where none ended.
    """
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    agents = list(env.possible_agents)
    n_envs, n_agents = env.num_envs, len(agents)
    space = env.observation_space(agents[0])["observation"]
    n_actions = int(env.action_space(agents[0]).n)
    agent = Agent(space.low.astype(np.float64), space.high.astype(np.float64), n_actions,
                  cfg.net_arch)
    optimizer = torch.optim.Adam(agent.parameters(), lr=cfg.learning_rate, eps=1e-5)
    rows = n_envs * n_agents
    buf = _Rollout.empty(cfg.n_steps, rows, space.shape[0], n_actions)
    observations, _ = env.reset(seed=1_000_000 * (seed + 1))
    drills = _Drills(env, agents, observations)
    n_updates = -(-cfg.steps // (n_envs * cfg.n_steps))
    n_minibatches = max(1, rows * cfg.n_steps // cfg.batch_size)
    start, steps, curve = time.perf_counter(), 0, []
    for _ in range(n_updates):
        ended = drills.collect(agent, buf, reward_agent)
        steps += n_envs * cfg.n_steps
        with torch.no_grad():
            next_value = agent.value(torch.as_tensor(drills.obs)).numpy()
        adv, ret = _advantages(buf, next_value, cfg)
        _update(agent, optimizer, buf, adv, ret, cfg, rng, n_minibatches)
        r = np.asarray(ended)
        curve.append([float(steps), time.perf_counter() - start,
                      float(r.mean()) if r.size else None,
                      float((r > 0).mean()) if r.size else None, float(r.size)])
    return agent, curve


# ----------------------------------------------------------------------------- evaluation
def evaluate(agent: Agent, env: Any, first_seed: int, reward_agent: str = "attacker_0"
             ) -> list[float]:
    """The greedy policy's reward (``reward_agent``'s) in each drill of ``env``, one
    episode per drill, drill ``i`` seeded ``first_seed + i``."""
    agents = list(env.possible_agents)
    observations, _ = env.reset(seed=[first_seed + i for i in range(env.num_envs)])
    result = np.full(env.num_envs, np.nan)
    while np.isnan(result).any():
        obs, mask = _stack(observations, agents)
        with torch.no_grad():
            logits = agent.dist(torch.as_tensor(obs), torch.as_tensor(mask)).logits
        observations, rewards, term, trunc, _ = env.step(
            _actions(logits.argmax(-1).numpy(), agents, env.num_envs))
        done = (term[agents[0]] | trunc[agents[0]]) & np.isnan(result)
        result[done] = rewards[reward_agent][done]
    return result.tolist()
