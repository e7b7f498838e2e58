"""Tests of ilpss._io: atomic writes and checked, pickle-free .npz archives."""

from __future__ import annotations

import io
import json
import os
import stat
import sys
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
    arrays, loaded_meta = load_npz(path, SCHEMA, REQUIRED)
    assert loaded_meta == meta
    assert set(arrays) == {"w", "c", "t", "extra"}
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
    refused("not a readable .npz archive .*allow_pickle=False")
    bad.write_bytes(b"\x80\x04\x95garbage")
    refused("not a readable .npz")
    _write(bad, {**_arrays(), "o": np.array([None], dtype=object)}, None)
    refused("not a readable .npz")
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


def test_container_constant() -> None:
    assert _io.CONTAINER == "ilpss.npz/1" and _io.META_KEY == "__meta__"
