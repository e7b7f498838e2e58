"""The documentation's pictures, regenerated from the code in one command.

Command line::

    soccer-drill-gallery [--docs docs] [--notebooks]

Writes ``<docs>/gifs/<team>.gif`` for each team of :data:`GALLERY` (the holder rule and
seed ``docs/opponents.md`` shows it with) and ``<docs>/gifs/side_by_side.gif``, the
README's leading picture (:data:`LEADING`: two rules on the same seed against the paper's
held-out team). With ``--notebooks`` it also executes ``notebooks/*.ipynb`` in place and
keeps their outputs (figures and GIFs inline; needs the ``test`` extra's nbclient). Every
path is checked, and the notebooks' folder and packages, before any GIF is written.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from collections.abc import Sequence
from pathlib import Path

from soccer_drill.envs.holder import HolderEnv
from soccer_drill.files import check_output_file
from soccer_drill.rendering.gif import check_writable_file, stopped_by_ctrl_c, write_episode_gif
from soccer_drill.rendering.side_by_side import policy_panel, write_side_by_side
from soccer_drill.teams.registry import TeamError

GALLERY: dict[str, tuple[str, int]] = {
    "interceptors_press": ("late_pass", 1),
    "interceptors_cover": ("shield_pass", 1),
    "interceptor_guard": ("early_pass", 1),
    "goal_guards": ("early_pass", 1),
    "chasers": ("late_pass", 1),
}
"""Each gallery team's holder rule (the best fixed rule against it, by
``soccer-drill-calibrate``) and episode seed, as ``docs/opponents.md`` states them."""
LEADING: tuple[str, tuple[str, ...], tuple[int, ...]] = (
    "goal_guards", ("pass_first", "early_pass"), (1,))
"""The README's picture: the team, the rules side by side and the seeds they play."""
NOTEBOOKS = ("01_drill_tour.ipynb", "02_ilpss_step_by_step.ipynb")


def write_gallery(docs: Path) -> dict[str, str]:
    """Write the gallery's GIFs under ``docs/gifs``; return each file's outcome(s).

    Every file's path is checked first (:func:`check_output_file`), so a path that cannot
    be written (a folder in a file's place) is refused before any episode is played."""
    gifs = docs / "gifs"
    for name in (*(f"{team}.gif" for team in GALLERY), "side_by_side.gif"):
        check_output_file(gifs / name)
    check_writable_file(gifs / "side_by_side.gif")
    written = {}
    for team, (rule, seed) in GALLERY.items():
        info = write_episode_gif(gifs / f"{team}.gif", team, seed, rule)
        written[f"{team}.gif"] = info["outcome"]
    team, rules, seeds = LEADING
    write_side_by_side(gifs / "side_by_side.gif", [policy_panel(r) for r in rules],
                       lambda: HolderEnv(opponent=team, render_mode="rgb_array_list"), seeds)
    written["side_by_side.gif"] = f"{' | '.join(rules)} against {team}"
    return written


def without_warnings(notebook) -> None:
    """Drop the cells' ``stderr`` streams: the warnings of the machine that ran them (its
    paths, its packages' versions), not what the notebook shows."""
    for cell in notebook.cells:
        if cell.cell_type == "code":
            cell.outputs = [o for o in cell.outputs
                            if not (o.output_type == "stream" and o.get("name") == "stderr")]


def check_notebooks(folder: Path) -> None:
    """``ValueError`` unless ``folder`` holds every notebook of :data:`NOTEBOOKS` and the
    packages that execute them are installed: said before any GIF is written."""
    missing = [name for name in NOTEBOOKS if not (folder / name).is_file()]
    if missing:
        raise ValueError(f"--notebooks {str(folder)!r}: no {', '.join(missing)} there; give "
                         f"the folder holding {', '.join(NOTEBOOKS)} (default notebooks)")
    absent = [m for m in ("nbformat", "nbclient") if importlib.util.find_spec(m) is None]
    if absent:
        raise ValueError(f"--notebooks needs {' and '.join(absent)} (the test extra: pip "
                         "install -e '.[test]')")


def run_notebooks(folder: Path, timeout: float = 900) -> list[Path]:
    """Execute each notebook of :data:`NOTEBOOKS` in ``folder`` top to bottom in a fresh
    kernel and write it back with its outputs (atomically)."""
    import nbformat
    from nbclient import NotebookClient

    from soccer_drill.files import atomic_write_bytes

    done = []
    for name in NOTEBOOKS:
        path = folder / name
        notebook = nbformat.read(path, as_version=4)
        NotebookClient(notebook, timeout=timeout, kernel_name="python3",
                       resources={"metadata": {"path": str(folder)}}).execute()
        without_warnings(notebook)
        atomic_write_bytes(path, (nbformat.writes(notebook) + "\n").encode("utf-8"))
        done.append(path)
    return done


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point ``soccer-drill-gallery``."""
    parser = argparse.ArgumentParser(prog="soccer-drill-gallery",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--docs", type=Path, default=Path("docs"),
                        help="the documentation folder, which exists (its gifs/ is written; "
                        "default %(default)s)")
    parser.add_argument("--notebooks", type=Path, nargs="?", const=Path("notebooks"),
                        default=None, help="also execute the notebooks of this folder "
                        "(default notebooks/) and keep their outputs")
    args = parser.parse_args(argv)
    if not args.docs.is_dir():
        parser.error(f"--docs must name an existing folder, got {str(args.docs)!r}")
    try:
        if args.notebooks is not None:
            check_notebooks(args.notebooks)
    except ValueError as exc:
        parser.error(str(exc))
    with stopped_by_ctrl_c(parser.prog, f"the GIFs written in {args.docs / 'gifs'} so far "
                           "are kept (each whole), and the notebooks executed so far"):
        return _write(parser, args)


def _write(parser: argparse.ArgumentParser, args: argparse.Namespace) -> int:
    """The gallery's GIFs, then the notebooks asked for; 1 on a failing write or team."""
    try:
        written = write_gallery(args.docs)
    except ValueError as exc:  # a path that cannot be written, found before any episode
        parser.error(str(exc))
    except (OSError, TeamError) as exc:
        print(f"{parser.prog}: error: {exc}", file=sys.stderr)
        return 1
    try:
        for name, what in written.items():
            print(f"wrote {args.docs / 'gifs' / name}: {what}")
        if args.notebooks is not None:
            for path in run_notebooks(args.notebooks):
                print(f"executed {path}")
    except (OSError, TeamError) as exc:
        print(f"{parser.prog}: error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
