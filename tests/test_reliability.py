"""Soak test, teams that hang or misbehave, SIGKILL mid-experiment, hostile configurations."""

from __future__ import annotations

import gc
import json
import math
import os
import re
import signal
import subprocess
import sys
import threading
import time
import weakref
from pathlib import Path

import numpy as np
import pytest
from benchmark_scripts import load_benchmark

import soccer_drill
import soccer_drill.envs.core
from ilpss.baselines import PrqConfig
from ilpss.experiments.cli import main as cli_main
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.run import run_experiment
from ilpss.lifelong import LearnerConfig, LifelongConfig
from ilpss.options import OptionSettings
from soccer_drill import TeamError
from soccer_drill.commands import Command, Skill

ROOT = Path(__file__).resolve().parent.parent
UNIX_TIMER = hasattr(signal, "setitimer") and hasattr(signal, "SIGPROF")


soak = load_benchmark("soak")


# ------------------------------------------------------------------------- soak
@pytest.mark.slow
def test_short_soak_has_no_violations_and_writes_its_section(tmp_path):
    out = tmp_path / "reliability.md"
    old = f"{soak.MARK_START}\nold\n{soak.MARK_END}"
    out.write_text(f"# Reliability\n\nintro\n\n{old}\n\ntrailer\n")
    code = soak.main(["--episodes", "200", "--warmup", "150", "--out", str(out)])
    text = out.read_text()
    assert code == 0
    assert "| **invariant violations** | **0** |" in text
    assert "200 episodes (aec 70, parallel 70, holder 60)" in text  # blocks of 10
    assert "`python benchmarks/soak.py --episodes 200 --warmup 150 --out" in text
    assert "per 1,000 episodes" in text and "| site | size diff | blocks diff |" in text
    # Only the section between the markers is replaced.
    assert text.startswith("# Reliability\n\nintro\n\n") and text.endswith("\n\ntrailer\n")
    assert "\nold\n" not in text and text.count(soak.MARK_START) == 1
    assert "Load average (1 min)" in text  # the rates depend on it
    assert [p.name for p in tmp_path.iterdir()] == ["reliability.md"]  # no temporary left


