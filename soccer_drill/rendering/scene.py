"""What a frame shows besides the bodies' positions (:class:`Scene`), and which of it is
drawn (:class:`FrameStyle`).

A :class:`Scene` is the render state an environment hands its renderer: read from its
public facts (the team's name, the step's decision, the outcome and reward its infos
report), built only when a frame is drawn, so that stepping without rendering builds none.
Nothing here imports pygame.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from soccer_drill.constraints import Bool, Constraint, Integer, NoneOr, check_fields, checked

MIN_WIDTH = 600
"""Pixels: the narrowest frame :class:`FrameStyle` allows, where the roles and the header
stay readable."""


class Scene(NamedTuple):
    """The facts of one frame beside the :class:`~soccer_drill.state.DrillState`.

    | field | shown as |
    |---|---|
    | ``team`` | the header's "team ..." (the defending team's name) |
    | ``policy`` | the header's "policy ..." (the method or rule deciding for the holder) |
    | ``chooser`` | the player whose ``choice`` is shown (an index, -1: none) |
    | ``choice`` | a tag over ``chooser``: HOLD, PASS or DRIBBLE, the decision being carried out |
    | ``outcome`` | the end banner (``None`` while the episode runs) |
    | ``reward`` | the attackers' reward, on the end banner |
    | ``caption`` | a second header line (e.g. the option running) |
    | ``score`` | the header's running score (e.g. of a played session) |
    """

    team: str | None = None
    policy: str | None = None
    chooser: int = -1
    choice: str | None = None
    outcome: str | None = None
    reward: float | None = None
    caption: str | None = None
    score: str | None = None


_FLAG = Bool()


@dataclass(frozen=True)
class FrameStyle:
    """What a frame draws; every part is on by default, so that a frame explains itself.

    | field | default | draws |
    |---|---|---|
    | ``width`` | 640 | the frame's width in pixels (at least :data:`MIN_WIDTH`); the field is scaled to it |
    | ``roles`` | ``True`` | each player's role (A1, A2, D1, D2, ...) on its disc |
    | ``legend`` | ``True`` | a strip under the field naming the sides, the holder's ring, the ball and the goal line's pay |
    | ``trails`` | 6 | the positions of the last frames drawn, as fading lines (0: none): the last cycles' where every cycle is drawn (``rgb_array_list``, ``human``, GIFs); positions are only kept when drawing, so stepping stays as cheap |
    | ``goal_shading`` | ``True`` | the goal line shaded by what crossing it pays (brightest at the centre), its ends' and centre's reward written |
    | ``holder`` | ``True`` | a ring around the ball's holder |
    | ``choice`` | ``True`` | the holder's current decision over its disc |
    | ``header`` | ``True`` | a strip over the field: team, policy, cycle, time left, score, caption |
    | ``banner`` | ``True`` | the outcome and the reward across the field once the episode ends |
    """

    width: int = 640
    roles: bool = True
    legend: bool = True
    trails: int = 6
    goal_shading: bool = True
    holder: bool = True
    choice: bool = True
    header: bool = True
    banner: bool = True

    def __post_init__(self) -> None:
        check_fields("FrameStyle", self, {
            "width": Integer(MIN_WIDTH, 4096), "trails": Integer(0, 100), "roles": _FLAG,
            "legend": _FLAG, "goal_shading": _FLAG, "holder": _FLAG, "choice": _FLAG,
            "header": _FLAG, "banner": _FLAG,
        })


DEFAULT_STYLE = FrameStyle()


class _IsStyle(Constraint):
    def allows(self, value: object) -> bool:
        return isinstance(value, FrameStyle)

    def describe(self) -> str:
        return "a soccer_drill.rendering.scene.FrameStyle"


RENDER_STYLE = NoneOr(_IsStyle())
"""What an environment's ``render_style`` may be: ``None`` (:data:`DEFAULT_STYLE`) or a
:class:`FrameStyle`."""


def check_style(style: object) -> FrameStyle:
    """``style`` as a :class:`FrameStyle` (``None``: :data:`DEFAULT_STYLE`), else
    ``ValueError`` saying what is allowed."""
    return checked("render_style", style, RENDER_STYLE) or DEFAULT_STYLE
