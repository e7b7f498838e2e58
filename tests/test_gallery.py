"""The documentation's GIFs and the README's leading picture are the code's:
``soccer-drill-gallery`` writes them byte for byte, and the pages say what they show."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from soccer_drill.rendering import gallery

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"


def test_the_opponents_page_states_each_gallery_gifs_rule_and_seed():
    text = (DOCS / "opponents.md").read_text(encoding="utf-8")
    for team, (rule, seed) in gallery.GALLERY.items():
        section = text.split(f"### {team}\n", 1)[1].split("###", 1)[0]
        assert re.search(rf"Holder rule `{rule}`.*seed {seed}:", section), team
        assert f"(gifs/{team}.gif)" in section


def test_the_readme_leads_with_the_side_by_side_picture():
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    first_image = next(line for line in lines if line.startswith("!["))
    assert "(docs/gifs/side_by_side.gif)" in first_image
    assert lines.index(first_image) < 5


@pytest.mark.slow
def test_the_gallery_command_writes_the_committed_gifs(tmp_path):
    (tmp_path / "gifs").mkdir()
    assert gallery.main(["--docs", str(tmp_path)]) == 0
    written = sorted(p.name for p in (tmp_path / "gifs").iterdir())
    assert written == sorted([*(f"{t}.gif" for t in gallery.GALLERY), "side_by_side.gif"])
    for name in written:
        new, old = (tmp_path / "gifs" / name).read_bytes(), (DOCS / "gifs" / name).read_bytes()
        assert new == old, f"docs/gifs/{name} is not what soccer-drill-gallery writes"
        assert len(new) < 400_000, name  # the repository stays small


@pytest.mark.parametrize("blocked", ["chasers.gif", "side_by_side.gif"])
def test_an_output_that_cannot_be_written_is_refused_before_any_episode(tmp_path, monkeypatch, capsys,
                                                                        blocked):
    (tmp_path / "gifs" / blocked).mkdir(parents=True)  # a folder where a GIF goes
    played = []
    monkeypatch.setattr(gallery, "write_episode_gif", lambda *a, **k: played.append(a))
    monkeypatch.setattr(gallery, "write_side_by_side", lambda *a, **k: played.append(a))
    with pytest.raises(SystemExit) as stopped:
        gallery.main(["--docs", str(tmp_path)])
    assert stopped.value.code == 2
    assert "the output must name a file, got the folder" in capsys.readouterr().err
    assert played == []  # refused before the first GIF, so no part of the gallery is rewritten
    assert sorted(p.name for p in (tmp_path / "gifs").iterdir()) == [blocked]
