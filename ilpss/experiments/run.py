"""Run an experiment: every seed and stream, every method, checkpointed and resumable.

Read top to bottom: :func:`run_experiment` writes the configuration, runs one job
per (seed, stream) through an executor, and gathers the learning curves;
:func:`run_stream` is one job: each method of the configuration runs on the stream
(:mod:`ilpss.experiments.methods`; a lifelong method checkpoints after every trial, and
PRQ-learning reuses the policies learnt anew), and the job's ``result.json`` is written.
A job whose ``result.json`` exists is not run again (it is read, checked), and a job that
was interrupted resumes from its last checkpoints, so a resumed experiment ends
identical to an uninterrupted one. The folder's layout is :class:`RunFolder`'s.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from ilpss._check import Integer, ListOf, Real, check_fields, check_keys
from ilpss._io import (
    atomic_write_bytes,
    json_differences,
    json_record_bytes,
    load_json_record,
    locked_folder,
    read_json,
    remove_stale_temporaries,
)
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.executor import make_executor
from ilpss.experiments.folder import RunFolder
from ilpss.experiments.methods import METHODS, Job, LifelongMethod, lifelong_entry
from ilpss.experiments.protocols import Stream, make_env
from ilpss.lifelong import latest_checkpoint, read_state

__all__ = ["RESULT_SCHEMA", "load_result", "read_config", "run_experiment", "run_stream"]

RESULT_SCHEMA = "ilpss.experiment_result/2"


def run_stream(job: tuple[ExperimentConfig, int, int, str]) -> dict[str, Any]:
    """One (seed, stream) job; returns (and saves) its learning curves."""
    cfg, seed, stream_index, out_dir = job
    stream = cfg.streams(seed)[stream_index]
    folder = RunFolder(out_dir)
    done = folder.result(seed, stream_index)
    if done.exists():
        return load_result(done, cfg, seed, stream_index, stream)
    folder.job(seed, stream_index).mkdir(parents=True, exist_ok=True)
    # The run holds the run folder's lock: temporaries in the job's folder are stale.
    remove_stale_temporaries(folder.job(seed, stream_index))
    context = Job(cfg, seed, stream_index, stream, folder)
    # Methods that reuse other methods' learners run after them.
    order = sorted(cfg.methods, key=lambda m: bool(METHODS.get(m).reuses))
    methods = {name: METHODS.get(name).run(context) for name in order}
    result = {
        "schema": RESULT_SCHEMA,
        "config": cfg.results_record(),
        "seed": seed,
        "stream": stream.name,
        "stream_index": stream_index,
        "tasks": [t.name for t in stream.tasks],
        "first_target": stream.first_target,
        "methods": methods,
    }
    atomic_write_bytes(done, json_record_bytes(result))
    return result


RESULT_FIELDS = ("schema", "config", "seed", "stream", "stream_index", "tasks", "first_target",
                 "methods")
LIFELONG_SERIES = {
    "library_size": Integer(0),
    "options_offered": Integer(0),
    "options_used": Integer(0),
    "rollout_success_rate": Real(0.0, 1.0),
}
"""Per lifelong method, one value per task of the stream (from its trial records)."""


def load_result(
    path: Path, cfg: ExperimentConfig, seed: int, stream_index: int, stream: Stream
) -> dict[str, Any]:
    """A job's saved ``result.json``, every field checked against the job and its
    configuration, and against the job's checkpoints when they are there.

    Raises
    ------
    ValueError
        Naming the file and the field: unreadable, modified (digest), of another schema,
        configuration or job, a curve of the wrong length or a reward outside the
        environment's range, or disagreeing with a method's last checkpoint.
    """
    hint = "delete it to run this job again"
    try:
        result = load_json_record(path, RESULT_SCHEMA)
        check_keys(str(path), result, RESULT_FIELDS)
    except ValueError as exc:
        raise ValueError(f"{exc}; {hint}") from exc
    diffs = json_differences(result["config"], cfg.results_record(), "config")
    if diffs:
        raise ValueError(f"{path}: comes from another configuration ({'; '.join(diffs)}); {hint}")
    tasks = [t.name for t in stream.tasks]
    job = {"seed": seed, "stream": stream.name, "stream_index": stream_index, "tasks": tasks,
           "first_target": stream.first_target}
    for key, value in job.items():
        if result[key] != value:
            raise ValueError(f"{path}: {key} is {result[key]!r}, expected {value!r}; {hint}")
    methods = result["methods"]
    if not isinstance(methods, dict) or set(methods) != set(cfg.methods):
        shown = sorted(methods) if isinstance(methods, dict) else methods
        raise ValueError(
            f"{path}: methods {shown} are not the configuration's {sorted(cfg.methods)}; {hint}"
        )
    low, high = cfg.reward_range
    curve = ListOf(Real(low, high), cfg.lifelong.train_episodes, cfg.lifelong.train_episodes)
    series = {name: ListOf(c, len(tasks), len(tasks)) for name, c in LIFELONG_SERIES.items()}
    targets = [str(t) for t in range(stream.first_target, len(tasks))]
    try:
        for method, values in methods.items():
            field = f"{path}: methods.{method}"
            if not isinstance(values, dict):
                raise ValueError(f"{field} must be an object")
            lifelong = isinstance(METHODS.get(method), LifelongMethod)
            check_keys(field, values, ("curves", *series) if lifelong else ("curves",))
            if not isinstance(values["curves"], dict) or sorted(values["curves"]) != targets:
                raise ValueError(f"{field}.curves must have the targets {targets} as keys")
            check_fields(f"{field}.curves", values["curves"], dict.fromkeys(targets, curve),
                         dict.get)
            if lifelong:
                check_fields(field, values, series, dict.get)
                checkpoints = RunFolder(path.parents[2]).checkpoints(seed, stream_index, method)
                _check_against_checkpoint(checkpoints, values, stream, field)
    except ValueError as exc:
        raise ValueError(f"{exc}; {hint}") from exc
    return result


def _check_against_checkpoint(
    directory: Path, values: dict[str, Any], stream: Stream, field: str
) -> None:
    """A lifelong method's result equals what its last checkpoint records (if kept)."""
    if not (directory / "LATEST").exists():
        return  # the checkpoints may be deleted once a job is done
    _, _, records = read_state(latest_checkpoint(directory))
    if len(records) != len(stream.tasks):
        raise ValueError(
            f"{field}: the job is done, but {directory} holds a checkpoint of "
            f"{len(records)} of its {len(stream.tasks)} trials"
        )
    mine = lifelong_entry(records, range(stream.first_target, len(stream.tasks)))
    diffs = json_differences(values, mine, field.split(": ")[-1])
    if diffs:
        raise ValueError(
            f"{field} disagrees with the checkpoint in {directory} ({diffs[0]} in the result, "
            "in the checkpoint)"
        )


