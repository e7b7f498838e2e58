"""One interface, two places to run jobs: local processes or a Ray cluster."""

from __future__ import annotations

import contextlib
import ctypes
import functools
import importlib.util
import multiprocessing
import os
import signal
import socket
import sys
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any, Protocol

from tqdm.auto import tqdm

from ilpss._io import release_inherited_locks
from ilpss.episode import DecisionLimitError
from ilpss.traces import DivergedError
from soccer_drill.constraints import OneOf, check

SETTINGS_ERRORS = (DecisionLimitError, DivergedError)
"""What a job raises because of its settings (a learner's bound too small, a step size
that diverges): running it again with the same settings raises it again."""

EXECUTOR = OneOf(("local", "ray"))
"""Where jobs run (``ExperimentConfig.executor`` is checked with it)."""

Done = Callable[[int, Any], None]
"""Called in the calling process with ``(index, result)`` as each item finishes."""


class Executor(Protocol):
    """Runs ``fn`` on every item, in any order, and returns results in item order."""

    def map(self, fn: Callable[[Any], Any], items: Sequence[Any], desc: str = "",
            done: Done | None = None) -> list[Any]:
        """``[fn(item) for item in items]``, computed in parallel, in item order; ``done``
        is called in this process as each result arrives."""
        ...


class JobsFailed(RuntimeError):
    """Some items raised; every other item finished and was given to ``done``.

    Attributes
    ----------
    failures : dict of int to BaseException
        Per failed item index, what it raised.
    """

    def __init__(self, failures: dict[int, BaseException], n_items: int) -> None:
        self.failures = dict(sorted(failures.items()))
        self.n_items = n_items
        super().__init__(f"{len(failures)} of {n_items} item(s) failed")


def _failure(exc: BaseException) -> BaseException:
    """What a failed item records: ``SystemExit`` from the item's code (a team or a plugin
    calling ``sys.exit()``) is a failure of that item, not a request to end the run
    with its status."""
    if isinstance(exc, SystemExit):
        return RuntimeError(f"the job's code called sys.exit({exc.code!r})")
    return exc


def _exit_as_failure(fn: Callable[[Any], Any]) -> Callable[[Any], Any]:
    """``fn`` for a Ray task: a ``SystemExit`` from the item's code is raised as the
    item's failure, inside the task (Ray takes a ``SystemExit`` that leaves a task for
    its worker's own exit, and reports the worker as crashed)."""
    @functools.wraps(fn)
    def run(item: Any) -> Any:
        try:
            return fn(item)
        except SystemExit as exc:
            raise _failure(exc) from None
    return run


class _RecordingContext:
    """A ``fork`` multiprocessing context that keeps the processes it starts, so that a
    pool's workers can be terminated through the ``mp_context`` seam of
    :class:`~concurrent.futures.ProcessPoolExecutor` (which has no public way to stop
    workers that are running)."""

    def __init__(self) -> None:
        self._context = multiprocessing.get_context("fork")
        self.processes: list[Any] = []

    def Process(self, *args: Any, **kwargs: Any) -> Any:  # the name of the context API
        process = self._context.Process(*args, **kwargs)
        self.processes.append(process)
        return process

    def __getattr__(self, name: str) -> Any:
        return getattr(self._context, name)

    def terminate(self) -> None:
        """Stop every worker still running (``SIGTERM``) and wait for it."""
        for process in self.processes:
            if process.is_alive():
                process.terminate()
        for process in self.processes:
            process.join(timeout=5)


def _worker_start(parent: int) -> None:
    """First thing in every local worker: let go of the folder locks the driver holds
    (the lock goes with the driver, not with its workers), leave Ctrl-C to the driver,
    and die with the driver (Linux: ``PR_SET_PDEATHSIG``), ``SIGKILL`` of it included."""
    release_inherited_locks()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # not the driver's handler: SIGTERM ends it
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
    if os.getppid() != parent:  # the driver died before the line above
        os._exit(1)


_PR_SET_PDEATHSIG = 1


