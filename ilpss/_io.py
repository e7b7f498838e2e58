"""Small, safe persistence helpers shared by the ``ilpss`` modules.

Everything ``ilpss`` saves (kernel models, policies, option libraries, checkpoints) is an
``.npz`` archive of plain numeric arrays plus one JSON record, written atomically:

* :func:`atomic_write_bytes` writes to a temporary file in the destination directory,
  ``fsync`` s it and renames it over the destination with :func:`os.replace`, so a crash
  leaves either the old file or the new one, never half of one.
* :func:`save_npz_atomic` stores ``arrays`` and a JSON ``meta`` record (which must name
  its ``"schema"``, e.g. ``"ilpss.kernels/1"``) together with a SHA-256 digest of both.
* :func:`load_archive` reads such a file **without ever unpickling**
  (``allow_pickle=False``) and checks it against its declared
  :class:`~ilpss._schema.ArchiveSchema` (arrays, dtypes, shapes with named dimensions,
  bounds, record fields), refusing with a :class:`ValueError` saying what is wrong
  anything that is not exactly what the caller expects: a truncated or corrupt archive,
  a member that is not an uncompressed ``.npy`` array, a missing or malformed JSON
  record, another schema version, missing or unexpected arrays, arrays of the wrong
  shape or dtype (all checked from the headers, before any array is read, so that a
  small file cannot fill the memory), a digest mismatch (arrays or record modified after
  saving), or values and record fields out of their bounds. :func:`load_npz` does the
  same given only the arrays' shapes and kinds.
* :func:`json_record_bytes` and :func:`load_json_record` do the same for a JSON file (a
  record naming its ``"schema"``, with the SHA-256 of its canonical form), and
  :func:`read_json` reads any JSON file with errors that name it.
* :func:`locked_folder` holds an exclusive lock on a folder while a run writes into it, so
  that a second writer gets a clear error instead of mixing its files with the first's.
* :func:`read_regular` and :func:`sha256_file` read regular files only (never a device, a
  FIFO or a socket, which could block or never end), bounded as they read;
  :func:`check_inside` refuses a path below a folder that leaves it through a symbolic
  link, so that a data folder never leads a read, a write or a deletion outside itself.

Shapes are written as :mod:`ilpss._schema` describes.
"""

from __future__ import annotations

import contextlib
import gzip
import hashlib
import io
import json
import math
import os
import stat
import zipfile
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from ilpss._schema import ArchiveSchema, Checked, Shape
from soccer_drill.files import TEMPORARY, atomic_write_bytes

__all__ = [
    "FolderInUseError",
    "atomic_write_bytes",
    "canonical_json",
    "check_inside",
    "json_differences",
    "json_record_bytes",
    "load_archive",
    "load_json_record",
    "load_npz",
    "locked_folder",
    "read_json",
    "read_regular",
    "release_inherited_locks",
    "remove_stale_temporaries",
    "save_figure",
    "save_npz_atomic",
    "sha256_file",
]

#: Name of the archive member that holds the JSON record.
META_KEY = "__meta__"
#: Version of the container layout (the JSON wrapper below), independent of any schema.
CONTAINER = "ilpss.npz/1"
#: Largest JSON file :func:`read_json` reads (and largest record of an archive).
MAX_JSON_BYTES = 64 * 2**20
#: Largest archive :func:`load_archive` reads, and file :func:`sha256_file` hashes: far above
#: any ilpss archive (a policy holds at most ``tiles.MAX_WEIGHTS`` weights per choice).
MAX_ARCHIVE_BYTES = 2**34

_Headers = dict[str, tuple[tuple[int, ...], np.dtype]]


