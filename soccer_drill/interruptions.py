"""Which exceptions out of a team's code a signal delivered, and short descriptions of
what a team gave or raised.

A team's ``KeyboardInterrupt`` or ``SystemExit`` is the team's failure, to be reported
as such; the user's Ctrl-C arriving while a team computes (or a ``SIGTERM`` handler
calling ``sys.exit()`` then) must still stop the program. The two look alike, so
:func:`delivered_by_signal` tells them apart from the traceback, only when such an
exception occurs (nothing is added to a call that succeeds):

| the exception | delivered by a signal when |
|---|---|
| ``KeyboardInterrupt`` | its innermost frame did not stop at a ``raise`` statement nor at a generator's ``yield`` (where ``generator.throw()`` raises it): Python's own ``SIGINT`` handler (C code) raises it wherever the interpreter checks for signals, never at either |
| any | one of its frames runs a Python signal handler installed now (e.g. a ``SIGTERM`` handler calling ``sys.exit()``, a ``SIGALRM`` handler raising a wall-clock bound's exception): a function, a method, a ``functools.partial`` or an object with ``__call__`` |

A team that catches the user's Ctrl-C and re-raises it (``raise`` alone) keeps the
original traceback, so that is still the user's; a team that raises a new
``KeyboardInterrupt`` is reported as the team's.

:class:`SignalsDeferred` holds back every signal with a Python handler over a block that
must not be cut (building and freeing pymunk spaces, numba's first compilation), and
delivers them when the block ends.
"""

from __future__ import annotations

import dis
import enum
import functools
import reprlib
import signal
import threading
from types import FrameType, TracebackType
from typing import Any

try:
    import _signal as _sig  # the C functions under signal's enum wrappers, ten times cheaper
except ImportError:  # pragma: no cover - other Python implementations
    _sig = signal  # type: ignore[assignment]

_MAIN_THREAD = threading.main_thread().ident

# Where code raises: a raise statement, or ``generator.throw()`` (also a coroutine's), which
# raises at the generator's suspended yield, or at the start of one not yet started. The
# interpreter delivers a signal at none of them (it checks for signals on calls, loops'
# backward jumps and a frame's resumption, after its yield). The names are looked up, so
# an instruction a Python version lacks is left out: its throw() then counts as a signal.
_RAISED_BY_CODE = frozenset(
    dis.opmap[name] for name in ("RAISE_VARARGS", "YIELD_VALUE", "RETURN_GENERATOR")
    if name in dis.opmap
)
_short = reprlib.Repr()
_short.maxlevel, _short.maxstring, _short.maxother, _short.maxlong = 2, 400, 400, 40
_short.maxdict = _short.maxlist = _short.maxtuple = _short.maxset = 6
MAX_ITEMS = 6
"""How many keys or items an error message lists at most."""


class _NoPythonOnMisses(enum.EnumType):
    """``EnumType`` whose class-attribute misses run no Python code (Python 3.11's
    ``EnumType.__getattr__`` does; a miss falls through to ``type``'s own lookup)."""

    __getattr__ = type.__getattribute__


class QuietIntEnum(enum.IntEnum, metaclass=_NoPythonOnMisses):
    """An ``IntEnum`` whose members numpy can meet without losing a signal.

    numpy probes the type of every object it is handed (``__array_priority__``,
    ``__array_function__``, ...) and clears any exception from the probe. On an
    ``IntEnum`` class each probe misses and runs ``EnumType.__getattr__``, Python code
    where a signal handler can run; what it raises (a Ctrl-C, a wall-clock bound's
    exception) was then lost in ``array == Outcome.RUNNING``. Here a miss is
    ``type``'s plain lookup, C code that never runs a handler.
    """


def short_repr(value: object) -> str:
    """``repr(value)`` cut to about 400 characters (containers to a few items), for
    error messages about what a team gave: a team's huge or hostile object must not make
    a huge message. Run it inside the team's time bound: it runs the value's
    ``__repr__``."""
    try:
        return _short.repr(value)
    except Exception as exc:  # a __repr__ that raises
        return f"<{type(value).__name__} whose repr() raised {type(exc).__name__}>"


def _innermost(tb: TracebackType) -> TracebackType:
    while tb.tb_next is not None:
        tb = tb.tb_next
    return tb


def _handler_codes() -> set:
    codes = set()
    for signum in signal.valid_signals():
        try:
            handler = signal.getsignal(signum)
        except (ValueError, OSError):  # pragma: no cover - signals Python cannot read
            continue
        code = _code_of(handler)
        if code is not None:
            codes.add(code)
    return codes


def _code_of(handler: object) -> object:
    """The code a Python signal handler runs first: a function's, a bound method's, a
    ``functools.partial``'s function's, or a callable object's ``__call__``'s."""
    for _ in range(8):  # partials of partials, methods, objects: a few layers at most
        code = getattr(handler, "__code__", None)
        if code is not None:
            return code
        if isinstance(handler, functools.partial):
            handler = handler.func
        elif hasattr(handler, "__func__"):
            handler = handler.__func__
        else:
            call = type(handler).__dict__.get("__call__")  # a class's own, not type's
            if call is None or call is handler:
                return None
            handler = call
    return None


