"""The per-seed numbers behind a results page, kept in the repository.

A page (``docs/results.md``, a confirmatory page) is computed from the learning curves of
its runs, which live in run folders that are not committed. This module keeps what the
page is computed from, and nothing else, as two files beside each other:

* ``<name>.csv.gz``: one row per (protocol, seed, stream, method, kind, task): ``kind`` is
  ``curve`` (the learning curve on target ``task``: one reward per episode, rounded to
  :data:`DECIMALS` decimals) or a series a method records per task of its stream
  (``library_size``, ``rollout_success_rate``, ...), ``values`` the numbers separated by
  spaces. Any CSV reader opens it (``pandas.read_csv("x.csv.gz")``).
* ``<name>.json``: the manifest: its schema, the SHA-256 of the CSV's bytes, and per
  protocol the run's configuration and every job's stream (its tasks, first target and
  the code that made it).

:meth:`SeedData.from_runs` reads finished run folders (every result checked as a resume
checks it); :meth:`SeedData.write` writes the two files atomically; :meth:`SeedData.read`
reads them back, refusing a file whose digest, schema, configuration or rows do not hold
together. Pages are then computed from a :class:`SeedData` alone (:meth:`results` gives
the jobs' results in the form the reports read, :meth:`seed_curves` each seed's pooled
curve on the targets), so the figures on a page are those of the committed numbers.
"""

from __future__ import annotations

import csv
import gzip
import hashlib
import io
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ilpss._io import (
    atomic_write_bytes,
    json_record_bytes,
    load_json_record,
    read_regular,
)
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.folder import WALL_TIME_FIELDS, RunFolder
from ilpss.experiments.methods import METHODS
from ilpss.experiments.provenance import check_code_field
from ilpss.experiments.run import check_entry, check_job_fields, load_result, read_config, run_order
from soccer_drill.constraints import Integer, JsonObject, NoneOr, check, check_fields, check_keys

__all__ = ["SeedData"]

SCHEMA = "ilpss.seed_data/1"
DECIMALS = 4
"""Rewards are kept to 4 decimals: a total over 300 episodes moves by at most 0.015."""
COLUMNS = ("protocol", "seed", "stream_index", "method", "kind", "task", "values")
MAX_CSV_BYTES = 256 * 2**20
"""The largest decompressed table read (a page's table is a few MB)."""


