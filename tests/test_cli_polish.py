"""The commands' edges: bad flags refused in one line before any work, Ctrl-C in one line
with status 130, help that states every default, descriptions in plain text."""

from __future__ import annotations

import errno
import re
import sys
from pathlib import Path

import numpy as np
import pygame
import pytest

import soccer_drill.rendering.gif as gif
import soccer_drill.rendering.side_by_side as sbs
from ilpss.experiments import calibrate, cli, demo, power, results_doc
from ilpss.experiments.config import ExperimentConfig
from soccer_drill.rendering import gallery, play

ROOT = Path(__file__).resolve().parent.parent
PLAN = ROOT / "docs" / "decisive_test.json"


def _never(*args, **kwargs):
    raise AssertionError("the work began before the arguments were checked")


def _interrupted(*args, **kwargs):
    raise KeyboardInterrupt


def _refused(main, argv, capsys) -> str:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    return capsys.readouterr().err


# ------------------------------------------------------------------------ ilpss-power
@pytest.mark.parametrize(("argv", "named"), [
    (["--sims", "0"], "--sims must be an integer in [1, 1,000,000], got 0"),
    (["--sims", "-5"], "--sims must be an integer in [1, 1,000,000], got -5"),
    (["--sims", "100000000"], "got 100000000"),
    (["--sims", "1000000"], "draws per test"),
    (["--seeds", "S=-3"], "--seeds S must be an integer >= 2, got -3"),
    (["--seeds", "S=abc"], "--seeds S must be an integer >= 2, got 'abc'"),
    (["--seeds", "S=0"], "needs at least 2"),
    (["--seeds", "S=1"], "needs at least 2"),
    (["--seeds", "Z=10"], "no protocol 'Z'; its protocols: S, A, B, R"),
])
def test_power_refuses_bad_counts_naming_the_flag(monkeypatch, capsys, argv, named):
    monkeypatch.setattr(power, "plan_power", _never)
    err = _refused(power.main, [str(PLAN), *argv], capsys)
    assert named in err and "Traceback" not in err


def test_power_names_a_file_that_is_not_json_once(tmp_path, capsys):
    path = tmp_path / "episode.gif"
    path.write_bytes(b"GIF89a")
    err = _refused(power.main, [str(path)], capsys)
    assert err.count("episode.gif") == 1 and "not valid JSON" in err


def test_power_describes_itself_in_a_whole_sentence():
    assert power._parser().description.endswith("before a single seed of the run is spent.")


# ---------------------------------------------------------------------- ilpss-results
def test_results_from_missing_data_is_refused_and_creates_nothing(tmp_path, capsys):
    err = _refused(results_doc.main, ["--from-data", str(tmp_path / "nosuch"), "--docs",
                                      str(tmp_path / "fdx"), "--runs", str(tmp_path / "r")],
                   capsys)
    assert "--from-data" in err and "nosuch.json" in err and "Traceback" not in err
    assert sorted(tmp_path.iterdir()) == []


@pytest.mark.parametrize(("stem", "named"), [
    ("decisive_test", "protocol(s) S, which ilpss-results does not run"),
    ("larger_drill", "its protocol A runs scratch, finetune"),
])
def test_results_refuses_another_experiments_data(tmp_path, capsys, stem, named):
    err = _refused(results_doc.main, ["--from-data", str(ROOT / "docs" / "data" / stem),
                                      "--docs", str(tmp_path / "d"), "--runs",
                                      str(tmp_path / "r")], capsys)
    assert "another experiment's data" in err and named in err
    assert "protocols A, R, B and C" in err
    assert sorted(tmp_path.iterdir()) == []


def test_a_one_seed_protocol_is_said_in_the_singular():
    cfg = ExperimentConfig(protocol="A", n_seeds=1).with_overrides(
        lifelong={"train_episodes": 1, "rollout_episodes": 1, "n_kernels": 1})
    text = " ".join(results_doc.header(cfg, None, None, "c.json"))
    assert "1 seed, 1 learning episode per opponent, 1 greedy rollout per trial" in text
    assert "1 kernel." in text
    cfg = ExperimentConfig(protocol="A", n_seeds=30)
    assert "30 seeds, 300 learning episodes" in " ".join(results_doc.header(cfg, None, None,
                                                                            "c.json"))


@pytest.mark.parametrize("parser", [results_doc.parser, cli.parser])
def test_descriptions_show_no_rest_markup(parser):
    description = parser().description
    assert "``" not in description and ("ilpss-results" in description
                                        or "ilpss-experiment" in description)


