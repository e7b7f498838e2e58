"""The experiment runner end to end on a tiny budget: results, resume, report, config."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from ilpss.experiments.cli import main as cli_main
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.report import write_report
from ilpss.experiments.run import run_experiment

pytestmark = pytest.mark.slow  # runs experiments end to end


def _tiny(**changes) -> ExperimentConfig:
    cfg = ExperimentConfig(n_seeds=2, workers=1, **changes)
    return cfg.with_overrides(lifelong={"train_episodes": 6, "rollout_episodes": 3, "n_kernels": 2})


def test_protocol_a_runs_resumes_identically_and_reports(tmp_path):
    cfg = _tiny()
    first = run_experiment(cfg, tmp_path, progress=False)
    assert [r["seed"] for r in first] == [0, 1]
    for result in first:
        assert set(result["methods"]) == set(ExperimentConfig().methods)
        for method in result["methods"].values():
            assert list(method["curves"]) == ["3"] and len(method["curves"]["3"]) == 6
    # An interrupted seed: its result is gone and its last trial's checkpoint too.
    seed_dir = tmp_path / "seed_001" / "stream_00"
    (seed_dir / "result.json").unlink()
    ilpss_dir = seed_dir / "ilpss"
    latest = (ilpss_dir / "LATEST").read_text()
    shutil.rmtree(ilpss_dir)  # lose the lifelong state entirely for one method
    again = run_experiment(cfg, tmp_path, progress=False)
    assert again == first and latest
    report = write_report(cfg, again, tmp_path)
    text = report.read_text()
    assert "### Verdicts" in text and "Holm-adjusted p" in text and "| jumpstart |" in text
    assert (tmp_path / "curves_00.png").stat().st_size > 0


def test_a_different_configuration_is_refused_in_the_same_folder(tmp_path):
    run_experiment(_tiny(methods=("scratch",)), tmp_path, progress=False)
    with pytest.raises(ValueError, match="different configuration"):
        run_experiment(_tiny(methods=("ilpss", "scratch")), tmp_path, progress=False)
    # Where seeds run does not matter.
    run_experiment(_tiny(methods=("scratch",)).with_overrides(workers=2), tmp_path, progress=False)


def test_protocols_b_and_c_build_their_streams():
    b = ExperimentConfig(protocol="B", n_shuffles=1)
    streams = b.streams(seed=0)
    assert len(streams) == 8  # 4 held-out teams x (paper order + 1 shuffle)
    assert {s.tasks[-1].name for s in streams} == set(b.teams)
    assert streams == b.streams(seed=0) and streams != b.streams(seed=1)
    c = ExperimentConfig(protocol="C", stream_length=21)
    (stream,) = c.streams(seed=0)
    assert len(stream.tasks) == 21 and stream.first_target == 1
    assert all(t.env_kwargs["opponent"] == "parametric" for t in stream.tasks)


def test_protocol_c_reports_library_size(tmp_path):
    cfg = _tiny(protocol="C", stream_length=3, methods=("ilpss", "scratch", "ilpss_no_discount"))
    results = run_experiment(cfg, tmp_path, progress=False)
    report = write_report(cfg, results, tmp_path).read_text()
    assert "Jumpstart on each new opponent" in report
    assert (tmp_path / "stream.png").exists()
    # pooled primary verdicts, one trend test per method, and the score distributions
    assert "Primary endpoints (pooled)" in report and report.count("**Along the stream**") == 2
    assert "![score distributions](profiles.png)" in report
    assert (tmp_path / "profiles.png").stat().st_size > 0


def test_configuration_round_trip_and_errors(tmp_path):
    cfg = _tiny(protocol="B")
    assert ExperimentConfig.from_dict(json.loads(cfg.to_json())) == cfg
    with pytest.raises(ValueError, match=r"methods must name a registered method .*'magic'"):
        ExperimentConfig(methods=("magic",))
    with pytest.raises(ValueError, match=r"method 'prq' reuses the learners of \['scratch'\]"):
        ExperimentConfig(methods=("ilpss", "prq"))
    with pytest.raises(ValueError, match=r"unknown ExperimentConfig field\(s\) \['seeds'\]"):
        ExperimentConfig.from_dict({"seeds": 3})
    with pytest.raises(ValueError, match="protocol must name a registered protocol"):
        ExperimentConfig(protocol="D")


def test_cli_runs_and_writes_report(tmp_path, capsys):
    out = tmp_path / "run"
    code = cli_main(["--protocol", "A", "--seeds", "1", "--episodes", "4", "--rollouts", "2",
                     "--methods", "ilpss", "scratch", "--workers", "1", "--quiet", "--out", str(out)])
    assert code == 0
    assert (out / "report.md").exists() and (out / "config.json").exists()
    saved = json.loads((out / "config.json").read_text())
    assert saved["n_seeds"] == 1 and saved["lifelong"]["train_episodes"] == 4


def test_cli_set_overrides_lifelong_and_learner_fields() -> None:
    from ilpss.experiments.cli import build_config, parser

    args = parser().parse_args(["--out", "x", "--set", "n_kernels=2",
                                "--set", "learner.intra_option=true",
                                "--set", "library.discount=0.25"])
    cfg = build_config(args)
    assert cfg.lifelong.n_kernels == 2
    assert cfg.lifelong.library.discount == 0.25
    assert cfg.lifelong.library.max_depth == ExperimentConfig().lifelong.library.max_depth
    assert cfg.lifelong.learner.intra_option is True
    # untouched learner fields keep the defaults
    assert cfg.lifelong.learner.tile_widths == ExperimentConfig().lifelong.learner.tile_widths


@pytest.mark.parametrize("episodes", ["-5", "0"])
def test_the_commands_say_the_episodes_an_experiment_allows(tmp_path, capsys, episodes) -> None:
    # before, -5 was refused as LifelongConfig's "in [0, 1,000,000]", and 0 then refused
    from ilpss.experiments import demo
    from ilpss.experiments.cli import main

    for command, argv in ((main, ["--protocol", "A", "--seeds", "1"]), (demo.main, [])):
        with pytest.raises(SystemExit):
            command([*argv, "--episodes", episodes, "--out", str(tmp_path / "run")])
        assert (f"--episodes must be an integer in [1, 1,000,000], got {episodes}"
                in capsys.readouterr().err)
    assert not (tmp_path / "run").exists()


def test_cli_refuses_a_run_it_could_not_report_before_it_starts(tmp_path, capsys) -> None:
    from ilpss.experiments.cli import main

    out = tmp_path / "run"
    for argv in (["--methods", "ilpss", "--baseline", "none"],
                 ["--protocol", "C", "--methods", "ilpss"]):
        with pytest.raises(SystemExit) as exc:
            main([*argv, "--seeds", "1", "--episodes", "1", "--out", str(out)])
        assert exc.value.code == 2 and not out.exists()
    err = capsys.readouterr().err
    assert "a run without a baseline (--baseline none) cannot be reported: add --no-report" \
        in err
    assert "ExperimentConfig.baseline: method 'scratch' is not among the methods ['ilpss']" \
        in err


def test_cli_bad_set_is_a_usage_error(capsys) -> None:
    from ilpss.experiments.cli import main

    for bad in (["--set", "n_kernels"], ["--set", "no_such_field=1"], ["--set", "n_kernels=0"]):
        with pytest.raises(SystemExit) as exc:
            main(["--out", "unused", *bad])
        assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "KEY=VALUE" in err and "no_such_field" in err and "n_kernels" in err


def test_compare_pairs_runs_by_seed_and_matches_the_report(tmp_path, capsys):
    from ilpss import metrics
    from ilpss.experiments.compare import main as compare_main
    from ilpss.experiments.report_stats import collect, threshold_for
    from ilpss.experiments.report_text import interval_text

    cfg = _tiny(methods=("ilpss", "scratch"))
    results = run_experiment(cfg, tmp_path / "a", progress=False)
    # An ablation run with one method and 3 seeds: only the 2 shared seeds are paired.
    run_experiment(_tiny(methods=("ilpss",), baseline=None).with_overrides(
        n_seeds=3, lifelong={"n_kernels": 1}), tmp_path / "b", progress=False)
    assert compare_main(["--baseline", f"{tmp_path / 'a'}:scratch",
                         f"ILPSS (K = 2)={tmp_path / 'a'}:ilpss",
                         f"K = 1={tmp_path / 'b'}:ilpss"]) == 0
    out = capsys.readouterr().out
    assert "2 paired seeds" in out and "| ILPSS (K = 2) |" in out and "| K = 1 |" in out
    # The same jumpstart as computing it directly from the curves.
    curves = collect(results)["held_out=goal_guards"]
    a, b = curves["ilpss"][3], curves["scratch"][3]
    est = metrics.compare(a, b, first=6, last=6, threshold=threshold_for(b), window=6)
    js = est["jumpstart"]
    assert f"| ILPSS (K = 2) | {interval_text(js, metrics.METRIC['jumpstart'].fmt)} |" in out
    # Its columns are the reports' headline metrics, from the table.
    assert "| run | " + " | ".join(
        c for m in metrics.headline_metrics()
        for c in (m.label, *(["p (Holm)"] if m.name in ("jumpstart", "total_reward_gain")
                             else []))) + " |" in out
    for bad in (["--baseline", "nofolder", "x=y:z"], ["--baseline", f"{tmp_path / 'a'}:prq", "x"]):
        with pytest.raises(SystemExit):
            compare_main(bad)


def test_compare_pools_every_stream_as_the_reports_do(tmp_path, capsys):
    from ilpss import metrics
    from ilpss.experiments.compare import main as compare_main
    from ilpss.experiments.report_stats import collect, target_curves
    from ilpss.experiments.report_text import interval_text

    cfg = _tiny(protocol="B", methods=("finetune", "scratch"), n_shuffles=0,
                teams=("interceptors_press", "chasers", "goal_guards"))
    results = run_experiment(cfg, tmp_path, progress=False)
    assert compare_main(["--baseline", f"{tmp_path}:scratch", f"ft={tmp_path}:finetune"]) == 0
    out = capsys.readouterr().out
    # Every held-out team's curves averaged per seed, as the report's pooled verdicts.
    table = collect(results)
    assert len(table) == 3
    pooled = {m: np.mean([target_curves(streams)[m] for streams in table.values()], axis=0)
              for m in ("finetune", "scratch")}
    est = metrics.compare(pooled["finetune"], pooled["scratch"], first=6, last=6,
                          threshold=None, window=6)
    assert f"| ft | {interval_text(est['jumpstart'], metrics.METRIC['jumpstart'].fmt)} |" in out
    assert "Largest" not in out  # one run: nothing picked as the largest


def test_the_demo_shows_the_recommended_method_succeeding_and_learning_anew_s_first_episode(
        tmp_path, capsys):
    import json

    from ilpss.experiments import demo

    assert demo.main(["--seeds", "2", "--episodes", "6", "--out", str(tmp_path)]) == 0
    text = (tmp_path / "report.md").read_text()
    assert "Command: `ilpss-demo --seeds 2 --episodes 6 --out " in text
    assert "(from Python)" not in text
    assert (tmp_path / "recommended.gif").stat().st_size > 0
    assert (tmp_path / "learning_anew_first.gif").stat().st_size > 0
    from PIL import Image

    with Image.open(tmp_path / "side_by_side.gif") as both:  # two panels of 600+ pixels
        assert both.size[0] > 2 * 600
    (left,) = [line for line in text.splitlines() if line.startswith("- Left:")]
    assert json.loads((tmp_path / "config.json").read_text())["methods"] == list(
        demo.demo_methods())
    # What it writes beside the run's folders is what the README's paragraph names.
    written = {p.name for p in tmp_path.iterdir() if p.suffix in {".md", ".png", ".gif"}}
    assert written - {"curves_00.png"} == set(demo.OUTPUTS)
    # An honest choice: the first success among the first GIF_EPISODES seeds, said so.
    assert ("the first success among environment seeds 0-19" in left and ": success," in left) \
        or ("on environment seed 0 (none of environment seeds 0-19 succeeds): " in left
            and ": success," not in left)
    # The right GIF is learning anew's first learning episode: its curve's first point.
    result = json.loads((tmp_path / "seed_000" / "stream_00" / "result.json").read_text())
    first = result["methods"]["scratch"]["curves"]["3"][0]
    (right,) = [line for line in text.splitlines() if line.startswith("- Right:")]
    assert f"reward {first:+.2f}" in right


def test_a_config_file_naming_where_checkpoints_go_needs_the_command_line_to_say_it(tmp_path):
    """A run folder's config.json edited to put its storage elsewhere: a resume from it
    would write there; refused unless --storage says the same on the command line."""
    from ilpss.experiments.cli import build_config, parser

    path = tmp_path / "config.json"
    elsewhere = str(tmp_path / "elsewhere")
    path.write_text(json.dumps(ExperimentConfig(storage=elsewhere).to_dict()))
    with pytest.raises(ValueError, match="sets storage to .*never taken from a file: give "
                                         f"--storage {elsewhere}"):
        build_config(parser().parse_args(["--out", "x", "--config", str(path)]))
    cfg = build_config(parser().parse_args(["--out", "x", "--config", str(path),
                                            "--storage", elsewhere]))
    assert cfg.storage == elsewhere


def test_a_bounded_method_is_refused_where_the_drills_returns_do_not_hold() -> None:
    # before, the bounded methods clipped every target to the drill's [-1, 1] in any
    # environment, whatever it paid, without a word
    from ilpss.experiments.config import ExperimentConfig

    for method in ("finetune_bounded", "whole_policies_ft_bounded_cut", "finetune_chained_bounded"):
        with pytest.raises(ValueError, match=rf"'{method}' bounds its learner's values by the "
                                             r"drill's episode returns \[-1, 1\], and env_id "
                                             r"'CartPole-v1' is not one of the drill's"):
            ExperimentConfig(env_id="CartPole-v1", methods=("scratch", method))
    ExperimentConfig(env_id="CartPole-v1", methods=("scratch", "finetune"))
    ExperimentConfig(methods=("scratch", "whole_policies_ft_bounded_cut"))  # the drill's own


def test_a_run_of_another_environment_is_not_reported_on_the_drills_floor(tmp_path,
                                                                          capsys) -> None:
    # before, its report measured the curves from the drill's lowest reward (-1): wrong
    # figures for rewards in [0, 1], and a failure after the whole run for rewards below -1
    import json

    from ilpss.experiments.cli import main
    from ilpss.experiments.config import ExperimentConfig
    from ilpss.experiments.report import write_report

    cfg = ExperimentConfig(env_id="CartPole-v1", methods=("scratch", "finetune"))
    with pytest.raises(ValueError, match=r"measure the curves from the drill's lowest "
                                         r"episode reward \(-1\), and env_id 'CartPole-v1'"):
        write_report(cfg, [], tmp_path / "report")
    assert not (tmp_path / "report").exists()
    config = tmp_path / "config.json"
    config.write_text(json.dumps({"env_id": "CartPole-v1", "methods": ["scratch", "finetune"]}))
    out = tmp_path / "run"
    with pytest.raises(SystemExit) as exc:
        main(["--config", str(config), "--seeds", "2", "--episodes", "1", "--out", str(out)])
    assert exc.value.code == 2 and not out.exists()
    assert "lowest episode reward as floor: add --no-report" in capsys.readouterr().err


def test_from_dict_of_a_runs_config_json_says_how_to_read_one(tmp_path) -> None:
    # before: "unknown ExperimentConfig field(s) ['code']", though --config takes the file
    import json

    from ilpss.experiments.config import ExperimentConfig
    from ilpss.experiments.run import read_config

    path = tmp_path / "config.json"
    path.write_text(json.dumps({**ExperimentConfig().to_dict(), "code": {"version": "0"}}))
    with pytest.raises(ValueError, match=r"'code' is not a field but a run's record of the "
                                         r"code that ran it: read a run's config.json with "
                                         r"ilpss.experiments.run.read_config"):
        ExperimentConfig.from_dict(json.loads(path.read_text()))
    assert read_config(path) == ExperimentConfig()
