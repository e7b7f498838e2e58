"""ilpss-holder-learning's comparison: learning seeds are the unit, paired by episode seed."""

from __future__ import annotations

import gzip
import os
import re
import signal
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from ilpss.experiments.holder_learning import compare_to_rule, learn_and_evaluate

sys.path.insert(0, str(Path(__file__).resolve().parent))  # full_disk


def test_episodes_are_not_replicates_of_the_learnt_policy():
    rng = np.random.default_rng(0)
    rule = rng.normal(0.4, 0.6, size=500)
    # 3 learning seeds whose policies differ: one clearly worse than the rule, two better
    learnt = rule + np.array([[-0.1], [0.35], [0.4]]) + rng.normal(0, 0.3, size=(3, 500))
    c = compare_to_rule(learnt, rule)
    # pooling the 1,500 episodes as if independent claims a tiny p-value ...
    assert stats.ttest_ind(learnt.ravel(), rule, equal_var=False).pvalue < 0.01
    # ... while over the 3 seeds the difference is not shown
    low, high = c["diff_ci"][1:]
    assert low < 0 < high and c["p"] > 0.2
    assert c["improvement"].better == 2 and c["improvement"].worse == 1
    # more evaluation episodes of the same policies do not add replicates
    twice = compare_to_rule(np.tile(learnt, 2), np.tile(rule, 2))
    assert twice["diff_ci"] == pytest.approx(c["diff_ci"])


def test_pairing_by_episode_seed_removes_the_episodes_difficulty():
    rng = np.random.default_rng(1)
    difficulty = rng.normal(0, 0.8, size=200)  # shared by the rule and every policy
    rule = 0.3 + difficulty
    learnt = 0.4 + difficulty + rng.normal(0, 0.02, size=(10, 200))
    c = compare_to_rule(learnt, rule)
    assert c["diff_ci"][0] == pytest.approx(0.1, abs=0.01)
    assert c["diff_ci"][2] - c["diff_ci"][1] < 0.01  # the difficulty cancels in the pairs
    assert c["p"] < 1e-6
    with pytest.raises(ValueError, match="n_seeds >= 2"):
        compare_to_rule(learnt[:1], rule)
    with pytest.raises(ValueError, match="n_episodes"):
        compare_to_rule(learnt, rule[:-1])


# ------------------------------------------------------------ finished jobs are kept
def _run(tmp_path, keep, *extra):
    from ilpss.experiments import holder_learning

    out = tmp_path / "learning.md"
    code = holder_learning.main(["--teams", "chasers", "--seeds", "3", "--episodes", "2",
                                 "--eval", "3", "--workers", "1", "--out", str(out),
                                 "--keep", str(keep), *extra])
    return code, out


def _counting_learner(monkeypatch, fail_seed=None):
    from ilpss.experiments import holder_learning

    calls = []

    def learn(job):
        calls.append(job[1])
        if job[1] == fail_seed:
            raise ZeroDivisionError("planted")
        return learn_and_evaluate(job)

    monkeypatch.setattr(holder_learning, "learn_and_evaluate", learn)
    return calls


def _table(page) -> list[str]:
    return [line for line in page.read_text().splitlines() if line.startswith("|")]


def test_a_failing_job_keeps_the_others_and_the_same_command_computes_only_what_is_left(
    tmp_path, monkeypatch, capsys
):
    keep = tmp_path / "keep"
    calls = _counting_learner(monkeypatch, fail_seed=1)
    code, out = _run(tmp_path, keep)
    err = capsys.readouterr().err
    assert code == 1 and not out.exists()
    assert "1 of 3 learning job(s) failed (team=chasers, seed=1, episodes=2, eval=3" in err
    assert "ZeroDivisionError: planted" in err and f"the 2 others are kept in {keep}" in err
    assert len(list(keep.glob("learning-*.json"))) == 2 and sorted(calls) == [0, 1, 2]

    calls = _counting_learner(monkeypatch)
    code, out = _run(tmp_path, keep)
    assert code == 0 and calls == [1]  # only the failed job is learnt again
    assert "2 of its learning jobs kept from an earlier run" in out.read_text()

    calls = _counting_learner(monkeypatch)
    fresh = tmp_path / "fresh"
    fresh.mkdir()
    code, page = _run(fresh, tmp_path / "keep_fresh")
    assert code == 0 and sorted(calls) == [0, 1, 2]
    assert _table(page) == _table(out)  # loaded results make the same page

    calls = _counting_learner(monkeypatch)
    assert _run(tmp_path, keep, "--alpha", "0.25")[0] == 0
    assert sorted(calls) == [0, 1, 2]  # other settings: nothing of the other run is taken


