"""Each row of docs/architecture.md's "Where a change belongs", done once.

A new lifelong method, a method with its own learner, a protocol, a way of reusing past
policies, a metric, a report section, a method's series and a team are each added from
here, touching only what the table says (tests/test_change_table.py checks that), and run
through the experiment runner; a run that cannot be reported is refused when it is
configured, and every setting's constraint is declared once and reaches its user.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from dataclasses import dataclass, replace
from types import MappingProxyType

import numpy as np
import pytest
from synthetic_smdp import ZoneCorridor

from ilpss.experiments import drill_facts
from ilpss.experiments.config import EXPERIMENT_CONSTRAINTS, ExperimentConfig
from ilpss.experiments.folder import RunFolder
from ilpss.experiments.methods import METHODS, Job, LifelongMethod, Method, register_method
from ilpss.experiments.protocols import (
    PROTOCOLS,
    Protocol,
    Stream,
    make_env,
    register_protocol,
    team_task,
)
from ilpss.experiments.report import write_report
from ilpss.experiments.run import JobError, run_experiment
from ilpss.kernels import RegionKernels
from soccer_drill.constraints import Real

pytestmark = pytest.mark.slow  # runs experiments end to end


def _tiny(**changes) -> ExperimentConfig:
    return ExperimentConfig(n_seeds=2, workers=1, **changes).with_overrides(
        lifelong={"train_episodes": 4, "rollout_episodes": 2, "n_kernels": 2})


@pytest.fixture
def registered() -> Iterator[list]:
    """Registers what a test appends as (registry, name); forgets it afterwards."""
    names: list = []
    yield names
    for registry, name in names:
        registry.unregister(name)


# ------------------------------------------------------------------------ a method
def test_a_new_lifelong_method_runs_and_is_reported(tmp_path, registered) -> None:
    register_method(LifelongMethod("ilpss_one_kernel", "ILPSS with one kernel",
                                   lambda base: {"n_kernels": 1}))
    registered.append((METHODS, "ilpss_one_kernel"))
    cfg = _tiny(methods=("ilpss_one_kernel", "scratch"))
    results = run_experiment(cfg, tmp_path, progress=False)
    for result in results:
        entry = result["methods"]["ilpss_one_kernel"]
        assert list(entry["curves"]) == ["3"] and len(entry["curves"]["3"]) == 4
        assert len(entry["library_size"]) == 4
    assert run_experiment(cfg, tmp_path, progress=False) == results  # read back, checked
    report = write_report(cfg, results, tmp_path).read_text()
    assert "### ILPSS with one kernel vs the baseline" in report


class _LearnAnewPerTarget(Method):
    """A plain SMDP learner on each target, seeded like PRQ-learning."""

    name = "smdp_per_target"
    label = "SMDP learning on the target alone"

    def run(self, job: Job) -> dict:
        from ilpss.experiments.protocols import make_env
        from ilpss.lifelong import trial_seeds
        from ilpss.smdp import SmdpLearner

        lc = job.cfg.lifelong.learner
        curves = {}
        for t in job.targets:
            env = make_env(job.cfg.env_id, job.stream.tasks[t])
            learner_seed, env_seed, _, _ = trial_seeds(job.seed, t)
            learner = SmdpLearner(3, lc.tile_coder(env.observation_space), None, lc,
                                  seed=learner_seed)
            results = learner.train(env, job.cfg.lifelong.train_episodes, seed=env_seed)
            curves[str(t)] = [r.total_reward for r in results]
        return {"curves": curves}


def test_a_new_learner_method_runs_and_is_reported(tmp_path, registered) -> None:
    register_method(_LearnAnewPerTarget())
    registered.append((METHODS, "smdp_per_target"))
    cfg = _tiny(methods=("scratch", "smdp_per_target"))
    results = run_experiment(cfg, tmp_path, progress=False)
    for result in results:
        mine, scratch = result["methods"]["smdp_per_target"], result["methods"]["scratch"]
        assert list(mine) == ["curves"] and len(mine["curves"]["3"]) == 4
        # The same learner, seeds and target as learning anew's last trial: the same curve.
        assert mine["curves"] == scratch["curves"]
    assert run_experiment(cfg, tmp_path, progress=False) == results
    report = write_report(cfg, results, tmp_path).read_text()
    assert "### SMDP learning on the target alone vs the baseline" in report


# ---------------------------------------------------------------------- a protocol
class _LastTeamFirst(Protocol):
    """D: the held-out team first, then every other team in order, all targets."""

    name = "D"
    title = "the held-out team first"

    def check(self, cfg: ExperimentConfig) -> None:
        if len(cfg.teams) < 2:
            raise ValueError("protocol D needs at least 2 teams in ExperimentConfig.teams")

    def streams(self, cfg: ExperimentConfig, seed: int) -> list[Stream]:
        teams = (cfg.teams[-1], *cfg.teams[:-1])
        return [Stream(f"first={teams[0]}", tuple(team_task(t) for t in teams), 1)]


def test_a_new_protocol_needs_no_change_elsewhere(tmp_path, registered, capsys) -> None:
    from ilpss.experiments.cli import parser

    register_protocol(_LastTeamFirst())
    registered.append((PROTOCOLS, "D"))
    with pytest.raises(ValueError, match="protocol D needs at least 2 teams"):
        _tiny(protocol="D", teams=("chasers",))
    cfg = _tiny(protocol="D", teams=("chasers", "goal_guards", "interceptors_press"),
                methods=("ilpss", "scratch", "prq"))
    results = run_experiment(cfg, tmp_path, progress=False)
    assert [r["tasks"] for r in results] == [["interceptors_press", "chasers", "goal_guards"]] * 2
    assert all(sorted(r["methods"]["prq"]["curves"]) == ["1", "2"] for r in results)
    assert "D" in parser().parse_args(["--protocol", "D", "--out", "x"]).protocol
    # Its report: the default sections, every target of every stream.
    report = write_report(cfg, results, tmp_path).read_text()
    assert report.startswith("# Protocol D: 2 seeds, 4 learning episodes per opponent")
    for t in (1, 2):
        assert f"## first=interceptors_press, task {t}" in report
        assert (tmp_path / f"curves_00_{t:02d}.png").stat().st_size > 0
    assert report.count("### PRQ-learning (policy reuse) vs the baseline") == 2
    # And its section of the results page, with the figures copied.
    from ilpss.experiments.sections import report_section

    docs = tmp_path / "docs"
    (docs / "figures").mkdir(parents=True)
    section = report_section(cfg, results, tmp_path, docs)
    assert "![learning curves](figures/protocol_d_curves_00_01.png)" in section
    assert (docs / "figures" / "protocol_d_curves_00_02.png").exists()


# ------------------------------------------------------------------------- a reuse
class _Halves(RegionKernels):
    """A kernel model of its own: the two halves of the field, either side of the middle."""


@dataclass(frozen=True)
class _HalvesOfTheField:
    """Regions that are the field's two halves after every trial, read back as such."""

    model_name: str = "_Halves"

    def fit(self, bags, n_features, config, seed):
        return _Halves(n_features, (drill_facts.LATERAL,) * 2, (0.0, 0.0), (True, False))

    def load(self, path):
        return _Halves.load(path)


