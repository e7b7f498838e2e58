"""The jobs of the reference command: what each computes, its key, the check of its result.

A job is one setting, one team (or the self-play run, or the transfer row's target) and
one training seed. Its key (:func:`job_key`) holds everything its result depends on:
the setting whole (``dataclasses.asdict``), the teams and their code, the seed and the
evaluation; :mod:`ilpss.experiments.kept_jobs` keeps its result under it, so that a
rerun computes only what is left and a changed setting is a new job.

Training imports torch: :func:`run_job` imports the learners when it runs, so that this
module (and the command's parser) loads without torch.
"""

from __future__ import annotations

import functools
from dataclasses import asdict, dataclass
from typing import Any

from ilpss.experiments.drill_facts import EPISODE_REWARD, PARALLEL_VEC_ENV, TEAM_CODE, drill_object
from ilpss.experiments.holder_learning import EVAL_SEED
from ilpss.reference.settings import (
    EvalSettings,
    HolderSetting,
    MultiAgentSetting,
    SelfPlaySetting,
    TransferSetting,
)
from soccer_drill.constraints import is_real

__all__: list[str] = []

KIND = "reference"
"""The kind of the kept files (``reference-<digest>.json``)."""
"""The batched parallel drill, looked up by name (``ilpss`` imports no drill module
directly)."""
SELF_PLAY = "self_play"
"""The team name of the self-play run's own defenders in its result."""


@dataclass(frozen=True)
class Job:
    """One training seed of one setting.

    ``team`` is the opponent of a holder or shared-policy job, the target of the
    transfer row, ``None`` for self-play; ``teams`` the teams the self-play attackers are
    evaluated against, or the transfer row's sources in order.
    """

    name: str
    setting: HolderSetting | MultiAgentSetting | SelfPlaySetting | TransferSetting
    seed: int
    team: str | None
    teams: tuple[str, ...]
    evaluation: EvalSettings


@functools.cache
def _team_code(team: str) -> dict[str, str]:
    return drill_object(TEAM_CODE)(team)


def job_key(job: Job) -> dict[str, Any]:
    """What the job's result depends on: its kept file's key."""
    teams = [job.team] if job.team else []
    teams += list(job.teams)
    return {"name": job.name, "setting_type": type(job.setting).__name__,
            "setting": asdict(job.setting), "seed": job.seed, "team": job.team,
            "teams": list(job.teams), "team_code": {t: dict(_team_code(t)) for t in teams},
            "evaluation": asdict(job.evaluation), "eval_seed": EVAL_SEED}


def _parallel(n: int, opponent: str | None, shared: bool | None = None) -> Any:
    return drill_object(PARALLEL_VEC_ENV)(n, opponent=opponent, shared_spaces=shared)


def run_job(job: Job) -> dict[str, Any]:
    """Train, then evaluate the greedy policy on the held-out episode seeds."""
    import torch

    n = job.evaluation.episodes
    s = job.setting
    if isinstance(s, HolderSetting):
        from ilpss.reference import holder
        model, venv, curve = holder.train(job.team, s, job.seed)
        return {"curve": curve, "eval": {job.team: holder.evaluate(model, venv, job.team, n,
                                                                    EVAL_SEED)}}
    if isinstance(s, TransferSetting):
        from ilpss.reference import holder
        return holder.transfer(job.teams, job.team, s, job.seed, n, EVAL_SEED)
    from ilpss.reference import masked_ppo
    torch.set_num_threads(1)
    if isinstance(s, MultiAgentSetting):
        agent, curve = masked_ppo.train(_parallel(s.ppo.n_envs, job.team), s.ppo, job.seed)
        return {"curve": curve,
                "eval": {job.team: masked_ppo.evaluate(agent, _parallel(n, job.team), EVAL_SEED)}}
    agent, curve = masked_ppo.train(_parallel(s.ppo.n_envs, None), s.ppo, job.seed)
    evals = {t: masked_ppo.evaluate(agent, _parallel(n, t, True), EVAL_SEED) for t in job.teams}
    evals[SELF_PLAY] = masked_ppo.evaluate(agent, _parallel(n, None), EVAL_SEED)
    return {"curve": curve, "eval": evals}


# ---------------------------------------------------------------------------- checks
def _rewards(where: str, value: Any, n: int) -> None:
    low, high = EPISODE_REWARD
    if not isinstance(value, list) or len(value) != n:
        raise ValueError(f"{where} must be a list of {n} episode rewards, got "
                         f"{type(value).__name__} of length {len(value) if isinstance(value, list) else '-'}")
    if not all(is_real(r) and low - 10 <= r <= high for r in value):
        raise ValueError(f"{where} holds a value that is not an episode reward")


def _curve(where: str, rows: Any) -> None:
    if not isinstance(rows, list) or not rows:
        raise ValueError(f"{where} must be a non-empty list of rows")
    for row in rows:
        if not (isinstance(row, list) and len(row) == 5
                and all(is_real(x) for x in row[:2] + row[4:])
                and all(x is None or is_real(x) for x in row[2:4])
                and row[0] >= 0 and row[1] >= 0 and row[4] >= 0
                and (row[3] is None or 0 <= row[3] <= 1)):
            raise ValueError(f"{where}: a row must be [steps, seconds, mean reward, success "
                             f"rate, episodes], got {row!r}")


def check_result(where: str, key: dict[str, Any], result: Any) -> None:
    """A kept result is what the key's job returns: its curves and evaluations, each as
    long as the key says, every reward one the drill (or the setting's reward option)
    can pay. Raises ``ValueError`` naming ``where``."""
    if not isinstance(result, dict):
        raise ValueError(f"{where} must be an object, got {type(result).__name__}")
    n = key["evaluation"]["episodes"]
    if key["setting_type"] == "TransferSetting":
        for arm in ("fine_tuned", "anew"):
            if not isinstance(result.get(arm), dict):
                raise ValueError(f"{where}.{arm} is missing")
            _rewards(f"{where}.{arm}.curve", result[arm].get("curve"),
                     key["setting"]["target_episodes"])
            _rewards(f"{where}.{arm}.eval", result[arm].get("eval"), n)
        return
    _curve(f"{where}.curve", result.get("curve"))
    evals = result.get("eval")
    wanted = ([key["team"]] if key["team"] else [*key["teams"], SELF_PLAY])
    if not isinstance(evals, dict) or sorted(evals) != sorted(wanted):
        raise ValueError(f"{where}.eval must hold the evaluations against {wanted}")
    for team in wanted:
        _rewards(f"{where}.eval.{team}", evals[team], n)
