"""Soak test: thousands of episodes of the three environments, invariants checked every step.

    python benchmarks/soak.py [--episodes 10000] [--seed 0] [--out docs/reliability.md]

Runs ``--episodes`` episodes mixing the PettingZoo AEC environment, the parallel
environment and the Gymnasium holder environment. Every ``--block`` episodes a new
environment is built: the kind cycles AEC, parallel, holder; the opponent cycles through
every registered team (``parametric`` with sampled parameters; the AEC and parallel
environments also run with no scripted team, four agents); half the blocks use a random
valid :class:`~soccer_drill.config.DrillConfig`, some the kinematic observation or
``illegal_action="default"``. Every episode has its own seed. Agents take uniformly
random legal actions (from the masks); about 1% of the turns first try a hostile action
(masked, out of range, wrong type) that must be refused without changing the episode,
and about 2% of the episodes are reset in the middle.

Checked at every step (any failure is a *violation*, counted and described):

* observations are inside their spaces (``space.contains``) and finite;
* the ``rewards``/``terminations``/``truncations``/``infos`` dictionaries have exactly
  the live agents (AEC), or each step's returns have exactly the agents that acted
  (parallel); the AEC agents are told once each that the episode ended, are stepped
  with ``None`` and removed, so ``agents`` ends empty; stepping after the end raises;
* rewards are zero until the end; each episode ends with exactly one outcome
  (``success``, ``interception``, ``out`` or ``timeout``) seen identically by every
  agent; ``truncated`` exactly for a timeout; the attackers' reward is the one the
  configuration gives that outcome and the defenders' its negation;
* the cycle count never exceeds ``max_cycles`` and a timeout happens exactly there;
  the holder's ``info["duration"]`` is >= 1 and adds up to ``info["cycles"]``.

Speed and memory: the first ``--warmup`` episodes run untraced (first environments,
caches) and give the episodes per second; then :mod:`tracemalloc` starts and the rest
run traced (about ten times slower, which is why the speed comes from the warm-up).
After a garbage collection at both ends, the report gives the Python heap still held
at the end that was allocated after the warm-up (per 1,000 episodes), the allocation
sites that grew most, and the process's resident set size (peak from :mod:`resource`,
current from ``/proc`` where available) after the warm-up and at the end.

The exit status is 1 if any invariant was violated. ``--out FILE`` writes the report
between ``<!-- soak:start -->`` and ``<!-- soak:end -->`` in ``FILE`` (appended if the
markers are missing), leaving the rest of the file alone.
"""

from __future__ import annotations

import argparse
import gc
import math
import os
import random
import sys
import time
import traceback
import tracemalloc
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

import soccer_drill

try:
    import resource
except ImportError:  # Windows
    resource = None  # type: ignore[assignment]
from soccer_drill.config import SPEEDS, DrillConfig, fewest_substeps
from soccer_drill.files import atomic_write_text, check_output_file
from soccer_drill.teams import team_ids

OUTCOMES = ("success", "interception", "out", "timeout")
KINDS = ("aec", "parallel", "holder")
MARK_START, MARK_END = "<!-- soak:start -->", "<!-- soak:end -->"
DEFAULT_OUT = Path(__file__).resolve().parent.parent / "docs" / "reliability.md"


class Violation(Exception):
    """An invariant failed."""


def check(condition: bool, message: str, *args: object) -> None:
    """Raise :class:`Violation` with ``message.format(*args)`` unless ``condition`` holds.

    The message is only formatted on failure: formatting an observation array at every
    step would cost more than the step itself.
    """
    if not condition:
        raise Violation(message.format(*args))


# ------------------------------------------------------------------ random settings
def random_config(rng: random.Random) -> dict[str, Any]:
    """A valid :class:`DrillConfig` dict with some fields drawn at random (or empty)."""
    if rng.random() < 0.5:
        return {}
    draws = {
        "max_cycles": lambda: rng.randint(1, 150),
        "substeps": lambda: rng.randint(1, 12),
        "tackle_probability": lambda: rng.uniform(0.0, 1.0),
        "ball_damping": lambda: rng.uniform(0.05, 1.0),
        "kick_angle_noise": lambda: rng.uniform(0.0, 30.0),
        "kick_speed_noise": lambda: rng.uniform(0.0, 0.3),
        "defender_speed": lambda: rng.uniform(1.0, 9.0),
        "attacker_speed": lambda: rng.uniform(1.0, 9.0),
        "control_speed": lambda: rng.uniform(0.5, 20.0),
        "start_jitter": lambda: rng.uniform(0.0, 3.0),
        "pass_lockout_cycles": lambda: rng.randint(0, 8),
    }
    names = rng.sample(sorted(draws), rng.randint(1, len(draws)))
    return enough_substeps({name: draws[name]() for name in names})


