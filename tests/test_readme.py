"""README.md tells the truth: its Python blocks run, and its shell commands exist.

Every fenced ``python`` block runs in a fresh namespace, in an empty temporary working
directory, with the team registry isolated (blocks may register teams). Shell blocks
(``bash``/``sh``/``shell``/``console``) are not run: each command must be a make target
of the Makefile or a console script of ``[project.scripts]``; a console script's
arguments are parsed by its own argument parser (which then stops it), so a renamed
flag or a wrong choice fails here without running an experiment.
"""

from __future__ import annotations

import argparse
import importlib
import inspect
import re
import shlex
import tomllib
from decimal import ROUND_HALF_UP, Decimal
from importlib.metadata import entry_points
from pathlib import Path

import pytest
from markdown_tables import table_after

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
FENCE = re.compile(r"^```([\w-]*)[^\n]*\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)
SHELL = {"bash", "sh", "shell", "console"}


def _blocks(languages: set[str]) -> list[tuple[int, str]]:
    """(first line number, code) of every fenced block in one of ``languages``."""
    text = README.read_text(encoding="utf-8")
    return [
        (text.count("\n", 0, m.start()) + 2, m.group(2))
        for m in FENCE.finditer(text)
        if m.group(1).lower() in languages
    ]


PYTHON_BLOCKS = _blocks({"python", "py"})


def _commands() -> list[tuple[int, list[str]]]:
    """(line number, argv) of every command line in the shell blocks, comments removed."""
    out = []
    for first, code in _blocks(SHELL):
        pending, start = "", first
        for offset, line in enumerate(code.splitlines()):
            if not pending:
                start = first + offset
            line = line.removeprefix("$ ")
            if line.rstrip().endswith("\\"):
                pending += line.rstrip()[:-1] + " "
                continue
            argv = shlex.split(pending + line, comments=True)
            pending = ""
            if argv:
                out.append((start, argv))
    return out


COMMANDS = _commands()


def _make_targets() -> set[str]:
    text = (ROOT / "Makefile").read_text(encoding="utf-8")
    targets = set()
    for m in re.finditer(r"^([A-Za-z0-9_.\- ]+?)\s*::?(?!=)", text, re.MULTILINE):
        targets.update(t for t in m.group(1).split() if not t.startswith("."))
    return targets


def _project_scripts() -> dict[str, str]:
    with (ROOT / "pyproject.toml").open("rb") as f:
        return tomllib.load(f)["project"].get("scripts", {})


def test_readme_has_code_to_check():
    assert PYTHON_BLOCKS, "README.md has no ```python blocks"
    assert COMMANDS, "README.md has no shell commands"


@pytest.mark.parametrize("code", [c for _, c in PYTHON_BLOCKS],
                         ids=[f"line{n}" for n, _ in PYTHON_BLOCKS])
def test_python_block_runs(code, tmp_path, monkeypatch, team_registry):
    monkeypatch.chdir(tmp_path)
    exec(compile(code, str(README), "exec"), {"__name__": "__readme__"})


class _Parsed(Exception):
    """Raised instead of running a console script once its arguments parsed."""


@pytest.mark.parametrize("argv", [a for _, a in COMMANDS],
                         ids=[f"line{n}:{' '.join(a[:2])}" for n, a in COMMANDS])
def test_shell_command_exists(argv, monkeypatch):
    command, args = argv[0], argv[1:]
    if command == "make":
        targets = _make_targets()
        wanted = [a for a in args if not a.startswith("-") and "=" not in a]
        assert wanted, "a bare `make` in README.md: name the target"
        missing = sorted(set(wanted) - targets)
        assert not missing, f"make target(s) {missing} not in the Makefile ({sorted(targets)})"
        return
    scripts = _project_scripts()
    assert command in scripts, (
        f"README.md runs {command!r}, which is neither a make target nor a console script "
        f"of [project.scripts] ({sorted(scripts)})"
    )
    installed = entry_points(group="console_scripts", name=command)
    assert installed, f"{command} is in pyproject.toml but not installed: pip install -e ."
    module_name, _, function = scripts[command].partition(":")
    module = importlib.import_module(module_name)
    assert "argparse" in inspect.getsource(module), (
        f"{command} does not use argparse; teach this test how to check it without running it"
    )
    original = argparse.ArgumentParser.parse_args

    def parse_then_stop(self, *a, **kw):
        raise _Parsed(original(self, *a, **kw))

    monkeypatch.setattr(argparse.ArgumentParser, "parse_args", parse_then_stop)
    try:
        getattr(module, function)(args)
    except _Parsed:
        return
    except SystemExit as exc:
        pytest.fail(
            f"README.md: `{' '.join(argv)}` is refused by {command}'s parser "
            f"(exit status {exc.code}; its message is in the captured stderr)"
        )
    pytest.fail(f"{command} returned without parsing its arguments")


def test_the_demo_paragraph_names_the_method_the_demo_shows_and_its_files():
    """The paragraph on ``make demo`` names the recommended method as the demo declares it
    (``ilpss.experiments.demo.RECOMMENDED``) and the files the demo writes."""
    from ilpss.experiments import demo

    text = README.read_text(encoding="utf-8")
    start = text.index("`make demo` runs")
    paragraph = text[start:text.index("\n\n", start)]
    assert f"`--methods {demo.RECOMMENDED}`" in paragraph
    assert "`RECOMMENDED` in `ilpss/experiments/demo.py`" in paragraph
    assert set(re.findall(r"results/demo/([\w.]+)", paragraph)) == set(demo.OUTPUTS)


def test_the_readme_team_holds_its_own_defenders_starts_at_every_size(team_registry):
    """The README's ``Statues`` keeps each defender where it started, in drills of any size
    (it read attacker rows as defenders' where there are more than two attackers)."""
    import numpy as np

    from soccer_drill import DrillConfig, HolderEnv

    code = next(c for _, c in PYTHON_BLOCKS if "class Statues" in c)
    space = {"__name__": "__readme__"}
    exec(compile(code, str(README), "exec"), space)
    for config in (DrillConfig(), DrillConfig(attackers=3, defenders=3),
                   DrillConfig(attackers=3, defenders=2)):
        env = HolderEnv(opponent="statues", config=config)
        env.reset(seed=0)
        start = np.array(env.drill_state.pos[config.attackers:config.attackers + config.defenders])
        env.step(0)  # a HOLD: four cycles
        moved = np.array(env.drill_state.pos[config.attackers:config.attackers + config.defenders]) - start
        assert np.abs(moved).max() < 0.5, (config, moved)


def _numbers(cell: str) -> list[float]:
    return [float(x) for x in re.findall(r"[+-]?\d+(?:\.\d+)?", cell)]


def _close(readme_cell: str, page_cell: str) -> bool:
    """The README's rounded figures are the page's (one decimal there, whole numbers here)."""
    ours, theirs = _numbers(readme_cell), _numbers(page_cell)
    return len(ours) == len(theirs) and all(abs(a - b) <= 0.55 for a, b in zip(ours, theirs, strict=False))


def test_the_headline_figures_are_the_decisive_pages():
    """Every figure of the README's two headline tables is the one docs/decisive_test.md
    (recomputed from its kept per-seed numbers by tests/test_pages_from_data.py) gives:
    the pick family's gains, intervals and Holm-adjusted p, and every method's gain over
    learning anew per stream, "-" where the method did not run on that stream."""
    text = README.read_text(encoding="utf-8")
    page = (ROOT / "docs" / "decisive_test.md").read_text(encoding="utf-8")
    family = {(row[2], row[3], row[4]): row for row in table_after(page, "| test | family |")}
    headline = table_after(text, "| stream (seeds) |")
    assert len(headline) == 4
    for stream, gain, holm, _ in headline:
        protocol = re.search(r"\(([A-Z]), \d+", stream).group(1)
        row = family[(protocol, "`whole_policies_ft_bounded_cut`", "`finetune_bounded`")]
        assert _close(gain, row[6]), (stream, gain, row[6])
        assert gain == _exact_gain("decisive_test", protocol, "whole_policies_ft_bounded_cut",
                                   "finetune_bounded"), (stream, gain)
        assert holm == row[9] and row[10] == "yes", (stream, holm, row[9], row[10])
    reported = {(row[0], row[1]): row[3]
                for row in table_after(page, "Reported comparisons, outside the family")
                if row[2] == "`scratch`"}
    gains = table_after(text, "| method (`--methods`) | S | A | B | R |")
    assert len(gains) >= 5
    for row in gains:
        method = re.findall(r"`(\w+)`", row[0])[-1]
        for protocol, cell in zip("SABR", row[1:], strict=True):
            page_cell = reported.get((protocol, f"`{method}`"))
            if cell == "-":
                assert page_cell is None, (method, protocol, page_cell)
            else:  # rounded once, from the kept numbers (the page's cell rounded again
                # could be one off: +85.46 is +85.5 there and +85 here)
                assert page_cell is not None and _close(cell, page_cell), (method, protocol, cell)
                exact = _exact_gain("decisive_test", protocol, method, "scratch")
                assert cell.replace("**", "") == exact, (method, protocol, cell, exact)


def _exact_gain(data: str, protocol: str, method: str, against: str) -> str:
    """``method``'s gain over ``against`` in total reward, from docs/data/<data>.csv.gz
    (each seed's curve averaged over its targets, then summed; paired by seed, a 95%
    t-interval), rounded to whole numbers half away from zero, as the README quotes it."""
    import csv
    import gzip
    from collections import defaultdict

    import numpy as np
    from scipy import stats

    totals: dict[str, dict[int, list[float]]] = {method: defaultdict(list),
                                                  against: defaultdict(list)}
    with gzip.open(ROOT / "docs" / "data" / f"{data}.csv.gz", "rt", encoding="utf-8") as f:
        for r in csv.DictReader(f):
            if r["kind"] == "curve" and r["protocol"] == protocol and r["method"] in totals:
                totals[r["method"]][int(r["seed"])].append(
                    sum(float(x) for x in r["values"].split()))
    seeds = sorted(totals[method])
    assert seeds == sorted(totals[against])
    d = np.array([np.mean(totals[method][s]) - np.mean(totals[against][s]) for s in seeds])
    half = stats.t.ppf(0.975, len(d) - 1) * d.std(ddof=1) / np.sqrt(len(d))
    m, lo, hi = (int(Decimal(repr(float(x))).quantize(Decimal(1), ROUND_HALF_UP))
                 for x in (d.mean(), d.mean() - half, d.mean() + half))
    return f"{m:+d} [{lo:+d}, {hi:+d}]"


@pytest.mark.parametrize(("pair", "methods"), [
    ("ILPSS-FT (fine-tuned start, options valued by their policies) - whole past policies, "
     "ILPSS-FT's settings", ("ilpss_ft", "whole_policies_ft")),
    ("fine-tuning chained (from its own latest policy), values bounded - fine-tuning from "
     "the latest source, values bounded", ("finetune_chained_bounded", "finetune_bounded"))])
def test_the_matched_comparisons_quoted_are_the_results_pages(pair, methods):
    """The kernels' and chaining's matched comparisons in the README's list are the
    total-reward cells of docs/results.md (recomputed from its kept numbers by
    tests/test_pages_from_data.py), protocol by protocol."""
    text = " ".join(README.read_text(encoding="utf-8").split())
    page = (ROOT / "docs" / "results.md").read_text(encoding="utf-8")
    sections = re.split(r"^## Protocol ([A-Z]):", page, flags=re.MULTILINE)[1:]
    quoted = 0
    for protocol, body in zip(sections[::2], sections[1::2], strict=True):
        (row,) = [line for line in body.splitlines() if line.startswith(f"| {pair} |")]
        cell = row.split(" | ")[-1]
        exact = _exact_gain("results", protocol, *methods)  # rounded once, from the data
        gain = " ".join(re.findall(r"[-+]\d+\.\d+", cell)[:3])  # the page's, 1 decimal
        assert _close(exact, gain), (protocol, exact, cell)
        assert f"{exact} on {protocol}" in text, (protocol, exact)
        quoted += 1
    assert quoted == 4


def test_the_source_distribution_holds_what_its_tests_read():
    """Before, the sdist held tests/test_*.py alone (setuptools' default): not conftest.py,
    the helper modules, tests/data, nor the docs, benchmarks and notebooks the tests read,
    so its test suite could not be collected."""
    rules = [line.split() for line in (ROOT / "MANIFEST.in").read_text().splitlines()
             if line.strip() and not line.startswith("#")]
    grafted = {words[1] for words in rules if words[0] == "graft"}
    assert {"tests", "docs", "benchmarks", "notebooks"} <= grafted
    assert ["include", "Makefile"] in rules
