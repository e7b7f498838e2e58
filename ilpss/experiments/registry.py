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

Other names in the files need no registry: methods, protocols, executors, the learner's
``method`` and the kernel model named in a checkpoint are checked against fixed lists, and
team ids are looked up by the drill in its own registry of teams.
"""

from __future__ import annotations

from collections.abc import Callable
from importlib.metadata import entry_points
from typing import Any

__all__ = [
    "ENV_PACKAGES",
    "SAMPLERS",
    "Registry",
    "check_env_id",
    "register_environment_package",
    "register_sampler",
]


def _is_name(name: object) -> bool:
    """Letters, digits, ``_``, ``-`` and ``.``, starting with a letter or ``_``."""
    return (
        isinstance(name, str)
        and bool(name)
        and all(part.replace("-", "_").isidentifier() for part in name.split("."))
    )


class Registry:
    """Named objects of one kind, from an entry-point group and in-process registrations.

    Parameters
    ----------
    group : str
        The entry-point group read once, on first use.
    kind : str
        What an entry is, for error messages (e.g. ``"sampler"``).
    """

    def __init__(self, group: str, kind: str) -> None:
        self.group = group
        self.kind = kind
        self._entries: dict[str, Any] = {}  # name -> EntryPoint (not loaded) or object
        self._loaded: dict[str, Any] = {}
        self._discovered = False

    def _discover(self) -> None:
        if not self._discovered:
            for ep in entry_points(group=self.group):
                self._entries.setdefault(ep.name, ep)
            self._discovered = True

    def register(self, name: str, obj: Any, *, overwrite: bool = False) -> None:
        """Register ``obj`` under ``name`` for this process.

        Raises
        ------
        ValueError
            ``name`` is not a name (letters, digits, ``_``, ``-``, ``.``), or is taken and
            ``overwrite`` is false.
        """
        if not _is_name(name):
            raise ValueError(
                f"a {self.kind} name must be letters, digits, '_', '-' or '.', got {name!r}"
            )
        self._discover()
        if name in self._entries and not overwrite:
            raise ValueError(f"{self.kind} {name!r} is already registered; pass overwrite=True")
        self._entries[name] = obj
        self._loaded[name] = obj

    def unregister(self, name: str) -> None:
        """Forget an in-process registration (entry points stay)."""
        self._entries.pop(name, None)
        self._loaded.pop(name, None)
        self._discovered = False  # an entry point of that name shows again

    def names(self) -> list[str]:
        """Every registered name, sorted (imports nothing)."""
        self._discover()
        return sorted(self._entries)

    def __contains__(self, name: object) -> bool:
        self._discover()
        return isinstance(name, str) and name in self._entries

    def check(self, field: str, name: object, *, registered: bool = True) -> None:
        """Refuse ``name`` unless it is a name and (if ``registered``) a registered one; the
        message names ``field``."""
        if not _is_name(name):
            raise ValueError(
                f"{field} must be the name of a registered {self.kind} (letters, digits, "
                f"'_', '-' or '.'), got {name!r}; registered: {self.names()}"
            )
        if registered and name not in self:
            raise ValueError(
                f"{field} must name a registered {self.kind} (entry-point group "
                f"{self.group!r}), got {name!r}; registered: {self.names()}"
            )

    def get(self, name: str) -> Any:
        """The object registered as ``name`` (an entry point is imported on first use)."""
        self._discover()
        if name not in self._entries:
            raise ValueError(
                f"unknown {self.kind} {name!r}; registered: {self.names()}"
            )
        if name not in self._loaded:
            ep = self._entries[name]
            try:
                self._loaded[name] = ep.load()
            except Exception as exc:
                raise ValueError(
                    f"the entry point of {self.kind} {name!r} ({ep.value}) failed to load: "
                    f"{exc!r}"
                ) from exc
        return self._loaded[name]


SAMPLERS = Registry("ilpss.samplers", "sampler")
"""Protocol C's samplers: ``sampler(n, seed) -> list of n opponent parameter dicts``."""
ENV_PACKAGES = Registry("ilpss.environments", "environment package")
"""Packages that ``gymnasium.make`` may import for an ``env_id`` of the form ``package:id``."""


def register_sampler(
    name: str, sampler: Callable[[int, int], list[dict[str, Any]]], *, overwrite: bool = False
) -> None:
    """Register a protocol C sampler for this process (tests, notebooks)."""
    if not callable(sampler):
        raise TypeError(f"sampler {name!r} must be callable, got {sampler!r}")
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
