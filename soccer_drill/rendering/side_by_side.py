"""Two or more policies on the same episode seeds, one panel each, in one GIF (or MP4).

Command line::

    soccer-drill-side-by-side --team goal_guards --policy pass_first --policy dribble \\
        [--seeds 0 1] [--fps 10] -o side_by_side.gif

Each panel plays every seed in turn on its own environment, one frame per cycle; a panel
whose episode ends first holds its last frame (its end banner) until the longest is over,
so the panels stay in step episode by episode. Each panel's header names its policy.
``-o x.mp4`` writes an MP4 where moviepy is installed (the ``video`` extra).
From code, :func:`write_side_by_side` takes any players of an episode (e.g. a learner's
``run_episode``) as :class:`Panel` s.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from soccer_drill.constraints import ListOf, Text, checked
from soccer_drill.envs.holder import HolderEnv
from soccer_drill.files import check_output_file
from soccer_drill.policies import HOLDER_POLICIES, get_policy
from soccer_drill.rendering.gif import (
    FPS_RANGE,
    check_fps,
    check_writable_file,
    fps_argument,
    save_gif,
    seed_argument,
    stopped_by_ctrl_c,
)
from soccer_drill.teams.registry import TeamError, team_ids

LINGER = 8
"""Frames each episode's end is held, in every panel, before the next seed."""
_GAP = 6  # pixels between panels
_GAP_COLOUR = (28, 28, 32)
SUFFIXES = (".gif", ".mp4")


@dataclass(frozen=True)
class Panel:
    """One panel: its ``label`` (in its header) and ``play(env, seed)``, which plays one
    episode of ``env`` from ``env.reset(seed=seed)`` to its end (e.g.
    ``lambda env, seed: learner.run_episode(env, learn=False, seed=seed)``)."""

    label: str
    play: Callable[[gym.Env, int], Any]


def policy_panel(name: str) -> Panel:
    """A panel of the registered holder policy ``name`` (``soccer_drill.policies``)."""
    policy = get_policy(name)

    def play(env: gym.Env, seed: int) -> None:
        obs, _ = env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        done = False
        while not done:
            obs, _, terminated, truncated, _ = env.step(policy(obs, rng))
            done = terminated or truncated

    return Panel(name, play)


class _Frames(gym.Wrapper):
    """Keeps every frame the environment draws (``render_mode="rgb_array_list"``)."""

    def __init__(self, env: gym.Env, frames: list[np.ndarray]) -> None:
        super().__init__(env)
        self.frames = frames

    def reset(self, **kwargs: Any) -> Any:
        out = self.env.reset(**kwargs)
        self.frames.extend(self.env.render())
        return out

    def step(self, action: Any) -> Any:
        out = self.env.step(action)
        self.frames.extend(self.env.render())
        return out


def panel_frames(panel: Panel, make_env: Callable[[], gym.Env], seed: int) -> list[np.ndarray]:
    """Every cycle's frame of ``panel`` playing ``seed`` on a fresh ``make_env()`` (made
    with ``render_mode="rgb_array_list"``), its header naming the panel."""
    env = make_env()
    if getattr(env, "render_mode", None) != "rgb_array_list":
        env.close()
        raise ValueError("side by side needs environments made with "
                         f"render_mode='rgb_array_list', got {env.render_mode!r}")
    if hasattr(env.unwrapped, "policy_name"):
        env.unwrapped.policy_name = panel.label
    frames: list[np.ndarray] = []
    try:
        panel.play(_Frames(env, frames), seed)
    finally:
        env.close()
    if not frames:
        raise RuntimeError(f"panel {panel.label!r} drew no frame on seed {seed}")
    return frames


def side_by_side(columns: Sequence[Sequence[np.ndarray]]) -> list[np.ndarray]:
    """One episode's frames of each panel, side by side: the shorter ones hold their last
    frame, and every panel's last is held :data:`LINGER` frames more."""
    length = max(len(c) for c in columns) + LINGER
    height = max(c[0].shape[0] for c in columns)
    gap = np.empty((height, _GAP, 3), dtype=np.uint8)
    gap[:] = _GAP_COLOUR
    frames = []
    for t in range(length):
        parts = []
        for k, column in enumerate(columns):
            frame = column[min(t, len(column) - 1)]
            if frame.shape[0] < height:  # panels of different heights: padded below
                pad = np.zeros((height - frame.shape[0], *frame.shape[1:]), dtype=np.uint8)
                frame = np.concatenate((frame, pad))
            parts += [gap, frame] if k else [frame]
        frames.append(np.concatenate(parts, axis=1))
    return frames