def test_the_soak_checks_its_output_before_any_episode(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(soak.Soak, "run", lambda *a: pytest.fail("it played"))
    (tmp_path / "file").write_text("")
    with pytest.raises(SystemExit) as exit_:
        soak.main(["--episodes", "20", "--out", str(tmp_path / "file" / "reliability.md")])
    assert exit_.value.code == 2
    assert f"'{tmp_path / 'file'}' is a file, not a folder" in capsys.readouterr().err


@pytest.mark.slow
def test_soak_counts_and_reports_violations(monkeypatch, tmp_path):
    """A drill whose observations turn NaN at cycle 3 must fail the soak (exit status 1)."""
    for method in ("__call__", "again"):  # a new array, or one made again each state
        observe = getattr(soccer_drill.envs.core.Observation, method)

        def broken(self, state, rows, players, observe=observe):
            obs = observe(self, state, rows, players)
            obs[state["cycle"][rows] == 3] = np.nan
            return obs

        monkeypatch.setattr(soccer_drill.envs.core.Observation, method, broken)
    out = tmp_path / "r.md"
    assert soak.main(["--episodes", "30", "--warmup", "20", "--out", str(out)]) == 1
    text = out.read_text()
    assert "| **invariant violations** | **0** |" not in text
    assert "First violations:" in text and "non-finite observation" in text


# ------------------------------------------------------------- teams that hang
class _Hanging:
    """Defenders that hang once, in ``reset`` or in ``act`` at cycle ``at``, then behave.

    ``how``: ``"loop"`` (a pure-Python busy loop that ignores ordinary exceptions),
    ``"swallow"`` (a busy loop that catches the first interruption and goes on) or
    ``"sleep"`` (waiting, not computing). The loops end after ``hang_seconds`` of the
    thread's CPU time, so that a broken bound fails the test instead of hanging it,
    however loaded the machine.
    """

    def __init__(self, where: str = "act", how: str = "loop", at: int = 2,
                 hang_seconds: float = 10.0) -> None:
        self.where, self.how, self.at, self.hang_seconds = where, how, at, hang_seconds
        self.hung = False
        self.cpu = 0.0  # CPU seconds the hang took, until it was stopped or ended

    def _hang(self) -> None:
        self.hung = True
        start = time.thread_time()
        end = start + self.hang_seconds
        try:
            if self.how == "sleep":
                time.sleep(self.hang_seconds)
            elif self.how == "swallow":  # a team that catches the first interruption
                try:
                    while time.thread_time() < end:
                        pass
                except BaseException:
                    pass
                while time.thread_time() < end:
                    pass
            else:
                while time.thread_time() < end:
                    try:
                        pass
                    except Exception:
                        pass
        finally:
            self.cpu = time.thread_time() - start

    def reset(self, view, rng):
        self.players = view.players
        if self.where == "reset" and not self.hung:
            self._hang()

    def act(self, view):
        if self.where == "act" and not self.hung and view.cycle == self.at:
            self._hang()
        return dict.fromkeys(self.players, Command(Skill.INTERCEPT))


def _run_to_end(env, kind: str, seed: int) -> str:
    """Reset ``env`` and play one episode with the first legal actions; its outcome."""
    if kind == "holder":
        env.reset(seed=seed)
        done = False
        while not done:
            _, _, term, trunc, info = env.step(1)
            done = term or trunc
        return info["outcome"]
    if kind == "parallel":
        obs, _ = env.reset(seed=seed)
        while env.agents:
            obs, *_ = env.step({a: int(np.flatnonzero(o["action_mask"])[0])
                                for a, o in obs.items()})
        return env.outcome
    env.reset(seed=seed)
    for _ in env.agent_iter():
        obs, _, term, trunc, _ = env.last()
        env.step(None if term or trunc else int(np.flatnonzero(obs["action_mask"])[0]))
    return env.outcome


def _make(kind: str, team, **kwargs):
    if kind == "holder":
        return soccer_drill.HolderEnv(opponent=team, **kwargs)
    return (soccer_drill.env if kind == "aec" else soccer_drill.parallel_env)(
        opponent=team, **kwargs)


def _steps(env, kind: str, n: int) -> None:
    """Step a reset ``env`` ``n`` times (cycles or holder decisions)."""
    for _ in range(n):
        if kind == "holder":
            env.step(0)
        elif kind == "parallel":
            env.step({a: 3 if env.drill_state.holder != i else 0
                      for i, a in enumerate(env.agents)})
        else:
            for _ in env.possible_agents:
                mask = env.observe(env.agent_selection)["action_mask"]
                env.step(int(np.flatnonzero(mask)[0]))


@pytest.fixture
def sentinel_prof_handler():
    """A SIGPROF handler of 'someone else', to check it is put back after every call."""
    if not UNIX_TIMER:
        yield None
        return

    def handler(signum, frame):  # pragma: no cover - must never run
        raise AssertionError("the test's own SIGPROF handler was called")

    previous = signal.signal(signal.SIGPROF, handler)
    yield handler
    signal.setitimer(signal.ITIMER_PROF, 0.0)
    signal.signal(signal.SIGPROF, previous)


@pytest.mark.skipif(not UNIX_TIMER, reason="interrupting a call needs setitimer (Unix)")
@pytest.mark.parametrize("kind", ["holder", "aec", "parallel"])
@pytest.mark.parametrize("how", ["loop", "swallow"])
def test_a_team_stuck_computing_in_act_is_stopped_named_and_the_env_recovers(
    kind, how, sentinel_prof_handler
):
    timeout = 0.2
    team = _Hanging("act", how)
    env = _make(kind, team, team_timeout=timeout)
    env.reset(seed=0)
    with pytest.raises(TeamError) as err:
        _steps(env, kind, 10)
    assert team.hung
    # Interrupted after its 0.2 s of CPU time (a tick later when it swallows the first
    # interruption), not when its loop of 10 s of CPU time ended.
    assert timeout <= team.cpu < 2.0
    assert re.fullmatch(
        rf"team '_Hanging' exceeded its time bound of {timeout:g} s of CPU time in act\(\) "
        r"at cycle 2 \(stopped after 0\.\d\d s of CPU time, \d+\.\d\d s in all\); fix the "
        r"team or pass a larger team_timeout; a team whose call compiles code \(numba's, at "
        r"its first call\) registers that compile with soccer_drill\.teams\.warms, which runs "
        r"it before any bounded call", str(err.value))
    assert err.value.__cause__ is None  # the internal interruption is not chained
    # The previous handler is back and no timer is left armed.
    assert signal.getsignal(signal.SIGPROF) is sentinel_prof_handler
    assert signal.getitimer(signal.ITIMER_PROF) == (0.0, 0.0)
    # The environment is usable: a reset and a whole episode work.
    assert _run_to_end(env, kind, seed=1) in soak.OUTCOMES


@pytest.mark.skipif(not UNIX_TIMER, reason="interrupting a call needs setitimer (Unix)")
def test_a_team_stuck_computing_in_reset_is_stopped_and_the_next_reset_works(
    sentinel_prof_handler
):
    team = _Hanging("reset")
    env = soccer_drill.HolderEnv(opponent=team, team_timeout=0.2)
    with pytest.raises(TeamError, match=r"'_Hanging' exceeded its time bound of 0.2 s of CPU "
                       r"time in reset\(\)"):
        env.reset(seed=0)
    assert team.cpu < 0.5
    assert signal.getsignal(signal.SIGPROF) is sentinel_prof_handler
    assert _run_to_end(env, "holder", seed=0) in soak.OUTCOMES


@pytest.mark.parametrize("kind", ["holder", "aec", "parallel"])
def test_a_team_that_waits_is_not_charged_for_the_wait(kind):
    """Sleeping stands for any wait: 0.6 s of it is within a bound of 0.2 s of CPU time."""
    team = _Hanging("act", "sleep", hang_seconds=0.6)
    env = _make(kind, team, team_timeout=0.2)
    env.reset(seed=0)
    start = time.monotonic()
    _steps(env, kind, 3)  # cycle 2 sleeps
    assert team.hung and time.monotonic() - start >= 0.6
    assert _run_to_end(env, kind, seed=1) in soak.OUTCOMES


_DESCHEDULED_TEAM = r'''
import sys, time
import soccer_drill
from soccer_drill.commands import Command, Skill

class Honest:
    """Computes for 0.3 s of wall time in its first act(), and says when it starts."""
    def reset(self, view, rng):
        self.players, self.done = view.players, False
    def act(self, view):
        if not self.done:
            self.done = True
            print("computing", flush=True)
            end = time.monotonic() + 0.3
            while time.monotonic() < end:
                pass
        return dict.fromkeys(self.players, Command(Skill.INTERCEPT))

env = soccer_drill.HolderEnv(opponent=Honest(), team_timeout=1.0)
env.reset(seed=0)
start = time.monotonic()
env.step(0)
print(f"finished after {time.monotonic() - start:.2f} s", flush=True)
'''


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(signal, "SIGSTOP"), reason="SIGSTOP (Unix)")
def test_a_team_descheduled_mid_call_is_not_charged_for_it(tmp_path):
    """The process is stopped for 1.5 s in the middle of an honest team's act(), as a
    loaded machine would deschedule it: longer than the 1 s bound, yet no TeamError."""
    script = tmp_path / "descheduled.py"
    script.write_text(_DESCHEDULED_TEAM)
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "computing"
        os.kill(proc.pid, signal.SIGSTOP)
        time.sleep(1.5)
        os.kill(proc.pid, signal.SIGCONT)
        out, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    seconds = float(re.fullmatch(r"finished after (\d+\.\d+) s\n", out).group(1))
    assert seconds >= 1.5  # the stop happened inside the team's call


