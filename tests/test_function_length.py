"""Functions short enough to read at once: none of the three packages' functions is longer
than :data:`MAX_LINES` lines, apart from those of :data:`LONGER`, a list that may only
shrink (a function shortened below the limit must leave it)."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("soccer_drill", "opponents", "ilpss")
MAX_LINES = 80
"""Lines of a function, from its ``def`` to its last line (``end_lineno - lineno``)."""

LONGER: set[str] = set()
"""The functions still longer than :data:`MAX_LINES`, as ``path::qualified name`` (none
now: a function that grows past the limit is split into named steps)."""


def _functions(tree: ast.AST, prefix: str = ""):
    """``(qualified name, node)`` of every function of ``tree``, methods and nested ones
    included."""
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            yield prefix + node.name, node
            yield from _functions(node, f"{prefix}{node.name}.")
        elif isinstance(node, ast.ClassDef):
            yield from _functions(node, f"{prefix}{node.name}.")
        else:
            yield from _functions(node, prefix)


def long_functions(root: Path = ROOT) -> dict[str, int]:
    """``{path::qualified name: lines}`` of every function longer than :data:`MAX_LINES`."""
    found = {}
    for package in PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            tree = ast.parse(path.read_text())
            for name, node in _functions(tree):
                lines = node.end_lineno - node.lineno
                if lines > MAX_LINES:
                    found[f"{path.relative_to(root).as_posix()}::{name}"] = lines
    return found


def test_no_function_is_longer_than_the_limit_unless_listed():
    found = long_functions()
    assert set(found) <= LONGER, {k: v for k, v in found.items() if k not in LONGER}


def test_the_list_of_longer_functions_only_shrinks():
    found = long_functions()
    assert LONGER <= set(found), f"now short enough, remove from LONGER: {LONGER - set(found)}"


def test_a_long_function_is_found(tmp_path):
    package = tmp_path / "ilpss"
    package.mkdir()
    body = "\n".join(f"        x{i} = {i}" for i in range(MAX_LINES))
    (package / "m.py").write_text(f"class A:\n    def f(self):\n{body}\n        return 0\n")
    assert long_functions(tmp_path) == {"ilpss/m.py::A.f": MAX_LINES + 1}
