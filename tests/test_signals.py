"""Signal handlers that raise, of any signal, at any point; and numba's compiled rules
under interruption, a changed source and a read-only install.

* A handler of ``SIGALRM``, ``SIGTERM`` or ``SIGINT`` that raises, run while pymunk frees
  a space, a body or a shape (at a reset, when an environment is dropped or closed and
  garbage collected): the exception reaches the program, never lost in a finaliser
  (before: cffi printed "Exception ignored" and the space was left half-freed).
* The program's own exception, raised by its signal handler (a function, a
  ``functools.partial``, an object with ``__call__``) while a team's time bound is set,
  passes unchanged (before: reported as the team's ``TeamError``).
* A signal during the first use of the compiled rules in a process, at points spread
  over it: delivered once the rules are compiled or loaded, and the process steps on
  (before: every later step failed with "generator raised StopIteration", or the
  signal was lost).
* A compiled function's disk cache is stale when a module whose compiled function it
  calls changes (before: the old code ran).
* A read-only install with no writable cache directory imports, with one warning, and
  compiles in memory (before: "no locator available" at import).

Each runs in a fresh interpreter where a process's first use matters.
"""

from __future__ import annotations

import enum
import functools
import os
import re
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import soccer_drill
from soccer_drill import Command, Skill
from soccer_drill.rules.arrays import Outcome
from soccer_drill.rules.compiled import COMPILED
from soccer_drill.rules.motion import BallAction
from soccer_drill.teams.registry import TeamError

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
ROOT = Path(soccer_drill.__file__).resolve().parent.parent


def _run(code: str, env: dict | None = None, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=timeout, env=env)


_FINALISERS = r"""
import gc, signal, sys
import soccer_drill
from soccer_drill.vector import HolderVectorEnv

class Raised(Exception):
    pass

def raising(signum, frame):
    raise Raised(signum)

class AtFinaliser:
    # A signal arrives at the first call of one of pymunk's finalisers.
    def __init__(self, signum):
        self.signum, self.sent = signum, 0
    def __call__(self, frame, event, arg):
        if event == "call" and frame.f_code.co_name in ("spacefree", "freebody", "shapefree"):
            if not self.sent:
                self.sent = 1
                signal.raise_signal(self.signum)

sent = caught = 0
makers = [lambda: soccer_drill.HolderEnv(opponent="chasers"),
          lambda: HolderVectorEnv(2, opponent="chasers", drills_per_space=1)]
for signum in (signal.SIGALRM, signal.SIGTERM, signal.SIGINT):
    previous = signal.signal(signum, raising)
    for how in ("reset", "drop", "close"):
        for make in makers:
            env, hook = make(), AtFinaliser(signum)
            env.reset(seed=0)
            env.step(env.action_space.sample() * 0)
            sys.settrace(hook)
            try:
                if how == "reset":
                    env.reset(seed=1)
                else:
                    if how == "close":
                        env.close()
                    env = None
                    gc.collect()
                    make()  # a space of an environment gone is freed here at the latest
            except Raised:
                caught += 1
            finally:
                sys.settrace(None)
            sent += hook.sent
    signal.signal(signum, previous)
gc.collect()
print("sent", sent, "caught", caught)
"""


def test_a_raising_handler_of_any_signal_in_pymunks_finalisers_reaches_the_program():
    done = _run(_FINALISERS)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "Exception ignored" not in done.stderr, done.stderr[-3000:]
    sent, caught = (int(w) for w in done.stdout.split()[1::2])
    assert sent >= 12 and caught == sent, done.stdout


# --------------------------------------------------- the program's own exception
class _Timeout(Exception):
    """A program's wall-clock bound, raised by its SIGALRM handler."""


def _raise_timeout(signum, frame, what="function"):
    raise _Timeout(what)


class _CallableHandler:
    def __call__(self, signum, frame):
        raise _Timeout("object")


class _SignalledTeam:
    """A team during whose act() (or reset()) the program's SIGALRM arrives."""

    def __init__(self, when: str) -> None:
        self.when = when

    def reset(self, view, rng):
        if self.when == "reset":
            signal.raise_signal(signal.SIGALRM)

    def act(self, view):
        if self.when == "act":
            signal.raise_signal(signal.SIGALRM)
        return {p: Command(Skill.INTERCEPT) for p in view.players}


