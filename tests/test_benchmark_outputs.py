"""The benchmark scripts check where they write before they measure anything."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def _load(name: str):
    spec = importlib.util.spec_from_file_location(f"_bench_{name}", BENCHMARKS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up by name
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("name, work", [("interval_coverage", "coverage"),
                                        ("bench_kernels", "run")])
def test_an_output_under_a_file_is_refused_before_any_work(tmp_path, monkeypatch, capsys, name,
                                                          work):
    module = _load(name)
    monkeypatch.setattr(module, work, lambda *a, **k: pytest.fail("it measured"))
    (tmp_path / "file").write_text("")
    with pytest.raises(SystemExit) as exit_:
        module.main(["--output", str(tmp_path / "file" / "report.md")])
    assert exit_.value.code == 2
    assert "--output" in (err := capsys.readouterr().err) and "is a file, not a folder" in err
