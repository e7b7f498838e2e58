"""Drill-specific pictures: kernels drawn on the field, and a GIF of the agent with its options.

The drill's features include the holder's position (its lateral offset from the line centre,
and its distance to the goal line: :data:`~ilpss.experiments.drill_facts.LATERAL` and
:data:`~ilpss.experiments.drill_facts.GOAL_DISTANCE` in the 2v2 drill, and at any size
:class:`~ilpss.experiments.drill_facts.HolderDrill`'s ``lateral`` and ``goal_distance``), so
each kernel, projected on those two features, is an ellipse on the field.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ilpss._io import save_figure
from ilpss.experiments.drill_facts import (
    FIELD,
    GIF_WRITER,
    SCENARIO,
    HolderDrill,
    drill_object,
    drill_of_env,
    holder_drill,
)
from ilpss.lifelong import LifelongLearner
from ilpss.options import OptionLibrary
from ilpss.policy import FrozenPolicy
from ilpss.smdp import LearnerConfig, SmdpLearner

GIF_SEEDS = range(1, 51)
"""Environment seeds of the greedy episodes scanned for the GIF of the results page."""


def plot_kernels_on_field(
    learner: LifelongLearner, path: str | os.PathLike[str], task_names: list[str] | None = None,
    drill: HolderDrill | None = None,
) -> Path:
    """Each kernel as 1- and 2-sigma ellipses on the field, the bags of states as dots,
    and the active options of each kernel (policy and scale) in the legend; ``drill``:
    the scenario the learner played (``None``: the paper's 2v2 drill), whose features
    say where the holder is."""
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Ellipse, Rectangle

    model = learner.kernel_model
    if model is None or not hasattr(model, "means_"):
        raise ValueError("the learner has no fitted kernel model yet")
    drill = drill or holder_drill(SCENARIO)
    if learner.tile_coder.n_features != len(drill.feature_names):
        raise ValueError(
            f"the learner has {learner.tile_coder.n_features} features, the holder of "
            f"{drill.scenario} {len(drill.feature_names)}: pass the drill it played")
    lateral, goal_distance = drill.lateral, drill.goal_distance
    names = task_names or [r.name for r in learner.records]
    # An explicit Agg figure: no pyplot, so a notebook's backend is left alone.
    fig = Figure(figsize=(6.4, 6.4))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.add_patch(Rectangle((0, 0), FIELD, FIELD, color="#2e783c", zorder=0))
    ax.plot([0, FIELD], [0, 0], color="white", lw=4, zorder=1)
    for i, bag in enumerate(learner.bags):
        if len(bag):
            ax.scatter(bag[:, lateral] + FIELD / 2, bag[:, goal_distance], s=3, alpha=0.35,
                       label=f"states, {names[i] if i < len(names) else i}", zorder=2)
    library: OptionLibrary | None = learner.library
    colours = matplotlib.colormaps["tab10"].colors
    for k in range(model.n_components):
        idx = [lateral, goal_distance]
        mean = model.means_[k, idx] + np.array([FIELD / 2, 0.0])
        cov = model.covariances_[k][np.ix_(idx, idx)]
        values, vectors = np.linalg.eigh(cov)
        angle = np.degrees(np.arctan2(vectors[1, -1], vectors[0, -1]))
        options = ""
        if library is not None:
            kid = int(library.kernel_ids[k])
            active = [
                f"pi{library.registry[int(o)][1]}:{s:.2f}"
                for o, s in zip(library.option_ids, library.scales, strict=True)
                if library.registry[int(o)][0] == kid
            ]
            options = f" options {', '.join(active) or 'none'}"
        for n_sigma, style in ((1, "-"), (2, ":")):
            w, h = 2 * n_sigma * np.sqrt(np.maximum(values[::-1], 1e-12))
            ax.add_patch(Ellipse(mean, w, h, angle=angle, fill=False, lw=2, ls=style,
                                 color=colours[k % 10], zorder=3,
                                 label=f"kernel {k}{options}" if n_sigma == 1 else None))
        ax.annotate(str(k), mean, color="white", weight="bold", ha="center", va="center",
                    zorder=4)
    ax.set_xlim(-1, FIELD + 1)
    ax.set_ylim(-1, FIELD + 1)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m): holder's position across the field")
    ax.set_ylabel("y (m): holder's distance to the goal line")
    ax.set_title("ILPSS kernels projected on the holder's position")
    ax.legend(loc="upper left", fontsize=6, bbox_to_anchor=(1.01, 1.0))
    return save_figure(fig, path, dpi=110, bbox_inches="tight")


def greedy_agent(
    policy: FrozenPolicy, library: OptionLibrary | None, config: LearnerConfig, seed: int
) -> SmdpLearner:
    """A learner that plays ``policy`` (and its options, from ``library``) greedily."""
    return SmdpLearner.from_policy(policy, library, replace(config, epsilon=0.0), seed=seed)


def greedy_runs(
    agent: Callable[[int], SmdpLearner], env: Any, seeds: range | list[int]
) -> list[dict[str, Any]]:
    """One episode per seed of the agent ``agent(seed)`` (seeded as its environment):
    ``[{"seed", "outcome", "reward", "options"}]`` (option ids run)."""
    out = []
    for seed in seeds:
        result = agent(seed).run_episode(env, learn=False, seed=seed)
        out.append({"seed": seed, "outcome": result.outcome, "reward": result.total_reward,
                    "options": [run.option_id for run in result.option_runs]})
    return out


def greedy_episodes(
    learner: LifelongLearner, env: Any, seeds: range | list[int], policy_index: int = -1
) -> list[dict[str, Any]]:
    """Play a learnt policy greedily, as :func:`write_agent_gif` does but without frames,
    once per seed: ``[{"seed", "outcome", "reward", "options"}]`` (option ids run)."""
    policy = learner.policies[policy_index]
    return greedy_runs(
        lambda seed: greedy_agent(policy, learner.library, learner.config.learner, seed),
        env, seeds)


def gif_episode(episodes: list[dict[str, Any]]) -> dict[str, Any]:
    """The episode worth a GIF among :func:`greedy_episodes`: one that shows an option at
    work, succeeding if one does (the first such), else the first episode."""
    with_options = [e for e in episodes if e["options"]]
    return next((e for e in with_options if e["outcome"] == "success"),
                with_options[0] if with_options else episodes[0])


def write_agent_gif(
    learner: LifelongLearner,
    env: Any,
    path: str | os.PathLike[str],
    seed: int = 0,
    fps: int = 10,
    policy_index: int = -1,
) -> dict[str, Any]:
    """Roll out a learnt policy greedily on ``env`` (a drill holder env made with
    ``render_mode="rgb_array_list"``: one frame per cycle) and write a GIF of every
    cycle captioned with the action and the active option (:func:`write_episode_gif`)."""
    agent = greedy_agent(learner.policies[policy_index], learner.library,
                         learner.config.learner, seed)
    return write_episode_gif(agent, env, path, seed=seed, fps=fps, learn=False,
                             task_names=[r.name for r in learner.records])


def write_episode_gif(
    agent: SmdpLearner,
    env: Any,
    path: str | os.PathLike[str],
    *,
    seed: int,
    fps: int = 10,
    learn: bool = False,
    task_names: list[str] | None = None,
    label: str | None = None,
) -> dict[str, Any]:
    """One episode of ``agent`` on ``env`` (made with ``render_mode="rgb_array_list"``),
    greedy or, with ``learn``, a learning episode (as it happens in training: exploring
    and updating), written as a GIF of every cycle captioned with the action and the
    option running, if any, with the drill's GIF writer
    (:data:`~ilpss.experiments.drill_facts.GIF_WRITER`); ``label`` names the agent in the
    frames' header (an environment with a ``policy_name``). The actions are named as the
    holder of the environment's scenario names them (another environment: the 2v2
    drill's). Returns the outcome, reward, options run and the number of frames."""
    import gymnasium as gym
    from PIL import Image, ImageDraw

    if getattr(env, "render_mode", None) != "rgb_array_list":
        raise ValueError(
            f"write_episode_gif needs an environment made with render_mode='rgb_array_list', "
            f"got {getattr(env, 'render_mode', None)!r}"
        )
    if label is not None and hasattr(env.unwrapped, "policy_name"):
        env.unwrapped.policy_name = label
    frames: list[np.ndarray] = []
    starts: list[int] = []
    actions: list[int] = []

    class _Recorder(gym.Wrapper):  # each decision's action and where its frames start
        def reset(self, **kw: Any) -> Any:
            out = self.env.reset(**kw)
            frames.extend(self.env.render())
            return out

        def step(self, action: int) -> Any:
            starts.append(len(frames))
            actions.append(int(action))
            out = self.env.step(action)
            frames.extend(self.env.render())
            return out

    spec = getattr(env, "spec", None)
    drill = (drill_of_env(spec.id) if spec is not None else None) or holder_drill(SCENARIO)
    action_names = drill.action_names
    result = agent.run_episode(_Recorder(env), learn=learn, seed=seed)
    starts.append(len(frames))
    names = task_names or []
    labels = [f"{action_names[a]} (primitive)" for a in actions]
    lib = agent.library
    for run in result.option_runs:
        kernel_id, policy_id = lib.registry[run.option_id] if lib is not None else (-1, -1)
        origin = names[policy_id] if 0 <= policy_id < len(names) else f"pi{policy_id}"
        for d in range(run.start_decision, run.start_decision + run.n_decisions):
            labels[d] = f"option {run.option_id}: kernel {kernel_id}, policy from {origin}"
    captioned = []
    for d, label in enumerate(labels):
        for frame in frames[0 if d == 0 else starts[d]:starts[d + 1]]:
            # A strip under the frame (its own legend stays in view).
            image = Image.new("RGB", (frame.shape[1], frame.shape[0] + 18), (20, 20, 20))
            image.paste(Image.fromarray(frame), (0, 0))
            draw = ImageDraw.Draw(image)
            draw.text((6, image.height - 15), f"{action_names[actions[d]]} <- {label}",
                      fill=(255, 255, 255))
            captioned.append(np.asarray(image))
    if not captioned:
        raise RuntimeError("the episode produced no frames")
    captioned += [captioned[-1]] * 5
    drill_object(GIF_WRITER)(captioned, path, fps=fps)
    return {"outcome": result.outcome, "reward": result.total_reward,
            "options": [run.option_id for run in result.option_runs], "frames": len(captioned)}
