"""Run an experiment: every seed and stream, every method, checkpointed and resumable.

Read top to bottom: :func:`run_stream` is one job: each method of the configuration
runs on the stream (:mod:`ilpss.experiments.methods`; a lifelong method checkpoints
after every trial into the run's checkpoint storage, :mod:`ilpss.experiments.checkpoints`,
and PRQ-learning reuses the policies learnt anew), and the job returns its result.
:func:`run_experiment` writes the configuration, runs the jobs that have no
``result.json`` yet through an executor (local processes or Ray tasks, on any node), and
writes each job's ``result.json`` as its result arrives: a job never writes into the run
folder itself. A job whose ``result.json`` exists is not run again (it is read,
checked), and a job that was interrupted resumes from its last checkpoints, so a resumed
experiment ends identical to an uninterrupted one. The folder's layout is
:class:`RunFolder`'s.
"""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym

from ilpss._io import (
    atomic_write_bytes,
    json_differences,
    json_record_bytes,
    load_json_record,
    locked_folder,
    read_json,
    remove_stale_temporaries,
)
from ilpss.experiments.checkpoints import (
    CheckpointStore,
    LocalStore,
    checkpoint_store,
    is_uri,
    open_store,
    stream_records,
)
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.drill_facts import TEAM_CODE, TEAM_ERROR, drill_exception, drill_object
from ilpss.experiments.executor import (
    SETTINGS_ERRORS,
    JobsFailed,
    check_ray_address,
    make_executor,
)
from ilpss.experiments.folder import RunFolder, checkpoint_key
from ilpss.experiments.methods import (
    METHODS,
    CheckpointRefused,
    Job,
    LifelongMethod,
    lifelong_entry,
)
from ilpss.experiments.outputs import check_out_dir
from ilpss.experiments.protocols import Stream, make_env
from ilpss.experiments.provenance import check_code_field, check_same_code, code_record
from soccer_drill.constraints import ListOf, Real, check_fields, check_keys

__all__ = [
    "JobDone",
    "JobSpec",
    "load_result",
    "run_experiment",
]

RESULT_SCHEMA = "ilpss.experiment_result/3"


@dataclass(frozen=True)
class JobSpec:
    """What a job needs, wherever it runs: nothing of the run folder but its storage."""

    cfg: ExperimentConfig
    seed: int
    stream_index: int
    storage: str
    """The checkpoint storage: a path (absolute) or a URI."""
    token: str | None = None
    """The run's claim on the storage (``None``: the run folder, unclaimed)."""


@dataclass(frozen=True)
class JobDone:
    """What a job sends back to the driver."""

    result: dict[str, Any]
    """Its ``result.json``, which the driver writes."""
    resumed: dict[str, int] = field(default_factory=dict)
    """Per lifelong method, the trials that were found done in its checkpoints."""


def run_order(methods: Sequence[str]) -> list[str]:
    """The order in which a job runs ``methods``, and so the order of its result: methods
    that reuse other methods' learners run after them."""
    return sorted(methods, key=lambda m: bool(METHODS.get(m).reuses))


def run_stream(spec: JobSpec) -> JobDone:
    """One (seed, stream) job: every method on the stream; returns its result."""
    cfg, seed, stream_index = spec.cfg, spec.seed, spec.stream_index
    stream = cfg.streams(seed)[stream_index]
    store = open_store(spec.storage)
    try:
        if spec.token is not None:
            store.check(spec.token)
        context = Job(cfg, seed, stream_index, stream, store, spec.token)
        methods = {name: METHODS.get(name).run(context) for name in run_order(cfg.methods)}
    finally:
        store.close()
    # Checked as a resume will read it: an entry its method does not declare fails this
    # job now, not the run's resume later.
    for name, values in methods.items():
        check_entry(name, values, cfg, stream, f"methods.{name}")
    result = {
        "schema": RESULT_SCHEMA,
        "config": cfg.results_record(),
        "seed": seed,
        "stream": stream.name,
        "stream_index": stream_index,
        "tasks": [t.name for t in stream.tasks],
        "first_target": stream.first_target,
        "methods": methods,
        "code": code_record(),  # the code that ran the job, wherever it ran
    }
    return JobDone(result, dict(context.resumed))


