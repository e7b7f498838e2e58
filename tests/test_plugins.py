"""A team from a distribution that is not ours is discovered through its entry point."""

from __future__ import annotations

import textwrap

import pytest

import soccer_drill
from soccer_drill import teams


@pytest.fixture
def foreign_distribution(tmp_path, monkeypatch):
    """An installed-looking distribution `thirdparty-teams` declaring one team."""
    (tmp_path / "thirdparty_teams.py").write_text(textwrap.dedent('''
        from soccer_drill import Command, Skill

        class Wall:
            """Both defenders stand on the goal line's centre."""

            def reset(self, view, rng):
                self.players = view.players

            def act(self, view):
                return {p: Command(Skill.MOVE_TO, (15.0 + 5 * i, 1.0))
                        for i, p in enumerate(self.players)}
    '''))
    info = tmp_path / "thirdparty_teams-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: thirdparty-teams\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[soccer_drill.opponents]\nwall = thirdparty_teams:Wall\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    teams.refresh()
    yield
    monkeypatch.undo()
    teams.refresh()


def test_foreign_team_is_discovered_and_plays(foreign_distribution, monkeypatch):
    assert "wall" in teams.team_ids()
    assert teams.available_teams()["wall"] == "Both defenders stand on the goal line's centre."
    env = soccer_drill.HolderEnv(opponent="wall")
    env.reset(seed=0)
    for _ in range(5):
        env.step(2)
    assert env.drill_state.pos[2][1] < 5.0  # the wall went to its line
    monkeypatch.undo()  # "uninstall" the distribution
    teams.refresh()
    assert "wall" not in teams.team_ids()


def test_broken_entry_point_is_reported_by_name(tmp_path, monkeypatch):
    info = tmp_path / "broken_teams-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: broken-teams\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[soccer_drill.opponents]\nbroken = no_such_module:Team\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    teams.refresh()
    try:
        with pytest.raises(teams.TeamError, match=r"team 'broken' \(no_such_module:Team\) failed to load"):
            soccer_drill.env(opponent="broken")
    finally:
        monkeypatch.undo()
        teams.refresh()


def test_register_for_notebooks():
    class Idle:
        """Stands still."""

        def reset(self, view, rng):
            self.players = view.players

        def act(self, view):
            return {p: soccer_drill.Command(soccer_drill.Skill.MOVE_TO, (17.5, 5.0))
                    for p in self.players}

    soccer_drill.register("idle_for_test", Idle, overwrite=True)
    assert "idle_for_test" in teams.team_ids()
    with pytest.raises(ValueError, match="already registered"):
        soccer_drill.register("idle_for_test", Idle)
    with pytest.raises(ValueError, match="team id must be a non-empty identifier"):
        soccer_drill.register("no spaces", Idle)


@pytest.mark.parametrize(
    ("behaviour", "message"),
    [
        ("raise", r"team 'sloppy' raised in act\(\) at cycle 0: RuntimeError\('no plan'\)"),
        ("foreign", r"team 'sloppy' must return a mapping with exactly the players it drives "
                    r"\['defender_0', 'defender_1'\], got \['attacker_1', 'defender_0'\]"),
        ("nan", r"team 'sloppy', player 'defender_1', cycle 0: MOVE_TO needs a finite"),
    ],
)
def test_misbehaving_plugin_is_named_by_its_id(tmp_path, monkeypatch, behaviour, message):
    (tmp_path / "sloppy_teams.py").write_text(textwrap.dedent('''
        import math
        from soccer_drill import Command, Skill

        class Sloppy:
            """Misbehaves on purpose."""

            def __init__(self, behaviour):
                self.behaviour = behaviour

            def reset(self, view, rng):
                self.players = view.players

            def act(self, view):
                if self.behaviour == "raise":
                    raise RuntimeError("no plan")
                if self.behaviour == "foreign":
                    return {"defender_0": Command(Skill.INTERCEPT),
                            "attacker_1": Command(Skill.INTERCEPT)}
                return {"defender_0": Command(Skill.INTERCEPT),
                        "defender_1": Command(Skill.MOVE_TO, (math.inf, 3.0))}
    '''))
    info = tmp_path / "sloppy_teams-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: sloppy-teams\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[soccer_drill.opponents]\nsloppy = sloppy_teams:Sloppy\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    teams.refresh()
    try:
        env = soccer_drill.HolderEnv(opponent="sloppy", opponent_params={"behaviour": behaviour})
        env.reset(seed=0)
        with pytest.raises(teams.TeamError, match=message):
            env.step(2)
    finally:
        monkeypatch.undo()
        teams.refresh()
