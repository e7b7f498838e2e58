"""Named scenarios: drills of a given size, made by one id in Gymnasium and PettingZoo.

| scenario | attackers v defenders | task | Gymnasium id (the holder's SMDP) | PettingZoo (``scenarios.parallel_env(name)``, ``scenarios.env(name)``) | default team |
|---|---|---|---|---|---|
| ``drill_2v2`` | 2 v 2 | drill: carry the ball over the goal line | ``soccer_drill/Holder-v0`` (the paper's drill) | ``drill_2v2`` | ``chasers`` |
| ``drill_1v1`` | 1 v 1 | drill | ``soccer_drill/Holder1v1-v0`` | ``drill_1v1`` | ``chasers`` |
| ``drill_3v2`` | 3 v 2 | drill | ``soccer_drill/Holder3v2-v0`` | ``drill_3v2`` | ``chasers`` |
| ``drill_3v3`` | 3 v 3 | drill | ``soccer_drill/Holder3v3-v0`` | ``drill_3v3`` | ``chasers`` |
| ``keepaway_3v2`` | 3 keepers v 2 takers | keepaway, 20 m x 20 m, 60 s limit | ``soccer_drill/Keepaway3v2-v0`` | ``keepaway_3v2`` | ``keepaway_takers`` |
| ``keepaway_4v3`` | 4 keepers v 3 takers | keepaway, 30 m x 30 m, 60 s limit | ``soccer_drill/Keepaway4v3-v0`` | ``keepaway_4v3`` | ``keepaway_takers`` |

Every drill scenario is the drill's :class:`~soccer_drill.config.DrillConfig` with its
numbers of players and the 35 m region of the paper; the keepaway scenarios are
``DrillConfig(task="keepaway")`` on keepaway's standard regions (3v2 on 20 m x 20 m,
4v3 on 30 m x 30 m; ``docs/keepaway.md``). ``docs/scenarios.md`` has the table with each
scenario's best fixed rule. The Gymnasium ids are registered when ``soccer_drill``
is imported; ``gymnasium.make(id, opponent=..., config=...)`` overrides a scenario's team
or any other field (``config``: a dict of ``DrillConfig`` fields, merged over the
scenario's). The PettingZoo environments are :func:`env` and :func:`parallel_env` of a
scenario's name (PettingZoo has no registry of ids: an environment is a function), with
the keyword arguments of :class:`~soccer_drill.envs.agents.raw_env`, which have no
scripted team unless ``opponent`` is given.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from soccer_drill.config import DrillConfig
from soccer_drill.constraints import OneOf, checked
from soccer_drill.envs.agents import parallel_env as _parallel_env
from soccer_drill.envs.agents import raw_env
from soccer_drill.envs.holder import HolderEnv


@dataclass(frozen=True)
class Scenario:
    """One named drill: its size, its task, its team and its ids."""

    name: str
    """Its name, ``drill_<A>v<D>``: the PettingZoo environments' argument."""
    attackers: int
    defenders: int
    gym_id: str
    """Its Gymnasium id (the ball holder's SMDP, :class:`~soccer_drill.envs.holder.HolderEnv`)."""
    task: str = "drill"
    """What the attackers do (:data:`~soccer_drill.tasks.TASKS`): ``drill``, carry the
    ball over the goal line; ``keepaway``, keep it in the region as long as they can."""
    opponent: str = "chasers"
    """The scripted team the holder's SMDP meets by default."""
    settings: tuple[tuple[str, Any], ...] = ()
    """The scenario's own ``DrillConfig`` fields (a keepaway region's size, its time
    limit), under any changes given."""

    def config(self, changes: Mapping[str, Any] | DrillConfig | None = None) -> DrillConfig:
        """The scenario's configuration, with ``changes`` (a dict of fields, or a whole
        ``DrillConfig`` of the scenario's size) over it."""
        if isinstance(changes, DrillConfig):
            if changes.size != (self.attackers, self.defenders) or changes.task != self.task:
                raise ValueError(
                    f"scenario {self.name!r} is {self.task} {self.attackers}v{self.defenders}; "
                    f"the config given is {changes.task} {changes.attackers}v{changes.defenders}")
            return changes
        values = {"attackers": self.attackers, "defenders": self.defenders, "task": self.task,
                  **dict(self.settings), **(changes or {})}
        return DrillConfig.from_dict(values)


KEEPAWAY_MAX_CYCLES = 600
"""The keepaway scenarios' time limit: 600 cycles, 60 s (a truncation; keepaway itself
has none)."""

