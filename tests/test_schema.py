"""Declared archive schemas (ilpss._schema): a new kind of archive in a few lines, and
every kind of violation refused with a message that names the file and the field."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ilpss._io import load_archive, save_npz_atomic
from ilpss._schema import FLOAT, INTEGER, ArchiveSchema, Field, RowsSumToOne, Symmetric
from soccer_drill.constraints import Integer, Real

# A new kind of archive: its arrays, their dimensions and bounds, and its record.
CLUSTERS = ArchiveSchema(
    "test.clusters/1",
    {
        "centres": Field(("n_clusters", "n_features"), FLOAT, each=Real()),
        "spreads": Field(("n_clusters", "n_features", "n_features"), FLOAT,
                         whole=(Symmetric(1e-12),)),
        "shares": Field(("n_clusters",), FLOAT, each=Real(0.0, 1.0), whole=(RowsSumToOne(1e-9),)),
        "counts": Field(("n_clusters",), INTEGER, each=Integer(0)),
        "labels": Field((None,), INTEGER, required=False),
    },
    record={"fit.n_clusters": Integer(1, 100), "fit.tol": Real(0.0)},
    dims={"n_features": Integer(1, 64)},
    sizes={"fit.n_clusters": "n_clusters"},
)
WHERE = "clusters.npz"


def _arrays(**changes: np.ndarray) -> dict[str, np.ndarray]:
    arrays = {"centres": np.zeros((3, 2)), "spreads": np.tile(np.eye(2), (3, 1, 1)),
              "shares": np.full(3, 1 / 3), "counts": np.array([4, 0, 2])}
    arrays.update(changes)
    return arrays


def _meta(**fit: object) -> dict:
    return {"schema": CLUSTERS.name, "fit": {"n_clusters": 3, "tol": 1e-3, **fit}}


def test_a_new_archive_kind_round_trips_with_its_dimensions(tmp_path: Path) -> None:
    path = tmp_path / WHERE
    save_npz_atomic(path, _arrays(labels=np.array([0, 2, 2])), _meta())
    checked = load_archive(path, CLUSTERS)
    assert checked.dims == {"n_clusters": 3, "n_features": 2}
    assert checked.meta == _meta()
    np.testing.assert_array_equal(checked.arrays["counts"], [4, 0, 2])
    assert sorted(checked.arrays) == ["centres", "counts", "labels", "shares", "spreads"]
    # A dimension the loader already knows is held to.
    with pytest.raises(ValueError, match=r"array 'centres' axis 1 has length 2, but "
                                         r"n_features = 5 as the loader requires"):
        load_archive(path, CLUSTERS, dims={"n_features": 5})


@pytest.mark.parametrize(
    ("arrays", "meta", "match"),
    [
        # wrong dtype
        (_arrays(counts=np.zeros(3)), _meta(),
         r"array 'counts' has dtype float64 \(kind 'f'\), expected kind 'iu' \(signed "
         r"integer or unsigned integer\)"),
        # wrong shape
        (_arrays(shares=np.full((3, 1), 1 / 3)), _meta(),
         r"array 'shares' has shape \(3, 1\), expected \(n_clusters\)"),
        # disagreeing dimensions
        (_arrays(counts=np.array([1, 2])), _meta(),
         r"array 'counts' axis 0 has length 2, but n_clusters = 3 from array 'centres'"),
        (_arrays(), _meta(n_clusters=4),
         r"field fit.n_clusters is 4, but n_clusters = 3 from array 'centres'"),
        # out of bounds: a value, an array as a whole, a dimension, a record field
        (_arrays(counts=np.array([4, -1, 2])), _meta(),
         r"array 'counts' holds the value -1 at index \(1,\); each value must be an "
         r"integer >= 0"),
        # an integer that int64 (what every saver writes) cannot hold: it would wrap around
        (_arrays(counts=np.array([4, 2**64 - 1, 2], dtype=np.uint64)), _meta(),
         r"array 'counts' holds the value 18446744073709551615 at index \(1,\), outside the "
         r"int64 range every saved integer lies in \(an integer in "
         r"\[-9,223,372,036,854,775,808, 9,223,372,036,854,775,807\]\): read as int64 it "
         r"would wrap around"),
        (_arrays(centres=np.array([[0.0, 0.0], [np.inf, 0.0], [0.0, 0.0]])), _meta(),
         r"array 'centres' holds a non-finite value inf at index \(1, 0\); each value must "
         r"be a finite number"),
        (_arrays(shares=np.array([0.5, 0.5, 0.5])), _meta(),
         r"array 'shares' must be probabilities: rows summing to 1"),
        (_arrays(spreads=np.tile([[1.0, 0.5], [0.0, 1.0]], (3, 1, 1))), _meta(),
         r"array 'spreads' must be symmetric matrices"),
        (_arrays(centres=np.zeros((3, 65)), spreads=np.tile(np.eye(65), (3, 1, 1))), _meta(),
         r"dimension n_features \(array 'centres'\) must be an integer in \[1, 64\], got 65"),
        (_arrays(), _meta(tol=-1.0),
         r"field fit.tol must be a finite number >= 0, got -1.0"),
        # missing fields: an array, a record field
        ({k: v for k, v in _arrays().items() if k != "shares"}, _meta(),
         r"missing array 'shares'"),
        (_arrays(), {"schema": CLUSTERS.name, "fit": {"n_clusters": 3}},
         r"missing field fit.tol"),
        # an unknown field
        (_arrays(weights=np.zeros(3)), _meta(),
         r"unexpected array\(s\) \['weights'\]; this schema holds \['centres', 'counts', "
         r"'labels', 'shares', 'spreads'\]"),
    ],
)
def test_each_kind_of_violation_is_refused_naming_the_file_and_field(
    tmp_path: Path, arrays, meta, match: str
) -> None:
    # In memory ...
    with pytest.raises(ValueError, match=match) as err:
        CLUSTERS.validate(arrays, meta, WHERE)
    assert str(err.value).startswith(f"{WHERE}: ")
    # ... and from a file, with a valid digest: only the schema can refuse it.
    path = tmp_path / WHERE
    save_npz_atomic(path, arrays, meta)
    with pytest.raises(ValueError, match=match) as err:
        load_archive(path, CLUSTERS)
    assert str(err.value).startswith(f"{path}: ")


def test_a_layout_fault_is_refused_from_the_headers_before_any_array_is_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / WHERE
    save_npz_atomic(path, _arrays(counts=np.array([1, 2])), _meta())

    def refuse(*args, **kwargs):
        raise AssertionError("an array was read")

    real = np.lib.format.read_array
    monkeypatch.setattr(np.lib.format, "read_array",
                        lambda fp, **kw: real(fp, **kw) if fp.name == "__meta__.npy"
                        else refuse())
    with pytest.raises(ValueError, match="axis 0 has length 2, but n_clusters = 3"):
        load_archive(path, CLUSTERS)


def test_sizes_must_name_declared_record_fields() -> None:
    with pytest.raises(ValueError, match=r"sizes names record fields \['fit.k'\]"):
        ArchiveSchema("x/1", {}, sizes={"fit.k": "k"})