def enough_substeps(config: dict[str, Any]) -> dict[str, Any]:
    """``config`` with ``substeps`` raised, if need be, to the fewest that keep its fastest
    player from passing through a wall (what ``DrillConfig`` requires)."""
    full = {**DrillConfig().to_dict(), **config}
    fewest = fewest_substeps(max(full[name] for name in SPEEDS), full["cycle_seconds"],
                             full["player_radius"])
    return config if full["substeps"] >= fewest else {**config, "substeps": fewest}


def team_schedule() -> list[tuple[str | None, dict[str, Any] | None]]:
    """Every registered team once (``parametric`` with sampled parameters), then no team."""
    schedule: list[tuple[str | None, dict[str, Any] | None]] = []
    for team in team_ids():
        if team == "parametric":
            from opponents.parametric import sample_opponents

            schedule += [("parametric", params) for params in sample_opponents(3, seed=0)]
        else:
            schedule.append((team, None))
    schedule.append((None, None))  # four agents (AEC and parallel only)
    return schedule


class LegalActions:
    """Uniformly random legal actions from a mask, cheaply (legal lists cached by mask)."""

    def __init__(self, rng: random.Random) -> None:
        self.rng = rng
        self._legal: dict[bytes, list[int]] = {}

    def __call__(self, mask: np.ndarray) -> int:
        """A random legal action of ``mask``."""
        key = mask.tobytes()
        legal = self._legal.get(key)
        if legal is None:
            legal = self._legal[key] = np.flatnonzero(mask).tolist()
        check(len(legal) > 0, "no legal action in mask {}", mask.tolist())
        return legal[self.rng.randrange(len(legal))]

    def hostile(self, mask: np.ndarray, strict: bool = True) -> object:
        """An action that must be refused: out of range, of a wrong type, or (``strict``,
        i.e. ``illegal_action="raise"``) masked."""
        masked = np.flatnonzero(mask == 0).tolist()
        choices: list[object] = [len(mask), -1, 1.5, "0", None, [0]]
        if masked and strict:
            choices.append(masked[self.rng.randrange(len(masked))])
        return choices[self.rng.randrange(len(choices))]


# -------------------------------------------------------------------- invariants
def expected_attacker_reward(cfg: DrillConfig, outcome: str, reward: float) -> None:
    """Check the attackers' final ``reward`` against ``outcome``."""
    if outcome == "success":
        low, high = sorted((cfg.reward_success_edge, cfg.reward_success_centre))
        check(low - 1e-9 <= reward <= high + 1e-9, "success paid {}, not in [{}, {}]",
              reward, low, high)
    elif outcome == "timeout":
        check(reward == cfg.reward_timeout, "timeout paid {}, not {}", reward, cfg.reward_timeout)
    else:
        check(reward == cfg.reward_failure, "{} paid {}, not {}",
              outcome, reward, cfg.reward_failure)


def check_end(cfg: DrillConfig, outcome: object, cycles: object, term: bool, trunc: bool) -> None:
    """One outcome, the right end flag, a cycle count within ``max_cycles``."""
    check(outcome in OUTCOMES, "outcome {!r} is not one of {}", outcome, OUTCOMES)
    check(term != trunc, "terminated={} and truncated={} at the end", term, trunc)
    check(trunc == (outcome == "timeout"), "truncated={} with outcome {!r}", trunc, outcome)
    check(isinstance(cycles, int) and 1 <= cycles <= cfg.max_cycles,
          "episode ended after {!r} cycles (max_cycles={})", cycles, cfg.max_cycles)
    if outcome == "timeout":
        check(cycles == cfg.max_cycles, "timeout after {} cycles, not {}", cycles, cfg.max_cycles)


