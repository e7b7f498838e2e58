"""Results folders as an attacker would write them: names of code, mixed runs, races."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from ilpss.experiments.config import ExperimentConfig

# A stand-in for ``os:kill``: importing the module or calling its function leaves a mark.
CANARY = '''
from pathlib import Path
Path({marker!r}).with_suffix(".imported").touch()

def fire(n, seed):
    Path({marker!r}).with_suffix(".called").touch()
    return [{{}}] * n
'''


@pytest.fixture
def canary(tmp_path, monkeypatch):
    """A module ``ilpss_canary`` on the path; ``marks()`` lists what it was made to do."""
    code = tmp_path / "code"
    code.mkdir()
    marker = tmp_path / "mark"
    (code / "ilpss_canary.py").write_text(CANARY.format(marker=str(marker)))
    monkeypatch.syspath_prepend(str(code))
    monkeypatch.delitem(sys.modules, "ilpss_canary", raising=False)

    def marks() -> list[str]:
        return sorted(p.suffix for p in tmp_path.glob("mark.*"))

    yield marks
    assert "ilpss_canary" not in sys.modules


def _folder(tmp_path: Path, **changes) -> Path:
    values = {**ExperimentConfig(protocol="C", stream_length=2, n_seeds=2).to_dict(), **changes}
    folder = tmp_path / "received"
    folder.mkdir()
    (folder / "config.json").write_text(json.dumps(values))
    return folder


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"sampler": "ilpss_canary:fire"}, "sampler must be the name of a registered sampler"),
        ({"sampler": "ilpss_canary"}, r"sampler must name a registered sampler .*\['parametric'"),
        ({"sampler": "ilpss_canary:fire", "protocol": "A"}, "sampler must be the name of"),
        ({"env_id": "ilpss_canary:soccer_drill/Holder-v0"},
         r"names the package 'ilpss_canary', which Gymnasium would import"),
    ],
)
def test_a_received_folder_naming_code_is_refused_without_importing_it(
    tmp_path, canary, capsys, changes, message
):
    from ilpss.experiments.cli import main as experiment_main
    from ilpss.experiments.compare import main as compare_main
    from ilpss.experiments.run import run_experiment

    folder = _folder(tmp_path, **changes)
    config = folder / "config.json"
    with pytest.raises(ValueError, match=message):
        ExperimentConfig.from_dict(json.loads(config.read_text()))
    for main in (
        lambda: compare_main(["--baseline", f"{folder}:scratch", f"x={folder}:ilpss"]),
        lambda: experiment_main(["--config", str(config), "--out", str(folder), "--quiet"]),
    ):
        with pytest.raises(SystemExit) as exit_info:
            main()
        assert exit_info.value.code == 2
        assert message.split(" ")[0] in capsys.readouterr().err
    # Resuming into the folder reads its config.json: refused, naming the file.
    with pytest.raises(ValueError, match=rf"{config}: .*{message}"):
        run_experiment(ExperimentConfig(protocol="C", stream_length=2, n_seeds=2).with_overrides(
            lifelong={"train_episodes": 1}), folder, progress=False)
    assert canary() == []


def test_a_registered_sampler_makes_the_protocol_c_stream():
    from ilpss.experiments.registry import SAMPLERS, register_sampler

    calls = []

    def sampler(n, seed):
        calls.append((n, seed))
        return [{"n_interceptors": 1 + i % 2} for i in range(n)]

    register_sampler("test_two_kinds", sampler)
    try:
        cfg = ExperimentConfig(protocol="C", stream_length=3, sampler="test_two_kinds")
        (stream,) = cfg.streams(seed=7)
        assert calls == [(3, 7)]
        assert [t.env_kwargs["opponent_params"] for t in stream.tasks] == sampler(3, 7)
        with pytest.raises(ValueError, match="already registered"):
            register_sampler("test_two_kinds", sampler)
    finally:
        SAMPLERS.unregister("test_two_kinds")
    # The drill's own sampler comes from its entry point.
    assert "parametric" in SAMPLERS.names()
    assert len(ExperimentConfig(protocol="C", stream_length=4).streams(0)[0].tasks) == 4
