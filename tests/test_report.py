"""The words of the reports: verdicts, primary endpoints, protocol B's structure, C's trend."""

from __future__ import annotations

import numpy as np
import pytest

from ilpss import metrics
from ilpss.experiments.report_stats import (
    compare_to_baseline,
    holm_primary,
    pairwise_estimates,
    stream_trend,
    success_rates,
)
from ilpss.experiments.report_text import (
    per_target_dips,
    structure_b,
    success_lines,
    verdict,
    verdict_lines,
    worst_target_dips,
)

EPISODES = 60


def _steps(times, low=-1.0, high=0.8):
    """Curves at ``low`` before episode ``time`` (1-based) and ``high`` from it on."""
    episode = np.arange(1, EPISODES + 1)
    return np.where(episode[None, :] >= np.asarray(times, float)[:, None], high, low)


def _curves(rng, shift=0.0, times=None):
    base = _steps(np.full(10, 30.0) if times is None else times)
    return np.clip(base + shift + 0.05 * rng.standard_normal(base.shape), -1, 1)


def test_never_and_undefined_are_worded_differently():
    rng = np.random.default_rng(0)
    scratch = _curves(rng)
    never = np.full((10, EPISODES), -1.0)  # the method never reaches the threshold
    est = compare_to_baseline({"scratch": scratch, "m": never}, "scratch")["m"]
    text = verdict(est)
    assert "never within the budget" in text and "clear negative result" in text
    assert "undefined" not in text
    # neither reaches it: undefined, not a negative result
    est = metrics.compare(never, never, first=20, last=50, threshold=0.5, window=20)
    text = verdict(est)
    assert "undefined: neither" in text and "negative" not in text


def test_every_verdict_states_jumpstart_total_gain_and_final_performance():
    rng = np.random.default_rng(1)
    scratch = _curves(rng)
    late_loss = scratch.copy()
    late_loss[:, :20] += 0.5  # a head start ...
    late_loss[:, -20:] -= 0.6  # ... and a late loss
    late_loss = np.clip(late_loss, -1, 1)
    est = compare_to_baseline({"scratch": scratch, "m": late_loss}, "scratch")
    text = verdict(est["m"], holm_primary(est)["m"], EPISODES)
    assert text.startswith("a head start: jumpstart +")
    assert "total-reward gain" in text and "over 60 episodes" in text
    assert "a lower final performance within the budget" in text  # the late loss is said
    assert "times that of the baseline" in text and "Kaplan-Meier medians" in text


def test_primary_endpoints_are_holm_adjusted_across_methods():
    rng = np.random.default_rng(2)
    scratch = _curves(rng)
    curves = {"scratch": scratch, "a": _curves(rng, 0.03), "b": _curves(rng, 0.0)}
    est = compare_to_baseline(curves, "scratch")
    adjusted = holm_primary(est)
    raw = [est[m][e].p_value for m in ("a", "b") for e in ("jumpstart", "total_reward_gain")]
    expected = metrics.holm(raw)
    got = [adjusted[m][e] for m in ("a", "b") for e in ("jumpstart", "total_reward_gain")]
    assert got == pytest.approx(list(expected))
    assert all(g >= r for g, r in zip(got, raw, strict=True))
    lines = verdict_lines(est, EPISODES)
    assert "4 tests in one family with Holm's adjustment" in lines[0]
    assert sum(line.startswith("- **") for line in lines) == 2
    assert all("Holm-adjusted p" in line for line in lines if line.startswith("- **"))


def _b_table(rng, same_baseline=True):
    table = {}
    for team in ("t1", "t2"):
        scratch = _curves(rng)
        for order in ("", ",shuffle=1"):
            anew = scratch if same_baseline else _curves(rng)
            table[f"held_out={team}{order}"] = {"scratch": {3: anew}, "ilpss": {3: _curves(rng)}}
    return table