def test_a_new_reuse_is_one_registration(tmp_path, registered) -> None:
    """Options on regions of a new kind (their own kernel model), the learner started
    from the latest past policy: one Reuse registered, and a method that names it."""
    from ilpss.lifelong import LifelongLearner
    from ilpss.reuse import REUSES, LatestPast, Reuse, register_reuse

    register_reuse(Reuse("halves_from_latest", _HalvesOfTheField(), LatestPast()))
    registered.append((REUSES, "halves_from_latest"))
    register_method(LifelongMethod("halves", "the field's halves on a fine-tuned start",
                                   lambda base: {"options": "halves_from_latest"}))
    registered.append((METHODS, "halves"))
    cfg = _tiny(methods=("halves", "scratch"))
    results = run_experiment(cfg, tmp_path, progress=False)
    # Two regions x the three past policies, offered on the held-out team.
    assert all(r["methods"]["halves"]["options_offered"][-1] == 6 for r in results)
    assert run_experiment(cfg, tmp_path, progress=False) == results  # resumed, checked
    space = make_env(cfg.env_id, cfg.streams(0)[0].tasks[0]).observation_space
    learner = LifelongLearner.load(RunFolder(tmp_path).checkpoints(0, 0, "halves"), space)
    assert type(learner.kernel_model) is _Halves and learner.n_trials == 4
    assert "### the field's halves on a fine-tuned start vs the baseline" in \
        write_report(cfg, results, tmp_path).read_text()