def test_a_kept_job_changed_after_it_was_written_is_refused_naming_it(tmp_path, capsys):
    keep = tmp_path / "keep"
    assert _run(tmp_path, keep)[0] == 0
    kept = sorted(keep.glob("learning-*.json"))[0]
    kept.write_text(kept.read_text().replace('"eval": 3', '"eval": 4', 1))
    capsys.readouterr()
    assert _run(tmp_path, keep)[0] == 1
    err = capsys.readouterr().err
    assert f"{kept}: content checksum mismatch" in err and "delete it to compute that job again" in err


def test_a_keep_folder_that_cannot_be_one_is_refused_before_learning(tmp_path, monkeypatch, capsys):
    from ilpss.experiments.executor import LocalExecutor

    monkeypatch.setattr(LocalExecutor, "map", lambda *a, **k: pytest.fail("it learnt"))
    (tmp_path / "file").write_text("x")
    with pytest.raises(SystemExit) as exit_info:
        _run(tmp_path, tmp_path / "file")
    assert exit_info.value.code == 2
    assert f"--keep {tmp_path / 'file'}: exists and is not a folder" in capsys.readouterr().err


def test_a_kept_job_that_is_a_link_is_refused_not_followed(tmp_path, capsys):
    keep = tmp_path / "keep"
    assert _run(tmp_path, keep)[0] == 0
    kept = sorted(keep.glob("learning-*.json"))[0]
    elsewhere = tmp_path / "elsewhere.json"
    kept.rename(elsewhere)
    kept.symlink_to(elsewhere)
    capsys.readouterr()
    assert _run(tmp_path, keep)[0] == 1
    assert f"{kept}: a symbolic link inside the job folder" in capsys.readouterr().err


def _tampered(keep, kind: str, change):
    """A kept file of ``kind`` changed by ``change(result)`` and its digest recomputed, as
    an editor who knows the format would leave it."""
    from ilpss._io import json_record_bytes, load_json_record
    from ilpss.experiments.kept_jobs import JOB_SCHEMA

    path = sorted(keep.glob(f"{kind}-*.json"))[0]
    record = load_json_record(path, JOB_SCHEMA)
    record["result"] = change(record["result"])
    path.write_bytes(json_record_bytes(record))
    return path


@pytest.mark.parametrize(("kind", "change", "said"), [
    ("learning", lambda r: {**r, "eval": [5.0, 7.0, 1.0]}, r"result\.eval must be a list of 3 "
     r"values, each a finite number in \[-1, 1\], got \[5\.0, 7\.0, 1\.0\]"),
    ("learning", lambda r: {**r, "eval": ["a", "b", "c"]}, r"result\.eval must be a list"),
    ("learning", lambda r: {**r, "curve": r["curve"][:1]}, r"result\.curve must be a list of 2"),
    ("learning", lambda r: {**r, "team": "goal_guards"}, "is the job of team 'chasers'"),
    ("learning", lambda r: {**r, "seed": 7}, "is the job of seed"),
    ("learning", lambda r: "hello", "must be an object, got str"),
    ("learning", lambda r: {**r, "extra": 1}, r"unknown field\(s\) \['extra'\]"),
    ("rule", lambda r: {**r, "rule": "pass_first" if r["rule"] != "pass_first" else "hold"},
     "is the job of rule"),
    ("rule", lambda r: {**r, "eval": [1.5, 0.0, 0.0]}, r"result\.eval must be a list of 3"),
])
def test_a_kept_result_edited_with_its_digest_recomputed_is_refused(tmp_path, capsys, kind,
                                                                    change, said):
    import re

    keep = tmp_path / "keep"
    assert _run(tmp_path, keep)[0] == 0
    path = _tampered(keep, kind, change)
    capsys.readouterr()
    assert _run(tmp_path, keep)[0] == 1
    err = capsys.readouterr().err
    assert str(path) in err and re.search(said, err), err
    assert "delete it to compute that job again" in err


def test_a_full_disk_at_the_page_is_one_line_and_a_rerun_writes_it(tmp_path, monkeypatch,
                                                                    capsys):
    from full_disk import full_disk

    from ilpss.experiments import holder_learning

    keep, page = tmp_path / "keep", tmp_path / "learning.md"
    monkeypatch.setattr(holder_learning, "atomic_write_bytes", full_disk(
        holder_learning.atomic_write_bytes, at=lambda path: path == page))
    assert _run(tmp_path, keep)[0] == 1  # not a traceback
    err = capsys.readouterr().err.splitlines()[-1]  # after the progress bars
    assert err.startswith(f"ilpss-holder-learning: error: the runs finished and their results "
                          f"are kept in {keep}, but their report could not be written: ")
    assert f"cannot write {page}: No space left on device" in err and not page.exists()
    monkeypatch.undo()
    calls = _counting_learner(monkeypatch)
    assert _run(tmp_path, keep) == (0, page) and calls == []  # the page, nothing learnt again
    assert page.is_file()


