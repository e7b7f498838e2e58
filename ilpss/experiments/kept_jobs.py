"""Finished jobs of a command kept as files, so that a rerun does only what is left.

A job is described by a JSON-ready ``key`` (everything its result depends on: the team,
the seed, the sizes, the learner's settings). Its result is written, as soon as it
arrives, to ``<folder>/<kind>-<digest of the key>.json``: a JSON record (schema and
SHA-256, :func:`ilpss._io.json_record_bytes`) holding the key and the result, written
atomically. A later run with the same key loads it instead of computing it again; a
run with other settings has other keys, so it never takes another run's results. The
file names come from the digest alone, and a kept file that is a symbolic link is
refused: nothing leads a read or a write outside the folder. Each file records the code
that computed it (:func:`~ilpss.experiments.provenance.code_record`): a result of other
code is refused naming both, unless mixing is allowed (then :attr:`KeptJobs.codes` names
every code the results came from), and a command's ``check`` of each result (types,
lengths, ranges, and that it is the key's job) refuses a file whose digest was
recomputed after an edit.

:func:`run_kept` is the loop a command uses: it loads what is kept, runs the rest on an
executor and keeps each result as it arrives, so that a job that fails, or a stop,
loses only the jobs still running.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from ilpss._io import (
    atomic_write_bytes,
    canonical_json,
    check_inside,
    json_record_bytes,
    load_json_record,
    locked_folder,
    remove_stale_temporaries,
)
from ilpss.experiments.executor import SETTINGS_ERRORS, JobsFailed
from ilpss.experiments.provenance import (
    check_code_field,
    check_same_code,
    code_record,
    with_libraries,
)

__all__ = ["KeptJobs", "run_kept"]

JOB_SCHEMA = "ilpss.kept_job/2"

ResultCheck = Callable[[str, Mapping[str, Any], Any], None]
"""``check(where, key, result)``: raises ``ValueError`` (naming ``where``) if ``result`` is
not what the job ``key`` returns."""


class KeptJobsFailed(RuntimeError):
    """Some jobs failed; every other one finished and is kept in the folder."""


class KeptJobs:
    """The kept results of one folder.

    Parameters
    ----------
    folder : str or os.PathLike
        An existing folder (the caller checks and locks it).
    allow_mixed_code : bool, default False
        Load results that other code computed (refused otherwise).
    libraries : dict of str to str, optional
        ``{distribution: version}`` of the libraries the results also depend on: recorded
        with this code in every result kept, and a result of other versions is other
        code (:func:`~ilpss.experiments.provenance.with_libraries`).

    Attributes
    ----------
    codes : dict
        By its record (as canonical JSON), every code that made what a page of these results shows: this
        process's, and that of every result loaded.
    """

    def __init__(self, folder: str | os.PathLike[str], *, allow_mixed_code: bool = False,
                 libraries: Mapping[str, str] | None = None) -> None:
        self.folder = Path(folder)
        self.allow_mixed_code = allow_mixed_code
        self.current = with_libraries(code_record(), libraries)
        self.codes: dict[str, dict[str, Any]] = {canonical_json(self.current): self.current}

    def path(self, kind: str, key: Mapping[str, Any]) -> Path:
        """Where the result of the job ``key`` of ``kind`` is kept."""
        digest = hashlib.sha256(canonical_json(key).encode()).hexdigest()[:20]
        return self.folder / f"{kind}-{digest}.json"

    @contextlib.contextmanager
    def held(self) -> Iterator[KeptJobs]:
        """The folder locked for this process, its stale temporaries removed: what a
        command holds while it loads and keeps jobs."""
        with locked_folder(self.folder, "job folder"):
            remove_stale_temporaries(self.folder)
            yield self

    def load(self, kind: str, key: Mapping[str, Any], check: ResultCheck | None = None
             ) -> Any | None:
        """The kept result of the job ``key`` (``None`` if it is not kept), checked by
        ``check`` if given.

        Raises
        ------
        ValueError
            Naming the file: damaged, modified, holding another job or a result that
            ``check`` refuses (delete the file to compute that job again).
        MixedCodeError
            Other code computed it (naming both), unless mixing is allowed.
        """
        path = self.path(kind, key)
        if not path.exists() and not path.is_symlink():
            return None
        try:
            check_inside(self.folder, path, "job folder")  # a link is refused, not followed
            record = load_json_record(path, JOB_SCHEMA)
            if record.get("kind") != kind or canonical_json(record.get("key")) != canonical_json(key):
                raise ValueError(f"{path}: holds the result of another job")
            code = check_code_field(str(path), record.get("code"))
            if check is not None:
                check(f"{path}: result", key, record.get("result"))
        except ValueError as exc:
            raise ValueError(f"{exc}; delete it to compute that job again") from None
        check_same_code(code, str(path), allow=self.allow_mixed_code, current=self.current)
        self.codes.setdefault(canonical_json(code), code)
        return record["result"]

    def save(self, kind: str, key: Mapping[str, Any], result: Any) -> None:
        """Keep ``result`` (JSON-ready) of the job ``key``, atomically, with this code."""
        record = {"schema": JOB_SCHEMA, "kind": kind, "key": dict(key), "result": result,
                  "code": self.current}
        atomic_write_bytes(self.path(kind, key), json_record_bytes(record))


def run_kept(
    executor: Any,
    fn: Callable[[Any], Any],
    jobs: Sequence[Any],
    kind: str,
    key: Callable[[Any], Mapping[str, Any]],
    kept: KeptJobs,
    desc: str = "",
    check: ResultCheck | None = None,
) -> tuple[list[Any], int]:
    """``[fn(job) for job in jobs]``: the kept results loaded (each checked by ``check``,
    if given), the others computed on ``executor`` (``map(fn, items, desc, done)``) and
    kept as each arrives. Returns the results, in job order, and how many were loaded.

    Raises
    ------
    KeptJobsFailed
        After every other job finished and was kept, naming the failed jobs' keys.
    """
    results = [kept.load(kind, key(job), check) for job in jobs]
    todo = [i for i, r in enumerate(results) if r is None]

    def done(k: int, result: Any) -> None:
        kept.save(kind, key(jobs[todo[k]]), result)
        results[todo[k]] = result

    try:
        executor.map(fn, [jobs[i] for i in todo], desc=desc, done=done)
    except JobsFailed as exc:
        failed = "; ".join(f"{_named(key(jobs[todo[k]]))}: {type(e).__name__}: {e}"
                           for k, e in exc.failures.items())
        if all(isinstance(e, SETTINGS_ERRORS) for e in exc.failures.values()):
            advice = ("they fail the same way with these settings, so running the same "
                      "command again does not help: change the setting named above")
        else:
            advice = "the same command computes only what is left"
        raise KeptJobsFailed(
            f"{len(exc.failures)} of {len(jobs)} {kind} job(s) failed ({failed}); the "
            f"{len(jobs) - len(exc.failures)} others are kept in {kept.folder}; {advice}"
        ) from exc
    return results, len(jobs) - len(todo)


def _named(key: Mapping[str, Any]) -> str:
    """A job by the plain values of its key (``team=chasers, seed=1, ...``)."""
    return ", ".join(f"{k}={v}" for k, v in key.items() if not isinstance(v, dict | list))
