"""MAPPO and IPPO on the batched parallel drill, in one file (CleanRL's style).

Read top to bottom: the networks, the value normalisation, the reward option, the
rollout, the advantages, the update, the training loop (against a scripted side, or in
self-play against a pool of past checkpoints), the evaluation.

Every learning side (the two attackers, or the two defenders) has one actor and one
critic, their parameters shared by the side's two players (each player's observation
says who it is: position, velocity, possession flags). The critic is the difference:

| ``critic`` | name | the critic sees |
|---|---|---|
| ``"state"`` | MAPPO (Yu et al. 2022) | the whole drill, ``state()`` (29 values: every body's position and velocity, who holds the ball, who may not take it back yet, the time elapsed) |
| ``"own"`` | IPPO (de Witt et al. 2020) | the player's own observation, as the actor |

The drill's conventions this follows (``soccer_drill.vector.ParallelVectorEnv``):

- ``observations[agent]`` is ``{"observation": (num_envs, d), "action_mask": (num_envs, n)}``;
  a masked action gets no probability (its logit is set to a large negative number),
  and with ``mask_input`` the mask is an input of the actor too (it says whether the
  player holds the ball).
- Autoreset is Gymnasium's ``NEXT_STEP``: the step after a drill's episode ends only
  resets it (actions ignored, reward 0). That step is not a decision: it is left out of
  the loss (``valid``), and the episode's last step is terminal (no bootstrap: a timeout
  is one of the drill's outcomes, paid -1).
- Inputs are scaled to [-1, 1] by their spaces' bounds, so no running statistics are
  needed for them; the critic's targets are normalised by running statistics
  (``value_norm``: MAPPO's value normalisation), since the returns' scale moves as
  the policy learns.

``steps`` counts environment steps: calls of ``step`` times drills, as SB3 counts a
``VecEnv``'s steps (however many agents act in a drill's step).
"""

from __future__ import annotations

import copy
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch import nn
from torch.distributions import Categorical

from ilpss.reference.settings import MarlSetting, PPOConfig, SelfPlaySetting

__all__ = ["train"]

MASKED = -1e8
"""The logit of a masked action."""
ATTACKERS = ("attacker_0", "attacker_1")
DEFENDERS = ("defender_0", "defender_1")
BALL_Y = 17
"""The ball's distance to the goal line in ``state()`` (its ``y``)."""
HOLDER_FLAGS = slice(20, 24)
"""Who holds the ball in ``state()``: a flag per player."""
Progress = Callable[[int, int], None]
"""``progress(steps done, steps of the budget)``, called after each update."""


# ----------------------------------------------------------------------------- networks
def _layer(n_in: int, n_out: int, gain: float = np.sqrt(2)) -> nn.Linear:
    layer = nn.Linear(n_in, n_out)
    nn.init.orthogonal_(layer.weight, gain)
    nn.init.constant_(layer.bias, 0.0)
    return layer


def _mlp(n_in: int, widths: Sequence[int], n_out: int, out_gain: float) -> nn.Sequential:
    layers: list[nn.Module] = []
    for width in widths:
        layers += [_layer(n_in, width), nn.Tanh()]
        n_in = width
    return nn.Sequential(*layers, _layer(n_in, n_out, out_gain))


class _Scaled(nn.Module):
    """An MLP on inputs scaled to [-1, 1] by their bounds."""

    def __init__(self, low: np.ndarray, high: np.ndarray, widths: Sequence[int], n_out: int,
                 out_gain: float, extra: int = 0) -> None:
        super().__init__()
        self.register_buffer("low", torch.as_tensor(low, dtype=torch.float32))
        self.register_buffer("span", torch.as_tensor(np.maximum(high - low, 1e-6),
                                                     dtype=torch.float32))
        self.net = _mlp(len(low) + extra, widths, n_out, out_gain)

    def scale(self, x: torch.Tensor) -> torch.Tensor:
        return 2.0 * (x - self.low) / self.span - 1.0


