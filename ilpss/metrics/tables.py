"""Estimates of :func:`~ilpss.metrics.compare` as a markdown table."""

from __future__ import annotations

import math
from collections.abc import Mapping

from ilpss.metrics.registry import MetricEstimate


def _fmt(x: float) -> str:
    x = float(x)
    if math.isnan(x):
        return "n/a"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    if x.is_integer() and abs(x) < 1e15:
        return str(int(x))
    if abs(x) >= 1000:
        return f"{x:.1f}"
    return f"{x:.4g}"


def format_metrics_markdown(estimates: Mapping[str, MetricEstimate]) -> str:
    """A markdown table of estimates: metric, value, CI, interval, p, n, definition.

    The CI column is headed with the common confidence level (e.g. "95% CI"); if the
    estimates use different levels each cell states its own. The interval column names
    the interval (:attr:`MetricEstimate.interval`), the p column the unadjusted p-value of
    "no difference" where there is one. ``nan`` prints as ``n/a``, infinities as ``inf``;
    ``|`` in definitions is escaped.

    Parameters
    ----------
    estimates : mapping of str to MetricEstimate
        E.g. the result of :func:`compare`; rows follow the mapping's order.

    Returns
    -------
    str
        The table, ending with a newline.
    """
    levels = {e.confidence for e in estimates.values()}
    uniform = len(levels) == 1
    head = f"{next(iter(levels)) * 100:g}% CI" if uniform else "CI"
    lines = [f"| metric | value | {head} | interval | p | n | definition |",
             "|---|---:|---|---|---:|---:|---|"]
    for key, e in estimates.items():
        ci = f"[{_fmt(e.low)}, {_fmt(e.high)}]"
        if not uniform:
            ci += f" ({e.confidence * 100:g}%)"
        p = "" if math.isnan(e.p_value) else f"{e.p_value:.2g}"
        definition = e.definition.replace("|", "\\|")
        lines.append(f"| {key} | {_fmt(e.value)} | {ci} | {e.interval} | {p} | {e.n} | "
                     f"{definition} |")
    return "\n".join(lines) + "\n"
