"""Run folders, saved files and commands as an attacker or a careless user would treat
them: links out of the folder, files that never end, workers left behind, failing jobs,
mismatched comparisons, settings that diverge, outputs that cannot be written."""

from __future__ import annotations

import importlib
import io
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest
from full_disk import full_disk

from ilpss import _io
from ilpss._io import locked_folder
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.run import JobError, read_config, run_experiment
from ilpss.smdp import KEEPAWAY

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))


def _tiny(**changes) -> ExperimentConfig:
    lifelong = changes.pop("lifelong", {})
    fields = {"n_seeds": 1, "workers": 1, "methods": ("scratch",), **changes}
    return ExperimentConfig(**fields).with_overrides(
        lifelong={"train_episodes": 3, "rollout_episodes": 1, **lifelong})


# ------------------------------------------------------------ a folder that leads outside
def _outside_folder(tmp_path: Path) -> Path:
    """A folder elsewhere, holding what a user keeps there."""
    outside = tmp_path / "elsewhere"
    for name in ("trial_0001", "trial_0000_notes", ".building_keep"):
        (outside / name).mkdir(parents=True)
        (outside / name / "keep.txt").write_text("mine")
    return outside


def test_a_symlinked_checkpoint_folder_is_refused_and_nothing_outside_changes(tmp_path):
    run, cfg = tmp_path / "run", _tiny(n_seeds=2)
    run_experiment(cfg, run, progress=False)
    outside = _outside_folder(tmp_path)
    before = sorted(p.relative_to(outside) for p in outside.rglob("*"))
    job = run / "seed_001" / "stream_00"
    (job / "result.json").unlink()
    shutil.rmtree(job / "scratch")
    (job / "scratch").symlink_to(outside, target_is_directory=True)
    with pytest.raises(JobError, match=r"seed_001/stream_00/scratch: a symbolic link inside "
                                       r"the checkpoint storage"):
        run_experiment(cfg, run, progress=False)
    assert sorted(p.relative_to(outside) for p in outside.rglob("*")) == before
    assert not (outside / "LATEST").exists()


def test_a_symlinked_job_folder_is_refused_before_anything_is_read_or_written(tmp_path):
    run, cfg = tmp_path / "run", _tiny()
    run_experiment(cfg, run, progress=False)
    outside = tmp_path / "elsewhere"
    shutil.move(run / "seed_000", outside)
    (run / "seed_000").symlink_to(outside, target_is_directory=True)
    stale = outside / "stream_00" / f".result.json.{os.getpid()}.{'a' * 12}.tmp"
    stale.write_text("theirs")
    with pytest.raises(ValueError, match=r"seed_000: a symbolic link inside the run folder"):
        run_experiment(cfg, run, progress=False)
    assert stale.read_text() == "theirs"  # not removed as a stale temporary of ours


def test_save_deletes_only_its_own_checkpoints_and_never_follows_a_link(tmp_path):
    from test_io import _corridor_learner

    learner, _ = _corridor_learner(1)
    folder = tmp_path / "ckpt"
    outside = _outside_folder(tmp_path)
    folder.mkdir()
    for name in ("trial_0000_notes", ".building_keep"):
        (folder / name).mkdir()
    (folder / "trial_0000").symlink_to(outside, target_is_directory=True)
    learner.save(folder)
    assert (folder / "trial_0000_notes").is_dir() and (folder / ".building_keep").is_dir()
    assert (folder / "trial_0000").is_symlink()
    assert sorted(p.name for p in outside.iterdir()) == [
        ".building_keep", "trial_0000_notes", "trial_0001"]
    # A link where the new checkpoint belongs is refused, not written through.
    (folder / "trial_0002").symlink_to(outside, target_is_directory=True)
    learner.records.append(learner.records[-1])
    with pytest.raises(ValueError, match="trial_0002: a symbolic link where this checkpoint"):
        learner.save(folder)


def test_a_checkpoint_whose_file_links_outside_is_refused(tmp_path):
    from test_io import _corridor_learner

    from ilpss.lifelong import LifelongLearner

    learner, space = _corridor_learner(1, tmp_path / "ckpt")
    policy = tmp_path / "ckpt" / "trial_0001" / "policy_0.npz"
    shutil.move(policy, tmp_path / "policy_0.npz")
    policy.symlink_to(tmp_path / "policy_0.npz")
    with pytest.raises(ValueError, match=r"policy_0.npz: a symbolic link inside the checkpoint"):
        LifelongLearner.load(tmp_path / "ckpt", space)


