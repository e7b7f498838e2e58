"""Named objects of one kind, from an entry-point group and in-process registrations.

Every name a configuration or a saved file may carry (a team, a sampler, a method, a
protocol, a way of reusing past policies) is looked up in a :class:`Registry` of things
installed code declared, never imported from the file's text.

An entry point is imported on first use, once. One that fails to import (or, for a
registry of callables, names something that is not callable) only breaks its own entry:
asking for it raises the registry's error naming it and what went wrong, every time,
without importing it again, and :meth:`Registry.broken` lists it. A declared name that
is not valid is refused the same way, with a :class:`PluginWarning`; a name declared by
two distributions warns, naming both, and the first found on ``sys.path`` is used,
unless one of them is this project's own distribution, which always wins.

This module imports nothing from the project's packages but the constraint vocabulary.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from importlib.metadata import entry_points
from typing import Any

from soccer_drill.constraints import Constraint, Name

__all__ = ["PROJECT_DISTRIBUTION", "PluginWarning", "Registry"]

PROJECT_DISTRIBUTION = "soccer-drill-ilpss"
"""The distribution of this project's own entries: they win a name that a plugin declares
too (results labelled ``"chasers"`` are always this project's chasers)."""


class PluginWarning(UserWarning):
    """A plugin is broken or ambiguous; the other entries are unaffected."""


@dataclass
class _Entry:
    """A registered object, or an entry point loaded on first use (its failure kept: a
    broken plugin is not imported again by every lookup)."""

    obj: Any = None
    entry_point: Any = None  # importlib.metadata.EntryPoint, or None for a registration
    loaded: bool = False
    failure: str | None = field(default=None, repr=False)
    cause: BaseException | None = field(default=None, repr=False)


def _origin(ep: Any) -> str:
    """The distribution that declares entry point ``ep``, for messages."""
    name = getattr(getattr(ep, "dist", None), "name", None)
    return f"distribution {name!r} ({ep.value})" if name else f"an entry point ({ep.value})"


def _distribution(ep: Any) -> str:
    name = getattr(getattr(ep, "dist", None), "name", None) or ""
    return name.lower().replace("_", "-").replace(".", "-")


def _article(word: str) -> str:
    return "an" if word[:1].lower() in "aeiou" else "a"


class Registry:
    """Named objects of one kind, from an entry-point group and in-process registrations.

    Parameters
    ----------
    group : str
        The entry-point group, read on first use (again after :meth:`refresh`).
    kind : str
        What an entry is, for messages (e.g. ``"sampler"``, ``"team"``).
    of : type, optional
        The class of the objects that :meth:`add` registers under their ``name``.
    label : str, default "name"
        What a name is called in messages (``"id"`` for teams).
    names : Constraint, default Name()
        What a name must be.
    calls : str, optional
        Entries must be callable; what one is, for messages (e.g. ``"a team class or
        factory"``).
    error : type of Exception, default ValueError
        Raised for an entry that cannot be used (failed to load, not callable, declared
        under a name that is not valid); an unknown name is always a ``ValueError``.
    own_distribution : str, default PROJECT_DISTRIBUTION
        The distribution whose entry points win a name that another declares too.
    """

    def __init__(
        self,
        group: str,
        kind: str,
        of: type | None = None,
        *,
        label: str = "name",
        names: Constraint = Name(),  # noqa: B008 - a frozen, immutable constraint
        calls: str | None = None,
        error: type[Exception] = ValueError,
        own_distribution: str = PROJECT_DISTRIBUTION,
    ) -> None:
        self.group = group
        self.kind = kind
        self.of = of
        self.label = label
        self.names_allowed = names
        self.calls = calls
        self.error = error
        self.own_distribution = own_distribution
        self._entries: dict[str, _Entry] = {}
        self._refused: dict[str, str] = {}  # declared names that are not valid: name -> why
        self._discovered = False

    # ------------------------------------------------------------------ discovery
    def _discover(self) -> None:
        if self._discovered:
            return
        self._discovered = True
        try:
            found = list(entry_points(group=self.group))
        except Exception as exc:  # unreadable metadata of some installed distribution
            warnings.warn(f"could not read the {self.group!r} entry points: {exc!r}",
                          PluginWarning, stacklevel=4)
            return
        found.sort(key=lambda ep: _distribution(ep) != self.own_distribution)  # own first
        first: dict[str, Any] = {}
        for ep in found:
            problem = self._name_problem(ep.name)
            if problem is not None:
                self._refused[ep.name] = f"{self.kind} {ep.name!r} of {_origin(ep)} is refused: {problem}"
                warnings.warn(self._refused[ep.name], PluginWarning, stacklevel=4)
            elif ep.name in first:
                own = _distribution(first[ep.name]) == self.own_distribution
                kept = f"this project's own {self.kind}" if own else "the first"
                warnings.warn(
                    f"{self.kind} {self.label} {ep.name!r} is declared twice, by "
                    f"{_origin(first[ep.name])} and by {_origin(ep)}; using {kept} (give the "
                    f"other {self.kind} {_article(self.label)} {self.label} of its own)",
                    PluginWarning, stacklevel=4,
                )
            else:
                first[ep.name] = ep
                self._entries.setdefault(ep.name, _Entry(entry_point=ep))  # a registration wins

    def refresh(self) -> None:
        """Look for newly installed entry points (keeps in-process registrations)."""
        for name in [k for k, e in self._entries.items() if e.entry_point is not None]:
            del self._entries[name]
        self._refused.clear()
        self._discovered = False
        self._discover()

    # ------------------------------------------------------------------ registration
    def _name_problem(self, name: object) -> str | None:
        """Why ``name`` is not valid, or ``None``."""
        if self.names_allowed.allows(name):
            return None
        return (f"{_article(self.kind)} {self.kind} {self.label} must be "
                f"{self.names_allowed.describe()}, got {name!r}")

    def register(self, name: str, obj: Any, *, overwrite: bool = False) -> None:
        """Register ``obj`` under ``name`` for this process (tests, notebooks).

        Raises
        ------
        ValueError
            ``name`` is not valid, or is taken and ``overwrite`` is false.
        TypeError
            The registry holds callables and ``obj`` is not one.
        """
        problem = self._name_problem(name)
        if problem is not None:
            raise ValueError(problem)
        if self.calls is not None and not callable(obj):
            raise TypeError(f"{self.kind} {name!r} must be {self.calls} (a callable), got {obj!r}")
        self._discover()
        if name in self._entries and not overwrite:
            raise ValueError(f"{self.kind} {name!r} is already registered; pass overwrite=True")
        self._entries[name] = _Entry(obj=obj, loaded=True)

    def add(self, obj: Any, *, overwrite: bool = False) -> None:
        """Register ``obj``, an instance of :attr:`of`, under its ``name``."""
        if self.of is None:
            raise TypeError(f"a {self.kind} is registered with register(name, obj)")
        if not isinstance(obj, self.of):
            raise TypeError(f"a {self.kind} must be a {self.of.__name__}, got "
                            f"{type(obj).__name__}")
        self.register(obj.name, obj, overwrite=overwrite)

    def unregister(self, name: str) -> None:
        """Forget an in-process registration (an entry point of that name shows again)."""
        self._entries.pop(name, None)
        self._discovered = False

    @contextmanager
    def isolated(self) -> Iterator[Registry]:
        """A context whose registrations are its own: the registry is put back as it was
        (the installed entries discovered first, so it holds them all) at its end."""
        self._discover()
        entries, refused = dict(self._entries), dict(self._refused)
        try:
            yield self
        finally:
            self._entries, self._refused, self._discovered = entries, refused, True

    # ------------------------------------------------------------------ lookup
    def names(self) -> list[str]:
        """Every registered name, sorted (imports nothing)."""
        self._discover()
        return sorted(self._entries)

    def __contains__(self, name: object) -> bool:
        self._discover()
        return isinstance(name, str) and name in self._entries

    def check(self, field: str, name: object, *, registered: bool = True) -> None:
        """Refuse ``name`` unless it is valid and (if ``registered``) a registered one; the
        message names ``field``."""
        if not self.names_allowed.allows(name):
            raise ValueError(
                f"{field} must be the {self.label} of a registered {self.kind}, "
                f"{self.names_allowed.describe()}, got {name!r}; registered: {self.names()}"
            )
        if registered and name not in self:
            raise ValueError(
                f"{field} must name a registered {self.kind} (entry-point group "
                f"{self.group!r}), got {name!r}; registered: {self.names()}"
            )

    def get(self, name: str) -> Any:
        """The object registered as ``name`` (an entry point is imported on first use).

        Raises
        ------
        ValueError
            ``name`` is not registered.
        Exception
            The registry's ``error``: the entry cannot be used (its entry point failed to
            load or names something not callable, or its declared name is not valid).
        """
        self._discover()
        entry = self._entries.get(name)
        if entry is None:
            if name in self._refused:
                raise self.error(self._refused[name])
            raise ValueError(f"unknown {self.kind} {name!r}; known {self.kind}s: {self.names()}")
        if not entry.loaded:
            self._load(name, entry)
        if entry.failure is not None:
            raise self.error(entry.failure) from entry.cause
        return entry.obj

    def _load(self, name: str, entry: _Entry) -> None:
        ep = entry.entry_point
        where = f"the entry point of {self.kind} {name!r} ({ep.value})"
        entry.loaded = True
        try:
            obj = ep.load()
        # SystemExit too: a plugin calling sys.exit() at import must not end the host.
        except (Exception, SystemExit) as exc:
            entry.failure, entry.cause = f"{where} failed to load: {exc!r}", exc
            return
        if self.calls is not None and not callable(obj):
            entry.failure = (f"{where} is not callable: it names a {type(obj).__name__} "
                             f"({obj!r}); it must name {self.calls}")
            return
        entry.obj = obj

    def entry_point(self, name: str) -> Any:
        """The entry point that declares ``name`` (``None`` for an in-process
        registration)."""
        self._discover()
        entry = self._entries.get(name)
        return None if entry is None else entry.entry_point

    def broken(self) -> dict[str, str]:
        """``{name: what is wrong}`` for every declared entry that cannot be used.

        Imports every entry point not imported yet.
        """
        self._discover()
        broken = dict(self._refused)
        for name in self.names():
            try:
                self.get(name)
            except self.error as exc:
                broken[name] = str(exc)
        return dict(sorted(broken.items()))
