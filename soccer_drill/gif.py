"""Write an episode of the holder environment to a GIF, headless.

Command line::

    soccer-drill-gif --team chasers --seed 0 --policy pass_first --fps 10 -o episode.gif
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from soccer_drill.holder import HolderEnv
from soccer_drill.policies import HOLDER_POLICIES, HolderPolicy, get_policy


def save_gif(frames: Sequence[np.ndarray], path: str | os.PathLike, fps: int = 10) -> Path:
    """Save ``(H, W, 3)`` uint8 frames as an animated GIF, atomically."""
    from PIL import Image

    if not frames:
        raise ValueError("no frames to save")
    if fps <= 0:
        raise ValueError(f"fps must be > 0, got {fps!r}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    images = [Image.fromarray(f) for f in frames]
    tmp = path.with_name(f".{path.name}.tmp")
    images[0].save(
        tmp, format="GIF", save_all=True, append_images=images[1:],
        duration=round(1000 / fps), loop=0,
    )
    os.replace(tmp, path)
    return path


def record_episode(
    env: HolderEnv,
    policy: HolderPolicy | Callable[[np.ndarray, np.random.Generator], int],
    seed: int,
    caption: Callable[[], str | None] | None = None,
) -> tuple[list[np.ndarray], dict]:
    """Run one episode, returning one frame per cycle and the final info."""
    frames: list[np.ndarray] = []
    obs, info = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    env.record_frames(frames)
    done = False
    while not done:
        if caption is not None:
            env.caption = caption()
        obs, _, terminated, truncated, info = env.step(policy(obs, rng))
        done = terminated or truncated
    env.record_frames(None)
    frames.extend([frames[-1]] * 5)  # linger on the outcome
    return frames, info


def write_episode_gif(
    path: str | os.PathLike,
    team: str = "chasers",
    seed: int = 0,
    policy: str | HolderPolicy = "pass_first",
    fps: int = 10,
    **env_kwargs,
) -> dict:
    """Play one holder episode against ``team`` and write it to ``path``; return its info."""
    holder_policy = get_policy(policy) if isinstance(policy, str) else policy
    env = HolderEnv(opponent=team, **env_kwargs)
    try:
        frames, info = record_episode(env, holder_policy, seed)
    finally:
        env.close()
    save_gif(frames, path, fps)
    return info


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point ``soccer-drill-gif``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--team", default="chasers", help="opponent team id")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--policy", default="pass_first", choices=sorted(HOLDER_POLICIES))
    parser.add_argument("--fps", type=int, default=10)
    parser.add_argument("-o", "--output", default="episode.gif")
    args = parser.parse_args(argv)
    info = write_episode_gif(args.output, args.team, args.seed, args.policy, args.fps)
    print(f"wrote {args.output}: {info['outcome']} after {info['cycles']} cycles")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