# ------------------------------------------------------------------- ilpss-experiment
def test_a_method_given_twice_is_named(tmp_path, capsys):
    err = _refused(cli.main, ["--methods", "scratch", "scratch", "ilpss", "--out",
                              str(tmp_path / "o")], capsys)
    assert "--methods: 'scratch' is given twice" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(("argv", "named"), [
    (["--episodes", "3", "--set", "train_episodes=7"],
     "--episodes 3 and --set train_episodes=7 both set train_episodes"),
    (["--set", "train_episodes=7", "--episodes", "3"],
     "--episodes 3 and --set train_episodes=7 both set train_episodes"),
    (["--rollouts", "3", "--set", "rollout_episodes=7"],
     "--rollouts 3 and --set rollout_episodes=7 both set rollout_episodes"),
])
def test_a_flag_and_a_set_of_the_same_setting_are_refused(tmp_path, capsys, argv, named):
    err = _refused(cli.main, [*argv, "--out", str(tmp_path / "o")], capsys)
    assert named in err
    assert not (tmp_path / "o").exists()


def test_the_experiment_help_states_the_defaults():
    text = " ".join(cli.parser().format_help().split())
    for said in ("the protocol run (default A", "--first-seed FIRST_SEED the first seed",
                 "(default 0)", "where the jobs run: local (default)",
                 "opponents in the stream (default 20)"):
        assert said in text


# ---------------------------------------------------------------- ilpss-demo, calibrate
def test_the_demo_help_explains_every_flag_with_its_default(capsys):
    with pytest.raises(SystemExit):
        demo.main(["--help"])
    text = " ".join(capsys.readouterr().out.split())
    for said in ("(default 6)", "(default 300)", "(default 2)", "(default results/demo)"):
        assert said in text


def test_the_demo_creates_no_folder_for_bad_settings(tmp_path, capsys):
    err = _refused(demo.main, ["--seeds", "0", "--out", str(tmp_path / "o")], capsys)
    assert "n_seeds" in err and not (tmp_path / "o").exists()


def test_the_calibration_help_states_the_defaults():
    text = " ".join(calibrate._parser().format_help().split())
    for said in ("episodes per cell, at least 2 (default 500)",
                 "worker processes (default 2", "(seed 0; default 0: none)",
                 "episodes per family cell, at least 2 (default 100)"):
        assert said in text


def test_ctrl_c_stops_the_calibration_in_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(calibrate, "calibrate_all", _interrupted)
    assert calibrate.main(["--teams", "chasers", "--episodes", "2", "--out",
                           str(tmp_path)]) == 130
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "stopped by Ctrl-C" in err and "opponents.md" in err


# ---------------------------------------------------------------------- ilpss-compare
def test_a_label_with_a_bar_stays_in_its_cell():
    from ilpss import metrics
    from ilpss.experiments.compare import _table
    from ilpss.experiments.report_stats import threshold_for

    rng = np.random.default_rng(0)
    b = rng.uniform(-0.5, 0.4, size=(4, 12))
    est = metrics.compare(b + 0.5, b, first=3, last=3, threshold=threshold_for(b), window=3)
    head, _, row = _table({"a|b": est}, {"a|b": 1.0})
    assert row.startswith("| a\\|b |")
    cells = re.split(r"(?<!\\)\|", row)
    assert len(cells) == len(head.split("|"))


# ------------------------------------------------------------------- soccer-drill-gif
def test_the_gif_help_explains_every_flag(capsys):
    with pytest.raises(SystemExit):
        gif.main(["--help"])
    text = " ".join(capsys.readouterr().out.split())
    for said in ("the episode's seed", "(default 0)", "the fixed holder rule",
                 "(default pass_first)", "(default episode.gif)"):
        assert said in text


def test_a_folder_that_takes_no_file_is_refused_before_the_episode(tmp_path, monkeypatch,
                                                                    capsys):
    def refused(*args, **kwargs):
        raise OSError(errno.EROFS, "Read-only file system")

    monkeypatch.setattr(gif, "record_episode", _never)
    monkeypatch.setattr(gif.tempfile, "mkstemp", refused)
    err = _refused(gif.main, ["-o", str(tmp_path / "x.gif")], capsys)
    assert "takes no new file (Read-only file system)" in err
    assert sorted(tmp_path.iterdir()) == []


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="no /proc file system")
def test_a_gif_into_proc_is_refused_before_the_episode(monkeypatch, capsys):
    monkeypatch.setattr(gif, "record_episode", _never)
    err = _refused(gif.main, ["-o", "/proc/x.gif"], capsys)
    assert "/proc" in err


def test_ctrl_c_stops_the_gif_in_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(gif, "record_episode", _interrupted)
    out = tmp_path / "x.gif"
    with pytest.raises(SystemExit) as exc:
        gif.main(["-o", str(out)])
    assert exc.value.code == 130
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "stopped by Ctrl-C" in err and "not written" in err
    assert not out.exists()


# ---------------------------------------------------------- soccer-drill-side-by-side
def test_the_side_by_side_help_states_the_defaults(capsys):
    with pytest.raises(SystemExit):
        sbs.main(["--help"])
    text = " ".join(capsys.readouterr().out.split())
    for said in ("; default goal_guards)", "in turn (default 0)", "(default 10, true speed)",
                 "(default side_by_side.gif)"):
        assert said in text