# ------------------------------------------------------------ files that never end
@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="needs /dev/zero")
@pytest.mark.parametrize("name", ["config.json", "result.json", "LATEST"])
def test_a_device_in_place_of_a_small_file_is_refused_without_reading_it(tmp_path, name):
    from ilpss.experiments.run import RESULT_SCHEMA
    from ilpss.lifelong import latest_checkpoint

    (tmp_path / name).symlink_to("/dev/zero")  # stat() says 0 bytes; reading never ends
    read = {"config.json": lambda: read_config(tmp_path / name),
            "result.json": lambda: _io.load_json_record(tmp_path / name, RESULT_SCHEMA),
            "LATEST": lambda: latest_checkpoint(tmp_path)}[name]
    with pytest.raises(ValueError, match=rf"{name}: a character device, where .* \(a regular "
                                         r"file\) was expected"):
        read()


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="needs /dev/zero")
def test_a_device_as_the_owner_record_of_a_uri_storage_is_refused_without_reading_it(tmp_path):
    pytest.importorskip("pyarrow.fs", reason="a storage URI needs pyarrow")
    from ilpss.experiments.checkpoints import UriStore

    (tmp_path / "owner.json").symlink_to("/dev/zero")
    store = UriStore(tmp_path.as_uri())
    try:
        with pytest.raises(ValueError, match=r"owner.json: a symbolic link inside the "
                                             r"checkpoint storage"):
            store.check("token")
    finally:
        store.close()


def test_a_fifo_in_place_of_result_json_is_refused_at_once(tmp_path):
    fifo = tmp_path / "result.json"
    os.mkfifo(fifo)
    outcome: list[BaseException] = []

    def read() -> None:
        try:
            _io.load_json_record(fifo, "ilpss.experiment_result/3")
        except BaseException as exc:
            outcome.append(exc)

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    reader.join(timeout=10)
    if reader.is_alive():  # release the blocked reader before failing
        with open(fifo, "wb"):
            pass
        pytest.fail("reading a FIFO blocked")
    assert "a FIFO (named pipe), where a JSON record" in str(outcome[0])


def test_reads_are_bounded_as_they_read_whatever_stat_said(tmp_path, monkeypatch):
    path = tmp_path / "big.json"
    path.write_bytes(b" " * 2000 + b"{}")
    monkeypatch.setattr(_io, "MAX_JSON_BYTES", 1000)
    with pytest.raises(ValueError, match="more than the 1,000 bytes a JSON record may have"):
        _io.read_json(path)


def test_latest_naming_another_file_does_not_print_it(tmp_path):
    from ilpss.lifelong import latest_checkpoint

    secret = tmp_path / "secret"
    secret.write_text("hunter2 hunter2")
    (tmp_path / "ckpt").mkdir()
    (tmp_path / "ckpt" / "LATEST").symlink_to(secret)
    with pytest.raises(ValueError) as err:
        latest_checkpoint(tmp_path / "ckpt")
    assert "hunter2" not in str(err.value)
    assert "does not name a checkpoint" in str(err.value)


def test_counts_in_a_library_record_are_bounded_before_use(tmp_path):
    from test_io import _corridor_learner

    from ilpss.options import LIBRARY_SCHEMA, OptionLibrary

    learner, _ = _corridor_learner(1)
    folder = tmp_path / "library"
    learner.library.save(folder)
    path = folder / "library.npz"
    arrays, meta = _io.load_npz(path, LIBRARY_SCHEMA, {}, {
        k: ((None,), "iuf") for k in np.load(path).files if k != "__meta__"})
    _io.save_npz_atomic(path, arrays, {**meta, "n_policies": 10**9})  # a valid digest
    start = time.process_time()
    with pytest.raises(ValueError, match=r"n_policies is 1000000000, but the record lists"):
        OptionLibrary.load(folder)
    assert time.process_time() - start < 5  # no set of 10**9 names was built


def test_a_uniform_kernel_naming_a_billion_features_is_refused(tmp_path):
    from ilpss.kernels import UNIFORM_SCHEMA, UniformKernel

    path = tmp_path / "kernels.npz"
    _io.save_npz_atomic(path, {}, {"schema": UNIFORM_SCHEMA, "n_features": 10**9})
    with pytest.raises(ValueError, match=r"field n_features must be an integer in \[1, 1,024\], "
                                         r"got 1000000000"):
        UniformKernel.load(path)


