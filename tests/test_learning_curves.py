"""The learning-curve experiment: per-seed records kept and read back, the page and its
numbers written from them, the comparison with the best fixed rule on the same
episodes."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from ilpss.experiments import learning_curves
from soccer_drill.files import read_digested_json

DOCS = Path(__file__).resolve().parents[1] / "docs"


def test_the_best_rule_is_the_one_docs_scenarios_names() -> None:
    fixed = read_digested_json(DOCS / "data" / learning_curves.FIXED_RULES)
    rule, successes = learning_curves.best_rule(fixed, "drill_3v3")
    assert rule == "lane" and len(successes) == 300
    assert f"`{rule}` | {sum(successes) / 300:.0%}" in (DOCS / "scenarios.md").read_text()


@pytest.mark.slow
def test_a_small_run_keeps_its_records_and_writes_the_page(tmp_path) -> None:
    docs = tmp_path / "docs"
    (docs / "data").mkdir(parents=True)
    shutil.copy(DOCS / "data" / learning_curves.FIXED_RULES, docs / "data")
    args = ["--scenario", "drill_1v1", "--seeds", "1000-1001", "--episodes", "5",
            "--every", "3", "--eval-episodes", "2", "--runs", str(tmp_path / "runs"),
            "--out", str(docs)]
    learning_curves.main(args)
    kept = read_digested_json(docs / "data" / "learning_curve_drill_1v1.json")
    result = kept["result"]
    assert result["points"] == [0, 3, 5]
    assert [len(s) for s in result["training_success"]] == [5, 5]
    assert all(len(e) == 2 for seed in result["evaluation_success"] for e in seed)
    page = (docs / "learning_curves.md").read_text()
    assert "## `drill_1v1`" in page and "`dribble`" in page and "| 5 |" in page
    records = sorted((tmp_path / "runs").rglob("seed_*.json"))
    assert len(records) == 2
    before = [r.stat().st_mtime_ns for r in records]
    learning_curves.main(args)  # a rerun reads the kept records
    assert [r.stat().st_mtime_ns for r in records] == before
    assert read_digested_json(records[0])["schema_version"] == learning_curves.SEED_SCHEMA
    # a kept seed changed by hand is refused, naming it and what to do (before, read as
    # it was, without a digest)
    text = records[0].read_text()
    records[0].write_text(text.replace('"seed": 1000', '"seed": 7'))
    with pytest.raises(SystemExit) as exit_info:
        learning_curves.main(args)
    assert exit_info.value.code == 1