RESULT_FIELDS = ("schema", "config", "seed", "stream", "stream_index", "tasks", "first_target",
                 "methods", "code")


def load_result(
    path: Path, cfg: ExperimentConfig, seed: int, stream_index: int, stream: Stream,
    store: CheckpointStore | None = None, *, code: dict[str, Any] | None = None,
    allow_mixed_code: bool = False,
) -> dict[str, Any]:
    """A job's saved ``result.json``, every field checked against the job and its
    configuration, against the code ``code`` when given (a resume gives this process's:
    :func:`~ilpss.experiments.provenance.check_same_code`), and against the job's
    checkpoints (in ``store``, by default the run's checkpoint storage) when they are
    there.

    Raises
    ------
    ValueError
        Naming the file and the field: unreadable, modified (digest), of another schema,
        configuration, job or code, a curve of the wrong length or a reward outside the
        environment's range, or disagreeing with a method's last checkpoint.
    """
    hint = "delete it to run this job again"
    try:
        result = load_json_record(path, RESULT_SCHEMA)
        check_keys(str(path), result, RESULT_FIELDS)
        check_code_field(str(path), result["code"])
    except ValueError as exc:
        raise ValueError(f"{exc}; {hint}") from exc
    if code is not None:
        check_same_code(result["code"], str(path), allow=allow_mixed_code, current=code)
    diffs = json_differences(result["config"], cfg.results_record(), "config")
    if diffs:  # the result or the run's configuration changed: deleting the one may lose work
        raise ValueError(f"{path}: comes from another configuration than the run's "
                         f"({'; '.join(diffs)}, saved in the result against the run's); if "
                         "the run's config.json or its settings were changed since, put them "
                         f"back (the finished results were made with the saved ones), else "
                         f"{hint}")
    try:
        check_job_fields(result, stream, seed, stream_index, str(path))
    except ValueError as exc:
        raise ValueError(f"{exc}; {hint}") from exc
    methods = result["methods"]
    if not isinstance(methods, dict) or set(methods) != set(cfg.methods):
        shown = sorted(methods) if isinstance(methods, dict) else methods
        raise ValueError(
            f"{path}: methods {shown} are not the configuration's {sorted(cfg.methods)}; {hint}"
        )
    with contextlib.ExitStack() as stack:
        if store is None:
            store = checkpoint_store(cfg, path.parents[2])
            stack.callback(store.close)
        try:
            for method, values in methods.items():
                field = f"{path}: methods.{method}"
                check_entry(method, values, cfg, stream, field)
                if isinstance(METHODS.get(method), LifelongMethod):
                    _check_against_checkpoint(store, seed, stream_index, method, values,
                                              stream, field)
        except ValueError as exc:
            raise ValueError(f"{exc}; {hint}") from exc
    return result


def check_job_fields(record: dict[str, Any], stream: Stream, seed: int, stream_index: int,
                     where: str) -> None:
    """The job ``record`` names (its seed, stream, tasks, first target) is job
    ``(seed, stream_index)`` of its configuration, whose stream is ``stream``; else
    ``ValueError`` naming ``where`` and the field."""
    job = {"seed": seed, "stream": stream.name, "stream_index": stream_index,
           "tasks": [t.name for t in stream.tasks], "first_target": stream.first_target}
    for key, value in job.items():
        if record[key] != value:
            raise ValueError(f"{where}: {key} is {record[key]!r:.200}, expected {value!r}")


def check_entry(method: str, values: Any, cfg: ExperimentConfig, stream: Stream,
                field: str) -> None:
    """A method's entry of a job's result, as the method declares it (``Method.series``):
    a learning curve per target of the stream, the budget's length, within the
    environment's reward range, and each declared series, one value per task. A job's
    result is checked so when the job returns it and when a resume reads it back."""
    if not isinstance(values, dict):
        raise ValueError(f"{field} must be an object")
    low, high = cfg.reward_range
    episodes = cfg.lifelong.train_episodes
    n = len(stream.tasks)
    targets = [str(t) for t in range(stream.first_target, n)]
    series = {name: ListOf(c, n, n) for name, c in METHODS.get(method).series.items()}
    check_keys(field, values, ("curves", *series))
    if not isinstance(values["curves"], dict) or sorted(values["curves"]) != sorted(targets):
        raise ValueError(f"{field}.curves must have the targets {targets} as keys")
    check_fields(f"{field}.curves", values["curves"],
                 dict.fromkeys(targets, ListOf(Real(low, high), episodes, episodes)), dict.get)
    check_fields(field, values, series, dict.get)


