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
from ilpss.experiments.outputs import check_out_file
from ilpss.experiments.protocols import Stream, make_env
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
    split: str = "the split's feature"
    """The holder's feature the target's region splits by (``dist_goal``, ``lateral``)."""

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
    names = drill_facts.drill_object(drill_facts.FEATURE_NAMES)(1, 2)  # the 2v2 drill's
    try:
        for method in methods or cfg.methods:
            for seed in seeds:
                stream = cfg.streams(seed)[0]
                for t, trial, branch in target_trials(stream):
                    task = stream.tasks[t]
                    known = composition(task.name)
                    if known is None:
                        continue
                    env = make_env(cfg.env_id, task)
                    key = checkpoint_key(seed, 0, method, branch)
                    learner = store.restore(key, env.observation_space)
                    if learner is None or learner.n_trials <= trial:
                        env.close()
                        continue  # not a lifelong method, or its checkpoint is not kept
                    use = replace(target_use(learner, trial, env, range(episodes), known),
                                  split=names[known[0]])
                    env.close()
                    out.setdefault(method, []).append(use)
    finally:
        store.close()
    if not out:
        raise ValueError(f"{folder}: no kept target checkpoint of a region-composed target "
                         f"for the methods {list(methods or cfg.methods)}")
    return out


def target_trials(stream: Stream) -> list[tuple[int, int, int | None]]:
    """Each target of ``stream``: its index in the stream, its trial in the learner its
    checkpoint holds (after the sources only, where every target starts from them: its
    branch holds them and it), and its branch's index for
    :func:`~ilpss.experiments.folder.checkpoint_key` (``None``: one target)."""
    targets = range(stream.first_target, len(stream.tasks))
    several = len(targets) > 1
    return [(t, stream.first_target if stream.shared_start else t, t if several else None)
            for t in targets]


def _rows(uses: dict[str, list[RegionUse]]) -> list[tuple[str, str, bool, list[RegionUse]]]:
    """The page's and the figure's rows: per method, per feature its targets split by
    (targets split by distance to goal and by side are not pooled), above then below."""
    rows = []
    for method, found in uses.items():
        for split in dict.fromkeys(u.split for u in found):
            same = [u for u in found if u.split == split]
            rows += [(method, split, below, same) for below in (False, True)]
    return rows


def _side(split: str, below: bool) -> str:
    """A side of the split in words: which feature, above or at-or-below the target's
    threshold."""
    return f"`{split}` {'at or below' if below else 'above'} the threshold"


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
    for method, split, below, found in _rows(uses):
        n, *parts = _pooled(found, below)
        cells = " | ".join("-" if n == 0 else f"{v:.0%}" for v in parts)
        lines.append(f"| `{method}` | {_side(split, below)} | {n} | {cells} |")
    if figure:
        lines += ["", f"![who runs where]({figure})"]
    return "\n".join(lines) + "\n"


def plot(uses: dict[str, list[RegionUse]], path: Path) -> Path:
    """Save :func:`bars_figure` of ``uses`` at ``path`` (a PNG, written atomically)."""
    return save_figure(bars_figure(uses), path, dpi=110)


_PARTS = (("right source", "tab:green"), ("other sources", "tab:red"),
          ("own primitives", "tab:gray"))


def bars_figure(uses: dict[str, list[RegionUse]]):
    """Horizontal stacked bars, one per method, split feature and side, read top to bottom
    in the page's order: the share of the side's decisions made by the right source's
    option, another source's and the target's own primitives. The method names sit on
    the axis at full length, one row each, so none runs into another."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    labels, bars = [], []
    for method, split, below, found in _rows(uses):
        labels.append(f"{method}, {_side(split, below).replace('`', '')}")
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
    try:  # the page a .md (never a run's config.json), checked before the work
        out = check_out_file(args.out or Path(args.run) / "region_use.md", "--out", ".md")
    except ValueError as exc:
        p.error(str(exc))
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