@pytest.mark.parametrize("handler", [_raise_timeout, functools.partial(_raise_timeout, what="p"),
                                     _CallableHandler()], ids=["function", "partial", "object"])
@pytest.mark.parametrize("when", ["reset", "act"])
def test_the_programs_exception_in_a_teams_bound_is_not_the_teams(handler, when):
    previous = signal.signal(signal.SIGALRM, handler)
    try:
        env = soccer_drill.HolderEnv(opponent=_SignalledTeam(when))
        with pytest.raises(_Timeout):
            env.reset(seed=0)
            for _ in range(200):
                env.step(0)
    finally:
        signal.signal(signal.SIGALRM, previous)


def test_a_teams_own_exception_is_still_the_teams():
    class Raises(_SignalledTeam):
        def act(self, view):
            raise _Timeout("the team's")

    env = soccer_drill.HolderEnv(opponent=Raises("never"))
    with pytest.raises(TeamError, match="the team's"):
        env.reset(seed=0)
        for _ in range(200):
            env.step(0)


# ------------------------------------------------------------- the first use
_FIRST_USE = r"""
import signal, sys
import numpy as np
import gymnasium as gym
import soccer_drill

class Raised(Exception):
    pass

def raising(signum, frame):
    raise Raised(signum)

class At:
    def __init__(self, k):
        self.k, self.seen = k, 0
    def __call__(self, frame, event, arg):
        if event == "call":
            self.seen += 1
            if self.seen == self.k:
                signal.raise_signal(signal.SIGALRM)

def first_use():
    env = gym.make_vec("soccer_drill/Holder-v0", num_envs=2,
                       vectorization_mode="vector_entry_point", opponent="chasers")
    env.reset(seed=0)
    for _ in range(5):
        env.step(np.zeros(2, dtype=np.int64))
    return env

signal.signal(signal.SIGALRM, raising)
hook = At(int(sys.argv[1]))
sys.settrace(hook)
try:
    first_use()
    outcome = "ran"
except Raised:
    outcome = "interrupted"
finally:
    sys.settrace(None)
env = first_use()  # the process steps on
env.reset(seed=1)
for _ in range(50):
    env.step(np.zeros(2, dtype=np.int64))
print(outcome, hook.seen)
"""


@pytest.mark.skipif(not COMPILED, reason="the rules run as plain Python")
def test_a_signal_during_the_first_use_of_the_compiled_rules_breaks_nothing():
    """The rules are loaded from the disk cache (the test suite has compiled them), the
    first use the issue's failure was seen in; a signal at points spread over it."""
    count = subprocess.run([sys.executable, "-c", _FIRST_USE, str(10**12)],
                           capture_output=True, text=True, timeout=600)
    assert count.returncode == 0, count.stderr[-3000:]
    calls = int(count.stdout.split()[1])
    for j in range(1, 7):
        k = calls * j // 7
        done = subprocess.run([sys.executable, "-c", _FIRST_USE, str(k)],
                              capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, (k, done.stderr[-3000:])
        assert done.stdout.split()[0] == "interrupted", (k, done.stdout, done.stderr[-2000:])


# --------------------------------------------------------------- the disk cache
_CALLER = """\
from soccer_drill.rules.compiled import compiled
from rulespkg.lead import lead


@compiled
def doubled():
    return 2.0 * lead()
"""
_CALLEE = """\
from soccer_drill.rules.compiled import compiled

LEAD_SECONDS = {}


@compiled
def lead():
    return LEAD_SECONDS
"""
_READ = ("import rulespkg.caller as c; print(c.doubled(), "
         "sum(c.doubled.stats.cache_hits.values()))")


@pytest.mark.skipif(not COMPILED, reason="the rules run as plain Python")
def test_a_compiled_cache_is_stale_when_a_module_it_calls_changes(tmp_path):
    package = tmp_path / "rulespkg"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "caller.py").write_text(_CALLER)
    (package / "lead.py").write_text(_CALLEE.format(1.0))
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    env.pop("NUMBA_CACHE_DIR", None)
    runs = []
    for lead in (1.0, 1.0, 3.0, 3.0):
        (package / "lead.py").write_text(_CALLEE.format(lead))
        done = _run(_READ, env)
        assert done.returncode == 0, done.stderr[-3000:]
        value, hits = done.stdout.split()
        runs.append((float(value), int(hits)))
    assert runs[0] == (2.0, 0)  # compiled, and cached
    assert runs[1] == (2.0, 1)  # loaded from the cache
    assert runs[2] == (6.0, 0)  # the callee changed: compiled again
    assert runs[3] == (6.0, 1)


