"""The code that made a result: recorded with every run and result, compared before mixing.

A run folder's ``config.json`` and every job's ``result.json`` record :func:`code_record`:
the installed version of the distribution, a digest of the source files of the three
packages (the drill, its teams and the learner), and the git commit of the source tree
when it is a git work tree. Two results come from the same code when their digests
agree; the version and the commit are there to name the code to a reader.

A resume, ``ilpss-compare``, ``ilpss-results`` and the kept jobs of
``ilpss-holder-learning`` refuse to mix results of different code
(:func:`check_same_code`, a :class:`MixedCodeError` naming both), unless they are told
to (``--allow-mixed-code``), in which case what they write says so.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.metadata
import importlib.util
import subprocess
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

__all__ = ["check_same_code", "describe"]

CODE_PACKAGES = ("soccer_drill", "opponents", "ilpss")
"""The packages whose source files make a result: the drill, its teams, the learner."""
DISTRIBUTION = "soccer-drill-ilpss"
CODE_FIELDS = ("version", "source_digest", "git_commit")
"""The fields of a code record; each a string, or ``None`` where it is not known."""
LIBRARIES = "libraries"
"""An optional field of a code record: ``{distribution: version}`` of the libraries a
result also depends on (the learners of ``soccer-drill-reference``: torch, SB3), so that
an upgrade of one is other code, never mixed silently."""
ALLOW_FLAG = "--allow-mixed-code"


class MixedCodeError(ValueError):
    """Results of different code would be mixed; the message names both."""


def _package_dirs() -> list[Path]:
    """Where the packages' source files are, found without importing them."""
    dirs = []
    for name in CODE_PACKAGES:
        spec = importlib.util.find_spec(name)
        if spec is None or not spec.submodule_search_locations:
            raise RuntimeError(f"the package {name!r} is not installed")
        dirs.append(Path(next(iter(spec.submodule_search_locations))))
    return dirs


def source_digest(package_dirs: Iterable[Path]) -> str:
    """SHA-256 over every source file of the packages, by package and relative path
    (compiled caches left out), so that any change to a file, a new file or a removed
    one gives another digest."""
    digest = hashlib.sha256()
    for root in package_dirs:
        files = sorted(p for p in root.rglob("*") if p.is_file()
                       and "__pycache__" not in p.parts and p.suffix not in (".pyc", ".pyo"))
        for path in files:
            name = f"{root.name}/{path.relative_to(root).as_posix()}"
            content = path.read_bytes()
            digest.update(f"{name}\0{len(content)}\0".encode())
            digest.update(content)
    return digest.hexdigest()


def _git_commit(source: Path) -> str | None:
    """The commit checked out where the packages are, if that folder is the top of a git
    work tree (an installed copy inside some other repository's tree is not its code)."""
    try:
        out = subprocess.run(["git", "-C", str(source), "rev-parse", "--show-toplevel", "HEAD"],
                             capture_output=True, text=True, encoding="utf-8", timeout=10,
                             check=False)
    except (OSError, subprocess.SubprocessError):
        return None
    lines = out.stdout.split()
    if out.returncode != 0 or len(lines) != 2 or len(lines[1]) != 40:
        return None
    return lines[1] if Path(lines[0]).resolve() == source.resolve() else None


def _version() -> str | None:
    try:
        return importlib.metadata.version(DISTRIBUTION)
    except importlib.metadata.PackageNotFoundError:
        return None


@functools.cache
def code_record() -> dict[str, str | None]:
    """This process's code: ``{"version", "source_digest", "git_commit"}`` (computed
    once: the files a process runs are the ones it imported)."""
    dirs = _package_dirs()
    return {"version": _version(), "source_digest": source_digest(dirs),
            "git_commit": _git_commit(dirs[-1].parent)}


def with_libraries(code: Mapping[str, Any], libraries: Mapping[str, str] | None
                   ) -> dict[str, Any]:
    """``code`` with the :data:`LIBRARIES` field when ``libraries`` are given."""
    return {**code, LIBRARIES: dict(sorted(libraries.items()))} if libraries else dict(code)


