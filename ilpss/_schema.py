"""Declared schemas of saved archives: which arrays an archive holds, their dtypes, shapes
and bounds, and the fields of its JSON record.

Every ``.npz`` archive ``ilpss`` saves (:func:`ilpss._io.save_npz_atomic`) is read back
through an :class:`ArchiveSchema` declared beside the class that writes it, so that the
checking of kinds, shapes, counts and bounds is written once, here, with messages that
name the file, the field and what it allows::

    KERNELS = ArchiveSchema("ilpss.kernels/1", {
        "weights": Field(("n_instances", "n_kernels"), FLOAT, each=Real(0.0),
                         whole=(RowsSumToOne(1e-9),)),
        "means": Field(("n_kernels", "n_features"), FLOAT, each=Real()),
    }, record={"fit.n_iter": Integer(0)})

A shape is a tuple with one entry per axis: an ``int`` (that exact length), a ``str`` (a
named dimension, which must have the same length wherever it appears, in any array, in a
record field declared to give it, or as given by the loader), or ``None`` (any length).
Dtypes are given as :attr:`numpy.dtype.kind` codes (:data:`FLOAT`, :data:`INTEGER`,
:data:`BOOL`, :data:`TEXT`). Bounds are constraints of the project's vocabulary: ``each``
applies to every value of an array, ``whole`` to the array itself (:class:`RowsSumToOne`,
:class:`Symmetric`), ``dims`` to the length of a named dimension, ``record`` to a field of
the JSON record (a dotted path such as ``"hyperparameters.tol"``).

:meth:`ArchiveSchema.check_layout` checks what the ``.npy`` headers say (names, kinds,
shapes), so that :func:`ilpss._io.load_archive` refuses a wrong archive before it reads
an array; :meth:`ArchiveSchema.validate` checks everything on the arrays and the record
read, and returns them with the resolved dimensions.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

# The constraint vocabulary, imported here only.
from soccer_drill.constraints import Constraint, Integer, Real, check

__all__ = [
    "BOOL",
    "FLOAT",
    "INTEGER",
    "TEXT",
    "ArchiveSchema",
    "Checked",
    "Field",
    "MappingOf",
    "RowsSumToOne",
    "Symmetric",
]

#: Accepted :attr:`numpy.dtype.kind` codes of the usual kinds of arrays.
FLOAT, INTEGER, BOOL, TEXT = "f", "iu", "b", "U"

_KIND_NAMES = {"f": "float", "i": "signed integer", "u": "unsigned integer", "b": "bool",
               "U": "string"}

SAVED_INTEGERS = Integer(-(2**63), 2**63 - 1)
"""The range of every integer an archive holds (int64, as every ``ilpss`` saver writes
them): an array of another integer dtype is refused beyond it, since read as int64 its
values would wrap around (a uint64 ``2**64 - 1`` would be ``-1``) or fail to be saved
again. Record fields that become array values are declared within it too."""

Shape = tuple[int | str | None, ...]
#: ``{array name: (shape, dtype)}``, as read from the ``.npy`` headers or the arrays.
Headers = Mapping[str, tuple[tuple[int, ...], np.dtype]]


@dataclass(frozen=True)
class Field:
    """One array of an archive.

    Parameters
    ----------
    shape : tuple of int, str or None
        One entry per axis: an exact length, a named dimension or ``None`` (any length).
    kinds : str
        The accepted dtype kinds (:data:`FLOAT`, :data:`INTEGER`, ...).
    each : Constraint, optional
        What every value must satisfy (e.g. ``Real()``: finite; ``Integer(0)``: >= 0).
    whole : tuple of Constraint
        What the array as a whole must satisfy (e.g. :class:`RowsSumToOne`).
    required : bool, default True
        Whether the archive must hold it (else it may).
    """

    shape: Shape
    kinds: str
    each: Constraint | None = None
    whole: tuple[Constraint, ...] = ()
    required: bool = True

    def shown_shape(self) -> str:
        """The shape as messages show it, e.g. ``(K, d)`` or ``(*, 2)``."""
        return "(" + ", ".join("*" if t is None else str(t) for t in self.shape) + ")"


@dataclass(frozen=True)
class RowsSumToOne(Constraint):
    """An array whose rows (last axis) each sum to 1, within ``atol``."""

    atol: float

    def allows(self, value: object) -> bool:
        a = np.asarray(value, dtype=np.float64)
        return bool(np.allclose(a.sum(axis=-1), 1.0, rtol=0.0, atol=self.atol))

    def describe(self) -> str:
        return f"probabilities: rows summing to 1 (within {self.atol:g})"


@dataclass(frozen=True)
class Symmetric(Constraint):
    """An array of square matrices (last two axes) equal to their transposes, within
    ``rtol``."""

    rtol: float

    def allows(self, value: object) -> bool:
        a = np.asarray(value, dtype=np.float64)
        return bool(np.allclose(a, np.swapaxes(a, -1, -2), rtol=self.rtol, atol=0.0))

    def describe(self) -> str:
        return f"symmetric matrices (within a relative {self.rtol:g})"


@dataclass(frozen=True)
class MappingOf(Constraint):
    """A JSON object (a mapping) whose keys ``keys`` allows and values ``values``."""

    keys: Constraint
    values: Constraint

    def allows(self, value: object) -> bool:
        return isinstance(value, Mapping) and all(
            self.keys.allows(k) and self.values.allows(v) for k, v in value.items())

    def describe(self) -> str:
        return (f"an object whose keys are each {self.keys.describe()} and values each "
                f"{self.values.describe()}")


@dataclass(frozen=True)
class Checked:
    """An archive's contents after :meth:`ArchiveSchema.validate`.

    Attributes
    ----------
    arrays : dict of str to numpy.ndarray
        Every array of the archive.
    meta : dict
        The JSON record.
    dims : dict of str to int
        The length of every named dimension.
    """

    arrays: dict[str, np.ndarray]
    meta: dict[str, Any]
    dims: dict[str, int]


class _Dims:
    """Named dimensions as they are resolved, each with where its length came from."""

    def __init__(self, where: str, given: Mapping[str, int] | None) -> None:
        self.where = where
        self.bound: dict[str, tuple[int, str]] = {
            name: (int(size), "as the loader requires") for name, size in (given or {}).items()
        }

    def bind(self, dim: str, size: int, source: str, mismatch: str) -> None:
        """Bind ``dim`` to ``size`` (from ``source``), or refuse a disagreeing length;
        ``mismatch`` says what had the length."""
        if dim in self.bound and self.bound[dim][0] != size:
            other_size, other = self.bound[dim]
            raise ValueError(f"{self.where}: {mismatch} {size}, but {dim} = {other_size} {other}")
        self.bound.setdefault(dim, (size, source))

    def sizes(self) -> dict[str, int]:
        return {name: size for name, (size, _) in self.bound.items()}


@dataclass(frozen=True)
class ArchiveSchema:
    """The declared contents of one kind of archive.

    Parameters
    ----------
    name : str
        The schema the record names, with its version (e.g. ``"ilpss.kernels/1"``).
    fields : mapping of str to Field
        The arrays; no other array is allowed.
    record : mapping of str to Constraint
        Fields of the JSON record, by dotted path, each required (the record may hold
        others, which its loader reads itself).
    dims : mapping of str to Constraint
        What the length of a named dimension allows (e.g. ``Integer(1)``: not empty).
    sizes : mapping of str to str
        Record fields (dotted paths, also in ``record``) that give the length of a
        named dimension, e.g. ``{"hyperparameters.n_components": "n_kernels"}``.
    """

    name: str
    fields: Mapping[str, Field]
    record: Mapping[str, Constraint] = field(default_factory=dict)
    dims: Mapping[str, Constraint] = field(default_factory=dict)
    sizes: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        undeclared = sorted(set(self.sizes) - set(self.record))
        if undeclared:
            raise ValueError(f"schema {self.name!r}: sizes names record fields {undeclared} "
                             "that record does not declare")

    @classmethod
    def from_templates(
        cls,
        name: str,
        required: Mapping[str, tuple[Shape, str]],
        optional: Mapping[str, tuple[Shape, str]] | None = None,
    ) -> ArchiveSchema:
        """A schema of arrays given as ``{name: (shape, kinds)}``, without bounds."""
        fields = {k: Field(shape, kinds) for k, (shape, kinds) in required.items()}
        for k, (shape, kinds) in (optional or {}).items():
            fields[k] = Field(shape, kinds, required=False)
        return cls(name, fields)

    # ------------------------------------------------------------------ layout
    def check_layout(
        self, headers: Headers, where: str, dims: Mapping[str, int] | None = None
    ) -> dict[str, int]:
        """Check the names, dtype kinds and shapes of an archive's arrays (from their
        headers: nothing needs to be read) and return the named dimensions' lengths.

        Parameters
        ----------
        headers : mapping of str to (shape, dtype)
            Every array of the archive.
        where : str
            The file, named by every message.
        dims : mapping of str to int, optional
            Lengths of named dimensions that the loader already knows.

        Raises
        ------
        ValueError
            A missing or unexpected array, another dtype kind, another shape, a named
            dimension of disagreeing lengths or of a length its constraint refuses.
        """
        return self._layout(headers, _Dims(where, dims)).sizes()

    def _layout(self, headers: Headers, dims: _Dims) -> _Dims:
        where = dims.where
        missing = sorted(k for k, f in self.fields.items() if f.required and k not in headers)
        if missing:
            raise ValueError(f"{where}: missing array {missing[0]!r}")
        unexpected = sorted(set(headers) - set(self.fields))
        if unexpected:
            raise ValueError(f"{where}: unexpected array(s) {unexpected}; this schema holds "
                             f"{sorted(self.fields)}")
        for name, spec in self.fields.items():
            if name in headers:
                self._check_header(name, spec, *headers[name], dims)
        for dim, constraint in self.dims.items():
            if dim in dims.bound:
                size, source = dims.bound[dim]
                check(f"{where}: dimension {dim} ({source.removeprefix('from ')})", size,
                      constraint)
        return dims

    @staticmethod
    def _check_header(name: str, spec: Field, shape: tuple[int, ...], dtype: np.dtype,
                      dims: _Dims) -> None:
        where = dims.where
        if dtype.kind not in spec.kinds:
            allowed = " or ".join(_KIND_NAMES.get(k, k) for k in spec.kinds)
            raise ValueError(f"{where}: array {name!r} has dtype {dtype} (kind {dtype.kind!r}), "
                             f"expected kind {spec.kinds!r} ({allowed})")
        wrong = f"{where}: array {name!r} has shape {shape}, expected {spec.shown_shape()}"
        if len(shape) != len(spec.shape):
            raise ValueError(wrong)
        for axis, (size, want) in enumerate(zip(shape, spec.shape, strict=True)):
            if isinstance(want, int) and size != want:
                raise ValueError(wrong)
            if isinstance(want, str):
                dims.bind(want, size, f"from array {name!r}",
                          f"array {name!r} axis {axis} has length")

    # ------------------------------------------------------------------ contents
    def validate(
        self,
        arrays: Mapping[str, np.ndarray],
        meta: Mapping[str, Any],
        where: str,
        dims: Mapping[str, int] | None = None,
    ) -> Checked:
        """Check an archive's arrays and record against the schema.

        Parameters
        ----------
        arrays : mapping of str to numpy.ndarray
            Every array of the archive.
        meta : mapping
            Its JSON record.
        where : str
            The file, named by every message.
        dims : mapping of str to int, optional
            Lengths of named dimensions that the loader already knows.

        Returns
        -------
        Checked
            The arrays, the record and the length of every named dimension.

        Raises
        ------
        ValueError
            Naming the file and the array or field: everything :meth:`check_layout`
            refuses, a record field missing or refused by its constraint or disagreeing
            with a dimension, a value refused by ``each``, an array refused by ``whole``.
        """
        resolved = self._layout({k: (a.shape, a.dtype) for k, a in arrays.items()},
                                _Dims(where, dims))
        for path, constraint in self.record.items():
            value = _record_value(meta, path, where)
            check(f"{where}: field {path}", value, constraint)
            if path in self.sizes:
                resolved.bind(self.sizes[path], value, f"from field {path}",
                              f"field {path} is")
        for name, spec in self.fields.items():
            if name in arrays:
                _check_values(name, spec, arrays[name], where)
        return Checked(dict(arrays), dict(meta), resolved.sizes())


def _record_value(meta: Mapping[str, Any], path: str, where: str) -> Any:
    """The value at the dotted ``path`` of the record."""
    value: Any = meta
    for key in path.split("."):
        if not isinstance(value, Mapping) or key not in value:
            raise ValueError(f"{where}: missing field {path}")
        value = value[key]
    return value


def _check_values(name: str, spec: Field, array: np.ndarray, where: str) -> None:
    """Refuse the first integer of ``array`` outside :data:`SAVED_INTEGERS`, then the
    first value that ``spec.each`` refuses, then the array if one of ``spec.whole``
    refuses it."""
    if array.dtype.kind == "u" and array.size and array.max() > SAVED_INTEGERS.high:
        index = tuple(int(i) for i in np.argwhere(array > SAVED_INTEGERS.high)[0])
        raise ValueError(
            f"{where}: array {name!r} holds the value {array[index].item()} at index {index}, "
            f"outside the int64 range every saved integer lies in "
            f"({SAVED_INTEGERS.describe()}): read as int64 it would wrap around"
        )
    if spec.each is not None and array.size:
        bad = ~_allowed_each(spec.each, array)
        if bad.any():
            index = tuple(int(i) for i in np.argwhere(bad)[0])
            value = array[index].item()
            what = "a non-finite value" if _non_finite(value) else "the value"
            raise ValueError(f"{where}: array {name!r} holds {what} {value!r} at index "
                             f"{index}; each value must be {spec.each.describe()}")
    for rule in spec.whole:
        if not rule.allows(array):
            raise ValueError(f"{where}: array {name!r} must be {rule.describe()}")


def _non_finite(value: object) -> bool:
    return isinstance(value, float | np.floating) and not math.isfinite(value)


def _allowed_each(constraint: Constraint, array: np.ndarray) -> np.ndarray:
    """Whether ``constraint`` allows each value of ``array``: vectorised for the bounds of
    numbers (policies hold millions of weights), value by value for anything else."""
    if isinstance(constraint, Real) and array.dtype.kind in "fiu":
        a = array.astype(np.float64, copy=False)
        above = a > constraint.low if constraint.low_open else a >= constraint.low
        below = a < constraint.high if constraint.high_open else a <= constraint.high
        return np.isfinite(a) & above & below
    if isinstance(constraint, Integer) and array.dtype.kind in "iu":
        ok = array >= constraint.low
        return ok if constraint.high is None else ok & (array <= constraint.high)
    return np.vectorize(constraint.allows, otypes=[bool])(array)