class _Cyclic:
    """An object in a reference cycle: only a garbage collection frees it."""

    def __init__(self) -> None:
        self.me = self


@pytest.mark.skipif(not UNIX_TIMER, reason="interrupting a call needs setitimer (Unix)")
def test_garbage_collections_during_a_team_call_are_not_charged_to_it(sentinel_prof_handler):
    """A collection the team triggers, and the weakref callbacks it runs (here 0.4 s of CPU
    time), neither count against the team's 0.1 s nor are interrupted."""
    unraisable: list = []

    def slow_callback(ref) -> None:
        end = time.thread_time() + 0.002
        while time.thread_time() < end:
            pass

    class CollectingTeam:
        def reset(self, view, rng):
            self.players = view.players

        def act(self, view):
            if view.cycle == 2:
                garbage = [_Cyclic() for _ in range(200)]
                refs = [weakref.ref(obj, slow_callback) for obj in garbage]
                del garbage
                gc.collect()
                assert all(ref() is None for ref in refs)
            return dict.fromkeys(self.players, Command(Skill.INTERCEPT))

    previous_hook = sys.unraisablehook
    sys.unraisablehook = unraisable.append
    enabled = gc.isenabled()
    gc.disable()  # only the team's own collection
    try:
        env = soccer_drill.HolderEnv(opponent=CollectingTeam(), team_timeout=0.1)
        env.reset(seed=0)
        _steps(env, "holder", 3)
    finally:
        sys.unraisablehook = previous_hook
        if enabled:
            gc.enable()
    assert unraisable == []  # nothing raised inside a weakref callback
    assert signal.getsignal(signal.SIGPROF) is sentinel_prof_handler


def test_a_slow_call_off_the_main_thread_is_reported_when_it_returns():
    """Off the main thread no signal can interrupt the team: its CPU time is checked after."""
    before = signal.getsignal(signal.SIGPROF) if UNIX_TIMER else None
    errors: list[BaseException] = []
    team = _Hanging("act", "loop", hang_seconds=0.5)
    env = soccer_drill.HolderEnv(opponent=team, team_timeout=0.1)

    def play() -> None:
        env.reset(seed=0)
        try:
            _steps(env, "holder", 10)
        except TeamError as exc:
            errors.append(exc)

    worker = threading.Thread(target=play)
    worker.start()
    worker.join(120)
    assert not worker.is_alive()
    assert len(errors) == 1
    assert "exceeded its time bound of 0.1 s of CPU time in act()" in str(errors[0])
    # The whole loop: the call was not interrupted, only measured.
    assert team.cpu >= 0.5
    assert re.search(r"stopped after (0\.[5-9]|[1-9])\d* s of CPU time", str(errors[0]))
    if UNIX_TIMER:
        assert signal.getsignal(signal.SIGPROF) is before


class _LaggingTimers:
    """``_signal`` as on a loaded machine: ``ITIMER_PROF`` fires after ``lag`` times the
    CPU time it was armed for (measured there: 0.22-0.85 s of the thread's CPU time for a
    timer of 0.2 s, the kernel counting the process's CPU time as sampled at clock ticks)."""

    def __init__(self, real, lag: float) -> None:
        self._real, self._lag = real, lag

    def setitimer(self, which, value, interval=0.0):
        if which != signal.ITIMER_PROF:
            return self._real.setitimer(which, value, interval)
        value, interval = self._real.setitimer(which, value * self._lag, interval * self._lag)
        return value / self._lag, interval / self._lag

    def __getattr__(self, name):
        return getattr(self._real, name)


