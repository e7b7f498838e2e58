"""``soccer-drill-teams``: list the installed opponent teams with their descriptions.

Every task's teams are listed (the drill's defenders, then keepaway's takers), or one
task's with ``--task``; any team may be named in any environment.

A plugin that cannot be used (it fails to import, is not callable, or declares an
invalid id) is reported on standard error with its error, after the teams that
work, and the exit status is then 1. Warnings (e.g. an id declared by two
distributions) go to standard error too.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from collections.abc import Sequence

from soccer_drill import available_teams
from soccer_drill.teams import PluginWarning, broken_teams, refresh


def main(argv: Sequence[str] | None = None) -> int:
    """List the installed teams, one per line; 1 if some plugin is broken."""
    summary = __doc__.split("\n\n")[0].split(":", 1)[1].strip()
    parser = argparse.ArgumentParser(
        prog="soccer-drill-teams", description=summary,
        epilog=__doc__.split("\n\n", 1)[1].strip(),
    )
    parser.add_argument("--task", default=None,
                        help="list only this task's teams, e.g. keepaway (default: every "
                             "task's)")
    args = parser.parse_args(argv)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", PluginWarning)
        refresh()  # discover afresh, so discovery's warnings are seen here
        try:
            teams = available_teams(args.task)
        except ValueError as exc:  # an unknown task: the message names the known ones
            parser.error(str(exc))
        broken = broken_teams()
    width = max(map(len, teams), default=0)
    for team_id, description in teams.items():
        print(f"{team_id:<{width}}  {description}")
    errors = list(broken.values())
    notes = [str(w.message) for w in caught if issubclass(w.category, PluginWarning)]
    for note in dict.fromkeys(notes):  # in order, once each
        if note not in errors:
            print(f"soccer-drill-teams: warning: {note}", file=sys.stderr)
    for error in errors:
        print(f"soccer-drill-teams: error: {error}", file=sys.stderr)
    return 1 if broken else 0


if __name__ == "__main__":
    raise SystemExit(main())
