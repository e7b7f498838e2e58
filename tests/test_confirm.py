"""The confirmatory run: a plan checked when read, Holm across the whole family, and the
pick rule applied as written."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from ilpss.experiments.confirm import Comparison, main, pick
from ilpss.experiments.plan import PRIMARY, Plan
from ilpss.metrics import MetricEstimate

DOCS = Path(__file__).resolve().parents[1] / "docs"

PLAN = {
    "methods": ["scratch", "finetune", "finetune_bounded", "whole_policies_ft_bounded_cut",
                "ilpss_ft_bounded_cut_available"],
    "protocols": {"A": {"n_seeds": 2, "first_seed": 2000,
                        "lifelong": {"train_episodes": 3, "rollout_episodes": 1}}},
    "comparisons": [["whole_policies_ft_bounded_cut", "finetune"],
                    ["whole_policies_ft_bounded_cut", "finetune_bounded"],
                    ["ilpss_ft_bounded_cut_available", "finetune"],
                    ["ilpss_ft_bounded_cut_available", "finetune_bounded"],
                    ["ilpss_ft_bounded_cut_available", "whole_policies_ft_bounded_cut"],
                    ["finetune_bounded", "finetune"]],
    "candidates": ["whole_policies_ft_bounded_cut", "ilpss_ft_bounded_cut_available"],
    "controls": ["finetune", "finetune_bounded"],
    "fallback": "finetune",
}
W, K, FB = "whole_policies_ft_bounded_cut", "ilpss_ft_bounded_cut_available", "finetune_bounded"


def _plan() -> Plan:
    return Plan.from_json(PLAN)


def _test(protocol: str, method: str, against: str, gain: float, low: float,
          adjusted: float) -> Comparison:
    estimate = MetricEstimate(PRIMARY, gain, low, 2 * gain - low, 10, "", p_value=adjusted)
    return Comparison(protocol, method, against, {PRIMARY: estimate}, adjusted)


def _family(gains: dict[tuple[str, str], list[tuple[float, float, float]]]) -> list[Comparison]:
    """Tests in protocols A and B: ``(gain, low, adjusted p)`` per protocol."""
    return [_test(p, m, a, *values[i]) for (m, a), values in gains.items()
            for i, p in enumerate("AB")]


SHOWN, LEVEL, LOSS = (30.0, 10.0, 0.01), (5.0, -10.0, 1.0), (-30.0, -50.0, 0.01)


def test_a_candidate_that_gains_somewhere_and_loses_nowhere_is_picked():
    tests = _family({(W, "finetune"): [SHOWN, LEVEL], (W, FB): [SHOWN, LEVEL],
                     (K, "finetune"): [LEVEL, LEVEL], (K, FB): [LEVEL, LEVEL],
                     (K, W): [LEVEL, LEVEL], (FB, "finetune"): [LEVEL, LEVEL]})
    chosen, said = pick(_plan(), tests)
    assert chosen == W and f"- `{W}` against `finetune`, `{FB}`: qualifies." in said


def test_a_later_candidate_replaces_an_earlier_only_if_it_beats_it():
    gains = {(W, "finetune"): [SHOWN, LEVEL], (W, FB): [SHOWN, LEVEL],
             (K, "finetune"): [SHOWN, SHOWN], (K, FB): [SHOWN, SHOWN],
             (K, W): [LEVEL, LEVEL], (FB, "finetune"): [LEVEL, LEVEL]}
    assert pick(_plan(), _family(gains))[0] == W  # both qualify; the simpler stays
    gains[K, W] = [SHOWN, LEVEL]
    assert pick(_plan(), _family(gains))[0] == K


def test_a_loss_anywhere_or_no_gain_shown_disqualifies_and_the_rule_falls_back():
    gains = {(W, "finetune"): [SHOWN, LOSS], (W, FB): [SHOWN, LEVEL],  # loses on B
             (K, "finetune"): [LEVEL, LEVEL], (K, FB): [LEVEL, LEVEL],  # shows nothing
             (K, W): [LEVEL, LEVEL], (FB, "finetune"): [LEVEL, LEVEL]}
    assert pick(_plan(), _family(gains))[0] == "finetune"
    gains[FB, "finetune"] = [LEVEL, SHOWN]  # the control beats the fallback
    assert pick(_plan(), _family(gains))[0] == FB
    # gains shown against one control only, in different protocols: not shown
    gains[W, "finetune"] = [SHOWN, LEVEL]
    gains[W, FB] = [LEVEL, SHOWN]
    assert pick(_plan(), _family(gains))[0] == FB


def test_a_plan_is_checked_when_read(tmp_path):
    path = tmp_path / "plan.json"
    for change, said in [({"methods": [*PLAN["methods"], "nope"]}, "nope"),
                         ({"candidates": ["prq"]}, "candidates"),
                         ({"fallback": "scratch"}, "fallback"),
                         ({"comparisons": [["finetune", "finetune"]]}, "two different"),
                         ({"comparisons": [["finetune"]]}, "pairs"),
                         ({"extra": 1}, "unknown field"),
                         ({"margin": 5}, "margin"),
                         # before, one seed was read and run, and the analysis then failed
                         ({"protocols": {"A": {**PLAN["protocols"]["A"], "n_seeds": 1}}},
                          r"protocols.A: n_seeds must be an integer >= 2")]:
        path.write_text(json.dumps({**PLAN, **change}))
        with pytest.raises((ValueError, KeyError), match=said):
            Plan.read(path)


def test_the_confirmatory_command_runs_the_plan_and_adjusts_across_the_whole_family(
        tmp_path, capsys):
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(PLAN))
    assert main([str(path), "--runs", str(tmp_path / "runs"), "--quiet"]) == 0
    page = (tmp_path / "runs" / "confirm.md").read_text()
    rows = [line for line in page.splitlines() if line.startswith("| A |")]
    assert len(rows) == len(PLAN["comparisons"])
    assert "Holm-adjusted together" in page and "**The rule picks `" in page
    assert "Code: version" in page
    config = json.loads((tmp_path / "runs" / "protocol_a" / "config.json").read_text())
    assert config["first_seed"] == 2000 and config["methods"] == PLAN["methods"]
    # analysed again without running: the same page
    assert main([str(path), "--runs", str(tmp_path / "runs"), "--analyse-only",
                 "--out", str(tmp_path / "again.md")]) == 0
    assert (tmp_path / "again.md").read_text() == page
    adjusted = [float(row.split("|")[5]) for row in rows]
    assert all(0.0 <= p <= 1.0 or math.isnan(p) for p in adjusted)
    # before, --out and --data were written wherever they pointed: over the run's
    # configuration, the per-seed numbers read back, or the plan itself
    runs = tmp_path / "runs"
    plan_copy = tmp_path / "myplan.json"
    plan_copy.write_text(path.read_text())
    kept = {f: f.read_bytes() for f in [plan_copy, *runs.rglob("*.json"), *runs.rglob("*.gz")]}
    for argv, said in (
            (["--out", str(runs / "protocol_a" / "config.json")], "its name ends in '.md'"),
            (["--out", str(runs / "protocol_a" / "page.md")], "inside the run folder"),
            (["--data", str(tmp_path / "myplan")], "the command reads that file"),
            (["--data", str(runs / "protocol_a" / "config")], "inside the run folder")):
        with pytest.raises(SystemExit):
            main([str(plan_copy), "--runs", str(runs), "--analyse-only", "--quiet", *argv])
        assert said in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main([str(plan_copy), "--from-data", str(runs / "seed_data"), "--out",
              str(runs / "seed_data.json")])
    assert "its name ends in '.md'" in capsys.readouterr().err
    assert {f: f.read_bytes() for f in kept} == kept


@pytest.mark.parametrize(("raised", "status", "said"), [
    (KeyboardInterrupt, 130, "ilpss-confirm: stopped by Ctrl-C (SIGINT); the finished jobs "
                             "are kept, and the same command goes on from them\n"),
    (RuntimeError("a job's own failure"), 1, "The 0 finished job(s) are kept; run the same "
                                             "command again to run only the failed one(s)\n"),
])
def test_a_stopped_or_failing_run_of_a_plan_ends_in_one_line(tmp_path, monkeypatch, capsys,
                                                             raised, status, said):
    """As ilpss-experiment does; before, Ctrl-C and a failed job (a team that raises)
    ended ilpss-confirm, which runs for hours, with a traceback."""
    import signal

    from ilpss.lifelong import LifelongLearner

    def run_trial(self, env, name, callback=None):
        raise raised  # in the middle of a job

    monkeypatch.setattr(LifelongLearner, "run_trial", run_trial)
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(PLAN))
    previous = signal.getsignal(signal.SIGTERM)
    try:
        with pytest.raises(SystemExit) as exit_info:
            main([str(path), "--runs", str(tmp_path / "runs"), "--quiet"])
    finally:
        signal.signal(signal.SIGTERM, previous)
    err = capsys.readouterr().err
    assert exit_info.value.code == status and err.endswith(said)
    assert "Traceback" not in err and err.startswith("ilpss-confirm: ")


def test_the_committed_plan_is_a_valid_plan_of_the_confirmatory_run():
    from pathlib import Path

    plan = Plan.read(Path(__file__).resolve().parents[1] / "docs" / "confirmatory.json")
    assert all(plan.config(p).first_seed >= 2000 for p in plan.protocols)  # fresh seeds
    assert len(plan.methods) <= 6 and set(plan.protocols) == {"A", "B", "R", "C"}


def test_a_comparison_written_the_other_way_round_serves_the_rule_mirrored():
    """The rule reads ``FB`` against ``finetune`` from ``finetune`` against ``FB``: the same
    paired test, its gain and interval negated (a plan may write either)."""
    gains = {(W, "finetune"): [LEVEL, LEVEL], (W, FB): [LEVEL, LEVEL],
             (K, "finetune"): [LEVEL, LEVEL], (K, FB): [LEVEL, LEVEL],
             (K, W): [LEVEL, LEVEL],
             ("finetune", FB): [(-30.0, -50.0, 0.01), (0.0, -10.0, 1.0)]}
    assert pick(_plan(), _family(gains))[0] == FB  # finetune loses 30 [-50, -10] to it
    gains["finetune", FB] = [(-30.0, -50.0, 0.01), LEVEL]  # mirrored: -5 [-20, +10] on B
    assert pick(_plan(), _family(gains))[0] == "finetune"


def test_the_committed_sharp_test_plan_can_be_decided():
    """Every comparison the sharp test's pick rule reads is in its family, either way."""
    from pathlib import Path

    plan = Plan.read(Path(__file__).resolve().parents[1] / "docs" / "sharp_test.json")
    tests = [_test(p, m, a, *LEVEL) for p in plan.protocols for m, a in plan.comparisons]
    chosen, _ = pick(plan, tests)
    assert chosen == plan.fallback


