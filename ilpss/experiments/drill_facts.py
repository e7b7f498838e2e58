"""Everything :mod:`ilpss` knows about the soccer drill, in one place.

``ilpss`` never imports the drill's rules or environments: it makes the holder
environment through Gymnasium (``gymnasium.make(ENV_ID, opponent=..., ...)``) and learns
on its features (the paper's 9 in the 2v2 drill) as it would on any ``Box``. (It shares one module of the drill's
package, ``soccer_drill.files``: the project's atomic writes and output checks.) The experiments need a few facts about it, all here:

==========================  =========================================================
fact                        used by
==========================  =========================================================
:data:`ENV_ID`              the default environment of every experiment
:data:`ENV_PACKAGE`         the package Gymnasium imports for it (declared in the
                            entry-point group ``ilpss.environments``)
:data:`PAPER_TEAMS`         protocols A and B, ``ilpss-results``,
                            ``ilpss-holder-learning``
:data:`TILE_WIDTHS`         the learner's tile coder (keepaway's widths)
:data:`SCENARIO`,           the drill an experiment plays (``ExperimentConfig.scenario``)
:func:`holder_drill`        and what ``ilpss`` knows of its holder at any size: its
                            Gymnasium id, feature and action names, tile widths, the
                            indices of the holder's position, its episode's reward
                            range (:class:`HolderDrill`; the constants of this table
                            are the 2v2 drill's)
:data:`SAMPLER`,            protocol C's stream of opponents
:data:`SAMPLER_TEAM`
:data:`EPISODE_REWARD`      the checks of saved results (an episode pays one reward)
:data:`ACTION_NAMES`        the captions of the agent's GIF
:data:`LATERAL`,            the kernels drawn on the field
:data:`GOAL_DISTANCE`,
:data:`FIELD`
:data:`REGION_SOURCES`,     protocol R (targets composed by region) and its oracle
:data:`REGION_TARGETS`,     arm's regions
:data:`REGION_SPLITS`
:data:`SHARP_SOURCES`,      protocols S and L (the sharp test of regions: behaviour
:data:`SHARP_TARGETS`,      that changes within an episode) and its oracles' regions
:data:`SHARP_SPLITS`
:data:`TEAM_COMPOSITION`    the oracles' knowledge of a target: its region and the
                            source played on each side
:data:`HOLDER_RULES`        ``ilpss-holder-learning``'s fixed rules to beat, the pages
                            of the drill (``soccer-drill-calibrate``, the region
                            pre-check, the batched drill's agreement)
:data:`PLAY_EPISODES`,      the pages of the drill: fixed rules in the batched drill,
:data:`EPISODE_GIF`,        GIFs, the teams by id, the parametric family's labels and
:data:`TEAM_IDS`,           the region teams and rules
:data:`TEAM_DESCRIPTION`,
:data:`MAKE_TEAM`,
:data:`SAMPLE_LABEL`,
:data:`REGION`,
:data:`REGION_TEAM`,
:data:`REGION_RULE`
:data:`GIF_WRITER`          the GIF of the agent (one GIF writer for the project)
:data:`SIDE_BY_SIDE`,       the demo's agents side by side on the same episode seed
:data:`PANEL`
:data:`TEAM_ERROR`          the commands' one-line error for a team that fails
:data:`TEAM_CODE`           what identifies a team's code: the key of
                            ``ilpss-holder-learning``'s kept jobs, a run folder's
                            ``team_code.json``
:data:`HOLDER_SB3_VEC_ENV`, the reference deep-RL runs (``soccer-drill-reference``):
:data:`PARALLEL_VEC_ENV`,   the batched holder behind SB3, the batched parallel drill,
:data:`ATTACKS`,            the scripted attacks and their code, the rewards the drill
:data:`ATTACK_CODE`,        pays (to check kept results)
:data:`FAILURE_REWARD`,
:data:`SUCCESS_REWARDS`
==========================  =========================================================

:data:`HOLDER_RULES`, :data:`GIF_WRITER`, :data:`SIDE_BY_SIDE`, :data:`PANEL`, :data:`TEAM_CODE`, :data:`TEAM_COMPOSITION`,
the pages' names and the two vector environments are drill code that
``ilpss`` uses by name (:func:`drill_object`), imported only when used, and
:data:`TEAM_ERROR` is caught by name
(:func:`drill_exception`), so that ``ilpss`` itself never depends on the drill's rules.
"""

from __future__ import annotations

import functools
import importlib
import sys
from dataclasses import dataclass
from typing import Any