class Actor(_Scaled):
    """The policy: masked logits of the player's observation (and mask, if an input)."""

    def __init__(self, low: np.ndarray, high: np.ndarray, n_actions: int,
                 widths: Sequence[int], mask_input: bool) -> None:
        super().__init__(low, high, widths, n_actions, 0.01, n_actions if mask_input else 0)
        self.mask_input = mask_input

    def dist(self, obs: torch.Tensor, mask: torch.Tensor) -> Categorical:
        x = self.scale(obs)
        if self.mask_input:
            x = torch.cat((x, mask.float()), dim=-1)
        logits = self.net(x)
        return Categorical(logits=torch.where(mask, logits, torch.full_like(logits, MASKED)))


class Critic(_Scaled):
    """The value of the critic's input (``state()`` or the player's observation), in the
    normalised scale when the targets are normalised."""

    def __init__(self, low: np.ndarray, high: np.ndarray, widths: Sequence[int]) -> None:
        super().__init__(low, high, widths, 1, 1.0)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net(self.scale(x)).squeeze(-1)


class ValueNorm:
    """Running mean and variance of the critic's targets (MAPPO's value normalisation:
    exponential moving averages with a bias correction, ``beta`` per update)."""

    def __init__(self, active: bool, beta: float = 0.99) -> None:
        self.active, self.beta = active, beta
        self.mean = self.mean_sq = self.debias = 0.0

    def update(self, targets: np.ndarray) -> None:
        if not self.active:
            return
        b = self.beta
        self.mean = b * self.mean + (1 - b) * float(targets.mean())
        self.mean_sq = b * self.mean_sq + (1 - b) * float((targets ** 2).mean())
        self.debias = b * self.debias + (1 - b)

    def _stats(self) -> tuple[float, float]:
        if not self.active or self.debias == 0.0:
            return 0.0, 1.0
        mean, mean_sq = self.mean / self.debias, self.mean_sq / self.debias
        return mean, max(mean_sq - mean ** 2, 1e-4) ** 0.5

    def normalize(self, x: torch.Tensor) -> torch.Tensor:
        mean, std = self._stats()
        return (x - mean) / std

    def denormalize(self, x: np.ndarray) -> np.ndarray:
        mean, std = self._stats()
        return x * std + mean


