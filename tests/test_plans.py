"""Plans of the current form: checked whole before anything runs, their power computed
before the run, their analysis refusing results that are not the plan's, and the
per-seed numbers a page is recomputed from."""

from __future__ import annotations

import copy
import gzip
import itertools
import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from ilpss import metrics
from ilpss.experiments.confirm import analyse, main
from ilpss.experiments.plan import Pilot, Plan, TestSpec
from ilpss.experiments.power import pilot_figures, plan_power, seeds_needed
from ilpss.experiments.seed_data import SeedData

ROOT = Path(__file__).resolve().parents[1]
TINY = {"n_seeds": 2, "first_seed": 2000, "lifelong": {"train_episodes": 3,
                                                      "rollout_episodes": 1}}
FT, FB, WP = "finetune_bounded", "finetune_best_bounded", "whole_policies_ft_bounded_cut_primitives"
PLAN = {
    "schema": "ilpss.plan/2",
    "title": "A tiny plan",
    "protocols": {"A": {**TINY, "methods": ["scratch", FT, FB, WP]}},
    "tests": [
        {"name": "options gain", "protocol": "A", "method": WP, "against": FT, "margin": 0,
         "pilot": {"effect": 20.0, "sd": 30.0, "seeds": 10}},
        {"name": "choice no loss", "protocol": "A", "method": FB, "against": FT,
         "margin": -30, "pilot": {"effect": -5.0, "sd": 40.0, "seeds": 10}},
    ],
    "rule": {"candidates": [{"method": FB, "requires": ["choice no loss"]},
                            {"method": WP, "requires": ["options gain"]}],
             "fallback": FT},
    "reported": [[FB, WP]],
    "secondary": ["jumpstart"],
}


def _changed(**changes) -> dict:
    plan = copy.deepcopy(PLAN)
    plan.update(changes)
    return plan


# ---------------------------------------------------------------------- the tests' p-values
def test_the_sign_flip_test_matches_every_sign_assignment_counted_by_hand():
    x = np.array([3.0, -1.0, 4.0, 1.5, -0.5, 2.0, 2.5, -2.0])
    means = [np.mean(np.array(s) * x) for s in itertools.product((-1, 1), repeat=x.size)]
    two = np.mean(np.abs(means) >= abs(x.mean()) - 1e-12)
    greater = np.mean(np.array(means) >= x.mean() - 1e-12)
    assert metrics.sign_flip_pvalue(x) == pytest.approx(two)
    assert metrics.sign_flip_pvalue(x, alternative="greater") == pytest.approx(greater)
    # against a margin: the values shifted by it
    assert metrics.sign_flip_pvalue(x, -1.0, "greater") == pytest.approx(
        metrics.sign_flip_pvalue(x + 1.0, 0.0, "greater"))


def test_the_sign_flip_test_with_many_seeds_agrees_with_scipys_permutation_test():
    x = np.random.default_rng(3).normal(0.4, 1.0, 30)
    ours = metrics.sign_flip_pvalue(x, alternative="greater")
    ref = stats.permutation_test((x,), np.mean, permutation_type="samples",
                                 alternative="greater", n_resamples=200_000,
                                 random_state=1).pvalue
    assert ours == pytest.approx(ref, abs=0.005)
    assert 1 / 1024 <= metrics.sign_flip_pvalue(np.ones(10), alternative="two-sided") \
        == pytest.approx(2 / 1024)


def test_the_one_sided_t_test_is_scipys_and_matches_the_intervals_lower_bound():
    x = np.array([12.0, -3.0, 25.0, 8.0, 30.0, -10.0, 14.0, 5.0, 9.0, 21.0])
    for margin in (0.0, -15.0):
        ours = metrics.t_test_pvalue(x, margin, "greater")
        assert ours == pytest.approx(stats.ttest_1samp(x, margin, alternative="greater").pvalue)
    _, low, _ = metrics.t_interval(x, 0.95)
    # the lower bound of the 95% interval lies above the margin exactly when p < 0.025
    assert (metrics.t_test_pvalue(x, low - 1e-9, "greater") < 0.025)
    assert not (metrics.t_test_pvalue(x, low + 1e-9, "greater") < 0.025)


