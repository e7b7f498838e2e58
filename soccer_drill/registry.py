"""Named objects of one kind, from an entry-point group and in-process registrations.

Every name a configuration or a saved file may carry (a team, a sampler, a method, a
protocol, a way of reusing past policies) is looked up in a :class:`Registry` of things
installed code declared, never imported from the file's text.

An entry point is imported on first use, once. One that fails to import (or names
something that is not callable, or not of the registry's class, or of another name) only
breaks its own entry: asking for it raises the registry's error naming it, its
distribution and group, and what went wrong, every time, without importing it again, and
:meth:`Registry.broken` lists it. A declared name that is not valid (the registry's
``names`` constraint: by default :class:`~soccer_drill.constraints.Name`, at most 64 ASCII
characters), or that looks like another (the same but for case, or ``-`` against ``_``),
is refused the same way, with a :class:`PluginWarning` (this project's own entries are
read first, so they keep their names); a name declared by two distributions warns, naming
both, and the first found on ``sys.path`` is used, unless one of them is this project's
own distribution, which always wins. A distribution whose entry points cannot be read (an
``entry_points.txt`` that is not UTF-8, a line without ``=``) is left out with a
:class:`PluginWarning` naming it; the others are read.

A registry may be used from several threads: its first reading of the entry points and
each entry point's import happen once, under the registry's lock (re-entrant: a plugin may
use its registry while it is imported; a plugin whose import hangs keeps the other
threads asking that registry waiting), and a name is listed, or an entry given, only once
that work is done. An exception that a signal delivers meanwhile (a
Ctrl-C, or one a program's signal handler raises: see :mod:`soccer_drill.interruptions`)
is not an entry's failure: it passes on unchanged, and the next use reads or imports
again.

This module imports nothing from the project's packages but the constraint vocabulary and
:mod:`soccer_drill.interruptions`.
"""

from __future__ import annotations

import threading
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from importlib import metadata
from typing import Any

from soccer_drill.constraints import NAME_LENGTH, Constraint, Name
from soccer_drill.interruptions import SignalsDeferred, delivered_by_signal, short_repr

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
    distribution: str = ""  # the name of the distribution that declares the entry point
    loaded: bool = False
    failure: str | None = field(default=None, repr=False)
    cause: BaseException | None = field(default=None, repr=False)


def _distribution_said(dist: Any) -> tuple[str, str]:
    """A distribution's name as declared (else as its folder says) and where it is
    installed, for messages."""
    said = []
    for read in (lambda: dist.metadata["Name"], lambda: dist.locate_file("")):
        try:
            said.append(read())
        except Exception as exc:  # metadata this broken: said by its folder, or as "?"
            if delivered_by_signal(exc):
                raise
            said.append(None)
    name, where = said
    return str(name or getattr(dist, "_normalized_name", None) or "?"), str(where or "?")


def _value(ep: Any) -> str:
    """What entry point ``ep`` names (``module:attribute``), cut for messages."""
    value = str(ep.value)
    return value if len(value) <= 200 else f"{value[:200]}... ({len(value):,} characters)"


def _origin(ep: Any, distribution: str) -> str:
    """The distribution that declares entry point ``ep``, for messages."""
    return f"distribution {distribution!r} ({_value(ep)})"


def _normalised(name: str) -> str:
    return name.lower().replace("_", "-").replace(".", "-")


def _article(word: str) -> str:
    return "an" if word[:1].lower() in "aeiou" else "a"


def _look_alike(name: str) -> str:
    """What two names that are easily taken for each other have in common: the same
    letters whatever their case, ``-`` and ``_`` alike."""
    return name.casefold().replace("-", "_")


def _shown(name: object) -> str:
    """A name for a message: a string far beyond any valid name is cut, with its length."""
    if isinstance(name, str) and len(name) > 2 * NAME_LENGTH:
        return f"{name[:NAME_LENGTH]!r}... ({len(name):,} characters)"
    return short_repr(name)


def _said(exc: BaseException) -> str:
    """An exception for a message: its type and the start of its text (a decoding error's
    own repr holds the whole file)."""
    text = str(exc)
    return f"{type(exc).__name__}: {text[:300]}{'...' if len(text) > 300 else ''}"


_UNREADABLE_WARNED: set[tuple[str, str]] = set()
"""The distributions whose entry points could not be read, already warned about in this
process (every registry reads every distribution: one warning each is enough)."""


