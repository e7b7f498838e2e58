"""Checkpoint storage: where a run's lifelong checkpoints live.

A run keeps one checkpoint folder per job, lifelong method and (in a stream whose targets
all start from the state after its sources) target, at the relative path
:func:`~ilpss.experiments.folder.checkpoint_key` gives, each with the layout of
:meth:`LifelongLearner.save <ilpss.lifelong.LifelongLearner.save>`. They are kept in a
*checkpoint storage*, named as Ray names its ``storage_path``:

=================================  ==========================================================
``ExperimentConfig.storage``       where the checkpoints go, and how they are written
=================================  ==========================================================
``None`` (the default)             the run folder; the learner saves into it (a locked folder,
                                   atomic renames, ``LATEST`` rewritten last)
a path                             a folder that every node can reach (a shared mount): the
                                   same, in that folder, which the run holds locked
a URI: ``s3://bucket/prefix``,     resolved by ``pyarrow.fs.FileSystem.from_uri``, as Ray
``gs://...``, ``hdfs://...``,      resolves ``storage_path`` (query parameters included);
``abfs://...``, ``file:///...``    needs pyarrow (``pip install 'soccer-drill-ilpss[cluster]'``).
                                   The learner saves into the job's own working folder; the
                                   new checkpoint is uploaded, its files first, then ``LATEST``
                                   (written under a temporary name and moved), and only then
                                   are older checkpoints deleted
=================================  ==========================================================

A restore reads ``LATEST``, downloads the checkpoint it names into the job's working
folder and loads it with every check of ``LifelongLearner.load`` (each file's digest,
the agreement of the files); the job that resumes from it
(:func:`ilpss.experiments.methods.run_lifelong`) refuses a checkpoint of another run (its
provenance) first. So a job restarted on another node resumes
from its last trial, and ends as it would have uninterrupted.

A storage is *claimed* by the run that uses it when its jobs run on Ray or it is not
the run folder: the driver writes ``owner.json`` (a token) into it, and every job checks the token before it starts
and before each checkpoint it writes. A job that cannot read the token (a path that its
node does not share) stops with an error saying so, and so do the jobs of a run whose
storage another run has claimed since.
"""

from __future__ import annotations

import os
import re
import shutil
import socket
import tempfile
import uuid
from pathlib import Path
from typing import Any, Protocol

from ilpss._io import (
    MAX_JSON_BYTES,
    atomic_write_bytes,
    check_inside,
    json_record_bytes,
    load_json_record,
    read_regular,
)
from ilpss.experiments.folder import checkpoint_key
from ilpss.experiments.protocols import Stream
from ilpss.lifelong import LifelongLearner, TrialRecord, latest_checkpoint, read_state

__all__ = [
    "LocalStore",
    "StorageSettings",
    "UriStore",
    "checkpoint_store",
]

OWNER = "owner.json"
"""The file of a claimed storage that names the run writing into it."""
OWNER_SCHEMA = "ilpss.storage_owner/1"
_URI = re.compile(r"[A-Za-z][A-Za-z0-9+.-]*://")
_CHECKPOINT = re.compile(r"trial_\d{4,}")
_TEMPORARY = re.compile(r"\.LATEST\.[0-9a-f]{32}\.tmp")
_LATEST_BYTES = 64


class StorageError(RuntimeError):
    """The checkpoint storage cannot be used: unreachable from a node, or claimed by
    another run."""


def is_uri(location: str) -> bool:
    """Whether a storage location is a URI (``scheme://...``) rather than a path."""
    return bool(_URI.match(location))


class CheckpointStore(Protocol):
    """What a job needs of a checkpoint storage (:class:`LocalStore`, :class:`UriStore`)."""

    location: str
    """The path or URI, as given."""

    def restore(self, key: str, observation_space: Any) -> LifelongLearner | None:
        """The learner of the checkpoint that ``<key>/LATEST`` names (checked), or
        ``None`` if there is none."""
        ...

    def save(self, key: str, learner: LifelongLearner) -> None:
        """Publish a checkpoint of ``learner`` at ``key`` (the previous one stays current
        until the new one is complete)."""
        ...

    def records(self, key: str) -> list[TrialRecord] | None:
        """The trial records of the checkpoint at ``key`` (its ``state.json``, checked),
        or ``None`` if there is none."""
        ...

    def claim(self, run: str) -> str:
        """Make this run the storage's owner; return the token its jobs check."""
        ...

    def check(self, token: str) -> None:
        """Raise :class:`StorageError` unless the storage is reachable and ``token``'s."""
        ...

    def close(self) -> None:
        """Remove the local working folder, if any."""
        ...


def _owner_record(run: str) -> tuple[str, bytes]:
    token = uuid.uuid4().hex
    record = {"schema": OWNER_SCHEMA, "token": token, "run": run, "host": socket.gethostname()}
    return token, json_record_bytes(record)


