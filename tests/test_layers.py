"""The import graph of ``ilpss``: no circle, counting imports inside functions (but not
those made for type checkers only), and the layers of ``ilpss.experiments`` in order."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _imports(path: Path, package: str) -> set[str]:
    """The ``package`` modules that the module at ``path`` imports when it runs."""
    found: set[str] = set()

    def visit(node: ast.AST) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_type_checking(child):
                for other in child.orelse:
                    visit(other)
                continue
            if isinstance(child, ast.Import):
                found.update(a.name for a in child.names if a.name.startswith(package))
            elif isinstance(child, ast.ImportFrom) and child.module and child.level == 0 \
                    and child.module.startswith(package):
                found.add(child.module)
                for alias in child.names:  # `from ilpss.experiments import drill`
                    candidate = f"{child.module}.{alias.name}"
                    if _module_path(candidate) is not None:
                        found.add(candidate)
            visit(child)

    visit(ast.parse(path.read_text()))
    return found


def _module_path(name: str) -> Path | None:
    base = ROOT.joinpath(*name.split("."))
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path
    return None


def graph(package: str = "ilpss") -> dict[str, set[str]]:
    """``{module: modules of the package it imports}`` for every module of ``package``."""
    out = {}
    for path in sorted((ROOT / package).rglob("*.py")):
        rel = path.relative_to(ROOT).with_suffix("")
        name = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        out[name] = {m for m in _imports(path, package) if m != name and _module_path(m)}
        # a package's __init__ is imported by its modules' imports, not a circle
        out[name] = {m for m in out[name] if not name.startswith(m + ".")}
    return out


def _cycle(edges: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def walk(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(edges.get(node, ())):
            if state.get(nxt) == 1:
                return [*stack[stack.index(nxt):], nxt]
            if nxt not in state and (found := walk(nxt)):
                return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(edges):
        if node not in state and (found := walk(node)):
            return found
    return None


def test_the_import_graph_of_ilpss_has_no_circle():
    cycle = _cycle(graph("ilpss"))
    assert cycle is None, " -> ".join(cycle or [])


def test_a_circle_is_found_where_there_is_one():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) is None


def test_storage_runs_no_learner_and_protocols_present_nothing():
    edges = graph("ilpss")
    assert not edges["ilpss.experiments.checkpoints"] & {"ilpss.smdp", "ilpss.baselines",
                                                         "ilpss.experiments.methods"}
    assert not edges["ilpss.experiments.protocols"] & {"ilpss.experiments.report",
                                                       "ilpss.experiments.sections",
                                                       "ilpss.experiments.methods"}
    assert "ilpss.experiments.run" not in edges["ilpss.experiments.sections"]
