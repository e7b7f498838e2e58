"""The jobs of the reference command: what each computes, its key, the check of its result.

A job is one setting, one team (or the defenders' or self-play run, or the transfer
row's target) and one training seed. Its key (:func:`job_key`) holds everything its
result depends on: the setting whole (``dataclasses.asdict``), the teams and attacks and
their code, the seed, the evaluation and the versions of the learners' libraries (torch,
Stable-Baselines3, sb3-contrib: :func:`library_versions`); :mod:`ilpss.experiments.kept_jobs`
keeps its result under it, so that a rerun computes only what is left and a changed
setting, or an upgraded library, is a new job.

:func:`check_result` refuses a kept result that its job cannot have returned: a field
that is not the job's, a reward the drill cannot pay, a curve whose steps go backwards
or whose rates contradict its rewards. Training imports torch: :func:`run_job` imports
the learners when it runs, so that this module (and the command's parser) loads without
torch.
"""

from __future__ import annotations

import functools
import importlib.metadata
import math
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ilpss.experiments.drill_facts import (
    ATTACK_CODE,
    FAILURE_REWARD,
    PARALLEL_VEC_ENV,
    SUCCESS_REWARDS,
    TEAM_CODE,
    drill_object,
)
from ilpss.experiments.holder_learning import EVAL_SEED
from ilpss.reference.settings import (
    EvalSettings,
    HolderSetting,
    MarlSetting,
    SelfPlaySetting,
    TransferSetting,
)
from soccer_drill.constraints import Integer, ListOf, check, is_real

__all__: list[str] = []

KIND = "reference"
"""The kind of the kept files (``reference-<digest>.json``)."""
SELF_PLAY = "self_play"
"""The name of the self-play run's own defenders (its attackers' opponent) in its result."""
LIBRARIES = ("torch", "stable-baselines3", "sb3-contrib")
"""The learners' libraries, whose versions are part of every job's key."""


@dataclass(frozen=True)
class Job:
    """One training seed of one setting.

    ``team`` is the opponent of a holder or attackers' job, the target of the transfer
    row, ``None`` for the defenders and self-play; ``teams`` the teams the self-play
    attackers are evaluated against, or the transfer row's sources in order; ``attacks``
    the scripted attacks the learnt defenders are evaluated against.
    """

    name: str
    setting: HolderSetting | MarlSetting | SelfPlaySetting | TransferSetting
    seed: int
    team: str | None
    teams: tuple[str, ...]
    evaluation: EvalSettings
    attacks: tuple[str, ...] = ()

    @property
    def label(self) -> str:
        """The job as progress lines name it."""
        return f"{self.name} {self.team or '-'} seed {self.seed}"


def library_versions() -> dict[str, str]:
    """``{distribution: version}`` of :data:`LIBRARIES` (``"absent"`` where one is not
    installed), read without importing them."""
    out = {}
    for name in LIBRARIES:
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = "absent"
    return out


@functools.cache
def _team_code(team: str) -> dict[str, str]:
    return drill_object(TEAM_CODE)(team)


@functools.cache
def _attack_code(attack: str) -> dict[str, str]:
    return drill_object(ATTACK_CODE)(attack)


def job_key(job: Job) -> dict[str, Any]:
    """What the job's result depends on: its kept file's key."""
    teams = [job.team] if job.team else []
    teams += list(job.teams)
    attacks = list(job.attacks)
    if isinstance(job.setting, MarlSetting) and job.setting.side == "defenders":
        attacks = list(dict.fromkeys([job.setting.attack, *attacks]))
    return {"name": job.name, "setting_type": type(job.setting).__name__,
            "setting": asdict(job.setting), "seed": job.seed, "team": job.team,
            "teams": list(job.teams), "attacks": list(job.attacks),
            "team_code": {t: dict(_team_code(t)) for t in teams},
            "attack_code": {a: dict(_attack_code(a)) for a in attacks},
            "evaluation": asdict(job.evaluation), "eval_seed": EVAL_SEED,
            "libraries": library_versions()}


# ---------------------------------------------------------------------------- running
def _progress(job: Job, total: int) -> Callable[[int, int], None]:
    """A progress line on stderr at every tenth of the job's budget, with the time it
    took so far and an estimate of what is left (at the rate so far)."""
    start, shown = time.perf_counter(), [0]

    def report(done: int, budget: int) -> None:
        tenth = done * 10 // max(budget, 1)
        if tenth <= shown[0] or done <= 0:
            return
        shown[0] = tenth
        took = time.perf_counter() - start
        left = took * max(budget - done, 0) / done  # whole rollouts may pass the budget
        print(f"  {job.label}: {min(done, budget):,} of {budget:,} steps in {took / 60:.1f} "
              f"min, about {left / 60:.1f} min of training left", file=sys.stderr, flush=True)

    return report