@pytest.mark.skipif(not UNIX_TIMER, reason="interrupting a call needs setitimer (Unix)")
@pytest.mark.parametrize("how", ["loop", "swallow"])
def test_a_cpu_timer_that_fires_late_still_stops_the_call_near_its_bound(
    how, monkeypatch, sentinel_prof_handler
):
    """Before: the timer was armed for the whole bound and trusted, so a call on a loaded
    machine ran several times its bound (1.0-1.2 s of CPU time for a bound of 0.2 s). The
    bound now looks at the thread's own CPU time at every tick of a short interval."""
    from soccer_drill.teams import time_bound

    monkeypatch.setattr(time_bound, "_sig", _LaggingTimers(time_bound._sig, lag=4.0))
    team = _Hanging("act", how)
    env = soccer_drill.HolderEnv(opponent=team, team_timeout=0.2)
    env.reset(seed=0)
    with pytest.raises(TeamError, match=r"stopped after 0\.2\d s of CPU time"):
        _steps(env, "holder", 10)
    assert 0.2 <= team.cpu < 0.3, team.cpu
    assert signal.getitimer(signal.ITIMER_PROF) == (0.0, 0.0)
    assert signal.getsignal(signal.SIGPROF) is sentinel_prof_handler


@pytest.mark.skipif(not UNIX_TIMER, reason="setitimer (Unix)")
def test_another_armed_cpu_timer_is_left_alone(sentinel_prof_handler):
    """With someone else's CPU-time timer armed (a profiler's), the driver measures instead."""
    signal.setitimer(signal.ITIMER_PROF, 600.0, 300.0)
    team = _Hanging("act", "loop", hang_seconds=0.4)
    env = soccer_drill.HolderEnv(opponent=team, team_timeout=0.1)
    env.reset(seed=0)
    with pytest.raises(TeamError, match=r"bound of 0.1 s .*stopped after (0\.[4-9]|[1-9])"):
        _steps(env, "holder", 10)
    assert team.cpu >= 0.4
    remaining, interval = signal.getitimer(signal.ITIMER_PROF)  # its value and interval back
    assert 500.0 < remaining <= 600.0 and interval == 300.0
    assert signal.getsignal(signal.SIGPROF) is sentinel_prof_handler


def test_no_bound_with_team_timeout_none():
    team = _Hanging("act", "loop", hang_seconds=0.3)
    env = soccer_drill.HolderEnv(opponent=team, team_timeout=None)
    env.reset(seed=0)
    _steps(env, "holder", 1)  # runs cycle 2, where the team computes 0.3 s: allowed
    assert team.hung and team.cpu >= 0.3


# 1e10 s is finite but more than setitimer takes (about 9.2e9 s); 1e-4 s is below 1 ms.
@pytest.mark.parametrize("bad", [0, -1.0, math.nan, math.inf, "1", True, [1.0], 1e10, 86_401,
                                 1e-4, np.float64(1e300)])
@pytest.mark.parametrize(("kind", "team"), [("holder", "chasers"), ("aec", "chasers"),
                                            ("parallel", "chasers"), ("aec", None)])
def test_invalid_team_timeout_is_refused(kind, team, bad):
    with pytest.raises(ValueError, match=r"team_timeout must be None or a finite number in "
                       r"\[0.001, 86400\], got "):
        _make(kind, team, team_timeout=bad)


def test_gymnasium_make_passes_team_timeout():
    import gymnasium as gym

    env = gym.make("soccer_drill/Holder-v0", opponent="chasers", team_timeout=None)
    assert env.unwrapped.loop.core.team.team_timeout is None


def test_team_timeout_bounds_and_numpy_numbers_are_accepted():
    for ok in (0.001, 86_400, np.float32(0.5), np.int64(2)):
        env = soccer_drill.HolderEnv(opponent="chasers", team_timeout=ok)
        assert env.loop.core.team.team_timeout == float(ok)


class _SigWithFailingTimer:
    """``_signal`` as the time bound uses it, except that arming a timer fails."""

    def __init__(self, real):
        self._real = real

    def __getattr__(self, name):
        return getattr(self._real, name)

    def setitimer(self, which, seconds, interval=0.0):
        if seconds > 0:
            raise OverflowError("timestamp out of range for platform time_t")
        return self._real.setitimer(which, seconds, interval)


@pytest.mark.skipif(not UNIX_TIMER, reason="setitimer (Unix)")
def test_the_previous_handler_is_back_even_when_arming_the_timer_fails(
    monkeypatch, sentinel_prof_handler
):
    import soccer_drill.teams.time_bound as time_bound

    env = soccer_drill.HolderEnv(opponent="chasers", team_timeout=1.0)
    monkeypatch.setattr(time_bound, "_sig", _SigWithFailingTimer(time_bound._sig))
    with pytest.raises(TeamError, match="OverflowError"):
        env.reset(seed=0)
    monkeypatch.undo()
    assert signal.getsignal(signal.SIGPROF) is sentinel_prof_handler
    assert signal.getitimer(signal.ITIMER_PROF) == (0.0, 0.0)