def check_obs(space: Any, obs: Any, who: str) -> None:
    """``obs`` lies in ``space`` and its features are finite."""
    features = obs["observation"] if isinstance(obs, dict) else obs
    check(bool(np.isfinite(features).all()), "non-finite observation for {}: {}", who, features)
    check(space.contains(obs), "observation of {} outside its space: {}", who, obs)


def is_attacker(agent: str) -> bool:
    """``attacker_0`` and ``attacker_1``."""
    return agent.startswith("attacker")


@dataclass
class Tally:
    """What the soak counted."""

    episodes: Counter = field(default_factory=Counter)
    outcomes: Counter = field(default_factory=Counter)
    cycles: int = 0
    steps: int = 0
    resets_mid_episode: int = 0
    hostile_refused: int = 0
    violations: int = 0
    examples: list[str] = field(default_factory=list)
    environments: int = 0


# ------------------------------------------------------------------ one episode each
def aec_episode(env: Any, cfg: DrillConfig, seed: int, pick: LegalActions, tally: Tally,
                reset_at: int | None, strict: bool) -> None:
    """One AEC episode with random legal actions and every check."""
    env.reset(seed=seed)
    check(env.agents == env.possible_agents, "agents after reset: {}", env.agents)
    told: set[str] = set()
    outcome, attacker_reward, turns = None, None, 0
    # Enough turns for a reset mid-episode then a whole episode; fewer means it never ended.
    for agent in env.agent_iter(max_iter=2 * 4 * (cfg.max_cycles + 1) + 100):
        check(agent in env.agents, "agent_iter gave {!r}, not a live agent {}", agent, env.agents)
        for name, table in (("rewards", env.rewards), ("terminations", env.terminations),
                            ("truncations", env.truncations), ("infos", env.infos)):
            check(set(table) == set(env.agents), "{} keys {} != {}",
                  name, sorted(table), env.agents)
        obs, reward, term, trunc, info = env.last()
        check_obs(env.observation_space(agent), obs, agent)
        if term or trunc:
            check(agent not in told, "{} told twice that the episode ended", agent)
            told.add(agent)
            check(env.outcome is not None, "an agent is done but the drill has no outcome")
            check_end(cfg, info.get("outcome"), info.get("cycles"), term, trunc)
            check(outcome in (None, info["outcome"]), "two outcomes: {}, {}",
                  outcome, info["outcome"])
            outcome = info["outcome"]
            if is_attacker(agent):
                expected_attacker_reward(cfg, outcome, reward)
                check(attacker_reward in (None, reward), "attackers paid differently")
                attacker_reward = reward
            else:
                paid = -reward
                expected_attacker_reward(cfg, outcome, paid)
                check(attacker_reward in (None, paid), "defenders not paid the attackers' negation")
                attacker_reward = paid
            env.step(None)
            continue
        check(reward == 0.0 and env.outcome is None, "{} paid {} before the end", agent, reward)
        turns += 1
        if reset_at is not None and turns == reset_at:
            tally.resets_mid_episode += 1
            env.reset(seed=seed + 1)
            check(env.agents == env.possible_agents, "agents after a mid-episode reset")
            continue
        if pick.rng.random() < 0.01:
            bad = pick.hostile(obs["action_mask"], strict)
            try:
                env.step(bad)
            except (ValueError, TypeError):
                tally.hostile_refused += 1
            else:
                raise Violation(f"hostile action {bad!r} for {agent} was accepted")
            check(env.agent_selection == agent, "a refused action moved the turn on")
        env.step(pick(obs["action_mask"]))
        tally.steps += 1
    check(env.agents == [], "agents left at the end: {}", env.agents)
    check(told == set(env.possible_agents), "told of the end: {}", sorted(told))
    check(outcome == env.outcome, "outcome {} but the drill says {}", outcome, env.outcome)
    try:
        env.step(0)
    except RuntimeError:
        pass
    else:
        raise Violation("step() after the end was accepted")
    tally.outcomes[outcome] += 1
    tally.cycles += env.drill_state.cycle