# ------------------------------------------------------------------------ a metric
def test_a_new_metric_is_one_entry(tmp_path, monkeypatch) -> None:
    """A headline metric added to the table, and nowhere else, reaches compare, every
    report's tables and ilpss-compare's."""
    from ilpss import metrics
    from ilpss.experiments.compare import compare_runs
    from ilpss.metrics import registry

    share = metrics.Metric(
        "wins_gain", "share of wins gain", "+.2f", "mean",
        lambda p: (p.transfer > 0).mean(axis=1) - (p.baseline > 0).mean(axis=1),
        lambda p: "mean over seeds of (share of episodes won with transfer) - (the same "
                  "for the baseline)", test=True, headline=True, pairwise=True)
    monkeypatch.setattr(registry, "METRICS", (*registry.METRICS, share))
    rng = np.random.default_rng(0)
    est = metrics.compare(rng.uniform(-1, 1, (3, 8)), rng.uniform(-1, 1, (3, 8)), first=2,
                          last=2, threshold=None, window=2)
    assert list(est)[-1] == "wins_gain" and est["wins_gain"].interval == "Student t"
    cfg = _tiny(methods=("ilpss", "whole_policies", "scratch"))
    results = run_experiment(cfg, tmp_path, progress=False)
    text = write_report(cfg, results, tmp_path).read_text()
    assert "share of wins gain [95% CI]" in text  # in the table against the baseline
    assert text.count("share of wins gain [95% CI]") >= 2  # and method against method
    assert "| wins_gain |" in text  # and every metric's table
    (head,) = [line for line in compare_runs((tmp_path, "scratch"), {"x": (tmp_path, "ilpss")})
               if line.startswith("| run |")]
    assert "| share of wins gain |" in head


# ---------------------------------------------------------------- a report section
def test_a_new_report_section_is_one_registration(tmp_path, monkeypatch) -> None:
    """A protocol's report body and its section of the results page, registered by the
    protocol's name, without touching the protocol."""
    from ilpss.experiments import report, sections

    def body(cfg, results, out):
        return ["## Just the success rates", ""]

    monkeypatch.setitem(report.REPORT_BODIES, "A", body)
    monkeypatch.setitem(sections.PAGE_SECTIONS, "A", lambda cfg, results, folder, docs:
                        ["### A page section of its own"])
    cfg = _tiny(methods=("scratch", "ilpss"))
    results = run_experiment(cfg, tmp_path, progress=False)
    text = write_report(cfg, results, tmp_path).read_text()
    assert "## Just the success rates" in text and "### Verdicts" not in text
    assert sections.page_section(cfg, results, tmp_path, tmp_path) == [
        "### A page section of its own"]


