"""Every module of the three packages has one name: it imports at its path only, and
``importlib.reload`` (IPython's autoreload) runs it again.

An import hook that aliased old module paths to new ones used to make a module's
``__spec__`` name the old path once that path was imported first, after which reloading
the module at its own path did nothing. Old paths now fail to import.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

_RELOAD_ALL = textwrap.dedent("""
    import importlib, pkgutil, sys, types

    OLD = ["soccer_drill.holder", "soccer_drill.env", "soccer_drill.batch_teams",
           "soccer_drill.features", "soccer_drill.gif", "soccer_drill.vector_agents"]
    still = []
    for old in OLD:  # a path from before the subpackages: gone, whatever is imported next
        try:
            importlib.import_module(old)
        except ImportError:
            pass
        else:
            still.append(f"{old} still imports")
    names = []
    for package in ("soccer_drill", "opponents", "ilpss"):
        root = importlib.import_module(package)
        names.append(package)
        for info in pkgutil.walk_packages(root.__path__, package + "."):
            if ".reference" in info.name or info.name.endswith(".sb3"):
                continue  # torch and stable-baselines3 are optional
            names.append(info.name)
    for name in names:
        importlib.import_module(name)
    not_reloaded = still
    for name in names:
        module = sys.modules[name]
        if module.__spec__ is None or module.__spec__.name != name:
            not_reloaded.append(f"{name}: __spec__ names {module.__spec__ and module.__spec__.name}")
            continue
        functions = {k: v for k, v in vars(module).items()
                     if isinstance(v, types.FunctionType) and v.__module__ == name}
        again = importlib.reload(module)
        if again is not module or any(vars(module)[k] is v for k, v in functions.items()):
            not_reloaded.append(f"{name}: reload did not run it again")
    print(len(names))
    if not_reloaded:
        raise SystemExit("\\n".join(not_reloaded))
""")


def test_old_paths_do_not_import_and_every_module_reloads():
    done = subprocess.run([sys.executable, "-c", _RELOAD_ALL], cwd=ROOT, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    assert int(done.stdout.split()[-1]) > 80  # every module was tried
