"""Results folders as an attacker would write them: names of code, mixed runs, races."""

from __future__ import annotations

import dataclasses
import json
import shutil
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


def test_protocols_methods_and_reuses_register_only_their_own_kind():
    from ilpss.experiments.methods import register_method
    from ilpss.experiments.protocols import register_protocol
    from ilpss.reuse import Reuse, register_reuse
    from soccer_drill.registry import Registry

    for register, kind, cls in ((register_reuse, "reuse", "Reuse"),
                                (register_method, "method", "Method"),
                                (register_protocol, "protocol", "Protocol")):
        with pytest.raises(TypeError, match=f"a {kind} must be a {cls}, got str"):
            register("kernels")
    with pytest.raises(ValueError, match="reuse 'kernels' is already registered"):
        register_reuse(Reuse("kernels", None))
    with pytest.raises(TypeError, match=r"a sampler is registered with register\(name, obj\)"):
        Registry("ilpss.samplers", "sampler").add(Reuse("x", None))


# ------------------------------------------------------------ runs that mix configurations
ROOT = Path(__file__).resolve().parent.parent
ENV = {"PYTHONPATH": str(ROOT)}


def _tiny(**lifelong) -> ExperimentConfig:
    return ExperimentConfig(n_seeds=1, workers=1, methods=("scratch",)).with_overrides(
        lifelong={"train_episodes": 3, "rollout_episodes": 1, **lifelong})


def _alpha(value: float) -> ExperimentConfig:
    cfg = _tiny()
    return cfg.with_overrides(lifelong={"learner": {**cfg.lifelong.learner.__dict__,
                                                    "alpha": value}})


def test_a_resume_refuses_checkpoints_and_results_of_another_configuration(tmp_path):
    from ilpss.experiments.run import JobError, run_experiment

    run_experiment(_alpha(0.125), tmp_path, progress=False)
    (tmp_path / "config.json").unlink()
    # The result of the 0.125 run is not returned as the 0.5 run's.
    with pytest.raises(ValueError, match=r"result.json: comes from another configuration "
                       r"than the run's \(config.lifelong.learner.alpha: 0.125 saved, 0.5 "
                       r"here, saved in the result against the run's\); if the run's "
                       r"config.json or its settings were changed since, put them back"):
        run_experiment(_alpha(0.5), tmp_path, progress=False)
    # Nor is its checkpoint continued.
    (tmp_path / "config.json").unlink()
    (tmp_path / "seed_000" / "stream_00" / "result.json").unlink()
    with pytest.raises(JobError, match=r"seed 0, stream 0: CheckpointRefused: .*scratch: the checkpoint comes from another run "
                       r"\(experiment.lifelong.learner.alpha: 0.125 saved, 0.5 here\)"):
        run_experiment(_alpha(0.5), tmp_path, progress=False)
    # The folder's own configuration still resumes.
    (tmp_path / "config.json").unlink()
    run_experiment(_alpha(0.125), tmp_path, progress=False)
    with pytest.raises(ValueError, match=r"different configuration \(lifelong.learner.alpha: "
                       r"0.125 saved, 0.5 here\)"):
        run_experiment(_alpha(0.5), tmp_path, progress=False)


def test_a_damaged_checkpoint_at_a_resume_says_how_to_go_on_and_deleting_it_does(tmp_path):
    """A resume reads a damaged checkpoint the same way every time, so the error says to
    delete the method's folder (the job's other methods are kept), not only what is wrong;
    before, a truncated policy or a file gone was named, and the advice was to run the same
    command again, which failed the same way."""
    from ilpss.experiments.run import JobError, run_experiment

    run_experiment(_tiny(), tmp_path, progress=False)
    job = tmp_path / "seed_000" / "stream_00"
    kept = (job / "result.json").read_bytes()
    (job / "result.json").unlink()
    checkpoint = next((job / "scratch").glob("trial_*"))
    for damage in (lambda: (checkpoint / "policy_0.npz").write_bytes(b"PK"),
                   lambda: (checkpoint / "policy_0.npz").unlink()):
        damage()
        with pytest.raises(JobError, match=r"seed 0, stream 0: CheckpointRefused: .*scratch: "
                           r"the checkpoint cannot be resumed: .*policy_0.npz: .*; delete that "
                           r"folder to run this method of the job again") as failed:
            run_experiment(_tiny(), tmp_path, progress=False)
        # the advice after the list: that folder deleted first (before: "run the same
        # command again", which fails the same way)
        assert str(failed.value).endswith("do what its message says (delete that folder), "
                                          "then run the same command again to run only the "
                                          "failed one(s)")
    shutil.rmtree(job / "scratch")
    run_experiment(_tiny(), tmp_path, progress=False)
    assert (job / "result.json").read_bytes() == kept