# ---------------------------------------------------------------------- checked whole, up front
@pytest.mark.parametrize("plan, said", [
    (_changed(protocols={"A": {**TINY, "protocol": "C", "methods": ["scratch", FT, FB, WP]}}),
     "holds protocol 'C'"),
    (_changed(protocols={"A": {**TINY, "methods": ["scratch", FT, FB, WP], "nope": 1}}),
     r"unknown field\(s\) \['nope'\]"),
    (_changed(protocols={"A": {**TINY, "methods": {"scratch": 1}}}), "must be a list"),
    (_changed(title="A plan\n| forged | row |"), "on one line"),
    (_changed(rule={"candidates": [{"method": FB, "requires": ["missing test"]}],
                    "fallback": FT}), "not tests of the family"),
    (_changed(rule={"candidates": [{"method": FB, "requires": []}], "fallback": FT}),
     "at least 1"),
    (_changed(protocols={"A": {**TINY, "methods": ["scratch", FT, FB, WP]},
                         "R": {"n_seeds": 0, "methods": ["scratch", FT]}}),
     "protocols.R"),
    (_changed(tests=[{**PLAN["tests"][0], "method": "prq"}]), "not run in protocol A"),
    (_changed(tests=[{**PLAN["tests"][0], "pilot": {"effect": 1.0, "sd": 0.0,
                                                    "seeds": 10}}]), "sd"),
    (_changed(tests=[PLAN["tests"][0], PLAN["tests"][0]]), "distinct"),
    (_changed(extra=1), "unknown field"),
])
def test_a_plan_is_refused_whole_before_anything_runs(tmp_path, plan, said):
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(plan))
    with pytest.raises(ValueError, match=said):
        Plan.read(path)
    # the command refuses it before creating a single run folder
    with pytest.raises(SystemExit):
        main([str(path), "--runs", str(tmp_path / "runs"), "--quiet"])
    assert not (tmp_path / "runs").exists()


def test_the_first_form_refuses_a_protocol_entry_that_runs_another_protocol(tmp_path):
    plan = json.loads((ROOT / "docs" / "confirmatory.json").read_text())
    plan["protocols"]["A"] = {**plan["protocols"]["A"], "protocol": "C"}
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(plan))
    with pytest.raises(ValueError, match="holds protocol 'C'"):
        Plan.read(path)


# ---------------------------------------------------------------------- power
def test_the_simulated_power_of_one_test_is_the_noncentral_t_power():
    spec = {**PLAN, "tests": [PLAN["tests"][0]],
            "rule": {"candidates": [{"method": WP, "requires": ["options gain"]}],
                     "fallback": FT}}
    plan = Plan.from_json(spec)
    n = 30
    report = plan_power(plan, seeds={"A": n}, sims=40_000)
    crit = stats.t.ppf(1 - 0.025, n - 1)
    exact = stats.nct.sf(crit, n - 1, 20.0 / (30.0 / math.sqrt(n)))
    assert report.shown["options gain"] == pytest.approx(exact, abs=0.01)
    assert report.qualifies[WP] == pytest.approx(exact, abs=0.01)
    assert report.picks[WP] + report.picks[FT] == pytest.approx(1.0)


def test_power_refuses_a_plan_too_weak_to_pick_its_candidate(tmp_path):
    weak = _changed(tests=[{**t, "pilot": {"effect": 2.0, "sd": 60.0, "seeds": 10}}
                           for t in PLAN["tests"]])
    path = tmp_path / "weak.json"
    path.write_text(json.dumps(weak))
    report = plan_power(Plan.read(path), sims=4000)
    assert report.qualifies[WP] < 0.1 and report.below(0.8)
    with pytest.raises(SystemExit) as stopped:
        main([str(path), "--runs", str(tmp_path / "runs"), "--quiet"])
    assert stopped.value.code == 1 and not (tmp_path / "runs").exists()


def test_seeds_needed_grows_with_the_spread_and_is_never_for_an_effect_below_the_margin():
    spec = TestSpec("t", "A", WP, FT, margin=-10.0)
    assert seeds_needed(spec, Pilot(10.0, 40.0, 10), 0.025) < \
        seeds_needed(spec, Pilot(10.0, 80.0, 10), 0.025)
    assert math.isinf(seeds_needed(spec, Pilot(-20.0, 40.0, 10), 0.025))


def test_the_first_confirmatory_rule_had_almost_no_power_at_its_development_effects():
    """The committed first-form plan, at effects as large as its development seeds
    suggested for the candidate (+15 to +81) and the spread its run measured, qualifies
    the candidate in a small share of runs: "picks fine-tuning" was the rule's default."""
    plan = Plan.read(ROOT / "docs" / "confirmatory.json")
    sd = {"A": 72.0, "B": 41.0, "R": 82.0, "C": 30.0}
    dev = {"A": 15.0, "B": 23.0, "R": 81.0, "C": 23.0}
    pilots = {t.name: Pilot(dev[t.protocol] if t.method == "whole_policies_ft_bounded_cut"
                            else 0.0, sd[t.protocol], 10) for t in plan.family}
    report = plan_power(plan, pilots, sims=1500)
    assert report.qualifies["whole_policies_ft_bounded_cut"] < 0.05


