"""A team from a distribution that is not ours is discovered through its entry point."""

from __future__ import annotations

import contextlib
import importlib
import importlib.metadata
import signal
import sys
import textwrap
import threading
import warnings
from pathlib import Path

import pytest

import opponents
import soccer_drill
from ilpss.experiments.registry import check_env_id
from opponents import cli as opponents_cli
from soccer_drill import teams
from soccer_drill.registry import PluginWarning
from soccer_drill.teams.registry import TEAMS


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


def test_the_recorded_episodes_are_of_this_projects_teams_alone(foreign_distribution):
    # A team installed beside the project has no recorded digest: with one installed, the
    # digests' test must still ask for exactly the recorded configurations.
    from episode_digests import configurations

    assert "wall" in teams.team_ids()
    recorded = {opponent for _, _, opponent, _ in configurations()}
    assert "wall" not in recorded
    assert recorded == {None, *TEAMS.own_names()}
    assert {"chasers", "goal_guards", "parametric"} <= recorded


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
    first installed is found first; ``first=True``: before every other distribution).
    A module named with ``/`` is written in its folders (``"ns/mod"``: ``ns/mod.py``, with
    no ``__init__.py`` in ``ns``: a namespace package). ``entry_points`` replaces the
    whole ``entry_points.txt`` (bytes are written as they are). Everything is undone after
    the test.
    """
    count = 0

    def _install(dist: str, modules: dict[str, str], lines: str = "", first: bool = False,
                 entry_points: str | bytes | None = None) -> Path:
        nonlocal count
        count += 1
        root = tmp_path / f"site{count}"
        root.mkdir()
        for module, source in modules.items():
            path = root / f"{module}.py"
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(textwrap.dedent(source))
        info = root / f"{dist.replace('-', '_')}-0.1.dist-info"
        info.mkdir()
        (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: 0.1\n")
        if entry_points is None:
            entry_points = f"[soccer_drill.opponents]\n{lines}\n"
        if isinstance(entry_points, str):
            entry_points = entry_points.encode()
        (info / "entry_points.txt").write_bytes(entry_points)
        path = [str(root), *sys.path] if first else [*sys.path, str(root)]
        monkeypatch.setattr(sys, "path", path)
        importlib.invalidate_caches()
        teams.refresh()
        return root

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
            r"the entry point of team 'odd' \(plugin_odd:TEAM\) is not callable: it names an "
            r"int \(5\); it must name a team class or factory \(distribution 'odd-teams', "
            r"entry-point group 'soccer_drill.opponents'\)")):
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


# ------------------------------------------------- every registry, first use
def _project_registries():
    """Every registry of the project, by name."""
    from ilpss.experiments.methods import METHODS
    from ilpss.experiments.protocols import PROTOCOLS
    from ilpss.experiments.registry import ENV_PACKAGES, SAMPLERS
    from ilpss.reuse import REUSES

    return {"teams": TEAMS, "methods": METHODS, "protocols": PROTOCOLS,
            "reuses": REUSES, "samplers": SAMPLERS, "environment packages": ENV_PACKAGES}


def _first_use(registry):
    """A registry like ``registry`` (its group and rules) that was never used."""
    return type(registry)(registry.group, registry.kind, registry.of, label=registry.label,
                          names=registry.names_allowed, calls=registry.calls,
                          error=registry.error)


def _alarm_handler(signum, frame):
    raise TimeoutError("the program's wall-clock bound")


def _sigterm_handler(signum, frame):
    sys.exit(143)


# What a signal delivers: the user's Ctrl-C (Python's own handler), a program's SIGALRM
# handler that raises (a wall-clock bound), a program's SIGTERM handler that exits.
SIGNALS = {
    "ctrl_c": (signal.SIGINT, signal.default_int_handler, KeyboardInterrupt),
    "alarm_handler_raising": (signal.SIGALRM, _alarm_handler, TimeoutError),
    "sigterm_handler_exiting": (signal.SIGTERM, _sigterm_handler, SystemExit),
}


@contextlib.contextmanager
def _handler(signum, handler):
    previous = signal.signal(signum, handler)
    try:
        yield
    finally:
        signal.signal(signum, previous)


def _on_reading(monkeypatch, marker: str, action) -> None:
    """Call ``action()`` while the ``entry_points.txt`` holding ``marker`` is read, once."""
    original = importlib.metadata.PathDistribution.read_text
    armed = [True]

    def read_text(self, filename):
        text = original(self, filename)
        if armed[0] and filename == "entry_points.txt" and text and marker in text:
            armed[0] = False
            action()
        return text

    monkeypatch.setattr(importlib.metadata.PathDistribution, "read_text", read_text)


_EVERY_GROUP = "".join(f"[{r.group}]\nsig_entry = plugin_sig:THING\n"
                       for r in _project_registries().values())


@pytest.mark.parametrize("kind", sorted(SIGNALS))
@pytest.mark.parametrize("name", sorted(_project_registries()))
def test_a_signal_during_a_registrys_first_read_propagates_and_the_next_use_reads_again(
        install, monkeypatch, name, kind):
    signum, handler, expected = SIGNALS[kind]
    install("signal-plugins", {}, entry_points=_EVERY_GROUP)
    registry = _first_use(_project_registries()[name])
    with _handler(signum, handler):
        _on_reading(monkeypatch, "sig_entry", lambda: signal.raise_signal(signum))
        with pytest.raises(expected):
            registry.names()
        # Not "known teams: []" for the rest of the process, nor a warning that the entry
        # points could not be read: the next use reads them.
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            names = registry.names()
    assert "sig_entry" in names
    assert names == _first_use(registry).names()


_INTERRUPTED_TEAM = '''
import signal
import plugin_sig_control

if plugin_sig_control.ARMED is not None:
    signum, plugin_sig_control.ARMED = plugin_sig_control.ARMED, None
    signal.raise_signal(signum)
''' + _GOOD_TEAM


@pytest.mark.parametrize("kind", sorted(SIGNALS))
def test_a_signal_while_a_plugin_is_first_imported_propagates_and_the_next_use_imports_it(
        install, kind):
    signum, handler, expected = SIGNALS[kind]
    install("signal-teams", {"plugin_sig_control": "ARMED = None\n",
                             "plugin_sig_team": _INTERRUPTED_TEAM},
            "sigwall = plugin_sig_team:Wall")
    import plugin_sig_control

    plugin_sig_control.ARMED = signum
    with _handler(signum, handler), pytest.raises(expected):
        soccer_drill.make_team("sigwall")
    assert plugin_sig_control.ARMED is None  # delivered, once
    # Not "loaded" holding None, nor a broken plugin: the next use imports it.
    assert "sigwall" not in teams.broken_teams()
    assert soccer_drill.available_teams()["sigwall"] == "Both defenders stand on the goal line."
    assert type(soccer_drill.make_team("sigwall")).__name__ == "Wall"


_SIGNAL_IN_A_WEAKREF_CALLBACK = '''
import signal
import weakref
import plugin_cb_control


class _Thing:
    pass


def _collected(ref):
    # The import machinery's module locks are freed in such callbacks: a handler's
    # exception raised in one is printed ("Exception ignored") and lost.
    if plugin_cb_control.ARMED is not None:
        signum, plugin_cb_control.ARMED = plugin_cb_control.ARMED, None
        signal.raise_signal(signum)


_thing = _Thing()
_ref = weakref.ref(_thing, _collected)
del _thing
''' + _GOOD_TEAM


@pytest.mark.parametrize("kind", sorted(SIGNALS))
def test_a_signal_in_a_weakref_callback_of_a_plugins_import_is_not_lost(install, kind):
    signum, handler, expected = SIGNALS[kind]
    install("callback-teams", {"plugin_cb_control": "ARMED = None\n",
                               "plugin_cb_team": _SIGNAL_IN_A_WEAKREF_CALLBACK},
            "cbwall = plugin_cb_team:Wall")
    import plugin_cb_control

    plugin_cb_control.ARMED = signum
    with _handler(signum, handler), pytest.raises(expected):  # before: the team, and
        soccer_drill.make_team("cbwall")                      # the signal lost
    assert plugin_cb_control.ARMED is None
    assert type(soccer_drill.make_team("cbwall")).__name__ == "Wall"


_TWICE_INTERRUPTED_TEAM = '''
import signal
import plugin_twice_control

plugin_twice_control.STEPS.append("first")
signal.raise_signal(signal.SIGINT)
plugin_twice_control.STEPS.append("second")
signal.raise_signal(signal.SIGINT)
plugin_twice_control.STEPS.append("after")  # an import that would hang from here
''' + _GOOD_TEAM


def test_a_second_ctrl_c_stops_a_plugins_import_at_once(install):
    install("twice-teams", {"plugin_twice_control": "STEPS = []\n",
                            "plugin_twice_team": _TWICE_INTERRUPTED_TEAM},
            "twicewall = plugin_twice_team:Wall")
    import plugin_twice_control

    calls = []

    def ctrl_c(signum, frame):
        calls.append(signum)
        raise KeyboardInterrupt

    with _handler(signal.SIGINT, ctrl_c), pytest.raises(KeyboardInterrupt):
        soccer_drill.make_team("twicewall")
    assert plugin_twice_control.STEPS == ["first", "second"]  # the first one held back
    assert calls == [signal.SIGINT]  # the two presses run the handler once


def test_a_thread_waits_while_another_reads_the_entry_points_or_imports_a_plugin(
        install, monkeypatch):
    gate = "import threading\nENTERED = threading.Event()\nGO = threading.Event()\n"
    slow = "import plugin_slow_gate\nplugin_slow_gate.ENTERED.set()\nplugin_slow_gate.GO.wait(60)\n"
    install("slow-teams", {"plugin_slow_gate": gate, "plugin_slow": slow + _GOOD_TEAM},
            "slowwall = plugin_slow:Wall")
    import plugin_slow_gate

    registry = _first_use(TEAMS)
    reading, go = threading.Event(), threading.Event()
    _on_reading(monkeypatch, "slowwall", lambda: (reading.set(), go.wait(60)))
    got: dict[str, object] = {}

    def run(key: str, call) -> threading.Thread:
        def target():
            try:
                got[key] = call()
            except BaseException as exc:  # reported by the asserts below
                got[key] = exc
        thread = threading.Thread(target=target)
        thread.start()
        return thread

    # The first read of the entry points: a second thread waits for it to end.
    first = run("first", registry.names)
    assert reading.wait(60)
    second = run("second", registry.names)
    second.join(0.5)  # time for it to answer without waiting, if it would
    go.set()
    first.join(60)
    second.join(60)
    assert "slowwall" in got["first"]
    assert got["second"] == got["first"]
    # The first import of a plugin: a second thread waits for it to end.
    first = run("first", lambda: registry.get("slowwall"))
    assert plugin_slow_gate.ENTERED.wait(60)
    second = run("second", lambda: registry.get("slowwall"))
    second.join(0.5)
    plugin_slow_gate.GO.set()
    first.join(60)
    second.join(60)
    assert getattr(got["first"], "__name__", got["first"]) == "Wall"
    assert got["second"] is got["first"]


# ------------------------------------------------- broken neighbours
def test_an_unreadable_unrelated_distribution_empties_no_registry_and_is_named(install):
    registries = _project_registries()
    before = {name: _first_use(r).names() for name, r in registries.items()}
    assert before["environment packages"] == ["soccer_drill"] and "chasers" in before["teams"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        install("latin-scripts", {},
                entry_points="[console_scripts]\ncafé = latin_scripts:main\n".encode("latin-1"))
        install("no-equals-scripts", {}, entry_points="[console_scripts]\njust_a_name\n")
        root = install("latin-metadata-teams", {"plugin_latin": _GOOD_TEAM},
                       "latin_wall = plugin_latin:Wall")
        (root / "latin_metadata_teams-0.1.dist-info" / "METADATA").write_bytes(
            "Metadata-Version: 2.1\nName: latin-metadata-teams\nVersion: 0.1\n"
            "Author: José\n".encode("latin-1"))
        after = {name: _first_use(r).names() for name, r in registries.items()}
        for registry in registries.values():
            registry.refresh()
        assert "chasers" in teams.team_ids()
        check_env_id("ExperimentConfig.env_id", "soccer_drill:soccer_drill/Holder-v0")
    assert after == before
    messages = [str(w.message) for w in caught if issubclass(w.category, PluginWarning)]
    assert any("distribution 'latin-scripts'" in m and "UnicodeDecodeError" in m
               for m in messages), messages
    assert any("distribution 'no-equals-scripts'" in m for m in messages), messages
    assert "latin_wall" not in after["teams"]  # named by its folder: its name is unreadable
    assert any("distribution 'latin_metadata_teams'" in m and "UnicodeDecodeError" in m
               for m in messages), messages
    assert all(len(m) < 1000 for m in messages)


# ------------------------------------------------- plugins of the wrong kind
def test_a_plugin_of_the_wrong_type_is_refused_naming_its_entry_point_group_and_distribution(
        install, monkeypatch):
    registries = _project_registries()
    install("wrong-plugins",
            {"plugin_wrong": "FIVE = 5\nfrom ilpss.experiments.methods import METHODS\n"
                             "SCRATCH = METHODS.get('scratch')\n"},
            entry_points="[ilpss.methods]\nodd = plugin_wrong:FIVE\n"
                         "renamed = plugin_wrong:SCRATCH\n"
                         "[ilpss.protocols]\nodd = plugin_wrong:FIVE\n"
                         "[ilpss.reuses]\nodd = plugin_wrong:FIVE\n"
                         "[ilpss.samplers]\nodd = plugin_wrong:FIVE\n")
    try:
        for name, cls in (("methods", "Method"), ("protocols", "Protocol"), ("reuses", "Reuse")):
            registry = registries[name]
            registry.refresh()
            with pytest.raises(ValueError, match=(
                    rf"^the entry point of {registry.kind} 'odd' \(plugin_wrong:FIVE\) names an "
                    rf"int \(5\), not a {cls} \(distribution 'wrong-plugins', entry-point group "
                    rf"'{registry.group}'\)$")):
                registry.get("odd")
            assert "odd" in registry.broken()
        with pytest.raises(ValueError, match=(
                r"the entry point of method 'renamed' \(plugin_wrong:SCRATCH\) names the "
                r"method 'scratch': a method's entry point must have its name \(distribution "
                r"'wrong-plugins', entry-point group 'ilpss.methods'\)")):
            registries["methods"].get("renamed")
        registries["samplers"].refresh()
        with pytest.raises(ValueError, match=(
                r"the entry point of sampler 'odd' \(plugin_wrong:FIVE\) is not callable: it "
                r"names an int \(5\); it must name a function sampler\(n, seed\) "
                r"\(distribution 'wrong-plugins', entry-point group 'ilpss.samplers'\)")):
            registries["samplers"].get("odd")
    finally:
        monkeypatch.undo()
        for registry in registries.values():
            registry.refresh()
    assert "odd" not in registries["methods"]


# ------------------------------------------------- ids
class _Idle:
    """Stands still."""

    def reset(self, view, rng):
        self.players = view.players

    def act(self, view):
        return {p: soccer_drill.Command(soccer_drill.Skill.MOVE_TO, (17.5, 5.0))
                for p in self.players}


def test_ids_are_bounded_ascii_names_and_look_alikes_are_refused(team_registry, install):
    huge = "x" * 100_000
    with pytest.raises(ValueError, match=r"at most 64 ASCII characters") as caught:
        soccer_drill.register(huge, _Idle)
    assert len(str(caught.value)) < 1000
    with pytest.raises(ValueError, match=r"unknown team 'xxx") as caught:
        soccer_drill.make_team(huge)
    assert len(str(caught.value)) < 2000
    cyrillic = "ch\u0430sers"  # a Cyrillic "a"
    with pytest.raises(ValueError, match=r"ASCII"):
        soccer_drill.register(cyrillic, _Idle)
    with pytest.raises(ValueError, match=r"unknown team 'ch.sers' \(not a valid team id: a "
                                         r"team id must be .*ASCII"):
        soccer_drill.make_team(cyrillic)
    for look_alike, of in (("Chasers", "chasers"), ("goal-guards", "goal_guards")):
        with pytest.raises(ValueError, match=(
                rf"team id '{look_alike}' looks like the team '{of}' \(ids that differ only "
                r"in case or in '-' against '_' are taken for each other\); give it an id of "
                r"its own")):
            soccer_drill.register(look_alike, _Idle)
    soccer_drill.register("chasers_ii", _Idle)  # a name of its own is fine
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        install("look-alike-teams", {"plugin_look": _GOOD_TEAM},
                f"{cyrillic} = plugin_look:Wall\nGoal_Guards = plugin_look:Wall\n"
                f"{'y' * 100_000} = plugin_look:Wall\n")
    messages = [str(w.message) for w in caught]
    assert len(messages) == 3 and all(len(m) < 1000 for m in messages), messages
    ids = teams.team_ids()
    assert cyrillic not in ids and "Goal_Guards" not in ids and max(map(len, ids)) <= 64
    broken = teams.broken_teams()
    assert "ASCII" in broken[cyrillic]
    assert ("team 'Goal_Guards' of distribution 'look-alike-teams' (plugin_look:Wall) is "
            "refused: it looks like the team 'goal_guards'") in broken["Goal_Guards"]
    assert "at most 64 ASCII characters" in broken["y" * 100_000]


# ------------------------------------------------- source digests
def test_a_team_in_a_namespace_package_is_identified_by_its_source(install):
    root = install("namespace-teams",
                   {"plugin_ns/walls": _GOOD_TEAM, "plugin_ns/deep/__init__": "",
                    "plugin_ns/deep/teams": _GOOD_TEAM},
                   "ns_wall = plugin_ns.walls:Wall\nns_deep = plugin_ns.deep.teams:Wall\n")
    for team_id, source in (("ns_wall", root / "plugin_ns" / "walls.py"),
                            ("ns_deep", root / "plugin_ns" / "deep" / "__init__.py")):
        before = teams.team_code(team_id)
        assert "source_sha256" in before, before
        source.write_text(source.read_text() + "\n# changed\n")
        assert teams.team_code(team_id)["source_sha256"] != before["source_sha256"]


def _keepaway_cycles():
    """Cycles of a few keepaway episodes against the default takers (the keepers hold)."""
    import gymnasium as gym

    env, out = gym.make("soccer_drill/Keepaway3v2-v0"), []
    for seed in range(3):
        env.reset(seed=seed)
        while True:
            _, _, terminated, truncated, info = env.step(0)
            if terminated or truncated:
                out.append(info["cycles"])
                break
    return out


def test_a_registration_cannot_take_the_id_of_another_tasks_built_in_team(team_registry):
    # before, register("keepaway_takers", ...) was accepted (the drill's registry does not
    # hold it) and, looked up first, replaced keepaway's default takers everywhere
    before = _keepaway_cycles()
    with pytest.raises(ValueError, match="'keepaway_takers' is one of the keepaway task's "
                                         "teams, and this project's own teams keep"):
        soccer_drill.register("keepaway_takers", lambda: None)
    with pytest.raises(ValueError, match="own teams keep their ids"):
        soccer_drill.register("keepaway_takers", lambda: None, overwrite=True)
    # nor one another task's team would be taken for (the drill's registry checks only
    # its own look-alikes)
    with pytest.raises(ValueError, match="'Keepaway-Takers' looks like the keepaway task's "
                                         "team 'keepaway_takers'"):
        soccer_drill.register("Keepaway-Takers", lambda: None)
    assert _keepaway_cycles() == before


def test_a_registration_cannot_replace_the_drills_own_teams(team_registry):
    # before, register("chasers", ..., overwrite=True) was accepted: results labelled
    # "chasers" came from another team
    with pytest.raises(ValueError, match="'chasers' is one of the drill task's teams, and "
                                         "this project's own teams keep their ids"):
        soccer_drill.register("chasers", lambda: None, overwrite=True)
    assert type(soccer_drill.make_team("chasers")).__name__ == "Chasers"
    soccer_drill.register("mine", _Idle)  # an id of its own: registered, and
    soccer_drill.register("mine", _Idle, overwrite=True)  # replaced when asked


def test_a_refused_plugin_of_another_task_is_named_with_why_when_asked_for(install):
    # before, the id of a keepaway plugin refused as a look-alike was "unknown team"
    with pytest.warns(PluginWarning, match="'keepaway-takers' .* is refused"):
        install("alike-teams", {"plugin_alike": _GOOD_TEAM}, entry_points=(
            "[soccer_drill.keepaway_teams]\nkeepaway-takers = plugin_alike:Wall\n"))
    with pytest.raises(soccer_drill.TeamError, match=r"'keepaway-takers' .* is refused: it "
                                                     "looks like the keepaway team"):
        soccer_drill.make_team("keepaway-takers")


def test_a_plugin_declaring_another_tasks_built_in_id_is_ignored_for_it(install):
    before = _keepaway_cycles()
    install("hijack-teams", {"plugin_hijack": _GOOD_TEAM}, "keepaway_takers = plugin_hijack:Wall")
    with pytest.warns(PluginWarning, match="'keepaway_takers' is one of this project's own"):
        listed = soccer_drill.available_teams()
    assert listed["keepaway_takers"].startswith("Keepaway's hand-coded takers")
    assert _keepaway_cycles() == before


def test_a_teams_description_is_its_first_sentence_as_plain_text(team_registry):
    class Wrapped:
        """A :class:`~soccer_drill.teams.Team` whose ``first`` sentence goes on
        to the next line. A second sentence.

        More."""

        def reset(self, view, rng):
            pass

        def act(self, view):
            return {}

    soccer_drill.register("wrapped", Wrapped)
    assert soccer_drill.available_teams()["wrapped"] == (
        "A Team whose first sentence goes on to the next line.")
