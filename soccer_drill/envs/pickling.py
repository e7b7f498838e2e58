"""What every environment of the drill shares about copies and threads.

A copy (``copy.copy``, ``copy.deepcopy``, ``pickle``) continues the episode; a pickle is
for the code that made it. Each pickle records the version of ``soccer_drill`` that made
it (the distribution's version and a digest of the package's source), and loading it
with any other version is refused before any of its state is read, naming both: a drill
of another version would continue the episode with other rules, or fail part-way with an
error about its own parts. A pickle that records no version (made before versions were
recorded) is refused the same way when its state reaches the environment.

One environment must be stepped by one thread at a time: :class:`Pickled` holds the lock
a step or a reset takes (never copied: a copy gets its own).
"""

from __future__ import annotations

import functools
import hashlib
import threading
from collections.abc import Callable
from importlib import metadata
from pathlib import Path
from typing import Any, TypeVar

from soccer_drill.registry import PROJECT_DISTRIBUTION

_R = TypeVar("_R")

_VERSION_KEY = "_made_by"


class PickleVersionError(RuntimeError):
    """A pickled environment made by another version of ``soccer_drill``."""


@functools.lru_cache(maxsize=1)
def code_version() -> str:
    """This ``soccer_drill``: ``"soccer_drill <version> (source <digest>)"``, the digest a
    SHA-256 of its ``.py`` files (by relative path), its first 12 hex digits."""
    package = Path(__file__).resolve().parent.parent
    digest = hashlib.sha256()
    for file in sorted(package.rglob("*.py")):
        digest.update(str(file.relative_to(package)).encode() + b"\0" + file.read_bytes())
    try:
        version = metadata.version(PROJECT_DISTRIBUTION)
    except metadata.PackageNotFoundError:  # run from a checkout not installed
        version = "(not installed)"
    return f"soccer_drill {version} (source {digest.hexdigest()[:12]})"


def _refused(cls: type, made_by: str) -> PickleVersionError:
    return PickleVersionError(
        f"this {cls.__name__} was pickled by {made_by} and cannot be loaded by "
        f"{code_version()}: a pickled environment is for the code that made it (its drill, "
        "rules and team would differ); make the environment anew with this version"
    )


def _restore(cls: type, made_by: str) -> Any:
    """A pickled environment's start, before any of its state is read: refused unless
    this code made it."""
    if made_by != code_version():
        raise _refused(cls, made_by)
    return cls.__new__(cls)


def claimed(method: Callable[..., _R]) -> Callable[..., _R]:
    """``method`` of a :class:`Pickled` environment run holding its lock
    (:meth:`Pickled._claim`): a second thread's call, or a re-entrant one, is refused."""
    name = method.__name__

    @functools.wraps(method)
    def run(self: Pickled, *args: Any, **kwargs: Any) -> _R:
        with self._claim(name):
            return method(self, *args, **kwargs)

    return run


class Pickled:
    """Copies, pickles and the thread lock of an environment (see the module docstring)."""

    def _busy_init(self) -> None:
        self._busy = threading.Lock()

    def _claim(self, method: str) -> threading.Lock:
        """The environment's lock, for ``with self._claim("step"):`` around ``method()``;
        raises at once if it is held (a re-entrant call, or another thread's).

        The ``with`` statement acquires it: between a lock's ``acquire()`` and the ``try``
        guarding its release, a signal handler that raises would leave it held, and the
        environment refusing every later call as if another thread were in it; the
        ``with`` statement's acquiring and guarding leave no point for a handler to run.
        """
        busy = self._busy
        if busy.locked():
            from soccer_drill.envs.core import concurrent_use

            raise concurrent_use(self, method)
        return busy

    def __reduce_ex__(self, protocol: Any) -> tuple:
        state = self.__dict__.copy()
        del state["_busy"]  # a lock cannot be pickled; a copy gets its own
        state[_VERSION_KEY] = code_version()
        return _restore, (type(self), code_version()), state

    def __setstate__(self, state: dict[str, Any]) -> None:
        made_by = state.pop(_VERSION_KEY, None)
        if made_by != code_version():
            raise _refused(type(self), made_by or "an earlier soccer_drill (no version recorded)")
        self.__dict__.update(state)
        self._busy_init()
