"""Write an episode of the holder environment to a GIF, headless.

Command line::

    soccer-drill-gif --team chasers --seed 0 --policy pass_first -o episode.gif

One frame per 0.1 s cycle, played at true speed (``--fps`` defaults to the
environment's ``render_fps``). The output path (its folder must take a new file), the
team and ``--fps`` are checked before the episode is played. Ctrl-C stops the command
with one line and status 130, the shell's for ``SIGINT``.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import sys
import tempfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

import numpy as np

from soccer_drill.constraints import Integer, Real, checked
from soccer_drill.envs.holder import HolderEnv
from soccer_drill.files import atomic_write_bytes, check_output_file
from soccer_drill.policies import HOLDER_POLICIES, HolderPolicy, get_policy
from soccer_drill.teams.registry import TeamError, team_ids

FPS_RANGE = (1, 50)
"""Frames per second a GIF can play: its frame delay is counted in hundredths of a second,
and viewers play a delay under 20 ms (above 50 fps) as 100 ms."""
FPS = Real(*FPS_RANGE)


def check_fps(fps: object) -> float:
    """``fps`` as a number in :data:`FPS_RANGE`, else ``ValueError`` saying what is allowed."""
    return checked("fps", fps, FPS, why="frames per second: a GIF counts its frame delay in "
                   "hundredths of a second; viewers play delays under 20 ms as 100 ms")


def palette_images(frames: Sequence[np.ndarray]) -> list | None:
    """The ``(H, W, 3)`` uint8 ``frames`` as palette images sharing one palette of their
    exact colours, or ``None`` if they have more than a GIF's 256.

    A drawn drill has about a hundred colours, so its GIF needs no colour quantization:
    the frames are written as drawn, and faster (Pillow's quantizer is most of the cost
    of writing an RGB frame).
    """
    from PIL import Image

    keys = []
    for f in frames:
        f = np.asarray(f)
        if f.ndim != 3 or f.shape[2] != 3 or f.dtype != np.uint8:
            return None
        k = f[..., 0].astype(np.uint32)
        k <<= 8
        k |= f[..., 1]
        k <<= 8
        k |= f[..., 2]
        keys.append(k)
    # A table over all 2**24 colours: marking and looking up are one pass over the pixels
    # each, where sorting them (np.unique, np.searchsorted) is several.
    seen = np.zeros(1 << 24, dtype=bool)
    for k in keys:
        seen[k] = True
    colours = np.flatnonzero(seen)  # ascending, as np.unique gives them
    if len(colours) > 256:
        return None
    palette = np.stack((colours >> 16, (colours >> 8) & 255, colours & 255), axis=1)
    palette = palette.astype(np.uint8).ravel().tolist()
    lookup = np.zeros(1 << 24, dtype=np.uint8)
    lookup[colours] = np.arange(len(colours))
    images = []
    for k in keys:
        index = lookup[k]
        image = Image.frombytes("P", (index.shape[1], index.shape[0]), index.tobytes())
        image.putpalette(palette)
        images.append(image)
    return images


def save_gif(frames: Sequence[np.ndarray], path: str | os.PathLike, fps: float = 10) -> Path:
    """Save ``(H, W, 3)`` uint8 frames as an animated GIF, atomically.

    ``fps`` is checked by :func:`check_fps` and ``path`` by :func:`check_output_file`;
    the GIF is encoded in memory (a drill's GIF is well under 1 MB) and written by
    :func:`~soccer_drill.files.atomic_write_bytes`: a failing write (a full disk) raises
    ``OSError`` naming ``path`` and leaves no temporary file behind.
    """
    from PIL import Image

    if not frames:
        raise ValueError("no frames to save")
    fps = check_fps(fps)
    path = check_output_file(path)
    images = palette_images(frames) or [Image.fromarray(f) for f in frames]
    encoded = io.BytesIO()
    images[0].save(encoded, format="GIF", save_all=True, append_images=images[1:],
                   duration=round(1000 / fps), loop=0)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, encoded.getvalue())
    return path


def check_writable_file(path: str | os.PathLike) -> Path:
    """``path`` checked by :func:`check_output_file`, and its folder (the nearest one that
    exists) shown to take a new file by creating and removing one: a folder the
    permissions call writable may still refuse files (``/proc``, a read-only mount).
    ``ValueError`` naming the folder otherwise."""
    out = check_output_file(path)
    folder = out.parent
    while not folder.exists():
        folder = folder.parent
    try:
        fd, probe = tempfile.mkstemp(prefix=f".{out.name}.", suffix=".probe", dir=folder)
    except OSError as exc:
        raise ValueError(f"cannot write {os.fspath(path)!r}: the folder {str(folder)!r} "
                         f"takes no new file ({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(probe)
    return out


EXIT_CTRL_C = 130
"""The status of a command stopped by Ctrl-C: the shell's for ``SIGINT`` (128 + 2)."""


@contextlib.contextmanager
def stopped_by_ctrl_c(prog: str, kept: str) -> Iterator[None]:
    """Around a command's work: Ctrl-C ends it with one line on stderr (``kept`` says
    what of its output is kept) and :data:`EXIT_CTRL_C`, not a traceback."""
    try:
        yield
    except KeyboardInterrupt:
        print(f"{prog}: stopped by Ctrl-C (SIGINT); {kept}", file=sys.stderr)
        raise SystemExit(EXIT_CTRL_C) from None


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
    fps: float | None = None,
    **env_kwargs,
) -> dict:
    """Play one holder episode against ``team`` and write it to ``path``; return its info.

    ``fps=None`` plays it at true speed (the environment's ``render_fps``). The path (by
    :func:`check_writable_file`) and ``fps`` are checked before the episode is played.
    """
    check_writable_file(path)
    holder_policy = get_policy(policy) if isinstance(policy, str) else policy
    env = HolderEnv(opponent=team, **env_kwargs)
    env.policy_name = policy_label(policy)
    try:
        fps = check_fps(env.metadata["render_fps"] if fps is None else fps)
        frames, info = record_episode(env, holder_policy, seed)
    finally:
        env.close()
    save_gif(frames, path, fps)
    return info


