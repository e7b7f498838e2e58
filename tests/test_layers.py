"""The import graph of the three packages: no circle, and the packages in layers.

Every import counts, wherever it is written: at module level, inside a function, under
``if TYPE_CHECKING:`` (two modules that each name the other for a type checker still
cannot be read one without the other), absolute or relative. Importing ``a.b.c`` first
runs ``a/__init__.py`` and ``a/b/__init__.py``, so it is an edge to those packages too,
except to the importing module's own ancestors (they ran before it). A module also
imports what it names in a string that code imports: ``"package.module:attribute"``
(Gymnasium's entry points, the drill code that ``ilpss`` looks up by name) and the literal
of ``importlib.import_module("package.module")``.

Entry points declared in ``pyproject.toml`` are not edges: they are the plugin mechanism,
by which a lower package's registry (teams, samplers, reuses, ...) finds what a higher
package declares without naming it (dependency inversion).

The packages are in layers, lowest first: ``soccer_drill``, ``opponents``, ``ilpss``; no
module of a lower package imports a higher one, strings included.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Mapping
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("soccer_drill", "opponents", "ilpss")
"""The project's packages, lowest layer first."""
_SPEC = re.compile(r"([A-Za-z_]\w*(?:\.[A-Za-z_]\w*)*):[\w./-]+")
"""``"package.module:attribute"`` (or a Gymnasium id, ``"module:namespace/Name-v0"``)."""


def _module_path(name: str, root: Path = ROOT) -> Path | None:
    base = root.joinpath(*name.split("."))
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path
    return None


def _module_name(path: Path, root: Path) -> str:
    rel = path.relative_to(root).with_suffix("")
    return ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)


def _named(path: Path, name: str) -> tuple[set[str], set[str]]:
    """The module names that the module ``name`` at ``path`` imports (some perhaps not
    modules: ``from a import f`` gives ``a.f``), and those it names in strings."""
    imported: set[str] = set()
    in_strings: set[str] = set()
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            imported.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            module = ".".join([*base, *([node.module] if node.module else [])])
            imported.add(module)
            imported.update(f"{module}.{alias.name}" for alias in node.names)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) \
                and (spec := _SPEC.fullmatch(node.value)):
            in_strings.add(spec.group(1))
        elif isinstance(node, ast.Call) and node.args \
                and isinstance(node.args[0], ast.Constant) \
                and isinstance(node.args[0].value, str) \
                and (getattr(node.func, "attr", None) == "import_module"
                     or getattr(node.func, "id", None) == "import_module"):
            in_strings.add(node.args[0].value)
    return imported, in_strings


def _runs(target: str, importer: str) -> list[str]:
    """``target`` and its ancestor packages, which importing it runs, but for
    ``importer`` itself and its own ancestors."""
    parts = target.split(".")
    prefixes = [".".join(parts[:k]) for k in range(1, len(parts) + 1)]
    return [m for m in prefixes if m != importer and not importer.startswith(m + ".")]


def graph_and_unresolved(
    *packages: str, root: Path = ROOT
) -> tuple[dict[str, set[str]], set[str]]:
    """``{module: modules it imports}`` over every module of ``packages`` (all three by
    default), and the names in strings of those packages that are no module of theirs."""
    packages = packages or PACKAGES

    def resolve(name: str) -> str | None:
        return name if name.split(".")[0] in packages and _module_path(name, root) else None

    edges: dict[str, set[str]] = {}
    unresolved: set[str] = set()
    for package in packages:
        for path in sorted((root / package).rglob("*.py")):
            name = _module_name(path, root)
            imported, in_strings = _named(path, name)
            unresolved |= {s for s in in_strings
                           if s.split(".")[0] in packages and resolve(s) is None}
            edges[name] = {m for target in imported | in_strings
                           if (module := resolve(target)) is not None
                           for m in _runs(module, name)}
    return edges, unresolved


def graph(*packages: str, root: Path = ROOT) -> dict[str, set[str]]:
    """``{module: modules it imports}`` for every module of ``packages`` (default: all three),
    counting only edges among them."""
    return graph_and_unresolved(*packages, root=root)[0]


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


def _upward(edges: dict[str, set[str]], layers: tuple[str, ...]) -> list[str]:
    """The edges from a module of a lower package to one of a higher package."""
    rank = {package: k for k, package in enumerate(layers)}
    return sorted(f"{a} -> {b}" for a, targets in edges.items() for b in targets
                  if rank[b.split(".")[0]] > rank[a.split(".")[0]])


def test_the_import_graph_of_the_three_packages_has_no_circle():
    cycle = _cycle(graph())
    assert cycle is None, " -> ".join(cycle or [])


def test_every_module_named_in_a_string_is_found():
    """A name the graph cannot resolve would hide its edge (and fail where it is used)."""
    assert graph_and_unresolved()[1] == set()


