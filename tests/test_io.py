"""Tests of ilpss._io: atomic writes and checked, pickle-free .npz archives."""

from __future__ import annotations

import io
import json
import os
import shutil
import stat
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from ilpss import _io
from ilpss._io import atomic_write_bytes, load_npz, save_npz_atomic

SCHEMA = "test.thing/1"
REQUIRED = {"w": (("K", "d"), "f"), "c": (("K",), "iu"), "t": ((None,), "f")}


def _arrays() -> dict[str, np.ndarray]:
    return {"w": np.arange(6.0).reshape(3, 2), "c": np.array([1, 2, 3]), "t": np.zeros(0)}


def test_atomic_write_creates_and_replaces(tmp_path: Path) -> None:
    path = tmp_path / "f.bin"
    atomic_write_bytes(path, b"first")
    atomic_write_bytes(path, b"second")
    assert path.read_bytes() == b"second"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.bin"]


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX permissions")
def test_atomic_write_respects_umask(tmp_path: Path) -> None:
    old = os.umask(0o027)
    try:
        atomic_write_bytes(tmp_path / "f.bin", b"x")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "f.bin").stat().st_mode) == 0o640


def test_atomic_write_failure_keeps_old_file_and_cleans_up(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "f.bin"
    path.write_bytes(b"old")

    def crash(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", crash)
    with pytest.raises(OSError, match="disk full"):
        atomic_write_bytes(path, b"new")
    assert path.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.bin"]


def test_atomic_write_missing_directory(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        atomic_write_bytes(tmp_path / "no" / "f.bin", b"x")


def test_round_trip_keeps_arrays_meta_and_extras(tmp_path: Path) -> None:
    path = tmp_path / "a.npz"
    meta = {"schema": SCHEMA, "nested": {"x": [1, 2.5, None, "s"]}, "flag": True}
    save_npz_atomic(path, {**_arrays(), "extra": np.array(["a", "bc"])}, meta)
    arrays, loaded_meta = load_npz(path, SCHEMA, REQUIRED, optional={"extra": ((None,), "U")})
    assert loaded_meta == meta
    assert set(arrays) == {"w", "c", "t", "extra"}
    with pytest.raises(ValueError, match=r"unexpected array\(s\) \['extra'\]; this schema holds"):
        load_npz(path, SCHEMA, REQUIRED)
    for name, value in _arrays().items():
        np.testing.assert_array_equal(arrays[name], value)
        assert arrays[name].dtype == value.dtype
    # Written exactly at the path given: no ".npz" appended to other names.
    save_npz_atomic(tmp_path / "b.model", _arrays(), {"schema": SCHEMA})
    assert (tmp_path / "b.model").exists()


@pytest.mark.parametrize(
    ("arrays", "meta", "match"),
    [
        ({}, {}, "must contain a string 'schema'"),
        ({}, {"schema": 1}, "must contain a string 'schema'"),
        ({}, {"schema": SCHEMA, "x": float("nan")}, "strict JSON"),
        ({}, {"schema": SCHEMA, "x": object()}, "strict JSON"),
        ({"o": np.array([{}], dtype=object)}, {"schema": SCHEMA}, "dtype object"),
        ({"__meta__": np.zeros(1)}, {"schema": SCHEMA}, "invalid array name"),
    ],
)
def test_save_refuses_unsafe_content(tmp_path: Path, arrays, meta, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        save_npz_atomic(tmp_path / "x.npz", arrays, meta)
    assert not (tmp_path / "x.npz").exists()


def _write(path: Path, arrays: dict, record: str | None) -> None:
    buffer = io.BytesIO()
    extra = {} if record is None else {"__meta__": np.array(record)}
    np.savez(buffer, **arrays, **extra)
    path.write_bytes(buffer.getvalue())


def test_load_refuses_bad_files(tmp_path: Path) -> None:
    good = tmp_path / "good.npz"
    save_npz_atomic(good, _arrays(), {"schema": SCHEMA})
    raw = good.read_bytes()
    bad = tmp_path / "bad.npz"

    def refused(match: str, required=REQUIRED, schema=SCHEMA) -> None:
        with pytest.raises(ValueError, match=match) as info:
            load_npz(bad, schema, required)
        assert str(bad) in str(info.value)  # the message names the file

    for cut in (0, 10, len(raw) // 2, len(raw) - 1):
        bad.write_bytes(raw[:cut])
        refused("not a readable .npz archive")
    # Flip a byte inside a member's data: the zip CRC catches it on read.
    damaged = bytearray(raw)
    damaged[60] ^= 0xFF
    bad.write_bytes(bytes(damaged))
    refused("not a readable .npz archive .*Bad CRC-32")
    # Pickles and object arrays are never loaded.
    with bad.open("wb") as fh:  # a file handle: np.save would append ".npy" to a path
        np.save(fh, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    refused(r"not an .npz archive \(a single .npy array\?\)")
    bad.write_bytes(b"\x80\x04\x95garbage")
    refused("not a readable .npz")
    _write(bad, {**_arrays(), "o": np.array([None], dtype=object)}, None)
    refused("not a readable .npz archive: member 'o.npy' holds pickled Python objects")
    # A single .npy array is not an archive.
    with bad.open("wb") as fh:
        np.save(fh, np.zeros(3))
    refused("not an .npz archive")
    # Record problems.
    _write(bad, _arrays(), None)
    refused("missing or malformed '__meta__'")
    _write(bad, _arrays(), "{not json")
    refused("not valid JSON")
    _write(bad, _arrays(), json.dumps({"meta": {"schema": SCHEMA}}))
    refused("unknown container layout")
    # Schema and checksum.
    bad.write_bytes(raw)
    refused("wrong schema 'test.thing/1', expected 'test.thing/2'", schema="test.thing/2")
    with np.load(good) as f:
        record = str(f["__meta__"])
    _write(bad, {**_arrays(), "w": np.ones((3, 2))}, record)
    refused("checksum mismatch")
    tampered = json.loads(record)
    tampered["meta"]["added"] = 1
    _write(bad, _arrays(), json.dumps(tampered))
    refused("checksum mismatch")


@pytest.mark.parametrize(
    ("arrays", "match"),
    [
        ({"w": np.zeros((3, 2)), "t": np.zeros(1)}, "missing array 'c'"),
        ({"w": np.zeros((3, 2)), "c": np.zeros(3), "t": np.zeros(1)}, r"'c' has dtype float64"),
        (
            {"w": np.zeros(6), "c": np.zeros(3, int), "t": np.zeros(1)},
            r"'w' has shape \(6,\), expected \(K, d\)",
        ),
        (
            {"w": np.zeros((3, 2)), "c": np.zeros(4, int), "t": np.zeros(1)},
            "'c' axis 0 has length 4, but K = 3",
        ),
        (
            {"w": np.zeros((3, 2)), "c": np.zeros(3, int), "t": np.zeros((1, 1))},
            r"'t' has shape \(1, 1\)",
        ),
    ],
)
def test_load_checks_required_arrays(tmp_path: Path, arrays, match: str) -> None:
    path = tmp_path / "x.npz"
    save_npz_atomic(path, arrays, {"schema": SCHEMA})
    with pytest.raises(ValueError, match=match):
        load_npz(path, SCHEMA, REQUIRED)


def test_exact_sizes_in_templates(tmp_path: Path) -> None:
    path = tmp_path / "x.npz"
    save_npz_atomic(path, {"v": np.zeros(4)}, {"schema": SCHEMA})
    assert load_npz(path, SCHEMA, {"v": ((4,), "f")})[0]["v"].shape == (4,)
    with pytest.raises(ValueError, match=r"'v' has shape \(4,\), expected \(3\)"):
        load_npz(path, SCHEMA, {"v": ((3,), "f")})


def test_missing_file_is_not_a_value_error(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        load_npz(tmp_path / "none.npz", SCHEMA, {})


# ===========================================================================
# Crash safety and hostile files for every artefact: models, policies, option
# libraries, lifelong checkpoints and experiment results.
class _HalfWriter:
    """A file whose ``write`` stores half of the data, then fails as a full disk would."""

    def __init__(self, fh, log: list[int]) -> None:
        self.fh, self.log = fh, log

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> bool:
        self.fh.close()
        return False

    def write(self, data: bytes) -> int:
        self.fh.write(data[: len(data) // 2])
        self.fh.flush()
        self.log.append(os.fstat(self.fh.fileno()).st_size)  # really half-written on disk
        raise OSError(28, "No space left on device")

    def __getattr__(self, name: str):
        return getattr(self.fh, name)


def _crash_on_write(monkeypatch: pytest.MonkeyPatch, nth: int = 1) -> list[int]:
    """Make the ``nth`` atomic write from now on die half-way; returns the sizes written."""
    real_fdopen, calls, log = os.fdopen, [0], []

    def fdopen(fd, mode="r", *args, **kwargs):
        fh = real_fdopen(fd, mode, *args, **kwargs)
        calls[0] += 1
        return _HalfWriter(fh, log) if calls[0] == nth else fh

    monkeypatch.setattr(os, "fdopen", fdopen)
    return log


def test_a_write_dying_half_way_keeps_the_old_file(tmp_path, monkeypatch) -> None:
    path = tmp_path / "f.bin"
    atomic_write_bytes(path, b"old contents")
    log = _crash_on_write(monkeypatch)
    with pytest.raises(OSError, match="No space left"):
        atomic_write_bytes(path, b"new contents, longer than the old ones")
    assert log and log[0] > 0  # the temporary file really held half the new bytes
    assert path.read_bytes() == b"old contents"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.bin"]  # temporary removed


def test_a_failing_fsync_keeps_the_old_archive(tmp_path, monkeypatch) -> None:
    path = tmp_path / "a.npz"
    save_npz_atomic(path, _arrays(), {"schema": SCHEMA})

    def fsync(fd):
        raise OSError(5, "Input/output error")

    monkeypatch.setattr(os, "fsync", fsync)
    with pytest.raises(OSError, match="Input/output"):
        save_npz_atomic(path, {**_arrays(), "w": np.ones((3, 2))}, {"schema": SCHEMA})
    monkeypatch.undo()
    arrays, _ = load_npz(path, SCHEMA, REQUIRED)
    np.testing.assert_array_equal(arrays["w"], _arrays()["w"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.npz"]


# ------------------------------------------------------------- lifelong checkpoints
def _corridor_learner(trials: int, checkpoint: Path | None = None):
    from synthetic_smdp import ZoneCorridor

    from ilpss.lifelong import LearnerConfig, LifelongConfig, LifelongLearner

    # The setting of tests/test_lifelong.py, which checks that trial 1 already ends with
    # kernels and options (so every kind of file is in the checkpoint).
    envs = [ZoneCorridor(cost=c, n_features=2) for c in (0.02, 0.05)]
    cfg = LifelongConfig(n_kernels=2, train_episodes=40, rollout_episodes=10,
                         learner=LearnerConfig(initial_value=1.0, tile_widths=(1.0, 0.5),
                                               n_tilings=8))
    learner = LifelongLearner(cfg, envs[0].observation_space, 3, seed=3)
    for t in range(trials):
        learner.run_trial(envs[t], f"corridor_{t}")
        if checkpoint is not None:
            learner.save(checkpoint)
    assert learner.library is not None, "the checkpoint tests need an option library"
    return learner, envs[0].observation_space


def _fingerprint(learner) -> tuple:
    lib = learner.library
    return (
        learner.records,
        [p.weights.tobytes() for p in learner.policies],
        [b.tobytes() for b in learner.bags],
        None if lib is None else (lib.option_ids.tolist(), lib.scales.tolist(),
                                  sorted(lib.registry.items())),
        None if learner.kernel_model is None else learner.kernel_model.means_.tobytes(),
    )


@pytest.fixture(scope="module")
def checkpoints(tmp_path_factory):
    """A checkpoint after trial 1, and the learner after trial 2 (not yet saved)."""
    from ilpss.lifelong import LifelongLearner

    root = tmp_path_factory.mktemp("checkpoints")
    one = root / "after_trial_1"
    learner, space = _corridor_learner(1, one)
    first = _fingerprint(LifelongLearner.load(one, space))
    two, _ = _corridor_learner(2)
    return one, space, first, two


def _copy(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst)
    return dst


def test_a_save_over_another_runs_checkpoint_is_refused_and_leaves_it(checkpoints, tmp_path):
    """A checkpoint folder holds one run: saving a learner of another seed or
    configuration there is refused (before, it deleted the other run's checkpoint, or,
    with fewer trials, hid it behind LATEST), while the same run saves on."""
    from dataclasses import replace

    from ilpss.lifelong import LifelongLearner

    template, space, first, learner = checkpoints
    root = _copy(template, tmp_path / "run")
    other = LifelongLearner(learner.config, space, 3, seed=4)
    longer = LifelongLearner(replace(learner.config, rollout_episodes=11), space, 3, seed=3)
    for stranger, differs in ((other, r"seed, records"), (longer, r"config")):
        with pytest.raises(ValueError, match=rf"holds another run's checkpoint \(trial_0001; it "
                                             rf"differs from this learner in {differs}"):
            stranger.save(root)
        assert sorted(p.name for p in root.iterdir()) == ["LATEST", "trial_0001"]
        assert _fingerprint(LifelongLearner.load(root, space)) == first
    learner.save(root)  # the same run, a trial further
    resumed = LifelongLearner.load(root, space)
    resumed.save(root)  # and as loaded
    assert _fingerprint(LifelongLearner.load(root, space)) == _fingerprint(learner)
    (root / "trial_0002" / "state.json").write_text("{}")
    with pytest.raises(ValueError, match=r"holds a checkpoint that cannot be read"):
        learner.save(root)


def test_a_save_to_a_file_is_refused_saying_a_checkpoint_is_a_folder(checkpoints, tmp_path):
    # before, a bare FileExistsError from mkdir
    learner = checkpoints[3]
    path = tmp_path / "notes.py"
    path.write_text("kept")
    with pytest.raises(ValueError, match="exists and is not a folder; a checkpoint is a folder"):
        learner.save(path)
    assert path.read_text() == "kept"


# One lifelong save writes 9 files here: policies 0-1, the library's kernels, policies 0-1
# and record, the bags, state.json, then LATEST (which publishes the checkpoint).
@pytest.mark.parametrize("nth_write", range(1, 10))
def test_a_checkpoint_save_dying_at_any_write_leaves_the_previous_one(
    checkpoints, tmp_path, monkeypatch, nth_write
) -> None:
    from ilpss.lifelong import LifelongLearner

    template, space, first, learner = checkpoints
    root = _copy(template, tmp_path / "run")
    log = _crash_on_write(monkeypatch, nth_write)
    with pytest.raises(OSError, match="No space left"):
        learner.save(root)
    monkeypatch.undo()
    assert log, "the crash was not triggered: fewer writes than expected"
    assert (root / "LATEST").read_text() == "trial_0001"
    assert _fingerprint(LifelongLearner.load(root, space)) == first
    # Saving again succeeds and publishes the new checkpoint; no debris is left.
    learner.save(root)
    assert _fingerprint(LifelongLearner.load(root, space)) == _fingerprint(learner)
    assert sorted(p.name for p in root.iterdir()) == ["LATEST", "trial_0002"]


def test_a_checkpoint_save_dying_at_the_directory_rename_or_cleanup(
    checkpoints, tmp_path, monkeypatch
) -> None:
    from ilpss.lifelong import LifelongLearner

    template, space, first, learner = checkpoints
    root = _copy(template, tmp_path / "rename")
    real_replace, real_rmtree = os.replace, shutil.rmtree

    def replace(src, dst):
        if Path(src).name.startswith(".building_"):
            raise OSError("killed before the rename")
        return real_replace(src, dst)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(OSError, match="killed before the rename"):
        learner.save(root)
    monkeypatch.undo()
    assert _fingerprint(LifelongLearner.load(root, space)) == first

    # Dying after LATEST names the new checkpoint, while deleting the old one: the new one wins.
    root = _copy(template, tmp_path / "cleanup")

    def rmtree(path, *args, **kwargs):
        if Path(path).name == "trial_0001":
            raise KeyboardInterrupt("killed while cleaning up")
        return real_rmtree(path, *args, **kwargs)

    monkeypatch.setattr(shutil, "rmtree", rmtree)
    with pytest.raises(KeyboardInterrupt):
        learner.save(root)
    monkeypatch.undo()
    assert (root / "trial_0001").exists()  # debris, but harmless
    assert _fingerprint(LifelongLearner.load(root, space)) == _fingerprint(learner)


def _edit_state(checkpoint: Path, edit) -> None:
    """Edit state.json and give it a valid digest: only the content checks can refuse."""
    state = checkpoint / "trial_0001" / "state.json"
    record = json.loads(state.read_text())
    del record["sha256"]
    edited = edit(record)
    state.write_bytes(_io.json_record_bytes(edited) if isinstance(edited, dict) and
                      isinstance(edited.get("schema"), str) else json.dumps(edited).encode())


def _record(**changes):
    """An edit of state.json that changes fields of its first trial record."""
    def edit(state: dict) -> dict:
        state["records"][0].update(changes)
        return state
    return edit


def _rewrite_bags(checkpoint: Path, edit) -> None:
    from synthetic_smdp import read_archive

    path = checkpoint / "trial_0001" / "bags.npz"
    arrays, meta = read_archive(path)
    edit(arrays, meta)
    save_npz_atomic(path, arrays, meta)  # a valid digest: only the content checks can refuse


@pytest.mark.parametrize(
    ("tamper", "match"),
    [
        (lambda c: (c / "LATEST").write_text(""), "LATEST: does not name a checkpoint"),
        (lambda c: (c / "LATEST").write_text("../../etc"), "LATEST: does not name a checkpoint"),
        (lambda c: (c / "LATEST").write_text("trial_0042"), r"trial_0042/state.json: unreadable"),
        (lambda c: (c / "trial_0001" / "state.json").write_text('{"schema": "ilpss.lif'),
         "state.json: not valid JSON"),
        (lambda c: _edit_state(c, lambda s: {**s, "schema": "ilpss.lifelong/1"}),
         r"schema 'ilpss.lifelong/1' is not 'ilpss.lifelong/2'"),
        (lambda c: (c / "trial_0001" / "bags.npz").write_bytes(
            (c / "trial_0001" / "bags.npz").read_bytes()[:200]), "not a readable .npz"),
        (lambda c: _rewrite_bags(c, lambda a, m: a.update(bag_0=np.zeros((4, 3)))),
         r"bags.npz: array 'bag_0' has shape \(4, 3\), expected \(\*, 2\)"),
        (lambda c: _rewrite_bags(c, lambda a, m: a.update(bag_0=np.zeros((4, 2), int))),
         r"array 'bag_0' has dtype int64"),
        (lambda c: _rewrite_bags(c, lambda a, m: a.pop("bag_0")), "missing array 'bag_0'"),
        (lambda c: _rewrite_bags(c, lambda a, m: m.update(schema="ilpss.lifelong/1/other")),
         "wrong schema 'ilpss.lifelong/1/other'"),
        (lambda c: (c / "trial_0001" / "policy_0.npz").write_bytes(b""), "not a readable .npz"),
        (lambda c: (c / "trial_0001" / "library" / "kernels.npz").write_bytes(
            (c / "trial_0001" / "library" / "kernels.npz").read_bytes()[:-30]),
         "not a readable|modified"),
        # A file gone is damage too (a FileNotFoundError, not a ValueError, before).
        (lambda c: (c / "trial_0001" / "bags.npz").unlink(), r"bags.npz: missing"),
        (lambda c: (c / "trial_0001" / "policy_0.npz").unlink(), r"policy_0.npz: missing"),
        (lambda c: (c / "trial_0001" / "library" / "library.npz").unlink(),
         r"library/library.npz: missing"),
    ],
)
def test_damaged_checkpoints_are_refused_by_name(checkpoints, tmp_path, tamper, match) -> None:
    from ilpss.lifelong import LifelongLearner

    template, space, _, _ = checkpoints
    root = _copy(template, tmp_path / "ckpt")
    tamper(root)
    with pytest.raises(ValueError, match=match) as err:
        LifelongLearner.load(root, space)
    assert str(root) in str(err.value)  # names the file or folder


# Damaged state.json: every field and its agreement with the other files, each refused by name.
@pytest.mark.parametrize(
    ("tamper", "match"),
    [
        (lambda c: _edit_state(c, lambda s: [s]), "state.json: not a JSON object"),
        (lambda c: _edit_state(c, lambda s: {**s, "config": {**s["config"], "n_kernels": 0}}),
         r"state.json: .*n_kernels must be an integer in \[1, 1,000\]"),
        (lambda c: _edit_state(c, lambda s: {**s, "config": {**s["config"], "magic": 1}}),
         r"state.json: .*unknown LifelongConfig field\(s\) \['magic'\]"),
        (lambda c: _edit_state(c, lambda s: {k: v for k, v in s.items() if k != "records"}),
         r"state.json: missing field\(s\) \['records'\]"),
        (lambda c: _edit_state(c, lambda s: {**s, "records": [{**s["records"][0], "x": 1}]}),
         r"state.json: records\[0\]: unknown field\(s\) \['x'\]"),
        (lambda c: _edit_state(c, lambda s: {**s, "records": []}),
         "holds 0 trial records, but its name says trial_0001"),
        (lambda c: shutil.rmtree(c / "trial_0001" / "library"),
         "the option library is missing"),
        (lambda c: _rewrite_bags(c, lambda a, m: a.update(bag_0=np.full((4, 2), np.nan))),
         "array 'bag_0' holds a non-finite value nan"),
        # One character changed: the digest refuses it.
        (lambda c: (c / "trial_0001" / "state.json").write_text(
            (c / "trial_0001" / "state.json").read_text().replace('"n_primitive": 3',
                                                                  '"n_primitive": 7')),
         "state.json: content checksum mismatch"),
        (lambda c: (c / "trial_0001" / "state.json").write_text("[" * 100_000 + "]" * 100_000),
         "state.json: JSON nested too deeply"),
        # With a valid digest, every field and its agreement with the other files.
        (lambda c: _edit_state(c, lambda s: {**s, "n_primitive": 7}),
         r"policy_0.npz: 3 primitive actions, but n_primitive in .*state.json is 7"),
        (lambda c: _edit_state(c, lambda s: {**s, "n_primitive": "3"}),
         r"state.json.n_primitive must be an integer >= 1, got '3'"),
        (lambda c: _edit_state(c, _record(rollout_success_rate="x")),
         r"records\[0\].rollout_success_rate must be a finite number in \[0, 1\], got 'x'"),
        (lambda c: _edit_state(c, _record(rollout_success_rate=0.55)),
         r"records\[0\].rollout_success_rate 0.55 is not a share of 10 rollouts"),
        (lambda c: _edit_state(c, _record(name=7)),
         r"records\[0\].name must be a non-empty string, got 7"),
        (lambda c: _edit_state(c, _record(rewards=[0.0])),
         r"records\[0\].rewards has 1 values, but the configuration's train_episodes is 40"),
        (lambda c: _edit_state(c, _record(bag_size=1)),
         r"bags.npz: bag_0 holds \d+ states, but records\[0\].bag_size in .* is 1"),
        (lambda c: _edit_state(c, _record(library_size=99)),
         r"records\[0\].library_size is 99, but the library holds 2 active options"),
        (lambda c: _edit_state(c, _record(options_used=[999])),
         r"records\[0\] names option ids \[999\] that the library never issued"),
        (lambda c: _edit_state(c, _record(options_offered=2)),
         r"records\[0\].options_offered must be 0"),
        (lambda c: _edit_state(c, lambda s: {**s, "kernel": None}),
         "kernel is None, but files list an option library"),
        (lambda c: _edit_state(c, lambda s: {**s, "config": {**s["config"], "options": "none"}}),
         "kernel 'SharedKernelModel' is not what options='none' builds"),
        (lambda c: _edit_state(c, lambda s: {**s, "files": {**s["files"], "../x.npz": "0"}}),
         "files must map every file of the checkpoint"),
        (lambda c: _edit_state(c, lambda s: {**s, "provenance": "elsewhere"}),
         "provenance must be an object or null"),
        (lambda c: (c / "LATEST").unlink() or (c / "LATEST").mkdir(),
         "LATEST: a folder, where the file naming the checkpoint belongs"),
    ],
)
def test_damaged_checkpoint_state_is_refused(checkpoints, tmp_path, tamper, match) -> None:
    from ilpss.lifelong import LifelongLearner

    template, space, _, _ = checkpoints
    root = _copy(template, tmp_path / "ckpt")
    tamper(root)
    with pytest.raises(ValueError, match=match):
        LifelongLearner.load(root, space)


def test_a_policy_from_another_checkpoint_is_refused(checkpoints, tmp_path) -> None:
    from ilpss.lifelong import LifelongLearner
    from ilpss.policy import FrozenPolicy

    template, space, _, learner = checkpoints
    root = _copy(template, tmp_path / "ckpt")
    learner.policies[1].save(root / "trial_0001" / "policy_0.npz")  # valid, same tile coder
    with pytest.raises(ValueError, match=r"policy_0\.npz: chooses among 2 options, but "
                       r"records\[0\].options_offered in .*state.json is 0"):
        LifelongLearner.load(root, space)
    # The same policy, slightly changed: it agrees with the records, not with the digests.
    root = _copy(template, tmp_path / "ckpt2")
    p = learner.policies[0]
    FrozenPolicy(p.tile_coder, p.n_primitive, p.option_ids, p.weights + 1e-9).save(
        root / "trial_0001" / "policy_0.npz")
    with pytest.raises(ValueError, match=r"library.npz: its policy 0 is not the checkpoint's "
                       r"policy_0.npz"):
        LifelongLearner.load(root, space)
    shutil.copy(root / "trial_0001" / "policy_0.npz", root / "trial_0001" / "library")
    with pytest.raises(ValueError, match=r"library/policy_0.npz: content differs from the file"):
        LifelongLearner.load(root, space)


# ------------------------------------------------------------------ never unpickled
class _Payload:
    """Unpickling this creates ``path``: proof that a loader unpickled."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def __reduce__(self):
        return (open, (str(self.path), "w"))


def _poison(path: Path, marker: Path) -> None:
    """Add a pickled object array to the archive at ``path``, keeping its other members."""
    with np.load(path, allow_pickle=False) as f:
        members = {k: f[k] for k in f.files}
    members["weights"] = np.array([_Payload(marker)], dtype=object)
    buffer = io.BytesIO()
    np.savez(buffer, **members)  # np.savez pickles object arrays
    path.write_bytes(buffer.getvalue())


def test_no_loader_ever_unpickles(checkpoints, tmp_path, monkeypatch) -> None:
    import pickle

    from ilpss.kernels import SharedKernelModel, UniformKernel
    from ilpss.lifelong import LifelongLearner
    from ilpss.options import OptionLibrary
    from ilpss.policy import FrozenPolicy

    template, space, first, _ = checkpoints
    uniform = tmp_path / "uniform.npz"
    UniformKernel(2).save(uniform)
    targets = {
        "policy": (lambda r: r / "trial_0001" / "policy_0.npz",
                   lambda r: FrozenPolicy.load(r / "trial_0001" / "policy_0.npz")),
        "kernels": (lambda r: r / "trial_0001" / "library" / "kernels.npz",
                    lambda r: SharedKernelModel.load(r / "trial_0001" / "library" / "kernels.npz")),
        "library": (lambda r: r / "trial_0001" / "library" / "library.npz",
                    lambda r: OptionLibrary.load(r / "trial_0001" / "library")),
        "bags": (lambda r: r / "trial_0001" / "bags.npz",
                 lambda r: LifelongLearner.load(r, space)),
    }
    for name, (file_of, load) in targets.items():
        root = _copy(template, tmp_path / name)
        marker = tmp_path / f"unpickled_{name}"
        _poison(file_of(root), marker)
        with pytest.raises(ValueError, match=r"not a readable \.npz archive"):
            load(root)
        assert not marker.exists(), f"{name}: the payload ran"
    marker = tmp_path / "unpickled_uniform"
    _poison(uniform, marker)
    with pytest.raises(ValueError, match=r"not a readable \.npz archive"):
        UniformKernel.load(uniform)
    assert not marker.exists()

    # And a whole checkpoint loads with every way to unpickle disabled.
    def refuse(*args, **kwargs):
        raise AssertionError("something tried to unpickle")

    for name in ("load", "loads", "Unpickler"):
        monkeypatch.setattr(pickle, name, refuse)
    assert _fingerprint(LifelongLearner.load(template, space)) == first


# --------------------------------------------------------------- experiment results
def _tiny_experiment():
    from ilpss.experiments.config import ExperimentConfig

    return ExperimentConfig(n_seeds=1, workers=1, methods=("scratch",)).with_overrides(
        lifelong={"train_episodes": 4, "rollout_episodes": 2})


@pytest.fixture(scope="module")
def experiment(tmp_path_factory):
    """An uninterrupted tiny run: (its folder, its job results)."""
    from ilpss.experiments.run import run_experiment

    out = tmp_path_factory.mktemp("experiment")
    return out, run_experiment(_tiny_experiment(), out, progress=False)


def test_a_crash_writing_result_json_leaves_none_and_the_rerun_matches(
    experiment, tmp_path, monkeypatch
) -> None:
    from ilpss.experiments.run import run_experiment

    straight_dir, straight = experiment
    out = tmp_path / "run"
    job = out / "seed_000" / "stream_00"
    real_fdopen = os.fdopen

    def fdopen(fd, mode="r", *args, **kwargs):  # only the result file's write dies
        fh = real_fdopen(fd, mode, *args, **kwargs)
        writing_result = job.is_dir() and any(
            p.name.startswith(".result.json.") for p in job.iterdir())
        return _HalfWriter(fh, []) if writing_result else fh

    monkeypatch.setattr(os, "fdopen", fdopen)
    with pytest.raises(OSError, match="No space left"):
        run_experiment(_tiny_experiment(), out, progress=False)
    monkeypatch.undo()
    assert not (job / "result.json").exists()
    assert not [p for p in job.iterdir() if p.name.startswith(".")]  # no temporary left
    assert run_experiment(_tiny_experiment(), out, progress=False) == straight
    assert (job / "result.json").read_bytes() == (
        straight_dir / "seed_000" / "stream_00" / "result.json").read_bytes()


def _edit_record(path: Path, edit) -> None:
    """Edit a JSON record and give it a valid digest: only the content checks can refuse."""
    record = json.loads(path.read_text())
    del record["sha256"]
    edit(record)
    path.write_bytes(_io.json_record_bytes(record))


def _scratch(record: dict) -> dict:
    return record["methods"]["scratch"]


@pytest.mark.parametrize(
    ("name", "tamper", "match"),
    [
        ("result.json", lambda p: p.write_text(p.read_text()[:40]), "result.json: not valid JSON"),
        ("result.json", lambda p: p.write_text(p.read_text().replace(
            "ilpss.experiment_result/3", "ilpss.experiment_result/0")), "result.json: schema"),
        # One character changed: the digest refuses it.
        ("result.json", lambda p: p.write_text(p.read_text().replace("-1.0", "-9.0", 1)),
         r"result.json: content checksum mismatch"),
        ("result.json", lambda p: p.write_text("[" * 100_000 + "]" * 100_000),
         "result.json: JSON nested too deeply"),
        # With a valid digest, every field is checked.
        ("result.json", lambda p: _edit_record(p, lambda r: r.update(methods={})),
         "result.json: methods"),
        ("result.json", lambda p: _edit_record(
            p, lambda r: _scratch(r)["curves"]["3"].__setitem__(0, -9.0)),
         r"result.json: methods.scratch.curves.3 must be a list of 4 values, each a finite "
         r"number in \[-1, 1\], got \[-9.0"),
        ("result.json", lambda p: _edit_record(
            p, lambda r: _scratch(r)["curves"]["3"].pop()), r"curves.3 must be a list of 4 values"),
        ("result.json", lambda p: _edit_record(
            p, lambda r: _scratch(r).update(rollout_success_rate=["x"] * 4)),
         r"methods.scratch.rollout_success_rate must be a list of 4 values, each a finite "
         r"number in \[0, 1\]"),
        ("result.json", lambda p: _edit_record(
            p, lambda r: _scratch(r).update(library_size=[0, 0, 0])), "library_size must be a list of 4 values"),
        ("result.json", lambda p: _edit_record(p, lambda r: r.update(stream="held_out=x")),
         r"result.json: stream is 'held_out=x', expected 'held_out=goal_guards'"),
        ("result.json", lambda p: _edit_record(p, lambda r: r.update(extra=1)),
         r"result.json: unknown field\(s\) \['extra'\]"),
        # Consistent in itself, but not with the checkpoint it came from.
        ("result.json", lambda p: _edit_record(
            p, lambda r: _scratch(r)["curves"]["3"].__setitem__(0, 0.5)),
         r"methods.scratch disagrees with the checkpoint in .*scratch \(methods.scratch.curves.3"),
        ("config.json", lambda p: p.write_text(p.read_text()[:40]), "config.json: not valid JSON"),
    ],
)
def test_damaged_results_are_refused_by_name(experiment, tmp_path, name, tamper, match) -> None:
    from ilpss.experiments.run import run_experiment

    out = _copy(experiment[0], tmp_path / "run")
    path = out / name if name == "config.json" else out / "seed_000" / "stream_00" / name
    tamper(path)
    with pytest.raises(ValueError, match=match) as err:
        run_experiment(_tiny_experiment(), out, progress=False)
    assert str(path) in str(err.value)


# ------------------------------------------------------------------- bounded loads
def _npy(array: np.ndarray, shape: tuple | None = None) -> bytes:
    """The .npy bytes of ``array``, with the header claiming ``shape`` if given."""
    buffer = io.BytesIO()
    np.lib.format.write_array(buffer, array)
    data = buffer.getvalue()
    if shape is None:
        return data
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": array.dtype.str, "fortran_order": False,
                                                  "shape": shape})
    return header.getvalue() + data[len(header.getvalue()):]


def _zip(path: Path, members: dict[str, bytes], compression: int) -> None:
    good = path.with_name("good.npz")
    save_npz_atomic(good, {"w": np.zeros((2, 2)), "c": np.zeros(2, int), "t": np.zeros(0)},
                    {"schema": SCHEMA})
    with zipfile.ZipFile(good) as src, zipfile.ZipFile(path, "w") as dst:
        dst.writestr("__meta__.npy", src.read("__meta__.npy"))
        for name, data in members.items():
            dst.writestr(name, data, compress_type=compression)


@pytest.fixture
def no_array_read(monkeypatch):
    """Fail the test if load_npz reads any array's data but the small record's."""
    real = np.lib.format.read_array

    def read_array(fp, *args, **kwargs):
        if not getattr(fp, "name", "").startswith("__meta__"):
            raise AssertionError(f"array data read: {fp.name}")
        return real(fp, *args, **kwargs)

    monkeypatch.setattr(np.lib.format, "read_array", read_array)


@pytest.mark.parametrize(
    ("members", "compression", "match"),
    [
        # 64 MiB of zeros in a 65 KiB file: refused before anything is decompressed.
        (lambda: {"w.npy": _npy(np.zeros((4096, 2048)))}, zipfile.ZIP_DEFLATED,
         "member 'w.npy' is compressed; ilpss archives store their arrays uncompressed"),
        # A header claiming more than the member holds.
        (lambda: {"w.npy": _npy(np.zeros((3, 2)), shape=(3 * 10**9, 2))}, zipfile.ZIP_STORED,
         r"member 'w.npy' declares shape \(3000000000, 2\) of float64 \(48,000,000,000 bytes\) "
         r"but holds 48 bytes"),
        (lambda: {"w.npy": _npy(np.zeros((3, 2))), "notes.txt": b"hello"}, zipfile.ZIP_STORED,
         "member 'notes.txt' is not an .npy array; ilpss archives hold only .npy arrays"),
        (lambda: {"w.npy": _npy(np.zeros((3, 2))), "c.npy": _npy(np.zeros(3, int)),
          "t.npy": _npy(np.zeros((3, 3)))}, zipfile.ZIP_STORED,
         r"array 't' has shape \(3, 3\), expected \(\*\)"),
        (lambda: {"w.npy": _npy(np.zeros((3, 2))), "c.npy": _npy(np.zeros(4, int)),
          "t.npy": _npy(np.zeros(0))}, zipfile.ZIP_STORED,
         "'c' axis 0 has length 4, but K = 3"),
        (lambda: {"w.npy": _npy(np.zeros((3, 2))), "c.npy": _npy(np.zeros(3, int)),
          "t.npy": _npy(np.zeros(0)), "x.npy": _npy(np.zeros(10**6))}, zipfile.ZIP_STORED,
         r"unexpected array\(s\) \['x'\]"),
    ],
)
def test_archives_are_checked_before_their_arrays_are_read(
    tmp_path, no_array_read, members, compression, match
) -> None:
    path = tmp_path / "hostile.npz"
    _zip(path, members(), compression)
    with pytest.raises(ValueError, match=match) as err:
        load_npz(path, SCHEMA, REQUIRED)
    assert str(path) in str(err.value)
    if compression == zipfile.ZIP_DEFLATED:
        assert path.stat().st_size < 2**17


def test_a_valid_archive_reads_each_array_once(tmp_path, monkeypatch) -> None:
    path = tmp_path / "a.npz"
    save_npz_atomic(path, _arrays(), {"schema": SCHEMA})
    real, read = np.lib.format.read_array, []
    monkeypatch.setattr(np.lib.format, "read_array",
                        lambda fp, *a, **k: read.append(fp.name) or real(fp, *a, **k))
    load_npz(path, SCHEMA, REQUIRED)
    assert sorted(read) == ["__meta__.npy", "c.npy", "t.npy", "w.npy"]


# ------------------------------------------------------- damaged zip structures
def _central_entries(data: bytes) -> list[int]:
    """Where each central directory entry of a zip file starts."""
    starts, at = [], data.find(b"PK\x01\x02")
    while at != -1:
        starts.append(at)
        at = data.find(b"PK\x01\x02", at + 4)
    return starts


# (offset in a central directory entry, a byte there): the flag bits of an encrypted
# member (0), of "compressed patched data" (5) and strong encryption (6); a version
# needed to extract that zipfile does not read.
@pytest.mark.parametrize(("offset", "value"), [(8, 0x01), (8, 0x20), (8, 0x40), (6, 0x6D),
                                               (6, 0xFF)])
def test_a_damaged_zip_directory_entry_is_a_value_error_naming_the_file(
        tmp_path, offset, value) -> None:
    good = tmp_path / "good.npz"
    save_npz_atomic(good, _arrays(), {"schema": SCHEMA})
    data = bytearray(good.read_bytes())
    for start in _central_entries(data):
        damaged = bytearray(data)
        damaged[start + offset] = value
        path = tmp_path / "damaged.npz"
        path.write_bytes(bytes(damaged))
        with pytest.raises(ValueError, match=r"not a readable \.npz archive") as err:
            load_npz(path, SCHEMA, REQUIRED)
        assert str(path) in str(err.value)


def test_a_damaged_byte_of_the_zip_structures_is_a_value_error_or_loads_the_same(
        tmp_path) -> None:
    good = tmp_path / "good.npz"
    save_npz_atomic(good, _arrays(), {"schema": SCHEMA})
    data = good.read_bytes()
    expected, _ = load_npz(good, SCHEMA, REQUIRED)
    with zipfile.ZipFile(good) as archive:
        headers = {p for info in archive.infolist()
                   for p in range(info.header_offset, info.header_offset + 30)}
    structures = sorted(headers | set(range(_central_entries(data)[0], len(data))))
    path = tmp_path / "damaged.npz"
    for position in structures:
        for flip in (0x01, 0x20, 0x40, 0xFF):  # the flag bits zipfile reads, and all
            damaged = bytearray(data)
            damaged[position] ^= flip
            path.write_bytes(bytes(damaged))
            try:
                arrays, _ = load_npz(path, SCHEMA, REQUIRED)
            except ValueError as exc:
                assert str(path) in str(exc)
            else:  # a byte the reader does not use (a time stamp, a version made by)
                assert all(np.array_equal(arrays[k], expected[k]) for k in expected)


# ------------------------------------------------------- values that pass the kinds
def _tamper(path: Path, **changes) -> None:
    """Save ``path`` back with some arrays (or record fields, ``meta=``) changed and a
    valid digest."""
    from synthetic_smdp import read_archive

    arrays, meta = read_archive(path)
    meta.update(changes.pop("meta", {}))
    arrays.update(changes)
    save_npz_atomic(path, arrays, meta)


@pytest.fixture
def kernels_file(tmp_path):
    from ilpss.kernels import SharedKernelModel

    rng = np.random.default_rng(0)
    model = SharedKernelModel(n_components=2, random_state=0).fit(
        [rng.normal(size=(30, 2)) for _ in range(3)])
    path = tmp_path / "kernels.npz"
    model.save(path)
    return path


def _policy_file(tmp_path):
    from synthetic_smdp import constant_policy

    path = tmp_path / "policy.npz"
    constant_policy(0, option_ids=(0, 1), prefer=2).save(path)
    return path


BEYOND_INT64 = np.array([2**64 - 1], dtype=np.uint64)


def test_integers_that_would_wrap_around_or_not_save_again_are_refused_naming_the_field(
        tmp_path, kernels_file) -> None:
    from synthetic_smdp import IntervalKernels, constant_policy

    from ilpss.kernels import SharedKernelModel
    from ilpss.options import OptionLibrary
    from ilpss.policy import FrozenPolicy

    beyond = r"holds the value 18446744073709551615 at index \((0|1),\), outside the int64 range"
    policy = _policy_file(tmp_path)
    _tamper(policy, option_ids=np.array([0, 2**64 - 1], dtype=np.uint64))
    with pytest.raises(ValueError, match=rf"{policy}: array 'option_ids' {beyond}"):
        FrozenPolicy.load(policy)
    counts = np.array([2**64 - 1, 30, 30], dtype=np.uint64)  # read as -1 before
    _tamper(kernels_file, n_states_per_instance=counts)
    with pytest.raises(ValueError, match=rf"{kernels_file}: array 'n_states_per_instance' "
                                         rf"{beyond}"):
        SharedKernelModel.load(kernels_file)
    library = tmp_path / "library"
    OptionLibrary(IntervalKernels([(0, 3), (3, 6)]), [constant_policy(2)]).save(library)
    _tamper(library / "library.npz", meta={"next_option_id": 2**64})
    with pytest.raises(ValueError, match=r"library.npz: field next_option_id must be an integer "
                                         r"in \[0, 9,223,372,036,854,775,807\], got 2\*\*64|"
                                         r"library.npz: field next_option_id must be an integer "
                                         r"in \[0, 9,223,372,036,854,775,807\], got "
                                         r"18446744073709551616"):
        OptionLibrary.load(library, kernel_loader=IntervalKernels.load)


@pytest.mark.parametrize(("array", "value", "match"), [
    # Every state but the mean standardised to infinity: memberships of 0.
    ("feature_scale", np.array([5e-324, 1.0]),
     r"array 'feature_scale' holds the value 5e-324 at index \(0,\); each value must be a "
     r"finite number in \[1e-150, 1e\+150\]"),
    ("std_means", np.array([[1e308, 0.0], [0.0, 0.0]]),
     r"array 'std_means' holds the value 1e\+308 at index \(0, 0\); each value must be a "
     r"finite number in \[-1e\+150, 1e\+150\]"),
    ("std_means", np.array([[-1e308, 0.0], [0.0, 0.0]]), r"array 'std_means' holds the value"),
])
def test_kernel_numerics_that_give_infinite_or_zero_memberships_are_refused(
        kernels_file, array, value, match) -> None:
    from ilpss.kernels import SharedKernelModel

    _tamper(kernels_file, **{array: value})
    with pytest.raises(ValueError, match=match) as err:
        SharedKernelModel.load(kernels_file)
    assert str(kernels_file) in str(err.value)


def test_kernels_whose_covariances_overflow_in_the_features_units_are_refused(
        kernels_file) -> None:
    from synthetic_smdp import read_archive

    from ilpss.kernels import SharedKernelModel

    covariances = read_archive(kernels_file)[0]["std_covariances"] * 1e10
    # Each allowed alone: 1e150**2 * 1e10 overflows.
    _tamper(kernels_file, feature_scale=np.array([1e150, 1.0]), std_covariances=covariances)
    with pytest.raises(ValueError, match=rf"{kernels_file}: invalid kernel model: its "
                                         r"covariances in the features' units are not finite"):
        SharedKernelModel.load(kernels_file)


@pytest.mark.parametrize("value", [1e308, -1e308])
def test_policy_weights_whose_values_are_infinite_are_refused(tmp_path, value) -> None:
    from synthetic_smdp import read_archive

    from ilpss.policy import FrozenPolicy

    path = _policy_file(tmp_path)
    weights = read_archive(path)[0]["weights"]
    _tamper(path, weights=np.full_like(weights, value))
    with pytest.raises(ValueError, match=(
            rf"{path}: weights up to 1e\+308 in magnitude: a value sums 4 of them, which "
            r"float64 cannot hold \(the values would be infinite\)")):
        FrozenPolicy.load(path)


@pytest.mark.parametrize("value", [1e308, -1e308, 3.5e38])
def test_region_thresholds_beyond_float32_are_refused(tmp_path, value) -> None:
    from ilpss.kernels import RegionKernels

    path = tmp_path / "regions.npz"
    RegionKernels(2, [0, 1], [1.0, 2.0], [True, False]).save(path)
    _tamper(path, thresholds=np.array([value, 2.0]))
    with pytest.raises(ValueError, match=(
            rf"{path}: array 'thresholds' holds the value {value:g}".replace("+", r"\+")
            + r" at index \(0,\); each value must be a finite number in "
              r"\[-3\.40282e\+38, 3\.40282e\+38\]")):
        RegionKernels.load(path)
