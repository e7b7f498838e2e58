"""Transfer metrics for learning curves (Taylor & Stone 2009), with intervals over seeds.

One module per concern; every public name is importable from ``ilpss.metrics``:

* :mod:`~ilpss.metrics.curves` -- per-curve metrics (:func:`jumpstart`,
  :func:`asymptotic_performance`, :func:`total_reward`, :func:`transfer_ratio`,
  :func:`time_to_threshold`, ...) and the trailing mean :func:`smooth`.
* :mod:`~ilpss.metrics.survival` -- time to threshold per seed, censored at the budget
  (:func:`threshold_times`), as survival data: :func:`kaplan_meier`, :func:`km_median`,
  :func:`median_interval`, :func:`restricted_mean_time`.
* :mod:`~ilpss.metrics.inference` -- intervals and tests over seeds: :func:`t_interval`,
  :func:`t_test_pvalue`, :func:`sign_flip_pvalue`, :func:`fieller_interval`, :func:`wilson_interval`,
  :func:`percentile_bootstrap_interval`, :func:`holm`, :func:`improvement_test`,
  :func:`trend_slopes`.
* :mod:`~ilpss.metrics.bands` -- :func:`mean_curve_band`, pointwise bootstrap bands for
  plotting.
* :mod:`~ilpss.metrics.dips` -- the handover: :func:`largest_dip`,
  :func:`episodes_below`.
* :mod:`~ilpss.metrics.registry` -- every metric of a paired comparison declared once
  (:class:`Metric` entries of :data:`METRICS`), :func:`compare` and
  :func:`per_seed_gains`.
* :mod:`~ilpss.metrics.tables` -- :func:`format_metrics_markdown`.

All inputs are validated: NaN or infinite rewards, empty curves, mismatched shapes and
curves shorter than a requested window raise :class:`ValueError`.
"""

from __future__ import annotations

from ilpss.metrics.bands import mean_curve_band
from ilpss.metrics.curves import (
    area_above_floor,
    asymptotic_gain,
    asymptotic_performance,
    jumpstart,
    smooth,
    time_to_threshold,
    time_to_threshold_ratio,
    total_reward,
    total_reward_gain,
    transfer_ratio,
)
from ilpss.metrics.dips import BELOW_MARGIN, episodes_below, largest_dip
from ilpss.metrics.inference import (
    INTERVALS,
    ImprovementTest,
    fieller_interval,
    holm,
    improvement_test,
    percentile_bootstrap_interval,
    sign_flip_pvalue,
    t_interval,
    t_test_pvalue,
    trend_slopes,
    wilson_interval,
)
from ilpss.metrics.registry import (
    GAINS,
    METRIC,
    METRICS,
    Metric,
    MetricEstimate,
    Paired,
    compare,
    headline_metrics,
    pairwise_metrics,
    per_seed_gains,
)
from ilpss.metrics.survival import (
    kaplan_meier,
    km_median,
    median_interval,
    restricted_mean_time,
    threshold_times,
)
from ilpss.metrics.tables import format_metrics_markdown

__all__ = [
    "BELOW_MARGIN",
    "GAINS",
    "INTERVALS",
    "METRIC",
    "METRICS",
    "ImprovementTest",
    "Metric",
    "MetricEstimate",
    "Paired",
    "area_above_floor",
    "asymptotic_gain",
    "asymptotic_performance",
    "compare",
    "episodes_below",
    "fieller_interval",
    "format_metrics_markdown",
    "headline_metrics",
    "holm",
    "improvement_test",
    "jumpstart",
    "kaplan_meier",
    "km_median",
    "largest_dip",
    "mean_curve_band",
    "median_interval",
    "pairwise_metrics",
    "per_seed_gains",
    "percentile_bootstrap_interval",
    "restricted_mean_time",
    "sign_flip_pvalue",
    "smooth",
    "t_interval",
    "t_test_pvalue",
    "threshold_times",
    "time_to_threshold",
    "time_to_threshold_ratio",
    "total_reward",
    "total_reward_gain",
    "transfer_ratio",
    "trend_slopes",
    "wilson_interval",
]