def _declared(
    group: str,
) -> tuple[list[tuple[Any, str]], list[tuple[tuple[str, str] | None, str]]]:
    """The entry points of ``group`` with the name of the distribution that declares each,
    distribution by distribution in the order of ``sys.path`` (the first of a name only,
    as :func:`importlib.metadata.entry_points` does), and a note for each distribution
    whose entry points or name cannot be read (with the distribution, to be said once in
    the process).

    Raises what a signal delivers meanwhile, as it is.
    """
    found, notes = [], []
    seen: set[str] = set()
    try:
        for dist in metadata.distributions():
            try:
                # The stdlib's own key of a distribution (its folder's name): the first on
                # sys.path wins, as for imports.
                key = getattr(dist, "_normalized_name", None) or _normalised(dist.name)
                if key in seen:
                    continue
                seen.add(key)
                declared = [ep for ep in dist.entry_points if ep.group == group]
                if declared:
                    name = dist.name
                    if not isinstance(name, str):
                        raise ValueError(f"its metadata declares no name (Name: {name!r})")
                    found += [(ep, name) for ep in declared]
            except Exception as exc:
                if delivered_by_signal(exc):
                    raise
                name, where = _distribution_said(dist)
                notes.append(((where, name), (
                    f"could not read the metadata of distribution {name!r} (in {where}): "
                    f"{_said(exc)}; its entry points are left out, the other distributions' "
                    "are read (reinstall or remove it)")))
    except Exception as exc:  # listing the distributions failed: keep what was read
        if delivered_by_signal(exc):
            raise
        notes.append((None, f"could not list the installed distributions while reading the "
                            f"{group!r} entry points: {_said(exc)}"))
    return found, notes


