"""Which source policy runs in each true region of a region-composed target.

    ilpss-region-use RUN_FOLDER [--methods M ...] [--seeds 5] [--episodes 20] [--out PAGE.md]

A region-composed target (:data:`~ilpss.experiments.drill_facts.TEAM_COMPOSITION`) plays one
source's behaviour on one side of a split and another source's on the other. This reads
each kept target checkpoint of a run of protocol R, S or L, plays the target's learnt
policy greedily (the options it was offered, as its trial offered them) for
``--episodes`` episodes, and counts every decision by the side of the split it is made
on and by what acts: the target's own primitive actions, or an option, named by the
past task whose policy it runs. The page gives, per method and side, the share of
decisions run by the source the team plays there (the right one), by the other sources,
and by the primitives, pooled over targets and seeds; the figure draws the same as
stacked bars. This is where the kernels' regions do, or do not, put the right fragment
of a past policy.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ilpss._io import atomic_write_bytes, save_figure
from ilpss.experiments import drill_facts
from ilpss.experiments.checkpoints import checkpoint_store
from ilpss.experiments.folder import RunFolder, checkpoint_key
from ilpss.experiments.protocols import make_env
from ilpss.experiments.run import read_config
from ilpss.lifelong import LifelongLearner
from ilpss.smdp import SmdpLearner

__all__ = ["main", "region_use"]

OWN = "own primitives"
"""What acts when no option runs: the target's own primitive actions."""


@dataclass(frozen=True)
class RegionUse:
    """Decisions of one target's greedy episodes, by side of its split and by what acts."""

    target: str
    below_source: str
    above_source: str
    counts: dict[tuple[bool, str], int]
    """``{(below, actor): decisions}``; actor: a past task's name, or :data:`OWN`."""

    def shares(self, below: bool) -> tuple[int, float, float, float]:
        """On one side: decisions, and the shares run by the right source (the one the
        team plays there), by other sources, by the primitives."""
        right = self.below_source if below else self.above_source
        side = {actor: n for (b, actor), n in self.counts.items() if b == below}
        total = sum(side.values())
        if total == 0:
            return 0, float("nan"), float("nan"), float("nan")
        own, mine = side.get(OWN, 0), side.get(right, 0)
        return total, mine / total, (total - own - mine) / total, own / total


def target_use(learner: LifelongLearner, trial: int, env: Any, seeds: Iterable[int],
               composition: tuple[int, float, str, str]) -> RegionUse:
    """Play the policy of ``learner``'s trial ``trial`` greedily on ``env``, one episode per
    seed, offered the options that trial was offered, and count its decisions by side of
    ``composition``'s split and by what acts."""
    feature, threshold, below_source, above_source = composition
    names = [r.name for r in learner.records]
    policy = learner.policies[trial]
    library = learner.library
    offer = learner.config.reuse.offer
    if library is not None and offer is not None:
        library = offer.offer(library, names[:trial], names[trial])
    config = replace(learner.config.learner, epsilon=0.0)
    counts: Counter[tuple[bool, str]] = Counter()
    limit = np.float32(threshold)
    for seed in seeds:
        agent = SmdpLearner.from_policy(policy, library if policy.option_ids else None, config,
                                        seed=seed)
        result = agent.run_episode(env, learn=False, seed=seed)
        actors = [OWN] * len(result.trace)
        for run in result.option_runs:
            source = names[library.policy_of(run.option_id)]  # type: ignore[union-attr]
            for d in range(run.start_decision, run.start_decision + run.n_decisions):
                actors[d] = source
        for state, actor in zip(result.trace, actors, strict=True):
            counts[bool(np.float32(state[feature]) <= limit), actor] += 1
    return RegionUse(names[trial], below_source, above_source, dict(counts))


def region_use(folder: Path, methods: Sequence[str] | None, n_seeds: int,
               episodes: int) -> dict[str, list[RegionUse]]:
    """Per method, the :class:`RegionUse` of every composed target of the first
    ``n_seeds`` finished seeds of the run in ``folder`` (those with kept checkpoints)."""
    cfg = read_config(RunFolder(folder).config)
    composition = drill_facts.drill_object(drill_facts.TEAM_COMPOSITION)
    seeds = RunFolder(folder).finished_seeds()[:n_seeds]
    if not seeds:
        raise ValueError(f"{folder}: no finished seed")
    out: dict[str, list[RegionUse]] = {}
    store = checkpoint_store(cfg, folder)
    try:
        for method in methods or cfg.methods:
            for seed in seeds:
                stream = cfg.streams(seed)[0]
                several = len(stream.tasks) - stream.first_target > 1
                for t in range(stream.first_target, len(stream.tasks)):
                    task = stream.tasks[t]
                    known = composition(task.name)
                    if known is None:
                        continue
                    env = make_env(cfg.env_id, task)
                    key = checkpoint_key(seed, 0, method, t if several else None)
                    learner = store.restore(key, env.observation_space)
                    if learner is None or learner.n_trials <= t:
                        env.close()
                        continue  # not a lifelong method, or its checkpoint is not kept
                    use = target_use(learner, t, env, range(episodes), known)
                    env.close()
                    out.setdefault(method, []).append(use)
    finally:
        store.close()
    if not out:
        raise ValueError(f"{folder}: no kept target checkpoint of a region-composed target "
                         f"for the methods {list(methods or cfg.methods)}")
    return out


