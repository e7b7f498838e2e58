"""The compiled rules read named structures: a few records per call (the drills' arrays,
the rule parameters by name), not twenty arrays and numbers by position, and no module
outside the rules reads an array by an index constant of theirs."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import numpy as np

from soccer_drill.config import DrillConfig
from soccer_drill.rules.arrays import CYCLE, PARAMETERS, STATE, rule_parameters

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("soccer_drill", "opponents", "ilpss")
MOST_PARAMETERS = 8
RULES = "soccer_drill.rules"


def _modules():
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            rel = path.relative_to(ROOT).with_suffix("")
            name = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
            yield name, ast.parse(path.read_text(encoding="utf-8"))


def _compiled_functions():
    for module, tree in _modules():
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef) and any(
                    getattr(d, "id", getattr(d, "attr", None)) == "compiled"
                    for d in node.decorator_list):
                yield module, node


def test_no_compiled_function_takes_more_than_eight_parameters():
    counted = {f"{module}.{node.name}": len(node.args.args) for module, node in _compiled_functions()}
    assert len(counted) > 30  # every rule of the drill and of the teams' plans
    assert {k: v for k, v in counted.items() if v > MOST_PARAMETERS} == {}


def _imported_index_constants(module: str, tree: ast.AST) -> list[str]:
    """Integers that ``module`` imports by name from the rules' modules."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith(RULES):
            source = importlib.import_module(node.module)
            for alias in node.names:
                value = getattr(source, alias.name, None)
                if isinstance(value, int | np.integer) and not isinstance(value, bool):
                    found.append(f"{module}: {node.module}.{alias.name}")
    return found


def test_no_module_outside_the_rules_imports_an_index_constant_of_theirs():
    found = [entry for module, tree in _modules() if not module.startswith(RULES)
             for entry in _imported_index_constants(module, tree)]
    assert found == []
    planted = ast.parse("from soccer_drill.rules.support import RESAMPLE_CYCLES\n")
    assert _imported_index_constants("planted", planted) == [
        "planted: soccer_drill.rules.support.RESAMPLE_CYCLES"]


def test_the_rule_parameters_are_the_configurations_numbers_by_name():
    cfg = DrillConfig(control_radius=1.2, max_cycles=50)
    params = rule_parameters(cfg)[0]
    assert params["control_radius"] == 1.2 and params["max_cycles"] == 50
    assert params["sub_dt"] == cfg.cycle_seconds / cfg.substeps
    assert set(PARAMETERS.names) >= {"field_size", "attacker_speed", "roll", "lockout_cycles"}
    assert not rule_parameters(cfg).flags.writeable
    assert {"pos", "holder", "outcome"} <= set(STATE.names)
    assert {"skill", "target", "speed"} <= set(CYCLE.names)
