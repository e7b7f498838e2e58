"""The guides' ``ilpss-experiment`` commands pass every check the command makes before it
runs, not only its argument parser (``tests/test_readme.py`` parses the README's).

A whole command on a guide page or in the command's ``--help`` (one with ``--out``, in a
shell block or inline; a resume by ``--config`` needs its run first) is run
with the experiment itself replaced: its flags, settings, methods, baseline and report
are checked as a user who copies it would have them checked. The pages of results
(``results.md``, ``discussion.md``, ...) record the commands that made them, with the code
of their day, and are not guides: they are left alone. A placeholder of a guide
(``--set KEY=VALUE``) stands for a real setting here.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
GUIDES = [ROOT / "README.md", *(ROOT / "docs" / f"{name}.md" for name in (
    "architecture", "plugins", "scenarios", "statistics", "reliability", "integrations"))]
FENCE = re.compile(r"^```([\w-]*)[^\n]*\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)
INLINE = re.compile(r"`(ilpss-experiment [^`]*)`")
PLACEHOLDERS = {"KEY=VALUE": "n_kernels=2"}


def _whole(line: str) -> bool:
    """An ``ilpss-experiment`` command that starts a run (a resume by ``--config`` needs
    the run before it)."""
    return line.startswith("ilpss-experiment ") and "--out" in line and "--config" not in line


def _commands() -> list[tuple[str, str]]:
    """(page, command) of every whole ``ilpss-experiment`` command of the guides."""
    found = []
    for page in GUIDES:
        text = page.read_text(encoding="utf-8")
        lines = [line.removeprefix("$ ").strip() for m in FENCE.finditer(text)
                 for line in m.group(2).replace("\\\n", " ").splitlines()]
        lines += INLINE.findall(FENCE.sub("", text))
        found += [(page.name, line) for line in lines if _whole(line)]
    from ilpss.experiments import cli  # its --help shows its module docstring's examples

    found += [("ilpss-experiment --help", line.strip())
              for line in cli.__doc__.replace("\\\n", " ").splitlines() if _whole(line.strip())]
    return found


COMMANDS = _commands()


class _Checked(Exception):
    """Raised instead of running the experiment once the command's checks passed."""


def test_the_guides_have_commands_to_check():
    assert len(COMMANDS) >= 5


@pytest.mark.parametrize(("page", "command"), COMMANDS,
                         ids=[f"{p}:{c[17:60]}" for p, c in COMMANDS])
def test_a_guides_command_passes_the_checks_before_its_run(page, command, monkeypatch,
                                                           tmp_path):
    from ilpss.experiments import cli

    def checked(*args, **kwargs):
        raise _Checked

    monkeypatch.setattr(cli, "run_experiment", checked)
    monkeypatch.chdir(tmp_path)  # the --out folders are never made, but stay out of the tree
    argv = [PLACEHOLDERS.get(a, a) for a in shlex.split(command, comments=True)[1:]]
    try:
        cli.main(argv)
    except _Checked:
        return
    except SystemExit as exc:
        pytest.fail(f"{page}: `{command}` is refused by ilpss-experiment before it runs "
                    f"(exit status {exc.code}; its message is in the captured stderr)")
    pytest.fail(f"{page}: `{command}` returned without running")