class Registry:
    """Named objects of one kind, from an entry-point group and in-process registrations.

    Parameters
    ----------
    group : str
        The entry-point group, read on first use (again after :meth:`refresh`).
    kind : str
        What an entry is, for messages (e.g. ``"sampler"``, ``"team"``).
    of : type, optional
        The class of the objects: :meth:`add` registers one under its ``name``, and an
        entry point must name one whose ``name`` is the entry point's.
    label : str, default "name"
        What a name is called in messages (``"id"`` for teams).
    names : Constraint, default Name()
        What a name must be.
    calls : str, optional
        Entries must be callable; what one is, for messages (e.g. ``"a team class or
        factory"``).
    error : type of Exception, default ValueError
        Raised for an entry that cannot be used (failed to load, not callable, not of the
        class ``of``, declared under a name that is not valid or looks like another); an
        unknown name is always a ``ValueError``.
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
        self._refused: dict[str, str] = {}  # declared names refused: name -> why
        self._discovered = False
        # Re-entrant: a plugin's import may use the registry that imports it.
        self._lock = threading.RLock()

    # ------------------------------------------------------------------ discovery
    def _discover(self) -> None:
        """Read the group's entry points, if not read yet (call it holding the lock).

        Nothing changes until all are read, so an interruption leaves the registry to
        read them at its next use; the warnings come once the registry is whole.
        """
        if self._discovered:
            return
        # Signals held back: importlib.metadata suppresses any Exception while it lists
        # a path entry, a signal handler's too (the signal soak lost a SIGALRM there).
        with SignalsDeferred():
            found, unreadable = _declared(self.group)
        notes = []
        for dist, note in unreadable:
            if dist not in _UNREADABLE_WARNED:
                notes.append(note)
        _UNREADABLE_WARNED.update(dist for dist, _ in unreadable if dist is not None)
        found.sort(key=lambda declared: _normalised(declared[1]) != self.own_distribution)
        refused: dict[str, str] = {}
        kept = {_look_alike(name): name for name in self._entries}
        first: dict[str, tuple[Any, str]] = {}
        for ep, dist in found:  # this project's own first
            problem = self._name_problem(ep.name)
            other = kept.get(_look_alike(ep.name)) if problem is None else None
            if problem is None and other is not None and other != ep.name:
                problem = f"it {self._looks_like(other)}"
            if problem is not None:
                refused[ep.name] = (f"{self.kind} {_shown(ep.name)} of {_origin(ep, dist)} is "
                                    f"refused: {problem}")
                notes.append(refused[ep.name])
            elif ep.name in first:
                own = _normalised(first[ep.name][1]) == self.own_distribution
                chosen = f"this project's own {self.kind}" if own else "the first"
                notes.append(
                    f"{self.kind} {self.label} {ep.name!r} is declared twice, by "
                    f"{_origin(*first[ep.name])} and by {_origin(ep, dist)}; using {chosen} "
                    f"(give the other {self.kind} {_article(self.label)} {self.label} of its "
                    "own)"
                )
            else:
                first[ep.name] = ep, dist
                kept.setdefault(_look_alike(ep.name), ep.name)
        for name, (ep, dist) in first.items():  # a registration wins
            self._entries.setdefault(name, _Entry(entry_point=ep, distribution=dist))
        self._refused.update(refused)
        self._discovered = True
        for note in notes:
            warnings.warn(note, PluginWarning, stacklevel=4)

    def refresh(self) -> None:
        """Look for newly installed entry points (keeps in-process registrations)."""
        with self._lock:
            entries, refused = dict(self._entries), dict(self._refused)
            self._entries = {k: e for k, e in entries.items() if e.entry_point is None}
            self._refused.clear()
            self._discovered = False
            try:
                self._discover()
            except BaseException:
                if not self._discovered:  # interrupted: as it was, to be refreshed again
                    self._entries, self._refused, self._discovered = entries, refused, True
                raise

    # ------------------------------------------------------------------ registration
    def _name_problem(self, name: object) -> str | None:
        """Why ``name`` is not valid, or ``None``."""
        if self.names_allowed.allows(name):
            return None
        return (f"{_article(self.kind)} {self.kind} {self.label} must be "
                f"{self.names_allowed.describe()}, got {_shown(name)}")

    def _looks_like(self, other: str) -> str:
        return (f"looks like the {self.kind} {other!r} ({self.label}s that differ only in "
                f"case or in '-' against '_' are taken for each other); give it "
                f"{_article(self.label)} {self.label} of its own")

    def register(self, name: str, obj: Any, *, overwrite: bool = False) -> None:
        """Register ``obj`` under ``name`` for this process (tests, notebooks).

        Raises
        ------
        ValueError
            ``name`` is not valid, looks like a registered name (the same but for case or
            ``-`` against ``_``), or is taken and ``overwrite`` is false. Another
            distribution's declaration not used yet neither blocks nor is overwritten: it
            is refused with a :class:`PluginWarning` naming it, and the registration
            takes the name.
        TypeError
            The registry holds callables and ``obj`` is not one.
        """
        problem = self._name_problem(name)
        if problem is not None:
            raise ValueError(problem)
        if self.calls is not None and not callable(obj):
            raise TypeError(f"{self.kind} {name!r} must be {self.calls} (a callable), got "
                            f"{short_repr(obj)}")
        with self._lock:
            other = self.alike(name)
            if other is not None and self._a_plugins(other):  # the registration wins
                self._set_aside(other, f"it looks like {name!r}, registered in this process")
                other = None
            if other is not None:
                raise ValueError(f"{self.kind} {self.label} {name!r} {self._looks_like(other)}")
            if name in self._entries and self._a_plugins(name):
                self._set_aside(name, "this process registers that name itself")
            elif name in self._entries and not overwrite:
                raise ValueError(f"{self.kind} {name!r} is already registered; pass overwrite=True")
            self._entries[name] = _Entry(obj=obj, loaded=True)

    def _a_plugins(self, name: str) -> bool:
        """Whether ``name`` is another distribution's declaration, not used yet: an
        in-process registration (this project's own at import, or a user's) takes its
        name, as a registration made before the plugins were read would have (call it
        holding the lock)."""
        entry = self._entries[name]
        return (entry.entry_point is not None and not entry.loaded
                and _normalised(entry.distribution) != self.own_distribution)

    def _set_aside(self, name: str, why: str) -> None:
        """Refuse another distribution's declaration of ``name`` (:meth:`get` and
        :meth:`broken` say ``why``), with a :class:`PluginWarning` naming it."""
        entry = self._entries.pop(name)
        note = (f"{self.kind} {_shown(name)} of {_origin(entry.entry_point, entry.distribution)} "
                f"is refused: {why}; give it {_article(self.label)} {self.label} of its own")
        self._refused[name] = note
        warnings.warn(note, PluginWarning, stacklevel=4)

    def alike(self, name: str) -> str | None:
        """The registered name, other than ``name``, that ``name`` would be taken for (the
        same but for case, or ``-`` against ``_``), or ``None``."""
        key = _look_alike(name)
        with self._lock:
            self._discover()
            return next((n for n in self._entries if n != name and _look_alike(n) == key),
                        None)

    def refused(self, name: str) -> bool:
        """Whether a plugin declared ``name`` and it was refused (:meth:`get` says why)."""
        with self._lock:
            self._discover()
            return name in self._refused

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
        with self._lock:
            self._entries.pop(name, None)
            self._discovered = False

    @contextmanager
    def isolated(self) -> Iterator[Registry]:
        """A context whose registrations are its own: the registry is put back as it was
        (the installed entries discovered first, so it holds them all) at its end."""
        with self._lock:
            self._discover()
            entries, refused = dict(self._entries), dict(self._refused)
        try:
            yield self
        finally:
            with self._lock:
                self._entries, self._refused, self._discovered = entries, refused, True

    # ------------------------------------------------------------------ lookup
    def names(self) -> list[str]:
        """Every registered name, sorted (imports nothing)."""
        with self._lock:
            self._discover()
            return sorted(self._entries)

    def own_names(self) -> list[str]:
        """The names this project's own distribution declares, sorted: none of a plugin
        installed beside it, nor of an in-process registration (imports nothing)."""
        with self._lock:
            self._discover()
            return sorted(name for name, entry in self._entries.items()
                          if entry.entry_point is not None
                          and _normalised(entry.distribution) == self.own_distribution)

    def __contains__(self, name: object) -> bool:
        with self._lock:
            self._discover()
            return isinstance(name, str) and name in self._entries

    def check(self, field: str, name: object, *, registered: bool = True) -> None:
        """Refuse ``name`` unless it is valid and (if ``registered``) a registered one; the
        message names ``field``."""
        if not self.names_allowed.allows(name):
            raise ValueError(
                f"{field} must be the {self.label} of a registered {self.kind}, "
                f"{self.names_allowed.describe()}, got {_shown(name)}; registered: "
                f"{self.names()}"
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
            load or names something not callable or not of the registry's class, or its
            declared name is not valid or looks like another).
        """
        with self._lock:
            self._discover()
            entry = self._entries.get(name)
            if entry is None:
                if name in self._refused:
                    raise self.error(self._refused[name])
                problem = self._name_problem(name)
                why = "" if problem is None else f" (not a valid {self.kind} {self.label}: {problem})"
                raise ValueError(f"unknown {self.kind} {_shown(name)}{why}; known "
                                 f"{self.kind}s: {sorted(self._entries)}")
            if not entry.loaded:
                self._load(name, entry)
            if entry.failure is not None:
                raise self.error(entry.failure) from entry.cause
            return entry.obj

    def _load(self, name: str, entry: _Entry) -> None:
        """Import ``entry``'s entry point and keep what it gives or why it cannot be used
        (call it holding the lock)."""
        ep = entry.entry_point
        where = f"the entry point of {self.kind} {name!r} ({_value(ep)})"
        declared = f" (distribution {entry.distribution!r}, entry-point group {self.group!r})"
        try:
            # Held back: a handler's exception raised while the import machinery runs a
            # weakref callback (its module locks) is printed and ignored by Python. A
            # second Ctrl-C still stops an import that hangs.
            with SignalsDeferred(second_passes=True):
                obj = ep.load()
        # SystemExit too: a plugin calling sys.exit() at import must not end the host.
        except BaseException as exc:
            if delivered_by_signal(exc):
                raise  # not the plugin's failure: nothing is kept, the next use imports it
            entry.failure, entry.cause = f"{where} failed to load: {short_repr(exc)}{declared}", exc
            entry.loaded = True
            return
        what = f"{_article(type(obj).__name__)} {type(obj).__name__} ({short_repr(obj)})"
        if self.calls is not None and not callable(obj):
            entry.failure = f"{where} is not callable: it names {what}; it must name {self.calls}"
        elif self.of is not None and not isinstance(obj, self.of):
            entry.failure = f"{where} names {what}, not {_article(self.of.__name__)} {self.of.__name__}"
        elif self.of is not None and getattr(obj, "name", None) != name:
            entry.failure = (f"{where} names the {self.kind} {_shown(obj.name)}: "
                             f"{_article(self.kind)} {self.kind}'s entry point must have its name")
        else:
            entry.obj = obj
        if entry.failure is not None:
            entry.failure += declared
        entry.loaded = True

    def entry_point(self, name: str) -> Any:
        """The entry point that declares ``name`` (``None`` for an in-process
        registration)."""
        with self._lock:
            self._discover()
            entry = self._entries.get(name)
            return None if entry is None else entry.entry_point

    def broken(self) -> dict[str, str]:
        """``{name: what is wrong}`` for every declared entry that cannot be used.

        Imports every entry point not imported yet.
        """
        with self._lock:
            self._discover()
            broken = dict(self._refused)
            for name in self.names():
                try:
                    self.get(name)
                except self.error as exc:
                    broken[name] = str(exc)
            return dict(sorted(broken.items()))
