"""Every results page in docs/ is recomputed from the per-seed numbers committed beside it
(docs/data) and gives the page that is committed; no page stands without its numbers."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from markdown_tables import table_after

from ilpss.experiments import confirm, results_doc

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"

CONFIRMATORY_PAGES = [
    ("decisive_test.md", "decisive_test.json", "decisive_test"),
]
FAMILY_LINE = re.compile(r"^\d+ (?:one-sided )?tests in (?:the family|\d+ families)", re.MULTILINE)
"""The line every page of ``ilpss-confirm`` opens its table with."""


def _kept(stem: str) -> bool:
    return (DOCS / "data" / f"{stem}.json").is_file()


def test_every_confirmatory_page_in_docs_has_its_numbers_beside_it():
    pages = {page.name for page in DOCS.glob("*.md") if FAMILY_LINE.search(page.read_text())}
    assert pages == {page for page, _, _ in CONFIRMATORY_PAGES}
    for page, plan, stem in CONFIRMATORY_PAGES:
        assert (DOCS / plan).is_file() and _kept(stem), page
        assert (DOCS / "data" / f"{stem}.csv.gz").is_file(), page


def test_the_results_page_has_its_numbers_beside_it():
    assert _kept("results") and (DOCS / "data" / "results.csv.gz").is_file()


@pytest.mark.slow
@pytest.mark.parametrize("page, plan, stem", CONFIRMATORY_PAGES)
def test_a_confirmatory_page_is_what_its_committed_numbers_give(tmp_path, page, plan, stem):
    out = tmp_path / page
    assert confirm.main([str(DOCS / plan), "--from-data", str(DOCS / "data" / stem),
                         "--out", str(out)]) == 0
    assert out.read_text() == (DOCS / page).read_text()


def _tables(text: str) -> list[str]:
    return [line for line in text.splitlines() if line.startswith("|")]


@pytest.mark.slow
def test_the_results_pages_tables_are_what_its_committed_numbers_give(tmp_path):
    assert results_doc.main(["--from-data", str(DOCS / "data" / "results"), "--docs",
                             str(tmp_path), "--runs", str(tmp_path / "runs"), "--quiet"]) == 0
    assert not (tmp_path / "runs").exists()  # nothing is run: no folder of runs made
    committed = _tables((DOCS / "results.md").read_text())
    assert len(committed) > 100
    assert _tables((tmp_path / "results.md").read_text()) == committed


@pytest.mark.slow
def test_the_larger_drills_page_is_what_its_committed_numbers_give(tmp_path, monkeypatch):
    from ilpss.experiments import larger_drill

    monkeypatch.chdir(DOCS)  # as the page says to regenerate it
    assert larger_drill.main(["--from-data", "data/larger_drill", "--docs", str(tmp_path)]) == 0
    made = (tmp_path / "larger_drill.md").read_text().splitlines()
    kept = (DOCS / "larger_drill.md").read_text().splitlines()
    # One line differs by folder: the metrics note links statistics.md beside the page.
    assert [a for a, b in zip(made, kept, strict=True) if a != b and "statistics.md" not in a] == []


def test_the_keepaway_page_is_what_its_committed_numbers_give(tmp_path):
    """Every keepaway scenario kept in docs/data (3v2 and 4v3) has its section, as the
    committed page shows it."""
    import shutil

    from ilpss.experiments import keepaway

    shutil.copytree(DOCS / "data", tmp_path / "data")
    keepaway.main(["--from-data", str(tmp_path)])
    made = (tmp_path / "keepaway.md").read_text()
    assert made == (DOCS / "keepaway.md").read_text()
    for scenario in keepaway.read_results(DOCS / "data"):
        assert f"## `{scenario}`" in made


def test_the_learning_curves_page_is_what_its_committed_numbers_give(tmp_path):
    import shutil

    from ilpss.experiments import learning_curves

    shutil.copytree(DOCS / "data", tmp_path / "data")
    learning_curves.main(["--from-data", str(tmp_path)])
    made = (tmp_path / "learning_curves.md").read_text()
    assert made == (DOCS / "learning_curves.md").read_text()
    for scenario in ("drill_1v1", "drill_3v3"):
        assert f"## `{scenario}`" in made


def test_a_changed_number_is_refused_by_its_digest(tmp_path, capsys):
    import json
    import shutil

    from ilpss.experiments import keepaway

    shutil.copytree(DOCS / "data", tmp_path / "data")
    path = tmp_path / "data" / "keepaway_3v2.json"
    kept = json.loads(path.read_text())
    kept["record"]["per_seed"]["learned"][0] += 1.0
    path.write_text(json.dumps(kept))
    with pytest.raises(SystemExit) as exit_info:
        keepaway.main(["--from-data", str(tmp_path)])
    assert exit_info.value.code == 1 and "sha256 does not match" in capsys.readouterr().err


def test_the_discussions_table_of_the_decisive_run_is_its_pages():
    """discussion.md's table of the pick family quotes docs/decisive_test.md (which the
    test above recomputes from its kept numbers): each test's gain and interval, Holm p,
    whether it is shown and its pilot effect."""
    page = table_after((DOCS / "decisive_test.md").read_text(), "| test | family |")
    by_name = {row[0]: row for row in page if row[1] == "`pick`"}
    quoted = table_after((DOCS / "discussion.md").read_text(),
                         "| test | gain [95% CI] | Holm-adjusted p | pilot |")
    assert [row[0].replace(" (margin 30)", "") for row in quoted] == list(by_name)
    for name, gain, holm, pilot in quoted:
        row = by_name[name.replace(" (margin 30)", "")]
        assert gain == row[6] and pilot == row[11].split(" (")[0], name
        assert holm == (row[9] if row[10] == "yes" else f"{row[9]}, not shown"), name
