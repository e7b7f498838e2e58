"""One vocabulary for the constraints on settings and saved fields.

In the spirit of scikit-learn's ``_parameter_constraints``: a constraint is declared
once, as an object that says whether a value satisfies it and describes what it allows,
and every place that takes the value (a configuration, the class it configures, a loader
of saved files) checks it with :func:`check`, whose message names the field and the
allowed values::

    >>> check("LearnerConfig.epsilon", 1.5, Real(0.0, 1.0))
    Traceback (most recent call last):
    ...
    ValueError: LearnerConfig.epsilon must be a finite number in [0, 1], got 1.5

Numbers are Python or NumPy numbers, never bools or strings (JSON may carry either by
mistake); reals must be finite. :func:`checked` also gives the value back as the plain
Python value it stands for (a ``float`` for :class:`Real`, an ``int`` for
:class:`Integer`), so that a configuration holding it is JSON-ready.

This module is the one vocabulary of the three packages (``soccer_drill``, ``opponents``,
``ilpss``): it imports nothing from them.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "AnyOf",
    "Bool",
    "Constraint",
    "Integer",
    "ListOf",
    "Name",
    "NoneOr",
    "OneOf",
    "Real",
    "Text",
    "check",
    "check_fields",
    "check_keys",
    "checked",
    "from_json",
    "is_int",
    "is_real",
]


def is_real(value: object) -> bool:
    """A real number (Python, NumPy or another :class:`numbers.Real`), not a bool (``True``
    is an ``int`` to Python, but a slip as a number)."""
    if isinstance(value, bool | np.bool_):
        return False
    # Python and NumPy numbers first: the common case, faster than the ABC's check.
    return isinstance(value, float | int | np.floating | np.integer) or isinstance(
        value, numbers.Real
    )


def is_int(value: object) -> bool:
    """An integer (Python, NumPy or another :class:`numbers.Integral`), not a bool (an
    ``int`` to Python, but a slip as a count, a seed or an action)."""
    if isinstance(value, bool | np.bool_):
        return False
    return isinstance(value, int | np.integer) or isinstance(value, numbers.Integral)


class Constraint:
    """What a value may be: :meth:`allows` and a :meth:`describe` for messages."""

    def allows(self, value: object) -> bool:  # pragma: no cover - interface
        """Whether ``value`` satisfies the constraint."""
        raise NotImplementedError

    def describe(self) -> str:  # pragma: no cover - interface
        """What is allowed, as the end of "``field`` must be ...\"."""
        raise NotImplementedError

    def plain(self, value: Any) -> Any:
        """An allowed ``value`` as the plain Python value it stands for (itself here)."""
        return value


def _bound(x: float) -> str:
    return f"{x:,}" if isinstance(x, int) else f"{x:g}"


@dataclass(frozen=True)
class Real(Constraint):
    """A finite real number in ``[low, high]`` (ends open when asked)."""

    low: float = -math.inf
    high: float = math.inf
    low_open: bool = False
    high_open: bool = False

    def allows(self, value: object) -> bool:
        if not is_real(value):
            return False
        try:
            v = float(value)  # type: ignore[arg-type]
        except OverflowError:  # an integer beyond float, e.g. 10**400
            return False
        if not math.isfinite(v):
            return False
        above = v > self.low if self.low_open else v >= self.low
        below = v < self.high if self.high_open else v <= self.high
        return above and below

    def describe(self) -> str:
        if math.isinf(self.low) and math.isinf(self.high):
            return "a finite number"
        if math.isinf(self.high):
            return f"a finite number {'>' if self.low_open else '>='} {_bound(self.low)}"
        if math.isinf(self.low):
            return f"a finite number {'<' if self.high_open else '<='} {_bound(self.high)}"
        return (f"a finite number in {'(' if self.low_open else '['}{_bound(self.low)}, "
                f"{_bound(self.high)}{')' if self.high_open else ']'}")

    def plain(self, value: Any) -> float:
        """The number as a Python ``float``."""
        return float(value)