def test_an_npz_header_with_an_absurd_axis_is_refused_by_name(tmp_path):
    path = tmp_path / "bomb.npz"
    _io.save_npz_atomic(path, {"weights": np.zeros((0, 3))}, {"schema": "x/1"})
    with zipfile.ZipFile(path) as archive:
        record = archive.read(_io.META_KEY + ".npy")  # a valid record: only the axis is wrong
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        member = io.BytesIO()
        np.lib.format.write_array_header_1_0(
            member, {"descr": "<f8", "fortran_order": False, "shape": (0, 10**30)})
        archive.writestr("weights.npy", member.getvalue())  # 0 bytes of data, as declared
        archive.writestr(_io.META_KEY + ".npy", record)
    path.write_bytes(buffer.getvalue())
    with pytest.raises(ValueError) as err:  # was an OverflowError from reading the array
        _io.load_npz(path, "x/1", {"weights": ((None, None), "f")})
    assert str(err.value) == (
        f"{path}: member 'weights.npy' declares shape (0, {10**30}), an axis longer than any "
        "ilpss array has")


def test_json_numbers_beyond_float_are_refused_naming_the_file(tmp_path):
    path = tmp_path / "config.json"
    path.write_text('{"n_seeds": 1e400}')
    with pytest.raises(ValueError, match=r"config.json: not valid JSON \(the number 1e400 is "
                                         r"too large for a float\)"):
        read_config(path)


def test_a_full_disk_names_the_file_it_could_not_write(tmp_path, monkeypatch):
    import errno

    real = os.fdopen

    class Full:
        def __init__(self, fh):
            self.fh = fh

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.fh.close()

        def write(self, data):
            raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "fdopen", lambda fd, *a, **k: Full(real(fd, *a, **k)))
    with pytest.raises(OSError, match=r"cannot write .*result.json: No space left on device"):
        _io.atomic_write_bytes(tmp_path / "result.json", b"{}")
    assert list(tmp_path.iterdir()) == []


def test_complex_states_are_refused_not_cut_to_their_real_part():
    from ilpss.kernels import SharedKernelModel

    model = SharedKernelModel(1, random_state=0).fit([np.random.default_rng(0).normal(size=(40, 2))])
    with pytest.raises(ValueError, match="complex values"):
        model.membership(np.array([0.5 + 3j, 0.0]))
    with pytest.raises(ValueError, match="instance 0: complex values"):
        SharedKernelModel(1).fit([np.ones((5, 2)) * (1 + 1j)])


# ------------------------------------------------------------ workers and the lock
def _started_run(tmp_path: Path, workers: int = 2) -> tuple[subprocess.Popen, Path]:
    """``ilpss-experiment`` running 2 long jobs, once both workers have started."""
    run = tmp_path / "run"
    proc = subprocess.Popen(
        [sys.executable, "-m", "ilpss.experiments.cli", "--protocol", "A", "--seeds", "2",
         "--methods", "scratch", "--episodes", "100000", "--workers", str(workers),
         "--quiet", "--no-report", "--out", str(run)],
        env={**os.environ, "PYTHONPATH": str(ROOT)}, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, start_new_session=True, preexec_fn=_ctrl_c_as_in_a_terminal)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and len(_workers_of(proc.pid)) < workers:
        time.sleep(0.2)
    if len(_workers_of(proc.pid)) != workers:
        _kill_all(proc, _workers_of(proc.pid))
        pytest.fail("the workers did not start")
    time.sleep(1.0)  # inside their jobs
    return proc, run