SCENARIOS: dict[str, Scenario] = {
    s.name: s for s in (
        Scenario("drill_2v2", 2, 2, "soccer_drill/Holder-v0"),
        Scenario("drill_1v1", 1, 1, "soccer_drill/Holder1v1-v0"),
        Scenario("drill_3v2", 3, 2, "soccer_drill/Holder3v2-v0"),
        Scenario("drill_3v3", 3, 3, "soccer_drill/Holder3v3-v0"),
        Scenario("keepaway_3v2", 3, 2, "soccer_drill/Keepaway3v2-v0", task="keepaway",
                 opponent="keepaway_takers",
                 settings=(("field_size", 20.0), ("max_cycles", KEEPAWAY_MAX_CYCLES))),
        Scenario("keepaway_4v3", 4, 3, "soccer_drill/Keepaway4v3-v0", task="keepaway",
                 opponent="keepaway_takers",
                 settings=(("field_size", 30.0), ("max_cycles", KEEPAWAY_MAX_CYCLES))),
    )
}
"""The named scenarios, by name."""


def scenario(name: object) -> Scenario:
    """The scenario called ``name``; else ``ValueError`` naming the scenarios."""
    return SCENARIOS[checked("scenario", name, OneOf(tuple(SCENARIOS)))]


def holder_env(name: str = "drill_2v2", **kwargs: Any) -> HolderEnv:
    """The holder's SMDP of scenario ``name`` (what its Gymnasium id makes):
    :class:`~soccer_drill.envs.holder.HolderEnv` with the scenario's team unless
    ``opponent`` is given, ``config`` merged over the scenario's."""
    s = scenario(name)
    kwargs.setdefault("opponent", s.opponent)
    return HolderEnv(config=s.config(kwargs.pop("config", None)), **kwargs)


def env(name: str, **kwargs: Any) -> raw_env:
    """The PettingZoo AEC environment of scenario ``name`` (keyword arguments of
    :class:`~soccer_drill.envs.agents.raw_env`, ``config`` merged over the scenario's)."""
    return raw_env(config=scenario(name).config(kwargs.pop("config", None)), **kwargs)


def parallel_env(name: str, **kwargs: Any) -> _parallel_env:
    """The PettingZoo parallel environment of scenario ``name`` (as :func:`env`)."""
    return _parallel_env(config=scenario(name).config(kwargs.pop("config", None)), **kwargs)


def _register() -> None:
    """The scenarios' Gymnasium ids (the paper's drill keeps ``soccer_drill/Holder-v0``,
    registered with ``soccer_drill``), each to :func:`holder_env` of its name."""
    import gymnasium

    for s in SCENARIOS.values():
        if s.gym_id not in gymnasium.registry:
            gymnasium.register(id=s.gym_id, entry_point=f"soccer_drill.scenarios:_make_{s.name}",
                               vector_entry_point=f"soccer_drill.scenarios:_make_vec_{s.name}")


def _id_entry_points(s: Scenario) -> tuple[Callable[..., Any], Callable[..., Any]]:
    """The entry points of ``s``'s Gymnasium id (:func:`holder_env` and
    :func:`holder_vector_env` of its name), which refuse ``name``: an id makes its own
    scenario (before, ``gymnasium.make(id, name=...)`` made another under the id)."""
    def refuse_name(kwargs: dict[str, Any]) -> None:
        if "name" in kwargs:
            raise TypeError(f"{s.gym_id} makes the scenario {s.name!r}; it takes no name "
                            f"(got {kwargs['name']!r}): make the id of the scenario wanted "
                            f"({', '.join(x.gym_id for x in SCENARIOS.values())})")

    def make(**kwargs: Any) -> HolderEnv:
        refuse_name(kwargs)
        return holder_env(s.name, **kwargs)

    def make_vec(num_envs: int = 1, **kwargs: Any):
        refuse_name(kwargs)
        return holder_vector_env(s.name, num_envs, **kwargs)

    return make, make_vec


for _s in SCENARIOS.values():  # the module's attributes the ids' entry points name
    globals()[f"_make_{_s.name}"], globals()[f"_make_vec_{_s.name}"] = _id_entry_points(_s)


def holder_vector_env(name: str = "drill_2v2", num_envs: int = 1, **kwargs: Any):
    """The batched holder's SMDP of scenario ``name`` (what ``gymnasium.make_vec`` of its
    id makes): :class:`~soccer_drill.vector.holder.HolderVectorEnv`."""
    from soccer_drill.vector.holder import HolderVectorEnv

    s = scenario(name)
    kwargs.setdefault("opponent", s.opponent)
    return HolderVectorEnv(num_envs=num_envs, config=s.config(kwargs.pop("config", None)),
                           **kwargs)
