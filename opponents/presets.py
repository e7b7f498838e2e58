"""Teams that are settings of another team's class: its parameters, with defaults of their own."""

from __future__ import annotations

import inspect
from typing import Any, ClassVar


class Preset:
    """A team class whose ``DEFAULTS`` replace some defaults of the team class it is
    listed before (``class GoalGuards(Preset, ParametricTeam)``); keyword arguments
    override ``DEFAULTS``.

    Each such class declares the full signature it takes (``__signature__``: the other
    class's parameters with these defaults), so the registry checks a team's parameters
    by name before building it, and an unknown name is refused with the names it takes,
    as for the other class itself.
    """

    DEFAULTS: ClassVar[dict[str, Any]] = {}

    def __init__(self, **overrides: Any) -> None:
        super().__init__(**{**self.DEFAULTS, **overrides})

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        preset = cls.__mro__.index(Preset)
        base = cls.__mro__[preset + 1]  # the class whose parameters are set
        signature = inspect.signature(base)
        cls.__signature__ = signature.replace(parameters=[
            p.replace(default=cls.DEFAULTS.get(p.name, p.default))
            for p in signature.parameters.values()
        ])