class LocalExecutor:
    """Local worker processes (``workers=1`` runs in this process, easy to debug).

    The workers are forked (so they see what the driver registered in-process), let go
    of the driver's folder locks, and stop with the driver: when it is interrupted
    (``KeyboardInterrupt``, ``SystemExit``, e.g. from a ``SIGTERM`` handler) the running
    jobs are terminated at once, and on Linux a worker also dies when the driver is
    killed. An item that raises does not stop the others: they finish, and
    :class:`JobsFailed` names the failed ones at the end.
    """

    def __init__(self, workers: int = 2, progress: bool = True) -> None:
        self.workers, self.progress = workers, progress

    def map(self, fn: Callable[[Any], Any], items: Sequence[Any], desc: str = "",
            done: Done | None = None) -> list[Any]:
        """``[fn(item) for item in items]``, computed in parallel, in item order.

        Raises
        ------
        JobsFailed
            After every other item finished, if any item raised.
        """
        results: list[Any] = [None] * len(items)
        failures: dict[int, BaseException] = {}
        bar = tqdm(total=len(items), desc=desc, disable=not self.progress)

        def finish(i: int, result: Any) -> None:
            results[i] = result
            if done is not None:
                done(i, result)
            bar.update()

        try:
            if self.workers == 1 or len(items) <= 1:
                for i, item in enumerate(items):
                    try:
                        result = fn(item)
                    except Stopped:
                        raise  # a signal to the command, not this job's sys.exit()
                    except (Exception, SystemExit) as exc:
                        failures[i] = _failure(exc)
                        continue
                    finish(i, result)
            else:
                self._in_pool(fn, items, finish, failures)
        finally:
            bar.close()
        if failures:
            raise JobsFailed(failures, len(items))
        return results

    def _in_pool(self, fn: Callable[[Any], Any], items: Sequence[Any],
                 finish: Callable[[int, Any], None],
                 failures: dict[int, BaseException]) -> None:
        context = _RecordingContext()
        pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=context,  # type: ignore[arg-type]
                                   initializer=_worker_start, initargs=(os.getpid(),))
        try:
            futures = {pool.submit(fn, item): i for i, item in enumerate(items)}
            for future in as_completed(futures):
                try:
                    result = future.result()
                except (Exception, SystemExit) as exc:
                    failures[futures[future]] = _failure(exc)
                    continue
                finish(futures[future], result)
        except BaseException:
            # Interrupted (Ctrl-C, a SIGTERM handler, an error in ``done``): the running
            # jobs stop now rather than after they end (they resume from their
            # checkpoints next time). The pool's manager thread is then waited for (it
            # ends at once, its workers gone): left running, it can close its wake-up
            # pipe while the interpreter's exit hook writes to it, and the command then
            # ends in a traceback ("Bad file descriptor") instead of its one line.
            context.terminate()
            pool.shutdown(wait=True, cancel_futures=True)
            raise
        pool.shutdown()


class RayExecutor:
    """Ray tasks, one CPU each, at most ``workers`` in flight at once.

    Joins the cluster at ``address`` (else at ``RAY_ADDRESS``, if set), whose nodes
    bring their own CPUs; without either, starts a local Ray instance of ``workers``
    CPUs. A task whose worker process or node dies is started again, up to
    ``max_retries`` times, wherever the cluster has room (a job then resumes from its
    checkpoints). A job that raises does not stop the others: :class:`JobsFailed`
    names it at the end, with what it raised.

    Every node needs this package installed, at the driver's version. Needs the
    optional extra: ``pip install 'soccer-drill-ilpss[ray]'``.
    """

    def __init__(self, workers: int = 2, address: str | None = None, progress: bool = True,
                 max_retries: int = 3) -> None:
        try:
            import ray
        except ImportError as exc:
            raise ImportError(
                "the Ray executor needs Ray: pip install 'soccer-drill-ilpss[ray]'"
            ) from exc
        self._ray = ray
        self.address = address or os.environ.get("RAY_ADDRESS") or None
        if not ray.is_initialized():
            check_ray_address(self.address)
            kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False}
            if self.address is None:
                # "local": a fresh instance of this machine's CPUs, never a cluster that
                # /tmp/ray happens to name (ray.init refuses num_cpus when joining one).
                kwargs["num_cpus"] = workers
            ray.init(address=self.address or "local", **kwargs)
        self.workers, self.progress, self.max_retries = workers, progress, max_retries

    def map(self, fn: Callable[[Any], Any], items: Sequence[Any], desc: str = "",
            done: Done | None = None) -> list[Any]:
        """``[fn(item) for item in items]``, computed in parallel, in item order."""
        ray = self._ray
        remote = ray.remote(num_cpus=1, max_retries=self.max_retries)(_exit_as_failure(fn))
        results: list[Any] = [None] * len(items)
        failures: dict[int, BaseException] = {}
        waiting = list(enumerate(items))[::-1]
        running: dict[Any, int] = {}
        try:
            with tqdm(total=len(items), desc=desc, disable=not self.progress) as bar:
                while waiting or running:
                    while waiting and len(running) < self.workers:
                        i, item = waiting.pop()
                        running[remote.remote(item)] = i
                    (ref,), _ = ray.wait(list(running), num_returns=1)
                    i = running.pop(ref)
                    bar.update()
                    try:
                        results[i] = ray.get(ref)
                    except ray.exceptions.RayTaskError as exc:
                        cause = getattr(exc, "cause", None)
                        failures[i] = _failure(cause if isinstance(cause, BaseException)
                                               else exc)
                        continue
                    except ray.exceptions.RayError as exc:  # its worker or node died, on
                        failures[i] = exc                     # every attempt Ray made
                        continue
                    if done is not None:
                        done(i, results[i])
        except BaseException:
            for ref in running:  # interrupted: stop the jobs in flight
                with contextlib.suppress(Exception):
                    ray.cancel(ref, force=True)
            raise
        if failures:
            raise JobsFailed(failures, len(items))
        return results

    def shutdown(self) -> None:
        """Stop the Ray instance this executor started or joined."""
        self._ray.shutdown()