def test_protocol_b_streams_are_teams_times_orders():
    rng = np.random.default_rng(3)
    text = structure_b(_b_table(rng), "scratch")
    assert text.startswith("The 4 streams are 2 held-out teams x 2 source orders.")
    assert "identical in the team's 2 orders" in text and "not 2 independent" in text
    assert "descriptive" in text
    other = structure_b(_b_table(rng, same_baseline=False), "scratch")
    assert "differ between the source orders" in other and "identical" not in other


def test_protocol_c_trend_is_one_test_with_seeds_as_clusters():
    rng = np.random.default_rng(4)
    targets = range(1, 11)
    scratch = {t: _curves(rng) for t in targets}
    growing = {"scratch": scratch,
               "ilpss": {t: np.clip(scratch[t] + np.where(np.arange(EPISODES) < 20,
                                                          0.04 * t, 0.0), -1, 1)
                         for t in targets}}
    value, low, high, p, n = stream_trend(growing, "ilpss", "scratch")
    assert n == 10 and low > 0 and p < 0.05
    assert value == pytest.approx(0.04 * 20 / 20, abs=0.01)  # jumpstart rises 0.04 per opponent
    flat = {"scratch": scratch, "ilpss": {t: _curves(rng) for t in targets}}
    _, low, high, _, _ = stream_trend(flat, "ilpss", "scratch")
    assert low < 0 < high


def _result(seed, tasks, curves):
    return {"seed": seed, "stream": "s", "stream_index": 0, "tasks": tasks,
            "methods": {m: {"curves": {"1": list(c)}} for m, c in curves.items()}}


def test_success_rates_count_successes_early_and_late_per_target():
    # 60 episodes: the first 20 and the last 50 (both windows shortened to the curve).
    early_then_late = np.r_[np.full(10, 0.6), np.full(50, -1.0)]  # 10 wins, all early
    anew = np.r_[np.full(30, -1.0), np.full(30, 0.5)]  # wins only from episode 31
    results = [_result(seed, ["a", "held"], {"scratch": anew, "ilpss": early_then_late})
               for seed in range(3)]
    lines = success_lines(results)
    (row,) = [line for line in lines if line.startswith("| s |")]
    assert row == "| s | `held` | 0 % -> 60 % | 50 % -> 0 % |"
    assert success_rates(np.vstack([anew, early_then_late])) == (0.25, 0.3)
    # Opponents drawn per seed: the row names the task index, not one seed's team.
    results[1]["tasks"] = ["a", "other"]
    assert "opponent 1 (drawn per seed)" in "\n".join(success_lines(results))


def test_the_handover_is_reported_on_the_worst_of_many_targets_and_where_it_is():
    rng = np.random.default_rng(5)
    per_target = {}
    for t in range(1, 6):
        anew = _curves(rng)
        steady = np.clip(anew + 0.3, -1, 1)
        per_target[t] = {"scratch": anew, "ilpss": steady}
    # one target where the method starts high, then falls below learning anew for a while
    collapse = np.full((10, EPISODES), 0.8)
    collapse[:, 25:45] = -1.0
    per_target[4]["ilpss"] = collapse
    names = {t: f"opponent {t + 1}" for t in per_target}
    lines = worst_target_dips(per_target, names, "scratch")
    (row,) = [line for line in lines if line.startswith("| ILPSS")]
    dip, below = row.split(" | ")[1:3]
    assert dip.startswith("1.") and "`opponent 5`" in dip  # 20 episodes at -1 after 0.8
    assert "`opponent 5`" in below and int(below.split()[0]) > 0
    (anew_row,) = [line for line in lines if line.startswith("| learning anew")]
    assert anew_row.split(" | ")[2].startswith("0 ")  # never below itself
    # each target on its own: the same dip in that target's column, none elsewhere
    table = per_target_dips(per_target, names, "scratch")
    (row,) = [line for line in table if line.startswith("| ILPSS")]
    cells = row.strip("| ").split(" | ")[1:]
    assert cells[3].startswith("1.") and all(not c.startswith("1.") for c in cells[:3])