def write_side_by_side(path: str | os.PathLike, panels: Sequence[Panel],
                       make_env: Callable[[], gym.Env], seeds: Sequence[int],
                       fps: float = 10) -> Path:
    """Play every seed with every panel and write the panels side by side to ``path``
    (``.gif``, or ``.mp4`` with moviepy); the path (by
    :func:`~soccer_drill.rendering.gif.check_writable_file`), ``fps`` and, for an MP4, its
    writer are checked before any episode is played."""
    path = check_output_file(path)
    if path.suffix.lower() not in SUFFIXES:
        raise ValueError(f"path must end in one of {SUFFIXES}, got {str(path)!r}")
    if path.suffix.lower() == ".mp4":
        _mp4_writer()
    path = check_writable_file(path)
    fps = check_fps(fps)
    checked("panel labels", [p.label for p in panels], ListOf(Text(), min_len=2))
    if not seeds:
        raise ValueError("seeds must name at least one episode seed")
    frames: list[np.ndarray] = []
    for seed in seeds:
        frames += side_by_side([panel_frames(p, make_env, seed) for p in panels])
    if path.suffix.lower() == ".mp4":
        return _write_mp4(frames, path, fps)
    return save_gif(frames, path, fps)


def _mp4_writer() -> Any:
    """The module writing MP4s (imageio-ffmpeg), else ``ValueError`` saying how to get it."""
    try:
        import imageio_ffmpeg
    except ImportError:
        raise ValueError("an MP4 needs the video extra, moviepy and imageio-ffmpeg (pip "
                         "install 'soccer-drill-ilpss[video]'); write a .gif instead") from None
    return imageio_ffmpeg


def _write_mp4(frames: Sequence[np.ndarray], path: Path, fps: float) -> Path:
    """Every frame into an H.264 MP4 (imageio-ffmpeg, which the video extra's moviepy
    brings; moviepy's own writer drops a clip's last frame). H.264's usual pixel format
    needs even sides: frames with an odd one get a dark row or column more."""
    imageio_ffmpeg = _mp4_writer()
    height, width = frames[0].shape[:2]
    if height % 2 or width % 2:
        pad = ((0, height % 2), (0, width % 2), (0, 0))
        frames = [np.pad(f, pad, constant_values=_GAP_COLOUR[0]) for f in frames]
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(f".{path.name}.partial.mp4")
    try:
        writer = imageio_ffmpeg.write_frames(
            str(partial), (frames[0].shape[1], frames[0].shape[0]), fps=fps,
            macro_block_size=2, ffmpeg_log_level="error")
        writer.send(None)  # start ffmpeg
        try:
            for frame in frames:
                writer.send(np.ascontiguousarray(frame))
        finally:
            writer.close()
        partial.replace(path)
    finally:
        partial.unlink(missing_ok=True)
    return path


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point ``soccer-drill-side-by-side``."""
    parser = argparse.ArgumentParser(prog="soccer-drill-side-by-side",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--team", default="goal_guards", choices=team_ids(), metavar="TEAM",
                        help="the defending team (soccer-drill-teams lists them; default "
                        "%(default)s)")
    parser.add_argument("--policy", action="append", choices=sorted(HOLDER_POLICIES),
                        help="a holder policy, one panel each (at least two)")
    parser.add_argument("--seeds", type=seed_argument, nargs="+", default=[0],
                        help="the episode seeds every panel plays, in turn (default 0)")
    parser.add_argument("--fps", type=fps_argument, default=10,
                        help=f"frames per second in [{FPS_RANGE[0]}, {FPS_RANGE[1]}] "
                        "(default %(default)s, true speed)")
    parser.add_argument("-o", "--output", default="side_by_side.gif",
                        help="the .gif (or .mp4, with moviepy) to write (default "
                        "%(default)s)")
    args = parser.parse_args(argv)
    if not args.policy or len(args.policy) < 2:
        parser.error("name at least two policies (--policy A --policy B)")
    try:
        check_output_file(args.output)
        if Path(args.output).suffix.lower() not in SUFFIXES:
            raise ValueError(f"-o/--output must end in one of {SUFFIXES}, got {args.output!r}")
        check_writable_file(args.output)
    except ValueError as exc:
        parser.error(str(exc))
    try:
        with stopped_by_ctrl_c(parser.prog, f"{args.output} is not written"):
            write_side_by_side(args.output, [policy_panel(p) for p in args.policy],
                               lambda: HolderEnv(opponent=args.team,
                                                 render_mode="rgb_array_list"),
                               args.seeds, args.fps)
    except (OSError, TeamError, ValueError) as exc:
        print(f"{parser.prog}: error: {exc}", file=sys.stderr)
        return 1
    print(f"wrote {args.output}: {' | '.join(args.policy)} against {args.team}, "
          f"seeds {' '.join(map(str, args.seeds))}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
