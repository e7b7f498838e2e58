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

import json
import os
from dataclasses import replace
from pathlib import Path
from typing import Any

import gymnasium as gym

from ilpss._io import atomic_write_bytes
from ilpss.experiments.config import ExperimentConfig, Stream, Task
from ilpss.experiments.executor import make_executor
from ilpss.lifelong import LifelongConfig, LifelongLearner, trial_seeds

RESULT_SCHEMA = "ilpss.experiment_result/1"


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
    """One lifelong method over the whole stream, resuming from its checkpoint."""
    env0 = make_env(cfg.env_id, stream.tasks[0])
    if (directory / "LATEST").exists():
        learner = LifelongLearner.load(directory, env0.observation_space)
    else:
        learner = LifelongLearner(
            method_config(cfg.lifelong, method), env0.observation_space,
            int(env0.action_space.n), seed,
        )
    for t in range(learner.n_trials, len(stream.tasks)):
        task = stream.tasks[t]
        learner.run_trial(make_env(cfg.env_id, task), task.name)
        learner.save(directory)
    return learner


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
        return json.loads(done.read_text())
    directory.mkdir(parents=True, exist_ok=True)
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
        "seed": seed,
        "stream": stream.name,
        "stream_index": stream_index,
        "tasks": [t.name for t in stream.tasks],
        "first_target": stream.first_target,
        "methods": methods,
    }
    atomic_write_bytes(done, json.dumps(result).encode())
    return result


def run_experiment(
    cfg: ExperimentConfig, out_dir: str | os.PathLike[str], progress: bool = True
) -> list[dict[str, Any]]:
    """Run (or resume) every job of ``cfg`` into ``out_dir``; return the job results."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    config_file = out / "config.json"
    if config_file.exists():
        saved = ExperimentConfig.from_dict(json.loads(config_file.read_text()))
        # Where the seeds run does not change the results.
        if replace(saved, executor=cfg.executor, workers=cfg.workers) != cfg:
            raise ValueError(
                f"{out} holds a run with a different configuration; "
                "choose another output folder or delete it"
            )
    else:
        atomic_write_bytes(config_file, cfg.to_json().encode())
    jobs = [
        (cfg, seed, index, os.fspath(out))
        for seed in cfg.seeds
        for index in range(len(cfg.streams(seed)))
    ]
    executor = make_executor(cfg.executor, cfg.workers, progress)
    return executor.map(run_stream, jobs, desc=f"protocol {cfg.protocol}")