@pytest.mark.skipif(not UNIX_TIMER, reason="setitimer (Unix)")
def test_a_later_cpu_timer_in_user_code_reaches_the_user_handler():
    """After the team's calls, whether they succeeded or failed, SIGPROF is the user's again."""
    fired = []

    def mine(signum, frame):
        fired.append(signum)

    previous = signal.signal(signal.SIGPROF, mine)
    try:
        env = soccer_drill.HolderEnv(opponent=_Hanging("act", "loop", hang_seconds=5.0),
                                     team_timeout=0.1)
        env.reset(seed=0)
        with pytest.raises(TeamError, match="exceeded its time bound"):
            _steps(env, "holder", 10)
        assert _run_to_end(env, "holder", seed=1) in soak.OUTCOMES
        signal.setitimer(signal.ITIMER_PROF, 0.01)
        end = time.thread_time() + 5.0
        while not fired and time.thread_time() < end:
            pass  # computing: the CPU-time timer fires and the handler runs here
        assert fired == [signal.SIGPROF]
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0.0)
        signal.signal(signal.SIGPROF, previous)


# -------------------------------------------------------- teams that misbehave
class _Scripted:
    """A team whose ``reset`` and ``act`` do what the test says."""

    def __init__(self, act=None, reset=None):
        self._act, self._reset = act, reset

    def reset(self, view, rng):
        self.players = view.players
        if self._reset is not None:
            self._reset()

    def act(self, view):
        return self._act(self.players)


class _NotAllowedToIterate(dict):
    def __iter__(self):
        raise RuntimeError("my mapping is broken")


def test_a_team_that_raises_in_reset_is_named_with_the_cause():
    calls = []

    def reset_once():
        calls.append(1)
        if len(calls) == 1:
            raise RuntimeError("lost the whistle")

    env = soccer_drill.env(
        opponent=_Scripted(lambda p: dict.fromkeys(p, Command(Skill.MARK)), reset_once)
    )
    with pytest.raises(TeamError, match=r"'_Scripted' raised in reset\(\): RuntimeError") as err:
        env.reset(seed=0)
    assert isinstance(err.value.__cause__, RuntimeError)
    assert _run_to_end(env, "aec", seed=0) in soak.OUTCOMES  # the next reset works


@pytest.mark.parametrize(
    ("act", "message"),
    [
        # Beyond tests/test_errors.py: other wrong shapes and types of commands.
        (lambda p: None, r"must return a mapping .* got NoneType at cycle 0"),
        (lambda p: [Command(Skill.MARK)] * 2, r"must return a mapping .* got list"),
        (lambda p: {**dict.fromkeys(p, Command(Skill.MARK)), 7: Command(Skill.MARK)},
         r"exactly the players it drives .*got \['defender_0', 'defender_1', 7\]"),
        (lambda p: _NotAllowedToIterate(dict.fromkeys(p, Command(Skill.MARK))),
         r"returned commands that could not be checked at cycle 0: RuntimeError"),
        (lambda p: dict.fromkeys(p, Command(Skill.MARK, speed=True)),
         r"speed must be a real number in \(0, 1\] .* got True of type bool"),
        (lambda p: dict.fromkeys(p, Command(Skill.MARK, speed=math.nan)), "speed must be in"),
        (lambda p: dict.fromkeys(p, Command(Skill.MARK, speed=0)), "speed must be in"),
        (lambda p: dict.fromkeys(p, Command(Skill.MARK, speed="fast")),
         "speed must be a real number .* of type str"),
        (lambda p: dict.fromkeys(p, Command(1)), "skill 1 is not allowed for a scripted defender"),
        (lambda p: dict.fromkeys(p, Command(Skill.PASS)), "not allowed for a scripted defender"),
        (lambda p: dict.fromkeys(p, Command(Skill.MOVE_TO)), "MOVE_TO needs a finite"),
        (lambda p: dict.fromkeys(p, Command(Skill.MOVE_TO, "ab")), "MOVE_TO needs a finite"),
        (lambda p: dict.fromkeys(p, Command(Skill.MOVE_TO, 5.0)), "MOVE_TO needs a finite"),
        (lambda p: dict.fromkeys(p, Command(Skill.MOVE_TO, (1.0, 2.0, 3.0))), "MOVE_TO needs"),
        (lambda p: dict.fromkeys(p, Command(Skill.MOVE_TO, (1.0, math.inf))), "MOVE_TO needs"),
    ],
)
def test_invalid_commands_are_refused_by_name(act, message):
    env = soccer_drill.parallel_env(opponent=_Scripted(act))
    obs, _ = env.reset(seed=0)
    with pytest.raises(TeamError, match=message) as err:
        env.step({a: int(np.flatnonzero(o["action_mask"])[0]) for a, o in obs.items()})
    assert "team '_Scripted'" in str(err.value)


def test_numpy_numbers_are_valid_commands():
    team = _Scripted(lambda p: dict.fromkeys(
        p, Command(Skill.MOVE_TO, np.array([10.0, np.float32(5.0)]), speed=np.float32(0.5))))
    assert _run_to_end(soccer_drill.env(opponent=team), "aec", seed=0) in soak.OUTCOMES


class _Writer:
    """A team that tries to change the drill through its view at cycle 1."""

    def __init__(self, write):
        self.write = write

    def reset(self, view, rng):
        self.players = view.players

    def act(self, view):
        if view.cycle == 1:
            self.write(view)
        return dict.fromkeys(self.players, Command(Skill.MARK))


def _set_cycle(view):
    view.state.cycle = 10**6