def _ctrl_c_as_in_a_terminal() -> None:
    """SIGINT's default in the driver: a test run started in the background by a shell
    without job control ignores SIGINT, and a child would inherit that (Python then
    installs no KeyboardInterrupt handler), unlike a command started in a terminal."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _kill_all(proc: subprocess.Popen, workers: list[int]) -> None:
    """Leave nothing running (jobs of 100,000 episodes), whatever the test found."""
    for pid in [proc.pid, *workers]:
        if _alive([pid]):
            os.kill(pid, signal.SIGKILL)
    proc.wait()


def _workers_of(pid: int) -> list[int]:
    """The child processes of ``pid`` (Linux /proc)."""
    children = Path(f"/proc/{pid}/task/{pid}/children")
    try:
        return [int(c) for c in children.read_text().split()]
    except OSError:
        return []


def _alive(pids: list[int]) -> list[int]:
    out = []
    for pid in pids:
        try:
            status = Path(f"/proc/{pid}/status").read_text()
        except OSError:
            continue
        if "State:\tZ" not in status:
            out.append(pid)
    return out


def _wait_gone(pids: list[int], seconds: float) -> list[int]:
    deadline = time.monotonic() + seconds
    while _alive(pids) and time.monotonic() < deadline:
        time.sleep(0.1)
    return _alive(pids)


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM, signal.SIGINT])
def test_a_signal_to_the_driver_stops_its_workers_and_frees_the_run_folder(tmp_path, sig):
    proc, run = _started_run(tmp_path)
    workers = _workers_of(proc.pid)
    try:
        os.kill(proc.pid, sig)
        proc.wait(timeout=30)  # had it waited for its jobs (100,000 episodes each): hours
        left = _wait_gone(workers, 10)
        assert left == [], f"workers {left} outlived the driver"
        with locked_folder(run, "run folder"):  # nobody holds it any more
            pass
    finally:
        _kill_all(proc, workers)
    if sig != signal.SIGKILL:  # the shell's status for a signal, and one line
        assert proc.returncode == 128 + sig
        err = proc.stderr.read().decode()
        assert "Traceback" not in err
        assert err.startswith("ilpss-experiment: stopped by ")
        assert err.endswith("the finished jobs are kept, and the same command goes on from "
                            "them\n")


def test_a_sigterm_during_a_job_run_in_the_driver_stops_the_command(monkeypatch):
    """With one worker the jobs run in the driver: the SIGTERM handler's exit is the
    command's, not a failure of the job it interrupted (after which the rest ran)."""
    from ilpss.experiments.executor import LocalExecutor, Stopped, stop_on_sigterm

    ran = []

    def job(i):
        ran.append(i)
        if i == 0:
            os.kill(os.getpid(), signal.SIGTERM)
            _spin_briefly()  # the handler runs here
        return i

    previous = signal.getsignal(signal.SIGTERM)
    try:
        stop_on_sigterm()
        with pytest.raises(Stopped) as stopped:
            LocalExecutor(1, progress=False).map(job, [0, 1, 2])
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert stopped.value.code == 143 and ran == [0]


def _spin_briefly() -> None:
    for _ in range(100_000):
        pass


@pytest.mark.parametrize("command", ["ilpss-experiment", "ilpss-demo", "ilpss-results"])
def test_ctrl_c_ends_a_command_in_one_line_with_status_130(tmp_path, monkeypatch, capsys,
                                                           command):
    from ilpss.lifelong import LifelongLearner

    def run_trial(self, env, name, callback=None):
        raise KeyboardInterrupt  # as Ctrl-C does in the middle of a job

    monkeypatch.setattr(LifelongLearner, "run_trial", run_trial)
    main_module, _, arguments, _, _ = REPORTING_COMMANDS[command]
    main = importlib.import_module(f"ilpss.experiments.{main_module}").main
    previous = signal.getsignal(signal.SIGTERM)
    try:
        with pytest.raises(SystemExit) as exit_info:
            main(arguments(tmp_path))
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert exit_info.value.code == 130
    assert capsys.readouterr().err.endswith(
        f"{command}: stopped by Ctrl-C (SIGINT); the finished jobs are kept, and the same "
        "command goes on from them\n")


def test_forked_workers_do_not_hold_the_drivers_folder_lock(tmp_path):
    """The lock goes with the driver: a worker that outlives it (on a platform without
    PR_SET_PDEATHSIG) does not keep the folder locked."""
    from ilpss.experiments.executor import _worker_start

    started_r, started_w = os.pipe()
    ready, release = os.pipe()
    with locked_folder(tmp_path, "run folder"):
        pid = os.fork()
        if pid == 0:  # the worker: starts as a pool's worker does, then outlives its job
            try:
                _worker_start(os.getppid())
                os.write(started_w, b"x")
                os.read(ready, 1)
            finally:
                os._exit(0)
        os.read(started_r, 1)
    try:
        with locked_folder(tmp_path, "run folder"):  # the driver let go; the worker lives
            pass
    finally:
        os.write(release, b"x")
        os.waitpid(pid, 0)


# ------------------------------------------------------------ failing jobs
def test_a_failing_job_keeps_the_others_results_and_names_itself(tmp_path, monkeypatch):
    from ilpss.lifelong import LifelongLearner

    real = LifelongLearner.run_trial

    def run_trial(self, env, name, callback=None):
        if self.seed == 1:
            raise RuntimeError("the team of seed 1 broke")
        return real(self, env, name, callback)

    monkeypatch.setattr(LifelongLearner, "run_trial", run_trial)
    cfg = _tiny(n_seeds=3, workers=2)
    with pytest.raises(JobError, match=r"1 of 3 job\(s\) failed:\n  seed 1, stream 0: "
                                       r"RuntimeError: the team of seed 1 broke\nThe 2 "
                                       r"finished job\(s\) are kept"):
        run_experiment(cfg, tmp_path, progress=False)
    assert [p.parent.parent.name for p in sorted(tmp_path.glob("seed_*/*/result.json"))] == [
        "seed_000", "seed_002"]
    monkeypatch.undo()
    ran = []
    run_experiment(cfg, tmp_path, progress=False, on_done=lambda spec, done: ran.append(spec.seed))
    assert ran == [1]