# ------------------------------------------------------------- a method's series
class _WithExtraSeries(_LearnAnewPerTarget):
    """A learner method that records one more series (its greedy reward per task)."""

    name = "smdp_with_series"
    label = "SMDP learning with a series"
    series = MappingProxyType({"reuse_share": Real(0.0, 1.0)})

    def run(self, job: Job) -> dict:
        entry = super().run(job)
        return {**entry, "reuse_share": [0.5] * len(job.stream.tasks)}


def test_a_method_with_an_extra_series_resumes(tmp_path, registered) -> None:
    register_method(_WithExtraSeries())
    registered.append((METHODS, "smdp_with_series"))
    cfg = _tiny(methods=("scratch", "smdp_with_series"))
    results = run_experiment(cfg, tmp_path, progress=False)
    assert results[0]["methods"]["smdp_with_series"]["reuse_share"] == [0.5] * 4
    assert run_experiment(cfg, tmp_path, progress=False) == results  # read back, checked


class _UndeclaredSeries(_LearnAnewPerTarget):
    """A learner method that records a series it does not declare."""

    name = "smdp_undeclared"
    label = "SMDP learning with an undeclared series"

    def run(self, job: Job) -> dict:
        return {**super().run(job), "reuse_share": [0.5] * len(job.stream.tasks)}


def test_a_series_its_method_does_not_declare_fails_the_job_not_the_resume(
        tmp_path, registered) -> None:
    register_method(_UndeclaredSeries())
    registered.append((METHODS, "smdp_undeclared"))
    cfg = _tiny(methods=("scratch", "smdp_undeclared"))
    with pytest.raises(JobError, match=r"seed 0, stream 0: ValueError: methods\."
                                       r"smdp_undeclared: unknown field\(s\) \['reuse_share'\]"):
        run_experiment(cfg, tmp_path, progress=False)
    assert not list(tmp_path.glob("seed_*/stream_*/result.json"))  # nothing to resume from


def test_a_protocol_run_that_cannot_be_reported_is_refused_up_front() -> None:
    with pytest.raises(ValueError, match=r"ExperimentConfig.baseline: method 'scratch' is not "
                                         r"among the methods \['ilpss'\]"):
        ExperimentConfig(protocol="C", methods=("ilpss",))
    with pytest.raises(ValueError, match=r"ExperimentConfig.featured: method 'prq' is not"):
        ExperimentConfig(methods=("ilpss", "scratch"), featured="prq")
    assert ExperimentConfig(methods=("ilpss",), baseline=None).baseline is None


# -------------------------------------------------------------------------- a team
class _SlowPressers:
    """A team written for the test: both defenders go for the ball at 60% of their speed."""

    def reset(self, view, rng) -> None:
        self._players = view.players

    def act(self, view):
        from soccer_drill import Command, Skill

        return dict.fromkeys(self._players, Command(Skill.INTERCEPT, speed=0.6))


class _SlowPressersBatched(_SlowPressers):
    """The same team with a batched ``act`` for the batched drill."""

    def batch(self, n: int):
        from soccer_drill import Command, Skill
        from soccer_drill.teams.kit import SameCommands

        return SameCommands(lambda: Command(Skill.INTERCEPT, speed=0.6))


def _holder_episode(opponent: str, seed: int, batched: bool) -> list[tuple]:
    """Every decision of one holder episode (``pass_first``): the single environment's, or
    the batched one's with one drill."""
    from soccer_drill import HolderEnv
    from soccer_drill.policies import HOLDER_POLICIES
    from soccer_drill.vector import HolderVectorEnv

    policy, steps = HOLDER_POLICIES["pass_first"], []
    if batched:
        env = HolderVectorEnv(num_envs=1, opponent=opponent)
        obs, _ = env.reset(seed=seed)
        obs, done = obs[0], False
        while not done:
            out, reward, term, trunc, _ = env.step(np.array([policy(obs, None)]))
            obs, done = out[0], bool(term[0] or trunc[0])
            steps.append((obs.tolist(), float(reward[0]), done))
        return steps
    env = HolderEnv(opponent=opponent)
    obs, _ = env.reset(seed=seed)
    done = False
    while not done:
        obs, reward, term, trunc, _ = env.step(policy(obs, None))
        done = term or trunc
        steps.append((obs.tolist(), float(reward), done))
    return steps