def _set_pos(view):
    view.state.pos = ((0.0, 0.0),) * 5


def _set_holder(view):
    view.state.holder = 2


def _set_players(view):
    view.players = ("attacker_0", "attacker_1")


def _write_positions(view):
    view.positions[2] = (1.0, 1.0)


@pytest.mark.parametrize("write", [_set_cycle, _set_pos, _set_holder, _set_players,
                                   _write_positions])
def test_a_team_cannot_change_the_drill_through_its_view(write):
    env = soccer_drill.HolderEnv(opponent=_Writer(write), decision_cycles=1)
    env.reset(seed=0)
    env.step(0)  # cycle 0
    before = env.drill_state
    with pytest.raises(TeamError, match=r"team '_Writer' raised in act\(\) at cycle 1: "
                                        r"(AttributeError|ValueError)"):
        env.step(0)
    assert env.drill_state is before and before.cycle == 1 and before.holder in (0, 1)
    assert env.loop.core.team.view.players == ("defender_0", "defender_1")


class _Flip:
    """A point that reads as finite once, then as NaN."""

    def __init__(self):
        self.reads = 0

    def __len__(self):
        return 2

    def __iter__(self):
        self.reads += 1
        return iter((5.0, 5.0) if self.reads == 1 else (math.nan, math.nan))


def test_a_move_to_target_is_copied_when_checked():
    targets = []

    def act(players):
        targets.append(_Flip())
        return {players[0]: Command(Skill.MOVE_TO, targets[-1]),
                players[1]: Command(Skill.MOVE_TO, [30.0, np.float32(5.0)])}

    env = soccer_drill.HolderEnv(opponent=_Scripted(act), decision_cycles=1)
    env.reset(seed=0)
    for _ in range(30):  # 3 s: long enough to get there from the start (13, 9)
        env.step(0)  # the holder shields the ball: no outcome this soon
    state = env.drill_state
    assert state.cycle == 30 and all(math.isfinite(c) for p in state.pos for c in p)
    assert math.hypot(state.pos[2][0] - 5.0, state.pos[2][1] - 5.0) < 1.0
    assert math.hypot(state.pos[3][0] - 30.0, state.pos[3][1] - 5.0) < 1.0
    assert all(t.reads == 1 for t in targets)


@pytest.mark.parametrize("bad", [Command(Skill.MARK, speed=0), None, Command(Skill.PASS)])
def test_each_players_command_is_checked_when_the_two_are_different_objects(bad):
    """One object for both players is checked once; a second, different one on its own."""
    team = _Scripted(lambda p: {p[0]: Command(Skill.MARK), p[1]: bad})
    env = soccer_drill.parallel_env(opponent=team)
    obs, _ = env.reset(seed=0)
    with pytest.raises(TeamError, match=r"player 'defender_1', cycle 0"):
        env.step({a: int(np.flatnonzero(o["action_mask"])[0]) for a, o in obs.items()})


def test_one_command_object_for_both_players_is_read_once_and_drives_both():
    targets = []

    def act(players):
        targets.append(_Flip())
        return dict.fromkeys(players, Command(Skill.MOVE_TO, targets[-1]))

    env = soccer_drill.HolderEnv(opponent=_Scripted(act), decision_cycles=1)
    env.reset(seed=0)
    for _ in range(50):  # 5 s: long enough for both to get there from their starts
        env.step(0)
    state = env.drill_state
    assert state.cycle == 50 and all(math.isfinite(c) for p in state.pos for c in p)
    for defender in (2, 3):  # both went to the point read once (side by side), not to NaN
        assert math.hypot(state.pos[defender][0] - 5.0, state.pos[defender][1] - 5.0) < 1.5
    assert len(targets) == 50 and all(t.reads == 1 for t in targets)


@pytest.mark.parametrize("params", [[1, 2], "speed", {1: 2}, 3.0])
def test_opponent_params_must_be_a_mapping_of_names(params):
    with pytest.raises(TypeError, match=r"opponent_params must be None or a mapping of parameter "
                                        r"names \(str\) to values, got "):
        soccer_drill.HolderEnv(opponent="chasers", opponent_params=params)


# ----------------------------------------------------- SIGKILL mid-experiment
def _experiment_command(out: Path) -> list[str]:
    return [sys.executable, "-m", "ilpss.experiments.cli", "--protocol", "A", "--seeds", "1",
            "--episodes", "150", "--rollouts", "5", "--methods", "ilpss", "--workers", "1",
            "--quiet", "--no-report", "--out", str(out)]


def _final_state(out: Path) -> tuple[bytes, bytes, list[np.ndarray]]:
    job = out / "seed_000" / "stream_00"
    checkpoint = job / "ilpss" / (job / "ilpss" / "LATEST").read_text()
    arrays = []
    for path in sorted(checkpoint.rglob("*.npz")):
        with np.load(path, allow_pickle=False) as f:
            arrays += [f[k] for k in sorted(f.files) if k != "__meta__"]
    return (job / "result.json").read_bytes(), (checkpoint / "state.json").read_bytes(), arrays