class Stopped(SystemExit):
    """A signal stopped the command (``SIGTERM``, or ``SIGINT``: Ctrl-C); its code is
    ``128 + signum``, the shell's status for a process a signal ended. A ``SystemExit``,
    so that it ends the program, but never taken for a job's own ``sys.exit()``."""


def stop_on_sigterm() -> None:
    """Make ``SIGTERM`` (``kill PID``) end the command as Ctrl-C would, by raising
    :class:`Stopped` in it: the running jobs are terminated with it, and the same command
    resumes the run. (Without this, ``SIGTERM`` ends the process with no clean-up.)"""
    signal.signal(signal.SIGTERM, _exit_on_signal)


def _exit_on_signal(signum: int, frame: object) -> None:
    raise Stopped(128 + signum)


@contextlib.contextmanager
def stopped_in_one_line(prog: str) -> Iterator[None]:
    """Around a command's work (with :func:`stop_on_sigterm`): Ctrl-C (``SIGINT``) and
    ``SIGTERM`` end it with one line on stderr and status 130 or 143, not a traceback.
    The running jobs are terminated on the way, and what finished is kept."""
    try:
        yield
    except (KeyboardInterrupt, Stopped) as exc:
        signum = exc.code - 128 if isinstance(exc, Stopped) else signal.SIGINT
        name = "Ctrl-C (SIGINT)" if signum == signal.SIGINT else signal.Signals(signum).name
        sys.stderr.write(f"{prog}: stopped by {name}; the finished jobs are kept, and the "
                         "same command goes on from them\n")
        raise Stopped(128 + signum) from None


def check_ray_address(address: str | None, timeout: float = 5.0) -> None:
    """Refuse, within ``timeout`` seconds, a Ray cluster address (``host:port``, or
    ``RAY_ADDRESS`` when ``address`` is ``None``) where nothing listens: ``ray.init``
    would otherwise retry for minutes. ``"auto"``, ``"local"`` and ``ray://`` client
    addresses are left to Ray."""
    address = address or os.environ.get("RAY_ADDRESS") or None
    if address is None or address in ("auto", "local") or "://" in address:
        return
    host, sep, port = address.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ValueError(f"Ray address {address!r}: expected HOST:PORT (e.g. 10.0.0.1:6379), "
                         "'auto', 'local' or ray://HOST:PORT")
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=timeout).close()
    except OSError as exc:
        raise ValueError(
            f"Ray address {address}: no cluster answers there ({exc.strerror or exc}); start "
            "one (ray start --head) or check the address"
        ) from None


def check_executor(kind: str) -> None:
    """``kind`` usable in this process (``"ray"`` needs Ray installed); else
    ``ValueError`` saying how to get it: for a command to refuse before it makes its folder."""
    check("executor", kind, EXECUTOR)
    if kind == "ray" and importlib.util.find_spec("ray") is None:
        raise ValueError("--executor ray needs Ray, which is not installed here: pip install "
                         "'soccer-drill-ilpss[ray]'")


def make_executor(kind: str, workers: int, progress: bool = True,
                  address: str | None = None) -> Executor:
    """``"local"`` or ``"ray"`` (joining the cluster at ``address``, if given)."""
    check("executor", kind, EXECUTOR)
    if kind == "local":
        if address is not None:
            raise ValueError("a Ray address needs the Ray executor (--executor ray)")
        return LocalExecutor(workers, progress)
    return RayExecutor(workers, address=address, progress=progress)