def _parallel(n: int, obs_type: str, opponent: str | None = None, attack: str | None = None
              ) -> Any:
    return drill_object(PARALLEL_VEC_ENV)(n, opponent=opponent, attack=attack,
                                          obs_type=obs_type, shared_spaces=False)


def _evaluate(s: MarlSetting) -> Callable[..., list[float]]:
    """``marl_ppo.evaluate`` at the pace the setting's players learnt."""
    from ilpss.reference import marl_ppo
    return functools.partial(marl_ppo.evaluate, decision_cycles=s.decision_cycles)


def _run_marl(job: Job, s: MarlSetting) -> dict[str, Any]:
    from ilpss.reference import marl_ppo
    n, o, evaluate = job.evaluation.episodes, s.obs_type, _evaluate(s)
    if s.side == "attackers":
        env = _parallel(s.ppo.n_envs, o, opponent=job.team)
        side, curve = marl_ppo.train(env, s, job.seed, _progress(job, s.ppo.steps))
        evaluation = _parallel(n, o, opponent=job.team)
        return {"curve": curve,
                "eval": {job.team: evaluate([side], evaluation, EVAL_SEED)},
                "stochastic": {job.team: evaluate([side], evaluation, EVAL_SEED, greedy=False,
                                                  sample_seed=job.seed)}}
    side, curve = marl_ppo.train(_parallel(s.ppo.n_envs, o, attack=s.attack), s, job.seed,
                                 _progress(job, s.ppo.steps))
    greedy, sampled = {}, {}
    for attack in job.attacks:
        evaluation = _parallel(n, o, attack=attack)
        greedy[attack] = evaluate([side], evaluation, EVAL_SEED)
        sampled[attack] = evaluate([side], evaluation, EVAL_SEED, greedy=False,
                                   sample_seed=job.seed)
    return {"curve": curve, "eval": greedy, "stochastic": sampled}


def _last(crossplay: Sequence[Sequence[int]]) -> tuple[int, int]:
    return len(crossplay) - 1, len(crossplay) - 1


def least_exploited(crossplay: Sequence[Sequence[int]]) -> tuple[int, int]:
    """The attackers' and the defenders' least exploited trained checkpoints in the
    cross-play table (``crossplay[i][j]``: attackers ``i``'s successes against defenders
    ``j``; checkpoint 0, the untrained networks, neither kept nor counted as an
    opponent): the attackers whose fewest successes against any trained defenders are
    most, and the defenders that concede fewest to the attackers that beat them most.
    Ties go to the later checkpoint."""
    table = np.asarray(crossplay)[1:, 1:]
    worst_attack = table.min(axis=1)  # each attackers' successes against their hardest
    worst_defence = table.max(axis=0)  # each defenders' concessions to their hardest
    last = len(table) - 1
    return (1 + last - int(np.argmax(worst_attack[::-1])),
            1 + last - int(np.argmin(worst_defence[::-1])))


KEEP: dict[str, Callable[[Sequence[Sequence[int]]], tuple[int, int]]] = {
    "last": _last, "least_exploited": least_exploited}
"""Each ``SelfPlaySetting.keep`` rule: the cross-play table -> the indices of the
attackers' and the defenders' checkpoints a job evaluates as trained."""


def _run_self_play(job: Job, s: SelfPlaySetting) -> dict[str, Any]:
    from ilpss.reference import marl_ppo
    n, o, evaluate = job.evaluation.episodes, s.marl.obs_type, _evaluate(s.marl)
    pool_a, pool_d, curve = marl_ppo.train_self_play(
        _parallel(s.ppo.n_envs, o), s, job.seed, _progress(job, s.ppo.steps))
    out: dict[str, Any] = {"curve": curve}
    m = s.crossplay_episodes
    crossplay = [[sum(r > 0 for r in evaluate([a, d], _parallel(m, o), EVAL_SEED))
                  for d in pool_d] for a in pool_a]
    kept_a, kept_d = KEEP[s.keep](crossplay)
    for prefix, a, d in (("", pool_a[kept_a], pool_d[kept_d]),
                         ("untrained_", pool_a[0], pool_d[0])):
        out[f"{prefix}eval"] = {t: evaluate([a], _parallel(n, o, opponent=t), EVAL_SEED)
                                for t in job.teams}
        out[f"{prefix}eval"][SELF_PLAY] = evaluate([a, d], _parallel(n, o), EVAL_SEED)
        out[f"{prefix}defence"] = {x: evaluate([d], _parallel(n, o, attack=x), EVAL_SEED)
                                   for x in job.attacks}
    out["crossplay"] = crossplay
    if s.keep != "last":
        out["kept"] = [kept_a, kept_d]
    return out