@pytest.mark.slow
@pytest.mark.skipif(sys.platform == "win32", reason="SIGKILL")
def test_sigkill_mid_trial_then_restart_ends_identical_to_an_uninterrupted_run(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    straight, killed = tmp_path / "straight", tmp_path / "killed"
    subprocess.run(_experiment_command(straight), check=True, env=env, timeout=120)

    process = subprocess.Popen(_experiment_command(killed), env=env)
    latest = killed / "seed_000" / "stream_00" / "ilpss" / "LATEST"
    deadline = time.monotonic() + 60
    while not latest.exists() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    time.sleep(0.2)  # well inside the next trial (each takes about a second)
    process.send_signal(signal.SIGKILL)
    assert process.wait(30) == -signal.SIGKILL  # killed, not finished
    assert latest.read_text() in ("trial_0001", "trial_0002", "trial_0003")
    assert not (killed / "seed_000" / "stream_00" / "result.json").exists()

    subprocess.run(_experiment_command(killed), check=True, env=env, timeout=120)
    result_a, state_a, arrays_a = _final_state(straight)
    result_b, state_b, arrays_b = _final_state(killed)
    assert result_a == result_b  # the saved results, byte for byte
    assert state_a == state_b  # records and configuration of the last checkpoint
    assert len(arrays_a) == len(arrays_b) > 0  # policies, bags, option library, kernels
    for a, b in zip(arrays_a, arrays_b, strict=True):
        np.testing.assert_array_equal(a, b)
    assert json.loads(result_a)["methods"]["ilpss"]["curves"].keys() == {"3"}


# ----------------------------------------------------------- hostile configs
@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"n_seeds": "3"},
         r"ExperimentConfig.n_seeds must be an integer in \[1, 100,000\], got '3'"),
        ({"n_seeds": 2.0}, r"n_seeds must be an integer in \[1, 100,000\], got 2.0"),
        ({"n_seeds": True}, r"n_seeds must be an integer in \[1, 100,000\], got True"),
        ({"first_seed": -1}, r"first_seed must be an integer in \[0, 4,294,967,295\], got -1"),
        ({"n_shuffles": False}, r"n_shuffles must be an integer in \[0, 1,000\], got False"),
        ({"workers": 0}, r"workers must be an integer in \[1, 1,024\]"),
        ({"workers": 10**6}, r"workers must be an integer in \[1, 1,024\], got 1000000"),
        ({"stream_length": 10**9}, r"stream_length must be an integer in \[1, 10,000\]"),
        ({"prq": {"psi": math.nan}},
         r"ExperimentConfig.prq: PrqConfig.psi must be a finite number in \[0, 1\], got nan"),
        ({"prq": {"psi": "0.5"}}, r"PrqConfig.psi must be a finite number in \[0, 1\], got '0.5'"),
        ({"prq": {"upsilon": math.inf}},
         r"PrqConfig.upsilon must be a finite number in \[0, 1\], got inf"),
        ({"prq": {"upsilon": 1.5}}, r"PrqConfig.upsilon must be a finite number in \[0, 1\]"),
        ({"prq": {"delta_tau": -math.inf}},
         r"PrqConfig.delta_tau must be a finite number >= 0, got -inf"),
        ({"prq": {"delta_tau": math.nan}}, "PrqConfig.delta_tau must be a finite number"),
        ({"prq": [1]}, "ExperimentConfig.prq must be a JSON object of PrqConfig fields, got list"),
        ({"methods": "ilpss"}, r"ExperimentConfig.methods must be a list of at least 1 distinct "
                               r"values, each a name .*, got 'ilpss'"),
        ({"methods": []}, r"ExperimentConfig.methods must be a list of at least 1 distinct"),
        ({"methods": ["scratch", "scratch"]}, r"methods must be a list of at least 1 distinct"),
        ({"methods": [1]}, r"ExperimentConfig.methods must be a list .*, got \(1,\)"),
        ({"methods": ["magic"]}, r"ExperimentConfig.methods must name a registered method "
                                 r"\(entry-point group 'ilpss.methods'\), got 'magic'"),
        ({"teams": "goal_guards"}, r"ExperimentConfig.teams must be a list of at least 1 values, "
                                   r"each a non-empty string, got 'goal_guards'"),
        ({"teams": ["chasers", ""]}, "ExperimentConfig.teams must be a list of at least 1 values"),
        ({"teams": ["chasers", None]}, "ExperimentConfig.teams must be a list of at least 1"),
        ({"protocol": "B", "teams": ["chasers", "chasers"]}, "must not repeat a team"),
        ({"protocol": "a"}, r"ExperimentConfig.protocol must name a registered protocol "
                            r"\(entry-point group 'ilpss.protocols'\), got 'a'; registered: "
                            r"\['A', 'B', 'C'"),
        ({"executor": "slurm"}, "ExperimentConfig.executor must be 'local' or 'ray'"),
        ({"env_id": ""}, "ExperimentConfig.env_id must be a Gymnasium id"),
        ({"env_id": "a:b:c"}, "ExperimentConfig.env_id must be 'id' or 'package:id'"),
        ({"sampler": "opponents.parametric:sample_opponents"},
         "sampler must be the name of a registered sampler"),
        ({"sampler": "a b"}, "sampler must be the name of a registered sampler"),
        ({"protocol": "C", "sampler": "nobody"},
         r"sampler must name a registered sampler .*registered: \[.*'parametric'"),
        ({"sampler_team": 3}, "ExperimentConfig.sampler_team must be a non-empty string, got 3"),
        ({"lifelong": [1, 2]}, "ExperimentConfig.lifelong must be a JSON object"),
        ({"lifelong": {"library": {"discount": 2.0}}},
         r"ExperimentConfig.lifelong: LifelongConfig.library: OptionSettings.discount must be a "
         r"finite number in \(0, 1\], got 2.0"),
        ({"lifelong": {"learner": {"alpah": 0.1}}}, r"ExperimentConfig.lifelong: "
         r"LifelongConfig.learner: unknown LearnerConfig field\(s\) \['alpah'\]"),
    ],
)
def test_hostile_experiment_configs_name_the_field(changes, message):
    values = {**ExperimentConfig().to_dict(), **changes}
    with pytest.raises(ValueError, match=message):
        ExperimentConfig.from_dict(json.loads(json.dumps(values)))


