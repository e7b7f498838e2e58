"""Output files written safely: checked before the work, replaced atomically.

* :func:`check_output_file` says, before any work is done, whether a file can be written
  at a path (not a folder, not under a file, in a writable folder).
* :func:`atomic_write_bytes` writes to a fresh temporary beside the destination (created
  with ``O_EXCL`` under a random name, so it never follows a link planted there nor
  meets another writer's temporary), ``fsync`` s it and renames it over the destination:
  a crash leaves the old file or the new one, never half of one.
* :func:`write_digested_json` / :func:`read_digested_json`: a page's kept numbers with the
  SHA-256 of their JSON, checked when read.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import secrets
from pathlib import Path
from typing import Any

__all__ = ["TEMPORARY", "atomic_write_bytes", "atomic_write_text", "check_output_file"]

#: The names of :func:`atomic_write_bytes`'s temporaries (``.NAME.PID.RANDOM.tmp``).
TEMPORARY = re.compile(r"\..+\.\d+\.[0-9a-f]{12}\.tmp")


def check_output_file(path: str | os.PathLike) -> Path:
    """``path`` if a file can be written there, else ``ValueError`` naming the problem:
    an empty path, a folder (an existing one, or a path ending in a separator), a path
    under a file, or a folder that cannot be written."""
    raw = os.fspath(path)
    if not raw:
        raise ValueError("the output must be a file path, got ''")
    out = Path(raw)
    if raw.endswith(("/", os.sep)) or out.is_dir():
        raise ValueError(f"the output must name a file, got the folder {raw!r}; e.g. "
                         f"{os.path.join(raw, 'episode.gif')!r}")
    ancestor = out.parent
    while not ancestor.exists():
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise ValueError(f"cannot write {raw!r}: {str(ancestor)!r} is a file, not a folder")
    if not os.access(ancestor, os.W_OK | os.X_OK):
        raise ValueError(f"cannot write {raw!r}: the folder {str(ancestor)!r} is not writable")
    return out


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to ``path`` atomically.

    The bytes go to a new temporary file in the same directory (same file system, so the
    final rename is atomic), are flushed and ``fsync`` ed, and the file is renamed over
    ``path`` with :func:`os.replace`. The directory is then ``fsync`` ed where the
    platform allows it, so the rename itself survives a crash. On any error the
    temporary file is removed, ``path`` is left untouched, and an ``OSError`` names
    ``path``.

    Parameters
    ----------
    path : str or os.PathLike
        Destination; its directory must exist.
    data : bytes
        The complete new contents.
    """
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    tmp = directory / f".{path.name}.{os.getpid()}.{secrets.token_hex(6)}.tmp"
    try:
        # O_EXCL: never clobber another writer's temporary nor follow a link; mode 0o666
        # lets the umask decide the permissions, as for any ordinary new file.
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0),
                     0o666)
    except OSError as exc:
        raise _naming(exc, path) from exc
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(exc, OSError):
            raise _naming(exc, path) from exc
        raise
    _fsync_directory(directory)


def atomic_write_text(path: str | os.PathLike[str], text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` with :func:`atomic_write_bytes`, creating missing
    parent folders; return ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, text.encode("utf-8"))
    return path


def write_digested_json(path: str | os.PathLike[str], record: dict[str, Any],
                        indent: int | None = None) -> Path:
    """``{"record": record, "sha256": digest}`` written atomically, the digest the SHA-256
    of the record's JSON with sorted keys: a page's kept numbers, whose reader
    (:func:`read_digested_json`) tells a file changed by hand."""
    body = json.dumps(record, sort_keys=True, allow_nan=False)
    digest = hashlib.sha256(body.encode()).hexdigest()
    return atomic_write_text(path, json.dumps({"sha256": digest, "record": json.loads(body)},
                                              sort_keys=True, indent=indent) + "\n")


def read_digested_json(path: str | os.PathLike[str],
                       schema_version: int | None = None) -> dict[str, Any]:
    """The record of a file :func:`write_digested_json` wrote, ``ValueError`` naming the
    file if it is not one (not UTF-8 JSON, no record or digest), if its digest does not
    match, or, given ``schema_version``, if its version differs."""
    try:
        kept = json.loads(Path(path).read_bytes().decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: not the JSON of a kept record ({exc})") from None
    record = kept.get("record") if isinstance(kept, dict) else None
    if not isinstance(record, dict) or not isinstance(kept.get("sha256"), str):
        raise ValueError(f"{path}: not a kept record (an object with 'record' and 'sha256')")
    if hashlib.sha256(json.dumps(record, sort_keys=True).encode()).hexdigest() != kept["sha256"]:
        raise ValueError(f"{path}: its sha256 does not match its record (changed by hand?)")
    if schema_version is not None and record.get("schema_version") != schema_version:
        raise ValueError(f"{path}: schema version {record.get('schema_version')!r}, this code "
                         f"reads {schema_version}")
    return record


def _naming(exc: OSError, path: Path) -> OSError:
    """``exc`` as the same kind of error, saying which file could not be written (a full
    disk's ``OSError`` otherwise names only the temporary, or nothing)."""
    if exc.filename == os.fspath(path):
        return exc
    return type(exc)(exc.errno, f"cannot write {os.fspath(path)}: "
                     f"{exc.strerror or exc}", os.fspath(path))


def _fsync_directory(directory: Path) -> None:
    """Persist a rename in ``directory``; a no-op where directories cannot be opened."""
    try:
        dir_fd = os.open(directory, os.O_RDONLY)
    except OSError:  # e.g. Windows
        return
    try:
        os.fsync(dir_fd)
    except OSError:
        pass
    finally:
        os.close(dir_fd)
