"""``soccer-drill-gif`` checks what it is given before it plays the episode, names what
was wrong and what is allowed, and writes frames at true speed."""

from __future__ import annotations

import errno
import os

import numpy as np
import pytest
from PIL import Image

import soccer_drill.rendering.gif as gif
from soccer_drill.rendering.gif import main


@pytest.fixture
def no_episode(monkeypatch):
    """Fail the test if an episode is played: every check must come before it."""
    def played(*args, **kwargs):
        raise AssertionError("the episode was played before the arguments were checked")

    monkeypatch.setattr(gif, "record_episode", played)


def _error(capsys) -> str:
    return capsys.readouterr().err


def test_an_output_under_a_file_is_refused_before_the_episode(tmp_path, capsys, no_episode):
    (tmp_path / "file").write_text("x")
    with pytest.raises(SystemExit) as exit_:
        main(["--out", str(tmp_path / "file" / "x.gif")])
    assert exit_.value.code == 2
    assert "is a file, not a folder" in _error(capsys)


@pytest.mark.parametrize("name", ["dir/", "existing"])
def test_an_output_that_is_a_folder_is_refused(tmp_path, capsys, no_episode, monkeypatch, name):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "existing").mkdir()
    with pytest.raises(SystemExit):
        main(["-o", name])
    assert f"the output must name a file, got the folder {name!r}" in _error(capsys)
    assert not (tmp_path / "dir").exists()


def test_an_unknown_team_is_refused_with_the_known_ones(capsys, no_episode):
    with pytest.raises(SystemExit):
        main(["--team", "nope"])
    err = _error(capsys)
    assert "invalid choice: 'nope'" in err and "'chasers'" in err


@pytest.mark.parametrize("fps", ["0", "1000", "-3", "nan", "ten"])
def test_fps_outside_what_a_gif_plays_is_refused(capsys, no_episode, fps):
    with pytest.raises(SystemExit):
        main(["--fps", fps])
    err = _error(capsys)
    assert "fps must be a finite number in [1, 50], got" in err and "frames per second" in err


@pytest.mark.parametrize("seed", ["-1", "1.5", "ten", str(2**63)])
def test_a_seed_outside_what_reset_takes_is_refused(capsys, no_episode, seed):
    with pytest.raises(SystemExit) as exit_:
        main(["--seed", seed])
    assert exit_.value.code == 2
    assert "seed must be an integer in [0, 9,223,372,036,854,775,807], got" in _error(capsys)


def test_the_gif_plays_at_true_speed_by_default(tmp_path, capsys):
    path = tmp_path / "out" / "episode.gif"
    assert main(["-o", str(path), "--seed", "1"]) == 0
    with Image.open(path) as image:
        assert image.info["duration"] == 100  # ms: one 0.1 s cycle per frame
        assert image.n_frames > 10
    assert "wrote" in capsys.readouterr().out


def test_a_full_disk_names_the_file_and_leaves_nothing(tmp_path, capsys, monkeypatch):
    def full(fd):  # the file system reports the full disk when the bytes are flushed
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "fsync", full)
    path = tmp_path / "episode.gif"
    assert main(["-o", str(path), "--seed", "1"]) == 1
    err = _error(capsys)
    assert "No space left on device" in err and str(path) in err
    assert list(tmp_path.iterdir()) == []  # no temporary left behind


def test_save_gif_checks_fps_and_path(tmp_path):
    frame = [np.zeros((4, 4, 3), np.uint8)]
    with pytest.raises(ValueError, match=r"fps must be a finite number in \[1, 50\], got .* \(frames per second"):
        gif.save_gif(frame, tmp_path / "a.gif", fps=1000)
    with pytest.raises(ValueError, match="the output must name a file"):
        gif.save_gif(frame, tmp_path, fps=10)
