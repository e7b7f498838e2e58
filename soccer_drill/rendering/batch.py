"""Frames of a batch's drills: :mod:`soccer_drill.rendering.draw`'s drawing, one frame per drill."""

from __future__ import annotations

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


class BatchRenderer:
    """Draws every drill of a :class:`~soccer_drill.drill.drills.BatchDrill` off-screen
    (pygame is imported at the first frame)."""

    def __init__(self, config: DrillConfig) -> None:
        self.config = config
        self._renderer = None

    def frames(self, batch: object, has_reset: bool) -> tuple[np.ndarray, ...]:
        """One ``(H, W, 3)`` uint8 frame per drill, in drill order (``has_reset``: the
        environment has been reset, else there is nothing to draw yet)."""
        if not has_reset:
            raise RuntimeError("render() called before reset(); call reset() first")
        if self._renderer is None:
            from soccer_drill.rendering.draw import Renderer

            self._renderer = Renderer(self.config, "rgb_array")
        n = batch.n  # type: ignore[attr-defined]
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
