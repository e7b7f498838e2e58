"""Frames of a batch's drills: :mod:`soccer_drill.rendering.draw`'s drawing, one frame per drill."""

from __future__ import annotations

from types import ModuleType

import numpy as np

from soccer_drill.config import DrillConfig
from soccer_drill.drill import OUTCOME_NAMES

RENDER_MODES = ("rgb_array",)
"""What the batched environments draw: one off-screen frame per drill."""


def check_render_mode(render_mode: str | None, env: str) -> str | None:
    """``render_mode`` if a batched environment can draw it, else ``ValueError``."""
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise ValueError(
            f"{env} draws one off-screen frame per drill: render_mode must be None or "
            f"one of {list(RENDER_MODES)}, got {render_mode!r} (a window: render a single "
            "environment with render_mode='human')"
        )
    return render_mode


def _memory() -> ModuleType:
    """The vector environments' memory estimates, imported when read (those environments
    import this module)."""
    from soccer_drill.vector import core

    return core


def frame_bytes(config: DrillConfig) -> tuple[int, tuple[int, int]]:
    """The bytes of one ``(H, W, 3)`` frame of ``config``'s drill, and its ``(W, H)``
    (imports pygame, through :mod:`soccer_drill.rendering.draw`)."""
    from soccer_drill.rendering.draw import frame_geometry

    width, height = frame_geometry(config)[2]
    return width * height * 3, (width, height)


def check_frames_fit(n: int, config: DrillConfig) -> None:
    """``ValueError`` if ``n`` drills and their frames do not fit in the memory available
    (:func:`~soccer_drill.vector.core.available_memory`): ``render()`` returns ``n`` frames
    at once, and draws each through one more (so ``n + 1``), besides the drills themselves
    (:data:`~soccer_drill.vector.core.DRILL_BYTES` each). Nothing is checked where the
    memory available cannot be read."""
    available = _memory().available_memory()
    if available is None:
        return
    each, (width, height) = frame_bytes(config)
    drill = _memory().DRILL_BYTES
    needed = n * drill + (n + 1) * each
    if needed > available:
        fit = max(0, (available - each) // (drill + each))
        raise ValueError(
            f"num_envs={n} with render_mode='rgb_array' needs about {needed / 2**20:,.0f} MiB: "
            f"{n} drills (up to {drill // 1024} KiB each) and their frames ({n + 1} of {width} "
            f"x {height} pixels, {each / 2**20:.2f} MiB each, render() returns them together), "
            f"more than the {available / 2**20:,.0f} MiB of memory available; at most {fit:,} "
            "drills fit now with their frames (or draw fewer: a HolderEnv draws one drill, "
            "also as a video)"
        )


class BatchRenderer:
    """Draws every drill of a :class:`~soccer_drill.drill.BatchDrill` off-screen, each
    time refusing frames that do not fit in the memory available then (``RuntimeError``
    with the estimate). The environments check ``num_envs`` with its frames when made
    (:func:`check_frames_fit`, which imports pygame for the frames' size)."""

    def __init__(self, config: DrillConfig) -> None:
        self.config = config
        self._renderer = None

    def frames(self, batch: object, has_reset: bool) -> tuple[np.ndarray, ...]:
        """One ``(H, W, 3)`` uint8 frame per drill, in drill order (``has_reset``: the
        environment has been reset, else there is nothing to draw yet)."""
        if not has_reset:
            raise RuntimeError("render() called before reset(); call reset() first")
        n = batch.n  # type: ignore[attr-defined]
        available = _memory().available_memory()
        if available is not None:  # n frames returned at once, one more while drawing
            each, (width, height) = frame_bytes(self.config)
            if (n + 1) * each > available:
                raise RuntimeError(
                    f"render() of {n} drills needs about {(n + 1) * each / 2**20:,.1f} MiB for "
                    f"their frames ({n + 1} of {width} x {height} pixels, {each / 2**20:.2f} MiB "
                    f"each), more than the {available / 2**20:,.1f} MiB of memory available "
                    f"now; at most {max(0, available // each - 1):,} frames fit"
                )
        if self._renderer is None:
            from soccer_drill.rendering.draw import Renderer

            self._renderer = Renderer(self.config, "rgb_array")
        outcome = batch.outcome  # type: ignore[attr-defined]
        return tuple(
            self._renderer.draw(batch.state_of(i), OUTCOME_NAMES[outcome[i]])  # type: ignore[attr-defined]
            for i in range(n)
        )

    def close(self) -> None:
        """Let go of pygame's surface."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