def test_a_new_team_is_taken_by_name(tmp_path, team_registry) -> None:
    import soccer_drill

    soccer_drill.register("test_slow_pressers", _SlowPressers)
    soccer_drill.register("test_slow_pressers_batched", _SlowPressersBatched)
    cfg = _tiny(teams=("test_slow_pressers", "chasers"), methods=("scratch",))
    (result, _) = run_experiment(cfg, tmp_path, progress=False)
    assert result["tasks"] == ["test_slow_pressers", "chasers"]
    # Single and batched: the batched drill runs a team without ``batch`` as one copy per
    # drill, and one with it through its batched act; both play the single drill's episodes.
    for seed in (3, 11):
        single = _holder_episode("test_slow_pressers", seed, batched=False)
        assert len(single) > 1
        assert _holder_episode("test_slow_pressers", seed, batched=True) == single
        assert _holder_episode("test_slow_pressers_batched", seed, batched=True) == single


# -------------------------------------------------------------- an observation type
def _positions(out, state, rows, players, params, low, high) -> None:
    """An observation type's rule: the player's position, clipped into the bounds."""
    for r in range(len(rows)):
        for k in range(2):
            out[r, k] = min(max(state["pos"][rows[r], players[r], k], low[k]), high[k])


def test_a_new_observation_type_is_one_entry(monkeypatch) -> None:
    """One entry of the table: the single and the batched multi-agent environments take
    it by name, with its space."""
    import soccer_drill
    from soccer_drill.rules import features
    from soccer_drill.vector import ParallelVectorEnv

    def bounds(cfg):
        return np.full(2, -cfg.wall_margin, np.float32), np.full(
            2, cfg.field_size + cfg.wall_margin, np.float32)

    monkeypatch.setitem(features.OBSERVATION_TYPES, "position", features.ObservationType(
        2, bounds, _positions, "the player's position on the field"))
    single = soccer_drill.parallel_env(obs_type="position", opponent="chasers")
    obs, _ = single.reset(seed=5)
    assert single.observation_space("attacker_0")["observation"].shape == (2,)
    assert np.array_equal(obs["attacker_1"]["observation"], single.state()[4:6])
    batched = ParallelVectorEnv(num_envs=3, obs_type="position", opponent="chasers")
    obs, _ = batched.reset(seed=5)
    assert obs["attacker_1"]["observation"].shape == (3, 2)
    assert np.array_equal(obs["attacker_1"]["observation"], batched.state()[:, 4:6])
    with pytest.raises(ValueError, match=r"obs_type must be one of .*'position'"):
        soccer_drill.parallel_env(obs_type="velocity")