def parallel_episode(env: Any, cfg: DrillConfig, seed: int, pick: LegalActions, tally: Tally,
                     reset_at: int | None, strict: bool) -> None:
    """One parallel episode with random legal actions and every check."""
    obs, infos = env.reset(seed=seed)
    check(env.agents == env.possible_agents, "agents after reset: {}", env.agents)
    check(set(obs) == set(infos) == set(env.agents), "reset returns keyed by the live agents")
    steps = 0
    while env.agents:
        live = list(env.agents)
        for agent in live:
            check_obs(env.observation_space(agent), obs[agent], agent)
        actions = {a: pick(obs[a]["action_mask"]) for a in live}
        if pick.rng.random() < 0.01:
            victim = live[pick.rng.randrange(len(live))]
            bad = {**actions, victim: pick.hostile(obs[victim]["action_mask"], strict)}
            if pick.rng.random() < 0.3:
                bad = {a: actions[a] for a in live[1:]}  # a missing agent
            try:
                env.step(bad)
            except (ValueError, TypeError):
                tally.hostile_refused += 1
            else:
                raise Violation(f"hostile actions {bad!r} were accepted")
        obs, rewards, terms, truncs, infos = env.step(actions)
        steps += 1
        tally.steps += 1
        for name, table in (("observations", obs), ("rewards", rewards), ("terminations", terms),
                            ("truncations", truncs), ("infos", infos)):
            check(set(table) == set(live), "{} keys {} != {}", name, sorted(table), live)
        if env.outcome is None:
            check(env.agents == live, "agents changed during the episode")
            check(all(r == 0.0 for r in rewards.values()), "rewards before the end: {}", rewards)
            check(not any(terms.values()) and not any(truncs.values()), "done flags before the end")
            if reset_at is not None and steps == reset_at:
                tally.resets_mid_episode += 1
                obs, infos = env.reset(seed=seed + 1)
                check(env.agents == env.possible_agents, "agents after a mid-episode reset")
            continue
        check(env.agents == [], "agents left after the last step: {}", env.agents)
        outcomes = {i.get("outcome") for i in infos.values()}
        check(len(outcomes) == 1, "agents saw different outcomes: {}", outcomes)
        outcome = outcomes.pop()
        check(outcome == env.outcome, "infos say {}, the drill {}", outcome, env.outcome)
        for agent in live:
            check_obs(env.observation_space(agent), obs[agent], agent)
            check_end(cfg, infos[agent].get("outcome"), infos[agent].get("cycles"),
                      terms[agent], truncs[agent])
            paid = rewards[agent] if is_attacker(agent) else -rewards[agent]
            expected_attacker_reward(cfg, outcome, paid)
        check(len({rewards[a] if is_attacker(a) else -rewards[a] for a in live}) == 1,
              "rewards not zero-sum and equal per side: {}", rewards)
        tally.outcomes[outcome] += 1
        tally.cycles += env.drill_state.cycle
    try:
        env.step({})
    except RuntimeError:
        pass
    else:
        raise Violation("step() after the end was accepted")


def holder_episode(env: Any, cfg: DrillConfig, seed: int, pick: LegalActions, tally: Tally,
                   reset_at: int | None, strict: bool) -> None:
    """One holder episode with random actions and every check."""
    obs, info = env.reset(seed=seed)
    check_obs(env.observation_space, obs, "the holder")
    check(info["duration"] == 0 and info["cycles"] == 0 and info["outcome"] is None,
          "reset info {}", info)
    mask = np.ones(env.action_space.n, dtype=np.int8)
    total, steps = 0, 0
    while True:
        check(info["holder"] in ("attacker_0", "attacker_1"), "holder {!r}", info["holder"])
        if pick.rng.random() < 0.01:
            bad = pick.hostile(mask)
            try:
                env.step(bad)
            except (ValueError, TypeError):
                tally.hostile_refused += 1
            else:
                raise Violation(f"hostile holder action {bad!r} was accepted")
        obs, reward, term, trunc, info = env.step(pick(mask))
        steps += 1
        tally.steps += 1
        check_obs(env.observation_space, obs, "the holder")
        check(isinstance(info["duration"], int) and info["duration"] >= 1,
              "duration {!r}", info["duration"])
        total += info["duration"]
        check(info["cycles"] == total, "cycles {} != summed durations {}", info["cycles"], total)
        check(total <= cfg.max_cycles, "{} cycles > max_cycles {}", total, cfg.max_cycles)
        if term or trunc:
            check_end(cfg, info["outcome"], info["cycles"], term, trunc)
            check(info["holder"] is None, "a holder named after the end")
            expected_attacker_reward(cfg, info["outcome"], reward)
            break
        check(reward == 0.0 and info["outcome"] is None, "reward {} before the end", reward)
        if reset_at is not None and steps == reset_at:
            tally.resets_mid_episode += 1
            obs, info = env.reset(seed=seed + 1)
            total = 0
    try:
        env.step(0)
    except RuntimeError:
        pass
    else:
        raise Violation("step() after the end was accepted")
    tally.outcomes[info["outcome"]] += 1
    tally.cycles += info["cycles"]


