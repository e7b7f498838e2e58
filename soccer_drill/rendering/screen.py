"""What the three environments share about rendering: what each ``render_mode`` does
after every cycle and on ``render()``, at one frame per cycle.

pygame is imported only when a frame is first drawn (:mod:`soccer_drill.rendering.draw`),
and the frame's :class:`~soccer_drill.rendering.scene.Scene` is only built then.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from soccer_drill.config import DrillConfig
from soccer_drill.constraints import NoneOr, OneOf, Text, check, checked
from soccer_drill.rendering.scene import DEFAULT_STYLE, FrameStyle, Scene, check_style
from soccer_drill.state import PLAYER_NAMES, DrillState

if TYPE_CHECKING:
    from soccer_drill.rendering.draw import Renderer

RENDER_MODES = ("human", "rgb_array", "rgb_array_list")
_LABEL = NoneOr(Text())


def frames_per_second(config: DrillConfig) -> float | int:
    """One frame per cycle at true speed: ``1 / cycle_seconds`` (an int when it is one)."""
    fps = 1.0 / config.cycle_seconds
    return round(fps) if abs(fps - round(fps)) < 1e-9 else fps


class Screen:
    """An environment's drawing, by ``render_mode``:

    | ``render_mode`` | after every cycle (and at reset) | ``render()`` returns |
    |---|---|---|
    | ``None`` | nothing | ``None`` |
    | ``"human"`` | draws the window, at ``fps`` frames per second | ``None`` |
    | ``"rgb_array"`` | nothing | the current frame, ``(H, W, 3)`` uint8 |
    | ``"rgb_array_list"`` | draws the frame and keeps it | every frame kept since the last ``render()`` or reset |

    So ``"rgb_array_list"`` gives one frame per cycle however the environment's steps
    map onto cycles. :meth:`record` also hands an ``rgb_array`` frame of every cycle to
    a list of the caller's, whatever the mode. Copies (``pickle``, ``copy``) keep the
    frames but not the renderers: a copy draws with its own, opening its own window.

    Parameters
    ----------
    config
        The drill's configuration (field size, radii, cycle length).
    render_mode
        One of :data:`RENDER_MODES` or ``None``.
    fps
        Frames per second of the ``human`` window.
    scene
        The environment's render state now (called only when a frame is drawn).
    style
        What a frame draws (:class:`~soccer_drill.rendering.scene.FrameStyle`).
    players
        The drill's player names, in index order.
    """

    def __init__(self, config: DrillConfig, render_mode: str | None, fps: float,
                 scene: Callable[[], Scene] = Scene, style: FrameStyle = DEFAULT_STYLE,
                 players: Sequence[str] = PLAYER_NAMES) -> None:
        check("render_mode", render_mode, NoneOr(OneOf(RENDER_MODES)))
        self.config, self.render_mode, self.fps = config, render_mode, fps
        self.style, self.players, self._scene = check_style(style), tuple(players), scene
        self._caption: str | None = None
        self._policy: str | None = None
        self._score: str | None = None
        self._draws_cycles = render_mode in ("human", "rgb_array_list")
        self.each_cycle = self._draws_cycles
        """Whether :meth:`after_cycle` has anything to do (the mode draws every cycle, or
        :meth:`record` is on)."""
        self._frames: list[np.ndarray] = []  # rgb_array_list: kept since render()
        self._recording: list[np.ndarray] | None = None
        self._renderers: dict[str, Renderer] = {}

    @property
    def caption(self) -> str | None:
        """Extra text drawn on every frame (e.g. the active option)."""
        return self._caption

    @caption.setter
    def caption(self, text: str | None) -> None:
        self._caption = checked("caption", text, _LABEL)

    @property
    def policy(self) -> str | None:
        """The name of what decides for the attackers, in the header (e.g. a rule's or a
        method's name)."""
        return self._policy

    @policy.setter
    def policy(self, text: str | None) -> None:
        self._policy = checked("policy", text, _LABEL)

    @property
    def score(self) -> str | None:
        """A running score, in the header (e.g. over the episodes of a played session)."""
        return self._score

    @score.setter
    def score(self, text: str | None) -> None:
        self._score = checked("score", text, _LABEL)

    def scene(self) -> Scene:
        """The render state now: the environment's, with the caption, policy and score."""
        return self._scene()._replace(caption=self._caption, policy=self._policy,
                                      score=self._score)

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["_renderers"] = {}  # pygame surfaces and windows are not copied
        return state

    def draw(self, mode: str, state: DrillState) -> np.ndarray | None:
        """Draw ``state`` in ``mode`` (``"rgb_array"`` or ``"human"``)."""
        renderer = self._renderers.get(mode)
        if renderer is None:
            from soccer_drill.rendering.draw import Renderer

            renderer = self._renderers[mode] = Renderer(self.config, mode, self.fps,
                                                        self.style, self.players)
        return renderer.draw(state, self.scene())

    def start(self, state: DrillState) -> None:
        """A new episode: the frames of the last one are dropped, the first is drawn."""
        self._frames = []
        self.after_cycle(state)

    def after_cycle(self, state: DrillState) -> None:
        """What the mode does with every cycle (see the table)."""
        if self.render_mode == "human":
            self.draw("human", state)
        elif self.render_mode == "rgb_array_list":
            self._frames.append(self.draw("rgb_array", state))  # type: ignore[arg-type]
        if self._recording is not None:
            self._recording.append(self.draw("rgb_array", state))  # type: ignore[arg-type]

    def record(self, frames: list[np.ndarray] | None, state: DrillState | None) -> None:
        """Append an ``rgb_array`` frame to ``frames`` after every cycle, from ``state``
        now if given (``None`` stops)."""
        self._recording = frames
        self.each_cycle = self._draws_cycles or frames is not None
        if frames is not None and state is not None:
            frames.append(self.draw("rgb_array", state))  # type: ignore[arg-type]

    def render(self, state: DrillState):
        """What ``render()`` returns (see the table)."""
        if self.render_mode is None:
            return None
        if self.render_mode == "rgb_array_list":
            frames, self._frames = self._frames, []
            return frames
        if self.render_mode == "human":
            self.draw("human", state)
            return None
        return self.draw("rgb_array", state)

    def close(self) -> None:
        """Close any window."""
        for renderer in self._renderers.values():
            renderer.close()
        self._renderers = {}


class HeaderTexts:
    """The texts an environment's user sets for its frames' header, held by the
    environment's :class:`Screen` (its ``_screen``): a mixin of the environments."""

    _screen: Screen

    @property
    def caption(self) -> str | None:
        """Extra text drawn on rendered frames (e.g. the active option, a prompt)."""
        return self._screen.caption

    @caption.setter
    def caption(self, text: str | None) -> None:
        self._screen.caption = text

    @property
    def policy_name(self) -> str | None:
        """The name of what decides for the attackers, in rendered frames' header."""
        return self._screen.policy

    @policy_name.setter
    def policy_name(self, text: str | None) -> None:
        self._screen.policy = text

    @property
    def score_text(self) -> str | None:
        """A running score, in rendered frames' header (``soccer-drill-play`` keeps one)."""
        return self._screen.score

    @score_text.setter
    def score_text(self, text: str | None) -> None:
        self._screen.score = text