def _check_against_checkpoint(
    store: CheckpointStore, seed: int, stream_index: int, method: str,
    values: dict[str, Any], stream: Stream, field: str,
) -> None:
    """A lifelong method's result equals what its last checkpoints record (if kept)."""
    records = stream_records(store, seed, stream_index, method, stream)
    if records is None:
        return  # the checkpoints may be deleted once a job is done
    where = f"{store.location}/{checkpoint_key(seed, stream_index, method)}"
    if len(records) != len(stream.tasks):
        raise ValueError(
            f"{field}: the job is done, but {where} holds a checkpoint of "
            f"{len(records)} of its {len(stream.tasks)} trials"
        )
    mine = lifelong_entry(records, range(stream.first_target, len(stream.tasks)))
    diffs = json_differences(values, mine, field.split(": ")[-1])
    if diffs:
        raise ValueError(
            f"{field} disagrees with the checkpoint in {where} ({diffs[0]} in the result, "
            "in the checkpoint)"
        )


def run_experiment(
    cfg: ExperimentConfig, out_dir: str | os.PathLike[str], progress: bool = True, *,
    ray_address: str | None = None, on_done: Callable[[JobSpec, JobDone], None] | None = None,
    allow_mixed_code: bool = False,
) -> list[dict[str, Any]]:
    """Run (or resume) every job of ``cfg`` into ``out_dir``; return the job results.

    With the Ray executor, ``ray_address`` (else ``RAY_ADDRESS``) names a cluster to
    join; ``cfg.workers`` then bounds the jobs in flight. ``on_done`` is called here as
    each job's ``result.json`` is written. A run folder records the code that started
    it, and every result the code that made it: a resume with other code, or a job
    that ran other code (a cluster's node), is refused naming both
    (:class:`~ilpss.experiments.provenance.MixedCodeError`) unless ``allow_mixed_code``.

    Raises
    ------
    FolderInUseError
        If another run is writing into ``out_dir`` or into its checkpoint storage path.
    StorageError
        If a job's node cannot reach the checkpoint storage, or another run claimed it.
    ValueError
        If ``out_dir`` is not a folder that can be written, holds a run of another
        configuration (or code), or a file of it is damaged; a task's environment cannot
        be made.
    """
    out = check_out_dir(out_dir)
    if cfg.executor == "ray":  # a wrong address fails now, not after config.json
        check_ray_address(ray_address)
    check_tasks(cfg)
    folder = RunFolder(out)
    jobs = [(seed, index, stream) for seed in cfg.seeds
            for index, stream in enumerate(cfg.streams(seed))]
    # One run at a time writes into a folder: a second one gets a clear error rather than
    # mixing its configuration, checkpoints and results with the first one's.
    with locked_folder(out, "run folder"), _storage(cfg, out) as (store, location):
        remove_stale_temporaries(out)
        _write_or_check_config(cfg, folder, allow_mixed_code)
        _write_or_check_team_code(team_codes(cfg), folder)
        results: dict[int, dict[str, Any]] = {}
        for i, (seed, index, stream) in enumerate(jobs):
            if folder.job(seed, index).is_dir():  # stale: this run holds the lock
                remove_stale_temporaries(folder.job(seed, index))
            if folder.result(seed, index).exists():
                results[i] = load_result(folder.result(seed, index), cfg, seed, index, stream,
                                         store, code=code_record(),
                                         allow_mixed_code=allow_mixed_code)
        todo = [i for i in range(len(jobs)) if i not in results]
        # A storage that is not this process's own run folder is claimed: a job that
        # cannot reach it, or finds another run's claim, stops with an error saying so.
        claim = cfg.executor == "ray" or location != os.fspath(out.resolve())
        token = store.claim(os.fspath(out.resolve())) if claim and todo else None
        specs = [JobSpec(cfg, jobs[i][0], jobs[i][1], location, token) for i in todo]

        def write(k: int, done: JobDone) -> None:
            seed, index, _ = jobs[todo[k]]
            check_same_code(done.result["code"], f"the job of seed {seed}, stream {index}",
                            allow=allow_mixed_code)
            folder.job(seed, index).mkdir(parents=True, exist_ok=True)
            atomic_write_bytes(folder.result(seed, index), json_record_bytes(done.result))
            results[todo[k]] = done.result
            if on_done is not None:
                on_done(specs[k], done)

        if specs:
            executor = make_executor(cfg.executor, cfg.workers, progress, ray_address)
            try:
                executor.map(run_stream, specs, desc=f"protocol {cfg.protocol}", done=write)
            except JobsFailed as exc:
                raise JobError(exc, [specs[k] for k in exc.failures], len(jobs),
                               len(results)) from exc
    return [results[i] for i in range(len(jobs))]