def test_sys_exit_in_a_job_is_a_failure_of_that_job_not_a_clean_exit(tmp_path, monkeypatch,
                                                                     capsys):
    from ilpss.experiments import cli
    from ilpss.lifelong import LifelongLearner

    def run_trial(self, env, name, callback=None):
        sys.exit()

    monkeypatch.setattr(LifelongLearner, "run_trial", run_trial)
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["--protocol", "A", "--seeds", "1", "--methods", "scratch", "--episodes", "3",
                  "--rollouts", "1", "--workers", "1", "--quiet", "--out", str(tmp_path)])
    assert exit_info.value.code == 1
    assert "seed 0, stream 0: RuntimeError: the job's code called sys.exit(None)" in \
        capsys.readouterr().err


# Each command that writes a page about finished runs: the module whose writer fails, the
# arguments (given the folder), the folder of the runs and the page, below that folder.
_TINY = ["--episodes", "3", "--rollouts", "1", "--workers", "1", "--quiet"]
REPORTING_COMMANDS = {
    "ilpss-experiment": ("cli", "report", lambda out: [
        "--protocol", "A", "--seeds", "1", "--methods", "scratch", "ilpss", *_TINY,
        "--out", str(out)], ".", "report.md"),
    "ilpss-results": ("results_doc", "results_doc", lambda out: [
        "--runs", str(out / "runs"), "--docs", str(out / "docs"), "--protocols", "A",
        "--seeds-a", "1", *_TINY], "runs", "docs/results.md"),
    "ilpss-demo": ("demo", "demo", lambda out: [
        "--out", str(out), "--seeds", "1", "--episodes", "3", "--workers", "1"], ".",
        "report.md"),
}


@pytest.mark.parametrize("command", REPORTING_COMMANDS)
def test_a_full_disk_at_the_report_is_a_clear_error_and_keeps_the_results(
        tmp_path, monkeypatch, capsys, command):
    main_module, writing_module, arguments, runs, page = REPORTING_COMMANDS[command]
    main = importlib.import_module(f"ilpss.experiments.{main_module}").main
    writing = importlib.import_module(f"ilpss.experiments.{writing_module}")
    page = tmp_path / page
    monkeypatch.setattr(writing, "atomic_write_bytes", full_disk(
        writing.atomic_write_bytes, at=lambda path: path == page))
    with pytest.raises(SystemExit) as exit_info:
        main(arguments(tmp_path))
    assert exit_info.value.code == 1  # not a traceback
    err = capsys.readouterr().err
    assert f"the runs finished and their results are kept in {(tmp_path / runs)}" in err
    assert f"cannot write {page}: No space left on device" in err
    assert list(tmp_path.glob("**/seed_000/stream_00/result.json"))
    monkeypatch.undo()
    assert main(arguments(tmp_path)) == 0  # the same command writes the page
    assert page.is_file()


@pytest.mark.parametrize("command", REPORTING_COMMANDS)
def test_a_folder_that_is_not_utf8_is_refused_before_any_job(tmp_path, monkeypatch, capsys,
                                                             command):
    from ilpss.experiments.executor import LocalExecutor

    monkeypatch.setattr(LocalExecutor, "map", lambda *a, **k: pytest.fail("it ran a job"))
    main_module, _, arguments, _, _ = REPORTING_COMMANDS[command]
    main = importlib.import_module(f"ilpss.experiments.{main_module}").main
    out = tmp_path / os.fsdecode(b"run\xff")  # as argv decodes a byte that is not UTF-8
    with pytest.raises(SystemExit) as exit_info:
        main(arguments(out))
    assert exit_info.value.code == 2  # before: every job ran, then the page failed
    err = capsys.readouterr().err
    assert ": not UTF-8; the page written at the end names it in UTF-8" in err
    assert repr(os.fsencode(out))[:-1] in err  # the folder's bytes (or a path under it)
    assert not out.exists()