_HOLD = """
import sys
from ilpss._io import locked_folder
with locked_folder(sys.argv[1]):
    print("locked", flush=True)
    sys.stdin.read()
"""


@pytest.fixture
def held(tmp_path):
    """``held(folder)`` locks ``folder`` from another process until the test ends."""
    import os
    import subprocess

    holders = []

    def hold(folder: Path) -> None:
        folder.mkdir(parents=True, exist_ok=True)
        proc = subprocess.Popen([sys.executable, "-c", _HOLD, str(folder)], text=True,
                                stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                env={**os.environ, **ENV})
        holders.append(proc)
        assert proc.stdout.readline() == "locked\n"

    yield hold
    for proc in holders:
        proc.communicate("", timeout=30)


def test_a_folder_being_written_is_refused_to_a_second_run(tmp_path, held, capsys):
    from ilpss._io import FolderInUseError
    from ilpss.experiments.cli import main as experiment_main
    from ilpss.experiments.run import run_experiment

    out = tmp_path / "run"
    held(out)
    with pytest.raises(FolderInUseError, match="run folder is being written by another"):
        run_experiment(_tiny(), out, progress=False)
    assert list(out.iterdir()) == []  # nothing written, not even config.json
    with pytest.raises(SystemExit) as exit_info:
        experiment_main(["--seeds", "1", "--methods", "scratch", "--out", str(out), "--quiet"])
    assert exit_info.value.code == 1
    assert "being written by another process" in capsys.readouterr().err


def test_a_checkpoint_folder_being_written_is_refused_to_a_second_save(tmp_path, held):
    from synthetic_smdp import ZoneCorridor

    from ilpss._io import FolderInUseError
    from ilpss.lifelong import LearnerConfig, LifelongConfig, LifelongLearner

    env = ZoneCorridor()
    learner = LifelongLearner(
        LifelongConfig(train_episodes=2, rollout_episodes=1, learner=LearnerConfig(n_tilings=2)),
        env.observation_space, 3)
    learner.run_trial(env, "corridor")
    held(tmp_path / "ckpt")
    with pytest.raises(FolderInUseError, match="checkpoint folder is being written"):
        learner.save(tmp_path / "ckpt")
    assert list((tmp_path / "ckpt").iterdir()) == []