def run_job(job: Job) -> dict[str, Any]:
    """Train, then evaluate the policies on the held-out episode seeds."""
    import torch

    n = job.evaluation.episodes
    s = job.setting
    if isinstance(s, HolderSetting):
        from ilpss.reference import holder
        model, venv, curve = holder.train(job.team, s, job.seed, _progress(job, s.ppo.steps))
        return {"curve": curve, "eval": {job.team: holder.evaluate(model, venv, job.team, n,
                                                                    EVAL_SEED)}}
    if isinstance(s, TransferSetting):
        from ilpss.reference import holder
        return holder.transfer(job.teams, job.team, s, job.seed, n, EVAL_SEED)
    torch.set_num_threads(1)
    if isinstance(s, MarlSetting):
        return _run_marl(job, s)
    return _run_self_play(job, s)


# ---------------------------------------------------------------------------- checks
def is_drill_reward(r: Any) -> bool:
    """Whether ``r`` is an episode reward the drill pays: a failure's, or a success's
    (between the line's ends and its centre)."""
    low, high = SUCCESS_REWARDS
    return is_real(r) and (r == FAILURE_REWARD or low <= r <= high)


def _fields(where: str, value: Any, wanted: set[str]) -> dict[str, Any]:
    """``value`` is an object with exactly the fields ``wanted``."""
    if not isinstance(value, dict):
        raise ValueError(f"{where} must be an object, got {type(value).__name__}")
    if set(value) != wanted:
        extra, missing = sorted(set(value) - wanted), sorted(wanted - set(value))
        raise ValueError(f"{where} must hold exactly the fields {sorted(wanted)}"
                         + (f"; unknown: {extra}" if extra else "")
                         + (f"; missing: {missing}" if missing else ""))
    return value


def _rewards(where: str, value: Any, n: int) -> None:
    if not isinstance(value, list) or len(value) != n:
        raise ValueError(f"{where} must be a list of {n} episode rewards, got "
                         f"{type(value).__name__} of length {len(value) if isinstance(value, list) else '-'}")
    bad = next((r for r in value if not is_drill_reward(r)), None)
    if bad is not None or any(isinstance(r, bool) for r in value):
        low, high = SUCCESS_REWARDS
        raise ValueError(f"{where} holds {bad!r}, not an episode reward of the drill "
                         f"({FAILURE_REWARD:g}, or a success in [{low:g}, {high:g}])")


def _rewards_by_name(where: str, value: Any, names: list[str], n: int) -> None:
    for name in names:
        _rewards(f"{where}.{name}", value[name], n)


def _curve(where: str, rows: Any, budget: int | None = None) -> None:
    """A learning curve: rows ``[steps, seconds, mean reward, success rate, episodes]``,
    steps rising, seconds never falling, the mean reward one the drill can pay with that
    success rate (``None`` both where no episode ended), the last row at the budget."""
    if not isinstance(rows, list) or not rows:
        raise ValueError(f"{where} must be a non-empty list of rows")
    low, high = SUCCESS_REWARDS
    before = (0.0, 0.0)
    for k, row in enumerate(rows):
        shape = (isinstance(row, list) and len(row) == 5
                 and all(is_real(x) and not isinstance(x, bool) for x in (*row[:2], row[4]))
                 and all(x is None or (is_real(x) and not isinstance(x, bool)) for x in row[2:4]))
        if not shape:
            raise ValueError(f"{where}[{k}]: a row must be [steps, seconds, mean reward, "
                             f"success rate, episodes], got {row!r}")
        steps, seconds, mean, rate, episodes = row
        if not steps > before[0] or not seconds >= before[1] or not math.isfinite(seconds):
            raise ValueError(f"{where}[{k}]: steps must rise and seconds never fall from row "
                             f"to row, got {row!r} after {list(before)}")
        if not (episodes >= 0 and float(episodes).is_integer()):
            raise ValueError(f"{where}[{k}]: episodes must be a count, got {episodes!r}")
        if (mean is None) != (episodes == 0) or (rate is None) != (episodes == 0):
            raise ValueError(f"{where}[{k}]: the mean reward and success rate are null exactly "
                             f"when no episode ended, got {row!r}")
        if mean is not None and not (
                0.0 <= rate <= 1.0
                and FAILURE_REWARD + rate * (low - FAILURE_REWARD) - 1e-9 <= mean
                <= FAILURE_REWARD + rate * (high - FAILURE_REWARD) + 1e-9):
            raise ValueError(f"{where}[{k}]: a mean reward of {mean!r} with a success rate of "
                             f"{rate!r} is not one the drill's rewards can give")
        before = (steps, seconds)
    if budget is not None and before[0] < budget:
        raise ValueError(f"{where}: the curve ends at {before[0]:g} steps, before the budget "
                         f"of {budget:,}")


