"""One interface, two places to run seeds: local processes or a Ray cluster."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any, Protocol

from tqdm.auto import tqdm

from ilpss._check import OneOf, check

EXECUTOR = OneOf(("local", "ray"))
"""Where seeds run (``ExperimentConfig.executor`` is checked with it)."""


class Executor(Protocol):
    """Runs ``fn`` on every item, in any order, and returns results in item order."""

    def map(self, fn: Callable[[Any], Any], items: Sequence[Any], desc: str = "") -> list[Any]:
        """``[fn(item) for item in items]``, computed in parallel, in item order."""
        ...


class LocalExecutor:
    """Local worker processes (``workers=1`` runs in this process, easy to debug)."""

    def __init__(self, workers: int = 2, progress: bool = True) -> None:
        self.workers, self.progress = workers, progress

    def map(self, fn: Callable[[Any], Any], items: Sequence[Any], desc: str = "") -> list[Any]:
        """``[fn(item) for item in items]``, computed in parallel, in item order."""
        results: list[Any] = [None] * len(items)
        bar = tqdm(total=len(items), desc=desc, disable=not self.progress)
        if self.workers == 1 or len(items) <= 1:
            for i, item in enumerate(items):
                results[i] = fn(item)
                bar.update()
        else:
            with ProcessPoolExecutor(max_workers=self.workers) as pool:
                futures = {pool.submit(fn, item): i for i, item in enumerate(items)}
                for future in as_completed(futures):
                    results[futures[future]] = future.result()
                    bar.update()
        bar.close()
        return results


class RayExecutor:
    """Ray tasks: connects to ``address`` (a cluster) or starts a local Ray instance.

    Needs the optional extra: ``pip install 'soccer-drill-ilpss[ray]'``.
    """

    def __init__(self, workers: int = 2, address: str | None = None, progress: bool = True) -> None:
        try:
            import ray
        except ImportError as exc:
            raise ImportError(
                "the Ray executor needs Ray: pip install 'soccer-drill-ilpss[ray]'"
            ) from exc
        self._ray = ray
        if not ray.is_initialized():
            kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False}
            if address is None:
                # "local" always starts a fresh instance: with None, Ray would join
                # whatever cluster RAY_ADDRESS or /tmp/ray names, and then refuse num_cpus.
                address, kwargs["num_cpus"] = "local", workers
            ray.init(address=address, **kwargs)
        self.workers, self.progress = workers, progress

    def map(self, fn: Callable[[Any], Any], items: Sequence[Any], desc: str = "") -> list[Any]:
        """``[fn(item) for item in items]``, computed in parallel, in item order."""
        ray = self._ray
        remote = ray.remote(num_cpus=1)(fn)
        refs = [remote.remote(item) for item in items]
        index = {ref: i for i, ref in enumerate(refs)}
        results: list[Any] = [None] * len(items)
        pending = list(refs)
        with tqdm(total=len(items), desc=desc, disable=not self.progress) as bar:
            while pending:
                done, pending = ray.wait(pending, num_returns=1)
                results[index[done[0]]] = ray.get(done[0])
                bar.update()
        return results

    def shutdown(self) -> None:
        """Stop the Ray instance this executor started or joined."""
        self._ray.shutdown()


def make_executor(kind: str, workers: int, progress: bool = True) -> Executor:
    """``"local"`` or ``"ray"``."""
    check("executor", kind, EXECUTOR)
    if kind == "local":
        return LocalExecutor(workers, progress)
    return RayExecutor(workers, progress=progress)
