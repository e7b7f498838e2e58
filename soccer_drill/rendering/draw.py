"""Drawing the drill with pygame: off-screen for ``rgb_array``, a window for ``human``.

A frame explains itself: a header (team, policy, cycle, time left), the players as discs
in their side's colour with their role (A1, A2, D1, D2, ... read from the drill's player
names, however many there are), a ring around the ball's holder and a tag with its
current choice, short trails, the goal line shaded by what crossing it pays, a legend,
and a banner with the outcome and the reward at the end. :class:`~soccer_drill.rendering.scene.FrameStyle`
turns each part off.

Rendering only reads the drill's state, so observations are identical with it on or off.
``rgb_array`` never opens a display nor starts audio: it draws on a plain
``pygame.Surface`` and only initialises the font module. Text is drawn without
anti-aliasing, so a frame has a few dozen colours and a GIF of it needs no quantization.
"""

from __future__ import annotations

import os
from collections import deque
from collections.abc import Sequence

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import numpy as np
import pygame

from soccer_drill.config import DrillConfig
from soccer_drill.rendering.scene import DEFAULT_STYLE, FrameStyle, Scene
from soccer_drill.state import PLAYER_NAMES, DrillState
from soccer_drill.tasks import TASKS

MARGIN = 2.0  # metres drawn around the region, at least (more when the walls are further)
HEADER = 46  # pixels: two lines of text over the field
LEGEND = 28  # pixels: one line under the field
MIN_DISC = 11  # pixels: the smallest player disc, wide enough for its role

_GRASS, _LINE, _TEXT, _DARK = (46, 120, 60), (235, 235, 235), (245, 245, 245), (28, 28, 32)
_HOLDER, _BALL, _OUTLINE = (255, 215, 0), (255, 255, 255), (10, 10, 10)
_GOAL_CENTRE, _GOAL_EDGE = (255, 240, 120), (120, 150, 120)
SIDE_COLOURS = {"attacker": (40, 90, 220), "defender": (215, 50, 50)}
"""A side's colour, by the prefix of its players' names (``attacker_0``: ``attacker``);
a side not listed is drawn grey."""
_OTHER_SIDE = (150, 150, 150)
_OUTCOME_COLOURS = {"success": (120, 235, 120), "timeout": (255, 190, 80)}
_FAILED = (255, 120, 110)  # an interception, the ball out


def side_of(player: str) -> str:
    """The side a player's name says (``"attacker_1"``: ``"attacker"``)."""
    return player.rsplit("_", 1)[0]


def roles(players: Sequence[str]) -> tuple[str, ...]:
    """Each player's role label: its side's initial and its number within the side, from 1
    (``attacker_0, attacker_1, defender_0``: ``A1, A2, D1``)."""
    counts: dict[str, int] = {}
    labels = []
    for name in players:
        side = side_of(name)
        counts[side] = counts.get(side, 0) + 1
        labels.append(f"{side[:1].upper()}{counts[side]}")
    return tuple(labels)


def frame_geometry(config: DrillConfig, style: FrameStyle = DEFAULT_STYLE
                   ) -> tuple[float, float, tuple[int, int]]:
    """How a frame of ``config``'s drill is drawn: the margin drawn around the field
    (metres), the scale (pixels a metre) and the frame's ``(width, height)`` in pixels."""
    # Everything a player can reach is drawn: the walls stand wall_margin outside.
    margin = max(MARGIN, config.wall_margin + config.player_radius)
    scale = style.width / (config.field_size + 2 * margin)
    height = style.width + (HEADER if style.header else 0) + (LEGEND if style.legend else 0)
    return margin, scale, (style.width, height)


def _mix(a: tuple[int, int, int], b: tuple[int, int, int], w: float) -> tuple[int, ...]:
    """``a`` weighted ``w``, ``b`` the rest (a solid colour: frames keep few colours)."""
    return tuple(round(x * w + y * (1 - w)) for x, y in zip(a, b, strict=True))


class Trail:
    """The last positions of every body, for trails: restarted when the cycle goes back
    (a new episode)."""

    def __init__(self, length: int) -> None:
        self.points: deque[tuple[tuple[float, float], ...]] = deque(maxlen=max(length, 1))
        self._cycle = -1

    def update(self, state: DrillState) -> None:
        """Add ``state``'s positions (once per cycle)."""
        if state.cycle < self._cycle or state.cycle == 0:
            self.points.clear()
        if state.cycle != self._cycle or not self.points:
            self.points.append(state.pos)
        self._cycle = state.cycle


