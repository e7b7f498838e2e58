"""The drill's rules compiled per drill with numba, or run as plain Python: the same floats.

A rule of the drill is written once, as a Python function over floats and NumPy arrays
(one drill's), and decorated with :func:`compiled`. With numba installed it is compiled
to machine code at first use (``cache=True``: the code is kept in ``__pycache__`` and
reused by later processes; ``benchmarks/bench_compile.py`` measures the first use); the
batched environments run it in a compiled loop over their drills, and the single ones
call it for their one drill. Without numba, or with ``NUMBA_DISABLE_JIT=1``, the same
functions run as plain Python, slower, with the same results:

* every arithmetic operation is IEEE double precision in both, in the order written
  (numba neither reorders nor fuses floating-point operations unless asked to);
* ``math.atan2``, ``acos``, ``cos``, ``sin``, ``exp`` and ``log`` call the C library's
  functions in both;
* a length is :data:`hypot`: CPython's ``math.hypot`` in plain Python, and in compiled
  code :func:`python_hypot`, CPython's algorithm for two coordinates written out (the C
  library's ``hypot``, which numba would call, rounds differently about once in 170
  calls). ``tests/test_compiled.py`` checks both equalities, and that whole episodes are
  the same bit for bit with and without compilation.
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import itertools
import math
import secrets
import sys
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any, ClassVar, TypeVar

import numpy as np

from soccer_drill.interruptions import SignalsDeferred, short_repr
from soccer_drill.registry import PluginWarning

try:
    import numba
except ImportError:  # pragma: no cover - numba is a dependency; tested with it disabled
    numba = None

F = TypeVar("F", bound=Callable[..., Any])
W = TypeVar("W", bound=Callable[[Any], None])

COMPILED = numba is not None and not numba.config.DISABLE_JIT
"""Whether the rules run compiled (numba importable, ``NUMBA_DISABLE_JIT`` not set)."""


def compiled(function: F) -> F:
    """``function`` compiled by numba (``nopython``, cached on disk: :func:`_disk_cache`),
    or, when the rules run as plain Python (:data:`COMPILED` false), itself reading its
    record arrays as compiled code does: by attribute (``state[i].holder``:
    :func:`_as_records`)."""
    if not COMPILED:
        return _as_records(function)  # type: ignore[return-value]
    dispatcher = numba.njit(function)  # type: ignore[union-attr]
    cache = _disk_cache(function)
    if cache is not None:
        dispatcher._cache = cache  # what Dispatcher.enable_caching sets, with our stamp
    return dispatcher  # type: ignore[return-value]


def bind(rule: Callable[..., Any], *args: Any) -> Callable[[], Any]:
    """``rule(*args)`` as a call of no arguments, for a caller that calls a compiled rule
    with the same objects every time: its own arrays, whose contents change between calls.

    numba types every argument at each call of a compiled function, about 0.1 us for an
    array of numbers and 0.4-1 us for an array of records (a cycle's rules take three);
    the bound call runs the code compiled for these arguments' types without typing them
    again, the same machine code with the same results. So the arguments must stay the
    objects they are, never reshaped nor given another dtype: bind only arrays the caller
    made and keeps. A bound call is not copied with its owner (a copy binds its own
    arrays). Found among the rules :func:`warm_up` compiled (or compiled here, with
    signals held back, for types it did not warm); plain Python when the rules are not
    compiled.
    """
    return functools.partial(typed(rule, *args), *args)


def typed(rule: F, *args: Any) -> F:
    """``rule``'s machine code for the types of ``args`` (as :func:`bind` finds it), called
    with arguments of exactly those types without typing them: for a caller that has
    checked what it passes (the dtype, the number of dimensions, C order, writeable or
    not), which numba would otherwise type again at each call. ``rule`` itself when the
    rules are not compiled, or ``rule`` is not a compiled function."""
    if not COMPILED or not hasattr(rule, "typeof_pyval"):  # plain Python (a user's rule)
        return rule
    types = tuple(rule.typeof_pyval(a) for a in args)  # type: ignore[attr-defined]
    with SignalsDeferred():
        return rule.compile(types)  # type: ignore[attr-defined,no-any-return]


class NoDiskCacheWarning(UserWarning):
    """No directory numba can write its cache in: the rules are compiled in memory, at
    every process's first use."""


_warned_no_cache = False


def _disk_cache(function: Callable[..., Any]) -> Any:
    """numba's disk cache of ``function``, stamped with every source it may depend on
    (:func:`rule_sources_digest`), or ``None`` (one :class:`NoDiskCacheWarning` per
    process) when no directory for it is writable.

    numba checks a cached function against its own file only, and a compiled function
    inlines the constants, and calls the compiled functions, of other modules: a cache
    stamped with its own file would run old rules after another module changed. numba
    looks for a directory in ``NUMBA_CACHE_DIR``, then the package's ``__pycache__``,
    then the user's cache directory (``~/.cache/numba``); a read-only install with a
    read-only home has none, and compiles every rule anew in each process. A function with
    no source file (defined in a notebook's cell, by ``exec`` or ``python -c``) has no
    cache, and no warning: numba keeps code by its file.
    """
    global _warned_no_cache
    source = inspect.getsourcefile(function) or ""
    if not Path(source).is_file():  # a notebook's cell, exec, python -c: no file to cache by
        return None
    try:
        return _StampedCache(function)
    except RuntimeError as exc:  # numba: "cannot cache function ...: no locator available"
        if not _warned_no_cache:
            _warned_no_cache = True
            warnings.warn(
                f"numba cannot cache the drill's compiled rules ({exc}): they are compiled "
                "in memory at each process's first use, which takes about a minute; set "
                "NUMBA_CACHE_DIR to a writable directory to keep them between processes",
                NoDiskCacheWarning, stacklevel=3)
        return None


@functools.cache
def _package_digest(root: str) -> str:
    """SHA-256 of every ``.py`` file under ``root`` (their paths and contents, sorted)."""
    digest = hashlib.sha256()
    base = Path(root)
    files = sorted(base.rglob("*.py")) if base.is_dir() else [base]
    for path in files:
        digest.update(str(path.relative_to(base.parent)).encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()


def rule_sources_digest(function: Callable[..., Any]) -> str:
    """A digest of the sources a compiled ``function`` may depend on: every module of
    ``soccer_drill`` (the rules, and the constants they read) and of the top-level
    package ``function`` belongs to (or its own file, outside a package)."""
    top = sys.modules.get(function.__module__.partition(".")[0])
    own = inspect.getfile(function)
    if top is not None and getattr(top, "__path__", None):  # a package
        own = next(iter(top.__path__))
    return _package_digest(str(Path(__file__).resolve().parent.parent)) + _package_digest(
        str(Path(own).resolve()))


if COMPILED:
    from numba.core.bytecode import FunctionIdentity
    from numba.core.caching import CompileResultCacheImpl, FunctionCache

    # numba names a compiled function's machine code by its qualified name, a number
    # from a counter that starts at 1 in every process, and its arguments' types (an
    # array of records by a number that is also counted per process), and code loaded
    # from the disk cache keeps the names the process that compiled it gave it. Two
    # processes that compiled the rules for different drill sizes gave different code the
    # same names, and a process that then held both (one loaded, one compiled or loaded)
    # ran one in place of the other: players that never moved, or a crash (numba issue
    # 10486). Each process's counter starts at a random multiple of 2**16, so no two
    # processes' names meet (unless two of 2**48 starts are equal).
    FunctionIdentity._unique_ids = itertools.count(secrets.randbits(48) << 16)

    class _StampedLocators:
        """Stamps a numba cache locator's source stamp with :func:`rule_sources_digest`."""

        _rules_digest = ""

        def get_source_stamp(self) -> Any:
            return (super().get_source_stamp(), self._rules_digest)  # type: ignore[misc]

    class _StampedImpl(CompileResultCacheImpl):
        _locator_classes: ClassVar[list] = [type(f"Stamped{c.__name__}", (_StampedLocators, c), {})
                            for c in CompileResultCacheImpl._locator_classes]

        def __init__(self, py_func: Callable[..., Any]) -> None:
            super().__init__(py_func)
            self._locator._rules_digest = rule_sources_digest(py_func)

    class _StampedCache(FunctionCache):
        _impl_class = _StampedImpl


def _as_records(function: Callable[..., Any]) -> Callable[..., Any]:
    """``function`` with every array of records among its arguments viewed as a
    ``np.recarray`` (the same memory), whose records read and write their fields by
    attribute as numba's do."""
    @functools.wraps(function)
    def plain(*args: Any) -> Any:
        return function(*(a.view(np.recarray) if isinstance(a, np.ndarray) and a.dtype.names
                          else a for a in args))
    return plain


_warmers: list[Callable[[Any], None]] = []
_warmed: set[tuple[Callable[[Any], None], tuple[int, int, str]]] = set()


def warms(warmer: W) -> W:
    """Register ``warmer``, a call of some compiled rules with the types their callers
    pass, for :func:`warm_up`: ``warmer(config)``, a drill's configuration (``None``: the
    default drill), whose numbers of players give the records' types."""
    _warmers.append(warmer)
    return warmer


def warm_up(config: Any = None) -> None:
    """Compile every registered rule now (or load it from the disk cache), once per
    process: a rule's first use compiles it, which can take seconds, and must not fall
    inside a scripted team's time-bounded call (``TeamDriver`` calls this first), nor be
    cut: numba's registries, left part-way through a compilation, fail every later call
    of the process. So signals with a Python handler (a Ctrl-C, a ``SIGALRM`` or
    ``SIGTERM`` handler that raises) wait for it to end
    (:class:`~soccer_drill.interruptions.SignalsDeferred`): a Ctrl-C during a first
    compilation stops the program when it ends.

    ``config``: a drill's configuration (``None``: the default drill); the rules are
    compiled once per number of attackers and defenders and task (a task's own rules
    are warmed for its configurations only)."""
    if not COMPILED:
        return
    size = ((2, 2, "drill") if config is None
            else (config.attackers, config.defenders, config.task))
    for warmer in list(_warmers):
        if (warmer, size) not in _warmed:
            with SignalsDeferred():
                _warm(warmer, config)
                _warmed.add((warmer, size))


_OWN_PACKAGES = ("soccer_drill", "opponents")
"""The packages whose warm-ups are this project's: their failure is a defect, raised."""


def _warm(warmer: Callable[[Any], None], config: Any) -> None:
    """``warmer(config)``. A plugin's warm-up that fails is its own failure: it warns
    (:class:`~soccer_drill.registry.PluginWarning`, naming the warm-up and the error) and
    is skipped, so that every other team's environment is still made (its team's code is
    then compiled at its first use)."""
    try:
        warmer(config)
    except Exception as exc:
        module = getattr(warmer, "__module__", None) or "?"
        if module.split(".")[0] in _OWN_PACKAGES:
            raise
        warnings.warn(
            f"the warm-up {module}:{getattr(warmer, '__qualname__', '?')} (registered with "
            f"@warms) failed and is skipped: {short_repr(exc)}; its compiled code compiles "
            "at its first use instead, which may fall inside its team's time bound",
            PluginWarning, stacklevel=4)


_SPLIT = 134217729.0  # 2**27 + 1: Dekker's split of a double into two halves
_SMALLEST_NORMAL = 2.2250738585072014e-308  # DBL_MIN


def python_hypot(x: float, y: float) -> float:
    """``math.hypot(x, y)`` as CPython computes it, in operations numba compiles.

    CPython scales the coordinates by a power of two, sums their squares in double-length
    arithmetic (exact products by Dekker's split, exact sums), takes the square root and
    corrects it once. The same operations in the same order give the same float.
    """
    x, y = abs(x), abs(y)
    if x == math.inf or y == math.inf:
        return math.inf
    if x != x or y != y:
        return math.nan
    largest = x if x > y else y
    if largest == 0.0:
        return 0.0
    factor = 1.0
    exponent = math.frexp(largest)[1]
    if exponent < -1023:  # 2**-exponent would overflow: scaled up first, as CPython does
        x, y, factor = x / _SMALLEST_NORMAL, y / _SMALLEST_NORMAL, _SMALLEST_NORMAL
        exponent = math.frexp(largest / _SMALLEST_NORMAL)[1]
    scale = math.ldexp(1.0, -exponent)
    total, low1, low2 = 1.0, 0.0, 0.0
    for v in (x * scale, y * scale):
        square, square_low = _exact_product(v, v)
        added = total + square
        low2 += square - (added - total)
        total = added
        low1 += square_low
    h = math.sqrt(total - 1.0 + (low1 + low2))
    square, square_low = _exact_product(-h, h)
    added = total + square
    low2 += square - (added - total)
    total = added
    low1 += square_low
    h += (total - 1.0 + (low1 + low2)) / (2.0 * h)
    return factor * (h / scale)


def _exact_product(a: float, b: float) -> tuple[float, float]:
    """``a * b`` as a rounded product and its exact remainder (Dekker's method)."""
    t = a * _SPLIT
    a_high = t - (t - a)
    a_low = a - a_high
    t = b * _SPLIT
    b_high = t - (t - b)
    b_low = b - b_high
    p = a_high * b_high
    q = a_high * b_low + a_low * b_high
    product = p + q
    return product, p - product + q + a_low * b_low


if COMPILED:
    _exact_product = compiled(_exact_product)
    python_hypot = compiled(python_hypot)
    hypot = python_hypot
else:
    hypot = math.hypot
"""The length of ``(x, y)``, the same float compiled or not (see the module docstring)."""