# ------------------------------------------------------------------------ a setting
def test_every_setting_is_declared_once_and_reaches_its_user() -> None:
    from ilpss.baselines import PRQ_CONSTRAINTS, PrqConfig, PrqLearner
    from ilpss.kernels import KERNEL_CONSTRAINTS
    from ilpss.lifelong import LIFELONG_CONSTRAINTS, LifelongConfig, LifelongLearner
    from ilpss.options import OPTION_CONSTRAINTS, OptionSettings
    from ilpss.smdp import LEARNER_CONSTRAINTS, SMDP_CONSTRAINTS, LearnerConfig, SmdpLearner
    from ilpss.tiles import TILE_CONSTRAINTS

    nested = {"lifelong", "prq", "library", "learner"}
    names = {"protocol", "env_id", "sampler"}  # checked by their registries
    for cls, constraints in ((LearnerConfig, LEARNER_CONSTRAINTS),
                             (LifelongConfig, LIFELONG_CONSTRAINTS),
                             (OptionSettings, OPTION_CONSTRAINTS),
                             (PrqConfig, PRQ_CONSTRAINTS),
                             (ExperimentConfig, EXPERIMENT_CONSTRAINTS)):
        fields = {f.name for f in dataclasses.fields(cls)}
        assert set(constraints) | (fields & (nested | names)) == fields, cls.__name__
    # A setting that a class takes has that class's constraint, the very same object.
    for name in set(LEARNER_CONSTRAINTS) - {"n_tilings", "tile_widths"}:
        assert LEARNER_CONSTRAINTS[name] is SMDP_CONSTRAINTS[name]
    assert LEARNER_CONSTRAINTS["n_tilings"] is TILE_CONSTRAINTS["n_tilings"]
    for mine, theirs in (("n_kernels", "n_components"), ("kernel_n_init", "n_init"),
                         ("kernel_max_iter", "max_iter"), ("kernel_reg_covar", "reg_covar")):
        assert LIFELONG_CONSTRAINTS[mine] is KERNEL_CONSTRAINTS[theirs]
    # And reaches it, whole.
    lc = LearnerConfig(alpha=0.05, method="sarsa", trace_decay=0.5, initial_value=0.5,
                       option_initial_value=0.25, tile_widths=(0.5,), n_tilings=4)
    env = ZoneCorridor()
    coder = lc.tile_coder(env.observation_space)
    assert (coder.n_tilings, coder.widths.tolist()) == (4, [0.5])
    smdp = SmdpLearner(3, coder, None, lc)
    assert smdp.config is lc  # the whole object, not its fields copied one by one
    reuse = PrqConfig(psi=0.5, upsilon=0.8, tau0=0.1, delta_tau=0.2)
    prq = PrqLearner(3, coder, [], replace(lc, method="q"), reuse)
    assert prq.reuse is reuse and prq.config == replace(lc, method="q")
    assert prq.trace_decay == lc.trace_decay  # the same base learner, unless told otherwise
    assert PrqConfig(trace_decay=0.0).trace_decay_for(lc) == 0.0
    settings = OptionSettings(discount=0.25, max_depth=2, continuation_exponent=0.5)
    cfg = LifelongConfig(library=settings, learner=lc, options="whole_policies",
                         train_episodes=2, rollout_episodes=1)
    learner = LifelongLearner(cfg, env.observation_space, 3)
    for _ in range(2):
        learner.run_trial(env, "corridor")
    assert learner.library is not None and learner.library.settings is settings


@pytest.mark.parametrize(("make", "said"), [
    (lambda: __import__("ilpss.reuse").reuse.Reuse("r1", "kernels"),
     "reuse 'r1': regions is a Regions"),
    (lambda: __import__("ilpss.reuse").reuse.Reuse("r2", None, start=3),
     "reuse 'r2': start is a StartRule"),
    (lambda: __import__("ilpss.reuse").reuse.Reuse("r3", None, offer=5),
     "reuse 'r3': offer is an OfferRule"),
    (lambda: LifelongMethod("m1", "x", {"n_kernels": 1}), "method 'm1': changes is a function"),
    (lambda: LifelongMethod("m2", 5), "method 'm2': label"),
])
def test_a_reuse_or_method_made_wrong_is_refused_when_made(make, said):
    # before, each was accepted and failed inside every job, after its sources had
    # trained ("'str' object has no attribute 'fit'", "'dict' object is not callable")
    with pytest.raises((TypeError, ValueError), match=said):
        make()


def test_a_methods_changes_naming_no_field_say_which_method():
    # before, "LifelongConfig.__init__() got an unexpected keyword argument", no method named
    from ilpss.lifelong import LifelongConfig

    method = LifelongMethod("m3", "x", lambda base: {"no_such_field": 1})
    with pytest.raises(ValueError, match=r"method 'm3': its changes name \['no_such_field'\]"):
        method.config(LifelongConfig())
