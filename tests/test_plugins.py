"""A team from a distribution that is not ours is discovered through its entry point."""

from __future__ import annotations

import importlib
import sys
import textwrap
import warnings

import pytest

import opponents
import soccer_drill
from opponents import cli as opponents_cli
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
    assert soccer_drill.available_teams()["wall"] == "Both defenders stand on the goal line's centre."
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
        with pytest.raises(soccer_drill.TeamError, match=r"team 'broken' \(no_such_module:Team\) failed to load"):
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
        with pytest.raises(soccer_drill.TeamError, match=message):
            env.step(2)
    finally:
        monkeypatch.undo()
        teams.refresh()


# ------------------------------------------------------- one bad plugin stays one
_GOOD_TEAM = '''
from soccer_drill import Command, Skill

class Wall:
    """Both defenders stand on the goal line."""

    def reset(self, view, rng):
        self.players = view.players

    def act(self, view):
        return {p: Command(Skill.MOVE_TO, (15.0 + 5 * i, 1.0)) for i, p in enumerate(self.players)}
'''


@pytest.fixture
def install(tmp_path, monkeypatch):
    """``install(dist, {module: source}, entry_points_lines)``: a fake installed distribution.

    Each distribution gets its own folder on ``sys.path``, in installation order (the
    first installed is found first; ``first=True``: before every other distribution). Everything is undone after the test.
    """
    count = 0

    def _install(dist: str, modules: dict[str, str], lines: str, first: bool = False) -> None:
        nonlocal count
        count += 1
        root = tmp_path / f"site{count}"
        root.mkdir()
        for module, source in modules.items():
            (root / f"{module}.py").write_text(textwrap.dedent(source))
        info = root / f"{dist.replace('-', '_')}-0.1.dist-info"
        info.mkdir()
        (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: 0.1\n")
        (info / "entry_points.txt").write_text(f"[soccer_drill.opponents]\n{lines}\n")
        path = [str(root), *sys.path] if first else [*sys.path, str(root)]
        monkeypatch.setattr(sys, "path", path)
        importlib.invalidate_caches()
        teams.refresh()

    yield _install
    for module in [m for m in sys.modules if m.startswith("plugin_")]:
        del sys.modules[module]
    monkeypatch.undo()
    teams.refresh()


def test_plugins_that_fail_to_import_leave_the_other_teams_listed_and_built(install, capsys):
    install("good-teams", {"plugin_good": _GOOD_TEAM}, "wall = plugin_good:Wall")
    install("bad-teams", {"plugin_raises": "raise ImportError('needs libfoo')",
                          "plugin_exits": "import sys\nsys.exit('no display')"},
            "raises = plugin_raises:Team\nexits = plugin_exits:Team")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        listed = soccer_drill.available_teams()
    assert {"chasers", "parametric", "wall"} <= set(listed)
    assert not {"raises", "exits"} & set(listed)
    assert {type(w.message).__name__ for w in caught} == {"PluginWarning"}
    messages = " | ".join(str(w.message) for w in caught)
    assert "team 'raises' (plugin_raises:Team) failed to load: ImportError('needs libfoo')" in messages
    assert "team 'exits' (plugin_exits:Team) failed to load: SystemExit('no display')" in messages
    broken = teams.broken_teams()
    assert sorted(broken) == ["exits", "raises"]
    assert "SystemExit('no display')" in broken["exits"]
    # The others still build and play; the broken ones fail by name.
    env = soccer_drill.HolderEnv(opponent="wall")
    env.reset(seed=0)
    env.step(2)
    soccer_drill.make_team("chasers")
    with pytest.raises(soccer_drill.TeamError, match=r"team 'raises' \(plugin_raises:Team\) failed"):
        soccer_drill.env(opponent="raises")
    # The command lists the good teams, reports the broken ones and exits with 1.
    assert opponents_cli.main([]) == 1
    out, err = capsys.readouterr()
    assert "wall " in out and "chasers " in out and "raises" not in out
    assert "error: the entry point of team 'exits' (plugin_exits:Team) failed to load" in err
    assert "error: the entry point of team 'raises' (plugin_raises:Team) failed to load" in err


def test_a_team_id_declared_by_two_distributions_warns_naming_both(install):
    install("first-teams", {"plugin_first": _GOOD_TEAM}, "wall = plugin_first:Wall")
    with pytest.warns(UserWarning, match=(
            r"team id 'wall' is declared twice, by distribution 'first-teams' "
            r"\(plugin_first:Wall\) and by distribution 'second-teams' \(plugin_second:Wall\); "
            r"using the first \(give the other team an id of its own\)")):
        install("second-teams", {"plugin_second": _GOOD_TEAM}, "wall = plugin_second:Wall")
    assert soccer_drill.make_team("wall").__module__ == "plugin_first"


def test_a_plugin_cannot_replace_one_of_the_project_s_own_teams(install):
    # Found before the project's own distribution on the path, and still not used.
    with pytest.warns(UserWarning, match=(
            r"team id 'chasers' is declared twice, by distribution 'soccer-drill-ilpss' "
            r"\(opponents.chasers:Chasers\) and by distribution 'shadow-teams' "
            r"\(plugin_shadow:Wall\); using this project's own team")):
        install("shadow-teams", {"plugin_shadow": _GOOD_TEAM}, "chasers = plugin_shadow:Wall",
                first=True)
    assert soccer_drill.make_team("chasers").__module__ == "opponents.chasers"


def test_a_declared_id_that_is_not_valid_is_refused(install, capsys):
    with pytest.warns(UserWarning, match=(
            r"team 'my team' of distribution 'spaced-teams' \(plugin_spaced:Wall\) is "
            r"refused: a team id must be a non-empty identifier")):
        install("spaced-teams", {"plugin_spaced": _GOOD_TEAM}, "my team = plugin_spaced:Wall")
    assert "my team" not in teams.team_ids()
    assert "refused" in teams.broken_teams()["my team"]
    with pytest.raises(soccer_drill.TeamError, match=r"'my team' .* is refused: a team id must be"):
        soccer_drill.env(opponent="my team")
    assert opponents_cli.main([]) == 1
    assert "error: team 'my team' of distribution 'spaced-teams'" in capsys.readouterr().err


def test_an_entry_point_naming_something_not_callable_is_reported_as_such(install):
    install("odd-teams", {"plugin_odd": "TEAM = 5\n"}, "odd = plugin_odd:TEAM")
    with pytest.raises(soccer_drill.TeamError, match=(
            r"the entry point of team 'odd' \(plugin_odd:TEAM\) is not callable: it names a "
            r"int \(5\); it must name a team class or factory")):
        soccer_drill.make_team("odd")
    assert "is not callable" in teams.broken_teams()["odd"]


def test_the_installed_teams_list_without_warnings(capsys):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        teams.refresh()
        assert set(opponents.PAPER_TEAMS) <= set(soccer_drill.available_teams())
        assert teams.broken_teams() == {}
    assert opponents_cli.main([]) == 0
    assert capsys.readouterr().err == ""


def test_a_team_s_code_is_identified_by_its_package_s_source(install, tmp_path):
    install("code-teams", {"plugin_code": _GOOD_TEAM}, "walled = plugin_code:Wall")
    before = teams.team_code("walled")
    assert before["factory"] == "plugin_code:Wall"
    assert before["distribution"] == "code-teams 0.1"
    source = next(tmp_path.rglob("plugin_code.py"))
    source.write_text(source.read_text() + "\n# changed\n")
    assert teams.team_code("walled")["source_sha256"] != before["source_sha256"]
    assert teams.team_code("chasers")["factory"] == "opponents.chasers:Chasers"
