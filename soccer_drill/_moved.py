"""The modules' old paths, from before the subpackages: each still imports, as the very module
at its new path (the same object: its names, its monkeypatching, the pickles naming it).
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
from types import ModuleType

MOVED = {
    "soccer_drill.batch": "soccer_drill.drill.drills",
    "soccer_drill.batch_physics": "soccer_drill.drill.spaces",
    "soccer_drill.batch_core": "soccer_drill.vector.core",
    "soccer_drill.batch_teams": "soccer_drill.teams.batch",
    "soccer_drill.batch_render": "soccer_drill.rendering.batch",
    "soccer_drill.vector_agents": "soccer_drill.vector.agents",
    "soccer_drill.sb3": "soccer_drill.vector.sb3",
    "soccer_drill.env": "soccer_drill.envs.agents",
    "soccer_drill.holder": "soccer_drill.envs.holder",
    "soccer_drill.core": "soccer_drill.envs.core",
    "soccer_drill.features": "soccer_drill.rules.features",
    "soccer_drill.support": "soccer_drill.rules.support",
    "soccer_drill.time_bound": "soccer_drill.teams.time_bound",
    "soccer_drill.screen": "soccer_drill.rendering.screen",
    "soccer_drill.video": "soccer_drill.rendering.video",
    "soccer_drill.gif": "soccer_drill.rendering.gif",
    "soccer_drill.render": "soccer_drill.rendering.draw",
}
"""Old module path -> new module path (``soccer_drill.teams`` and ``soccer_drill.vector``
are packages now, re-exporting what their modules held)."""


class _OldPaths(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds an old path and loads it as the module at its new path."""

    def find_spec(self, fullname: str, path: object, target: object = None):
        if fullname not in MOVED:
            return None
        return importlib.util.spec_from_loader(fullname, self)

    def create_module(self, spec) -> ModuleType:
        return importlib.import_module(MOVED[spec.name])

    def exec_module(self, module: ModuleType) -> None:
        """Nothing: the module ran at its new path."""


def install(package: ModuleType) -> None:
    """Add the finder of old paths (once), and alias at once those of modules already loaded,
    each also an attribute of ``package`` unless it has one of that name: importing an old
    path anew would set it to the module (``soccer_drill.env`` is a function too)."""
    if not any(isinstance(finder, _OldPaths) for finder in sys.meta_path):
        sys.meta_path.insert(0, _OldPaths())  # before any finder of an older copy of the files
    for old, new in MOVED.items():
        if new in sys.modules and old not in sys.modules:
            sys.modules[old] = sys.modules[new]
            name = old.rpartition(".")[2]
            if not hasattr(package, name):
                setattr(package, name, sys.modules[new])
