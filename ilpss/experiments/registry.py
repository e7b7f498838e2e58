"""Names that experiment files may carry, and the code each one stands for.

A results folder is data: reading one (``ilpss-compare``, ``ilpss-experiment --config``,
a resume) must never import or call something the folder names. So every name in a
configuration is looked up in a registry of things that installed code declared, never
imported from the file's text:

====================  =========================  ======================================
registry              entry-point group          a name stands for
====================  =========================  ======================================
:data:`SAMPLERS`      ``ilpss.samplers``         ``sampler(n, seed) -> list of parameter
                                                 dicts``: the opponents of protocol C
:data:`ENV_PACKAGES`  ``ilpss.environments``     a package that ``gymnasium.make`` may
                                                 import for an ``env_id`` written
                                                 ``"package:id"``
====================  =========================  ======================================

A distribution declares its entries in its ``pyproject.toml``, as this one does::

    [project.entry-points."ilpss.samplers"]
    parametric = "opponents.parametric:sample_opponents"

    [project.entry-points."ilpss.environments"]
    soccer_drill = "soccer_drill"

(``pip install -e .`` again after adding one, so that it is seen). Tests and notebooks
register in-process with :func:`register_sampler` and :func:`register_environment_package`;
such a registration is seen by local worker processes (they are forked) but not by Ray
workers. Listing the names of a group imports nothing; an entry point is imported when it
is first used.

Methods, protocols and ways of reusing past policies are registries of their own
(:data:`~ilpss.experiments.methods.METHODS`, :data:`~ilpss.experiments.protocols.PROTOCOLS`,
:data:`~ilpss.reuse.REUSES`, on the same :class:`Registry`). Other names in the files need
none: executors and the learner's ``method`` are checked against fixed lists, the kernel
model named in a checkpoint against the one its configuration's reuse builds, and team ids
are looked up in the drill's registry of teams (:data:`soccer_drill.teams.registry.TEAMS`, a
:class:`Registry` too).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from soccer_drill.registry import Registry

__all__ = [
    "ENV_PACKAGES",
    "SAMPLERS",
    "register_environment_package",
    "register_sampler",
]


SAMPLERS = Registry("ilpss.samplers", "sampler", calls="a function sampler(n, seed)")
"""Protocol C's samplers: ``sampler(n, seed) -> list of n opponent parameter dicts``."""
ENV_PACKAGES = Registry("ilpss.environments", "environment package")
"""Packages that ``gymnasium.make`` may import for an ``env_id`` of the form ``package:id``."""


def register_sampler(
    name: str, sampler: Callable[[int, int], list[dict[str, Any]]], *, overwrite: bool = False
) -> None:
    """Register a protocol C sampler for this process (tests, notebooks)."""
    SAMPLERS.register(name, sampler, overwrite=overwrite)


def register_environment_package(name: str, *, overwrite: bool = False) -> None:
    """Allow ``env_id`` values of the form ``"name:id"`` in this process."""
    ENV_PACKAGES.register(name, name, overwrite=overwrite)


def check_env_id(field: str, env_id: object) -> None:
    """Refuse an environment id that would make ``gymnasium.make`` import an unregistered
    module.

    Allowed: a plain Gymnasium id (``"CartPole-v1"``, ``"soccer_drill/Holder-v0"``),
    which Gymnasium only looks up in its registry of environments that code registered;
    or ``"package:id"`` where ``package`` is in :data:`ENV_PACKAGES`.
    """
    if not isinstance(env_id, str) or not env_id.strip():
        raise ValueError(f"{field} must be a Gymnasium id (a non-empty string), got {env_id!r}")
    if ":" not in env_id:
        return
    package, _, name = env_id.partition(":")
    if not name or ":" in name:
        raise ValueError(f"{field} must be 'id' or 'package:id', got {env_id!r}")
    if package not in ENV_PACKAGES:
        raise ValueError(
            f"{field} {env_id!r} names the package {package!r}, which Gymnasium would import; "
            f"only registered environment packages may be named (entry-point group "
            f"{ENV_PACKAGES.group!r}): {ENV_PACKAGES.names()}"
        )