def run_experiment(
    cfg: ExperimentConfig, out_dir: str | os.PathLike[str], progress: bool = True
) -> list[dict[str, Any]]:
    """Run (or resume) every job of ``cfg`` into ``out_dir``; return the job results.

    Raises
    ------
    FolderInUseError
        If another run is writing into ``out_dir``.
    ValueError
        If ``out_dir`` is not a folder that can be written, holds a run of another
        configuration, or a file of it is damaged; a task's environment cannot be made.
    """
    out = check_out_dir(out_dir)
    # Build every distinct task's environment once, so that a mistyped team fails now
    # rather than after hours of earlier trials.
    tasks = {repr(t): t for seed in cfg.seeds for s in cfg.streams(seed) for t in s.tasks}
    for task in tasks.values():
        env = make_env(cfg.env_id, task)
        cfg.lifelong.learner.tile_coder(env.observation_space)  # widths that fit, at most
        env.close()  # MAX_WEIGHTS tiles: refused before config.json is written
    # One run at a time writes into a folder: a second one gets a clear error rather than
    # mixing its configuration, checkpoints and results with the first one's.
    with locked_folder(out, "run folder"):
        remove_stale_temporaries(out)
        _write_or_check_config(cfg, RunFolder(out))
        jobs = [
            (cfg, seed, index, os.fspath(out))
            for seed in cfg.seeds
            for index in range(len(cfg.streams(seed)))
        ]
        executor = make_executor(cfg.executor, cfg.workers, progress)
        return executor.map(run_stream, jobs, desc=f"protocol {cfg.protocol}")


def check_out_dir(out_dir: str | os.PathLike[str]) -> Path:
    """The output folder, created if needed; a clear error if it cannot be one."""
    if not os.fspath(out_dir).strip():
        raise ValueError(f"the output folder must be a path, got {os.fspath(out_dir)!r}")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ValueError(f"{out}: exists and is not a folder; choose another output folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"{out}: cannot create the output folder ({exc.strerror})") from exc
    if not os.access(out, os.W_OK | os.X_OK):
        raise ValueError(f"{out}: the output folder is not writable")
    return out


def read_config(path: Path) -> ExperimentConfig:
    """A run folder's ``config.json`` (errors name the file)."""
    values = read_json(path)
    try:
        return ExperimentConfig.from_dict(values)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from exc


def _write_or_check_config(cfg: ExperimentConfig, folder: RunFolder) -> None:
    """Write ``config.json``, or refuse a folder whose ``config.json`` differs (naming the
    fields); the caller holds the folder's lock, so no other run is between the two."""
    config_file = folder.config
    if not config_file.exists():
        atomic_write_bytes(config_file, cfg.to_json().encode())
        return
    saved = read_config(config_file)
    diffs = json_differences(saved.results_record(), cfg.results_record())
    if diffs:
        raise ValueError(
            f"{folder.root} holds a run with a different configuration ({'; '.join(diffs)}); "
            "choose another output folder or delete it"
        )
