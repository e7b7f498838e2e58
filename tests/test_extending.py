"""Each row of docs/architecture.md's "Where a change belongs", done once.

A new lifelong method, a new method with its own learner, a new protocol and a new team
are each added from here, touching only what the table says, and run through the
experiment runner; every setting's constraint is declared once and reaches its user.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from dataclasses import replace

import pytest
from synthetic_smdp import ZoneCorridor

from ilpss.experiments.config import EXPERIMENT_CONSTRAINTS, ExperimentConfig
from ilpss.experiments.methods import METHODS, Job, LifelongMethod, Method, register_method
from ilpss.experiments.protocols import PROTOCOLS, Protocol, Stream, register_protocol, team_task
from ilpss.experiments.report import write_report
from ilpss.experiments.run import run_experiment

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
    section = report_section(PROTOCOLS.get("D"), cfg, results, tmp_path, docs)
    assert "![learning curves](figures/protocol_d_curves_00_01.png)" in section
    assert (docs / "figures" / "protocol_d_curves_00_02.png").exists()


# -------------------------------------------------------------------------- a team
def test_a_new_team_is_taken_by_name(tmp_path) -> None:
    import soccer_drill
    from opponents.chasers import Chasers

    soccer_drill.register("test_chasers_again", Chasers, overwrite=True)
    cfg = _tiny(teams=("test_chasers_again", "chasers"), methods=("scratch",))
    (result, _) = run_experiment(cfg, tmp_path, progress=False)
    assert result["tasks"] == ["test_chasers_again", "chasers"]


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