# ------------------------------------------------------------- declared Holm families
def _wins_gain(pairwise: bool = True) -> metrics.Metric:
    """A metric a newcomer might add: the paired difference of the share of wins."""
    return metrics.Metric(
        "wins_gain", "share of wins gain", "+.2f", "mean",
        lambda p: (p.transfer > 0).mean(axis=1) - (p.baseline > 0).mean(axis=1),
        lambda p: "mean over seeds of (share of episodes won) - (the same for the other)",
        test=True, pairwise=pairwise)


def _three_methods() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(3)
    return {"scratch": _curves(rng), "a": _curves(rng, 0.2), "b": _curves(rng, 0.0),
            "c": _curves(rng, 0.1)}


def test_a_pairwise_metric_leaves_the_family_of_an_existing_report_as_it_was(monkeypatch):
    """Declaring a metric pairwise shows it method against method, unadjusted; the tests
    of the table's declared family keep their Holm-adjusted p-values."""
    import sys

    curves = _three_methods()
    before = pairwise_estimates(curves, "scratch")
    assert any(p < 0.05 for est in before.values() for *_, p in est.values())
    # where the registry of metrics is declared (the module of Metric)
    registry = sys.modules[metrics.Metric.__module__]
    monkeypatch.setattr(registry, "METRICS", (*registry.METRICS, _wins_gain()))
    after = pairwise_estimates(curves, "scratch")
    for pair, est in before.items():
        assert {m: after[pair][m] for m in est} == est  # the family's p-values unchanged
        assert "wins_gain" in after[pair]  # and the new metric is shown beside them


def test_a_family_that_declares_a_metric_adjusts_it_with_the_others(monkeypatch):
    from ilpss.experiments.report_stats import METHOD_PAIRS_FAMILY, HolmFamily
    from ilpss.experiments.report_text import pairwise_lines
    from ilpss.metrics import registry

    curves = _three_methods()
    monkeypatch.setattr(registry, "METRICS", (*registry.METRICS, _wins_gain()))
    shown = pairwise_estimates(curves, "scratch")
    wider = HolmFamily("with wins", (*METHOD_PAIRS_FAMILY.metrics, "wins_gain"))
    adjusted = pairwise_estimates(curves, "scratch", family=wider)
    keys = [(pair, m) for pair in shown for m in wider.metrics]
    raw = []
    for pair, m in keys:  # the family's raw p-values: a paired t-test per pair and metric
        a, b = pair
        paired = metrics.Paired(curves[a], curves[b], first=20, last=50, window=20)
        raw.append(float(metrics.t_test_pvalue(registry.METRIC.get(m, _wins_gain()).values(
            paired))))
    assert [adjusted[pair][m][3] for pair, m in keys] == pytest.approx(list(metrics.holm(raw)))
    assert [shown[pair]["wins_gain"][3] for pair in shown] == pytest.approx(
        [p for (pair, m), p in zip(keys, raw, strict=True) if m == "wins_gain"])
    text = "\n".join(pairwise_lines(curves, "scratch"))
    assert "the p-values of share of wins gain are unadjusted" in text
    assert text.count(", unadjusted)") == 3  # one per pair
    text = "\n".join(pairwise_lines(curves, "scratch", family=wider))
    assert "Holm-adjusted across the 3 pairs x 4 metrics." in text and "unadjusted)" not in text


def test_a_family_names_metrics_that_exist_and_are_differences():
    from ilpss.experiments.report_stats import HolmFamily

    with pytest.raises(ValueError, match="non-empty tuple"):
        HolmFamily("empty", ())
    with pytest.raises(ValueError, match="distinct"):
        HolmFamily("twice", ("jumpstart", "jumpstart"))
    with pytest.raises(ValueError, match=r"\['no_such'\], which are not metrics"):
        HolmFamily("unknown", ("no_such",)).members()
    with pytest.raises(ValueError, match="not paired differences"):
        HolmFamily("ratio", ("transfer_ratio",)).members()