def remove_stale_temporaries(directory: str | os.PathLike[str]) -> list[str]:
    """Remove the temporaries that :func:`atomic_write_bytes` left in ``directory`` when
    its process died before the rename (``SIGKILL``, power loss); return their names.

    Only call it while no other process writes into ``directory`` (hold its lock, see
    :func:`locked_folder`): another writer's temporary looks the same.
    """
    removed = []
    for path in Path(directory).iterdir():
        if TEMPORARY.fullmatch(path.name) and path.is_file():
            try:
                path.unlink()
            except FileNotFoundError:
                continue
            removed.append(path.name)
    return sorted(removed)


def save_figure(fig: Any, path: str | os.PathLike[str], **savefig: Any) -> Path:
    """Write a matplotlib figure to ``path`` atomically (the format from its suffix unless
    ``savefig`` gives one; ``savefig`` passed to ``Figure.savefig``); missing parent
    folders are created."""
    path = Path(path)
    buffer = io.BytesIO()
    savefig.setdefault("format", path.suffix.lstrip(".") or "png")
    fig.savefig(buffer, **savefig)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, buffer.getvalue())
    return path


class FolderInUseError(RuntimeError):
    """Another process holds the lock of a folder (see :func:`locked_folder`)."""


@contextlib.contextmanager
def locked_folder(path: str | os.PathLike[str], what: str = "folder") -> Iterator[None]:
    """Hold an exclusive lock on the existing folder ``path`` for the ``with`` block.

    The lock is :func:`fcntl.flock` on the folder itself (no lock file is left behind) and
    is released when the block ends or the process dies, ``SIGKILL`` included. A process
    forked inside the block shares it until it calls :func:`release_inherited_locks`
    (local worker processes do, first thing). It does not wait: a second
    holder gets :class:`FolderInUseError` at once. A process must not lock one folder
    twice. Where ``fcntl`` is missing (Windows) nothing is locked.

    Parameters
    ----------
    path : str or os.PathLike
    what : str
        How the error message calls the folder (e.g. ``"run folder"``).
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        yield
        return
    fd = os.open(path, os.O_RDONLY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise FolderInUseError(
                f"{os.fspath(path)}: this {what} is being written by another process; wait "
                "for it to finish or use another folder"
            ) from None
        _HELD_LOCKS.add(fd)
        yield
    finally:
        _HELD_LOCKS.discard(fd)
        os.close(fd)  # releases the lock


_HELD_LOCKS: set[int] = set()
"""The descriptors of the folder locks this process holds (:func:`locked_folder`)."""


def release_inherited_locks() -> None:
    """Close, in a forked child, the descriptors of the folder locks its parent holds.

    An ``flock`` belongs to the open file, which a forked child shares: a child that kept
    the descriptor would keep the folder locked after its parent died. Closing the
    child's copy leaves the parent's lock as it is. Call it first in every forked worker
    (:class:`~ilpss.experiments.executor.LocalExecutor` does).
    """
    for fd in list(_HELD_LOCKS):
        with contextlib.suppress(OSError):
            os.close(fd)
    _HELD_LOCKS.clear()


def json_differences(saved: Any, current: Any, prefix: str = "") -> list[str]:
    """Where two JSON values differ, as ``"a.b.c: <saved> saved, <current> here"`` lines.

    Objects are compared key by key (a key missing on one side is a difference); any
    other values, lists included, as wholes.
    """
    if isinstance(saved, dict) and isinstance(current, dict):
        out: list[str] = []
        for key in sorted(set(saved) | set(current), key=str):
            name = f"{prefix}.{key}" if prefix else str(key)
            if key not in saved or key not in current:
                side = "missing in the saved record" if key not in saved else "not set here"
                out.append(f"{name}: {side}")
            else:
                out += json_differences(saved[key], current[key], name)
        return out
    if saved == current and isinstance(saved, bool) == isinstance(current, bool):
        return []
    return [f"{prefix or 'value'}: {saved!r} saved, {current!r} here"]


def canonical_json(meta: Any) -> str:
    """``meta`` as strict JSON with sorted keys and no spaces: what digests are taken of."""
    return json.dumps(meta, allow_nan=False, sort_keys=True, separators=(",", ":"))


def _refuse_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a JSON number")


def _finite_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):  # 1e400: a number JSON allows, which float cannot hold
        raise ValueError(f"the number {text[:40]} is too large for a float")
    return value


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    # json.loads keeps the last of repeated keys: a hand-edited file would then run
    # another setting than the one its reader sees first.
    record: dict[str, Any] = {}
    for key, value in pairs:
        if key in record:
            raise ValueError(f"the key {key!r} appears more than once in one object; each "
                             "key must appear once")
        record[key] = value
    return record


def _parse_json(text: str | bytes, where: str) -> Any:
    """Strict JSON (no NaN or Infinity, no number beyond float's range, no repeated key
    in an object); errors name ``where``."""
    try:
        return json.loads(text, parse_constant=_refuse_constant, parse_float=_finite_float,
                          object_pairs_hook=_unique_keys)
    except ValueError as exc:  # JSONDecodeError, UnicodeDecodeError, NaN
        raise ValueError(f"{where}: not valid JSON ({exc})") from exc
    except RecursionError:
        raise ValueError(f"{where}: JSON nested too deeply to be a record") from None


def read_json(path: str | os.PathLike[str]) -> Any:
    """The parsed contents of a JSON file.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        Naming the file: it is a folder, larger than :data:`MAX_JSON_BYTES`, not UTF-8
        JSON, repeats a key within an object, or is nested too deeply to parse.
    """
    return _parse_json(read_regular(path, MAX_JSON_BYTES, "a JSON record"), os.fspath(path))


_KINDS = {stat.S_IFDIR: "a folder", stat.S_IFCHR: "a character device",
          stat.S_IFBLK: "a block device", stat.S_IFIFO: "a FIFO (named pipe)",
          stat.S_IFSOCK: "a socket"}


@contextlib.contextmanager
def _open_regular(path: str | os.PathLike[str], what: str) -> Iterator[int]:
    """A read-only descriptor of the regular file ``path`` (a symbolic link is followed);
    anything else is refused before a byte is read. ``O_NONBLOCK``: opening a FIFO
    returns at once (and is then refused) instead of waiting for a writer."""
    where = os.fspath(path)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(path, flags)
    except IsADirectoryError:
        raise ValueError(f"{where}: a folder, where {what} was expected") from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            kind = _KINDS.get(stat.S_IFMT(mode), "not a regular file")
            raise ValueError(f"{where}: {kind}, where {what} (a regular file) was expected")
        yield fd
    finally:
        os.close(fd)


def read_regular(path: str | os.PathLike[str], limit: int, what: str = "a file") -> bytes:
    """The contents of the regular file ``path``, refused if it holds more than ``limit``
    bytes: the bound is kept while reading (a file that grows, or a ``stat`` size that
    lies, cannot make it read more than ``limit + 1`` bytes).

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        Naming the file: a folder, a device, a FIFO or a socket, or larger than ``limit``.
    """
    with _open_regular(path, what) as fd:
        chunks, total = [], 0
        while True:
            chunk = os.read(fd, min(2**20, limit + 1 - total))
            if not chunk:
                return b"".join(chunks)
            total += len(chunk)
            if total > limit:
                raise ValueError(f"{os.fspath(path)}: more than the {limit:,} bytes "
                                 f"{what} may have")
            chunks.append(chunk)


def sha256_file(path: str | os.PathLike[str], limit: int = MAX_ARCHIVE_BYTES) -> str:
    """The SHA-256 of the regular file ``path``, read in blocks (at most ``limit`` bytes;
    errors as :func:`read_regular`'s)."""
    digest = hashlib.sha256()
    with _open_regular(path, "a saved file") as fd:
        total = 0
        while chunk := os.read(fd, 2**20):
            total += len(chunk)
            if total > limit:
                raise ValueError(f"{os.fspath(path)}: more than the {limit:,} bytes any "
                                 "ilpss file has")
            digest.update(chunk)
    return digest.hexdigest()


def check_inside(root: str | os.PathLike[str], path: str | os.PathLike[str],
                 what: str = "folder") -> Path:
    """``path``, after checking that it lies below ``root`` without leaving it: written
    below it, with no ``..``, and no component after ``root`` a symbolic link (which could
    lead a read, a write or a deletion anywhere). ``root`` itself may be a link.

    Raises
    ------
    ValueError
        Naming the link or the path, and the ``what`` it would leave.
    """
    root, path = Path(root), Path(path)
    try:
        parts = path.relative_to(root).parts
    except ValueError:
        raise ValueError(f"{path}: not inside the {what} {root}") from None
    current = root
    for part in parts:
        if part == "..":
            raise ValueError(f"{path}: leaves the {what} {root} ('..')")
        current = current / part
        if current.is_symlink():
            raise ValueError(
                f"{current}: a symbolic link inside the {what} {root}; everything a run "
                f"reads, writes or deletes there must lie inside it (remove the link)"
            )
    return path


def json_record_bytes(record: Mapping[str, Any]) -> bytes:
    """The file contents of a JSON record: ``record`` (which names its ``"schema"``) with
    the SHA-256 of its canonical JSON added as ``"sha256"``, indented for reading.

    Raises
    ------
    ValueError
        If ``record`` has no string ``"schema"``, already has a ``"sha256"``, or is not
        strict JSON.
    """
    if not isinstance(record.get("schema"), str):
        raise ValueError("a record must contain a string 'schema', e.g. 'ilpss.lifelong/2'")
    if "sha256" in record:
        raise ValueError("a record must not contain 'sha256': it is added here")
    try:
        digest = hashlib.sha256(canonical_json(record).encode()).hexdigest()
    except (TypeError, ValueError) as exc:
        raise ValueError(f"the record is not serialisable as strict JSON: {exc}") from exc
    return json.dumps({**record, "sha256": digest}, indent=1, allow_nan=False).encode()


def load_json_record(path: str | os.PathLike[str], schema: str) -> dict[str, Any]:
    """Read a file written with :func:`json_record_bytes`: an object of ``schema`` whose
    digest matches (returned without its ``"sha256"``).

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        Naming the file: unreadable (see :func:`read_json`), not an object, another
        schema, or modified after saving.
    """
    return _verified(read_json(path), schema, os.fspath(path))


def _verified(record: Any, schema: str, where: str) -> dict[str, Any]:
    """``record`` without its ``"sha256"``, once it is an object of ``schema`` whose digest
    matches; ``ValueError`` naming ``where`` otherwise."""
    if not isinstance(record, dict):
        raise ValueError(f"{where}: not a JSON object")
    if record.get("schema") != schema:
        raise ValueError(f"{where}: schema {record.get('schema')!r} is not {schema!r}")
    digest = record.pop("sha256", None)
    if digest != hashlib.sha256(canonical_json(record).encode()).hexdigest():
        raise ValueError(
            f"{where}: content checksum mismatch (sha256); the record was modified after saving"
        )
    return record


def save_gzip_record(record: Mapping[str, Any], path: str | os.PathLike[str]) -> None:
    """Write :func:`json_record_bytes` of ``record`` gzip-compressed, atomically; the same
    record gives the same bytes (no time stamp in the gzip header)."""
    atomic_write_bytes(path, gzip.compress(json_record_bytes(record), mtime=0))


def load_gzip_record(path: str | os.PathLike[str], schema: str, limit: int,
                     what: str) -> dict[str, Any]:
    """Read a file written by :func:`save_gzip_record`: an object of ``schema`` whose digest
    matches (returned without its ``"sha256"``). ``what`` names the kind of file in errors.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        Naming the file: larger than ``limit`` bytes, not gzip, not strict JSON, not an
        object of ``schema``, or modified after saving (as :func:`load_json_record`).
    """
    where = os.fspath(path)
    compressed = read_regular(path, limit, what)
    try:
        record = _parse_json(gzip.decompress(compressed), where)
    except (OSError, EOFError, ValueError) as exc:  # not gzip, or not JSON inside
        raise ValueError(f"{where}: not a gzip-compressed JSON {what} ({exc})") from None
    return _verified(record, schema, where)


def _digest(arrays: Mapping[str, np.ndarray], meta: Mapping[str, Any]) -> str:
    """SHA-256 over the canonical JSON of ``meta`` and the names, dtypes, shapes and bytes
    of ``arrays`` in name order (JSON floats round-trip exactly, so this is reproducible)."""
    h = hashlib.sha256(canonical_json(meta).encode())
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(json.dumps([name, a.dtype.str, list(a.shape)]).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def save_npz_atomic(
    path: str | os.PathLike[str], arrays: Mapping[str, Any], meta: Mapping[str, Any]
) -> None:
    """Save numeric ``arrays`` and a JSON ``meta`` record to ``path`` atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Destination, written exactly as given (no ``.npz`` suffix is appended).
    arrays : mapping of str to array_like
        The arrays. Object arrays are refused: they could only be read back by
        unpickling, which :func:`load_archive` never does.
    meta : mapping
        JSON-serialisable record (strict JSON: no NaN or infinity). Must contain a string
        ``"schema"`` naming the format and its version, e.g. ``"ilpss.kernels/1"``.

    Raises
    ------
    ValueError
        If ``meta`` has no string ``"schema"``, is not strict JSON, an array name is
        reserved or not a string, or an array has dtype ``object``.
    """
    if not isinstance(meta.get("schema"), str):
        raise ValueError("meta must contain a string 'schema', e.g. 'ilpss.kernels/1'")
    converted: dict[str, np.ndarray] = {}
    for name, value in arrays.items():
        if not isinstance(name, str) or name == META_KEY:
            raise ValueError(f"invalid array name {name!r} (must be a str other than {META_KEY!r})")
        a = np.asarray(value)
        if a.dtype.hasobject:
            raise ValueError(f"array {name!r} has dtype object, which cannot be saved safely")
        converted[name] = a
    try:
        record = json.dumps(
            {"container": CONTAINER, "sha256": _digest(converted, meta), "meta": dict(meta)},
            allow_nan=False,
            sort_keys=True,
        )
    except (TypeError, ValueError) as exc:
        raise ValueError(f"meta is not serialisable as strict JSON: {exc}") from exc
    buffer = io.BytesIO()
    np.savez(buffer, **converted, **{META_KEY: np.array(record)})
    atomic_write_bytes(path, buffer.getvalue())


def load_archive(
    path: str | os.PathLike[str],
    schema: ArchiveSchema,
    dims: Mapping[str, int] | None = None,
) -> Checked:
    """Load a file written by :func:`save_npz_atomic` and check it against ``schema``.

    Everything that can be checked without reading the arrays is checked first, from the
    zip directory and each member's ``.npy`` header: that every member is an
    uncompressed ``.npy`` array (what :func:`save_npz_atomic` writes, so that no member
    can expand beyond the file's size), that no array holds Python objects, that each
    header's shape and dtype give exactly the member's size, and the schema's layout
    (:meth:`~ilpss._schema.ArchiveSchema.check_layout`: the arrays, their kinds and
    shapes). Only then are the record and the arrays read, the digest compared, and the
    values and the record checked (:meth:`~ilpss._schema.ArchiveSchema.validate`).

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    schema : ArchiveSchema
        What the file must hold; its ``name`` must be the record's ``"schema"``.
    dims : mapping of str to int, optional
        Lengths of named dimensions that the caller already knows.

    Returns
    -------
    Checked
        The arrays (fully read into memory), the record given to
        :func:`save_npz_atomic`, and the length of every named dimension.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        If the file is not a complete, unmodified archive of this schema; the message
        names the file, the array or field, and what is allowed.
    """
    where = os.fspath(path)
    arrays, meta = _read_archive(
        path, schema.name, lambda headers: schema.check_layout(headers, where, dims))
    return schema.validate(arrays, meta, where, dims)


def load_npz(
    path: str | os.PathLike[str],
    schema: str,
    required: Mapping[str, tuple[Shape, str]],
    optional: Mapping[str, tuple[Shape, str]] | None = None,
) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Load a file written by :func:`save_npz_atomic`, given its arrays' shapes and kinds
    only: :func:`load_archive` with :meth:`ArchiveSchema.from_templates`.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    schema : str
        The exact schema the caller understands (``meta["schema"]`` must equal it).
    required, optional : mapping of str to (shape, dtype_kinds)
        Arrays that must (may) be present, with their shape and accepted dtype kinds
        (see :mod:`ilpss._schema`). No other array is allowed.

    Returns
    -------
    arrays : dict of str to numpy.ndarray
    meta : dict

    Raises
    ------
    FileNotFoundError, ValueError
        As :func:`load_archive`.
    """
    checked = load_archive(path, ArchiveSchema.from_templates(schema, required, optional))
    return checked.arrays, checked.meta


def _read_archive(
    path: str | os.PathLike[str], schema: str, check_layout: Callable[[_Headers], object]
) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """The arrays and record of an archive of ``schema``, digest compared, after
    ``check_layout`` accepted the arrays' headers."""
    where = os.fspath(path)
    with _open_regular(path, "an .npz archive") as fd, \
            os.fdopen(os.dup(fd), "rb") as fh:  # FileNotFoundError, PermissionError
        _check_container(fh, os.fstat(fd).st_size, where)
        try:
            archive = zipfile.ZipFile(fh)
        except _READ_ERRORS as exc:
            raise _unreadable(where, exc) from exc
        with archive:
            headers = _array_headers(archive, where)
            meta, digest = _read_record(archive, where, schema)
            check_layout(headers)
            arrays = _read_arrays(archive, sorted(headers), where)
    if _digest(arrays, meta) != digest:
        raise ValueError(
            f"{where}: content checksum mismatch; the arrays or the record were modified "
            "after saving"
        )
    return arrays, meta


def _check_container(fh: BinaryIO, size: int, where: str) -> None:
    """Refuse a file too large for any archive, or a single ``.npy`` array."""
    if size > MAX_ARCHIVE_BYTES:
        raise ValueError(f"{where}: {size:,} bytes, more than any ilpss archive has "
                         f"({MAX_ARCHIVE_BYTES:,})")
    if fh.read(6) == b"\x93NUMPY":
        raise ValueError(f"{where}: not an .npz archive (a single .npy array?)")


def _array_headers(archive: zipfile.ZipFile, where: str) -> _Headers:
    """The headers of the arrays of an archive, without the record's, which must be
    one string."""
    try:
        headers = _member_headers(archive, where)
    except _Refused:
        raise
    except _READ_ERRORS as exc:
        raise _unreadable(where, exc) from exc
    if META_KEY not in headers:
        raise ValueError(f"{where}: missing or malformed {META_KEY!r} record")
    shape, dtype = headers.pop(META_KEY)
    if dtype.kind != "U" or shape != () or dtype.itemsize > 4 * MAX_JSON_BYTES:
        raise ValueError(f"{where}: missing or malformed {META_KEY!r} record")
    return headers


def _read_arrays(
    archive: zipfile.ZipFile, names: list[str], where: str
) -> dict[str, np.ndarray]:
    try:
        arrays = {}
        for name in names:
            with archive.open(name + ".npy") as fp:
                arrays[name] = np.lib.format.read_array(fp, allow_pickle=False)
    except _READ_ERRORS as exc:  # e.g. a zip CRC mismatch, found while reading
        raise _unreadable(where, exc) from exc
    return arrays


def _read_record(
    archive: zipfile.ZipFile, where: str, schema: str
) -> tuple[dict[str, Any], str]:
    """The ``meta`` record and the digest of an archive, checked for layout and schema."""
    try:
        with archive.open(META_KEY + ".npy") as fp:
            text = str(np.lib.format.read_array(fp, allow_pickle=False))
    except _READ_ERRORS as exc:
        raise _unreadable(where, exc) from exc
    record = _parse_json(text, f"{where}: the {META_KEY!r} record")
    if (
        not isinstance(record, dict)
        or record.get("container") != CONTAINER
        or not isinstance(record.get("meta"), dict)
        or not isinstance(record.get("sha256"), str)
    ):
        raise ValueError(f"{where}: unknown container layout (expected {CONTAINER!r})")
    meta: dict[str, Any] = record["meta"]
    if meta.get("schema") != schema:
        raise ValueError(f"{where}: wrong schema {meta.get('schema')!r}, expected {schema!r}")
    return meta, record["sha256"]


# What zipfile and numpy raise for a damaged file. RuntimeError too: zipfile raises it for
# a member flagged as encrypted, and NotImplementedError (a RuntimeError) for other flag
# bits or a version it does not read, all read from the zip directory's bytes.
_READ_ERRORS = (OSError, EOFError, ValueError, KeyError, RuntimeError, zipfile.BadZipFile)
#: Largest ``.npy`` header read (numpy's own default bound).
_MAX_HEADER = 10_000


def _member_headers(archive: zipfile.ZipFile, where: str) -> _Headers:
    """``{array name: (shape, dtype)}`` from the zip directory and the ``.npy`` headers,
    reading no array data; refuses what :func:`save_npz_atomic` never writes."""
    out: _Headers = {}
    for info in archive.infolist():
        member = info.filename
        if not member.endswith(".npy") or "/" in member or info.is_dir():
            raise _Refused(
                f"{where}: member {member!r} is not an .npy array; ilpss archives hold "
                "only .npy arrays"
            )
        name = member[: -len(".npy")]
        if name in out:
            raise _Refused(f"{where}: member {member!r} appears twice")
        if info.compress_type != zipfile.ZIP_STORED:
            raise _Refused(
                f"{where}: member {member!r} is compressed; ilpss archives store their "
                "arrays uncompressed (np.savez), so that nothing expands beyond the file"
            )
        with archive.open(info) as fp:
            version = np.lib.format.read_magic(fp)
            if version == (1, 0):
                shape, _, dtype = np.lib.format.read_array_header_1_0(fp, _MAX_HEADER)
            else:
                shape, _, dtype = np.lib.format.read_array_header_2_0(fp, _MAX_HEADER)
            header = fp.tell()
        if dtype.hasobject:
            raise _Refused(
                f"{where}: not a readable .npz archive: member {member!r} holds pickled Python "
                "objects (dtype object), which are never loaded"
            )
        if any(n > MAX_ARCHIVE_BYTES for n in shape):  # (0, 10**30) holds 0 bytes, but
            raise _Refused(                          # no array can have that shape
                f"{where}: member {member!r} declares shape {shape}, an axis longer than "
                "any ilpss array has"
            )
        size = int(np.prod(shape, dtype=object)) * dtype.itemsize
        if header + size != info.file_size:
            raise _Refused(
                f"{where}: member {member!r} declares shape {shape} of {dtype} "
                f"({size:,} bytes) but holds {info.file_size - header:,} bytes of data"
            )
        out[name] = (tuple(int(n) for n in shape), dtype)
    return out


class _Refused(ValueError):
    """What :func:`_member_headers` refuses, already naming the file and the member: passed
    on as it is, not as an archive that failed to read."""


def _unreadable(where: str, exc: BaseException) -> ValueError:
    return ValueError(
        f"{where}: not a readable .npz archive (truncated, corrupt, or containing pickled "
        f"objects): {type(exc).__name__}: {exc}"
    )