def test_no_package_imports_a_higher_layer():
    assert _upward(graph(), PACKAGES) == []


ILPSS_SEAM = {"soccer_drill", "soccer_drill.files", "soccer_drill.constraints",
              "soccer_drill.registry"}
"""What ``ilpss`` imports of the drill's package (docs/architecture.md): the writes and
output checks, and the one vocabulary of constraints and registries (``soccer_drill`` is
the package their import runs). The drill itself only by the names of ``drill_facts``."""


def test_ilpss_reaches_the_drill_only_through_its_seam():
    reached = {f"{a} -> {b}" for a, targets in graph().items() if a.startswith("ilpss.")
               and a != "ilpss.experiments.drill_facts"
               for b in targets if b.split(".")[0] == "soccer_drill" and b not in ILPSS_SEAM}
    assert reached == set()


OPPONENTS_SEAM = {"soccer_drill", "soccer_drill.teams", "soccer_drill.constraints",
                  "soccer_drill.policies"}
"""What the teams import of the drill's package: the team kit (``soccer_drill.teams``), the
vocabulary of constraints, and the fixed holder rules (the region rules compose them)."""


def test_opponents_reach_the_drill_only_through_the_team_kit():
    reached = {f"{a} -> {b}" for a, targets in graph().items() if a.startswith("opponents")
               for b in targets if b.split(".")[0] == "soccer_drill" and b not in OPPONENTS_SEAM}
    assert reached == set()


def test_the_import_graph_of_ilpss_has_no_circle():
    cycle = _cycle(graph("ilpss"))
    assert cycle is None, " -> ".join(cycle or [])


def test_a_circle_is_found_where_there_is_one():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) is None


def _tree(root: Path, files: Mapping[str, str]) -> Path:
    for name, text in files.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)
    return root


_PLANTED = {
    "module level": "from low import b\n",
    "function level": "def f():\n    import low.b\n",
    "TYPE_CHECKING": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                     "    from low.b import B\n",
    "relative": "from . import b\n",
    "an ancestor's __init__": "import low.sub.c\n",
    "a module:attribute string": "TARGET = 'low.b:B'\n",
    "an import_module literal": "import importlib\nB = importlib.import_module('low.b').B\n",
}


def test_the_graph_finds_a_circle_planted_through_each_kind_of_edge(tmp_path):
    """``low.a`` imports ``low.b`` in each way, and ``low.b`` (or ``low.sub``'s
    ``__init__``, which importing ``low.sub.c`` runs) imports ``low.a``."""
    for kind, text in _PLANTED.items():
        root = _tree(tmp_path / kind.replace(" ", "_"), {
            "low/__init__.py": "", "low/a.py": text, "low/b.py": "import low.a\n",
            "low/sub/__init__.py": "from low import a\n", "low/sub/c.py": "",
        })
        assert _cycle(graph("low", root=root)) is not None, kind
        # the same tree without the way back from low.b and low.sub has no circle
        (root / "low/b.py").write_text("")
        (root / "low/sub/__init__.py").write_text("")
        assert _cycle(graph("low", root=root)) is None, kind


def test_a_package_importing_its_own_modules_is_no_circle(tmp_path):
    """A package's ``__init__`` imports its modules, which import one another by their
    full names: the ancestors they name have run before them."""
    root = _tree(tmp_path, {"low/__init__.py": "from low.a import A\n",
                            "low/a.py": "from low.b import B\nA = B\n",
                            "low/b.py": "import low\nB = 1\n"})
    edges = graph("low", root=root)
    assert edges == {"low": {"low.a"}, "low.a": {"low.b"}, "low.b": set()}
    assert _cycle(edges) is None


def test_a_lower_package_naming_a_higher_one_is_found_strings_included(tmp_path):
    root = _tree(tmp_path, {"low/__init__.py": "", "low/a.py": "DEFAULT = 'high.b:B'\n",
                            "high/__init__.py": "", "high/b.py": "from low import a\n"})
    edges, unresolved = graph_and_unresolved("low", "high", root=root)
    assert _upward(edges, ("low", "high")) == ["low.a -> high", "low.a -> high.b"]
    assert unresolved == set()
    (root / "low/a.py").write_text("DEFAULT = 'high.gone:B'\n")
    assert graph_and_unresolved("low", "high", root=root)[1] == {"high.gone"}


def test_storage_runs_no_learner_and_protocols_present_nothing():
    edges = graph("ilpss")
    assert not edges["ilpss.experiments.checkpoints"] & {"ilpss.smdp", "ilpss.baselines",
                                                         "ilpss.experiments.methods"}
    assert not edges["ilpss.experiments.protocols"] & {"ilpss.experiments.report",
                                                       "ilpss.experiments.sections",
                                                       "ilpss.experiments.methods"}
    assert "ilpss.experiments.run" not in edges["ilpss.experiments.sections"]
