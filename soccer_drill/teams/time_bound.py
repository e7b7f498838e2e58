"""A bound on the CPU time of one call, for the calls of scripted teams.

What is counted is the CPU time of the thread making the call (``time.thread_time``:
user and system time), less the CPU time of garbage collections that run during it. So
a loaded machine, which deschedules the process, never makes an honest call overrun: the
time the thread waits for a CPU, sleeps, or blocks on I/O or a lock is not counted. The
price is that a call blocked forever (a ``time.sleep`` or a lock that never comes) is
not stopped either: that needs a wall-clock watchdog around the whole run.

How an overrun is stopped: on the main thread of a Unix process a CPU-time interval
timer (``setitimer(ITIMER_PROF)``) ticks every :data:`LOOK` seconds of the process's CPU
time around the call (or once the bound is spent, if that comes first), and its ``SIGPROF``
handler raises :class:`Overrun` inside the call once the thread's own CPU time (less
garbage collections) has passed the bound. The timer is only the prompt to look, never
the measure: the kernel counts ``ITIMER_PROF`` against the process's CPU time as sampled
at clock ticks, which on a loaded machine falls far behind the time the thread really ran
(a 0.2 s ``ITIMER_PROF`` timer fired after 0.22-0.85 s of the thread's
``time.thread_time``, measured with four busy processes sharing one core), so a timer
armed for the whole bound let a call run several times its bound. Looking every
:data:`LOOK` seconds keeps that lag to a few hundredths of a second; other threads' CPU
time only makes it look more often. It does not raise in a garbage collection (where
finalisers and weakref callbacks run, and where an exception would be printed and
ignored) nor in this module's own bookkeeping: it marks the call overrun and raises when
the call returns, or at the next tick. Elsewhere -- off the main thread (signals reach
the main thread only), without ``setitimer`` (Windows), or with another ``ITIMER_PROF``
timer already armed (a profiler's: it is put back, with what it had left, within
microseconds) -- the call's CPU time is measured and :class:`Overrun` raised when it
returns. The previous ``SIGPROF`` handler is put back and the timer disarmed after every
call, whatever fails.
"""

from __future__ import annotations

import gc
import signal
import threading
import time
from collections.abc import Callable
from typing import Any

try:
    # The C functions under ``signal``'s enum wrappers: ``signal.signal`` costs ~2.7 us a
    # call (it converts the returned handler to an enum through an exception), these
    # ~0.3 us, which matters at two calls per drill cycle.
    import _signal as _sig
except ImportError:  # pragma: no cover - other Python implementations
    _sig = signal  # type: ignore[assignment]

CAN_INTERRUPT = hasattr(signal, "setitimer") and hasattr(signal, "SIGPROF")
"""Whether an overrunning call can be interrupted (on the main thread)."""
_MAIN_THREAD = threading.main_thread().ident
LOOK = 0.01
"""CPU seconds (of the process, as ``ITIMER_PROF`` counts them) between two looks at a
bounded call's own CPU time: a look costs a few microseconds."""
_thread_time = time.thread_time


class Overrun(BaseException):
    """Raised inside a call (or after it) whose CPU time passed its bound.

    A ``BaseException``, so the ``except Exception`` blocks of the call do not swallow
    it. ``cpu`` is the CPU time counted when the call was stopped, in seconds.
    """

    def __init__(self, cpu: float) -> None:
        super().__init__(cpu)
        self.cpu = cpu


class _GcTime(threading.local):
    """CPU seconds this thread has spent in garbage collections during bounded calls,
    and whether in one now."""

    started: float | None = None
    total = 0.0


_gc_time = _GcTime()


def _count_gc(phase: str, info: dict[str, Any]) -> None:
    """A ``gc.callbacks`` entry, there only while a bounded call runs (so collections
    outside them cost nothing)."""
    gc_time = _gc_time
    if phase == "start":
        gc_time.started = _thread_time()
    elif gc_time.started is not None:
        gc_time.total += _thread_time() - gc_time.started
        gc_time.started = None


class _Call:
    """A bounded call in progress: when it started and whether it has overrun."""

    __slots__ = ("closing", "cpu_start", "gc_start", "overrun", "timeout")

    def __init__(self, timeout: float) -> None:
        self.timeout = timeout
        self.cpu_start, self.gc_start = _thread_time(), _gc_time.total
        self.overrun = self.closing = False

    def cpu(self) -> float:
        """CPU seconds of this thread since the call started, garbage collections apart
        (also the one running now, if any)."""
        now = _thread_time()
        collecting = 0.0 if _gc_time.started is None else now - max(_gc_time.started,
                                                                     self.cpu_start)
        return now - self.cpu_start - (_gc_time.total - self.gc_start) - collecting