def test_a_full_disk_at_a_result_is_a_clear_error_and_keeps_the_results_written(
        tmp_path, monkeypatch, capsys):
    from ilpss.experiments import cli
    from ilpss.experiments import run as run_module

    monkeypatch.setattr(run_module, "atomic_write_bytes", full_disk(
        run_module.atomic_write_bytes,
        at=lambda path: path.name == "result.json" and path.parent.parent.name == "seed_001"))
    argv = ["--protocol", "A", "--seeds", "2", "--methods", "scratch", "--episodes", "3",
            "--rollouts", "1", "--workers", "1", "--quiet", "--no-report", "--out",
            str(tmp_path)]
    with pytest.raises(SystemExit) as exit_info:
        cli.main(argv)
    assert exit_info.value.code == 1  # not a traceback
    assert (f"ilpss-experiment: error: [Errno 28] cannot write "
            f"{tmp_path / 'seed_001' / 'stream_00' / 'result.json'}: No space left on device"
            ) in capsys.readouterr().err
    assert (tmp_path / "seed_000" / "stream_00" / "result.json").is_file()
    monkeypatch.undo()
    assert cli.main(argv) == 0  # the resume finishes seed 1 only
    assert (tmp_path / "seed_001" / "stream_00" / "result.json").is_file()


# ------------------------------------------------------------ comparisons and settings
@pytest.mark.parametrize("other_cfg, differs", [
    # Held out against goal guards (the baseline) and against chasers.
    ({"teams": ("interceptors_press", "interceptors_cover", "interceptor_guard"),
      "targets": ("chasers",)}, r"tasks: .*goal_guards.* saved, .*chasers.* here"),
    ({"protocol": "C", "stream_length": 2}, r"protocol: 'A' saved, 'C' here"),
])
def test_compare_refuses_runs_of_another_stream(tmp_path, other_cfg, differs):
    from ilpss.experiments.compare import compare_runs

    base, other = tmp_path / "base", tmp_path / "other"
    run_experiment(_tiny(n_seeds=2), base, progress=False)
    run_experiment(_tiny(n_seeds=2, **other_cfg), other, progress=False)
    with pytest.raises(ValueError, match=r"does not learn what the baseline .* learns on seed "
                                         rf"0: .*{differs}"):
        compare_runs((base, "scratch"), {"other": (other, "scratch")})


def test_compare_splits_an_item_where_a_run_folder_follows(tmp_path, monkeypatch):
    from ilpss.experiments.compare import split_run

    monkeypatch.chdir(tmp_path)
    (tmp_path / "runs" / "alpha=0.5").mkdir(parents=True)
    (tmp_path / "runs" / "alpha=0.5" / "config.json").write_text("{}")
    assert split_run("A=runs/alpha=0.5:scratch") == ("A", Path("runs/alpha=0.5"), "scratch")
    assert split_run("K = 1=runs/alpha=0.5:ilpss") == ("K = 1", Path("runs/alpha=0.5"), "ilpss")
    (tmp_path / "0.5").mkdir()  # another run, which splitting at the last "=" would read
    (tmp_path / "0.5" / "config.json").write_text("{}")
    with pytest.raises(ValueError, match=r"ambiguous: it can be read with the run folders "
                                         r"'runs/alpha=0.5', '0.5'"):
        split_run("A=runs/alpha=0.5:scratch")
    with pytest.raises(ValueError, match="FOLDER a run folder"):
        split_run("A=nowhere:scratch")


def test_compare_refuses_a_label_given_twice(tmp_path, monkeypatch, capsys):
    from ilpss.experiments.compare import main as compare_main

    monkeypatch.chdir(tmp_path)
    for name in ("base", "one", "two"):
        (tmp_path / name).mkdir()
        (tmp_path / name / "config.json").write_text("{}")
    # Refused before any run is read: keeping the last would drop a row from the table
    # and a run from the Holm family.
    with pytest.raises(SystemExit) as exc:
        compare_main(["--baseline", "base:scratch", "A=one:ilpss", "B=one:ilpss",
                      "A=two:ilpss"])
    assert exc.value.code == 2
    assert ("the label 'A' is given twice ('A=one:ilpss' and 'A=two:ilpss'); every run "
            "needs a label of its own") in capsys.readouterr().err


def test_a_partial_config_keeps_the_experiments_defaults(tmp_path):
    path = tmp_path / "config.json"
    path.write_text(json.dumps({"protocol": "A", "lifelong": {"train_episodes": 50,
                                                              "learner": {"alpha": 0.25}}}))
    cfg = read_config(path)
    default = ExperimentConfig()
    assert cfg.lifelong.learner.tile_widths == default.lifelong.learner.tile_widths
    assert (cfg.lifelong.train_episodes, cfg.lifelong.learner.alpha) == (50, 0.25)
    assert cfg == default.with_overrides(lifelong={"train_episodes": 50,
                                                   "learner": {"alpha": 0.25}})