# ---------------------------------------------------------------------- runs and their numbers
@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    root = tmp_path_factory.mktemp("tiny")
    path = root / "plan.json"
    path.write_text(json.dumps(PLAN))
    assert main([str(path), "--runs", str(root / "runs"), "--quiet", "--force"]) == 0
    return path, root


def test_the_page_is_recomputed_from_the_committed_numbers_alone(tiny_run, tmp_path):
    path, root = tiny_run
    page = (root / "runs" / "confirm.md").read_text()
    assert "Seeds used (every planned seed finished): A: 2 seeds (2000-2001)" in page
    assert "**unadjusted**" in page and "**The rule picks `" in page
    stem = root / "runs" / "seed_data"
    assert main([str(path), "--from-data", str(stem), "--out", str(tmp_path / "again.md")]) == 0
    assert (tmp_path / "again.md").read_text() == page


def test_per_seed_numbers_that_were_changed_are_refused(tiny_run, tmp_path):
    _, root = tiny_run
    data = SeedData.read(root / "runs" / "seed_data")
    stem = tmp_path / "copy"
    table, manifest = data.write(stem)
    text = gzip.decompress(table.read_bytes()).decode().replace("-1 ", "1 ", 1)
    table.write_bytes(gzip.compress(text.encode()))
    with pytest.raises(ValueError, match="SHA-256"):
        SeedData.read(stem)


def test_per_seed_numbers_missing_a_method_of_one_job_are_refused_by_name(tiny_run, tmp_path):
    _, root = tiny_run
    data = SeedData.read(root / "runs" / "seed_data")
    jobs = {p: [dict(job) for job in js] for p, js in data.jobs.items()}
    first = jobs["A"][0]
    first["methods"] = {k: v for k, v in first["methods"].items() if k != FT}
    stem = tmp_path / "short"
    SeedData(data.configs, jobs, data.wall_times).write(stem)
    with pytest.raises(ValueError, match=rf"protocol A, seed {first['seed']}, stream 0 holds "
                                         rf"the methods .*; its run has"):
        SeedData.read(stem)


def test_an_analysis_refuses_runs_that_are_not_the_plans(tiny_run, tmp_path):
    path, root = tiny_run
    data = SeedData.read(root / "runs" / "seed_data")
    other = _changed(protocols={"A": {**TINY, "n_seeds": 30, "first_seed": 9000,
                                      "methods": ["scratch", FT, FB, WP]}})
    with pytest.raises(ValueError, match="another configuration"):
        analyse(Plan.from_json(other), data)
    # a planned seed missing from the folders: refused, never analysed on fewer seeds
    import shutil

    runs = tmp_path / "runs"
    shutil.copytree(root / "runs", runs)
    shutil.rmtree(runs / "protocol_a" / "seed_2001")
    with pytest.raises(SystemExit) as stopped:
        main([str(path), "--runs", str(runs), "--analyse-only", "--quiet"])
    assert stopped.value.code == 1


def test_the_committed_decisive_plan_is_powered_and_fresh():
    """The plan in docs/ is a valid plan of the current form, on seeds never used before
    (from 3000), whose rule picks each candidate with its required probability if the
    pilot effects are true."""
    path = ROOT / "docs" / "decisive_test.json"
    if not path.exists():
        pytest.skip("no decisive plan committed yet")
    plan = Plan.read(path)
    assert all(plan.config(p).first_seed >= 3000 for p in plan.protocols)
    required = {r for _, requires in plan.rule.candidates for r in requires}
    (group,) = {t.group for t in plan.family if t.name in required}  # one family
    assert 5 <= len(plan.groups()[group]) <= 8
    report = plan_power(plan, sims=5000)
    assert not report.below(plan.required_power)
    # the pilot figures are those of the committed development runs (the spread never
    # below the pilot's: the plan takes the larger of it and an earlier fresh run's)
    stems = sorted(p.with_suffix("") for p in (ROOT / "docs" / "data").glob("decisive_pilot*.json"))
    pilots = pilot_figures(plan, [SeedData.read(stem) for stem in stems])
    for t in plan.family:
        assert (t.pilot.effect, t.pilot.seeds) == (pilots[t.name].effect, pilots[t.name].seeds)
        assert t.pilot.sd >= pilots[t.name].sd