def check_tasks(cfg: ExperimentConfig) -> None:
    """Make every distinct task's environment of ``cfg`` once, so that a mistyped team or
    an environment that does not fit fails now rather than after hours of earlier trials
    (``ValueError`` naming the environment, the task and what failed)."""
    tasks = {repr(t): t for seed in cfg.seeds for s in cfg.streams(seed) for t in s.tasks}
    for task in tasks.values():
        made = f"ExperimentConfig.env_id {cfg.env_id!r}: the environment of task {task.name!r}"
        try:
            env = make_env(cfg.env_id, task)
        except (TypeError, gym.error.Error) as exc:  # e.g. it takes no ``opponent``
            raise ValueError(
                f"{made} cannot be made with the protocol's arguments {task.env_kwargs} "
                f"({type(exc).__name__}: {exc}); the experiments need an environment that "
                "takes them, as the drill's does"
            ) from exc
        try:
            if not isinstance(env.action_space, gym.spaces.Discrete):
                raise ValueError(f"{made} has the action space {env.action_space!r}; the "
                                 "learners need a Discrete one")
            # Widths that fit, at most MAX_WEIGHTS tiles: refused before config.json.
            cfg.lifelong.learner.tile_coder(env.observation_space)
        finally:
            env.close()


class JobError(RuntimeError):
    """Some jobs of a run failed; the others' results are written (a resume runs only
    the failed ones again). The message names each failed job and what it raised."""

    def __init__(self, failed: JobsFailed, specs: list[JobSpec], n_jobs: int,
                 n_done: int) -> None:
        self.failures = {(spec.seed, spec.stream_index): exc
                         for spec, exc in zip(specs, failed.failures.values(), strict=True)}
        lines = [f"seed {seed}, stream {index}: {type(exc).__name__}: {exc}"
                 for (seed, index), exc in self.failures.items()]
        if all(isinstance(exc, SETTINGS_ERRORS) for exc in self.failures.values()):
            # The same settings fail the same way again, and the run folder keeps them (a
            # resume with others is refused): only a new folder can take other settings.
            advice = ("they fail the same way with these settings, so running the same "
                      "command again does not help: change the setting named above, in a new "
                      "run folder (this one's config.json keeps these settings)")
        elif any(isinstance(exc, drill_exception(TEAM_ERROR))
                 for exc in self.failures.values()):
            # A team plays the same given its seeds, and the folder refuses a team whose code
            # changed (team_code.json): the rerun that would help is a fixed team elsewhere.
            advice = ("a team that failed fails the same way when run again (unless it "
                      "overran its time bound on a loaded machine), and this folder refuses "
                      "a team whose code changed since its jobs played it (team_code.json): "
                      "fix the team, then run the command with a new run folder")
        elif all(isinstance(exc, CheckpointRefused) for exc in self.failures.values()):
            # A kept checkpoint that cannot be resumed is refused the same way every time.
            advice = ("each names a kept checkpoint that cannot be resumed: do what its "
                      "message says (delete that folder), then run the same command again "
                      "to run only the failed one(s)")
        else:
            advice = "run the same command again to run only the failed one(s)"
        super().__init__(
            f"{len(specs)} of {n_jobs} job(s) failed:\n  " + "\n  ".join(lines) +
            f"\nThe {n_done} finished job(s) are kept; {advice}"
        )