from soccer_drill.constraints import OneOf, checked

ENV_PACKAGE = "soccer_drill"
"""The package that registers the holder environment with Gymnasium."""
ENV_ID = f"{ENV_PACKAGE}:soccer_drill/Holder-v0"
"""The holder environment, made by ``gymnasium.make`` (``ilpss`` names it, never imports
its module)."""
PAPER_TEAMS = ("interceptors_press", "interceptors_cover", "interceptor_guard", "goal_guards")
"""The paper's four opponent teams, in its order (ids of the ``opponents`` package)."""
TILE_WIDTHS = (3.0, 3.0, 3.0, 3.0, 10.0, 3.0, 3.0, 3.0, 10.0)
"""Keepaway's tile widths for the drill's 9 features: 3 m for distances, 10 degrees for
angles (:attr:`HolderDrill.tile_widths` at any size)."""
DISTANCE_WIDTH, ANGLE_WIDTH = 3.0, 10.0
"""Keepaway's tile widths: metres for a distance, degrees for an angle."""
SAMPLER = "parametric"
"""The registered sampler of protocol C's opponents (``opponents.parametric``)."""
SAMPLER_TEAM = "parametric"
"""The team id that takes the sampled parameters."""
EPISODE_REWARD = (-1.0, 1.0)
"""Range of an episode's total reward: the drill pays one reward, in [-1, 1], at its end."""
FAILURE_REWARD = -1.0
"""What the drill pays for an interception, the ball out or the timeout."""
SUCCESS_REWARDS = (0.5, 1.0)
"""What the drill pays for a success: 1 at the goal line's centre, 0.5 at its ends."""
ACTION_NAMES = ("HOLD", "PASS", "DRIBBLE")
"""The holder's primitive actions, by index."""
LATERAL, GOAL_DISTANCE = 6, 5
"""Feature indices of the holder's position: its lateral offset from the line centre and
its distance to the goal line (metres)."""
FIELD = 35.0
"""Side of the square field (metres)."""
REGION_SOURCES = ("interceptors_press", "contain_cover")
"""Protocol R's sources: two pure behaviours whose best fixed rules differ
(``docs/regions.md``)."""
REGION_TARGETS = ("press_far_contain_near", "contain_left_press_right",
                  "press_left_contain_right")
"""Protocol R's targets: the sources composed by region, each kept because the
hand-composed rule beats the best single rule there (``docs/regions.md``)."""
REGION_SPLITS = ((GOAL_DISTANCE, 12.0), (LATERAL, 0.0))
"""The splits of protocol R's targets, as ``(feature index, threshold)``: within 12 m of
the goal line, and the left half (``opponents.region_stream``); the oracle's regions are
both sides of each."""
SHARP_SOURCES = ("interceptors_press", "interceptors_cover", "interceptor_guard",
                 "goal_guards", "contain_cover")
"""Protocol S's sources: the paper's four teams, then the contain
(``opponents.region_stream.SHARP_SOURCES``)."""
SHARP_TARGETS = ("press_far_contain_near_9", "press_far_contain_near",
                 "press_far_contain_near_15")
