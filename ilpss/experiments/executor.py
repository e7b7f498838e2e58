"""One interface, two places to run jobs: local processes or a Ray cluster."""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any, Protocol

from tqdm.auto import tqdm

from ilpss._check import OneOf, check

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


class LocalExecutor:
    """Local worker processes (``workers=1`` runs in this process, easy to debug)."""

    def __init__(self, workers: int = 2, progress: bool = True) -> None:
        self.workers, self.progress = workers, progress

    def map(self, fn: Callable[[Any], Any], items: Sequence[Any], desc: str = "",
            done: Done | None = None) -> list[Any]:
        """``[fn(item) for item in items]``, computed in parallel, in item order."""
        results: list[Any] = [None] * len(items)
        bar = tqdm(total=len(items), desc=desc, disable=not self.progress)

        def finish(i: int, result: Any) -> None:
            results[i] = result
            if done is not None:
                done(i, result)
            bar.update()

        if self.workers == 1 or len(items) <= 1:
            for i, item in enumerate(items):
                finish(i, fn(item))
        else:
            with ProcessPoolExecutor(max_workers=self.workers) as pool:
                futures = {pool.submit(fn, item): i for i, item in enumerate(items)}
                for future in as_completed(futures):
                    finish(futures[future], future.result())
        bar.close()
        return results


class RayExecutor:
    """Ray tasks, one CPU each, at most ``workers`` in flight at once.

    Joins the cluster at ``address`` (else at ``RAY_ADDRESS``, if set), whose nodes
    bring their own CPUs; without either, starts a local Ray instance of ``workers``
    CPUs. A task whose worker process or node dies is started again, up to
    ``max_retries`` times, wherever the cluster has room (a job then resumes from its
    checkpoints). An error raised by a job is raised here, as itself.

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
        remote = ray.remote(num_cpus=1, max_retries=self.max_retries)(fn)
        results: list[Any] = [None] * len(items)
        waiting = list(enumerate(items))[::-1]
        running: dict[Any, int] = {}
        with tqdm(total=len(items), desc=desc, disable=not self.progress) as bar:
            while waiting or running:
                while waiting and len(running) < self.workers:
                    i, item = waiting.pop()
                    running[remote.remote(item)] = i
                (ref,), _ = ray.wait(list(running), num_returns=1)
                i = running.pop(ref)
                try:
                    results[i] = ray.get(ref)
                except ray.exceptions.RayTaskError as exc:
                    cause = getattr(exc, "cause", None)
                    if isinstance(cause, Exception):
                        raise cause from exc
                    raise
                if done is not None:
                    done(i, results[i])
                bar.update()
        return results

    def shutdown(self) -> None:
        """Stop the Ray instance this executor started or joined."""
        self._ray.shutdown()


def make_executor(kind: str, workers: int, progress: bool = True,
                  address: str | None = None) -> Executor:
    """``"local"`` or ``"ray"`` (joining the cluster at ``address``, if given)."""
    check("executor", kind, EXECUTOR)
    if kind == "local":
        if address is not None:
            raise ValueError("a Ray address needs the Ray executor (--executor ray)")
        return LocalExecutor(workers, progress)
    return RayExecutor(workers, address=address, progress=progress)
