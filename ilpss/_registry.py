"""Named objects of one kind, from an entry-point group and in-process registrations.

Every name a saved file may carry (a sampler, a method, a protocol, a way of reusing
past policies) is looked up in a :class:`Registry` of things installed code declared,
never imported from the file's text (see :mod:`ilpss.experiments.registry`).
"""

from __future__ import annotations

from importlib.metadata import entry_points
from typing import Any

__all__ = ["Registry"]


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
    of : type, optional
        The class of the objects that :meth:`add` registers under their ``name``.
    """

    def __init__(self, group: str, kind: str, of: type | None = None) -> None:
        self.group = group
        self.kind = kind
        self.of = of
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

    def add(self, obj: Any, *, overwrite: bool = False) -> None:
        """Register ``obj``, an instance of :attr:`of`, under its ``name``."""
        if self.of is None:
            raise TypeError(f"a {self.kind} is registered with register(name, obj)")
        if not isinstance(obj, self.of):
            raise TypeError(f"a {self.kind} must be a {self.of.__name__}, got "
                            f"{type(obj).__name__}")
        self.register(obj.name, obj, overwrite=overwrite)

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