def test_config_must_be_an_object_and_direct_construction_is_checked_too():
    for bad in ([], "A", None, 3):
        with pytest.raises(ValueError, match="must be a JSON object"):
            ExperimentConfig.from_dict(bad)
    with pytest.raises(ValueError, match=r"PrqConfig\.psi must be a finite number"):
        ExperimentConfig(prq=PrqConfig(psi=float("nan")))
    with pytest.raises(ValueError, match="lifelong must be a LifelongConfig"):
        ExperimentConfig(lifelong={"train_episodes": 3})
    with pytest.raises(ValueError, match="prq must be a PrqConfig"):
        ExperimentConfig(prq={"psi": 1.0})
    assert ExperimentConfig(methods=["ilpss", "scratch"]).methods == ("ilpss", "scratch")  # JSON's lists: tuples


def test_an_unknown_team_fails_the_run_naming_it(tmp_path):
    cfg = ExperimentConfig(n_seeds=1, workers=1, methods=("scratch",),
                           teams=("no_such_team", "chasers")).with_overrides(
        lifelong={"train_episodes": 2, "rollout_episodes": 1})
    with pytest.raises(ValueError, match=r"unknown team 'no_such_team'; known teams: \["):
        run_experiment(cfg, tmp_path, progress=False)


def test_cli_config_with_wrong_types_is_refused_by_name(tmp_path, capsys):
    path = tmp_path / "config.json"
    path.write_text(json.dumps({"n_seeds": "3"}))
    with pytest.raises(SystemExit) as exc:  # a usage error, not a traceback
        cli_main(["--config", str(path), "--out", str(tmp_path / "out"), "--quiet"])
    assert exc.value.code == 2
    assert "ExperimentConfig.n_seeds must be an integer" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()  # refused before anything was written


def test_cli_config_that_is_not_json_gives_a_clear_error(tmp_path, capsys):
    path = tmp_path / "config.json"
    path.write_text('{"n_seeds": 3,')  # truncated
    with pytest.raises(SystemExit) as exit_info:
        cli_main(["--config", str(path), "--out", str(tmp_path / "out"), "--quiet"])
    assert exit_info.value.code == 2
    assert f"--config {path}: not valid JSON" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("alpha", math.nan, r"LearnerConfig.alpha must be a finite number in \(0, 1\]"),
        ("epsilon", "0.1", r"LearnerConfig.epsilon must be a finite number in \[0, 1\]"),
        ("epsilon", 1.5, r"LearnerConfig.epsilon must be a finite number in \[0, 1\]"),
        ("gamma", -0.1, r"LearnerConfig.gamma must be a finite number in \[0, 1\]"),
        ("method", "td", "LearnerConfig.method must be 'sarsa' or 'q'"),
        ("n_tilings", 0, r"LearnerConfig.n_tilings must be an integer in \[1, 1,024\]"),
        ("n_tilings", 10**9, r"LearnerConfig.n_tilings must be an integer in \[1, 1,024\]"),
        ("tile_widths", (1.0, math.nan), r"LearnerConfig.tile_widths must be None or a list of at "
                                         r"least 1 values, each a finite number > 0"),
    ],
)
def test_learner_config_validation(field, value, message):
    with pytest.raises(ValueError, match=message):
        LearnerConfig(**{field: value})


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [

        ("kernel_reg_covar", -1.0, "LifelongConfig.kernel_reg_covar must be"),
        ("train_episodes", 10**9,
         r"LifelongConfig.train_episodes must be an integer in \[0, 1,000,000\]"),
        ("n_kernels", 0, r"LifelongConfig.n_kernels must be an integer in \[1, 1,000\]"),
        ("learner", {"alpha": 0.1}, "LifelongConfig.learner must be a LearnerConfig"),
    ],
)
def test_lifelong_config_validation(field, value, message):
    with pytest.raises(ValueError, match=message):
        LifelongConfig(**{field: value})


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("discount", "0.5", r"OptionSettings.discount must be a finite number in \(0, 1\]"),
        ("max_match_distance", math.nan, "OptionSettings.max_match_distance must be None or a"),
        ("max_depth", 10**6, r"OptionSettings.max_depth must be an integer in \[1, 1,000\]"),
    ],
)
def test_option_settings_validation(field, value, message):
    with pytest.raises(ValueError, match=message):
        OptionSettings(**{field: value})
