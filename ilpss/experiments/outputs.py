"""Where a command writes: every output path checked before the work starts.

A run of hours must not fail at its end because ``--out`` names a folder where a file
belongs, a file where a folder belongs, or a place that cannot be written. Every command
of ``ilpss`` checks its outputs with these functions before it computes anything.
"""

from __future__ import annotations

import argparse
import json
import os
import re
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from soccer_drill.files import TEMPORARY, read_digested_json, write_digested_json

__all__ = ["check_out_dir", "check_out_file"]

_JOB_FOLDER = re.compile(r"seed_\d{3,}")


_RUN_FILES = frozenset({"config.json", "team_code.json"})


_WRITTEN = {".md": "a page", ".json.gz": "numbers (gzip-compressed JSON)"}
"""What a file of each ending that :func:`check_out_file` asks for holds, in its errors."""


def _is_run_file(name: str) -> bool:
    """Whether a run wrote ``name``: its configuration, a job's folder, or the temporary
    of an atomic write (what a run killed while writing ``config.json`` leaves, and what
    a second run started on the same folder sees while the first one writes it)."""
    return name in _RUN_FILES or bool(_JOB_FOLDER.fullmatch(name) or TEMPORARY.fullmatch(name))


def _refuse_file_system_root(path: Path, flag: str) -> None:
    resolved = path.resolve()
    if resolved == Path(resolved.anchor):
        raise ValueError(f"{flag} {path}: the root of a file system; give a folder of its own "
                         "(e.g. results/my_run)")


def check_out_dir(out_dir: str | os.PathLike[str], flag: str = "--out",
                  run_folder: bool = True) -> Path:
    """The output folder, created if needed; a clear error if it cannot be one.

    With ``run_folder``, the folder must be new, empty, or a run folder already (it holds
    a ``config.json``, ``seed_*`` folders or the temporary of an atomic write): a run
    writes ``seed_*`` folders and ``config.json`` into it, which would litter a folder of
    other files (``--out ~``).

    Raises
    ------
    ValueError
        Naming ``flag``: an empty path, the root of a file system, an existing file, a
        path under a file, a folder that cannot be created or written, or (with
        ``run_folder``) a folder of other files.
    """
    if not os.fspath(out_dir).strip():
        raise ValueError(f"{flag}: the output folder must be a path, got {os.fspath(out_dir)!r}")
    out = Path(out_dir)
    _refuse_file_system_root(out, flag)
    if out.exists() and not out.is_dir():
        raise ValueError(f"{flag} {out}: exists and is not a folder; choose another output folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"{flag} {out}: cannot create the output folder ({exc.strerror})") from exc
    if not os.access(out, os.W_OK | os.X_OK):
        raise ValueError(f"{flag} {out}: the output folder is not writable")
    if run_folder and any(out.iterdir()) and not any(_is_run_file(p.name) for p in out.iterdir()):
        raise ValueError(
            f"{flag} {out}: holds other files and no config.json, so it is not a run folder; "
            "give a new or empty folder (a run writes config.json and seed_* folders into it)"
        )
    return out


def check_out_file(path: str | os.PathLike[str], flag: str = "--out", suffix: str = "",
                   inputs: Sequence[str | os.PathLike[str]] = ()) -> Path:
    """An output file's path, its folder created if needed; a clear error if a file
    cannot be written there.

    ``suffix``: the ending the file must have (``".md"`` for a page, so that no data or
    configuration file is ever replaced by one); ``inputs``: files the command reads,
    which the output must not be.

    Raises
    ------
    ValueError
        Naming ``flag``: an empty path, another ending than ``suffix``, one of
        ``inputs``, an existing folder (or a path ending in ``/``), a folder that is a
        file or cannot be created, or a place that is not writable.
    """
    text = os.fspath(path)
    if not text.strip():
        raise ValueError(f"{flag}: the output file must be a path, got {text!r}")
    out = Path(text)
    if text.endswith(("/", os.sep)) or out.is_dir():
        raise ValueError(f"{flag} {text}: a folder, where the output file belongs; name the "
                         "file (e.g. docs/learning.md)")
    if suffix and not out.name.endswith(suffix):
        what = _WRITTEN.get(suffix, "of its kind")
        raise ValueError(f"{flag} {text}: the file written is {what} and its name ends in "
                         f"{suffix!r} (so that it never replaces a file of another kind: "
                         "a page, data or a configuration)")
    for given in inputs:
        if out.resolve() == Path(given).resolve():
            raise ValueError(f"{flag} {text}: the command reads that file ({os.fspath(given)}); "
                             "write to another")
    parent = out.parent
    if parent.exists() and not parent.is_dir():
        raise ValueError(f"{flag} {text}: {parent} is a file, not a folder")
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"{flag} {text}: cannot create its folder {parent} "
                         f"({exc.strerror})") from exc
    if not os.access(parent, os.W_OK | os.X_OK) or (out.exists() and not os.access(out, os.W_OK)):
        raise ValueError(f"{flag} {text}: not writable")
    return out


