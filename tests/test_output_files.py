"""Every page and GIF the commands write goes through a fresh temporary beside it: a link
planted at a predictable temporary name never leads the write outside the folder."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from benchmark_scripts import load_benchmark

from ilpss.experiments.calibrate import Cell, write_markdown
from ilpss.experiments.region_check import write_page
from opponents import PAPER_TEAMS
from soccer_drill.files import TEMPORARY, atomic_write_text
from soccer_drill.policies import HOLDER_POLICIES
from soccer_drill.rendering.gif import save_gif


def _calibration_page(path: Path) -> None:
    cells = {(t, r): Cell(t, r, 50, 100, 0.1, 0.0, 0.2)
             for t in PAPER_TEAMS for r in HOLDER_POLICIES}
    write_markdown(cells, 100, path, gifs={})


# Each writer, and the temporary name it used to write through (the one an attacker
# who can write into the folder would plant a link at).
WRITERS = {
    "GIF": ("episode.gif", ".episode.gif.tmp",
            lambda path: save_gif([np.zeros((4, 4, 3), np.uint8)] * 2, path, fps=10)),
    "calibration page": ("opponents.md", ".opponents.md.tmp", _calibration_page),
    "pre-check page": ("regions.md", ".regions.md.tmp",
                       lambda path: write_page({}, [], 4, path, "cmd")),
    "soak section": ("reliability.md", f".reliability.md.{os.getpid()}.tmp",
                     lambda path: load_benchmark("soak").write_section(path, "soak\n")),
}


@pytest.mark.parametrize("writer", WRITERS)
def test_a_link_planted_at_the_temporary_does_not_lead_the_write_outside(tmp_path, writer):
    name, temporary, write = WRITERS[writer]
    folder, outside = tmp_path / "out", tmp_path / "elsewhere.txt"
    folder.mkdir()
    outside.write_text("not yours")
    (folder / temporary).symlink_to(outside)
    write(folder / name)
    assert outside.read_text() == "not yours"
    assert (folder / name).is_file() and not (folder / name).is_symlink()
    assert (folder / name).stat().st_size > 0
    # nothing of the write is left beside the page, and the planted link is untouched
    assert sorted(p.name for p in folder.iterdir()) == sorted([name, temporary])


def test_text_is_written_whole_with_its_folders_and_a_temporary_of_the_shared_pattern(
        tmp_path, monkeypatch):
    seen = []
    real_replace = os.replace

    def replace(src, dst):
        seen.append(Path(src).name)
        real_replace(src, dst)

    monkeypatch.setattr(os, "replace", replace)
    path = atomic_write_text(tmp_path / "a" / "b" / "page.md", "é\n")
    assert path.read_bytes() == "é\n".encode()
    (temporary,) = seen
    assert TEMPORARY.fullmatch(temporary) and temporary.startswith(".page.md.")
