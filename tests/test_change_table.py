"""docs/architecture.md's "Where a change belongs": every row names a test that makes its
change, and that test changes only what the row names, in the files the row names.

A test's changes are the registrations it calls (``register_*``, ``X.register``) and the
module attributes it patches (``monkeypatch.setattr(module, "NAME", ...)``,
``monkeypatch.setitem(module.NAME, ...)``). Each must be named by its row (in backticks),
and, where the row names files, be defined in one of them: an extension that needs a
change the table does not mention fails here.
"""

from __future__ import annotations

import ast
import importlib
import re
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TABLE_HEAD = "## Where a change belongs"


def rows() -> list[tuple[str, str, str]]:
    """``(what, touch, test)`` per row of the table (``test`` as ``path::name``)."""
    text = (ROOT / "docs" / "architecture.md").read_text()
    table = text[text.index(TABLE_HEAD):].split("\n\n")[1]
    out = []
    for line in table.splitlines()[2:]:
        what, touch, done = (cell.strip() for cell in line.strip("|").split(" | "))
        (test,) = re.findall(r"`(tests/[\w/]+\.py::\w+)`", done)
        out.append((what, touch, test))
    return out


def _imports(tree: ast.AST) -> dict[str, tuple[str, str | None]]:
    """``{local name: (module, attribute or None for the module itself)}``."""
    out: dict[str, tuple[str, str | None]] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                out[alias.asname or alias.name.split(".")[0]] = (alias.name, None)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            for alias in node.names:
                out[alias.asname or alias.name] = (node.module, alias.name)
    return out


def _resolve(imports: dict[str, tuple[str, str | None]], base: str,
             attr: str | None) -> tuple[str, str]:
    """``(name, module that defines it)`` of ``base`` or ``base.attr``."""
    module_name, name = imports[base]
    holder = importlib.import_module(module_name)
    if name is not None:
        try:
            holder = importlib.import_module(f"{module_name}.{name}")  # a module
        except ModuleNotFoundError:
            obj = getattr(holder, name)
            return name, getattr(obj, "__module__", None) or module_name
    obj = getattr(holder, attr)
    defined = obj.__module__ if callable(obj) and hasattr(obj, "__module__") else \
        holder.__name__
    return f"{base}.{attr}", defined


def changes(source: str, function: str) -> list[tuple[str, str]]:
    """``(name, defining module)`` of every change the test ``function`` of ``source``
    makes (module-level imports and the function's own)."""
    tree = ast.parse(source)
    imports = _imports(tree)
    (node,) = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == function]
    found = []
    for call in ast.walk(node):
        if not isinstance(call, ast.Call):
            continue
        f = call.func
        if isinstance(f, ast.Name) and f.id.startswith("register") and f.id in imports:
            found.append(_resolve(imports, f.id, None))
        elif isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name):
            if f.value.id == "monkeypatch" and f.attr in ("setattr", "setitem"):
                target = call.args[0]
                if f.attr == "setattr" and isinstance(target, ast.Name):
                    found.append(_resolve(imports, target.id, call.args[1].value))
                elif isinstance(target, ast.Attribute) and isinstance(target.value, ast.Name):
                    found.append(_resolve(imports, target.value.id, target.attr))
            elif f.attr.startswith("register") and f.value.id in imports and \
                    imports[f.value.id][1] is None:
                found.append(_resolve(imports, f.value.id, f.attr))
    return found


def unnamed(touch: str, made: list[tuple[str, str]]) -> list[str]:
    """The changes in ``made`` that the row's ``touch`` cell does not name, or that lie
    outside the files it names."""
    named = re.findall(r"`([^`]+)`", touch)
    files = {n for n in named if n.endswith(".py")}
    wrong = []
    for name, module in made:
        short = name.rsplit(".", 1)[-1]
        if not any(n == name or n == short or n.endswith(f".{short}") or
                   re.search(rf"\b{re.escape(short)}\b", n) for n in named):
            wrong.append(f"{name} is not named")
        path = module.replace(".", "/") + ".py"
        if files and path not in files:
            wrong.append(f"{name} lies in {path}, not in {sorted(files)}")
    return wrong


def test_every_row_names_a_test_that_changes_only_what_the_row_names():
    table = rows()
    assert {"a **way of reusing past policies** (fine-tuning, oracle regions, ...)",
            "a **metric**", "a **report section** of a protocol"} <= {w for w, _, _ in table}
    changed = 0
    for what, touch, test in table:
        path, name = test.split("::")
        made = changes((ROOT / path).read_text(), name)
        assert not unnamed(touch, made), (what, unnamed(touch, made))
        changed += bool(made)
    assert changed >= 8  # every row that adds something does it through a change


def test_a_change_the_row_does_not_name_is_found():
    source = textwrap.dedent("""
        from ilpss import metrics
        from ilpss.experiments import report

        def test_metric(monkeypatch):
            monkeypatch.setattr(metrics, "METRICS", ())
            monkeypatch.setattr(report, "REPORT_BODIES", {})
        """)
    made = changes(source, "test_metric")
    assert made == [("metrics.METRICS", "ilpss.metrics"), ("report.REPORT_BODIES",
                                                           "ilpss.experiments.report")]
    touch = "one `Metric` entry of `METRICS` in `ilpss/metrics.py`"
    assert unnamed(touch, made) == [
        "report.REPORT_BODIES is not named",
        "report.REPORT_BODIES lies in ilpss/experiments/report.py, not in ['ilpss/metrics.py']"]
    assert unnamed(touch, made[:1]) == []