@dataclass(frozen=True)
class Integer(Constraint):
    """An integer in ``[low, high]``."""

    low: int = 0
    high: int | None = None

    def allows(self, value: object) -> bool:
        return is_int(value) and self.low <= value and (  # type: ignore[operator]
            self.high is None or value <= self.high  # type: ignore[operator]
        )

    def describe(self) -> str:
        if self.high is None:
            return f"an integer >= {self.low:,}"
        return f"an integer in [{self.low:,}, {self.high:,}]"

    def plain(self, value: Any) -> int:
        """The integer as a Python ``int``."""
        return int(value)


@dataclass(frozen=True)
class Bool(Constraint):
    """``True`` or ``False`` (Python or NumPy)."""

    def allows(self, value: object) -> bool:
        return isinstance(value, bool | np.bool_)

    def describe(self) -> str:
        return "true or false"


@dataclass(frozen=True)
class OneOf(Constraint):
    """One of the given values (compared with ``==``, bools never equal to numbers)."""

    values: tuple[Any, ...]

    def allows(self, value: object) -> bool:
        return any(
            value == v and isinstance(value, bool) == isinstance(v, bool)
            for v in self.values
        )

    def describe(self) -> str:
        shown = [repr(v) for v in self.values]
        if len(shown) == 1:
            return shown[0]
        listed = ", ".join(shown[:-1]) + f" or {shown[-1]}"
        return listed if len(shown) == 2 else f"one of {listed}"


@dataclass(frozen=True)
class Text(Constraint):
    """A string that is not blank; with ``one_line``, without a line break (a title that
    must not forge a line of the page it heads); at most ``max_len`` characters."""

    one_line: bool = False
    max_len: int | None = None

    def allows(self, value: object) -> bool:
        return (isinstance(value, str) and bool(value.strip())
                and not (self.one_line and any(c in value for c in "\r\n\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029"))
                and (self.max_len is None or len(value) <= self.max_len))

    def describe(self) -> str:
        line = " on one line" if self.one_line else ""
        most = f" of at most {self.max_len:,} characters" if self.max_len is not None else ""
        return f"a non-empty string{line}{most}"


NAME_LENGTH = 64
"""The longest name (of a team, a method, a protocol...): room for a descriptive one, and a
bound on every message that shows a name."""
_NAME_PART = "[A-Za-z_-][A-Za-z0-9_-]*"


@dataclass(frozen=True)
class Name(Constraint):
    """A name: at most :data:`NAME_LENGTH` ASCII letters, digits, ``_``, ``-`` and (if
    ``dots``) ``.``, each part between dots not starting with a digit.

    ASCII only: names are compared character by character, and letters of other scripts
    that look like ASCII ones (a Cyrillic "а" in "chаsers") would make two names that read
    the same.
    """

    dots: bool = True

    def allows(self, value: object) -> bool:
        if not isinstance(value, str) or len(value) > NAME_LENGTH:
            return False
        pattern = rf"{_NAME_PART}(\.{_NAME_PART})*" if self.dots else _NAME_PART
        return re.fullmatch(pattern, value) is not None

    def describe(self) -> str:
        if self.dots:
            return (f"a name of 1 to {NAME_LENGTH} ASCII characters (letters, digits, '_', "
                    "'-' or '.', each part between dots not starting with a digit)")
        return (f"a non-empty identifier of at most {NAME_LENGTH} ASCII characters (letters, "
                "digits, '_' or '-', not starting with a digit)")


@dataclass(frozen=True)
class NoneOr(Constraint):
    """``None`` or a value allowed by ``inner``."""

    inner: Constraint

    def allows(self, value: object) -> bool:
        return value is None or self.inner.allows(value)

    def describe(self) -> str:
        return f"None or {self.inner.describe()}"

    def plain(self, value: Any) -> Any:
        """``None``, or the value as ``inner`` gives it."""
        return None if value is None else self.inner.plain(value)


@dataclass(frozen=True)
class AnyOf(Constraint):
    """A value allowed by at least one of ``options``."""

    options: tuple[Constraint, ...]

    def allows(self, value: object) -> bool:
        return any(c.allows(value) for c in self.options)

    def describe(self) -> str:
        return " or ".join(c.describe() for c in self.options)


