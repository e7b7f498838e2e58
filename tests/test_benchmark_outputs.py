"""The benchmark scripts check where they write before they measure anything."""

from __future__ import annotations

import pytest
from benchmark_scripts import load_benchmark


@pytest.mark.parametrize("name, work", [("interval_coverage", "coverage"),
                                        ("bench_kernels", "run")])
def test_an_output_under_a_file_is_refused_before_any_work(tmp_path, monkeypatch, capsys, name,
                                                          work):
    module = load_benchmark(name)
    monkeypatch.setattr(module, work, lambda *a, **k: pytest.fail("it measured"))
    (tmp_path / "file").write_text("")
    with pytest.raises(SystemExit) as exit_:
        module.main(["--output", str(tmp_path / "file" / "report.md")])
    assert exit_.value.code == 2
    assert "--output" in (err := capsys.readouterr().err) and "is a file, not a folder" in err
