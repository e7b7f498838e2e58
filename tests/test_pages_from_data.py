"""Every results page in docs/ is recomputed from the per-seed numbers committed beside it
(docs/data), and gives the page that is committed."""

from __future__ import annotations

from pathlib import Path

import pytest

from ilpss.experiments import confirm, results_doc

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"

CONFIRMATORY_PAGES = [
    ("decisive_test.md", "decisive_test.json", "decisive_test"),
    ("confirmatory.md", "confirmatory.json", "confirmatory"),
    ("sharp_test.md", "sharp_test.json", "sharp_test"),
]


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
                             str(tmp_path), "--quiet"]) == 0
    committed = _tables((DOCS / "results.md").read_text())
    assert len(committed) > 100
    assert _tables((tmp_path / "results.md").read_text()) == committed