EPISODES: dict[str, Callable[..., None]] = {
    "aec": aec_episode, "parallel": parallel_episode, "holder": holder_episode,
}


def make_env(kind: str, team: str | None, params: dict | None, config: dict,
             rng: random.Random) -> tuple[Any, bool]:
    """A fresh environment of ``kind`` (``holder`` never gets ``team=None``), and whether
    it refuses masked actions (``illegal_action="raise"``)."""
    if kind == "holder":
        env = soccer_drill.HolderEnv(opponent=team or "chasers", opponent_params=params,
                                     config=config, decision_cycles=rng.choice((1, 2, 4, 8)))
        return env, True
    illegal = "default" if rng.random() < 0.2 else "raise"
    kwargs = {
        "opponent": team, "opponent_params": params, "config": config,
        "obs_type": "kinematic" if rng.random() < 0.25 else "features",
        "illegal_action": illegal,
    }
    make = soccer_drill.env if kind == "aec" else soccer_drill.parallel_env
    return make(**kwargs), illegal == "raise"


# ----------------------------------------------------------------------- the run
class Soak:
    """Runs episodes block by block; one environment per block."""

    def __init__(self, seed: int, block: int) -> None:
        self.rng = random.Random(seed)
        self.pick = LegalActions(random.Random(seed + 1))
        self.block = block
        self.schedule = team_schedule()
        self.tally = Tally()
        self.done = 0
        self._env: Any = None
        self._env_left = 0
        self._block_index = 0
        self._setting: tuple = ()

    def _next_env(self) -> None:
        kind = KINDS[self._block_index % len(KINDS)]
        team, params = self.schedule[(self._block_index // len(KINDS)) % len(self.schedule)]
        config = random_config(self.rng)
        self._block_index += 1
        if self._env is not None:
            self._env.close()
        self._env, strict = make_env(kind, team, params, config, self.rng)
        self._setting = (kind, team if kind != "holder" else team or "chasers", config, strict)
        self._env_left = self.block
        self.tally.environments += 1

    def run(self, episodes: int) -> None:
        """Run ``episodes`` more episodes."""
        for _ in range(episodes):
            if self._env_left == 0:
                self._next_env()
            kind, team, config, strict = self._setting
            env, seed = self._env, self.rng.randrange(2**31)
            reset_at = self.rng.randint(1, 40) if self.rng.random() < 0.02 else None
            try:
                EPISODES[kind](env, env.config, seed, self.pick, self.tally, reset_at, strict)
            except Exception as exc:  # a violation, or any crash: record it and go on
                self.tally.violations += 1
                if len(self.tally.examples) < 20:
                    where = traceback.extract_tb(exc.__traceback__)[-1]
                    self.tally.examples.append(
                        f"episode {self.done} ({kind}, team={team}, seed={seed}, "
                        f"config={config}): {type(exc).__name__}: {exc} "
                        f"[{Path(where.filename).name}:{where.lineno}]"
                    )
                self._env_left = 1  # rebuild: the environment may be in any state
            self.tally.episodes[kind] += 1
            self.done += 1
            self._env_left -= 1


def rss_bytes() -> tuple[int | None, int | None]:
    """(peak RSS from ``resource``, current RSS from ``/proc/self/statm``); ``None``: unknown."""
    peak = None
    if resource is not None:
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        peak *= 1 if sys.platform == "darwin" else 1024  # macOS reports bytes, Linux KiB
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[1])
        return peak, pages * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return peak, None


def _mib(n: float | None) -> str:
    return "n/a" if n is None else f"{n / 2**20:.1f} MiB"


def _kib(n: float) -> str:
    return f"{n / 1024:+.1f} KiB"


def grown_sites(before: tracemalloc.Snapshot, after: tracemalloc.Snapshot, top: int) -> list[str]:
    """Markdown rows for the ``top`` allocation sites that grew most between snapshots."""
    ignore = (
        tracemalloc.Filter(False, tracemalloc.__file__),
        tracemalloc.Filter(False, "<frozen importlib._bootstrap*>"),
        tracemalloc.Filter(False, "<unknown>"),
    )
    stats = after.filter_traces(ignore).compare_to(before.filter_traces(ignore), "lineno")
    rows: list[str] = []
    for stat in [s for s in stats if s.size_diff > 0][:top]:
        frame = stat.traceback[0]
        path = Path(frame.filename)
        parts = path.parts
        short = "/".join(parts[parts.index("site-packages") + 1:]) if "site-packages" in parts \
            else "/".join(parts[-2:])
        rows.append(f"| `{short}:{frame.lineno}` | {_kib(stat.size_diff)} | {stat.count_diff:+d} |")
    return rows


def report(args: argparse.Namespace, soak: Soak, timing: dict[str, Any],
           memory: dict[str, Any]) -> str:
    """The markdown section."""
    t = soak.tally
    measured = soak.done - args.warmup
    per_k = 1000 / measured if measured else math.nan
    lines = [
        MARK_START,
        "## Soak test",
        "",
        f"Command: `{memory['command']}`",
        "",
        f"Python {sys.version.split()[0]}, {os.cpu_count()} cores; {soak.done:,} episodes "
        f"({', '.join(f'{k} {t.episodes[k]:,}' for k in KINDS)}) on {t.environments:,} "
        f"environments, {t.steps:,} agent steps, {t.cycles:,} drill cycles; "
        f"{t.resets_mid_episode:,} resets mid-episode; {t.hostile_refused:,} hostile actions "
        f"refused.{_load_text(timing)}",
        "",
        "| measure | value |",
        "|---|---|",
        f"| **invariant violations** | **{t.violations}** |",
        f"| episodes/s, warm-up ({args.warmup:,} episodes, untraced) | "
        f"{timing['warmup_rate']:,.1f} |",
        f"| episodes/s, measured phase ({measured:,} episodes, under tracemalloc) | "
        f"{timing['measured_rate']:,.1f} |",
        f"| wall time | {timing['total']:,.0f} s |",
        f"| Python heap held at the end, allocated after the warm-up | "
        f"{_kib(memory['traced_growth'])} ({_kib(memory['traced_growth'] * per_k)} "
        f"per 1,000 episodes) |",
        f"| peak traced Python heap during the measured phase | {_mib(memory['traced_peak'])} |",
        f"| current RSS after warm-up -> end | {_mib(memory['rss_start'][1])} -> "
        f"{_mib(memory['rss_end'][1])} |",
        f"| peak RSS (`resource`) after warm-up -> end | {_mib(memory['rss_start'][0])} -> "
        f"{_mib(memory['rss_end'][0])} |",
        "",
        "Outcomes: " + ", ".join(f"{o} {t.outcomes[o]:,}" for o in OUTCOMES) + ".",
        "",
    ]
    if memory["rss_start"][1] is not None and measured:
        growth = memory["rss_end"][1] - memory["rss_start"][1]
        lines += [f"Current RSS grew {_mib(growth)} over the measured phase, "
                  f"{_mib(growth * per_k)} per 1,000 episodes (it includes tracemalloc's "
                  "own bookkeeping, in the table below).", ""]
    lines += ["Through the measured phase (after a garbage collection each time):", "",
              "| episodes | Python heap held since the warm-up | tracemalloc's own memory "
              "| current RSS |", "|---:|---:|---:|---:|"]
    lines += [f"| {done:,} | {_kib(heap)} | {_mib(own)} | {_mib(rss)} |"
              for done, heap, own, rss in memory["series"]]
    lines += [""]
    lines += [f"Allocation sites whose live Python memory grew most between the snapshot "
              f"after the warm-up and the one at the end (top {args.top}):", "",
              "| site | size diff | blocks diff |", "|---|---:|---:|"]
    lines += memory["sites"] or ["| (none grew) | | |"]
    if t.examples:
        lines += ["", "First violations:", ""] + [f"- {e}" for e in t.examples]
    lines += [MARK_END]
    return "\n".join(lines) + "\n"


def _load_text(timing: dict[str, Any]) -> str:
    """The machine's load while the soak ran: its rates depend on it."""
    if timing.get("load") is None:
        return ""
    start, end = timing["load"]
    return (f" Load average (1 min) {start:.1f} at the start, {end:.1f} at the end, on "
            f"{os.cpu_count()} cores.")


def write_section(path: Path, section: str) -> None:
    """Put ``section`` between the soak markers of ``path`` (appended if it has none),
    atomically: a failed write leaves the page as it was."""
    text = path.read_text() if path.exists() else "# Reliability\n\n"
    if MARK_START in text and MARK_END in text:
        head, rest = text.split(MARK_START, 1)
        tail = rest.split(MARK_END, 1)[1]
        text = head + section.rstrip("\n") + tail
    else:
        text = text.rstrip("\n") + "\n\n" + section
    atomic_write_text(path, text)


def parse(argv: Sequence[str] | None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--episodes", type=int, default=10_000, help="episodes in all")
    p.add_argument("--warmup", type=int, default=None,
                   help="untraced episodes first (default: 10%% of --episodes, at most 1,000)")
    p.add_argument("--block", type=int, default=10, help="episodes per environment")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--top", type=int, default=10, help="allocation sites listed")
    p.add_argument("--frames", type=int, default=1, help="tracemalloc frames per allocation")
    p.add_argument("--out", type=Path, default=None,
                   help=f"markdown file to write the section into (e.g. {DEFAULT_OUT.name})")
    args = p.parse_args(argv)
    if args.episodes < 1 or args.block < 1 or args.top < 0 or args.frames < 1:
        p.error("--episodes, --block and --frames must be >= 1, --top >= 0")
    if args.warmup is None:
        args.warmup = min(1000, args.episodes // 10)
    if not 0 <= args.warmup < args.episodes:
        p.error("--warmup must lie in [0, --episodes)")
    if args.out is not None:
        try:  # before the episodes, not after them
            check_output_file(args.out)
        except ValueError as exc:
            p.error(f"--out: {exc}")
    return args


def main(argv: Sequence[str] | None = None) -> int:
    """Run the soak, print (and optionally write) the report; 1 if any invariant failed."""
    args = parse(argv)
    shown = [] if argv is None else list(argv)
    command = " ".join(["python benchmarks/soak.py", *(sys.argv[1:] if argv is None else shown)])
    soak = Soak(args.seed, args.block)
    load_start = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    start = time.perf_counter()
    soak.run(args.warmup)
    warm = time.perf_counter()
    gc.collect()  # measure what is held, not garbage awaiting collection (pymunk has cycles)
    rss_start = rss_bytes()
    was_tracing = tracemalloc.is_tracing()
    if not was_tracing:
        tracemalloc.start(args.frames)
    tracemalloc.reset_peak()
    before = tracemalloc.take_snapshot()
    traced_before = tracemalloc.get_traced_memory()[0]
    # In ten stretches, to tell steady growth (a leak) from a plateau (caches filling up).
    measured, series = args.episodes - args.warmup, []
    for k in range(1, 11):
        soak.run(measured * k // 10 - measured * (k - 1) // 10)
        gc.collect()
        series.append((soak.done, tracemalloc.get_traced_memory()[0] - traced_before,
                       tracemalloc.get_tracemalloc_memory(), rss_bytes()[1]))
    end = time.perf_counter()
    traced_after, traced_peak = tracemalloc.get_traced_memory()
    after = tracemalloc.take_snapshot()
    if not was_tracing:
        tracemalloc.stop()
    timing = {
        "warmup_rate": args.warmup / (warm - start) if args.warmup else math.nan,
        "measured_rate": (args.episodes - args.warmup) / (end - warm),
        "total": end - start,
        "load": None if load_start is None else (load_start, os.getloadavg()[0]),
    }
    memory = {
        "command": command,
        "traced_growth": traced_after - traced_before,
        "traced_peak": traced_peak,
        "rss_start": rss_start,
        "rss_end": rss_bytes(),
        "sites": grown_sites(before, after, args.top),
        "series": series,
    }
    section = report(args, soak, timing, memory)
    print(section)
    if args.out is not None:
        write_section(args.out, section)
    return 1 if soak.tally.violations else 0


if __name__ == "__main__":
    raise SystemExit(main())
