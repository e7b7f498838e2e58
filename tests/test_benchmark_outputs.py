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


def test_what_the_profiles_wrap_and_the_learners_they_make_exist():
    # before, profile_vector.py wrapped a method that had moved (BatchCore.support_commands)
    # and bench_learner_library.py made its learner with arguments SmdpLearner no longer
    # takes: both failed at once, as documented in docs/benchmarks.md
    profile = load_benchmark("profile_vector")
    missing = [label for label, owner, name in profile.COMPONENTS if not hasattr(owner, name)]
    assert not missing
    library = load_benchmark("bench_learner_library")
    from soccer_drill import HolderEnv

    coder = library.keepaway_coder(HolderEnv().observation_space)
    assert library.make_learner(None, coder, 0).n_primitive == library.N_PRIMITIVE