@contextlib.contextmanager
def _storage(cfg: ExperimentConfig, out: Path) -> Iterator[tuple[CheckpointStore, str]]:
    """The run's checkpoint storage and its location as jobs get it (an absolute path or
    a URI); a path other than the run folder is held locked, as the run folder is."""
    location = os.fspath(out.resolve()) if cfg.storage is None else cfg.storage
    if not is_uri(location):
        location = os.path.abspath(location)
        if Path(location).resolve() == out.resolve():
            location = os.fspath(out.resolve())
    store = open_store(location)
    try:
        if isinstance(store, LocalStore) and location != os.fspath(out.resolve()):
            if (store.root / "config.json").is_file():  # checkpoints and owner.json there
                raise ValueError(f"{location}: another run's folder (it holds config.json) "
                                 "given as this run's checkpoint storage; give a folder of "
                                 "its own, or leave --storage out (the run folder)")
            try:
                store.root.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise ValueError(f"{location}: cannot create the checkpoint storage "
                                 f"({exc.strerror})") from exc
            with locked_folder(store.root, "checkpoint storage"):
                yield store, location
        else:
            yield store, location
    finally:
        store.close()


def read_config(path: Path) -> ExperimentConfig:
    """A run folder's ``config.json`` (errors name the file); the code it records, if
    any, is :func:`read_run_code`'s."""
    values = read_json(path)
    if isinstance(values, dict):
        values = {k: v for k, v in values.items() if k != "code"}
    try:
        return ExperimentConfig.from_dict(values)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from exc


TEAM_CODE_SCHEMA = "ilpss.team_code/1"


def team_codes(cfg: ExperimentConfig) -> dict[str, dict[str, str]]:
    """The code of every drill team ``cfg``'s tasks play
    (:data:`~ilpss.experiments.drill_facts.TEAM_CODE`), by team id; none for another environment."""
    if cfg.drill is None:  # not a scenario of the drill (with or without its package)
        return {}
    code_of = drill_object(TEAM_CODE)
    teams = {t.env_kwargs.get("opponent") for seed in cfg.seeds for s in cfg.streams(seed)
             for t in s.tasks}
    return {team: code_of(team) for team in sorted(t for t in teams if isinstance(t, str))}


def _write_or_check_team_code(codes: dict[str, dict[str, str]], folder: RunFolder) -> None:
    """Record the teams' code (``team_code.json``), or refuse to go on with a team whose
    code changed since the run started: its finished jobs played the old code. A folder
    of a run started before this record gets it now."""
    path = folder.team_code
    if not path.exists():
        atomic_write_bytes(path, json_record_bytes({"schema": TEAM_CODE_SCHEMA, "teams": codes}))
        return
    saved = load_json_record(path, TEAM_CODE_SCHEMA).get("teams")
    if not isinstance(saved, dict):
        raise ValueError(f"{path}: 'teams' must be an object of team id to its code")
    changed = [f"{team} ({'; '.join(json_differences(saved[team], code))})"
               for team, code in codes.items() if team in saved and saved[team] != code]
    if changed:
        raise ValueError(
            f"{folder.root}: the code of {', '.join(changed)} changed since this run started; "
            "its finished jobs played the old code, so the run cannot go on with the new one: "
            "choose another output folder, or put the old code back"
        )


def read_run_code(path: Path) -> dict[str, Any] | None:
    """The code that started the run whose ``config.json`` is ``path`` (``None``: a run
    started before runs recorded it)."""
    values = read_json(path)
    if not isinstance(values, dict) or "code" not in values:
        return None
    return check_code_field(str(path), values["code"])


def _write_or_check_config(cfg: ExperimentConfig, folder: RunFolder,
                           allow_mixed_code: bool = False) -> None:
    """Write ``config.json`` with the code that starts the run, or refuse a folder whose
    ``config.json`` differs (naming the fields) or was written by other code (naming both,
    unless ``allow_mixed_code``); the caller holds the folder's lock, so no other run is
    between the two."""
    config_file = folder.config
    if not config_file.exists():
        record = {**cfg.to_dict(), "code": code_record()}
        atomic_write_bytes(config_file, json.dumps(record, indent=2, sort_keys=True).encode())
        return
    saved = read_config(config_file)
    diffs = json_differences(saved.results_record(), cfg.results_record())
    if diffs:
        raise ValueError(
            f"{folder.root} holds a run with a different configuration ({'; '.join(diffs)}); "
            "choose another output folder or delete it"
        )
    check_same_code(read_run_code(config_file), f"the run in {folder.root}",
                    allow=allow_mixed_code)
