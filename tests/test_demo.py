"""The demo follows its one declaration of the recommended method
(``ilpss.experiments.demo.RECOMMENDED``): whichever lifelong or fine-tuning method it
names runs once and is the one shown, and any other is refused before any work."""

from __future__ import annotations

import json

import pytest

from ilpss.experiments import demo
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.folder import RunFolder
from ilpss.experiments.report_text import label
from ilpss.experiments.run import run_experiment

# The methods docs/discussion.md lists for the recommendation, and earlier rounds' picks.
CANDIDATES = ("whole_policies_ft_bounded_cut", "finetune", "finetune_best",
              "whole_policies_ft", "ilpss_ft", "whole_policies_plus", "ilpss_plus", "ilpss",
              "scratch")


class _Configured(Exception):
    """Raised in place of running the experiment, with the configuration it was given."""


def _configure(monkeypatch, tmp_path, recommended: str) -> ExperimentConfig:
    monkeypatch.setattr(demo, "RECOMMENDED", recommended)

    def stop(cfg, out, **_):
        raise _Configured(cfg)

    monkeypatch.setattr(demo, "run_experiment", stop)
    with pytest.raises(_Configured) as stopped:
        demo.main(["--out", str(tmp_path / "demo")])
    return stopped.value.args[0]


@pytest.mark.parametrize("recommended", CANDIDATES)
def test_changing_the_recommendation_is_one_line(recommended, monkeypatch, tmp_path):
    cfg = _configure(monkeypatch, tmp_path, recommended)
    assert cfg.methods == tuple(dict.fromkeys(("scratch", "ilpss", "finetune", recommended)))


def test_a_method_with_no_agent_to_show_is_refused_before_any_work(monkeypatch, tmp_path,
                                                                    capsys):
    monkeypatch.setattr(demo, "RECOMMENDED", "prq")
    monkeypatch.setattr(demo, "run_experiment", pytest.fail)
    with pytest.raises(SystemExit) as exc:
        demo.main(["--out", str(tmp_path / "demo")])
    assert exc.value.code == 2
    assert "'prq' is neither a lifelong nor a fine-tuning method" in capsys.readouterr().err


@pytest.mark.slow
def test_the_demo_shows_the_agent_of_a_lifelong_or_a_fine_tuning_method(monkeypatch,
                                                                        tmp_path):
    shown = ("finetune", "finetune_best", "ilpss_ft", demo.RECOMMENDED)
    cfg = ExperimentConfig(protocol="A", n_seeds=1, workers=1, featured="ilpss",
                           methods=("scratch", "ilpss", *shown)).with_overrides(
        lifelong={"train_episodes": 6, "rollout_episodes": 3, "n_kernels": 2})
    run_experiment(cfg, tmp_path, progress=False)
    folder = RunFolder(tmp_path)
    for method in shown:
        monkeypatch.setattr(demo, "RECOMMENDED", method)
        (tmp_path / "recommended.gif").unlink(missing_ok=True)
        lines = demo.agent_lines(cfg, folder)
        (left,) = [line for line in lines if line.startswith("- Left:")]
        assert f"seed 0's {label(method)} agent" in left
        assert (tmp_path / "recommended.gif").stat().st_size > 0
    # Fine-tuning's agent is learnt again: it must be the run's, episode for episode.
    result = folder.result(0, 0)
    run = json.loads(result.read_text())
    run["methods"]["finetune"]["curves"]["3"][-1] *= -1
    result.write_text(json.dumps(run))
    with pytest.raises(ValueError, match="not the run's agent"):
        demo.target_agent(cfg, folder, "finetune", 0)