@dataclass(frozen=True)
class ListOf(Constraint):
    """A list or tuple of values allowed by ``item``, of a length in ``[min_len, max_len]``,
    without repeats if ``unique``."""

    item: Constraint
    min_len: int = 0
    max_len: int | None = None
    unique: bool = False
    kinds: tuple[type, ...] = (list, tuple)

    def allows(self, value: object) -> bool:
        if not isinstance(value, self.kinds):
            return False
        seq = list(value)  # type: ignore[call-overload]
        if len(seq) < self.min_len or (self.max_len is not None and len(seq) > self.max_len):
            return False
        if self.unique and len(set(map(repr, seq))) != len(seq):
            return False
        return all(self.item.allows(v) for v in seq)

    def describe(self) -> str:
        kind = "tuple" if self.kinds == (tuple,) else "list"
        unique = "distinct " if self.unique else ""
        if self.max_len is not None and self.max_len == self.min_len:
            size = f"of {self.min_len:,} {unique}values"
        elif self.max_len is not None:
            size = f"of {self.min_len:,} to {self.max_len:,} {unique}values"
        elif self.min_len:
            size = f"of at least {self.min_len:,} {unique}values"
        else:
            size = f"of {unique}values"
        return f"a {kind} {size}, each {self.item.describe()}"


def check(field: str, value: object, constraint: Constraint, why: str | None = None) -> None:
    """Raise ``ValueError("<field> must be <what is allowed>, got <value>")`` unless
    ``constraint`` allows ``value``; ``why``, if given, ends the message in parentheses
    (why the value is limited so)."""
    if not constraint.allows(value):
        reason = "" if why is None else f" ({why})"
        raise ValueError(f"{field} must be {constraint.describe()}, got {_shown(value)}{reason}")


def checked(field: str, value: object, constraint: Constraint, why: str | None = None) -> Any:
    """:func:`check` ``value``, and give it back as the plain Python value it stands for
    (:meth:`Constraint.plain`: a NumPy number as a ``float`` or an ``int``)."""
    check(field, value, constraint, why)
    return constraint.plain(value)


def check_fields(
    owner: str,
    values: Mapping[str, Any] | object,
    constraints: Mapping[str, Constraint],
    get: Callable[[Any, str], Any] = getattr,
) -> None:
    """:func:`check` every ``constraints`` entry on ``values`` (an object, or a mapping
    with ``get=dict.get``), naming fields ``<owner>.<name>``."""
    for name, constraint in constraints.items():
        check(f"{owner}.{name}" if owner else name, get(values, name), constraint)


def check_keys(where: str, record: Mapping[str, Any], allowed: Iterable[str],
               required: Iterable[str] | None = None) -> None:
    """Refuse unknown keys, and missing ones among ``required`` (default: all allowed)."""
    allowed = set(allowed)
    unknown = sorted(set(record) - allowed, key=str)
    if unknown:
        raise ValueError(f"{where}: unknown field(s) {unknown}; allowed: {sorted(allowed)}")
    missing = sorted(set(allowed if required is None else required) - set(record))
    if missing:
        raise ValueError(f"{where}: missing field(s) {missing}")


def from_json(
    cls: type[Any],
    values: object,
    *,
    nested: Mapping[str, type[Any]] | None = None,
    tuples: Iterable[str] = (),
) -> Any:
    """A frozen configuration dataclass from a JSON object.

    Unknown keys are refused by name; a ``nested`` field given as an object is built with
    that class's ``from_dict``; a ``tuples`` field given as a list becomes a tuple. The
    dataclass itself checks the values.
    """
    name = cls.__name__
    if not isinstance(values, Mapping):
        raise ValueError(
            f"a {name} must be a JSON object of its fields, got {type(values).__name__}"
        )
    values = dict(values)
    known = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(values) - known, key=str)
    if unknown:
        raise ValueError(f"unknown {name} field(s) {unknown}; allowed: {sorted(known)}")
    for key, sub in (nested or {}).items():
        if key in values and not isinstance(values[key], sub):
            if not isinstance(values[key], Mapping):
                raise ValueError(
                    f"{name}.{key} must be a JSON object of {sub.__name__} fields, "
                    f"got {type(values[key]).__name__}"
                )
            try:
                values[key] = sub.from_dict(values[key])
            except ValueError as exc:
                raise ValueError(f"{name}.{key}: {exc}") from exc
    for key in tuples:
        if isinstance(values.get(key), list):
            values[key] = tuple(values[key])
    return cls(**values)


def _shown(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 200 else text[:200] + "..."