@dataclass(frozen=True)
class SeedData:
    """Every job's results of one or more runs, by protocol."""

    configs: Mapping[str, ExperimentConfig]
    """Per protocol, the run's configuration."""
    jobs: Mapping[str, Sequence[Mapping[str, Any]]]
    """Per protocol, every job's result in the form of ``result.json`` (``seed``,
    ``stream``, ``stream_index``, ``tasks``, ``first_target``, ``code`` and ``methods``:
    per method its ``curves`` by target and its series)."""
    wall_times: Mapping[str, Mapping[str, Any] | None] = field(default_factory=dict)
    """Per protocol, the run folder's timing record (``seconds``, ``workers``,
    ``executor``), where it has one."""

    # ------------------------------------------------------------------ from run folders
    @classmethod
    def from_runs(cls, folders: Mapping[str, Path], *, require_all: bool = True) -> SeedData:
        """The results of the run folders ``folders`` (by protocol), every ``result.json``
        checked against its configuration and job. With ``require_all`` every job of
        each configuration must be finished (``ValueError`` naming the missing seeds);
        otherwise the seeds whose every stream is finished are kept."""
        configs, jobs, times = {}, {}, {}
        for protocol, folder in folders.items():
            run = RunFolder(folder)
            if not run.config.is_file():
                raise ValueError(f"{folder}: no config.json (not a folder written by "
                                 "ilpss-experiment)")
            cfg = read_config(run.config)
            if cfg.protocol != protocol:
                raise ValueError(f"{folder}: holds protocol {cfg.protocol}, not {protocol}")
            kept, missing = [], []
            for seed in cfg.seeds:
                streams = cfg.streams(seed)
                paths = [run.result(seed, i) for i in range(len(streams))]
                if not all(p.is_file() for p in paths):
                    missing.append(seed)
                    continue
                kept += [load_result(p, cfg, seed, i, s)
                         for i, (p, s) in enumerate(zip(paths, streams, strict=True))]
            if missing and require_all:
                raise ValueError(f"{folder}: seeds {seed_ranges(missing)} of its {cfg.n_seeds} are "
                                 "not finished")
            configs[protocol], jobs[protocol] = cfg, kept
            times[protocol] = run.wall_time()
        return cls(configs, jobs, times)

    # ------------------------------------------------------------------ views
    def results(self, protocol: str) -> list[dict[str, Any]]:
        """The jobs of ``protocol`` as the reports read them (``result.json``'s fields)."""
        cfg = self.configs[protocol]
        # In the order a run gives them (the table is sorted by name).
        order = run_order(cfg.methods)
        return [{**job, "config": cfg.results_record(),
                 "methods": {name: job["methods"][name] for name in order}}
                for job in self.jobs[protocol]]

    def seeds(self, protocol: str) -> list[int]:
        """The seeds of ``protocol`` held here, in order."""
        return sorted({job["seed"] for job in self.jobs[protocol]})

    def seed_curves(self, protocol: str, method: str) -> dict[int, np.ndarray]:
        """``{seed: curve}``: each seed's learning curve of ``method`` averaged over the
        targets of every one of its streams (as every report pools them)."""
        by_seed: dict[int, list[list[float]]] = {}
        for job in self.jobs[protocol]:
            entry = job["methods"].get(method)
            if entry is None:
                raise ValueError(f"protocol {protocol}: no method {method!r}; the run has "
                                 f"{sorted(job['methods'])}")
            curves = entry["curves"]
            by_seed.setdefault(job["seed"], []).extend(curves[t] for t in sorted(curves, key=int))
        return {seed: np.mean(curves, axis=0) for seed, curves in sorted(by_seed.items())}

    def codes(self) -> list[dict[str, Any]]:
        """The distinct codes that made the results, in the order first met."""
        seen: dict[str, dict[str, Any]] = {}
        for jobs in self.jobs.values():
            for job in jobs:
                seen.setdefault(job["code"]["source_digest"], job["code"])
        return list(seen.values())

    # ------------------------------------------------------------------ files
    def write(self, stem: str | os.PathLike[str]) -> tuple[Path, Path]:
        """Write ``<stem>.csv.gz`` and ``<stem>.json`` (each atomically, the table first);
        return their paths."""
        table, manifest = data_paths(stem)
        payload = _gzip(self._csv())
        atomic_write_bytes(table, payload)
        record = {
            "schema": SCHEMA, "decimals": DECIMALS,
            "table_sha256": hashlib.sha256(payload).hexdigest(),
            "protocols": {p: {"config": self.configs[p].results_record(),
                              "wall_time": self.wall_times.get(p),
                              "jobs": [{k: job[k] for k in _JOB_FIELDS}
                                       for job in self.jobs[p]]}
                          for p in self.configs},
        }
        atomic_write_bytes(manifest, json_record_bytes(record))
        return table, manifest

    @classmethod
    def read(cls, stem: str | os.PathLike[str]) -> SeedData:
        """The numbers written by :meth:`write` at ``stem`` (the table and its manifest,
        both checked: ``ValueError`` naming the file and what is wrong)."""
        table, manifest = data_paths(stem)
        record = load_json_record(manifest, SCHEMA)
        payload = read_regular(table, MAX_CSV_BYTES, "a table of per-seed numbers")
        if hashlib.sha256(payload).hexdigest() != record.get("table_sha256"):
            raise ValueError(f"{table}: its SHA-256 is not the one {manifest} records; the "
                             "table was modified or belongs to another manifest")
        protocols = record.get("protocols")
        if not isinstance(protocols, dict) or not protocols:
            raise ValueError(f"{manifest}: 'protocols' must map protocol names to runs")
        configs, jobs, times = {}, {}, {}
        for protocol, run in protocols.items():
            try:
                check_keys(f"{manifest}: protocols.{protocol}", run,
                           ("config", "wall_time", "jobs"))
                times[protocol] = _wall_time(run["wall_time"], f"{manifest}: {protocol}")
                configs[protocol] = ExperimentConfig.from_dict(run["config"])
                jobs[protocol] = [_job(job, f"{manifest}: protocols.{protocol}")
                                  for job in run["jobs"]]
            except (KeyError, TypeError) as exc:
                raise ValueError(f"{manifest}: protocols.{protocol} is malformed ({exc})") from exc
        _fill(jobs, _rows(_gunzip(payload, table), table), table)
        for protocol, js in jobs.items():  # every job holds exactly its run's methods
            wanted = set(configs[protocol].methods)
            for job in js:
                if set(job["methods"]) != wanted:
                    raise ValueError(
                        f"{table}: protocol {protocol}, seed {job['seed']}, stream "
                        f"{job['stream_index']} holds the methods {sorted(job['methods'])}; "
                        f"its run has {sorted(wanted)}")
                _check_job(job, configs[protocol], f"{table}: protocol {protocol}")
        return cls(configs, jobs, times)

    def _csv(self) -> str:
        out = io.StringIO()
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow(COLUMNS)
        for protocol, jobs in self.jobs.items():
            for job in jobs:
                for method, entry in sorted(job["methods"].items()):
                    for target, curve in sorted(entry["curves"].items(), key=lambda kv: int(kv[0])):
                        writer.writerow([protocol, job["seed"], job["stream_index"], method,
                                         "curve", target, _numbers(curve, DECIMALS)])
                    for series, values in sorted(entry.items()):
                        if series != "curves":
                            writer.writerow([protocol, job["seed"], job["stream_index"],
                                             method, series, "", _numbers(values, 6)])
        return out.getvalue()