def delivered_by_signal(exc: BaseException) -> bool:
    """Whether a signal delivered ``exc`` rather than code raising it (table above)."""
    tb = exc.__traceback__
    if tb is None:
        return isinstance(exc, KeyboardInterrupt)  # nothing to tell by: the user's, to be safe
    if isinstance(exc, KeyboardInterrupt):
        last = _innermost(tb)
        try:
            if last.tb_frame.f_code.co_code[last.tb_lasti] not in _RAISED_BY_CODE:
                return True
        except IndexError:  # pragma: no cover - an offset outside the code: be safe
            return True
    codes = _handler_codes()
    while tb is not None:
        if tb.tb_frame.f_code in codes:
            return True
        tb = tb.tb_next
    return False


def _readable(signum: int) -> bool:
    try:
        _sig.getsignal(signum)
    except (ValueError, OSError):  # pragma: no cover - signals Python cannot read
        return False
    return True


_SIGNALS = tuple(sorted(s for s in map(int, signal.valid_signals()) if _readable(s)))
_getsignal = _sig.getsignal
_mask = getattr(signal, "pthread_sigmask", None)


class SignalsDeferred:
    """A block in which every signal with a Python handler waits for the block to end,
    then arrives: a Ctrl-C, and a ``SIGALRM`` or ``SIGTERM`` handler that raises.

    For code that an exception must not cut: pymunk frees a space, its bodies and shapes
    in finalisers that run Python code, and cffi prints and ignores an exception raised
    there, so a signal handler raising inside (a ``KeyboardInterrupt``, a wall-clock
    bound's exception, ``sys.exit()`` in a ``SIGTERM`` handler) is lost, and a space freed
    half-way aborts or crashes the process at a later garbage collection; numba's first
    compilation of a function, cut, leaves its registries broken for the process.

    Inside the block each Python handler is replaced by one that notes the signal; at the
    end the handlers are put back and each signal noted is raised again
    (``signal.raise_signal``, with the signals blocked for this thread until all are
    raised), so its handler runs just after the block as it would have run inside: with
    the program's own frame, so :func:`delivered_by_signal` knows it. A handler left in
    place because an exception arrived while they were being put back passes its signal
    on to the program's handler. Only on the main thread, where Python runs signal
    handlers; ``SIG_DFL`` and ``SIG_IGN`` are left alone. Costs about 14 us on a loaded
    2-core machine (it reads each of the 62 signals' handlers).

    With ``second_passes=True`` a signal that comes a second time inside the block is not
    held: its handler runs at once (pressing Ctrl-C twice stops a block that hangs, such
    as a plugin's import), and the first one is then not raised again.
    """

    __slots__ = ("_came", "_deferring", "_previous", "_second_passes")

    def __init__(self, second_passes: bool = False) -> None:
        self._second_passes = second_passes

    def __enter__(self) -> SignalsDeferred:
        self._previous: dict[int, Any] = {}
        self._came: list[int] = []
        self._deferring = True
        if threading.get_ident() != _MAIN_THREAD:
            return self
        note, previous, getsignal, setsignal = self._note, self._previous, _getsignal, _sig.signal
        try:
            for signum in _SIGNALS:
                handler = getsignal(signum)
                if handler is not None and type(handler) is not int and handler != note:
                    previous[signum] = handler
                    setsignal(signum, note)
        except BaseException:  # a handler not yet replaced raised: nothing is held back
            self.__exit__()
            raise
        return self

    def _note(self, signum: int, frame: FrameType | None) -> None:
        if self._deferring and not (self._second_passes and signum in self._came):
            self._came.append(signum)
            return
        if self._deferring:  # a second one: it arrives now, and once
            self._came.remove(signum)
        handler = self._previous.get(signum)  # left in place: the program's handler runs
        if callable(handler):
            handler(signum, frame)

    def __exit__(self, *exc: object) -> None:
        self._deferring = False  # from here a signal reaching _note goes to its handler
        try:
            _put_back(list(self._previous.items()))
        finally:
            _raise_again(self._came)


def _put_back(handlers: list) -> None:
    """Put each ``(signum, handler)`` back, going on if a handler raises meanwhile (one
    left out still passes its signal on: :meth:`SignalsDeferred._note`)."""
    for i, (signum, handler) in enumerate(handlers):
        try:
            _sig.signal(signum, handler)
        except BaseException:
            _put_back(handlers[i + 1:])
            raise


def _raise_again(signals: list[int]) -> None:
    """Raise each of ``signals`` again, all pending before the first handler runs."""
    if not signals:
        return
    if _mask is None:  # pragma: no cover - platforms without pthread_sigmask
        for signum in dict.fromkeys(signals):
            signal.raise_signal(signum)
        return
    blocked = _mask(signal.SIG_BLOCK, [])
    try:
        _mask(signal.SIG_BLOCK, signals)
        for signum in dict.fromkeys(signals):
            signal.raise_signal(signum)
    finally:
        _mask(signal.SIG_SETMASK, blocked)  # the handlers run from here, one after another
