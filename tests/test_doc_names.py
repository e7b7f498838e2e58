"""The README and the pages of ``docs/`` name only modules, objects and files that exist.

A name there is a promise to a reader: ``soccer_drill.vector.holder.play_episodes`` must
import, ``soccer_drill/envs/holder.py`` must be a file. Entry-point groups
(``soccer_drill.opponents``), environment ids (``soccer_drill/Holder-v0``) and schema
names (``ilpss.options/1``) are names of other kinds and are left alone.
"""

from __future__ import annotations

import importlib
import re
import tomllib
from pathlib import Path

import gymnasium
import pytest

import soccer_drill  # noqa: F401  (registers the environment ids)

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
DOTTED = re.compile(
    r"(?<![\w/.-])((?:soccer_drill|opponents|ilpss)(?:\.[A-Za-z_]\w*)+)(?![\w/-])")
PATH = re.compile(
    r"(?<![\w/.-])((?:soccer_drill|opponents|ilpss|tests|benchmarks|docs|notebooks)/[\w./-]*\w)")
OPTIONAL = {"torch", "stable_baselines3", "ray"}
FILE_KINDS = {"md", "py", "json", "gif", "npz", "toml", "txt", "tmp", "csv", "png"}
"""A dotted name ending in one of these is a file's name (``opponents.md``)."""


def _groups() -> set[str]:
    """The entry-point groups: those this project declares, and those its registries read."""
    from ilpss.experiments.methods import METHODS
    from ilpss.experiments.protocols import PROTOCOLS
    from ilpss.experiments.registry import ENV_PACKAGES, SAMPLERS
    from ilpss.reuse import REUSES
    from soccer_drill.teams.registry import TEAMS

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    registries = (TEAMS, METHODS, PROTOCOLS, REUSES, SAMPLERS, ENV_PACKAGES)
    return set(project.get("entry-points", {})) | {r.group for r in registries}


def exists(name: str) -> bool:
    """Whether the dotted ``name`` is a module, or an attribute path below one."""
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        try:
            found: object = importlib.import_module(".".join(parts[:i]))
        except ModuleNotFoundError as error:
            if error.name in OPTIONAL:
                return True
            continue
        for attribute in parts[i:]:
            if not hasattr(found, attribute):
                return False
            found = getattr(found, attribute)
        return True
    return False


def missing(text: str) -> list[str]:
    """The names of ``text`` that do not exist."""
    groups = _groups()
    wrong = [name for name in sorted(set(DOTTED.findall(text)))
             if name not in groups and name.rsplit(".", 1)[1] not in FILE_KINDS
             and not exists(name)]
    for path in sorted(set(PATH.findall(text))):
        file = path.split("::")[0]
        stem_of_kept_numbers = (ROOT / f"{file}.json").is_file()  # --from-data STEM
        if (file not in gymnasium.registry
                and not (ROOT / file).exists() and not stem_of_kept_numbers):
            wrong.append(path)
    return wrong


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_name_on_the_page_exists(page):
    assert missing(page.read_text(encoding="utf-8")) == []


def test_a_name_that_is_gone_is_found():
    text = ("`soccer_drill.vector.holder.play_episodes`, `soccer_drill.envs.core.DrillCore`, "
            "`soccer_drill/envs/holder.py`, `soccer_drill/vector/core.py`, "
            "`soccer_drill.opponents`, `soccer_drill/Holder-v0`, `ilpss.options/1`, "
            "[x](docs/opponents.md)")
    assert missing(text) == ["soccer_drill.envs.core.DrillCore", "soccer_drill/vector/core.py"]
