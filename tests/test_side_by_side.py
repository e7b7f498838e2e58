"""``soccer-drill-side-by-side``: panels of policies on the same episode seeds."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest
from PIL import Image

import soccer_drill
from soccer_drill.rendering import side_by_side as sbs
from soccer_drill.rendering.draw import HEADER


def _alone(policy: str, team: str, seed: int) -> list[np.ndarray]:
    """The frames of ``policy`` on ``seed`` played alone."""
    def make():
        return soccer_drill.HolderEnv(opponent=team, render_mode="rgb_array_list")
    return sbs.panel_frames(sbs.policy_panel(policy), make, seed)


def _gif(path) -> list[np.ndarray]:
    """A 10 fps GIF's frames, each as many times as its duration says (the writer merges
    identical frames into one of a longer duration)."""
    image = Image.open(path)
    frames = []
    for k in range(image.n_frames):
        image.seek(k)
        frames += [np.asarray(image.convert("RGB"))] * round(image.info["duration"] / 100)
    return frames


def test_each_panel_is_its_policy_played_alone_on_the_same_seed(tmp_path):
    out = tmp_path / "two.gif"
    assert sbs.main(["--team", "chasers", "--policy", "pass_first", "--policy",
                     "dribble", "--seeds", "4", "-o", str(out)]) == 0
    left, right = _alone("pass_first", "chasers", 4), _alone("dribble", "chasers", 4)
    frames = _gif(out)
    width = left[0].shape[1]
    assert len(frames) == max(len(left), len(right)) + sbs.LINGER
    assert frames[0].shape == (left[0].shape[0], 2 * width + 6, 3)
    for t, frame in enumerate(frames):
        assert np.array_equal(frame[:, :width], left[min(t, len(left) - 1)])
        assert np.array_equal(frame[:, width + 6:], right[min(t, len(right) - 1)])
    # The same seed: the same start, the headers (naming the policies) aside.
    assert np.array_equal(frames[0][HEADER:, :width], frames[0][HEADER:, width + 6:])
    assert not np.array_equal(frames[0][:HEADER, :width], frames[0][:HEADER, width + 6:])


def test_seeds_are_played_in_turn(tmp_path):
    out = tmp_path / "seeds.gif"
    sbs.main(["--team", "chasers", "--policy", "hold", "--policy", "pass_first",
              "--seeds", "1", "2", "-o", str(out)])
    lengths = [max(len(_alone("hold", "chasers", s)), len(_alone("pass_first",
                                                                        "chasers", s)))
               for s in (1, 2)]
    assert len(_gif(out)) == sum(lengths) + 2 * sbs.LINGER


@pytest.mark.parametrize("argv, message", [
    (["--policy", "pass_first"], "at least two policies"),
    (["--policy", "pass_first", "--policy", "hold", "-o", "x.png"], "must end in"),
])
def test_bad_commands_are_refused_before_any_episode(argv, message, capsys, tmp_path):
    with pytest.raises(SystemExit) as exc:
        sbs.main(argv)
    assert exc.value.code == 2
    assert message in capsys.readouterr().err


@pytest.mark.skipif(importlib.util.find_spec("imageio_ffmpeg") is not None,
                    reason="the video extra is installed")
def test_an_mp4_without_moviepy_says_what_to_install(tmp_path, capsys):
    out = tmp_path / "x.mp4"
    assert sbs.main(["--team", "chasers", "--policy", "pass_first", "--policy",
                     "hold", "-o", str(out)]) == 1
    assert "moviepy" in capsys.readouterr().err and not out.exists()


def test_an_mp4_holds_every_frame_of_the_panels(tmp_path):
    imageio_ffmpeg = pytest.importorskip(
        "imageio_ffmpeg", reason="an MP4 needs the video extra (pip install -e '.[video]'), "
        "not installed")

    out = tmp_path / "two.mp4"
    assert sbs.main(["--team", "chasers", "--policy", "pass_first", "--policy", "dribble",
                     "--seeds", "4", "-o", str(out)]) == 0
    left, right = _alone("pass_first", "chasers", 4), _alone("dribble", "chasers", 4)
    frames, seconds = imageio_ffmpeg.count_frames_and_secs(str(out))
    assert frames == max(len(left), len(right)) + sbs.LINGER
    assert seconds == pytest.approx(frames / 10, abs=0.1 + 1e-6)  # 10 fps, the default
    reader = imageio_ffmpeg.read_frames(str(out))
    meta = next(reader)
    assert tuple(meta["size"]) == (2 * left[0].shape[1] + 6, left[0].shape[0])
    reader.close()
    assert not list(tmp_path.glob(".*partial*"))  # written in place of a partial file


@pytest.mark.parametrize("size", [(9, 14), (10, 15), (11, 13)])
def test_an_mp4_of_odd_sized_frames_keeps_every_frame(tmp_path, size):
    imageio_ffmpeg = pytest.importorskip(
        "imageio_ffmpeg", reason="an MP4 needs the video extra (pip install -e '.[video]'), "
        "not installed")
    frames = [np.full((*size, 3), 20 * k, dtype=np.uint8) for k in range(7)]
    out = sbs._write_mp4(frames, tmp_path / "odd.mp4", 10)
    assert imageio_ffmpeg.count_frames_and_secs(str(out))[0] == 7
    reader = imageio_ffmpeg.read_frames(str(out))
    assert tuple(next(reader)["size"]) == (size[1] + size[1] % 2, size[0] + size[0] % 2)
    reader.close()