def test_runs_are_bound_to_the_plan_they_were_made_for(tmp_path):
    # before, a plan edited after its runs (a margin of -1000 instead of 0) was analysed
    # over them with --analyse-only, and nothing said the plan had changed
    from ilpss.experiments.confirm import PLAN_RECORD, bind_plan, plan_digest

    plan = json.loads((DOCS / "decisive_test.json").read_text())
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(plan))
    runs = tmp_path / "runs"
    bind_plan(runs, path)  # the first time: recorded
    assert (runs / PLAN_RECORD).is_file()
    path.write_text(json.dumps(plan, indent=4))  # the same plan, laid out otherwise
    bind_plan(runs, path)
    assert plan_digest(path) == plan_digest(DOCS / "decisive_test.json")
    edited = {**plan, "title": plan["title"] + " (edited)"}
    path.write_text(json.dumps(edited))
    with pytest.raises(ValueError, match=r"not the plan the runs in .* were made for .* "
                                         r"it differs: title: "):
        bind_plan(runs, path)


def test_analysing_runs_that_are_not_there_makes_no_folder(tmp_path, capsys):
    # before, --analyse-only with a mistyped --runs made that folder (and its parents)
    with pytest.raises(SystemExit) as exit_info:
        main([str(DOCS / "decisive_test.json"), "--runs", str(tmp_path / "typo" / "deep"),
              "--analyse-only", "--force"])
    assert exit_info.value.code == 1
    assert "no such folder of runs to analyse" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