_active: _Call | None = None  # the main thread's interruptible call, read by the handler


class _Innermost(threading.local):
    """This thread's innermost bounded call (interruptible or measured)."""

    call: _Call | None = None


_innermost = _Innermost()


def counted_cpu() -> float:
    """This thread's CPU seconds as a bound counts them: less the garbage collections
    seen inside bounded calls. The difference of two readings within one bounded call is
    what a part of that call cost (a batch of drills times each drill's team apart)."""
    return _thread_time() - _gc_time.total


def restart_count() -> float:
    """Count the CPU time of this thread's innermost bounded call afresh from now, and
    return :func:`counted_cpu`.

    For a call that runs parts one after another, each held to the bound on its own (the
    batched drill runs a team's copies, one per drill, in one bounded call): a part that
    runs past ``timeout`` from its start is stopped as a call would be, with one timer
    armed for all of them (each tick looks at the part running then). Outside a bounded
    call it only returns :func:`counted_cpu`.
    """
    call, now, collected = _innermost.call, _thread_time(), _gc_time.total
    if call is not None:
        call.cpu_start, call.gc_start = now, collected
    return now - collected


def call_within(timeout: float, method: Callable[..., Any], *args: Any) -> Any:
    """``method(*args)``, raising :class:`Overrun` if it takes more than ``timeout``
    seconds of CPU time (see the module docstring for how, and what is not counted;
    :func:`restart_count` for a call of parts, each bounded on its own)."""
    global _active
    callbacks = gc.callbacks
    # No collection is running as a call starts: a signal handler that raised inside the
    # callback's "stop" (the exception ignored, as in any gc callback) left it marked as
    # running, which would have kept the timer from ever interrupting a call again.
    _gc_time.started = None
    callbacks.append(_count_gc)
    innermost = _innermost
    enclosing = innermost.call
    try:
        call = innermost.call = _Call(timeout)
        if (
            CAN_INTERRUPT
            and threading.get_ident() == _MAIN_THREAD
            and _sig.getsignal(signal.SIGPROF) is not None  # a handler we can put back
        ):
            outer = _active
            previous = _sig.signal(signal.SIGPROF, _on_cpu_timer)
            disarm = True
            try:
                # An interval, not a one-shot: it looks every LOOK seconds, and a call that
                # swallows the first interruption (a bare ``except:``) is interrupted again
                # at the next tick. Armed inside the ``try``, so
                # that the previous handler is put back even if arming fails. Arming
                # returns the timer it replaced, which saves asking first: someone else's
                # (a profiler's) is put back at once, and the call only measured.
                replaced = _sig.setitimer(signal.ITIMER_PROF, min(timeout, LOOK), LOOK)
                if replaced[0] == 0.0:
                    _active = call
                    try:
                        result = method(*args)
                    finally:
                        call.closing = True
                        _sig.setitimer(signal.ITIMER_PROF, 0.0)
                        _drain()  # run a handler pending from just before the disarm
                        _active = outer
                    if call.overrun:
                        raise Overrun(call.cpu())
                    return result
                disarm = False  # someone else's timer: put back as it was
                _sig.setitimer(signal.ITIMER_PROF, *replaced)
            finally:
                # Ours disarmed whatever happened, also when a signal handler raised just
                # after arming (an interval left armed made every later call only
                # measured, and with SIGPROF's default action would end the process).
                if disarm:
                    _sig.setitimer(signal.ITIMER_PROF, 0.0)
                _active = outer
                _sig.signal(signal.SIGPROF, previous)
        result = method(*args)
        if call.cpu() > timeout:
            raise Overrun(call.cpu())
        return result
    finally:
        innermost.call = enclosing
        callbacks.remove(_count_gc)


def _drain() -> None:
    """Nothing; calling a Python function runs the signal handlers pending by then."""


# Frames where the handler must not raise: the bookkeeping around the call.
_OWN_CODES = (call_within.__code__, _drain.__code__)


def _on_cpu_timer(signum: int, frame: Any) -> None:
    """SIGPROF during a bounded call: stop it if its own CPU time passed the bound (else
    the next tick looks again)."""
    call = _active
    if call is None:
        return
    used = call.cpu()
    if used < call.timeout:
        return
    call.overrun = True
    if call.closing or (frame is not None and frame.f_code in _OWN_CODES):
        return  # raised when the call returns
    if _gc_time.started is not None:  # in a collection (finalisers, weakref callbacks)
        return  # the next tick, after it
    raise Overrun(used)
