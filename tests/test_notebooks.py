"""The notebooks run top to bottom in a fresh kernel of this interpreter, without error.

Each notebook is executed with nbclient in an empty working directory and must leave it
empty (notebooks write only to temporary folders). The committed files carry their outputs
(figures and GIFs inline, for a reader browsing them), as ``soccer-drill-gallery
--notebooks`` writes them: every code cell run once in order, without error; the drill
tour's outputs are exactly what running it again gives. The kernel is "python3", made to resolve to ``sys.executable``: if the installed
python3 kernelspec would start another interpreter, a temporary kernelspec that starts
this one is put first on ``JUPYTER_PATH``.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import nbformat
import pytest
from jupyter_client.kernelspec import KernelSpecManager, NoSuchKernel
from nbclient import NotebookClient

from soccer_drill.rendering.gallery import without_warnings

pytestmark = pytest.mark.slow  # executes the notebooks

NOTEBOOKS = Path(__file__).resolve().parent.parent / "notebooks"
NAMES = ("01_drill_tour.ipynb", "02_ilpss_step_by_step.ipynb")
KERNEL = "python3"
TIMEOUT = 600  # seconds per cell
# jupyter_client starts sys.executable for a kernelspec whose argv[0] is one of these.
_ALIASES = {"python", f"python{sys.version_info[0]}", "python{}.{}".format(*sys.version_info[:2])}


def _starts_this_interpreter(argv0: str | None) -> bool:
    if argv0 is None:
        return False
    if argv0 in _ALIASES:
        return True
    return os.path.abspath(argv0) == os.path.abspath(sys.executable)


@pytest.fixture
def kernel_name(tmp_path, monkeypatch) -> str:
    """``"python3"``, resolving to this interpreter (with a temporary kernelspec if need be)."""
    try:
        argv0 = KernelSpecManager().get_kernel_spec(KERNEL).argv[0]
    except NoSuchKernel:
        argv0 = None
    if not _starts_this_interpreter(argv0):
        spec_dir = tmp_path / "jupyter" / "kernels" / KERNEL
        spec_dir.mkdir(parents=True)
        spec = {
            "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
            "display_name": "Python 3 (test interpreter)",
            "language": "python",
        }
        (spec_dir / "kernel.json").write_text(json.dumps(spec))
        paths = [str(tmp_path / "jupyter"), os.environ.get("JUPYTER_PATH", "")]
        monkeypatch.setenv("JUPYTER_PATH", os.pathsep.join(p for p in paths if p))
        assert KernelSpecManager().get_kernel_spec(KERNEL).argv[0] == sys.executable
    return KERNEL


def _execute(name: str, kernel: str, workdir: Path) -> nbformat.NotebookNode:
    """Run a copy of the notebook in ``workdir``; return it with outputs."""
    nb = nbformat.read(NOTEBOOKS / name, as_version=4)
    # A last cell proves which interpreter ran the notebook.
    nb.cells.append(nbformat.v4.new_code_cell("import sys\nprint(sys.executable, end='')"))
    client = NotebookClient(
        nb, timeout=TIMEOUT, kernel_name=kernel,
        resources={"metadata": {"path": str(workdir)}},
    )
    client.execute()  # raises CellExecutionError on the first failing cell
    return nb


def _text_outputs(nb: nbformat.NotebookNode) -> list[str]:
    """Every output of the notebook, as text (images as their encoded bytes).

    Consecutive stream outputs of a cell are joined: how the kernel splits printed text
    into messages depends on timing (a loaded machine splits more), not on the notebook.
    """
    out = []
    for cell in nb.cells:
        stream = None
        for output in cell.get("outputs", []):
            if output.output_type == "stream":
                if stream == output.name:
                    out[-1] += output.text
                else:
                    out.append(output.text)
                stream = output.name
                continue
            stream = None
            if "data" in output:
                out.append(json.dumps(output.data, sort_keys=True))
            else:
                out.append(json.dumps(output, sort_keys=True, default=str))
    return out


IMAGES = ("image/png", "image/gif")


@pytest.mark.parametrize("name", NAMES)
def test_notebook_is_committed_with_its_outputs(name):
    nb = nbformat.read(NOTEBOOKS / name, as_version=4)
    nbformat.validate(nb)
    assert nb.metadata["kernelspec"]["name"] == KERNEL
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert code, f"{name} has no code cells"
    assert [c.execution_count for c in code] == list(range(1, len(code) + 1)), (
        f"{name}: run every cell once, in order (soccer-drill-gallery --notebooks)")
    outputs = [o for c in code for o in c.outputs]
    assert not [o for o in outputs if o.output_type == "error"], f"{name}: an error was kept"
    assert any(kind in o.get("data", {}) for o in outputs for kind in IMAGES), (
        f"{name}: no figure or GIF inline")
    assert "SDL_VIDEODRIVER" in code[0].source, f"{name}: set SDL_VIDEODRIVER=dummy first"


@pytest.mark.parametrize("name", NAMES)
def test_notebook_runs_and_writes_nothing_outside_temporary_folders(name, kernel_name, tmp_path):
    workdir = tmp_path / "work"
    workdir.mkdir()
    before = sorted(p.name for p in NOTEBOOKS.iterdir())
    nb = _execute(name, kernel_name, workdir)
    assert nb.cells[-1].outputs[0].text == sys.executable, "the notebook ran another interpreter"
    errors = [o for c in nb.cells for o in c.get("outputs", []) if o.output_type == "error"]
    assert not errors
    assert sorted(p.name for p in workdir.iterdir()) == [], "wrote into its working directory"
    assert sorted(p.name for p in NOTEBOOKS.iterdir()) == before, "wrote into notebooks/"


def test_drill_tour_is_deterministic(kernel_name, tmp_path):
    """Running the drill tour prints and draws exactly what its committed outputs hold
    (the cell this test appends aside)."""
    name = NAMES[0]
    ran = _execute(name, kernel_name, tmp_path)
    ran.cells.pop()
    without_warnings(ran)  # as the gallery writes it
    assert _text_outputs(ran) == _text_outputs(nbformat.read(NOTEBOOKS / name, as_version=4))