@pytest.mark.parametrize("item, match", [
    ("learner.alpha=100", r"LearnerConfig.alpha must be a finite number in \(0, 1\]"),
    ("learner.initial_value=1e308", r"LearnerConfig.initial_value must be a finite number in"),
    ("kernel_reg_covar=1e308", r"LifelongConfig.kernel_reg_covar must be a finite number in "
                               r"\[0, 1e\+06\]"),
])
def test_settings_that_would_diverge_are_refused_before_config_json(tmp_path, capsys, item,
                                                                    match):
    from ilpss.experiments import cli

    with pytest.raises(SystemExit) as exit_info:
        cli.main(["--seeds", "1", "--set", item, "--out", str(tmp_path / "run")])
    assert exit_info.value.code == 2
    assert __import__("re").search(match, capsys.readouterr().err)
    assert not (tmp_path / "run").exists()


def test_learning_that_diverges_stops_at_once_naming_the_settings(monkeypatch):
    from synthetic_smdp import ZoneCorridor

    import ilpss.smdp
    from ilpss.smdp import SmdpLearner
    from ilpss.tiles import TileCoder
    from ilpss.traces import DivergedError

    class Overflowing(ZoneCorridor):
        def step(self, action):
            obs, reward, terminated, truncated, info = super().step(action)
            return obs, reward * 1e308 * 10, terminated, truncated, info  # inf

    env = Overflowing(cost=0.05, n_features=2)
    coder = TileCoder.from_space(env.observation_space, np.array([1.0, 0.5]), 4)
    learner = SmdpLearner(3, coder, None, config=KEEPAWAY, seed=0)
    # an environment's reward that is not finite: refused at its step, naming it
    with pytest.raises(ValueError, match=r"the reward the environment's step returned must be "
                                         r"a finite number, got -?inf"):
        learner.train(env, 3, seed=0)

    def overflowed(*args):  # values that left a float's range in an update
        raise DivergedError("a TD target of inf (the action values are no longer finite)")

    monkeypatch.setattr(ilpss.smdp, "td_update", overflowed)
    learner = SmdpLearner(3, coder, None, config=KEEPAWAY, seed=0)
    with pytest.raises(DivergedError, match=r"SMDP learning diverged in learning episode 1: a "
                                            r"TD target of inf .*alpha=0.125"):
        learner.train(ZoneCorridor(cost=0.05, n_features=2), 3, seed=0)


def test_a_job_failing_for_its_settings_is_not_advised_to_run_again(tmp_path, capsys):
    from ilpss.experiments import cli

    argv = ["--protocol", "A", "--seeds", "1", "--methods", "scratch", *_TINY, "--no-report",
            "--set", "learner.max_decisions=1", "--out", str(tmp_path)]
    with pytest.raises(SystemExit) as exit_info:
        cli.main(argv)
    assert exit_info.value.code == 1
    err = capsys.readouterr().err
    assert ("seed 0, stream 0: DecisionLimitError: episode exceeded max_decisions=1 "
            "(LearnerConfig.max_decisions") in err
    # The same command fails the same way: the advice is to change the setting elsewhere.
    assert "run the same command again" not in err
    assert ("running the same command again does not help: change the setting named above, "
            "in a new run folder") in err


# ------------------------------------------------------------ outputs checked first
def test_holder_learning_checks_its_output_before_learning(tmp_path, monkeypatch, capsys):
    from ilpss.experiments import holder_learning
    from ilpss.experiments.executor import LocalExecutor

    monkeypatch.setattr(LocalExecutor, "map", lambda *a, **k: pytest.fail("it learnt"))
    (tmp_path / "file").write_text("x")
    for out, said in ((tmp_path, "a folder, where the output file belongs"),
                      (tmp_path / "file" / "learning.md", "file is a file, not a folder")):
        with pytest.raises(SystemExit) as exit_info:
            holder_learning.main(["--teams", "chasers", "--episodes", "1", "--eval", "1",
                                  "--out", str(out)])
        assert exit_info.value.code == 2
        assert said in capsys.readouterr().err


@pytest.mark.parametrize("argv, said", [
    (["--teams", "chasers", "nope"], "unknown team 'nope'; known teams: ["),
    (["--rules", "soccer_drill.policies:NOTHING"], "--rules soccer_drill.policies:NOTHING: "),
])
def test_holder_learning_checks_its_teams_and_rules_before_learning(tmp_path, monkeypatch,
                                                                    capsys, argv, said):
    from ilpss.experiments import holder_learning
    from ilpss.experiments.executor import LocalExecutor

    monkeypatch.setattr(LocalExecutor, "map", lambda *a, **k: pytest.fail("it learnt"))
    with pytest.raises(SystemExit) as exit_info:
        holder_learning.main([*argv, "--out", str(tmp_path / "learning.md")])
    assert exit_info.value.code == 2
    assert said in capsys.readouterr().err