"""Protocol S's targets: the press far from the goal line, the contain near it, at 9, 12
and 15 m; each kept by the pre-check as needing a change of behaviour within the episode
(``docs/regions.md``)."""
SHARP_SPLITS = ((GOAL_DISTANCE, 9.0), (GOAL_DISTANCE, 15.0))
"""The splits of protocol S's targets besides :data:`REGION_SPLITS`' 12 m."""
TEAM_COMPOSITION = "opponents.regions:composition"
"""``composition(team_id) -> (feature index, threshold, team below, team above) | None``:
a region-composed team's split and the source on each side (``None``: not composed)."""
HOLDER_RULES = "soccer_drill.policies:HOLDER_POLICIES"
"""Where the drill's fixed holder rules are: a mapping of name to ``rule(obs, rng)``."""
PLAY_EPISODES = "soccer_drill.vector.holder:play_episodes"
"""``play_episodes(venv, rules, seeds) -> [(total reward, outcome)]``: fixed holder rules in
the batched holder drill (``gymnasium.make_vec`` of :data:`ENV_ID`), one episode per seed."""
EPISODE_GIF = "soccer_drill.rendering.gif:write_episode_gif"
"""``write_episode_gif(path, team=..., seed=..., policy=..., fps=...) -> info``: one holder
episode of a fixed rule, written as a GIF."""
TEAM_IDS = "soccer_drill.teams:team_ids"
"""``team_ids()``: the id of every installed team."""
TEAM_DESCRIPTION = "soccer_drill.teams:describe"
"""``describe(team_id)``: the first line of a team's docstring."""
MAKE_TEAM = "soccer_drill:make_team"
"""``make_team(team_id, **params)``: a team, built."""
SAMPLE_LABEL = "opponents.parametric:spec_label"
"""``spec_label(params)``: a short label of a member of :data:`SAMPLER`'s family."""
REGION = "opponents.regions:Region"
"""``Region(feature name, threshold)``: a split of the field by one of the holder's features."""
REGION_TEAM = "opponents.regions:RegionTeam"
"""``RegionTeam(above, below, region)``: one team on each side of a region."""
REGION_RULE = "opponents.regions:RegionRule"
"""``RegionRule(above, below, region)``: one fixed holder rule on each side of a region."""
GIF_WRITER = "soccer_drill.rendering.gif:save_gif"
"""The drill's GIF writer: ``save_gif(frames, path, fps)``, atomic."""
SIDE_BY_SIDE = "soccer_drill.rendering.side_by_side:write_side_by_side"
"""``write_side_by_side(path, panels, make_env, seeds)``: panels on the same seeds, one GIF."""
PANEL = "soccer_drill.rendering.side_by_side:Panel"
"""``Panel(label, play)``: one panel of :data:`SIDE_BY_SIDE`, ``play(env, seed)`` one episode."""
HOLDER_SB3_VEC_ENV = "soccer_drill.vector.sb3:HolderSB3VecEnv"
"""The batched holder behind Stable-Baselines3's ``VecEnv`` (needs SB3)."""
PARALLEL_VEC_ENV = "soccer_drill.vector.agents:ParallelVectorEnv"
"""The batched parallel drill, PettingZoo's parallel API with a leading batch axis."""
ATTACKS = "soccer_drill.vector.attack:ATTACKS"
"""The drill's scripted attacks (the fixed holder rules playing both attackers), by id."""
ATTACK_CODE = "soccer_drill.vector.attack:attack_code"
"""What identifies an attack's code, ``attack_code(attack_id) -> dict``, as
:data:`TEAM_CODE` a team's."""


TEAM_CODE = "soccer_drill.teams:team_code"
"""The drill's record of a team's code, ``team_code(team_id) -> dict`` (its factory, the
distribution that declares it, the digest of its package's source): results kept between
runs are tied to it, so that a team whose code changed is not taken for the old one."""


TEAM_ERROR = "soccer_drill:TeamError"
"""The drill's error for a team that fails to load, or whose commands break the rules (a
``RuntimeError``)."""


class _NeverRaised(Exception):
    """Stands for a drill exception while the drill is not imported."""


def drill_exception(spec: str) -> type[BaseException]:
    """The exception class named ``spec`` (``"module:attribute"``, e.g. :data:`TEAM_ERROR`)
    if its module is imported, else a class nothing raises; for an ``except`` clause, which
    looks it up only once an exception reaches it. The drill is never imported here: until
    it is, none of its exceptions can have been raised."""
    module, _, attribute = spec.partition(":")
    return getattr(sys.modules.get(module), attribute, _NeverRaised)


def drill_object(spec: str) -> Any:
    """The object named ``spec`` (``"module:attribute"``, e.g. :data:`GIF_WRITER`)."""
    module, _, attribute = spec.partition(":")
    return getattr(importlib.import_module(module), attribute)


KEEPAWAY_ENV_IDS = {"keepaway_3v2": "soccer_drill/Keepaway3v2-v0",
                    "keepaway_4v3": "soccer_drill/Keepaway4v3-v0"}
"""The keepaway scenarios' Gymnasium ids (the keeper with the ball's SMDP), by name."""
KEEPER_POLICIES = "soccer_drill.keepaway_policies:KEEPER_POLICIES"
"""Keepaway's fixed keeper policies (``hand_coded``, ``random``, ``hold``): name to
``rule(obs, rng)``."""
KEEPAWAY_LAYOUT = "soccer_drill.keepaway_policies:keepaway_layout"
"""``keepaway_layout(obs) -> (keepers, takers)`` of keepaway's state variables (their
last ``keepers - 1`` are the passing lanes' angles, in degrees; the rest distances, in
metres)."""
KEEPAWAY_VECTOR_ENV = "soccer_drill.scenarios:holder_vector_env"
"""``holder_vector_env(name, num_envs)``: a keepaway scenario's batched SMDP, for
:data:`PLAY_EPISODES` (which pays keepaway's seconds)."""