TIMING = {**WALL_TIME_FIELDS, "executor": NoneOr(WALL_TIME_FIELDS["executor"])}
"""A run's timing record; executor ``None``: a span read from the files' times."""
_JOB_FIELDS = ("seed", "stream", "stream_index", "tasks", "first_target", "code")


def data_paths(stem: str | os.PathLike[str]) -> tuple[Path, Path]:
    """The two files of the per-seed numbers ``stem`` names: the table and the manifest."""
    stem = Path(stem)
    return stem.with_name(stem.name + ".csv.gz"), stem.with_name(stem.name + ".json")


def _numbers(values: Iterable[float], decimals: int) -> str:
    out = []
    for v in values:
        r = round(float(v), decimals)
        out.append(str(int(r)) if r == int(r) else repr(r))
    return " ".join(out)


def _gzip(text: str) -> bytes:
    # mtime 0 and no file name: the same numbers always give the same bytes.
    buffer = io.BytesIO()
    with gzip.GzipFile(fileobj=buffer, mode="wb", mtime=0, filename="") as fh:
        fh.write(text.encode())
    return buffer.getvalue()


def _gunzip(payload: bytes, where: Path) -> str:
    try:
        with gzip.GzipFile(fileobj=io.BytesIO(payload)) as fh:
            text = fh.read(MAX_CSV_BYTES + 1)
    except (OSError, EOFError) as exc:
        raise ValueError(f"{where}: not a readable gzip file ({exc})") from exc
    if len(text) > MAX_CSV_BYTES:
        raise ValueError(f"{where}: decompresses to more than {MAX_CSV_BYTES} bytes")
    return text.decode()


