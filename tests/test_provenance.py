"""Results record the code that made them, and results of different code are not mixed.

The code is read from copies of the three packages (the digest's ``_package_dirs`` seam),
so that a test can change a drill source file between a run and its resume, as a
developer would between two commands, without touching the installed packages.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from ilpss._io import json_record_bytes, load_json_record
from ilpss.experiments import provenance
from ilpss.experiments.config import ExperimentConfig
from ilpss.experiments.provenance import MixedCodeError, code_record, source_digest


@pytest.fixture
def code_copy(tmp_path, monkeypatch):
    """Copies of the three packages that stand for the installed code; the returned
    function changes a file of the copy (the code is read anew after each change)."""
    dirs = []
    for original in provenance._package_dirs():
        copy = tmp_path / "code" / original.name
        shutil.copytree(original, copy, ignore=shutil.ignore_patterns("__pycache__"))
        dirs.append(copy)
    monkeypatch.setattr(provenance, "_package_dirs", lambda: dirs)
    code_record.cache_clear()

    def change(relative: str, text: str = "\n# changed\n") -> None:
        path = tmp_path / "code" / relative
        path.write_text(path.read_text() + text)
        code_record.cache_clear()

    yield change
    code_record.cache_clear()


def _tiny() -> ExperimentConfig:
    return ExperimentConfig(n_seeds=2, workers=1, methods=("scratch",)).with_overrides(
        lifelong={"train_episodes": 3, "rollout_episodes": 1})


def test_the_digest_changes_with_any_source_file_added_changed_or_removed(tmp_path):
    root = tmp_path / "pkg"
    (root / "sub").mkdir(parents=True)
    (root / "a.py").write_text("x = 1\n")
    (root / "sub" / "b.py").write_text("y = 2\n")
    (root / "__pycache__").mkdir()
    first = source_digest([root])
    (root / "__pycache__" / "a.cpython-311.pyc").write_bytes(b"compiled")
    assert source_digest([root]) == first  # compiled caches are not the code
    (root / "a.py").write_text("x = 2\n")
    changed = source_digest([root])
    (root / "c.py").write_text("")
    added = source_digest([root])
    (root / "c.py").unlink()
    (root / "a.py").write_text("x = 1\n")
    assert len({first, changed, added}) == 3 and source_digest([root]) == first


def test_a_run_and_each_result_record_the_code(tmp_path, code_copy):
    from ilpss.experiments.run import run_experiment

    run_experiment(_tiny(), tmp_path / "run", progress=False)
    config = json.loads((tmp_path / "run" / "config.json").read_text())
    result = load_json_record(tmp_path / "run" / "seed_000" / "stream_00" / "result.json",
                              "ilpss.experiment_result/3")
    assert config["code"] == result["code"] == code_record()
    assert set(code_record()) == {"version", "source_digest", "git_commit"}
    assert len(code_record()["source_digest"]) == 64


def test_a_resume_after_a_drill_source_file_changed_is_refused_naming_both(tmp_path,
                                                                          code_copy):
    from ilpss.experiments.run import run_experiment

    cfg = _tiny()
    out = tmp_path / "run"
    run_experiment(cfg.with_overrides(n_seeds=1), out, progress=False)  # seed 0 only
    old = code_record()["source_digest"][:12]
    # A resume that would add seed 1 is of another configuration: grow the run in place
    # by resuming the same configuration after deleting its result, as an interrupted
    # run would leave it.
    shutil.rmtree(out / "seed_000" / "stream_00")
    code_copy("soccer_drill/skills.py")
    new = code_record()["source_digest"][:12]
    with pytest.raises(MixedCodeError) as refused:
        run_experiment(cfg.with_overrides(n_seeds=1), out, progress=False)
    assert f"sources {old}" in str(refused.value) and f"sources {new}" in str(refused.value)
    assert "--allow-mixed-code" in str(refused.value)
    assert not (out / "seed_000" / "stream_00" / "result.json").exists()  # nothing ran


def test_mixing_knowingly_is_allowed_and_the_report_says_so(tmp_path, code_copy):
    from ilpss.experiments.report import write_report
    from ilpss.experiments.run import run_experiment

    cfg = _tiny()
    out = tmp_path / "run"
    run_experiment(cfg, out, progress=False)
    shutil.rmtree(out / "seed_001")  # seed 1 is run again by the new code
    code_copy("opponents/paper.py")
    results = run_experiment(cfg, out, progress=False, allow_mixed_code=True)
    assert results[0]["code"] != results[1]["code"]
    page = write_report(cfg, results, out).read_text()
    assert "**Mixed code** (allowed by --allow-mixed-code)" in page
    assert page.count("sources ") >= 2


def test_a_result_of_other_code_inside_a_run_folder_is_refused(tmp_path, code_copy):
    """A result file whose code differs from the run's (put there by hand, or by a node
    of a cluster running other code) is refused when the run resumes."""
    from ilpss.experiments.run import run_experiment

    out = tmp_path / "run"
    run_experiment(_tiny(), out, progress=False)
    path = out / "seed_001" / "stream_00" / "result.json"
    record = load_json_record(path, "ilpss.experiment_result/3")
    record["code"] = {**record["code"], "source_digest": "0" * 64}
    path.write_bytes(json_record_bytes(record))
    with pytest.raises(MixedCodeError, match=f"{path} was made by .*sources 000000000000"):
        run_experiment(_tiny(), out, progress=False)


def test_compare_refuses_runs_of_different_code(tmp_path, code_copy, capsys):
    from ilpss.experiments.compare import main
    from ilpss.experiments.run import run_experiment

    run_experiment(_tiny(), tmp_path / "before", progress=False)
    code_copy("ilpss/smdp.py")
    run_experiment(_tiny(), tmp_path / "after", progress=False)
    with pytest.raises(SystemExit):
        main(["--baseline", f"{tmp_path / 'before'}:scratch", f"new={tmp_path / 'after'}:scratch"])
    err = capsys.readouterr().err
    assert "was made by" in err and "--allow-mixed-code" in err
    assert main(["--baseline", f"{tmp_path / 'before'}:scratch",
                 f"new={tmp_path / 'after'}:scratch", "--allow-mixed-code"]) == 0
    assert "**Mixed code**" in capsys.readouterr().out
    # runs of one code compare without a word about mixing
    run_experiment(_tiny(), tmp_path / "again", progress=False)
    assert main(["--baseline", f"{tmp_path / 'after'}:scratch",
                 f"again={tmp_path / 'again'}:scratch"]) == 0
    out = capsys.readouterr().out
    assert "Mixed" not in out and f"sources {code_record()['source_digest'][:12]}" in out


def _holder(tmp_path: Path, *extra: str) -> int:
    from ilpss.experiments import holder_learning

    return holder_learning.main(["--teams", "chasers", "--seeds", "2", "--episodes", "2",
                                 "--eval", "3", "--workers", "1",
                                 "--out", str(tmp_path / "learning.md"),
                                 "--keep", str(tmp_path / "keep"), *extra])


def test_kept_jobs_of_other_code_are_refused_not_reported(tmp_path, code_copy, capsys):
    """The case that was silent: a rule's evaluation kept, then the drill's rules file
    changed; the rerun reported the old evaluation."""
    assert _holder(tmp_path) == 0
    code_copy("soccer_drill/policies.py")
    capsys.readouterr()
    assert _holder(tmp_path) == 1
    err = capsys.readouterr().err
    assert "was made by" in err and "--allow-mixed-code" in err
    assert _holder(tmp_path, "--allow-mixed-code") == 0
    assert "**Mixed code**" in (tmp_path / "learning.md").read_text()


def test_the_commit_is_named_only_at_the_top_of_the_packages_own_work_tree(tmp_path):
    import subprocess

    top = tmp_path / "repo"
    inner = top / "lib" / "site-packages"
    inner.mkdir(parents=True)
    subprocess.run(["git", "init", "-q", str(top)], check=True)
    subprocess.run(["git", "-C", str(top), "-c", "user.email=a@b", "-c", "user.name=a",
                    "commit", "-q", "--allow-empty", "-m", "x"], check=True)
    assert len(provenance._git_commit(top)) == 40
    # an installed copy inside another repository's tree is not that commit's code
    assert provenance._git_commit(inner) is None
    assert provenance._git_commit(tmp_path / "nowhere") is None
