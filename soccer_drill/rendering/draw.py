"""Drawing the drill with pygame: off-screen for ``rgb_array``, a window for ``human``.

Rendering only reads the drill's state, so observations are identical with it on
or off. ``rgb_array`` never opens a display nor starts audio: it draws on a plain
``pygame.Surface`` and only initialises the font module.
"""

from __future__ import annotations

import os

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import numpy as np
import pygame

from soccer_drill.config import DrillConfig
from soccer_drill.state import BALL, DrillState

SCALE = 12  # pixels per metre, on fields that fit MAX_SIDE at it
MARGIN = 2.0  # metres drawn around the region, at least (more when the walls are further)
MAX_SIDE = 1024  # pixels: a larger field is drawn at a smaller scale (a frame stays ~3 MB)
_GRASS, _LINE, _BALL = (46, 120, 60), (235, 235, 235), (250, 250, 250)
_ATTACKER, _DEFENDER, _HOLDER = (40, 90, 220), (215, 50, 50), (255, 215, 0)
_GOAL_CENTRE, _GOAL_EDGE = (255, 255, 255), (150, 150, 150)


def frame_geometry(config: DrillConfig) -> tuple[float, float, tuple[int, int]]:
    """How a frame of ``config``'s drill is drawn: the margin drawn around the field
    (metres), the scale (pixels a metre) and the frame's ``(width, height)`` in pixels."""
    # Everything a player can reach is drawn: the walls stand wall_margin outside.
    margin = max(MARGIN, config.wall_margin + config.player_radius)
    drawn = config.field_size + 2 * margin
    scale = min(SCALE, MAX_SIDE / drawn)
    side = round(drawn * scale)
    return margin, scale, (side, side + 24)  # a strip for the caption


class Renderer:
    """Draws :class:`DrillState` snapshots: the field and what lies within the walls, at
    :data:`SCALE` pixels a metre, or less on a field too large for :data:`MAX_SIDE`.

    Parameters
    ----------
    config
        The drill's configuration (field size, radii).
    mode
        ``"rgb_array"`` or ``"human"``.
    fps
        Frame rate of the ``human`` window.
    """

    def __init__(self, config: DrillConfig, mode: str, fps: int = 10) -> None:
        self.config, self.mode, self.fps = config, mode, fps
        self.margin, self.scale, self.size = frame_geometry(config)
        pygame.font.init()
        self._font = pygame.font.Font(None, 20)
        self._window = None
        self._clock = None
        self._surface = pygame.Surface(self.size)

    def _px(self, x: float, y: float) -> tuple[int, int]:
        """Field metres to pixels (y up on the field, down on screen)."""
        top = self.config.field_size + self.margin
        return round((x + self.margin) * self.scale), round((top - y) * self.scale) + 24

    def draw(
        self, state: DrillState, outcome: str | None = None, caption: str | None = None
    ) -> np.ndarray | None:
        """Draw one frame; return it as ``(H, W, 3)`` uint8 in ``rgb_array`` mode."""
        cfg, s = self.config, self._surface
        s.fill(_GRASS)
        size = cfg.field_size
        pygame.draw.rect(s, (30, 30, 30), (0, 0, self.size[0], 24))
        x0, y0 = self._px(0, size)
        x1, y1 = self._px(size, 0)
        pygame.draw.rect(s, _LINE, (x0, y0, x1 - x0, y1 - y0), 1)
        # The goal line, brighter where crossing pays more.
        steps = 20
        for k in range(steps):
            a, b = k / steps * size, (k + 1) / steps * size
            w = 1.0 - abs((a + b) / 2 - size / 2) / (size / 2)
            colour = tuple(int(e + (c - e) * w) for c, e in zip(_GOAL_CENTRE, _GOAL_EDGE, strict=True))
            pygame.draw.line(s, colour, self._px(a, 0), self._px(b, 0), 4)
        r = max(2, round(cfg.player_radius * self.scale))
        for i in range(4):
            centre = self._px(*state.pos[i])
            pygame.draw.circle(s, _ATTACKER if i < 2 else _DEFENDER, centre, r)
            if state.holder == i:
                pygame.draw.circle(s, _HOLDER, centre, r + 3, 2)
        pygame.draw.circle(s, _BALL, self._px(*state.pos[BALL]), max(2, r // 2))
        text = f"cycle {state.cycle}"
        if outcome:
            text += f"   {outcome.upper()}"
        if caption:
            text += f"   {caption}"
        s.blit(self._font.render(text, True, _LINE), (6, 4))
        if self.mode == "human":
            if self._window is None:
                pygame.display.init()
                self._window = pygame.display.set_mode(self.size)
                pygame.display.set_caption("soccer_drill")
                self._clock = pygame.time.Clock()
            pygame.event.pump()
            self._window.blit(s, (0, 0))
            pygame.display.flip()
            self._clock.tick(self.fps)
            return None
        return surface_pixels(s)

    def close(self) -> None:
        """Close the window (if one was opened)."""
        if self._window is not None:
            pygame.display.quit()
            self._window = None


def surface_pixels(surface: object) -> np.ndarray:
    """A pygame surface's pixels as an ``(H, W, 3)`` uint8 array (a copy, writable): the
    bytes pygame exports row by row, which is ``surfarray.array3d`` transposed, in about a
    third of its time."""
    w, h = surface.get_size()  # type: ignore[attr-defined]
    return np.frombuffer(pygame.image.tobytes(surface, "RGB"), dtype=np.uint8).reshape(h, w, 3).copy()