def _wall_time(record: Any, where: str) -> dict[str, Any] | None:
    if record is None:
        return None
    check(f"{where}: wall_time", record, JsonObject("timings"))
    check_keys(f"{where}: wall_time", record, TIMING)
    check_fields(f"{where}: wall_time", record, TIMING, get=dict.get)
    return record


def _job(job: Any, where: str) -> dict[str, Any]:
    if not isinstance(job, dict) or set(job) != set(_JOB_FIELDS):
        raise ValueError(f"{where}: a job must hold exactly {list(_JOB_FIELDS)}")
    for key in ("seed", "stream_index"):  # a job's key, before anything looks it up
        check(f"{where}: a job's {key}", job[key], Integer(0))
    check_code_field(where, job["code"])
    return {**job, "methods": {}}


def _check_job(job: dict[str, Any], cfg: ExperimentConfig, where: str) -> None:
    """A job read back is one its configuration has (its seed, stream, tasks) and each
    method's numbers are what a run checks when it keeps them (a curve per target of the
    budget's length within the environment's reward range, each series per task)."""
    seed, index = job["seed"], job["stream_index"]
    streams = cfg.streams(seed) if seed in cfg.seeds else []
    if index >= len(streams):
        raise ValueError(f"{where}: seed {seed}, stream {index} is not a job of its "
                         f"configuration (seeds {seed_ranges(list(cfg.seeds))})")
    where = f"{where}, seed {seed}, stream {index}"
    check_job_fields(job, streams[index], seed, index, where)
    for method, entry in job["methods"].items():
        check_entry(method, entry, cfg, streams[index], f"{where}: methods.{method}")


def _rows(text: str, where: Path) -> list[list[str]]:
    rows = list(csv.reader(io.StringIO(text)))
    if not rows or tuple(rows[0]) != COLUMNS:
        raise ValueError(f"{where}: the header must be {','.join(COLUMNS)}")
    return rows[1:]


def _fill(jobs: dict[str, list[dict[str, Any]]], rows: list[list[str]], where: Path) -> None:
    """Put each row's numbers into its job (every row must name a job of the manifest,
    and every job must have rows)."""
    index = {(p, job["seed"], job["stream_index"]): job for p, js in jobs.items() for job in js}
    for n, row in enumerate(rows, start=2):
        try:
            protocol, seed, stream, method, kind, task, values = row
            job = index[protocol, int(seed), int(stream)]
            numbers = [float(v) for v in values.split()]
        except (ValueError, KeyError) as exc:
            raise ValueError(f"{where}: line {n} does not name a job of the manifest with "
                             f"numbers ({exc})") from exc
        if not all(np.isfinite(numbers)):
            raise ValueError(f"{where}: line {n} holds a number that is not finite")
        entry = job["methods"].setdefault(method, {"curves": {}})
        if kind == "curve":
            entry["curves"][task] = numbers
        else:
            entry[kind] = _series_values(method, kind, numbers, f"{where}: line {n}")
    for key, job in index.items():
        if not job["methods"]:
            raise ValueError(f"{where}: no rows for job {key}")


def _series_values(method: str, series: str, numbers: list[float], where: str) -> list:
    """A series' numbers as the method declares them (integers where it counts)."""
    declared = METHODS.get(method).series.get(series)
    if declared is None:
        raise ValueError(f"{where}: method {method!r} records no series {series!r}")
    if isinstance(declared, Integer):
        if not all(v.is_integer() for v in numbers):
            raise ValueError(f"{where}: the series {series!r} holds counts, got {numbers}")
        return [int(v) for v in numbers]
    return numbers


def seed_ranges(seeds: Sequence[int]) -> str:
    """``[1000, 1001, 1002, 1005]`` as ``1000-1002, 1005``."""
    parts, start = [], None
    for i, s in enumerate(seeds):
        if start is None:
            start = s
        if i + 1 == len(seeds) or seeds[i + 1] != s + 1:
            parts.append(f"{start}" if start == s else f"{start}-{s}")
            start = None
    return ", ".join(parts)
