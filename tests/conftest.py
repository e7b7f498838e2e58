"""Test-wide setup: no display, no audio (pygame's render tests run headless), and the
BLAS kernels the recorded fixtures were computed with.

OpenBLAS picks its kernels by CPU, and kernels for different CPUs round matrix products
differently in the last bit; a lifelong run amplifies such a bit into other choices and
other curves. The fixtures of ``tests/data`` (the reference runs) were recorded with
OpenBLAS's ``Haswell`` kernels, so they are asked for here, before numpy is imported,
wherever the CPU can run them (AVX2 and FMA: nearly every x86-64 machine) and
``OPENBLAS_CORETYPE`` does not already name kernels. Elsewhere the reference tests say
why they cannot compare bits (``tests/blas.py``).
"""

import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from blas import pin_recorded_kernels

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
pin_recorded_kernels()


import pytest  # noqa: E402  (after the environment above is set)


@pytest.fixture
def team_registry():
    """The team registry, isolated for one test: the installed teams are discovered first
    (so the registry put back afterwards holds them all), then teams the test registers
    are gone after it."""
    import soccer_drill.teams.registry as teams

    with teams.TEAMS.isolated():
        yield teams




def pytest_configure(config):
    """The suite sends Ctrl-C and checks that it stops what runs, which needs Python's
    own SIGINT handler. A command started in the background by a shell without job
    control (``make test &`` in a script, a CI runner's step) inherits SIGINT ignored,
    and Python then installs no handler: every such test would see nothing raised."""
    import signal

    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)

_GUARDED_SIGNALS = ("SIGINT", "SIGTERM", "SIGALRM")


@pytest.fixture(autouse=True)
def _signal_handlers_put_back():
    """Every test ends with the handlers of the signals the suite sends as it found them,
    set again at the C level too. A command's ``main()`` leaves its ``SIGTERM`` handler in
    place (as a command should), a handler an interruption left in place passes its signal
    on but is not the one the test found, and a library that installs a C handler where
    it finds ``SIG_DFL`` (SDL, under pygame's display) is invisible to
    ``signal.getsignal``: left so, a later test in the same worker that sends the signal
    sees no exception, far from the cause."""
    import signal

    before = {name: signal.getsignal(getattr(signal, name)) for name in _GUARDED_SIGNALS}
    yield
    for name, handler in before.items():
        if handler is not None:  # None: a handler not set from Python, left alone
            signal.signal(getattr(signal, name), handler)