_READ_ONLY = r"""
import sys, warnings
sys.meta_path[:] = [f for f in sys.meta_path if "editable" not in repr(f).lower()]
sys.path.insert(0, sys.argv[1])
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    import soccer_drill
    from soccer_drill.rules import compiled
    assert compiled.__file__.startswith(sys.argv[1]), compiled.__file__
    print(compiled.hypot(3.0, 4.0), compiled.hypot.stats.cache_misses)
print(len([w for w in caught if w.category is compiled.NoDiskCacheWarning]))
print(str([str(w.message) for w in caught]))
"""


@pytest.mark.skipif(not COMPILED, reason="the rules run as plain Python")
def test_a_read_only_install_with_a_read_only_home_imports(tmp_path):
    """Where no cache directory can be made (each ``__pycache__`` and the home's cache a
    file, so even root cannot write there), the package imports with one warning and
    compiles in memory."""
    install = tmp_path / "install"
    shutil.copytree(ROOT / "soccer_drill", install / "soccer_drill",
                    ignore=shutil.ignore_patterns("__pycache__"))
    for folder in [install / "soccer_drill", *(install / "soccer_drill").rglob("*")]:
        if folder.is_dir():
            (folder / "__pycache__").write_text("")
    home = tmp_path / "home"
    home.write_text("")
    env = {k: v for k, v in os.environ.items()
           if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME", "PYTHONPATH")}
    env.update(HOME=str(home), PYTHONDONTWRITEBYTECODE="1")
    done = subprocess.run([sys.executable, "-c", _READ_ONLY, str(install)],
                          capture_output=True, text=True, timeout=600, env=env)
    assert done.returncode == 0, done.stderr[-3000:]
    lines = done.stdout.splitlines()
    assert lines[0].startswith("5.0"), done.stdout
    assert lines[1] == "1", done.stdout
    assert "NUMBA_CACHE_DIR" in lines[2]



# ---------------------------------------------------------------- numpy and enums
@pytest.mark.parametrize("member", [Skill.PASS, Outcome.RUNNING, BallAction.KICK],
                         ids=["Skill", "Outcome", "BallAction"])
def test_numpy_meets_the_drills_enums_without_running_python_code(member):
    """numpy probes the type of what it is handed and clears any exception of the probe;
    on Python 3.11's ``IntEnum`` each probe ran ``EnumType.__getattr__``, where a signal
    handler's exception was lost (the signal soak found a Ctrl-C lost in
    ``outcome == Outcome.RUNNING``)."""
    calls = []
    array = np.arange(4)
    sys.setprofile(lambda frame, event, arg: calls.append(frame.f_code.co_name)
                   if event == "call" and frame.f_code.co_filename == enum.__file__ else None)
    try:
        np.where(array == member, array, -1)
        array[0] = member
        np.asarray(member)
    finally:
        sys.setprofile(None)
    assert calls == []


# ------------------------------------------------------- the single environments' lock
class _Alarm(Exception):
    pass


class _AtEvent:
    """A ``SIGALRM`` at the k-th point of one environment call where the interpreter runs
    signal handlers: a Python function's entry, and the return of a C function (checked
    right after the call); a profile function's exception lands there as a handler's."""

    def __init__(self, k: int) -> None:
        self.k, self.seen = k, 0

    def __call__(self, frame, event, arg) -> None:
        if event in ("call", "c_return"):
            self.seen += 1
            if self.seen == self.k:
                signal.raise_signal(signal.SIGALRM)


def _single_envs():
    def holder():
        env = soccer_drill.HolderEnv(opponent="chasers")
        return env, lambda: env.step(0)

    def parallel():
        env = soccer_drill.parallel_env(opponent="chasers")
        env.reset(seed=0)
        return env, lambda: env.step({a: 0 for a in env.agents})

    def aec():
        env = soccer_drill.env(opponent="chasers")
        return env, lambda: env.step(0)

    return {"holder": holder, "parallel": parallel, "aec": aec}


@pytest.mark.parametrize("kind", ["holder", "parallel", "aec"])
def test_a_signal_at_any_point_of_a_single_step_leaves_the_environment_usable(kind):
    """A handler raising at every call and return of one step (and of one reset): the
    environment then steps, or says to call reset(), and resets. Before: a signal just
    after the environment's lock was taken (``acquire()``, then ``try``) left it held,
    and every later call was refused as if another thread were stepping."""
    previous = signal.signal(signal.SIGALRM, functools.partial(_raise_timeout, what="alarm"))
    try:
        env, step = _single_envs()[kind]()
        for call in ("step", "reset"):
            env.reset(seed=0)
            count = _AtEvent(10**9)
            sys.setprofile(count)
            step() if call == "step" else env.reset(seed=1)
            sys.setprofile(None)
            for k in range(1, count.seen + 1):
                env.reset(seed=0)
                hook = _AtEvent(k)
                sys.setprofile(hook)
                try:
                    step() if call == "step" else env.reset(seed=1)
                except _Timeout:
                    pass
                finally:
                    sys.setprofile(None)
                try:
                    step()
                except RuntimeError as exc:
                    assert re.search(r"call reset\(\)|before reset\(\)", str(exc)), (k, exc)
                env.reset(seed=2)
                step()
    finally:
        signal.signal(signal.SIGALRM, previous)


# ----------------------------------------------------------- a registry's first read
def test_a_signal_while_a_registry_reads_its_entry_points_reaches_the_program(monkeypatch):
    """importlib.metadata suppresses any ``Exception`` while it lists a path entry, a
    signal handler's too: the signal soak lost a ``SIGALRM`` there. Here the signal
    arrives inside such a ``suppress`` while the distributions are listed; the registry
    reads its entry points with signals held back, and then delivers them."""
    import contextlib

    from soccer_drill import registry as registries

    listed, sent = registries.metadata.distributions, []

    def distributions():
        if not sent:
            sent.append(1)
            with contextlib.suppress(Exception):  # as importlib.metadata lists a path entry
                signal.raise_signal(signal.SIGALRM)
        return listed()

    monkeypatch.setattr(registries.metadata, "distributions", distributions)
    registry = registries.Registry("soccer_drill.opponents", "team")
    previous = signal.signal(signal.SIGALRM, _raise_timeout)
    try:
        with pytest.raises(_Timeout):
            registry.names()
    finally:
        signal.signal(signal.SIGALRM, previous)
    assert "chasers" in registry.names()  # read again, whole, at the next use


def test_a_signal_at_any_point_of_a_bounded_call_leaves_the_bound_working():
    """Before: a handler raising just after the CPU-time timer was armed left it armed,
    so every later call of a team was only measured, never interrupted (and with
    ``SIGPROF``'s default action a later tick would end the process)."""
    from soccer_drill.teams.time_bound import Overrun, call_within

    def spin():
        while True:
            pass

    previous = signal.signal(signal.SIGALRM, _raise_timeout)
    try:
        count = _AtEvent(10**9)
        sys.setprofile(count)
        call_within(1.0, int)
        sys.setprofile(None)
        for k in range(1, count.seen + 1):
            sys.setprofile(_AtEvent(k))
            try:
                call_within(1.0, int)
            except _Timeout:
                pass
            finally:
                sys.setprofile(None)
            assert signal.getitimer(signal.ITIMER_PROF) == (0.0, 0.0), k
        with pytest.raises(Overrun):
            call_within(0.05, spin)
    finally:
        signal.signal(signal.SIGALRM, previous)
