"""Frames of a batch's drills: :mod:`soccer_drill.rendering.draw`'s drawing, one frame per drill."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from soccer_drill.config import DrillConfig
from soccer_drill.constraints import NoneOr, OneOf, checked
from soccer_drill.rendering.scene import Scene
from soccer_drill.rules.arrays import OUTCOME_NAMES, Outcome

RENDER_MODES = ("rgb_array",)
"""What the batched environments draw: one off-screen frame per drill."""


def check_render_mode(render_mode: str | None, env: str) -> str | None:
    """``render_mode`` if a batched environment can draw it, else ``ValueError``."""
    return checked("render_mode", render_mode, NoneOr(OneOf(RENDER_MODES)),
                   why=f"{env} draws one off-screen frame per drill; a window: render a "
                   "single environment with render_mode='human'")


def frame_bytes(config: DrillConfig) -> tuple[int, tuple[int, int]]:
    """The bytes of one ``(H, W, 3)`` frame of ``config``'s drill, and its ``(W, H)``
    (imports pygame, through :mod:`soccer_drill.rendering.draw`)."""
    from soccer_drill.rendering.draw import frame_geometry

    width, height = frame_geometry(config)[2]
    return width * height * 3, (width, height)


class BatchRenderer:
    """Draws every drill of a :class:`~soccer_drill.drill.drills.BatchDrill` off-screen, each
    time first calling ``check_memory(n, config)``, if given, to refuse ``n`` frames that
    do not fit in the memory available then. The batched environments give
    :func:`~soccer_drill.vector.memory.check_frames_memory`, and check ``num_envs`` with its
    frames when made (:func:`~soccer_drill.vector.memory.check_frames_fit`): memory is
    theirs to estimate. A frame shows ``team`` (the defending team's name) in its header,
    and the outcome and the reward once its drill's episode ends."""

    def __init__(self, config: DrillConfig,
                 check_memory: Callable[[int, DrillConfig], None] | None = None,
                 team: str | None = None) -> None:
        self.config, self.team = config, team
        self._check_memory = check_memory
        self._renderer = None
        self._trails: list = []

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["_renderer"] = None  # pygame's surfaces and fonts are not copied: drawn anew
        return state

    def frames(self, batch: object, has_reset: bool) -> tuple[np.ndarray, ...]:
        """One ``(H, W, 3)`` uint8 frame per drill, in drill order (``has_reset``: the
        environment has been reset, else there is nothing to draw yet)."""
        if not has_reset:
            raise RuntimeError("render() called before reset(); call reset() first")
        n = batch.n  # type: ignore[attr-defined]
        if self._check_memory is not None:
            self._check_memory(n, self.config)
        if self._renderer is None:
            from soccer_drill.rendering.draw import Renderer

            self._renderer = Renderer(self.config, "rgb_array", players=self.config.player_names)
        if len(self._trails) != n:
            from soccer_drill.rendering.draw import Trail

            self._trails = [Trail(self._renderer.style.trails) for _ in range(n)]
        outcome, reward = batch.outcome, batch.attacker_reward  # type: ignore[attr-defined]
        frames = []
        for i in range(n):
            code = int(outcome[i])
            scene = Scene(team=self.team, outcome=OUTCOME_NAMES[code],
                          reward=None if code == Outcome.RUNNING else float(reward[i]))
            frames.append(self._renderer.draw(batch.state_of(i), scene, self._trails[i]))  # type: ignore[attr-defined]
        return tuple(frames)

    def close(self) -> None:
        """Let go of pygame's surface."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
