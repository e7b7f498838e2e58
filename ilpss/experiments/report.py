"""``report.md`` of an experiment, written in its folder: its head, and the body that
:data:`REPORT_BODIES` holds for the run's protocol (:func:`register_report_body`).

The reports know no method by name: they compare every method with the run's baseline
(``ExperimentConfig.baseline``) and every transfer method with every other, on the metrics
of :data:`ilpss.metrics.METRICS`, each table's tests adjusted within its declared family
(:class:`~ilpss.experiments.report_stats.HolmFamily`), and show the kernels of its
featured method (``ExperimentConfig.featured_method``). The statistics, their words, the
figures and the bodies per protocol are modules of their own
(:mod:`~ilpss.experiments.report_stats`, :mod:`~ilpss.experiments.report_text`,
:mod:`~ilpss.experiments.report_figures`, :mod:`~ilpss.experiments.report_bodies`).
"""

from __future__ import annotations

import os
import shlex
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ilpss._io import atomic_write_bytes
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.provenance import code_line
from ilpss.experiments.report_bodies import (
    held_out_sections,
    parametric_stream_sections,
    protocol_a_sections,
    target_sections,
)
from ilpss.experiments.report_text import counted, metrics_note, success_lines

__all__ = ["REPORT_BODIES", "register_report_body", "write_report"]


def write_report(
    cfg: ExperimentConfig, results: list[dict[str, Any]], out_dir: str | os.PathLike[str],
    command: str | None = None,
) -> Path:
    """Write ``report.md`` with figures into ``out_dir``; return its path.

    ``command`` is the command line written in the report; by default the current one
    when it is ``ilpss-experiment``, else "(from Python)".
    """
    if cfg.unreportable is not None:
        raise ValueError(cfg.unreportable)
    out = Path(out_dir)
    if command is None:
        command = "ilpss-experiment " + " ".join(shlex.quote(a) for a in sys.argv[1:]) \
            if Path(sys.argv[0]).name == "ilpss-experiment" else "(from Python)"
    lines = [
        f"# Protocol {cfg.protocol}: {counted(cfg.n_seeds, 'seed')}, "
        f"{counted(cfg.lifelong.train_episodes, 'learning episode')} per opponent",
        "",
        f"Command: `{command}`; configuration: [`config.json`](config.json).",
        "",
        code_line(results),
        "",
        metrics_note(cfg.lifelong.train_episodes, out),
        "",
    ]
    lines += report_body(cfg, results, out)
    lines += success_lines(results)
    path = out / "report.md"
    atomic_write_bytes(path, "\n".join(lines).encode())
    return path


ReportBody = Callable[[ExperimentConfig, list[dict[str, Any]], Path], list[str]]


REPORT_BODIES: dict[str, ReportBody] = {
    "A": protocol_a_sections,
    "B": lambda cfg, results, out: held_out_sections(cfg, results, out, pooled=True),
    "C": parametric_stream_sections,
    "R": protocol_a_sections,
}
"""The body of ``report.md`` per protocol name; a protocol with none gets
:func:`target_sections`."""


def register_report_body(protocol: str, body: ReportBody, *, overwrite: bool = False) -> None:
    """Write ``report.md``'s body of the protocol named ``protocol`` with ``body``."""
    if protocol in REPORT_BODIES and not overwrite:
        raise ValueError(f"protocol {protocol!r} has a report body; pass overwrite=True")
    REPORT_BODIES[protocol] = body


def report_body(cfg: ExperimentConfig, results: list[dict[str, Any]], out: Path) -> list[str]:
    """The body of ``report.md`` for ``cfg``'s protocol (its figures written into ``out``)."""
    return REPORT_BODIES.get(cfg.protocol, target_sections)(cfg, results, out)