class Renderer:
    """Draws :class:`DrillState` snapshots with their :class:`Scene`: the field and what
    lies within the walls, scaled to ``style.width`` pixels.

    Parameters
    ----------
    config
        The drill's configuration (field size, radii, rewards, cycle length).
    mode
        ``"rgb_array"`` or ``"human"``.
    fps
        Frame rate of the ``human`` window.
    style
        What is drawn (:class:`FrameStyle`).
    players
        The drill's player names, in index order (the ball follows them in ``state.pos``).
    """

    def __init__(self, config: DrillConfig, mode: str, fps: float = 10,
                 style: FrameStyle = DEFAULT_STYLE, players: Sequence[str] = PLAYER_NAMES) -> None:
        self.config, self.mode, self.fps, self.style = config, mode, fps, style
        self.players = tuple(players)
        self.roles = roles(self.players)
        self.margin, self.scale, self.size = frame_geometry(config, style)
        self.top = HEADER if style.header else 0
        pygame.font.init()
        self._font = pygame.font.Font(None, 22)
        self._small = pygame.font.Font(None, 18)
        self._big = pygame.font.Font(None, 40)
        self._window = None
        self._clock = None
        self._surface = pygame.Surface(self.size)
        self.trail = Trail(style.trails)
        self.disc = max(MIN_DISC, round(config.player_radius * self.scale))

    def _px(self, x: float, y: float) -> tuple[int, int]:
        """Field metres to pixels (y up on the field, down on screen)."""
        top = self.config.field_size + self.margin
        return round((x + self.margin) * self.scale), round((top - y) * self.scale) + self.top

    def _text(self, text: str, at: tuple[int, int], font=None, colour=_TEXT, centre=False):
        image = (font or self._font).render(text, False, colour)
        x, y = at
        if centre:
            x, y = x - image.get_width() // 2, y - image.get_height() // 2
        self._surface.blit(image, (x, y))
        return image.get_width()

    def draw(self, state: DrillState, scene: Scene | None = None,
             trail: Trail | None = None) -> np.ndarray | None:
        """Draw one frame; return it as ``(H, W, 3)`` uint8 in ``rgb_array`` mode.
        ``trail``: the positions behind this drill's trails (default: the renderer's own,
        for a renderer drawing one drill)."""
        scene = scene or Scene()
        style = self.style
        self._surface.fill(_GRASS)
        self._field()
        if style.trails:
            trail = trail or self.trail
            trail.update(state)
            self._trails(trail)
        self._bodies(state, scene)
        if style.header:
            self._header(state, scene)
        if style.legend:
            self._legend()
        if style.banner and scene.outcome:
            self._banner(scene)
        return self._show()

    def _field(self) -> None:
        cfg, s = self.config, self._surface
        size = cfg.field_size
        x0, y0 = self._px(0, size)
        x1, y1 = self._px(size, 0)
        pygame.draw.rect(s, _LINE, (x0, y0, x1 - x0, y1 - y0), 1)
        if not TASKS[cfg.task].goal_line:  # keepaway: the region's square is its boundary
            pygame.draw.rect(s, _LINE, (x0, y0, x1 - x0, y1 - y0), 3)
            self._text("keepaway region", ((x0 + x1) // 2, y1 + 4), self._small, centre=True)
            return
        if not self.style.goal_shading:
            pygame.draw.line(s, _LINE, (x0, y1), (x1, y1), 3)
            return
        # The goal line, brighter where crossing it pays more (the reward is linear in x).
        steps, depth = 16, max(6, round(0.6 * self.scale))
        for k in range(steps):
            a, b = k / steps * size, (k + 1) / steps * size
            w = 1.0 - abs((a + b) / 2 - size / 2) / (size / 2)
            xa, xb = self._px(a, 0)[0], self._px(b, 0)[0]
            pygame.draw.rect(s, _mix(_GOAL_CENTRE, _GOAL_EDGE, w), (xa, y1, xb - xa + 1, depth))
        below = y1 + depth + 2
        edge, centre = cfg.success_reward(0.0), cfg.success_reward(size / 2)
        self._text(f"{edge:+.1f}", (x0, below), self._small)
        self._text(f"goal line {centre:+.1f}", ((x0 + x1) // 2, below + 6), self._small,
                   centre=True)
        width = self._small.size(f"{edge:+.1f}")[0]
        self._text(f"{edge:+.1f}", (x1 - width, below), self._small)

    def _trails(self, trail: Trail) -> None:
        points = list(trail.points)
        n = len(points)
        for k in range(1, n):
            w = k / n  # older segments fade into the grass
            for i in range(len(self.players) + 1):  # the players, then the ball
                colour = self._colour(i)
                pygame.draw.line(self._surface, _mix(colour, _GRASS, 0.25 + 0.5 * w),
                                 self._px(*points[k - 1][i]), self._px(*points[k][i]), 3)

    def _colour(self, i: int) -> tuple[int, int, int]:
        if i >= len(self.players):
            return _BALL
        return SIDE_COLOURS.get(side_of(self.players[i]), _OTHER_SIDE)

    def _bodies(self, state: DrillState, scene: Scene) -> None:
        s, r, style = self._surface, self.disc, self.style
        for i, role in enumerate(self.roles):
            centre = self._px(*state.pos[i])
            pygame.draw.circle(s, _OUTLINE, centre, r + 1)
            pygame.draw.circle(s, self._colour(i), centre, r)
            if style.roles:
                self._text(role, centre, self._small, centre=True)
            if style.holder and state.holder == i:
                pygame.draw.circle(s, _HOLDER, centre, r + 5, 3)
        ball = self._px(*state.pos[len(self.players)])
        pygame.draw.circle(s, _OUTLINE, ball, max(4, r // 2) + 1)
        pygame.draw.circle(s, _BALL, ball, max(4, r // 2))
        if style.choice and scene.choice and 0 <= scene.chooser < len(self.players):
            x, y = self._px(*state.pos[scene.chooser])
            w, h = self._small.size(scene.choice)
            box = pygame.Rect(x - w // 2 - 4, y - r - h - 12, w + 8, h + 4)
            pygame.draw.rect(s, _HOLDER, box)
            self._text(scene.choice, (box.x + 4, box.y + 2), self._small, _DARK)

    def _header(self, state: DrillState, scene: Scene) -> None:
        cfg = self.config
        pygame.draw.rect(self._surface, _DARK, (0, 0, self.size[0], HEADER))
        words = []
        if scene.team:
            words.append(f"team {scene.team}")
        if scene.policy:
            words.append(f"policy {scene.policy}")
        if scene.score:
            words.append(scene.score)
        width = self.size[0] - 16
        title, face = self._fitted("   ".join(words) or "soccer drill", width, self._font)
        self._text(title, (8, 5), face)
        left = max(0, cfg.max_cycles - state.cycle) * cfg.cycle_seconds
        line = f"cycle {state.cycle}/{cfg.max_cycles}   {left:.1f} s left"
        if scene.caption:
            line += f"   {scene.caption}"
        text, _ = self._fitted(line, width, self._small)
        self._text(text, (8, 26), self._small)

    def _fitted(self, text: str, width: int, font: pygame.font.Font
                ) -> tuple[str, pygame.font.Font]:
        """``text`` and a font that draw it within ``width`` pixels: ``font``, else the
        small one, else the small one with the text cut short and ``...`` (a long team or
        policy name runs off the frame otherwise)."""
        for face in dict.fromkeys((font, self._small)):
            if face.size(text)[0] <= width:
                return text, face
        while text and self._small.size(text + "...")[0] > width:
            text = text[:-1]
        return text.rstrip() + "...", self._small

    def _legend(self) -> None:
        s, y = self._surface, self.size[1] - LEGEND
        pygame.draw.rect(s, _DARK, (0, y, self.size[0], LEGEND))
        x, mid = 10, y + LEGEND // 2
        sides: dict[str, list[str]] = {}
        for name, role in zip(self.players, self.roles, strict=True):
            sides.setdefault(side_of(name), []).append(role)
        for side, members in sides.items():
            pygame.draw.circle(s, SIDE_COLOURS.get(side, _OTHER_SIDE), (x + 6, mid), 6)
            x += 16 + self._text(f"{side}s {' '.join(members)}", (x + 16, mid - 6), self._small)
            x += 14
        pygame.draw.circle(s, _HOLDER, (x + 6, mid), 7, 2)
        x += 16 + self._text("holder", (x + 16, mid - 6), self._small) + 14
        pygame.draw.circle(s, _BALL, (x + 5, mid), 4)
        x += 14 + self._text("ball", (x + 14, mid - 6), self._small) + 14
        if self.style.goal_shading and TASKS[self.config.task].goal_line:
            pygame.draw.rect(s, _GOAL_CENTRE, (x, mid - 4, 10, 8))
            self._text("goal line: brighter pays more", (x + 16, mid - 6), self._small)

    def _banner(self, scene: Scene) -> None:
        outcome = scene.outcome or ""
        text = outcome.upper()
        if scene.reward is not None:
            text += f"   reward {scene.reward:+.2f}"
        w, h = self._big.size(text)
        x, y = self.size[0] // 2, self.top + self.size[0] // 2
        box = pygame.Rect(x - w // 2 - 14, y - h // 2 - 8, w + 28, h + 16)
        colour = _OUTCOME_COLOURS.get(outcome, _FAILED)
        pygame.draw.rect(self._surface, _DARK, box)
        pygame.draw.rect(self._surface, colour, box, 3)
        self._text(text, (x, y), self._big, colour, centre=True)

    def _show(self) -> np.ndarray | None:
        if self.mode == "human":
            if self._window is None:
                pygame.display.init()
                self._window = pygame.display.set_mode(self.size)
                pygame.display.set_caption("soccer_drill")
                self._clock = pygame.time.Clock()
            pygame.event.pump()
            self._window.blit(self._surface, (0, 0))
            pygame.display.flip()
            self._clock.tick(self.fps)
            return None
        return surface_pixels(self._surface)

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