def _check_owner(location: str, data: bytes | None, token: str, where: Path) -> None:
    """Compare a storage's owner record with the token of this run."""
    node = socket.gethostname()
    if data is None:
        raise StorageError(
            f"checkpoint storage {location}: not reachable from node {node} (its {OWNER} "
            "is missing there); on a cluster, pass --storage a path or URI that every node "
            "can reach"
        )
    where.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(where, data)
    owner = load_json_record(where, OWNER_SCHEMA)
    if owner.get("token") != token:
        raise StorageError(
            f"checkpoint storage {location}: claimed since by another run (run folder "
            f"{owner.get('run')!r} on {owner.get('host')!r}); one run at a time may write "
            "into a storage"
        )


class LocalStore:
    """Checkpoints in a folder: the run folder, or a path that every node can reach."""

    def __init__(self, root: str | os.PathLike[str]) -> None:
        self.root = Path(root)
        self.location = os.fspath(root)

    def _path(self, key: str) -> Path:
        """``<root>/<key>``, refused if a symbolic link below the root leads it outside."""
        return check_inside(self.root, self.root / key, "checkpoint storage")

    def restore(self, key: str, observation_space: Any) -> LifelongLearner | None:
        directory = self._path(key)
        if not (directory / "LATEST").exists():
            return None
        return LifelongLearner.load(directory, observation_space)

    def save(self, key: str, learner: LifelongLearner) -> None:
        learner.save(self._path(key))

    def records(self, key: str) -> list[TrialRecord] | None:
        directory = self._path(key)
        if not (directory / "LATEST").exists():
            return None
        return read_state(latest_checkpoint(directory))[2]

    def claim(self, run: str) -> str:
        self.root.mkdir(parents=True, exist_ok=True)
        token, data = _owner_record(run)
        atomic_write_bytes(self._path(OWNER), data)
        return token

    def check(self, token: str) -> None:
        path = self._path(OWNER)
        data = read_regular(path, MAX_JSON_BYTES, "an owner record") if path.exists() else None
        with tempfile.TemporaryDirectory(prefix="ilpss-owner-") as tmp:
            _check_owner(self.location, data, token, Path(tmp) / OWNER)

    def close(self) -> None:
        pass