def describe(code: Mapping[str, Any] | None) -> str:
    """A code record as a reader names it: version, sources' digest, commit (and the
    libraries it records)."""
    if code is None:
        return "no record of its code (made before results recorded it)"
    commit = code.get("git_commit")
    libraries = "".join(f", {name} {version}" for name, version in
                        (code.get(LIBRARIES) or {}).items())
    return (f"version {code.get('version') or '?'}, sources {str(code.get('source_digest'))[:12]}"
            + (f", commit {commit[:10]}" if commit else "") + libraries)


def check_code_field(where: str, value: Any) -> dict[str, Any]:
    """A code record read from a file: an object of :data:`CODE_FIELDS`, each a string
    or null (the digest a string), and optionally :data:`LIBRARIES` (an object of
    strings), else ``ValueError`` naming ``where``."""
    if not isinstance(value, dict) or set(value) - {LIBRARIES} != set(CODE_FIELDS):
        raise ValueError(f"{where}: 'code' must be an object with the fields "
                         f"{list(CODE_FIELDS)} (and optionally {LIBRARIES!r}), got {value!r}")
    for name, item in value.items():
        if name == LIBRARIES:
            if not (isinstance(item, dict) and all(isinstance(k, str) and isinstance(v, str)
                                                   for k, v in item.items())):
                raise ValueError(f"{where}: code.{LIBRARIES} must be an object of versions "
                                 f"(strings), got {item!r}")
        elif not (isinstance(item, str) or (item is None and name != "source_digest")):
            raise ValueError(f"{where}: code.{name} must be a string, got {item!r}")
    return value


def same_code(one: Mapping[str, Any] | None, other: Mapping[str, Any] | None) -> bool:
    """Whether two code records name the same code: the same sources and libraries."""
    return (one is not None and other is not None
            and one.get("source_digest") == other.get("source_digest")
            and one.get(LIBRARIES) == other.get(LIBRARIES))


def check_same_code(
    found: Mapping[str, Any] | None, where: str, *, allow: bool = False,
    current: Mapping[str, Any] | None = None, current_where: str | None = None,
) -> bool:
    """Whether ``found`` (a record read from ``where``; ``None``: none) is the same code
    as ``current`` (default: this process's; ``current_where``: where that was read).
    Different code raises :class:`MixedCodeError` naming both, unless ``allow``; then
    ``False`` is returned."""
    current = code_record() if current is None else current
    if same_code(found, current):
        return True
    if allow:
        return False
    other = (f"{current_where} by {describe(current)}" if current_where
             else f"this is {describe(current)}")
    raise MixedCodeError(
        f"{where} was made by {describe(found)}; {other}. Results of different code are not "
        f"mixed: use another folder (or put that code back), or pass {ALLOW_FLAG} to mix "
        "them knowingly (what is written then says so)"
    )


def check_one_code(codes: Mapping[str, tuple[Mapping[str, Any], str]], *,
                   allow: bool = False) -> None:
    """Refuse results of more than one code (``codes``: by digest, a code and a file that
    has it), naming two of them, unless ``allow``."""
    if len(codes) > 1:
        (one, one_file), (other, other_file) = list(codes.values())[:2]
        check_same_code(other, other_file, allow=allow, current=one, current_where=one_file)


def code_line(results: Iterable[Mapping[str, Any]]) -> str:
    """The line a report gives to the code of its ``results`` (each with ``"code"``): the
    one code that made them, or every code when they were mixed knowingly."""
    codes: dict[Any, Mapping[str, Any] | None] = {}
    for result in results:
        code = result.get("code")
        codes.setdefault(None if code is None else
                         (code.get("source_digest"), str(code.get(LIBRARIES))), code)
    if len(codes) == 1:
        return f"Code: {describe(next(iter(codes.values())))}."
    named = "; ".join(describe(code) for code in codes.values())
    return (f"**Mixed code** (allowed by {ALLOW_FLAG}): these results come from "
            f"{len(codes)} versions of the code: {named}.")
