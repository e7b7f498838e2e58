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
| any | one of its frames runs a Python signal handler installed now (e.g. a ``SIGTERM`` handler calling ``sys.exit()``) |

A team that catches the user's Ctrl-C and re-raises it (``raise`` alone) keeps the
original traceback, so that is still the user's; a team that raises a new
``KeyboardInterrupt`` is reported as the team's.

:class:`CtrlCDeferred` holds a Ctrl-C back over a block that must not be cut (building
and freeing pymunk spaces), and delivers it when the block ends.
"""

from __future__ import annotations

import dis
import reprlib
import signal
import threading
from types import FrameType, TracebackType

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
        code = getattr(handler, "__code__", None)
        if code is not None:
            codes.add(code)
    return codes


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


class CtrlCDeferred:
    """A block in which a Ctrl-C (``SIGINT``) waits for the block to end, then arrives.

    For code that a ``KeyboardInterrupt`` must not cut: pymunk frees a space in a
    finaliser that lists its shapes and bodies through callbacks, and an exception raised
    in a callback is printed and ignored by cffi, so a Ctrl-C arriving there (or anywhere
    in the finaliser) leaves some of them in the freed space, and a later garbage
    collection aborts the process ("Aborting due to Chipmunk error") or crashes it. Inside
    the block, the program's ``SIGINT`` handler is replaced by one that notes the signal;
    at the end the handler is put back and, if the signal came, called then (Python's own
    raises ``KeyboardInterrupt`` there). Only on the main thread, where Python runs signal
    handlers, and only where that handler is a Python callable (not ``SIG_DFL`` or
    ``SIG_IGN``); elsewhere nothing changes. Costs about 1 us.
    """

    __slots__ = ("_came", "_previous")

    def __enter__(self) -> CtrlCDeferred:
        self._previous, self._came = None, False
        if threading.get_ident() == _MAIN_THREAD:
            previous = _sig.getsignal(signal.SIGINT)
            if callable(previous):
                _sig.signal(signal.SIGINT, self._note)
                self._previous = previous
        return self

    def _note(self, signum: int, frame: FrameType | None) -> None:
        self._came = True

    def __exit__(self, *exc: object) -> None:
        previous = self._previous
        if previous is not None:
            self._previous = None
            _sig.signal(signal.SIGINT, previous)
            if self._came:
                previous(signal.SIGINT, None)
