"""``soccer-drill-teams``: list the installed opponent teams with their descriptions."""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from soccer_drill.teams import available_teams


def main(argv: Sequence[str] | None = None) -> int:
    """List the installed teams, one per line."""
    parser = argparse.ArgumentParser(prog="soccer-drill-teams", description=__doc__.split(":")[1].strip())
    parser.parse_args(argv)
    teams = available_teams()
    width = max(map(len, teams), default=0)
    for team_id, description in teams.items():
        print(f"{team_id:<{width}}  {description}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
