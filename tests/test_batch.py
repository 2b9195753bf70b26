"""mocapkit batch: input expansion, bad files as error rows equal to the single-file command's errors,
good rows equal to what the single-file commands print, outputs equal to theirs, resume and the journal.

The batches run in-process through :func:`mocapkit.cli.main` (their workers are real processes)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from cli_run import run
from mocapkit.batch.journal import Journal, read_journal
from mocapkit.batch.results import read_results
from mocapkit.errors import InvalidParameterError, MocapFormatError
from mocapkit.jobs.inputs import expand_inputs, output_bases

pytest.importorskip("pyarrow", reason="the batch results need pyarrow (mocapkit[batch])")


def rows_by_input(out: Path) -> dict[str, dict]:
    rows = read_results(out / "results.parquet")
    assert len({r["input"] for r in rows}) == len(rows), "one row per input"
    return {r["input"]: r for r in rows}


# --------------------------------------------------------------------------------------------------
# inputs
# --------------------------------------------------------------------------------------------------

def _tree(root: Path, tests_data: Path) -> None:
    (root / "a" / "deep").mkdir(parents=True)
    (root / ".hidden").mkdir()
    shutil.copy(tests_data / "bvh" / "walk-meredith-60.bvh", root / "a" / "walk.bvh")
    shutil.copy(tests_data / "cmu" / "86_01_first60.amc", root / "a" / "deep" / "86_01.amc")
    shutil.copy(tests_data / "cmu" / "86.asf", root / "a" / "deep" / "86.asf")
    shutil.copy(tests_data / "cmu" / "86_01_15hz_first1600.labels.txt", root / "a" / "deep" / "86_01.labels.txt")
    shutil.copy(tests_data / "formats" / "ngimu.csv", root / "ngimu.csv")
    shutil.copy(tests_data / "formats" / "ngimu.csv", root / ".hidden" / "x.csv")
    shutil.copy(tests_data / "formats" / "ngimu.csv", root / ".dot.csv")
    (root / "notes.md").write_text("hello\n")


def test_expand_inputs_walks_folders_skips_companions_hidden_and_out(tests_data, tmp_path):
    root = tmp_path / "db"
    _tree(root, tests_data)
    out = root / "out"  # the output folder inside the input folder is never entered
    out.mkdir()
    shutil.copy(tests_data / "formats" / "ngimu.csv", out / "old.csv")
    found = expand_inputs([root, root / "a" / "walk.bvh"], out)  # a file named twice is one input
    assert found.files == sorted([root / "a" / "walk.bvh", root / "a" / "deep" / "86_01.amc", root / "ngimu.csv"])
    assert dict(found.skipped) == {
        str(root / "a" / "deep" / "86.asf"): "ASF skeleton (read with the AMC takes beside it)",
        str(root / "a" / "deep" / "86_01.labels.txt"): "reference labels of a take",
        str(root / "notes.md"): "unknown suffix",
    }
    # a hidden file named explicitly is an input; one inside the output folder is skipped with its reason
    found = expand_inputs([root / ".dot.csv", out / "old.csv"], out)
    assert found.files == [root / ".dot.csv"]
    assert found.skipped == [(str(out / "old.csv"), "inside the output folder")]


def test_expand_inputs_globs_and_missing_paths(tests_data, tmp_path, monkeypatch):
    root = tmp_path / "db"
    _tree(root, tests_data)
    monkeypatch.chdir(tmp_path)
    found = expand_inputs(["db/**/*.amc", "db/*.csv"])
    assert found.files == [root / "a" / "deep" / "86_01.amc", root / "ngimu.csv"]
    with pytest.raises(InvalidParameterError, match=r"db/\*\.c3d: no file matches"):
        expand_inputs(["db/*.c3d"])
    with pytest.raises(InvalidParameterError, match="nothing.bvh: no such file or folder"):
        expand_inputs([root, "nothing.bvh"])


def test_output_bases_mirror_the_tree_and_part_same_stems(tmp_path):
    files = [tmp_path / "d" / "s1" / "walk.bvh", tmp_path / "d" / "s1" / "walk.amc", tmp_path / "d" / "s2" / "run.bvh"]
    bases = output_bases(files, tmp_path / "out")
    assert bases == {files[0]: tmp_path / "out" / "s1" / "walk-bvh", files[1]: tmp_path / "out" / "s1" / "walk-amc",
                     files[2]: tmp_path / "out" / "s2" / "run"}


# --------------------------------------------------------------------------------------------------
# a folder with corrupt, empty and unreadable files
# --------------------------------------------------------------------------------------------------

GOOD = {
    "bvh/walk.bvh": "bvh/walk-meredith-60.bvh",
    "cmu/86_01_first60.amc": "cmu/86_01_first60.amc",
    "cmu/86.asf": "cmu/86.asf",
    "imu/ngimu.csv": "formats/ngimu.csv",
    "markers/juggling.tsv": "markers/juggling-qualisys-300hz-first120.tsv",
    "opensim/walk.trc": "opensim/walk_free_01-first20.trc",
    "opensim/ik.mot": "opensim/subject01_walk1_ik-first20.mot",
}


@pytest.fixture
def messy(tests_data, tmp_path) -> tuple[Path, list[Path], list[Path]]:
    """A database of good files and bad ones: corrupt, cut short, empty, unreadable."""
    root = tmp_path / "db"
    for rel, src in GOOD.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(tests_data / src, root / rel)
    bad = root / "bad"
    bad.mkdir()
    (bad / "garbage.bvh").write_text("this is not a BVH file\n")
    text = (tests_data / "markers" / "juggling-qualisys-300hz-first120.tsv").read_text()
    (bad / "cut.tsv").write_text(text[: len(text) // 2 - 7])  # cut in the middle of a row
    (bad / "empty.c3d").write_bytes(b"")
    (bad / "empty.trc").write_bytes(b"")
    (bad / "binary.csv").write_bytes(bytes(range(256)) * 4)
    os.symlink(tmp_path / "gone" / "x.bvh", bad / "dangling.bvh")  # unreadable for root too
    if os.geteuid() != 0:  # chmod 000 stops reading only for a user without CAP_DAC_OVERRIDE
        shutil.copy(tests_data / "formats" / "ngimu.csv", bad / "locked.csv")
        os.chmod(bad / "locked.csv", 0)
    good = sorted(root / rel for rel in GOOD if not rel.endswith(".asf"))
    return root, good, sorted(bad.iterdir())


def test_batch_over_bad_files_finishes_and_rows_equal_the_single_file_command(messy, tmp_path):
    root, good, bad = messy
    out = tmp_path / "out"
    code, stdout, stderr = run("batch", "info", root, "--out", out, "--jobs", "2")
    assert code == 1, stderr  # some rows are errors, the batch finished
    rows = rows_by_input(out)
    assert sorted(rows) == sorted(str(p) for p in good + bad)
    warned = sorted(p for p, r in rows.items() if r["status"] == "ok" and json.loads(r["record_json"])["warnings"])
    assert warned  # the TRC excerpt's header counts more frames than it holds
    assert f"batch info: {len(good)} ok ({len(warned)} with warnings), {len(bad)} errors, 1 skipped" in stdout
    for p in warned:  # each file read with a warning is named under "warnings" with its first warning
        first = json.loads(rows[p]["record_json"])["warnings"][0]
        assert f"  {p}: {first}" in stdout
    for p in bad:
        r = rows[str(p)]
        assert r["status"] == "error" and r["record_json"] is None
        c, o, e = run("info", "--json", p)  # the single-file command fails with the same one line
        assert c == 2 and o == ""
        if p.is_symlink() and not p.exists():  # the batch's content hash is what fails first
            assert r["error"] == f"{p}: No such file or directory" and str(p) in e and "no such file" in e
        else:
            assert e.strip() == f"error: {r['error']}"
        assert r["error"] in stdout  # listed in the summary
    for p in good:
        r = rows[str(p)]
        assert r["status"] == "ok" and r["error"] is None, r
        c, o, e = run("info", "--json", p)
        assert c == 0, e
        assert json.loads(r["record_json"]) == json.loads(o)
    # the journal holds the same rows (in the order they finished)
    journal = read_journal(out / "journal.jsonl")
    assert sorted(json.dumps(x, sort_keys=True) for x in journal) == sorted(
        json.dumps(x, sort_keys=True) for x in rows.values())


def test_batch_all_ok_exits_0_and_usage_errors_exit_2(tests_data, tmp_path):
    src = tmp_path / "db"
    src.mkdir()
    shutil.copy(tests_data / "formats" / "ngimu.csv", src / "a.csv")
    code, stdout, stderr = run("batch", "info", src, "--out", tmp_path / "out", "--jobs", "1")
    assert code == 0, stderr
    assert "batch info: 1 ok, 0 errors, 0 skipped" in stdout
    for args, named in [
        (("batch", "info", tmp_path / "none", "--out", tmp_path / "o2"), "none: no such file or folder"),
        (("batch", "info", src, "--out", tmp_path / "o2", "--jobs", "0"), "--jobs"),
        (("batch", "info", src, "--out", tmp_path / "o2", "--engine", "spark"), "--engine"),
        (("batch", "info", src, "--out", tmp_path / "o2", "--scheduler", "tcp://127.0.0.1:1"), "--scheduler"),
        (("batch", "info", src, "--out", src / "a.csv"), "not a folder"),
        (("batch", "compress", src, "--out", tmp_path / "o2"), "exactly one of"),
        (("batch", "compress", src, "--out", tmp_path / "o2", "-t", "1", "--max-angle", "2"), "exactly one of"),
        (("batch", "filter", src, "--out", tmp_path / "o2"), "--penalty"),
        (("batch", "info", src), "--out"),
        (("batch", "info", src, "--out", src), "holds the input"),  # OUT is never entered: nothing would run
        (("batch", "info", src, "--out", tmp_path), "holds the input"),
        (("batch", "segment", src, "--out", tmp_path / "o2"), "no input that segment reads"),
        (("batch", "segment", src, "--out", tmp_path / "o2", "-m", "mlp"), "--train"),  # checked before any file
        (("batch", "segment", src, "--out", tmp_path / "o2", "--downsample", "2", "-m", "pca"), "--downsample"),
    ]:
        code, stdout, stderr = run(*args)
        assert code == 2, (args, stderr)
        assert stderr.startswith("error: ") and named in stderr and stderr.count("\n") == 1, stderr
    assert not (tmp_path / "o2").exists()  # refused before any work: not even the OUT folder is made


def test_batch_compress_filter_segment_rows_and_outputs_equal_the_single_file_commands(tests_data, tmp_path):
    db = tmp_path / "db"
    (db / "imu").mkdir(parents=True)
    (db / "skel").mkdir()
    (db / "markers").mkdir()
    shutil.copy(tests_data / "formats" / "ngimu.csv", db / "imu" / "ngimu.csv")
    shutil.copy(tests_data / "bvh" / "walk-meredith-60.bvh", db / "skel" / "walk.bvh")
    shutil.copy(tests_data / "markers" / "juggling-qualisys-300hz-first120.tsv", db / "markers" / "jug.tsv")
    shutil.copy(tests_data / "cmu" / "86_01_15hz_first1600.amc", db / "skel" / "86_01.amc")
    shutil.copy(tests_data / "cmu" / "86.asf", db / "skel" / "86.asf")
    single = tmp_path / "single"
    single.mkdir()

    # compress: IMU points and a skeleton's glTF, byte for byte what the single-file command writes
    out = tmp_path / "c"
    code, _, stderr = run("batch", "compress", db / "imu", db / "skel" / "walk.bvh", "--out", out, "-t", "0.01",
                          "-j", "2")
    assert code == 0, stderr
    rows = rows_by_input(out)
    rec = json.loads(rows[str(db / "imu" / "ngimu.csv")]["record_json"])
    code, o, e = run("compress", db / "imu" / "ngimu.csv", "-t", "0.01", "--json", "-o", single / "ngimu.csv")
    assert code == 0, e
    assert rec["signals"] == json.loads(o)
    assert (out / "imu" / "ngimu.points" / "ngimu.csv").read_bytes() == (single / "ngimu.csv").read_bytes()
    rec = json.loads(rows[str(db / "skel" / "walk.bvh")]["record_json"])
    code, o, e = run("compress", db / "skel" / "walk.bvh", "-t", "0.01", "--json", "-o", single / "walk.glb")
    assert code == 0, e
    expect = json.loads(o)
    assert {k: v for k, v in rec.items() if k in expect and k not in ("output", "file_bytes", "outputs")} == {
        k: v for k, v in expect.items() if k not in ("output", "file_bytes", "outputs")}
    assert (out / "skel" / "walk.glb").read_bytes() == (single / "walk.glb").read_bytes()
    assert rec["outputs"][0]["path"] == str(out / "skel" / "walk.glb")
    assert rec["outputs"][0]["bytes"] == (out / "skel" / "walk.glb").stat().st_size

    # filter: the pieces and the filtered CSV
    out = tmp_path / "f"
    code, _, stderr = run("batch", "filter", db / "markers", "--out", out, "--penalty", "5", "--markers",
                          "base_1,base_2", "-j", "1")
    assert code == 0, stderr
    rec = json.loads(rows_by_input(out)[str(db / "markers" / "jug.tsv")]["record_json"])
    code, o, e = run("filter", db / "markers" / "jug.tsv", "--penalty", "5", "--markers", "base_1,base_2", "--json",
                     "-o", single / "jug.csv")
    assert code == 0, e
    assert rec["signals"] == json.loads(o)
    assert (out / "jug.filtered.csv").read_bytes() == (single / "jug.csv").read_bytes()

    # segment: the cuts of an AMC take (its ASF found beside it, CMU naming)
    out = tmp_path / "s"
    code, _, stderr = run("batch", "segment", f"{db}/**/*.amc", "--out", out, "--rate", "15", "--method", "pca")
    assert code == 0, stderr
    rows = rows_by_input(out)
    assert len(rows) == 1
    rec = json.loads(rows[str(db / "skel" / "86_01.amc")]["record_json"])
    code, o, e = run("segment", db / "skel" / "86_01.amc", "--rate", "15", "--method", "pca", "--json")
    assert code == 0, e
    assert rec == json.loads(o)
    assert len(rec["cuts"]) >= 1


# --------------------------------------------------------------------------------------------------
# resume and the journal (the kill -9 test is in test_batch_resume.py)
# --------------------------------------------------------------------------------------------------

def test_resume_keeps_ok_rows_and_reruns_errors_changed_files_and_other_options(tests_data, tmp_path):
    db = tmp_path / "db"
    db.mkdir()
    for name in ("a", "b", "c"):
        shutil.copy(tests_data / "formats" / "ngimu.csv", db / f"{name}.csv")
    (db / "d.bvh").write_text("broken\n")
    out = tmp_path / "out"
    assert run("batch", "info", db, "--out", out, "-j", "2")[0] == 1
    first = rows_by_input(out)
    # a changed file and a fixed file run again; the others are kept as they were
    with open(db / "b.csv", "a") as f:
        f.write("1.5,1,0,0,0\n")
    shutil.copy(tests_data / "bvh" / "walk-meredith-60.bvh", db / "d.bvh")
    code, stdout, stderr = run("batch", "info", db, "--out", out, "-j", "2", "--resume")
    assert code == 0, stderr
    assert "2 kept from an earlier run" in stdout
    second = rows_by_input(out)
    assert sorted(second) == sorted(first)
    for name in ("a", "c"):
        assert second[str(db / f"{name}.csv")] == first[str(db / f"{name}.csv")]
    for name in ("b.csv", "d.bvh"):
        assert second[str(db / name)]["started_at"] != first[str(db / name)]["started_at"]
        assert second[str(db / name)]["status"] == "ok"
    samples = {k: [s["samples"] for s in json.loads(r["record_json"])["signals"].values()]
               for k, r in second.items() if k.endswith(".csv")}
    assert samples[str(db / "b.csv")] == [samples[str(db / "a.csv")][0] + 1]
    # other options: nothing is kept
    code, stdout, _ = run("batch", "info", db, "--out", out, "-j", "2", "--resume", "--no-strict")
    assert code == 0 and "kept" not in stdout
    third = rows_by_input(out)
    assert all(third[k]["started_at"] != second[k]["started_at"] for k in third)
    assert len({r["options_hash"] for r in third.values()}) == 1
    assert third[str(db / "a.csv")]["options_hash"] != second[str(db / "a.csv")]["options_hash"]
    # without --resume everything runs again and the journal starts afresh
    assert run("batch", "info", db, "--out", out, "-j", "1")[0] == 0
    assert len(read_journal(out / "journal.jsonl")) == 4


def test_journal_survives_a_cut_last_line(tmp_path):
    p = tmp_path / "journal.jsonl"
    with Journal(p, fresh=True) as j:
        j.append({"input": "a", "status": "ok", "x": 1.5})
        j.append({"input": "b", "status": "error", "x": None})
    with open(p, "ab") as f:
        f.write(b'{"input": "c", "sta')  # a write cut by a kill
    assert [r["input"] for r in read_journal(p)] == ["a", "b"]
    with Journal(p, fresh=False) as j:  # the cut line is dropped before appending
        j.append({"input": "d", "status": "ok"})
    assert [r["input"] for r in read_journal(p)] == ["a", "b", "d"]
    p.write_bytes(b'{"input": "a", "status": "ok"}\nnot json\n{"input": "b", "status": "ok"}\n')
    with pytest.raises(MocapFormatError, match=r"journal.jsonl:2: not a journal row"):
        read_journal(p)


def test_numba_cache_rule(monkeypatch, tmp_path):
    from mocapkit.batch import worker

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "given"))
    assert worker.numba_cache_dir() == str(tmp_path / "given")
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    monkeypatch.setattr(worker.os, "access", lambda p, mode: True)
    assert worker.numba_cache_dir() is None  # numba's own cache beside the sources
    monkeypatch.setattr(worker.os, "access", lambda p, mode: False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    assert worker.numba_cache_dir() == str(tmp_path / "cache" / "mocapkit" / "numba")


def test_db_gets_the_rows_from_the_main_process_and_resume_adds_no_duplicate(tests_data, tmp_path):
    pytest.importorskip("duckdb", reason="the embedded catalog needs duckdb (mocapkit[batch])")
    from mocapkit.catalog import open_catalog

    db = tmp_path / "db"
    db.mkdir()
    shutil.copy(tests_data / "formats" / "ngimu.csv", db / "a.csv")
    shutil.copy(tests_data / "bvh" / "walk-meredith-60.bvh", db / "b.bvh")
    (db / "c.bvh").write_text("broken\n")
    url = tmp_path / "motion.duckdb"
    out = tmp_path / "out"
    code, stdout, stderr = run("batch", "info", db, "--out", out, "-j", "2", "--db", url)
    assert code == 1, stderr
    assert "catalog: 3 runs, 2 recordings written" in stdout
    rows = rows_by_input(out)
    with open_catalog(url) as cat:
        _, got = cat.query("SELECT path, status, error, content_hash, options_hash FROM runs ORDER BY path")
    assert got == [(k, r["status"], r["error"], r["content_hash"], r["options_hash"]) for k, r in sorted(rows.items())]
    code, stdout, stderr = run("batch", "info", db, "--out", out, "-j", "2", "--db", url, "--resume")
    assert code == 1 and "2 kept from an earlier run" in stdout, stderr
    with open_catalog(url) as cat:
        _, n = cat.query("SELECT count(*) FROM runs WHERE status = 'ok'")
        _, n_rec = cat.query("SELECT count(*) FROM recordings")
    assert n == [(2,)] and n_rec == [(2,)]
    # a catalog URL that cannot be opened is refused before any work
    code, _, stderr = run("batch", "info", db, "--out", tmp_path / "o2", "--db", tmp_path / "no" / "x.duckdb")
    assert code == 2 and stderr.startswith("error: ") and "does not exist" in stderr
    assert not (tmp_path / "o2" / "journal.jsonl").exists()
