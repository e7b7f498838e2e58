"""Registrations that do not depend on import order: a fresh interpreter that imports only
a registry's module knows every name that importing the whole project registers in it."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow

# Every registry the three packages' modules define, as {"module:ATTRIBUTE": names}: one
# object is listed once, under the module whose top level assigns it (its own), whether
# or not that module's __all__ names it.
_EVERY_REGISTRY = """
import ast, importlib, json, pkgutil
import ilpss, opponents, soccer_drill
found = {}
for package in (soccer_drill, opponents, ilpss):
    for info in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
        try:
            module = importlib.import_module(info.name)
        except ImportError:  # an optional dependency (torch, stable-baselines3)
            continue
        with open(module.__file__, encoding="utf-8") as source:
            body = ast.parse(source.read()).body
        assigned = sorted({target.id for node in body if isinstance(node, (ast.Assign, ast.AnnAssign))
                           for target in (node.targets if isinstance(node, ast.Assign) else [node.target])
                           if isinstance(target, ast.Name)})
        for attribute in assigned:
            registry = getattr(module, attribute, None)
            if type(registry).__name__ == "Registry":
                found.setdefault(id(registry), (f"{info.name}:{attribute}", registry))
print(json.dumps({spec: registry.names() for spec, registry in found.values()}))
"""

_ONE_REGISTRY = """
import importlib, json, sys
module, attribute = sys.argv[1].split(":")
print(json.dumps(getattr(importlib.import_module(module), attribute).names()))
"""


def _run(code: str, *args: str) -> object:
    out = subprocess.run([sys.executable, "-c", code, *args], capture_output=True,
                         text=True, check=True, timeout=300)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_a_registry_alone_knows_every_name_the_project_registers():
    everything = _run(_EVERY_REGISTRY)
    assert {"ilpss.reuse:REUSES", "ilpss.experiments.methods:METHODS",
            "ilpss.experiments.protocols:PROTOCOLS", "soccer_drill.teams.registry:TEAMS"} <= set(
        everything)
    for spec, names in everything.items():
        assert _run(_ONE_REGISTRY, spec) == names, spec


def test_the_oracles_reuses_are_valid_in_a_fresh_interpreter_that_imports_only_lifelong():
    """The oracles' reuses are declared in ``ilpss.experiments.oracles``, above
    ``ilpss.reuse``: as entry points of ``ilpss.reuses``, not registered on import."""
    code = """
import json, sys
from ilpss.lifelong import LifelongConfig
reuses = [LifelongConfig(options=name).reuse for name in (
    "oracle_regions_finetune", "true_regions_finetune", "assigned_regions_finetune")]
print(json.dumps([[r.name, r.model_name, r.offer is not None] for r in reuses]))
"""
    assert _run(code) == [["oracle_regions_finetune", "RegionKernels", False],
                          ["true_regions_finetune", "RegionKernels", True],
                          ["assigned_regions_finetune", "RegionKernels", True]]


def test_a_plugin_declaring_the_projects_own_names_is_refused_not_fatal(tmp_path):
    # before, a plugin declaring "scratch" (a method), "Kernels" (like the reuse
    # "kernels") or "A" (a protocol) stopped ilpss from importing: the project's own
    # registration at import met the plugin's declaration and raised
    info = tmp_path / "clash-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: clash\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[ilpss.methods]\nscratch = clash_mod:M\n[ilpss.reuses]\nKernels = clash_mod:R\n"
        "[ilpss.protocols]\nA = clash_mod:P\n")
    code = ("import warnings; warnings.simplefilter('always')\n"
            "from ilpss.experiments.methods import METHODS\n"
            "from ilpss.experiments.protocols import PROTOCOLS\n"
            "from ilpss.reuse import REUSES\n"
            "print(type(METHODS.get('scratch')).__name__, 'kernels' in REUSES.names(),"
            " 'Kernels' in REUSES.names(), PROTOCOLS.get('A').name)\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env={**os.environ, "PYTHONPATH": os.pathsep.join(
                             [str(tmp_path), *sys.path])}, check=False)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.split() == ["LifelongMethod", "True", "False", "A"]
    for said in ("method 'scratch' of distribution 'clash'", "reuse 'Kernels' of distribution "
                 "'clash'", "protocol 'A' of distribution 'clash'"):
        assert said in run.stderr and "is refused" in run.stderr
