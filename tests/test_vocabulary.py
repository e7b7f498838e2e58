"""One vocabulary across soccer_drill, opponents and ilpss: the constraints of
:mod:`soccer_drill.constraints` are the only way to say what a value may be, and every
registry of named things is a :class:`soccer_drill.registry.Registry`."""

from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest

from soccer_drill.constraints import Integer, Name, Real, checked, is_int, is_real
from soccer_drill.registry import PluginWarning, Registry

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("soccer_drill", "opponents", "ilpss")
VOCABULARY = Path("soccer_drill/constraints.py")
REGISTRY = Path("soccer_drill/registry.py")
INTERRUPTIONS = Path("soccer_drill/interruptions.py")

# What a second vocabulary would define: a number test of its own, or a class of limits.
NUMBER_TESTS = {"is_real", "is_int", "is_integer", "is_number", "is_finite_number"}
LIMIT_CLASSES = {"Limits", "Limit", "Range", "Bounds", "Interval"}


def _modules():
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            yield path.relative_to(ROOT), ast.parse(path.read_text(encoding="utf-8"))


def _definitions():
    for path, tree in _modules():
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                yield path, node


def test_no_module_defines_its_own_number_tests_or_limits():
    found = [
        f"{path}:{node.lineno} {node.name}"
        for path, node in _definitions()
        if path != VOCABULARY and (
            (not isinstance(node, ast.ClassDef) and node.name.lstrip("_") in NUMBER_TESTS)
            or (isinstance(node, ast.ClassDef) and node.name in LIMIT_CLASSES)
        )
    ]
    assert not found, f"use soccer_drill.constraints instead: {found}"


def _hand_made_number_test(node: ast.AST) -> bool:
    """``isinstance(x, ...)`` with ``numbers.Integral``/``numbers.Real``, ``np.integer``, or
    ``int`` and ``float`` together: what ``is_int``/``is_real`` say once."""
    if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
            and node.func.id == "isinstance" and len(node.args) == 2):
        return False
    parts = list(ast.walk(node.args[1]))
    attrs = {p.attr for p in parts if isinstance(p, ast.Attribute)}
    names = {p.id for p in parts if isinstance(p, ast.Name)}
    return bool(attrs & {"Integral", "Real", "integer"}) or {"int", "float"} <= names


def test_no_module_tests_a_number_by_hand():
    found = [f"{path}:{node.lineno}" for path, tree in _modules() if path != VOCABULARY
             for node in ast.walk(tree) if _hand_made_number_test(node)]
    assert not found, f"use is_int/is_real of soccer_drill.constraints: {found}"
    planted = ast.parse("isinstance(x, int | np.integer) or isinstance(y, numbers.Real)")
    assert sum(map(_hand_made_number_test, ast.walk(planted))) == 2


def test_no_module_defines_a_second_registry_class_or_reads_entry_points_itself():
    classes = [f"{path}:{node.lineno} {node.name}" for path, node in _definitions()
               if isinstance(node, ast.ClassDef) and node.name.endswith("Registry")
               and path != REGISTRY]
    assert not classes, f"a registry is a soccer_drill.registry.Registry: {classes}"
    readers = []
    for path, tree in _modules():
        for node in ast.walk(tree):
            if (isinstance(node, ast.ImportFrom) and node.module == "importlib.metadata"
                    and any(a.name == "entry_points" for a in node.names) and path != REGISTRY):
                readers.append(str(path))
    assert not readers, f"entry points are read by soccer_drill.registry only: {readers}"


def test_the_registries_of_every_kind_are_one_registry_type():
    from ilpss.experiments.methods import METHODS
    from ilpss.experiments.protocols import PROTOCOLS
    from ilpss.experiments.registry import ENV_PACKAGES, SAMPLERS
    from ilpss.reuse import REUSES
    from soccer_drill.teams import PluginWarning as TeamPluginWarning
    from soccer_drill.teams.registry import TEAMS

    assert TeamPluginWarning is PluginWarning
    registries = {"teams": TEAMS, "methods": METHODS, "protocols": PROTOCOLS,
                  "reuses": REUSES, "samplers": SAMPLERS, "environment packages": ENV_PACKAGES}
    for what, registry in registries.items():
        assert type(registry) is Registry, what
    assert len({r.group for r in registries.values()}) == len(registries)


def test_numbers_are_python_numpy_or_numbers_abc_never_bools():
    for value in (1, 1.5, np.int8(3), np.float32(0.5), np.uint64(7)):
        assert is_real(value)
    for value in (True, np.bool_(False), "1", None, np.array([1.0]), 1 + 2j):
        assert not is_real(value) and not is_int(value)
    assert is_int(np.int64(3)) and not is_int(3.0)
    assert not Real().allows(10**400) and not Real().allows(math.nan)
    assert type(checked("x", np.float32(0.5), Real(0.0, 1.0))) is float
    assert type(checked("n", np.uint8(4), Integer(1))) is int
    with pytest.raises(ValueError, match=r"^n must be an integer >= 1, got 0$"):
        checked("n", 0, Integer(1))