@pytest.mark.parametrize("argv, said", [
    (["--runs", "{file}"], "--runs {file}: exists and is not a folder"),
    (["--docs", "{file}"], "--docs {file}: exists and is not a folder"),
    (["--seeds-a", "0"], "ExperimentConfig.n_seeds must be an integer in [1, 100,000], got 0"),
])
def test_results_checks_its_arguments_before_any_run(tmp_path, monkeypatch, capsys, argv, said):
    from ilpss.experiments import results_doc

    monkeypatch.setattr(results_doc, "run_experiment", lambda *a, **k: pytest.fail("it ran"))
    monkeypatch.chdir(tmp_path)
    file = tmp_path / "file"
    file.write_text("x")
    with pytest.raises(SystemExit) as exit_info:
        results_doc.main([a.format(file=file) for a in argv])
    assert exit_info.value.code == 2
    assert said.format(file=file) in capsys.readouterr().err


def test_demo_checks_its_output_folder_first(tmp_path, capsys):
    from ilpss.experiments import demo

    (tmp_path / "file").write_text("x")
    with pytest.raises(SystemExit) as exit_info:
        demo.main(["--out", str(tmp_path / "file")])
    assert exit_info.value.code == 2
    assert "exists and is not a folder" in capsys.readouterr().err


@pytest.mark.parametrize("out, said", [
    ("/", "the root of a file system"),
    ("{home}", "holds other files and no config.json, so it is not a run folder"),
])
def test_an_output_folder_that_is_not_a_run_folder_is_refused(tmp_path, capsys, out, said):
    from ilpss.experiments import cli

    home = tmp_path / "home"
    home.mkdir()
    (home / "notes.txt").write_text("mine")
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["--seeds", "1", "--out", out.format(home=home)])
    assert exit_info.value.code == 1
    assert said in capsys.readouterr().err
    assert sorted(p.name for p in home.iterdir()) == ["notes.txt"]


def test_a_folder_holding_only_the_temporary_of_config_json_is_a_run_folder(tmp_path):
    """What a run killed while writing config.json leaves, and what a second run started
    on the same folder sees while the first writes it: a run folder, not other files."""
    out = tmp_path / "run"
    out.mkdir()
    (out / ".config.json.4242.0123456789ab.tmp").write_text('{"half": ')
    run_experiment(_tiny(), out)
    assert not list(out.glob(".config.json.*.tmp"))
    assert json.loads((out / "config.json").read_text())["n_seeds"] == 1
    assert (out / "seed_000" / "stream_00" / "result.json").is_file()


def test_a_ray_address_where_nothing_listens_fails_at_once_before_config_json(tmp_path):
    from ilpss.experiments.executor import check_ray_address

    start = time.monotonic()
    with pytest.raises(ValueError, match=r"Ray address 127.0.0.1:1: no cluster answers there"):
        run_experiment(_tiny(executor="ray"), tmp_path / "run", ray_address="127.0.0.1:1")
    assert time.monotonic() - start < 10
    assert not (tmp_path / "run" / "config.json").exists()
    with pytest.raises(ValueError, match="expected HOST:PORT"):
        check_ray_address("nohost")


def test_the_report_names_the_windows_its_curves_have(tmp_path):
    from ilpss.experiments.report import write_report

    cfg = _tiny(n_seeds=2)
    results = run_experiment(cfg, tmp_path, progress=False)
    text = write_report(cfg, results, tmp_path, command="x").read_text()
    assert "jumpstart over the first 3 episodes" in text
    assert "the mean of the last 3" in text and "first 20" not in text


def _top_level(i):
    return i


def test_an_interrupted_pool_leaves_no_thread_behind():
    """After a map is interrupted, the pool's manager thread has ended: left running, it
    raced the interpreter's exit hook, and a stopped command could end in a traceback
    ("Bad file descriptor") after its one line."""
    import threading

    from ilpss.experiments.executor import LocalExecutor

    def done(i, result):
        raise KeyboardInterrupt  # as Ctrl-C does while the driver records a result

    with pytest.raises(KeyboardInterrupt):
        LocalExecutor(2, progress=False).map(_top_level, list(range(6)), done=done)
    managers = [t for t in threading.enumerate()
                if type(t).__name__ == "_ExecutorManagerThread" and t.is_alive()]
    assert managers == []