def _crossplay(where: str, value: Any, k: int, m: int) -> None:
    row = ListOf(Integer(0, m), min_len=k, max_len=k, kinds=(list,))
    check(where, value, ListOf(row, min_len=k, max_len=k, kinds=(list,)),
          f"a {k} x {k} table of success counts")


def check_result(where: str, key: Mapping[str, Any], result: Any) -> None:
    """A kept result is what the key's job returns: exactly its fields, its curves and
    evaluations as long as the key says, every reward one the drill can pay (the
    evaluations and curves are the drill's rewards, before any reward option). Raises
    ``ValueError`` naming ``where``."""
    n = key["evaluation"]["episodes"]
    kind = key["setting_type"]
    setting = key["setting"]
    if kind == "TransferSetting":
        _fields(where, result, {"source_seconds", "fine_tuned", "anew"})
        if not (is_real(result["source_seconds"]) and result["source_seconds"] >= 0):
            raise ValueError(f"{where}.source_seconds must be a number of seconds >= 0")
        for arm in ("fine_tuned", "anew"):
            r = _fields(f"{where}.{arm}", result[arm], {"curve", "rows", "eval"})
            _rewards(f"{where}.{arm}.curve", r["curve"], setting["target_episodes"])
            _curve(f"{where}.{arm}.rows", r["rows"])
            _rewards(f"{where}.{arm}.eval", r["eval"], n)
        return
    if kind == "HolderSetting":
        r = _fields(where, result, {"curve", "eval"})
        _curve(f"{where}.curve", r["curve"], setting["ppo"]["steps"])
        _fields(f"{where}.eval", r["eval"], {key["team"]})
        _rewards(f"{where}.eval.{key['team']}", r["eval"][key["team"]], n)
        return
    if kind == "MarlSetting":
        r = _fields(where, result, {"curve", "eval", "stochastic"})
        _curve(f"{where}.curve", r["curve"], setting["ppo"]["steps"])
        names = [key["team"]] if setting["side"] == "attackers" else list(key["attacks"])
        for part in ("eval", "stochastic"):
            _fields(f"{where}.{part}", r[part], set(names))
            _rewards_by_name(f"{where}.{part}", r[part], names, n)
        return
    if kind != "SelfPlaySetting":
        raise ValueError(f"{where}: unknown setting type {kind!r}")
    parts = {"curve", "crossplay"} | {f"{p}{x}" for p in ("", "untrained_")
                                      for x in ("eval", "defence")}
    keep = setting.get("keep", "last")  # kept before the field: the last checkpoints
    r = _fields(where, result, parts | ({"kept"} if keep != "last" else set()))
    _curve(f"{where}.curve", r["curve"], setting["marl"]["ppo"]["steps"])
    teams, attacks = [*key["teams"], SELF_PLAY], list(key["attacks"])
    for prefix in ("", "untrained_"):
        _fields(f"{where}.{prefix}eval", r[f"{prefix}eval"], set(teams))
        _rewards_by_name(f"{where}.{prefix}eval", r[f"{prefix}eval"], teams, n)
        _fields(f"{where}.{prefix}defence", r[f"{prefix}defence"], set(attacks))
        _rewards_by_name(f"{where}.{prefix}defence", r[f"{prefix}defence"], attacks, n)
    _crossplay(f"{where}.crossplay", r["crossplay"], setting["snapshots"],
               setting["crossplay_episodes"])
    if keep != "last" and r["kept"] != list(KEEP[keep](r["crossplay"])):
        raise ValueError(f"{where}.kept is {r['kept']!r}, not the checkpoints the "
                         f"{keep!r} rule keeps from the cross-play table")