SCENARIO = "drill_2v2"
"""The paper's drill: the default of ``ExperimentConfig.scenario``."""
SCENARIOS = "soccer_drill.scenarios:SCENARIOS"
"""The drill's named scenarios, ``{name: Scenario}`` (``attackers``, ``defenders``,
``gym_id``, ``config()``)."""
FEATURE_NAMES = "soccer_drill.rules.features:feature_names"
"""``feature_names(teammates, opponents)``: the holder's features' names at a size."""


@dataclass(frozen=True)
class HolderDrill:
    """What ``ilpss`` knows of the holder of one scenario of the drill.

    The holder's features are keepaway's at every size (teammates and opponents by
    distance, a passing lane per teammate) with the goal line's, ``4 m + d + 3`` of them
    for ``m`` teammates and ``d`` opponents (the paper's 9 at 2v2); its actions are
    ``HOLD``, one ``PASS`` per teammate (nearest first) and ``DRIBBLE``.
    """

    scenario: str
    """The scenario's name (``drill_2v2``, ``drill_3v2``, ...)."""
    attackers: int
    defenders: int
    env_id: str
    """The holder's Gymnasium id, with its package (what ``gymnasium.make`` takes)."""
    feature_names: tuple[str, ...]
    """The features' names, by index."""
    episode_reward: tuple[float, float]
    """Range of an episode's total reward (the drill pays one reward, at the end)."""

    @property
    def teammates(self) -> int:
        """The holder's teammates (``m``)."""
        return self.attackers - 1

    @property
    def opponents(self) -> int:
        """The holder's opponents (``d``)."""
        return self.defenders

    @property
    def action_names(self) -> tuple[str, ...]:
        """The primitive actions by index: ``HOLD``, the passes (nearest teammate first;
        ``PASS`` when there is one teammate), ``DRIBBLE``."""
        passes = (("PASS",) if self.teammates == 1 else
                  tuple(f"PASS_{k}" for k in range(1, self.teammates + 1)))
        return ("HOLD", *passes, "DRIBBLE")

    @property
    def tile_widths(self) -> tuple[float, ...]:
        """Keepaway's widths, one per feature: :data:`ANGLE_WIDTH` for an angle, else
        :data:`DISTANCE_WIDTH` (every other feature is a distance or an offset in
        metres)."""
        return tuple(ANGLE_WIDTH if "angle" in name else DISTANCE_WIDTH
                     for name in self.feature_names)

    @property
    def lateral(self) -> int:
        """Index of the holder's lateral offset from the line centre."""
        return self.feature_names.index("lateral")

    @property
    def goal_distance(self) -> int:
        """Index of the holder's distance to the goal line."""
        return self.feature_names.index("dist_goal")


def scenario_names() -> tuple[str, ...]:
    """The names of the drill's scenarios: those of its task ``drill`` (keepaway's, whose
    holder has other features and pays by the second, have their own experiment,
    :mod:`ilpss.experiments.keepaway`)."""
    return tuple(name for name, s in drill_object(SCENARIOS).items() if s.task == "drill")


def holder_drill(scenario: str) -> HolderDrill:
    """What ``ilpss`` knows of scenario ``scenario``'s holder.

    Raises:
        ValueError: ``scenario`` is not a scenario of the drill (the message names them).
    """
    return _holder_drill(checked("scenario", scenario, OneOf(scenario_names())))


@functools.cache
def _holder_drill(scenario: str) -> HolderDrill:
    s = drill_object(SCENARIOS)[scenario]
    config = s.config()
    rewards = (config.reward_success_centre, config.reward_success_edge,
               config.reward_failure, config.reward_timeout)
    return HolderDrill(
        scenario=scenario, attackers=s.attackers, defenders=s.defenders,
        env_id=f"{ENV_PACKAGE}:{s.gym_id}",
        feature_names=tuple(drill_object(FEATURE_NAMES)(s.attackers - 1, s.defenders)),
        episode_reward=(float(min(rewards)), float(max(rewards))),
    )


def drill_of_env(env_id: str) -> HolderDrill | None:
    """The scenario whose holder ``env_id`` names (with or without its package), or
    ``None`` for another environment."""
    name = env_id.rpartition(":")[2]
    for scenario in scenario_names():
        if holder_drill(scenario).env_id.rpartition(":")[2] == name:
            return holder_drill(scenario)
    return None