def test_a_candidate_its_pilot_does_not_support_is_reported_not_required():
    unsupported = _changed(tests=[PLAN["tests"][0], {**PLAN["tests"][1], "pilot": {
        "effect": -60.0, "sd": 20.0, "seeds": 10}}])
    report = plan_power(Plan.from_json(unsupported), sims=2000)
    assert report.qualifies[FB] < 0.01 and not report.supported[FB]
    assert f"`{FB}`" not in " ".join(report.below(0.8))


def test_every_headline_difference_carries_its_sign_flip_p_beside_the_t_p():
    rng = np.random.default_rng(0)
    base = rng.uniform(-1, 1, size=(12, 40))
    transfer = np.clip(base + rng.normal(0.2, 0.3, size=(12, 40)), -1, 1)
    est = metrics.compare(transfer, base, first=5, last=10, threshold=None, window=5)
    gains = transfer.sum(axis=1) - base.sum(axis=1)
    assert est["total_reward_gain"].p_sign_flip == pytest.approx(
        metrics.sign_flip_pvalue(gains))
    assert math.isnan(est["total_reward_transfer"].p_sign_flip)  # not a difference
    from ilpss.experiments.report_text import verdict

    assert "sign-flip p = " in verdict(est)


@pytest.mark.parametrize("effect, sd, level", [(20.0, 20.0, 0.025), (171.9, 106.3, 0.025 / 8),
                                                (47.4, 45.0, 0.025)])
def test_seeds_needed_is_the_fewest_at_which_a_simulated_t_test_reaches_the_power(effect, sd, level):
    """An independent oracle: t tests on simulated seeds reach 80% at the seeds given and
    fall short one seed below (the normal approximation, at small counts, fell short)."""
    n = int(seeds_needed(TestSpec("t", "A", "m", "c", margin=0.0), Pilot(effect, sd, 10), level))
    rng = np.random.default_rng(0)

    def simulated_power(seeds: int) -> float:
        draws = rng.normal(effect, sd, size=(20_000, seeds))
        t = draws.mean(1) / (draws.std(1, ddof=1) / np.sqrt(seeds))
        return float(np.mean(t > stats.t.ppf(1 - level, seeds - 1)))

    assert simulated_power(n) >= 0.79
    assert simulated_power(n - 1) < 0.80


def test_pilot_figures_from_the_plans_own_seeds_are_refused():
    """The decisive run's own per-seed numbers (seeds from 3000) as its pilot: its power
    would be read off its outcomes; refused, naming the seeds."""
    path = ROOT / "docs" / "decisive_test.json"
    if not (ROOT / "docs" / "data" / "decisive_test.json").exists():
        pytest.skip("the decisive run's numbers are not kept")
    plan = Plan.read(path)
    with pytest.raises(ValueError, match=r"seeds \[3000, 3001, 3002, 3003, 3004\] \.\.\. of "
                                         r"the plan's own \(3000 to 30"):
        pilot_figures(plan, [SeedData.read(ROOT / "docs" / "data" / "decisive_test")])


def test_a_plan_naming_where_checkpoints_are_written_is_refused():
    """A plan is a data file: it never leads a write outside its folder."""
    plan = _changed(protocols={"A": {**PLAN["protocols"]["A"], "storage": "/elsewhere"}})
    with pytest.raises(ValueError, match=r"protocols\.A\.storage: where checkpoints are "
                                         "written is not a plan's to say"):
        Plan.from_json(plan)


@pytest.mark.parametrize(("change", "said"), [
    (lambda job: job["methods"]["ilpss"]["curves"].update(
        {t: [1000.0, *c[1:]] for t, c in job["methods"]["ilpss"]["curves"].items()}),
     r"each a finite number in \[-1, 1\], got \[1000\.0"),
    (lambda job: job.update(tasks=["zz"] * len(job["tasks"])), "tasks is "),
    (lambda job: job["methods"]["ilpss"]["curves"].update(
        {t: c[:3] for t, c in job["methods"]["ilpss"]["curves"].items()}), "must be a list of"),
    (lambda job: job.update(seed=123456), "is not a job of its configuration"),
])
def test_kept_numbers_rewritten_with_their_digests_are_checked_as_a_runs(tmp_path, change, said):
    # before, numbers whose digests were recomputed were read as they were: a reward of
    # 1000 where the drill pays [-1, 1], another job's tasks, a curve of 3 episodes (an
    # error about an inhomogeneous array, naming nothing) were all made into pages
    data = SeedData.read(Path(__file__).resolve().parents[1] / "docs" / "data" / "larger_drill")
    change(data.jobs["A"][0])
    data.write(tmp_path / "changed")
    with pytest.raises(ValueError, match=said):
        SeedData.read(tmp_path / "changed")