class Side(nn.Module):
    """One learning side: its players, actor, critic and the critic's target scale."""

    def __init__(self, agents: Sequence[str], env: Any, setting: MarlSetting) -> None:
        super().__init__()
        self.agents = tuple(agents)
        space = env.observation_space(agents[0])["observation"]
        low, high = space.low.astype(np.float64), space.high.astype(np.float64)
        self.agent_id = setting.agent_id
        if self.agent_id:  # a one-hot of the player's index in its side ends each row
            low = np.concatenate((low, np.zeros(len(agents))))
            high = np.concatenate((high, np.ones(len(agents))))
        n_actions = int(env.action_space(agents[0]).n)
        widths = setting.ppo.net_arch
        self.actor = Actor(low, high, n_actions, widths, setting.mask_input)
        if setting.critic == "state":
            low, high = (b.astype(np.float64) for b in (env.state_space.low, env.state_space.high))
        self.critic = Critic(low, high, widths)
        self.critic_on_state = setting.critic == "state"
        self.value_norm = ValueNorm(setting.value_norm)

    def values(self, critic_in: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            v = self.critic(torch.as_tensor(critic_in)).numpy()
        return self.value_norm.denormalize(v)


# ----------------------------------------------------------------------------- helpers
def _rows(observations: dict[str, Any], side: Side, drills: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray]:
    """The observations and masks of ``side``'s players in ``drills`` as ``(len(drills) *
    len(agents), ...)`` rows, drill by drill (row ``k * len(agents) + j`` is agent ``j``
    of the ``k``-th drill); with ``agent_id`` each observation ends with a one-hot of
    ``j``."""
    agents = side.agents
    obs = np.stack([observations[a]["observation"][drills] for a in agents], axis=1)
    mask = np.stack([observations[a]["action_mask"][drills] for a in agents], axis=1)
    if side.agent_id:
        ids = np.broadcast_to(np.eye(len(agents), dtype=obs.dtype), (len(drills),) + (len(agents),) * 2)
        obs = np.concatenate((obs, ids), axis=-1)
    return obs.reshape(-1, obs.shape[-1]), mask.reshape(-1, mask.shape[-1]).astype(bool)


def _act(actor: Actor, obs: np.ndarray, mask: np.ndarray, greedy: bool,
         generator: torch.Generator | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Actions (greedy or sampled) and their log-probabilities."""
    with torch.no_grad():
        dist = actor.dist(torch.as_tensor(obs), torch.as_tensor(mask))
        if greedy:
            action = dist.logits.argmax(-1)
        elif generator is not None:
            action = torch.multinomial(dist.probs, 1, generator=generator).squeeze(-1)
        else:
            action = dist.sample()
        return action.numpy(), dist.log_prob(action).numpy()


def holders(state: np.ndarray) -> np.ndarray:
    """The player holding the ball in each drill of ``state()`` (-1: a loose ball)."""
    flags = state[:, HOLDER_FLAGS]
    return np.where(flags.max(axis=1) > 0.5, flags.argmax(axis=1), -1)


def potential(state: np.ndarray, shaping: float, field: float) -> np.ndarray:
    """The reward option's potential of each drill (attackers' side): ``-shaping`` times
    the ball's distance to the goal line in fields (0 at the line)."""
    return -shaping * state[:, BALL_Y] / field


# ----------------------------------------------------------------------------- rollout
class Decisions:
    """When the players of each drill decide (``decision_cycles`` k): at an episode's first
    cycle, every k cycles, and whenever the ball changes hands (a holder's actions are not
    an off-ball player's); in between each keeps its last action, as a holder's option
    of ``HolderEnv`` runs for several cycles. k = 1: every cycle, the drill's own pace."""

    def __init__(self, n: int, cycles: int) -> None:
        self.cycles = cycles
        self.since = np.zeros(n, np.int64)
        self.holder = np.full(n, -2, np.int64)  # -2: no decision yet

    def deciding(self, holder: np.ndarray, resetting: np.ndarray) -> np.ndarray:
        """Which drills decide now (``resetting``: their step only resets them, after
        which they decide)."""
        due = (self.since >= self.cycles) | (holder != self.holder) | resetting
        self.since = np.where(due, 1, self.since + 1)
        self.holder = np.where(resetting, -2, holder)
        return due



@dataclass
class _Rollout:
    """One rollout of a side's rows, ``(n_steps, rows, ...)`` each; ``valid`` marks the
    decisions (not the steps that only reset a drill)."""

    obs: np.ndarray
    mask: np.ndarray
    critic_in: np.ndarray
    act: np.ndarray
    logp: np.ndarray
    val: np.ndarray
    rew: np.ndarray
    done: np.ndarray
    valid: np.ndarray

    @classmethod
    def empty(cls, n_steps: int, rows: int, n_obs: int, n_actions: int, n_critic: int
              ) -> _Rollout:
        def zeros(dtype: Any, *last: int) -> np.ndarray:
            return np.zeros((n_steps, rows, *last), dtype)
        return cls(zeros(np.float32, n_obs), zeros(bool, n_actions), zeros(np.float32, n_critic),
                   zeros(np.int64), zeros(np.float32), zeros(np.float32), zeros(np.float32),
                   zeros(np.float32), zeros(bool))


@dataclass
class _Learner:
    """A side that learns in ``drills`` of the batch: its rollout and optimiser."""

    side: Side
    drills: np.ndarray
    optimizer: torch.optim.Optimizer
    buf: _Rollout
    sign: float  # +1: paid the attackers' reward; -1: the defenders'

    def critic_in(self, obs: np.ndarray, state: np.ndarray) -> np.ndarray:
        if not self.side.critic_on_state:
            return obs
        return np.repeat(state[self.drills], len(self.side.agents), axis=0)


class _Drills:
    """The batch between rollouts: observations, state, and which drills' next step
    only resets them; after ``collect``, each drill's episodes in it (``games``) and
    the attackers' successes among them (``wins``)."""

    def __init__(self, env: Any, seed: int, setting: MarlSetting) -> None:
        self.env, self.setting = env, setting
        self.observations, _ = env.reset(seed=seed)
        self.state = env.state()
        self.resetting = np.zeros(env.num_envs, bool)
        self.field = float(env.config.field_size)
        self.schedule = Decisions(env.num_envs, setting.decision_cycles)
        self.actions: dict[str, np.ndarray] = {}

    def collect(self, learners: list[_Learner], others: dict[str, Callable], n_steps: int
                ) -> list[float]:
        """Fill each learner's rollout (``others``: agent -> ``act(observations)`` giving
        that agent's actions in every drill, for the agents no learner plays there);
        the attackers' rewards of the episodes that ended."""
        env, ended, shaping = self.env, [], self.setting.shaping
        self.games, self.wins = np.zeros(env.num_envs), np.zeros(env.num_envs)
        for t in range(n_steps):
            deciding = self.schedule.deciding(holders(self.state), self.resetting)
            actions = self.actions
            for a, act in others.items():
                actions[a] = np.where(deciding, act(self.observations), actions.get(a, 0))
            for ln in learners:
                obs, mask = _rows(self.observations, ln.side, ln.drills)
                critic_in = ln.critic_in(obs, self.state)
                action, logp = _act(ln.side.actor, obs, mask, greedy=False)
                k = len(ln.side.agents)
                b = ln.buf
                b.obs[t], b.mask[t], b.critic_in[t] = obs, mask, critic_in
                b.act[t], b.logp[t], b.val[t] = action, logp, ln.side.values(critic_in)
                b.valid[t] = np.repeat(deciding[ln.drills] & ~self.resetting[ln.drills], k)
                per = action.reshape(len(ln.drills), k)
                for j, agent in enumerate(ln.side.agents):
                    held = actions.setdefault(agent, np.zeros(env.num_envs, np.int64))
                    held[ln.drills] = np.where(deciding[ln.drills], per[:, j], held[ln.drills])
                b.act[t] = np.stack([actions[a][ln.drills] for a in ln.side.agents], 1).reshape(-1)
            before = self.state
            self.observations, rewards, term, trunc, _ = env.step(actions)
            agent = env.agents[0]
            done = term[agent] | trunc[agent]
            reward = rewards[agent] if agent.startswith("attacker") else -rewards[agent]
            self.state = env.state()
            if shaping:
                # Potential-based (Ng et al. 1999), the end's potential 0: the total over
                # an episode is the drill's reward minus its start's potential, whatever
                # the policy, so the best policies are the drill's.
                after = np.where(done, 0.0, potential(self.state, shaping, self.field))
                shaped = reward + after - potential(before, shaping, self.field)
                shaped[self.resetting] = 0.0
            else:
                shaped = reward
            for ln in learners:
                k = len(ln.side.agents)
                ln.buf.rew[t] = np.repeat(ln.sign * shaped[ln.drills], k)
                ln.buf.done[t] = np.repeat(done[ln.drills], k)
            ended += reward[done].tolist()
            self.games += done
            self.wins += done & (reward > 0)
            self.resetting = done
        return ended


def _advantages(buf: _Rollout, next_value: np.ndarray, cfg: PPOConfig
                ) -> tuple[np.ndarray, np.ndarray]:
    """GAE advantages and returns of the decisions (``valid``), each paid the rewards of
    its cycles until the next decision (an episode's last step is terminal: no
    bootstrap). With a decision every cycle this is CleanRL's GAE."""
    adv = np.zeros_like(buf.rew)
    n_rows = buf.rew.shape[1]
    following, following_adv = next_value.astype(np.float32), np.zeros(n_rows, np.float32)
    paid, going_on = np.zeros(n_rows, np.float32), np.ones(n_rows, np.float32)
    for t in reversed(range(len(buf.rew))):
        ends = buf.done[t] > 0
        paid = np.where(ends, buf.rew[t], paid + buf.rew[t])
        going_on = np.where(ends, 0.0, going_on)
        here = buf.valid[t]
        delta = paid + cfg.gamma * following * going_on - buf.val[t]
        a = delta + cfg.gamma * cfg.gae_lambda * going_on * following_adv
        adv[t] = np.where(here, a, 0.0)
        following = np.where(here, buf.val[t], following)
        following_adv = np.where(here, a, following_adv)
        paid = np.where(here, 0.0, paid)
        going_on = np.where(here, 1.0, going_on)
    return adv, adv + buf.val


def _update(ln: _Learner, adv: np.ndarray, ret: np.ndarray, cfg: PPOConfig,
            rng: np.random.Generator, left: float) -> None:
    """PPO's clipped update on the decisions, the critic on normalised targets; ``left``
    (the share of the budget still to come, with ``anneal``) scales the step size and
    the entropy bonus."""
    for group in ln.optimizer.param_groups:
        group["lr"] = cfg.learning_rate * left
    side, buf = ln.side, ln.buf
    keep = buf.valid.reshape(-1)
    side.value_norm.update(ret.reshape(-1)[keep])

    def flat(a: np.ndarray) -> torch.Tensor:
        return torch.as_tensor(a.reshape(-1, *a.shape[2:])[keep])

    b_obs, b_mask, b_crit = flat(buf.obs), flat(buf.mask), flat(buf.critic_in)
    b_act, b_logp, b_adv = flat(buf.act), flat(buf.logp), flat(adv)
    b_ret = side.value_norm.normalize(flat(ret))
    n = len(b_act)
    n_minibatches = max(1, round(n / cfg.batch_size))
    for _epoch in range(cfg.n_epochs):
        for idx in np.array_split(rng.permutation(n), n_minibatches):
            if len(idx) < 2:
                continue
            i = torch.as_tensor(idx)
            dist = side.actor.dist(b_obs[i], b_mask[i])
            ratio = torch.exp(dist.log_prob(b_act[i]) - b_logp[i])
            a = b_adv[i]
            a = (a - a.mean()) / (a.std() + 1e-8)
            policy_loss = torch.max(-a * ratio, -a * torch.clamp(
                ratio, 1 - cfg.clip_range, 1 + cfg.clip_range)).mean()
            value_loss = 0.5 * ((side.critic(b_crit[i]) - b_ret[i]) ** 2).mean()
            entropy = cfg.ent_coef * left * dist.entropy().mean()
            loss = policy_loss - entropy + cfg.vf_coef * value_loss
            ln.optimizer.zero_grad()
            loss.backward()
            nn.utils.clip_grad_norm_(side.parameters(), cfg.max_grad_norm)
            ln.optimizer.step()


def _learner(side: Side, drills: np.ndarray, env: Any, cfg: PPOConfig, sign: float) -> _Learner:
    n_obs = side.actor.low.shape[0]
    n_actions = int(env.action_space(side.agents[0]).n)
    rows = len(drills) * len(side.agents)
    buf = _Rollout.empty(cfg.n_steps, rows, n_obs, n_actions, side.critic.low.shape[0])
    optimizer = torch.optim.Adam(side.parameters(), lr=cfg.learning_rate, eps=1e-5)
    return _Learner(side, drills, optimizer, buf, sign)


def _learn(ln: _Learner, drills: _Drills, cfg: PPOConfig, rng: np.random.Generator,
           left: float) -> None:
    obs, _ = _rows(drills.observations, ln.side, ln.drills)
    next_value = ln.side.values(ln.critic_in(obs, drills.state))
    adv, ret = _advantages(ln.buf, next_value, cfg)
    _update(ln, adv, ret, cfg, rng, left)


def _left(setting: MarlSetting, update: int, n_updates: int) -> float:
    """The share of the budget still to come before this update (1 without ``anneal``)."""
    return 1.0 - update / n_updates if setting.anneal else 1.0


def _curve_row(steps: int, start: float, ended: list[float]) -> list[float | None]:
    r = np.asarray(ended)
    return [float(steps), time.perf_counter() - start,
            float(r.mean()) if r.size else None,
            float((r > 0).mean()) if r.size else None, float(r.size)]


# ----------------------------------------------------------------------------- training
def train(env: Any, setting: MarlSetting, seed: int, progress: Progress | None = None
          ) -> tuple[Side, list[list[float | None]]]:
    """Train the side ``setting.side`` of ``env`` (a ``ParallelVectorEnv`` of
    ``setting.ppo.n_envs`` drills whose agents are that side) for ``setting.ppo.steps``
    environment steps.

    Returns the side and its learning curve: one row per update, ``[steps, seconds,
    mean reward, success rate, episodes]`` over the episodes that ended in its rollout
    (the attackers' reward, before the reward option), ``None`` where none ended.
    """
    cfg = setting.ppo
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    agents = ATTACKERS if setting.side == "attackers" else DEFENDERS
    side = Side(agents, env, setting)
    ln = _learner(side, np.arange(env.num_envs), env, cfg, 1.0 if agents is ATTACKERS else -1.0)
    drills = _Drills(env, 1_000_000 * (seed + 1), setting)
    n_updates = -(-cfg.steps // (env.num_envs * cfg.n_steps))
    start, steps, curve = time.perf_counter(), 0, []
    for update in range(n_updates):
        ended = drills.collect([ln], {}, cfg.n_steps)
        steps += env.num_envs * cfg.n_steps
        _learn(ln, drills, cfg, rng, _left(setting, update, n_updates))
        curve.append(_curve_row(steps, start, ended))
        if progress is not None:
            progress(steps, cfg.steps)
    return side, curve


def _frozen(side: Side) -> Side:
    frozen = copy.deepcopy(side)
    frozen.requires_grad_(False)
    return frozen


def train_self_play(env: Any, setting: SelfPlaySetting, seed: int,
                    progress: Progress | None = None
                    ) -> tuple[list[Side], list[Side], list[list[float | None]]]:
    """Self-play of the attackers' and the defenders' sides in ``env`` (a
    ``ParallelVectorEnv`` of all four players, per-role spaces), against a pool of
    their past checkpoints (fictitious self-play): the first half of the drills trains
    the attackers, the second half the defenders, and in each rollout the other side of
    each half is drawn from the pool and the current networks as ``setting.opponents``
    says (:func:`opponents_for`). With exploiters, the last ``setting.exploiter_drills()``
    drills of each half train that half's exploiter against the other side's current
    networks, and the exploiter is one more live opponent of the other side's half.
    ``setting.snapshots`` checkpoints are taken at even intervals, the untrained
    networks first and the trained ones last.

    Returns the attackers' and the defenders' checkpoints, and the learning curve (the
    attackers' success in every drill's episodes).
    """
    marl, cfg = setting.marl, setting.ppo
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    n = env.num_envs
    half = n // 2
    main = half - setting.exploiter_drills()  # each half's drills of its main side
    attack, defend = Side(ATTACKERS, env, marl), Side(DEFENDERS, env, marl)
    learners = [_learner(attack, np.arange(main), env, cfg, 1.0),
                _learner(defend, np.arange(half, half + main), env, cfg, -1.0)]
    live_a, live_d = [attack], [defend]  # each side's networks that are learning
    exploits: list[tuple[Side, np.ndarray]] = []  # the exploiters' opponents and drills
    if main < half:
        # main exploiters (Vinyals et al. 2019): each learns only against the other
        # side's current networks, in its half's last drills, and is an opponent the
        # other side's main networks may draw
        for live, sign, drills, other in ((live_a, 1.0, np.arange(main, half), defend),
                                          (live_d, -1.0, np.arange(half + main, n), attack)):
            exploiter = Side(live[0].agents, env, marl)
            learners.append(_learner(exploiter, drills, env, cfg, sign))
            live.append(exploiter)
            exploits.append((other, drills))
    pool_a, pool_d = [_frozen(attack)], [_frozen(defend)]
    # the attackers' half meets defenders, the defenders' half attackers
    halves = (opponents_for(setting, np.arange(main), pool_d, live_d, rng),
              opponents_for(setting, np.arange(half, half + main), pool_a, live_a, rng))
    drills = _Drills(env, 1_000_000 * (seed + 1), marl)
    n_updates = -(-cfg.steps // (n * cfg.n_steps))
    # checkpoint k (1 .. snapshots - 2) after update ceil(k n_updates / (snapshots - 1)):
    # evenly spaced, and exactly `snapshots` of them however short the budget
    due = [-(-k * n_updates // (setting.snapshots - 1)) for k in range(1, setting.snapshots - 1)]
    start, steps, curve = time.perf_counter(), 0, []
    for update in range(n_updates):
        plays_d, plays_a = halves[0].draw(), halves[1].draw()
        for other, exploited in exploits:
            (plays_d if other is defend else plays_a).append((other, exploited))
        ended = drills.collect(learners, {**_scripted(plays_d, n), **_scripted(plays_a, n)},
                               cfg.n_steps)
        for h in halves:
            h.record(drills.games, drills.wins)
        steps += n * cfg.n_steps
        for ln in learners:
            _learn(ln, drills, cfg, rng, _left(marl, update, n_updates))
        curve.append(_curve_row(steps, start, ended))
        while len(pool_a) - 1 < len(due) and update + 1 >= due[len(pool_a) - 1]:
            pool_a.append(_frozen(attack))
            pool_d.append(_frozen(defend))
        if progress is not None:
            progress(steps, cfg.steps)
    pool_a.append(_frozen(attack))
    pool_d.append(_frozen(defend))
    return pool_a, pool_d, curve


class Opponents:
    """Who plays the other side in one half of the self-play drills (``drills``): the
    checkpoints of ``pool`` (a list the training loop appends to) or the ``live``
    networks (the other side's current ones, then its exploiter's, if any), drawn at
    each rollout. :func:`opponents_for` makes the kind ``setting.opponents`` names
    (:data:`OPPONENTS`).
    """

    def __init__(self, setting: SelfPlaySetting, drills: np.ndarray, pool: list[Side],
                 live: list[Side], rng: np.random.Generator) -> None:
        self.setting, self.drills, self.pool, self.live, self.rng = (
            setting, drills, pool, live, rng)

    def draw(self) -> list[tuple[Side, np.ndarray]]:
        """This rollout's opponents: ``(side, drills)``, each side playing in those drills."""
        raise NotImplementedError

    def record(self, games: np.ndarray, wins: np.ndarray) -> None:
        """Count the rollout's episodes (``games``, ``wins``: per drill of the batch)."""


class UniformOpponents(Opponents):
    """``"uniform"``: one opponent for the half, a checkpoint drawn uniformly with
    probability 1/2, else live networks (the current ones, or with an exploiter either,
    evenly). It keeps no counts."""

    def draw(self) -> list[tuple[Side, np.ndarray]]:
        pool, live, rng = self.pool, self.live, self.rng
        if rng.random() < 0.5:
            side = pool[rng.integers(len(pool))]
        else:
            # no draw for a lone live side: the draws stay those of before exploiters
            side = live[rng.integers(len(live))] if len(live) > 1 else live[0]
        return [(side, self.drills)]


class PrioritisedOpponents(Opponents):
    """``"pfsp"``: one opponent per drill, candidate ``c`` drawn with probability
    proportional to ``q_c (1 - q_c) + pfsp_floor``, where ``q_c`` is the attackers'
    success in the episodes of that pairing, each rollout's earlier counts kept at
    ``pfsp_decay`` (every candidate starts at one success in two episodes, ``q = 1/2``).
    """

    def __init__(self, setting: SelfPlaySetting, drills: np.ndarray, pool: list[Side],
                 live: list[Side], rng: np.random.Generator) -> None:
        super().__init__(setting, drills, pool, live, rng)
        self.games: list[float] = []
        self.wins: list[float] = []
        self.drawn = np.zeros(len(drills), np.int64)

    def _candidates(self) -> list[Side]:
        while len(self.games) < len(self.pool) + len(self.live):
            # a new checkpoint, the pool's last, starts at q = 1/2
            self.games.insert(len(self.pool) - 1, 2.0)
            self.wins.insert(len(self.pool) - 1, 1.0)
        return [*self.pool, *self.live]

    def weights(self) -> np.ndarray:
        """Each candidate's probability (the pool's, then the live networks')."""
        self._candidates()
        q = np.asarray(self.wins) / np.asarray(self.games)
        w = q * (1.0 - q) + self.setting.pfsp_floor
        return w / w.sum()

    def draw(self) -> list[tuple[Side, np.ndarray]]:
        candidates = self._candidates()
        self.drawn = self.rng.choice(len(candidates), size=len(self.drills), p=self.weights())
        return [(c, self.drills[self.drawn == k]) for k, c in enumerate(candidates)
                if (self.drawn == k).any()]

    def record(self, games: np.ndarray, wins: np.ndarray) -> None:
        keep = self.setting.pfsp_decay
        for k in range(len(self.games)):
            mine = self.drills[self.drawn == k]
            self.games[k] = keep * self.games[k] + games[mine].sum()
            self.wins[k] = keep * self.wins[k] + wins[mine].sum()


OPPONENTS: dict[str, type[Opponents]] = {
    "uniform": UniformOpponents, "pfsp": PrioritisedOpponents}
"""Each ``SelfPlaySetting.opponents`` name's kind of :class:`Opponents`."""


def opponents_for(setting: SelfPlaySetting, drills: np.ndarray, pool: list[Side],
                  live: list[Side], rng: np.random.Generator) -> Opponents:
    """The opponents of a half of the drills, of the kind ``setting.opponents`` names."""
    return OPPONENTS[setting.opponents](setting, drills, pool, live, rng)


def _scripted(plays: Sequence[tuple[Side, np.ndarray]], n: int) -> dict[str, Callable]:
    """Fixed players (actions sampled, not learnt from): each ``(side, drills)`` of
    ``plays`` plays its players in those drills; agent -> ``act(observations)``, that
    agent's actions in every drill (0 where no side plays)."""
    agents = plays[0][0].agents
    out: dict[str, Callable] = {}
    for j, agent in enumerate(agents):
        def act(observations: dict[str, Any], j: int = j) -> np.ndarray:
            full = np.zeros(n, np.int64)
            for side, drills in plays:
                obs, mask = _rows(observations, side, drills)
                action, _ = _act(side.actor, obs, mask, greedy=False)
                full[drills] = action.reshape(len(drills), len(side.agents))[:, j]
            return full
        out[agent] = act
    return out


# ----------------------------------------------------------------------------- evaluation
def evaluate(sides: Sequence[Side], env: Any, first_seed: int, greedy: bool = True,
             sample_seed: int = 0, decision_cycles: int = 1) -> list[float]:
    """The attackers' reward in each drill of ``env``, one episode per drill, drill ``i``
    seeded ``first_seed + i``, ``sides`` playing their players (``env``'s other players
    are scripted) at the pace they learnt (``decision_cycles``); greedy, or sampled
    from a generator seeded ``sample_seed``."""
    generator = torch.Generator().manual_seed(sample_seed)
    observations, _ = env.reset(seed=[first_seed + i for i in range(env.num_envs)])
    every = np.arange(env.num_envs)
    result = np.full(env.num_envs, np.nan)
    schedule = Decisions(env.num_envs, decision_cycles)
    actions: dict[str, np.ndarray] = {}
    while np.isnan(result).any():
        deciding = schedule.deciding(holders(env.state()), np.zeros(env.num_envs, bool))
        for side in sides:
            obs, mask = _rows(observations, side, every)
            action, _ = _act(side.actor, obs, mask, greedy, generator)
            per = action.reshape(env.num_envs, len(side.agents))
            for j, a in enumerate(side.agents):
                actions[a] = np.where(deciding, per[:, j], actions.get(a, per[:, j]))
        observations, rewards, term, trunc, _ = env.step(actions)
        agent = env.agents[0]
        reward = rewards[agent] if agent.startswith("attacker") else -rewards[agent]
        done = (term[agent] | trunc[agent]) & np.isnan(result)
        result[done] = reward[done]
    return result.tolist()