def _pooled(uses: Sequence[RegionUse], below: bool) -> tuple[int, float, float, float]:
    """Decisions and shares on one side, pooled over targets and seeds (weighted by
    decisions)."""
    parts = [u.shares(below) for u in uses]
    total = sum(n for n, *_ in parts)
    if total == 0:
        return 0, float("nan"), float("nan"), float("nan")
    return (total, *(sum(n * p[k] for n, *p in parts if n) / total for k in range(3)))


def page(uses: dict[str, list[RegionUse]], command: str, figure: str | None) -> str:
    """The page: per method and side, who runs the decisions."""
    lines = ["# Which source runs in each true region", "", f"Made by `{command}`.", "",
             "Greedy episodes of each target's learnt policy, every decision counted by the "
             "side of the target's split it is made on and by what acts: an option of the "
             "source the team plays on that side (the right source), an option of another "
             "past policy, or the target's own primitive actions. Pooled over targets and "
             "seeds.", "",
             "| method | side | decisions | right source | other sources | own primitives |",
             "|---|---|---:|---:|---:|---:|"]
    for method, found in uses.items():
        for below, side in ((False, "far side (above the threshold)"),
                            (True, "near side (at or below it)")):
            n, *parts = _pooled(found, below)
            cells = " | ".join("-" if n == 0 else f"{v:.0%}" for v in parts)
            lines.append(f"| `{method}` | {side} | {n} | {cells} |")
    if figure:
        lines += ["", f"![who runs where]({figure})"]
    return "\n".join(lines) + "\n"


def plot(uses: dict[str, list[RegionUse]], path: Path) -> Path:
    """Save :func:`bars_figure` of ``uses`` at ``path`` (a PNG, written atomically)."""
    return save_figure(bars_figure(uses), path, dpi=110)


_PARTS = (("right source", "tab:green"), ("other sources", "tab:red"),
          ("own primitives", "tab:gray"))


def bars_figure(uses: dict[str, list[RegionUse]]):
    """Horizontal stacked bars, one per method and side (far, near), read top to bottom
    in the page's order: the share of the side's decisions made by the right source's
    option, another source's and the target's own primitives. The method names sit on
    the axis at full length, one row each, so none runs into another."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    labels, bars = [], []
    for method, found in uses.items():
        for below, side in ((False, "far side"), (True, "near side")):
            labels.append(f"{method}, {side}")
            bars.append(_pooled(found, below)[1:])
    values = np.nan_to_num(np.array(bars, dtype=float))
    fig = Figure(figsize=(8.0, 1.6 + 0.32 * len(labels)), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    rows = np.arange(len(labels))[::-1]  # the first method on top
    left = np.zeros(len(labels))
    for k, (name, colour) in enumerate(_PARTS):
        ax.barh(rows, values[:, k], left=left, label=name, color=colour, height=0.7)
        left += values[:, k]
    ax.set_yticks(rows, labels, fontsize=8)
    ax.set_xlim(0, 1)
    ax.set_xlabel("share of the side's decisions (greedy episodes, pooled over targets "
                  "and seeds)")
    ax.set_title("Who acts on each side of the target's split", fontsize=10)
    fig.legend(loc="outside lower center", ncols=len(_PARTS), fontsize=8)
    return fig


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point."""
    p = argparse.ArgumentParser(prog="ilpss-region-use",
                                description=__doc__.splitlines()[0])
    p.add_argument("run", help="a run folder of protocol R, S or L")
    p.add_argument("--methods", nargs="+", help="lifelong methods (default: every one)")
    p.add_argument("--seeds", type=int, default=5, help="the first finished seeds read")
    p.add_argument("--episodes", type=int, default=20, help="greedy episodes per target")
    p.add_argument("--out", help="the page (default: <run>/region_use.md)")
    args = p.parse_args(argv)
    if args.seeds < 1 or args.episodes < 1:
        p.error("--seeds and --episodes must be at least 1")
    out = Path(args.out) if args.out else Path(args.run) / "region_use.md"
    try:
        uses = region_use(Path(args.run), args.methods, args.seeds, args.episodes)
        figure = plot(uses, out.with_suffix(".png"))
        given = sys.argv[1:] if argv is None else list(argv)
        command = " ".join(["ilpss-region-use", *given])
        atomic_write_bytes(out, page(uses, command, figure.name).encode())
    except (ValueError, KeyError, OSError) as exc:
        p.exit(1, f"{p.prog}: error: {exc}\n")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
