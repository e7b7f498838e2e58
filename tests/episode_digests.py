"""Digests of recorded episodes, so that a change to the drill's code can be checked to
leave every episode bit-identical.

Each digest is a SHA-256 of everything one configuration's episodes expose, in a
canonical byte form: every observation, reward, termination, truncation and info, the
global ``state()`` and the exact ``DrillState`` floats, cycle after cycle. A
configuration plays an episode from one seed, one that continues the generator, then
reseeds and plays the first seed's episode again: the reseeded episode is played after
others, as users play them. Actions are drawn at random, some of them masked, so the
replacement of masked actions is recorded too.

    python tests/episode_digests.py            # print this platform's digests (JSON)
    python tests/episode_digests.py --write    # record them in episode_digests.json

Floating-point results are bit-reproducible on one platform, not across platforms, so
the file keeps one set of digests per platform (see :func:`platform_key`).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import struct
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pymunk

import soccer_drill
from soccer_drill.policies import keepaway_rule
from soccer_drill.teams.registry import TEAMS

DIGEST_FILE = Path(__file__).with_name("episode_digests.json")
SCHEMA_VERSION = 1
_SEED = 20240
_MASKED_SHARE = 0.15  # share of actions drawn from the whole action space, masked ones too


def platform_key() -> str:
    """What floating-point results depend on: OS, CPU architecture and pymunk's version."""
    return f"{platform.system()}-{platform.machine()}-pymunk{pymunk.version}"


def _feed(h: Any, value: object) -> None:
    """Feed ``value`` into hash ``h`` in a canonical, type-tagged byte form."""
    if isinstance(value, np.ndarray):
        h.update(b"A" + value.dtype.str.encode() + repr(value.shape).encode())
        h.update(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, dict):
        h.update(b"D%d" % len(value))
        for key in sorted(value, key=repr):
            _feed(h, key)
            _feed(h, value[key])
    elif isinstance(value, tuple | list):
        h.update(b"T%d" % len(value))
        for item in value:
            _feed(h, item)
    elif isinstance(value, bool | np.bool_):
        h.update(b"B1" if value else b"B0")
    elif isinstance(value, float | np.floating):
        h.update(b"F" + struct.pack("<d", float(value)))
    elif isinstance(value, int | np.integer):
        h.update(b"I" + str(int(value)).encode())
    elif value is None or isinstance(value, str):
        h.update(b"S" + repr(value).encode())
    else:
        raise TypeError(f"cannot digest {type(value).__name__}: {value!r}")


def _state(env: Any) -> tuple:
    s = env.drill_state
    return (s.pos, s.vel, s.holder, s.cycle, s.passer, s.lockout_until)


def _pick(rng: np.random.Generator, mask: np.ndarray) -> int:
    if rng.random() < _MASKED_SHARE:
        return int(rng.integers(len(mask)))
    return int(rng.choice(np.flatnonzero(mask)))


def _episode_seeds(seed: int) -> tuple[int | None, ...]:
    return (seed, None, seed + 1, seed)


def aec_digest(opponent: str | None, **kwargs: Any) -> str:
    """Digest of AEC episodes (``last()`` at every turn) for one configuration."""
    env = soccer_drill.env(opponent=opponent, **kwargs)
    flat = env.obs_format == "flat"
    rng = np.random.default_rng(_SEED)
    h = hashlib.sha256()
    for seed in _episode_seeds(_SEED):
        env.reset(seed=seed)
        _feed(h, (env.state(), _state(env)))
        for agent in env.agent_iter():
            obs, reward, term, trunc, info = env.last()
            _feed(h, (agent, obs, reward, term, trunc, info, env.state(), _state(env)))
            if term or trunc:
                env.step(None)
            else:
                mask = env.action_mask() if flat else obs["action_mask"]
                env.step(_pick(rng, mask))
    return h.hexdigest()