@pytest.mark.slow
def test_two_runs_started_together_on_one_folder_never_mix(tmp_path):
    """Two processes with different configurations: one runs, the other is refused, and
    every file of the folder comes from the one that ran."""
    import os
    import subprocess

    out = tmp_path / "run"
    base = [sys.executable, "-m", "ilpss.experiments.cli", "--seeds", "1", "--episodes", "3",
            "--rollouts", "1", "--methods", "scratch", "--workers", "1", "--quiet",
            "--no-report", "--out", str(out)]
    alphas = ("0.125", "0.5")
    procs = [subprocess.Popen([*base, "--set", f"learner.alpha={a}"], env={**os.environ, **ENV},
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for a in alphas]
    outputs = [p.communicate(timeout=300) for p in procs]
    codes = [p.returncode for p in procs]
    assert sorted(codes) == [0, 1], outputs
    loser = outputs[codes.index(1)][1]
    assert "being written by another process" in loser or "different configuration" in loser
    winner = float(alphas[codes.index(0)])
    config = json.loads((out / "config.json").read_text())
    assert config["lifelong"]["learner"]["alpha"] == winner
    result = json.loads((out / "seed_000" / "stream_00" / "result.json").read_text())
    assert result["config"]["lifelong"]["learner"]["alpha"] == winner
    state = out / "seed_000" / "stream_00" / "scratch"
    state = json.loads((state / (state / "LATEST").read_text() / "state.json").read_text())
    assert state["config"]["learner"]["alpha"] == winner


# ------------------------------------------------------------------------ absurd values
def test_tile_widths_that_would_need_terabytes_are_refused_before_anything_is_written(
    tmp_path, capsys
):
    from gymnasium.spaces import Box

    from ilpss.experiments.cli import main as experiment_main
    from ilpss.lifelong import LearnerConfig
    from ilpss.tiles import MAX_WEIGHTS, TileCoder

    out = tmp_path / "run"
    code = None
    with pytest.raises(SystemExit) as exit_info:
        code = experiment_main(["--seeds", "1", "--methods", "scratch", "--quiet", "--out",
                                str(out), "--set", f"learner.tile_widths={[1e-9] * 9}"])
    assert code is None and exit_info.value.code == 1
    err = capsys.readouterr().err
    assert "LearnerConfig.tile_widths / n_tilings: these widths and 32 tilings give" in err
    assert f"at most {MAX_WEIGHTS:,} are allowed" in err and "(feature 4 spans 180 with width 1e-09)" in err
    assert not (out / "config.json").exists()
    # The bound itself: one tile short of it is fine, one over is not.
    fits = TileCoder([0.0], [1.0], [1.0 / (MAX_WEIGHTS // 2 - 2)], n_tilings=2)
    assert fits.n_weights == MAX_WEIGHTS
    with pytest.raises(ValueError, match="at most"):
        TileCoder([0.0], [1.0], [1.0 / (MAX_WEIGHTS // 2 - 1)], n_tilings=2)
    with pytest.raises(ValueError, match=r"LearnerConfig.tile_widths / n_tilings: widths must"):
        LearnerConfig(tile_widths=(1.0, 2.0)).tile_coder(Box(0.0, 1.0, (1,)))


# ------------------------------------------------------------- records with integrity checks
def test_a_resume_refuses_rewards_the_environment_cannot_pay(tmp_path):
    from ilpss import _io
    from ilpss.experiments.run import JobError, run_experiment

    run_experiment(_tiny(), tmp_path, progress=False)
    job = tmp_path / "seed_000" / "stream_00"
    (job / "result.json").unlink()
    state = job / "scratch" / (job / "scratch" / "LATEST").read_text() / "state.json"
    record = json.loads(state.read_text())
    del record["sha256"]
    record["records"][0]["rewards"][0] = -9.0  # with a valid digest
    state.write_bytes(_io.json_record_bytes(record))
    with pytest.raises(JobError, match=r"CheckpointRefused: .*records\[0\].rewards lie outside the environment's "
                       r"range \[-1, 1\]"):
        run_experiment(_tiny(), tmp_path, progress=False)


# ----------------------------------------------------------------------- smaller things
def test_output_folders_that_cannot_be_one_are_refused_clearly(tmp_path, capsys):
    from ilpss.experiments.cli import main as experiment_main
    from ilpss.experiments.run import run_experiment

    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    for out, message in (("", "the output folder must be a path, got ''"),
                         (a_file, "a_file: exists and is not a folder"),
                         (a_file / "sub", r"a_file/sub: cannot create the output folder "
                                          r"\(Not a directory\)")):
        with pytest.raises(ValueError, match=message):
            run_experiment(_tiny(), out, progress=False)
        with pytest.raises(SystemExit) as exit_info:
            experiment_main(["--seeds", "1", "--methods", "scratch", "--quiet",
                             "--out", str(out)])
        assert exit_info.value.code == 1
        assert "error: " in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]


@pytest.mark.slow
@pytest.mark.skipif(sys.platform == "win32", reason="SIGKILL")
def test_a_kill_just_before_result_json_is_renamed_leaves_no_temporary_after_the_resume(
    tmp_path,
):
    import os
    import subprocess

    script = """
import os, signal, sys
from pathlib import Path
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.run import run_experiment

real = os.replace
def replace(src, dst):
    if Path(src).name.startswith(".result.json."):
        os.kill(os.getpid(), signal.SIGKILL)
    return real(src, dst)
os.replace = replace
cfg = ExperimentConfig(n_seeds=1, workers=1, methods=("scratch",)).with_overrides(
    lifelong={"train_episodes": 3, "rollout_episodes": 1})
run_experiment(cfg, sys.argv[1], progress=False)
"""
    from ilpss.experiments.run import run_experiment

    killed = tmp_path / "killed"
    proc = subprocess.run([sys.executable, "-c", script, str(killed)], env={**os.environ, **ENV},
                          timeout=300)
    assert proc.returncode == -9
    job = killed / "seed_000" / "stream_00"
    (temporary,) = [p.name for p in job.iterdir() if p.name.endswith(".tmp")]
    assert temporary.startswith(".result.json.") and not (job / "result.json").exists()
    resumed = run_experiment(_tiny(), killed, progress=False)
    assert sorted(p.name for p in job.iterdir()) == ["result.json", "scratch"]
    straight = run_experiment(_tiny(), tmp_path / "straight", progress=False)
    assert resumed == straight
    assert (job / "result.json").read_bytes() == (
        tmp_path / "straight" / "seed_000" / "stream_00" / "result.json").read_bytes()


def test_another_runs_folder_is_refused_as_the_checkpoint_storage(tmp_path):
    # before, its checkpoints were mixed with this run's (and owner.json written into
    # it), or refused with the advice to delete the other run's checkpoints
    from ilpss.experiments.run import run_experiment

    first = tmp_path / "first"
    run_experiment(_tiny(), first, progress=False)
    before = sorted(p.relative_to(first).as_posix() for p in first.rglob("*"))
    with pytest.raises(ValueError, match=r"another run's folder \(it holds config.json\) given "
                                         r"as this run's checkpoint storage"):
        run_experiment(dataclasses.replace(_tiny(), storage=str(first)), tmp_path / "second",
                       progress=False)
    assert sorted(p.relative_to(first).as_posix() for p in first.rglob("*")) == before
