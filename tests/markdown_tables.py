"""Reading the tables of the project's Markdown pages, for the tests that hold a quoted
figure to the page it comes from."""

from __future__ import annotations


def cells(line: str) -> list[str]:
    """A table row's cells, stripped of spaces and bold marks."""
    return [c.strip().strip("*").strip() for c in line.strip().strip("|").split("|")]


def table_after(text: str, heading: str) -> list[list[str]]:
    """The rows (cells) of the first table at or after ``heading`` (a section's heading, or
    the start of the table's header line), its header and rule left out."""
    lines = text[text.index(heading):].splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("|"))
    rows = []
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        rows.append(cells(line))
    return rows