class UriStore:
    """Checkpoints under a URI, through ``pyarrow.fs`` (as Ray's ``storage_path``).

    Each checkpoint is written locally first, into this store's working folder (one per
    job: a fresh temporary folder of the node it runs on), then uploaded.
    """

    def __init__(self, uri: str) -> None:
        try:
            import pyarrow.fs
        except ImportError as exc:
            raise StorageError(
                f"checkpoint storage {uri}: a URI needs pyarrow (pip install "
                "'soccer-drill-ilpss[cluster]'); or pass a path that every node can reach"
            ) from exc
        self._pafs = pyarrow.fs
        try:
            self._fs, base = pyarrow.fs.FileSystem.from_uri(uri)
        except Exception as exc:  # pyarrow raises ArrowInvalid, OSError, ValueError...
            raise ValueError(
                f"checkpoint storage {uri!r}: not a URI that pyarrow.fs can open ({exc})"
            ) from exc
        self._base = base.rstrip("/")
        self.location = uri
        self._work: Path | None = None

    # ------------------------------------------------------------------ plumbing
    def _remote(self, *parts: str) -> str:
        return "/".join([self._base, *parts])

    def _local(self, *parts: str) -> Path:
        if self._work is None:
            self._work = Path(tempfile.mkdtemp(prefix="ilpss-job-"))
        return self._work.joinpath(*parts)

    def _read(self, path: str, limit: int = MAX_JSON_BYTES) -> bytes | None:
        """A small file of the storage (at most ``limit`` bytes), or ``None``."""
        self._check_local(path)
        info = self._fs.get_file_info(path)
        if info.type == self._pafs.FileType.NotFound:
            return None
        if info.type != self._pafs.FileType.File:
            raise ValueError(f"{self.location}: {path} is not a file")
        with self._fs.open_input_stream(path) as f:
            data = f.read(limit + 1)  # bounded as it reads, whatever the listing said
        if len(data) > limit:
            raise ValueError(f"{self.location}: {path} holds more than {limit:,} bytes")
        return data

    def _check_local(self, path: str, tree: bool = False) -> None:
        """On a local file system (``file://``), refuse a path that a symbolic link below
        the storage's root leads outside it (with ``tree``, also anything below it)."""
        if isinstance(self._fs, self._pafs.LocalFileSystem):
            check_inside(self._base, path, "checkpoint storage")
            for inner in Path(path).rglob("*") if tree else ():
                check_inside(path, inner, "checkpoint")

    def _publish(self, path: str, data: bytes) -> None:
        """Write a small file so that readers see the old or the new content, whole."""
        parent, _, name = path.rpartition("/")
        self._fs.create_dir(parent, recursive=True)
        temporary = f"{parent}/.{name}.{uuid.uuid4().hex}.tmp"
        with self._fs.open_output_stream(temporary) as f:
            f.write(data)
        self._fs.move(temporary, path)

    def _copy(self, source: str, destination: str, upload: bool) -> None:
        """Copy a folder between the job's working folder and the storage."""
        local = self._pafs.LocalFileSystem()
        (self._fs if upload else local).create_dir(destination, recursive=True)
        self._pafs.copy_files(
            source, destination,
            source_filesystem=local if upload else self._fs,
            destination_filesystem=self._fs if upload else local,
            use_threads=False,
        )

    def _latest(self, key: str, local: Path) -> Path | None:
        """The checkpoint that the storage's ``<key>/LATEST`` names, as a local path
        below ``local`` (whose ``LATEST`` is written), or ``None``."""
        name = self._read(self._remote(key, "LATEST"), _LATEST_BYTES)
        if name is None:
            return None
        shutil.rmtree(local, ignore_errors=True)
        local.mkdir(parents=True)
        atomic_write_bytes(local / "LATEST", name)
        try:
            return latest_checkpoint(local)  # refuses a malformed name
        except ValueError as exc:
            raise ValueError(str(exc).replace(str(local), f"{self.location}/{key}")) from exc

    # ------------------------------------------------------------------ the store
    def restore(self, key: str, observation_space: Any) -> LifelongLearner | None:
        local = self._local(key)
        checkpoint = self._latest(key, local)
        if checkpoint is None:
            return None
        self._check_local(self._remote(key, checkpoint.name), tree=True)
        self._copy(self._remote(key, checkpoint.name), os.fspath(checkpoint), upload=False)
        return LifelongLearner.load(local, observation_space)

    def save(self, key: str, learner: LifelongLearner) -> None:
        target = learner.save(self._local(key))
        remote = self._remote(key, target.name)
        self._check_local(remote)
        # Left by an attempt that died while uploading: not named by LATEST, so unused.
        self._fs.delete_dir_contents(remote, missing_dir_ok=True)
        self._copy(os.fspath(target), remote, upload=True)
        self._publish(self._remote(key, "LATEST"), target.name.encode())
        # Only now that LATEST names the new checkpoint may older ones go, and the
        # temporaries of a LATEST that an earlier attempt did not move into place.
        selector = self._pafs.FileSelector(self._remote(key))
        for info in self._fs.get_file_info(selector):
            name = info.path.rstrip("/").rpartition("/")[2]
            if (info.type == self._pafs.FileType.Directory and _CHECKPOINT.fullmatch(name)
                    and name < target.name):
                self._fs.delete_dir(info.path)
            elif info.type == self._pafs.FileType.File and _TEMPORARY.fullmatch(name):
                self._fs.delete_file(info.path)

    def records(self, key: str) -> list[TrialRecord] | None:
        local = self._local(".records", key)
        checkpoint = self._latest(key, local)
        if checkpoint is None:
            return None
        checkpoint.mkdir()
        data = self._read(self._remote(key, checkpoint.name, "state.json"))
        if data is None:
            raise ValueError(f"{self.location}/{key}/{checkpoint.name}: no state.json")
        atomic_write_bytes(checkpoint / "state.json", data)
        return read_state(checkpoint)[2]

    def claim(self, run: str) -> str:
        token, data = _owner_record(run)
        self._publish(self._remote(OWNER), data)
        return token

    def check(self, token: str) -> None:
        _check_owner(self.location, self._read(self._remote(OWNER)), token,
                     self._local(".owner", OWNER))

    def close(self) -> None:
        if self._work is not None:
            shutil.rmtree(self._work, ignore_errors=True)
            self._work = None


class StorageSettings(Protocol):
    """What the storage reads of an experiment's configuration
    (:class:`~ilpss.experiments.config.ExperimentConfig`, a layer above this module)."""

    storage: str | None


def checkpoint_store(cfg: StorageSettings, root: str | os.PathLike[str]) -> CheckpointStore:
    """The checkpoint storage of a run of ``cfg`` whose run folder is ``root``."""
    return open_store(cfg.storage) if cfg.storage is not None else LocalStore(root)


def open_store(location: str) -> LocalStore | UriStore:
    """The checkpoint storage at a path or a URI (see the module's table)."""
    if not isinstance(location, str) or not location.strip():
        raise ValueError(f"a checkpoint storage must be a path or a URI, got {location!r}")
    return UriStore(location) if is_uri(location) else LocalStore(location)


def stream_records(
    store: CheckpointStore, seed: int, stream_index: int, method: str, stream: Stream
) -> list[TrialRecord] | None:
    """A lifelong method's trial records of a job, one per task of the stream, as its
    last checkpoints hold them (the targets' own, in a stream whose targets share their
    start); ``None`` if any of them is not kept (checkpoints may be deleted once a job
    is done)."""
    records = store.records(checkpoint_key(seed, stream_index, method))
    n_targets = len(stream.tasks) - stream.first_target
    if records is None or not (stream.shared_start and n_targets > 1):
        return records
    records = list(records)
    for t in range(stream.first_target, len(stream.tasks)):
        branch = store.records(checkpoint_key(seed, stream_index, method, t))
        if branch is None:
            return None
        records += branch[-1:]
    return records