def parallel_digest(opponent: str | None, **kwargs: Any) -> str:
    """Digest of parallel-API episodes for one configuration."""
    env = soccer_drill.parallel_env(opponent=opponent, **kwargs)
    flat = env.obs_format == "flat"
    rng = np.random.default_rng(_SEED)
    h = hashlib.sha256()
    for seed in _episode_seeds(_SEED):
        obs, infos = env.reset(seed=seed)
        _feed(h, (obs, infos, env.state(), _state(env)))
        while env.agents:
            actions = {
                a: _pick(rng, env.action_mask(a) if flat else obs[a]["action_mask"])
                for a in env.agents
            }
            obs, rewards, terms, truncs, infos = env.step(actions)
            _feed(h, (actions, obs, rewards, terms, truncs, infos, env.state(), _state(env)))
    return h.hexdigest()


def holder_digest(opponent: str) -> str:
    """Digest of holder-env episodes, half random actions, half keepaway's rule."""
    env = soccer_drill.HolderEnv(opponent=opponent)
    rng = np.random.default_rng(_SEED)
    h = hashlib.sha256()
    for seed in _episode_seeds(_SEED):
        obs, info = env.reset(seed=seed)
        _feed(h, (obs, info, _state(env)))
        done = False
        while not done:
            action = keepaway_rule(obs, rng) if rng.random() < 0.5 else int(rng.integers(3))
            obs, reward, term, trunc, info = env.step(action)
            _feed(h, (action, obs, reward, term, trunc, info, _state(env)))
            done = term or trunc
    return h.hexdigest()


def configurations() -> list[tuple[str, str, str | None, dict[str, Any]]]:
    """``(name, api, opponent, keyword arguments)`` of every recorded configuration: this
    project's own teams (a team installed beside it as a plugin has no recorded digest)."""
    out = []
    teams = TEAMS.own_names()
    for opponent in (None, *teams):
        for obs_type in ("features", "kinematic"):
            for obs_format in ("dict", "flat"):
                for shared in (False, True):
                    kwargs = {"obs_type": obs_type, "obs_format": obs_format,
                              "shared_spaces": shared}
                    tag = f"{opponent}/{obs_type}/{obs_format}/shared={shared}"
                    out.append((f"aec/{tag}", "aec", opponent, kwargs))
                    out.append((f"parallel/{tag}", "parallel", opponent, kwargs))
    for opponent in teams:
        out.append((f"holder/{opponent}", "holder", opponent, {}))
    return out


def digest(api: str, opponent: str | None, kwargs: dict[str, Any]) -> str:
    if api == "aec":
        return aec_digest(opponent, **kwargs)
    if api == "parallel":
        return parallel_digest(opponent, **kwargs)
    return holder_digest(opponent)  # type: ignore[arg-type]


def all_digests() -> dict[str, str]:
    """``{configuration name: digest}`` on this platform."""
    return {name: digest(api, opp, kw) for name, api, opp, kw in configurations()}


def load() -> dict[str, Any]:
    data = json.loads(DIGEST_FILE.read_text())
    if data.get("schema_version") != SCHEMA_VERSION:
        raise ValueError(f"{DIGEST_FILE.name}: schema_version {data.get('schema_version')!r}, "
                         f"expected {SCHEMA_VERSION}")
    return data


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true",
                        help=f"record this platform's digests in {DIGEST_FILE.name}")
    args = parser.parse_args()
    digests = all_digests()
    if not args.write:
        json.dump({platform_key(): digests}, sys.stdout, indent=1, sort_keys=True)
        print()
        return
    data = load() if DIGEST_FILE.exists() else {"schema_version": SCHEMA_VERSION, "platforms": {}}
    data["platforms"][platform_key()] = digests
    tmp = DIGEST_FILE.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
    os.replace(tmp, DIGEST_FILE)  # atomic
    print(f"recorded {len(digests)} digests for {platform_key()} in {DIGEST_FILE}")


if __name__ == "__main__":
    main()