def test_an_mp4_without_its_writer_is_refused_before_the_episodes(tmp_path, monkeypatch,
                                                                  capsys):
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)  # as if not installed
    monkeypatch.setattr(sbs, "panel_frames", _never)
    out = tmp_path / "x.mp4"
    assert sbs.main(["--policy", "pass_first", "--policy", "hold", "-o", str(out)]) == 1
    assert "moviepy" in capsys.readouterr().err and not out.exists()


def test_ctrl_c_stops_the_side_by_side_in_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(sbs, "panel_frames", _interrupted)
    with pytest.raises(SystemExit) as exc:
        sbs.main(["--policy", "pass_first", "--policy", "hold", "-o", str(tmp_path / "x.gif")])
    assert exc.value.code == 130
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "stopped by Ctrl-C" in err


# -------------------------------------------------------------- soccer-drill-gallery
def test_missing_notebooks_are_refused_before_any_gif(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(gallery, "write_episode_gif", _never)
    err = _refused(gallery.main, ["--docs", str(tmp_path), "--notebooks",
                                  str(tmp_path / "nosuch_nb")], capsys)
    assert "--notebooks" in err and "01_drill_tour.ipynb" in err
    assert sorted(tmp_path.iterdir()) == []


def test_the_gallery_help_states_the_docs_default(capsys):
    with pytest.raises(SystemExit):
        gallery.main(["--help"])
    assert "; default docs)" in " ".join(capsys.readouterr().out.split())


def test_ctrl_c_stops_the_gallery_in_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(gallery, "write_episode_gif", _interrupted)
    with pytest.raises(SystemExit) as exc:
        gallery.main(["--docs", str(tmp_path)])
    assert exc.value.code == 130
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "stopped by Ctrl-C" in err and "kept" in err


# ----------------------------------------------------------------- soccer-drill-play
@pytest.fixture
def linux_without_display(monkeypatch):
    for name in ("DISPLAY", "WAYLAND_DISPLAY", "SDL_VIDEODRIVER"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.setattr(play, "_key", _never)  # waiting for a key no one can press


def test_play_without_a_display_says_so(linux_without_display, capsys):
    assert play.main([]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "neither DISPLAY nor WAYLAND_DISPLAY" in err


@pytest.mark.parametrize("driver", ["dummy", "offscreen"])
def test_play_with_a_windowless_driver_says_so(linux_without_display, monkeypatch, capsys,
                                               driver):
    monkeypatch.setenv("SDL_VIDEODRIVER", driver)
    assert play.main([]) == 1
    assert f"SDL_VIDEODRIVER={driver} shows no window" in capsys.readouterr().err


def test_play_refuses_sdls_fallback_to_offscreen(linux_without_display, monkeypatch, capsys):
    monkeypatch.setenv("DISPLAY", ":99")  # set, but SDL found no display there
    monkeypatch.setattr(pygame.display, "init", lambda: None)
    monkeypatch.setattr(pygame.display, "quit", lambda: None)
    monkeypatch.setattr(pygame.display, "get_driver", lambda: "offscreen")
    assert play.main([]) == 1
    assert "chose its offscreen driver" in capsys.readouterr().err


def test_the_api_without_keys_refuses_a_windowless_driver(linux_without_display, monkeypatch):
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    with pytest.raises(ValueError, match="SDL_VIDEODRIVER=dummy shows no window"):
        play.play("chasers", episodes=1)


def test_ctrl_c_stops_play_in_one_line(monkeypatch, capsys):
    monkeypatch.setattr(play, "play", _interrupted)
    assert play.main([]) == 130
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "stopped by Ctrl-C" in err


def test_confirm_names_a_plan_that_is_not_json_once(tmp_path, capsys):
    # before, "episode.gif: episode.gif: not valid JSON"
    from ilpss.experiments import confirm

    plan = tmp_path / "episode.gif"
    plan.write_bytes(b"GIF89a")
    with pytest.raises(SystemExit):
        confirm.main([str(plan), "--runs", str(tmp_path / "r")])
    err = capsys.readouterr().err
    assert err.count(str(plan)) == 1 and "not valid JSON" in err


def test_counts_in_report_titles_are_singular_for_one():
    from ilpss.experiments.report_text import counted

    assert [counted(n, "seed") for n in (0, 1, 2)] == ["0 seeds", "1 seed", "2 seeds"]


def test_the_ray_executor_without_ray_is_a_usage_error_before_any_folder(
        tmp_path, monkeypatch, capsys):
    """Before, ilpss-experiment made the run folder and its files, then failed with a
    two-part ImportError traceback."""
    import sys

    from ilpss.experiments import cli

    monkeypatch.setitem(sys.modules, "ray", None)  # as if Ray were not installed
    out = tmp_path / "run"
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["--protocol", "A", "--seeds", "1", "--episodes", "2", "--rollouts", "1",
                  "--methods", "scratch", "--executor", "ray", "--out", str(out)])
    assert exit_info.value.code == 2
    assert ("--executor ray needs Ray, which is not installed here: pip install "
            "'soccer-drill-ilpss[ray]'") in capsys.readouterr().err
    assert not out.exists()