def unwritten_report(results: str | os.PathLike[str], exc: OSError) -> str:
    """What a command says when its runs finished but a page about them could not be
    written (a full disk): nothing finished is lost, and the same command writes it."""
    return (f"the runs finished and their results are kept in {os.fspath(results)}, but "
            f"their report could not be written: {exc}; run the same command again to "
            "write it (the finished jobs are not rerun)")


def check_utf8(args: argparse.Namespace) -> None:
    """Refuse a flag's value that is not UTF-8 (a path of other bytes, as ``argv`` decodes
    them): the page a command writes at its end names its folders and its command in
    UTF-8, and could be written neither after the work nor by a rerun.

    Raises
    ------
    ValueError
        Naming the flag and the value's bytes.
    """
    for dest, value in vars(args).items():
        for item in value if isinstance(value, list) else [value]:
            if isinstance(item, str) and not item.isascii():
                try:
                    item.encode()
                except UnicodeEncodeError:
                    raise ValueError(
                        f"--{dest.replace('_', '-')} {os.fsencode(item)!r}: not UTF-8; the "
                        "page written at the end names it in UTF-8, so give a name in UTF-8"
                    ) from None


def kept_seed_record(path: Path, schema_version: int, identity: Mapping[str, Any],
                     compute: Callable[[], dict[str, Any]]) -> dict[str, Any]:
    """A seed's record kept at ``path`` (digested JSON, written atomically): read if kept,
    else ``compute()`` merged into ``identity`` (what the record is of: its scenario,
    seed, budget, ...) and kept, so that a rerun computes only what is missing.

    Raises
    ------
    ValueError
        Naming the file: it is damaged (not a kept record, its digest does not match), or
        it is of another schema or of something else than ``identity`` says; deleting it
        computes that seed again.
    """
    identity = json.loads(json.dumps(identity))  # as a record reads back (tuples as lists)
    if path.exists():
        try:
            record = read_digested_json(path, schema_version)
            other = {k: record.get(k) for k, v in identity.items() if record.get(k) != v}
            if other:
                raise ValueError(f"{path}: the record of {other}, where {dict(identity)} "
                                 "belongs")
        except (ValueError, OSError) as exc:
            raise ValueError(f"{exc}; delete it to compute that seed again") from None
        return record
    record = {"schema_version": schema_version, **identity, **compute()}
    record = json.loads(json.dumps(record))  # as read back: lists, not tuples
    path.parent.mkdir(parents=True, exist_ok=True)
    write_digested_json(path, record)
    return record


def seed_range(text: str, smallest: int = 2) -> list[int]:
    """``--seeds first-last`` (inclusive; or one seed ``n``) as seeds, at least
    ``smallest`` of them (a page's intervals need two), each ``>= 0``.

    Raises
    ------
    ValueError
        Naming the flag, what was given and what is allowed.
    """
    first, _, last = text.partition("-")
    allowed = (f"--seeds: first-last of integers >= 0, at least {smallest} seeds (e.g. 0-9; "
               "the seed is the unit of every interval)")
    try:
        seeds = list(range(int(first), int(last or first) + 1))
    except ValueError:
        raise ValueError(f"{allowed}, got {text!r}") from None
    if int(first) < 0 or len(seeds) < smallest:
        raise ValueError(f"{allowed}, got {text!r}")
    return seeds


def written_or_exit(parser: argparse.ArgumentParser, write: Callable[[], None],
                    page_path: Path) -> None:
    """``write()``, then say what was written; a kept file that cannot be read, or a page
    that cannot be written, ends the command with one line naming it (exit 1; whatever
    was kept before stays)."""
    try:
        write()
    except (ValueError, OSError) as exc:
        parser.exit(1, f"{parser.prog}: error: {exc}\n")
    print(f"wrote {page_path}")


def description(doc: str | None) -> str:
    """A command's ``--help`` description from its module's docstring: the first
    paragraph, whole (a sentence over two lines is not cut), without reST's literal
    markup (double backticks)."""
    return " ".join((doc or "").split("\n\n")[0].split()).replace("``", "")