def test_a_full_disk_at_a_kept_job_is_one_line(tmp_path, monkeypatch, capsys):
    from full_disk import full_disk

    from ilpss.experiments import kept_jobs

    monkeypatch.setattr(kept_jobs, "atomic_write_bytes", full_disk())
    assert _run(tmp_path, tmp_path / "keep")[0] == 1
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert err.splitlines()[-1].startswith(  # after the progress bar
        f"ilpss-holder-learning: error: [Errno 28] cannot write {tmp_path / 'keep'}/learning-")


@pytest.mark.parametrize("flag", ["--out", "--keep"])
def test_a_path_that_is_not_utf8_is_refused_before_learning(tmp_path, monkeypatch, capsys,
                                                            flag):
    from ilpss.experiments import holder_learning
    from ilpss.experiments.executor import LocalExecutor

    monkeypatch.setattr(LocalExecutor, "map", lambda *a, **k: pytest.fail("it learnt"))
    name = os.fsdecode(b"\xff")  # a byte of no UTF-8 character, as argv decodes it
    paths = {"--out": str(tmp_path / "learning.md"), "--keep": str(tmp_path / "keep"),
             flag: str(tmp_path / name)}
    with pytest.raises(SystemExit) as exit_info:
        holder_learning.main(["--teams", "chasers", "--seeds", "2", "--episodes", "2", "--eval",
                              "3", "--workers", "1", *(x for kv in paths.items() for x in kv)])
    assert exit_info.value.code == 2
    assert (f"{flag} {os.fsencode(tmp_path / name)!r}: not UTF-8; the page written at the "
            "end names it in UTF-8, so give a name in UTF-8") in capsys.readouterr().err


def test_ctrl_c_ends_holder_learning_in_one_line_with_status_130(tmp_path, monkeypatch, capsys):
    from ilpss.experiments import holder_learning

    def learn(job):
        raise KeyboardInterrupt  # as Ctrl-C does in the middle of a job

    monkeypatch.setattr(holder_learning, "learn_and_evaluate", learn)
    previous = signal.getsignal(signal.SIGTERM)
    try:
        with pytest.raises(SystemExit) as exit_info:
            _run(tmp_path, tmp_path / "keep")
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert exit_info.value.code == 130
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert err.splitlines()[-1] == (  # after the progress bar
        "ilpss-holder-learning: stopped by Ctrl-C (SIGINT); the finished jobs are kept, and "
        "the same command goes on from them")


def test_jobs_failing_for_their_settings_are_not_advised_to_run_again(tmp_path, monkeypatch,
                                                                      capsys):
    from ilpss.experiments import holder_learning
    from ilpss.traces import DivergedError

    def diverge(job):
        raise DivergedError("the values left the range of a float")

    monkeypatch.setattr(holder_learning, "learn_and_evaluate", diverge)
    assert _run(tmp_path, tmp_path / "keep")[0] == 1
    err = capsys.readouterr().err
    assert "running the same command again does not help: change the setting" in err
    assert "computes only what is left" not in err


# ------------------------------------------------------------ the numbers beside the page
def test_the_page_is_written_again_from_its_numbers_alone(tmp_path):
    from ilpss.experiments import holder_learning

    code, out = _run(tmp_path, tmp_path / "keep")
    assert code == 0
    data = tmp_path / "learning_seeds.json.gz"
    numbers = holder_learning.load_numbers(data)
    assert [(r["team"], r["seed"]) for r in numbers["learnt"]] == [("chasers", s) for s in range(3)]
    assert all(len(r["eval"]) == 3 for r in numbers["learnt"] + numbers["rules"])
    again = tmp_path / "again.md"
    assert holder_learning.main(["--from-data", str(data), "--out", str(again)]) == 0
    assert again.read_bytes() == out.read_bytes()
    # The same numbers give the same bytes; a changed file is refused, naming it.
    before = data.read_bytes()
    holder_learning.save_numbers(numbers, data)
    assert data.read_bytes() == before
    raw = gzip.decompress(before).replace(b'"seeds": 3', b'"seeds": 4')
    (tmp_path / "changed.json.gz").write_bytes(gzip.compress(raw))
    with pytest.raises(SystemExit):
        holder_learning.main(["--from-data", str(tmp_path / "changed.json.gz"),
                              "--out", str(tmp_path / "x.md")])
    with pytest.raises(ValueError, match=r"changed\.json\.gz: content checksum mismatch"):
        holder_learning.load_numbers(tmp_path / "changed.json.gz")


