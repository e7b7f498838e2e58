"""Run an experiment: every seed and stream, every method, checkpointed and resumable.

Read top to bottom: :func:`run_experiment` writes the configuration, runs one job
per (seed, stream) through an executor, and gathers the learning curves;
:func:`run_stream` is one job: each method meets the stream's task instances in
order, with a checkpoint after every trial, then PRQ-learning reuses the policies
learnt anew. A job whose ``result.json`` exists is not run again, and a job that was
interrupted resumes from its last checkpoints, so a resumed experiment ends
identical to an uninterrupted one.
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path
from typing import Any

import gymnasium as gym

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
from ilpss.experiments.config import ExperimentConfig, Stream, Task
from ilpss.experiments.executor import make_executor
from ilpss.lifelong import (
    LifelongConfig,
    LifelongLearner,
    latest_checkpoint,
    read_state,
    trial_seeds,
)

RESULT_SCHEMA = "ilpss.experiment_result/2"


def make_env(env_id: str, task: Task) -> gym.Env:
    """The task's environment (Gymnasium's env checker off: it only slows learning)."""
    return gym.make(env_id, disable_env_checker=True, **task.env_kwargs)


def method_config(base: LifelongConfig, method: str) -> LifelongConfig:
    """The lifelong configuration of each lifelong method."""
    variants = {
        "ilpss": {},
        "scratch": {"options": "none"},
        "whole_policies": {"options": "whole_policies"},
        "ilpss_no_discount": {"discount": 1.0},
    }
    return replace(base, **variants[method])


def run_lifelong(
    cfg: ExperimentConfig, method: str, stream: Stream, seed: int, directory: Path
) -> LifelongLearner:
    """One lifelong method over the whole stream, resuming from its checkpoint (which
    must come from this very job: a checkpoint of another configuration is refused)."""
    env0 = make_env(cfg.env_id, stream.tasks[0])
    provenance = {"experiment": cfg.results_record(), "method": method, "seed": seed,
                  "stream": stream.name, "tasks": [t.name for t in stream.tasks]}
    if (directory / "LATEST").exists():
        learner = LifelongLearner.load(directory, env0.observation_space)
        _check_resumable(learner, provenance, directory, cfg.reward_range)
    else:
        learner = LifelongLearner(
            method_config(cfg.lifelong, method), env0.observation_space,
            int(env0.action_space.n), seed, provenance=provenance,
        )
    for t in range(learner.n_trials, len(stream.tasks)):
        task = stream.tasks[t]
        learner.run_trial(make_env(cfg.env_id, task), task.name)
        learner.save(directory)
    return learner


def _check_resumable(
    learner: LifelongLearner, provenance: dict, directory: Path,
    reward_range: tuple[float, float],
) -> None:
    """Refuse a checkpoint that another configuration or job wrote, naming the field, or
    whose rewards the environment cannot have paid."""
    hint = "delete that folder to run this method of the job again"
    if learner.provenance is None:
        raise ValueError(f"{directory}: the checkpoint records no provenance; {hint}")
    diffs = json_differences(learner.provenance, provenance)
    if diffs:
        raise ValueError(
            f"{directory}: the checkpoint comes from another run ({'; '.join(diffs)}); {hint}"
        )
    low, high = reward_range
    for i, record in enumerate(learner.records):
        if not all(low <= r <= high for r in record.rewards):
            raise ValueError(
                f"{directory}: records[{i}].rewards lie outside the environment's range "
                f"[{low:g}, {high:g}]; {hint}"
            )


def run_prq(cfg: ExperimentConfig, stream: Stream, seed: int, scratch: LifelongLearner) -> dict:
    """PRQ-learning on every target, reusing the policies learnt anew on earlier tasks."""
    from ilpss.baselines import PrqLearner

    curves = {}
    for t in range(stream.first_target, len(stream.tasks)):
        learner_seed, env_seed, _, _ = trial_seeds(seed, t)
        lc = cfg.lifelong.learner
        prq = PrqLearner(
            scratch.n_primitive, scratch.tile_coder, scratch.policies[:t],
            alpha=lc.alpha, epsilon=lc.epsilon, gamma=lc.gamma,
            initial_value=lc.initial_value, psi=cfg.prq_psi, upsilon=cfg.prq_upsilon,
            delta_tau=cfg.prq_delta_tau, seed=learner_seed,
        )
        env = make_env(cfg.env_id, stream.tasks[t])
        results = prq.train(env, cfg.lifelong.train_episodes, seed=env_seed)
        curves[str(t)] = [float(r.total_reward) for r in results]
    return {"curves": curves}


def run_stream(job: tuple[ExperimentConfig, int, int, str]) -> dict[str, Any]:
    """One (seed, stream) job; returns (and saves) its learning curves."""
    cfg, seed, stream_index, out_dir = job
    stream = cfg.streams(seed)[stream_index]
    directory = Path(out_dir) / f"seed_{seed:03d}" / f"stream_{stream_index:02d}"
    done = directory / "result.json"
    if done.exists():
        return load_result(done, cfg, seed, stream_index, stream)
    directory.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(directory)  # the run holds the folder's lock: they are stale
    methods: dict[str, Any] = {}
    learners = {}
    for method in cfg.methods:
        if method == "prq":
            continue
        learner = learners[method] = run_lifelong(cfg, method, stream, seed, directory / method)
        methods[method] = {
            "curves": {
                str(t): list(r.rewards)
                for t, r in enumerate(learner.records) if t >= stream.first_target
            },
            "library_size": [r.library_size for r in learner.records],
            "options_offered": [r.options_offered for r in learner.records],
            "options_used": [len(r.options_used) for r in learner.records],
            "rollout_success_rate": [r.rollout_success_rate for r in learner.records],
        }
    if "prq" in cfg.methods:
        methods["prq"] = run_prq(cfg, stream, seed, learners["scratch"])
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
            check_keys(field, values, ("curves",) if method == "prq" else ("curves", *series))
            if not isinstance(values["curves"], dict) or sorted(values["curves"]) != targets:
                raise ValueError(f"{field}.curves must have the targets {targets} as keys")
            check_fields(f"{field}.curves", values["curves"], dict.fromkeys(targets, curve),
                         dict.get)
            if method != "prq":
                check_fields(field, values, series, dict.get)
                _check_against_checkpoint(path.parent / method, values, stream, field)
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
    mine = {
        "curves": {str(t): list(r.rewards) for t, r in enumerate(records)
                   if t >= stream.first_target},
        "library_size": [r.library_size for r in records],
        "options_offered": [r.options_offered for r in records],
        "options_used": [len(r.options_used) for r in records],
        "rollout_success_rate": [r.rollout_success_rate for r in records],
    }
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
        _write_or_check_config(cfg, out)
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


def _write_or_check_config(cfg: ExperimentConfig, out: Path) -> None:
    """Write ``config.json``, or refuse a folder whose ``config.json`` differs (naming the
    fields); the caller holds the folder's lock, so no other run is between the two."""
    config_file = out / "config.json"
    if not config_file.exists():
        atomic_write_bytes(config_file, cfg.to_json().encode())
        return
    saved = read_config(config_file)
    diffs = json_differences(saved.results_record(), cfg.results_record())
    if diffs:
        raise ValueError(
            f"{out} holds a run with a different configuration ({'; '.join(diffs)}); "
            "choose another output folder or delete it"
        )
