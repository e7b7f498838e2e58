"""Checkpoint storage named by a path or a URI: the results equal a run in the run folder,
a crash at any upload leaves the last checkpoint current, and a storage that a node cannot
reach, or that another run claimed, stops the job with an error saying so."""

from __future__ import annotations

import os
import sys

import pytest

from ilpss._io import FolderInUseError, locked_folder
from ilpss.experiments.checkpoints import OWNER, StorageError, UriStore, open_store
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.run import JobError, JobSpec, run_experiment, run_stream
from ilpss.lifelong import LifelongLearner

pytest.importorskip("pyarrow.fs", reason="a storage URI needs pyarrow (the 'cluster' extra)")


def _tiny(**changes) -> ExperimentConfig:
    return ExperimentConfig(n_seeds=1, workers=1, methods=("ilpss", "scratch"),
                            **changes).with_overrides(
        lifelong={"train_episodes": 3, "rollout_episodes": 2, "n_kernels": 2})


@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    """A run with its checkpoints in the run folder: (folder, results)."""
    out = tmp_path_factory.mktemp("straight")
    return out, run_experiment(_tiny(), out, progress=False)


def _files(root) -> list[str]:
    return sorted(p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file())


def test_a_uri_storage_holds_the_checkpoints_and_the_results_are_the_same(tmp_path, straight):
    folder, expected = straight
    storage = tmp_path / "storage"
    cfg = _tiny(storage=storage.as_uri())
    out = tmp_path / "run"
    assert run_experiment(cfg, out, progress=False) == expected
    # The driver wrote the results; no job wrote into the run folder.
    assert _files(out) == ["config.json", "seed_000/stream_00/result.json", "team_code.json"]
    assert (out / "seed_000/stream_00/result.json").read_bytes() == (
        folder / "seed_000/stream_00/result.json").read_bytes()
    # The storage holds what the run folder would have held, file for file.
    checkpoints = [f for f in _files(folder) if "/ilpss/" in f or "/scratch/" in f]
    assert _files(storage) == sorted([OWNER, *checkpoints])
    for name in checkpoints:
        assert (storage / name).read_bytes() == (folder / name).read_bytes(), name
    # A resume reads the checkpoints back from the storage: every trial is found done.
    (out / "seed_000/stream_00/result.json").unlink()
    done = []
    assert run_experiment(cfg, out, progress=False,
                          on_done=lambda spec, d: done.append(d)) == expected
    assert done[0].resumed == {"ilpss": 4, "scratch": 4}


def test_a_crash_at_an_upload_leaves_the_last_checkpoint_current(tmp_path, straight, monkeypatch):
    _, expected = straight
    storage = tmp_path / "storage"
    cfg = _tiny(storage=storage.as_uri())
    real = UriStore._publish

    def publish(self, path, data):  # dies between writing LATEST's temporary and the move
        if path.endswith("ilpss/LATEST") and data == b"trial_0002":
            with self._fs.open_output_stream(path.replace("LATEST", f".LATEST.{'0' * 32}.tmp")
                                             ) as f:
                f.write(data)
            raise OSError("connection reset")
        return real(self, path, data)

    monkeypatch.setattr(UriStore, "_publish", publish)
    with pytest.raises(JobError, match="seed 0, stream 0: OSError: connection reset"):
        run_experiment(cfg, tmp_path / "run", progress=False)
    ilpss = storage / "seed_000/stream_00/ilpss"
    assert (ilpss / "LATEST").read_text() == "trial_0001"  # the upload before is current
    assert (ilpss / "trial_0002" / "state.json").exists()  # uploaded, never named
    assert (ilpss / f".LATEST.{'0' * 32}.tmp").read_text() == "trial_0002"
    monkeypatch.undo()
    assert run_experiment(cfg, tmp_path / "run", progress=False) == expected
    assert sorted(p.name for p in ilpss.iterdir()) == ["LATEST", "trial_0004"]


def test_a_storage_claimed_by_another_run_stops_the_first_ones_jobs(tmp_path, monkeypatch):
    uri = (tmp_path / "storage").as_uri()
    real = LifelongLearner.run_trial

    def run_trial(self, env, name, callback=None):
        if self.n_trials == 1:  # meanwhile, another run takes the storage over
            open_store(uri).claim(os.fspath(tmp_path / "other"))
        return real(self, env, name, callback)

    monkeypatch.setattr(LifelongLearner, "run_trial", run_trial)
    with pytest.raises(JobError, match=r"StorageError: .*claimed since by another run \(run folder "
                                           r"'.*other' on '.*'\); one run at a time"):
        run_experiment(_tiny(storage=uri), tmp_path / "run", progress=False)
    ilpss = tmp_path / "storage/seed_000/stream_00/ilpss"
    assert (ilpss / "LATEST").read_text() == "trial_0001"  # nothing written after the claim


def test_a_job_that_cannot_reach_the_storage_is_told_so(tmp_path):
    spec = JobSpec(_tiny(), 0, 0, os.fspath(tmp_path / "not_shared"), token="abc")
    with pytest.raises(StorageError, match=r"not_shared: not reachable from node .* \(its "
                                           r"owner.json is missing there\); on a cluster, pass "
                                           r"--storage a path or URI that every node"):
        run_stream(spec)
    assert not (tmp_path / "not_shared" / "seed_000").exists()  # nothing learnt or written


def test_a_path_storage_is_held_locked_like_the_run_folder(tmp_path):
    storage = tmp_path / "shared"
    storage.mkdir()
    with locked_folder(storage, "test"), pytest.raises(
            FolderInUseError, match=r"shared: this checkpoint storage is being written by "
                                    r"another process"):
        run_experiment(_tiny(storage=os.fspath(storage)), tmp_path / "run", progress=False)
    assert not (tmp_path / "run" / "config.json").exists()


def test_storage_locations_that_cannot_be_one_are_refused_by_name(tmp_path, monkeypatch):
    with pytest.raises(ValueError, match=r"checkpoint storage 'nosuch://x/y': not a URI that "
                                         r"pyarrow.fs can open"):
        open_store("nosuch://x/y")
    for bad in ("", 3):
        with pytest.raises(ValueError, match=r"ExperimentConfig.storage must be None or a "
                                             r"non-empty string"):
            ExperimentConfig(storage=bad)
    store = open_store((tmp_path / "s").as_uri())
    (tmp_path / "s" / "k").mkdir(parents=True)
    (tmp_path / "s" / "k" / "LATEST").write_text("../../../etc")
    with pytest.raises(ValueError, match=r"s/k/LATEST: does not name a checkpoint"):
        store.restore("k", None)
    store.close()
    monkeypatch.setitem(sys.modules, "pyarrow.fs", None)  # pyarrow not installed
    with pytest.raises(StorageError, match=r"a URI needs pyarrow \(pip install "
                                           r"'soccer-drill-ilpss\[cluster\]'\)"):
        open_store("s3://bucket/run")


def test_a_ray_address_needs_the_ray_executor(tmp_path, capsys):
    from ilpss.experiments.cli import main

    with pytest.raises(SystemExit) as exit_info:
        main(["--ray-address", "head:6379", "--out", str(tmp_path / "run")])
    assert exit_info.value.code == 2
    assert "--ray-address needs --executor ray" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()