def test_the_shipped_learning_page_is_what_its_numbers_give(tmp_path):
    from ilpss.experiments import holder_learning

    docs = Path(__file__).resolve().parents[1] / "docs"
    out = tmp_path / "learning.md"
    assert holder_learning.main(["--from-data", str(docs / "learning_seeds.json.gz"),
                                 "--out", str(out)]) == 0
    assert out.read_text() == (docs / "learning.md").read_text()


def test_numbers_written_over_the_page_are_refused_before_learning(tmp_path, monkeypatch, capsys):
    # before, --data equal to --out was accepted: the page overwrote the numbers, and
    # "page written to x.md, the numbers it is computed from to x.md" was printed
    from ilpss.experiments import holder_learning
    from ilpss.experiments.executor import LocalExecutor

    monkeypatch.setattr(LocalExecutor, "map", lambda *a, **k: pytest.fail("it learnt"))
    page = tmp_path / "learning.md"
    with pytest.raises(SystemExit) as exit_info:
        holder_learning.main(["--teams", "chasers", "--seeds", "2", "--episodes", "2", "--eval",
                              "2", "--out", str(page), "--data", str(page),
                              "--keep", str(tmp_path / "keep")])
    assert exit_info.value.code == 2
    assert (f"--data {page}: the file written is numbers (gzip-compressed JSON) and its name "
            "ends in '.json.gz'") in capsys.readouterr().err
    assert not (tmp_path / "keep").exists()  # before, the keep folder was made first


def test_a_success_rate_interval_stays_within_0_and_1():
    # before, a t interval over few seeds near 0 or 1 read e.g. 37.5% [-439.0%, 514.0%]
    learnt = np.array([[1.0, -1.0, -1.0, -1.0], [1.0, 1.0, 1.0, -1.0]])
    mean, low, high = compare_to_rule(learnt, np.full(4, -1.0))["learnt_success_ci"]
    assert mean == 0.5 and low == 0.0 and high == 1.0


def test_region_use_refuses_a_page_over_a_runs_files_before_reading_it(tmp_path, capsys):
    # before, --out run/config.json replaced the run's configuration with the page: the
    # run could no longer be resumed or read
    from ilpss.experiments import region_use

    run = tmp_path / "run"
    run.mkdir()
    (run / "config.json").write_text("{}")
    with pytest.raises(SystemExit) as exit_info:
        region_use.main([str(run), "--out", str(run / "config.json")])
    assert exit_info.value.code == 2
    assert "its name ends in '.md'" in capsys.readouterr().err
    assert (run / "config.json").read_text() == "{}"


@pytest.mark.parametrize(("change", "said"), [
    (lambda n: n.pop("learnt"), r"missing field\(s\) \['learnt'\]|learnt"),
    (lambda n: n.update(teams="chasers"), "teams"),
    (lambda n: n["learnt"][0]["eval"].__setitem__(0, 1000.0), r"learnt\[0\]"),
    (lambda n: n["learnt"].pop(), "has the seeds"),
])
def test_numbers_rewritten_with_their_digest_are_checked_as_a_runs(tmp_path, capsys, change,
                                                                   said):
    # before, only the schema and the digest were checked: a missing field or a team
    # given as a string ended in a KeyError or ValueError traceback, a reward of 1000
    # was made into a page
    from ilpss.experiments import holder_learning

    docs = Path(__file__).resolve().parents[1] / "docs"
    numbers = holder_learning.load_gzip_record(
        docs / "learning_seeds.json.gz", holder_learning.NUMBERS_SCHEMA,
        holder_learning.MAX_NUMBERS_BYTES, "numbers")["numbers"]
    change(numbers)
    holder_learning.save_numbers(numbers, tmp_path / "changed.json.gz")
    with pytest.raises(SystemExit) as exit_info:
        holder_learning.main(["--from-data", str(tmp_path / "changed.json.gz"),
                              "--out", str(tmp_path / "x.md")])
    err = capsys.readouterr().err
    assert exit_info.value.code == 2 and re.search(said, err) and "Traceback" not in err
    assert not (tmp_path / "x.md").exists()