def test_a_registry_s_rules_are_declared_not_subclassed():
    team_like = Registry("vocabulary.tests", "widget", label="id", names=Name(dots=False),
                         calls="a widget factory", error=RuntimeError)
    with pytest.raises(ValueError, match=r"^a widget id must be a non-empty identifier"):
        team_like.register("a.b", object)
    with pytest.raises(TypeError, match=r"widget 'w' must be a widget factory \(a callable\)"):
        team_like.register("w", 5)
    with team_like.isolated():
        team_like.register("w", dict)
        assert team_like.get("w") is dict and team_like.names() == ["w"]
    assert "w" not in team_like
    with pytest.raises(ValueError, match=r"unknown widget 'w'; known widgets: \[\]"):
        team_like.get("w")
    assert team_like.broken() == {}


def test_the_vocabulary_and_the_registry_sit_below_everything():
    allowed = {VOCABULARY: set(), INTERRUPTIONS: set(),
               REGISTRY: {"soccer_drill.constraints", "soccer_drill.interruptions"}}
    for path, tree in _modules():
        if path not in allowed:
            continue
        imported = {node.module for node in ast.walk(tree)
                    if isinstance(node, ast.ImportFrom) and node.module} | {
            a.name for node in ast.walk(tree) if isinstance(node, ast.Import) for a in node.names}
        own = {m for m in imported if m.split(".")[0] in PACKAGES}
        assert own == allowed[path], path


# ------------------------------------------------------ hand-written "must be" checks
def _hand_written_in(tree: ast.AST) -> list[str]:
    """The functions (by name, one entry per raise) whose raises say what a value "must
    be" in words written there rather than a constraint's ``describe()``."""
    scopes = [(node, node.name) for node in ast.walk(tree)
              if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)]
    found = []
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Raise) and node.exc is not None):
            continue
        parts = list(ast.walk(node.exc))
        words = " ".join(p.value for p in parts if isinstance(p, ast.Constant)
                         and isinstance(p.value, str))
        described = any(isinstance(p, ast.Attribute) and p.attr == "describe" for p in parts)
        if " must be " in f" {words}" and not described:
            inside = [name for scope, name in scopes
                      if scope.lineno <= node.lineno <= (scope.end_lineno or scope.lineno)]
            found.append(inside[-1] if inside else "<module>")
    return found


def _hand_written_checks() -> dict[str, int]:
    """``{"path::function": n}`` of every module but the vocabulary itself."""
    found: dict[str, int] = {}
    for path, tree in _modules():
        if path != VOCABULARY:
            for name in _hand_written_in(tree):
                key = f"{path}::{name}"
                found[key] = found.get(key, 0) + 1
    return found


# What is left, by place: shapes of arrays and mappings, kinds of objects. The list may
# only shrink: a check written by hand anew fails, and one moved to the vocabulary must
# be taken off it.
HAND_WRITTEN_ALLOWED = {
    "soccer_drill/envs/agents.py::_step": 2,
    "soccer_drill/envs/core.py::make_config": 1,
    "soccer_drill/files.py::check_output_file": 1,
    "soccer_drill/registry.py::register": 1,
    "soccer_drill/registry.py::add": 1,
    "soccer_drill/teams/driver.py::resolve_team": 2,
    "soccer_drill/teams/driver.py::check_commands": 1,
    "soccer_drill/teams/kit.py::random": 1,
    "soccer_drill/teams/registry.py::team_parameters": 1,
    "soccer_drill/vector/agents.py::_commands": 2,
    "soccer_drill/envs/core.py::check_reset_options": 1,
    "soccer_drill/vector/holder.py::play_episodes": 1,
    "soccer_drill/vector/holder.py::_check_reset": 1,
    "soccer_drill/vector/holder.py::_check_actions": 1,
    "soccer_drill/vector/holder.py::_check_env_id": 1,
    "opponents/regions.py::_region": 1,
}
LEARNER_HAND_WRITTEN = 92
"""The hand-written checks left in ``ilpss`` (its settings' constraints are declared in
the vocabulary; these are the rest, to be moved there, among them the kinds of the JSON
values of plans, pilots, kept per-seed numbers and the reference command's kept results):
the number may only fall."""


def test_hand_written_checks_only_shrink():
    found = _hand_written_checks()
    drill_side = {k: v for k, v in found.items() if not k.startswith("ilpss/")}
    assert drill_side == HAND_WRITTEN_ALLOWED, (
        "say what a value may be with soccer_drill.constraints (check, checked, or a "
        "constraint's describe()); a check moved there comes off HAND_WRITTEN_ALLOWED")
    learner_side = sum(v for k, v in found.items() if k.startswith("ilpss/"))
    assert learner_side <= LEARNER_HAND_WRITTEN, learner_side


def test_a_range_check_written_by_hand_is_found_and_one_through_the_vocabulary_is_not():
    planted = ast.parse(
        "def by_hand(x):\n"
        "    if not 0 < x <= 1:\n"
        "        raise ValueError(f'x must be in (0, 1], got {x}')\n"
        "def said(x):\n"
        "    raise ValueError(f'x must be {SPEED.describe()}, got {x}')\n")
    assert _hand_written_in(planted) == ["by_hand"]