def policy_label(policy: object) -> str:
    """How a frame's header names a holder policy: its registered name, else its
    ``__name__`` or its class's name."""
    if isinstance(policy, str):
        return policy
    return getattr(policy, "__name__", type(policy).__name__)


def fps_argument(text: str) -> float:
    """A command line's ``--fps``, checked (an ``argparse`` type)."""
    try:
        value: object = float(text)
    except ValueError:
        value = text
    try:
        return check_fps(value)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


SEED = Integer(0, 2**63 - 1)
"""A seed of ``soccer-drill-gif``."""


def seed_argument(text: str) -> int:
    """A command line's seed, checked (an ``argparse`` type)."""
    try:
        return checked("seed", int(text) if text.lstrip("-").isdigit() else text, SEED)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point ``soccer-drill-gif``."""
    parser = argparse.ArgumentParser(prog="soccer-drill-gif", description=__doc__.splitlines()[0])
    parser.add_argument("--team", default="chasers", choices=team_ids(), metavar="TEAM",
                        help="opponent team id (soccer-drill-teams lists them; default "
                        "%(default)s)")
    parser.add_argument("--seed", type=seed_argument, default=0,
                        help="the episode's seed, an integer >= 0: the same seed plays the "
                        "same episode (default %(default)s)")
    parser.add_argument("--policy", default="pass_first", choices=sorted(HOLDER_POLICIES),
                        help="the fixed holder rule deciding for the attackers (default "
                        "%(default)s)")
    parser.add_argument("--fps", type=fps_argument, default=None,
                        help=f"frames per second in [{FPS_RANGE[0]}, {FPS_RANGE[1]}] "
                        "(default: true speed, one frame per 0.1 s cycle)")
    parser.add_argument("-o", "--output", default="episode.gif",
                        help="the .gif file to write (default %(default)s)")
    args = parser.parse_args(argv)
    try:
        check_output_file(args.output)
    except ValueError as exc:
        parser.error(str(exc))
    if Path(args.output).suffix.lower() != ".gif":  # the bytes written are a GIF's
        parser.error(f"-o/--output must name a .gif file, got {args.output!r}")
    try:
        check_writable_file(args.output)
    except ValueError as exc:
        parser.error(str(exc))
    try:
        with stopped_by_ctrl_c(parser.prog, f"{args.output} is not written"):
            info = write_episode_gif(args.output, args.team, args.seed, args.policy, args.fps)
    except (OSError, TeamError) as exc:  # a full disk, a failing team: said in one line
        print(f"{parser.prog}: error: {exc}", file=sys.stderr)
        return 1
    print(f"wrote {args.output}: {info['outcome']} after {info['cycles']} cycles")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
