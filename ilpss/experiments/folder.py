"""The layout of a run folder, spelled once.

::

    <root>/config.json                          the configuration (ExperimentConfig)
    <root>/seed_SSS/stream_TT/result.json       one job's curves and series, checked
    <root>/seed_SSS/stream_TT/<method>/         a lifelong method's checkpoints
    <root>/seed_SSS/stream_TT/<method>/target_KK/   ... of each target, when a stream's
                                                targets all start after its sources
    <root>/report.md, <root>/*.png              the report and its figures
    <root>/wall_time.json                       ilpss-results' timing record
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ilpss._io import (
    atomic_write_bytes,
    check_inside,
    json_record_bytes,
    load_json_record,
    read_json,
)
from ilpss.experiments.executor import EXECUTOR
from soccer_drill.constraints import Integer, Real, check_fields

__all__ = ["RunFolder", "checkpoint_key"]

WALL_TIME_SCHEMA = "ilpss.wall_time/1"
WALL_TIME_FIELDS = {"seconds": Real(0.0), "workers": Integer(1), "executor": EXECUTOR}
"""The fields of ``wall_time.json`` and what each allows."""

_SEED = re.compile(r"seed_(\d{3,})")


def checkpoint_key(seed: int, stream_index: int, method: str, target: int | None = None) -> str:
    """Where a checkpoint folder lies below the run folder or the checkpoint storage (a
    ``/``-separated relative path; see :mod:`ilpss.experiments.checkpoints`)."""
    key = f"seed_{seed:03d}/stream_{stream_index:02d}/{method}"
    return key if target is None else f"{key}/target_{target:02d}"


@dataclass(frozen=True, init=False)
class RunFolder:
    """The paths of one run of an experiment."""

    root: Path
    """The folder (``--out``)."""

    def __init__(self, root: str | os.PathLike[str]) -> None:
        object.__setattr__(self, "root", Path(root))

    def _inside(self, path: Path) -> Path:
        """``path``, refused if a symbolic link below the root leads it outside: every
        path this class gives is checked, so a run never reads, writes or deletes
        outside its folder (the root itself may be a link)."""
        return check_inside(self.root, path, "run folder")

    @property
    def config(self) -> Path:
        """``config.json``."""
        return self._inside(self.root / "config.json")

    @property
    def team_code(self) -> Path:
        """``team_code.json``: the code of the teams the run plays, checked on resume."""
        return self._inside(self.root / "team_code.json")

    @property
    def report(self) -> Path:
        """``report.md``."""
        return self._inside(self.root / "report.md")

    @property
    def timing(self) -> Path:
        """The wall-time record of ``ilpss-results``."""
        return self._inside(self.root / "wall_time.json")

    def figure(self, name: str) -> Path:
        """A figure of the report."""
        return self._inside(self.root / name)

    def job(self, seed: int, stream_index: int) -> Path:
        """The folder of one (seed, stream) job."""
        return self._inside(self.root / f"seed_{seed:03d}" / f"stream_{stream_index:02d}")

    def result(self, seed: int, stream_index: int) -> Path:
        """A job's ``result.json``."""
        return self._inside(self.job(seed, stream_index) / "result.json")

    def checkpoints(
        self, seed: int, stream_index: int, method: str, target: int | None = None
    ) -> Path:
        """The checkpoint folder of a lifelong method in a job (of one ``target`` task, in
        a stream whose targets all start from the state after its sources)."""
        return self._inside(self.root / checkpoint_key(seed, stream_index, method, target))

    def wall_time(self) -> dict[str, Any] | None:
        """The timing record (``seconds``, ``workers``, ``executor``), if there is one.

        Raises
        ------
        ValueError
            Naming the file: damaged, modified after saving, or with a value that
            :data:`WALL_TIME_FIELDS` does not allow.
        """
        path = self.timing
        if not path.exists() and not path.is_symlink():
            return None
        record = read_json(path)
        if isinstance(record, dict) and "schema" in record:
            record = load_json_record(path, WALL_TIME_SCHEMA)
            del record["schema"]
        # Before the schema, the record was the three fields alone: still read.
        if not (isinstance(record, dict) and record.keys() == WALL_TIME_FIELDS.keys()):
            raise ValueError(f"{path}: not a wall-time record ({WALL_TIME_SCHEMA}); delete it, "
                             "and the next run of ilpss-results starts a new one")
        try:
            check_fields("wall_time", record, WALL_TIME_FIELDS, get=dict.get)
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}; delete it, and the next run of ilpss-results "
                             "starts a new one") from None
        return {**record, "seconds": float(record["seconds"])}

    def add_wall_time(self, seconds: float, workers: int, executor: str) -> None:
        """Add ``seconds`` of a run that finished jobs to the timing record."""
        record = self.wall_time()
        total = (record["seconds"] if record else 0.0) + seconds
        atomic_write_bytes(self.timing, json_record_bytes(
            {"schema": WALL_TIME_SCHEMA, "seconds": total, "workers": workers,
             "executor": executor}))

    def finished_seeds(self, stream_index: int = 0) -> list[int]:
        """Seeds whose job on stream ``stream_index`` has a ``result.json``, in order."""
        seeds = []
        for path in self.root.glob(f"seed_*/stream_{stream_index:02d}/result.json"):
            match = _SEED.fullmatch(path.parent.parent.name)
            if match:
                seeds.append(int(match.group(1)))
        return sorted(seeds)
