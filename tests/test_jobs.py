"""The jobs layer (``mocapkit.jobs``): one plain function per job, the same record whether printed by the
command line or run in another process, outputs where ``batch_output`` says, bad input as errors."""

from __future__ import annotations

import contextlib
import io
import json
import multiprocessing
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from mocapkit import cli
from mocapkit.errors import InvalidParameterError, MocapError
from mocapkit.jobs import JOBS, batch_output, run_job
from mocapkit.jobs.segment import segments_of


def _cli_json(*args) -> object:
    out, errs = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(errs), pytest.raises(SystemExit) as e:
        cli.main([str(a) for a in args])
    assert e.value.code == 0, errs.getvalue()
    return json.loads(out.getvalue())


def _roundtrip(rec):
    """The record as strict JSON gives it back (every value JSON-able and finite)."""
    return json.loads(json.dumps(rec, allow_nan=False))


@pytest.fixture(scope="module")
def files(tests_data) -> dict[str, Path]:
    return {
        "bvh": tests_data / "bvh" / "walk-meredith-60.bvh",
        "amc": tests_data / "cmu" / "86_01_15hz_first1600.amc",
        "asf": tests_data / "cmu" / "86.asf",
        "labels": tests_data / "cmu" / "86_01_15hz_first1600.labels.txt",
        "imu": tests_data / "imu" / "xio" / "ngimu_quaternion.csv",
        "tsv": tests_data / "markers" / "juggling-qualisys-300hz-first120.tsv",
    }


# (job, file key, options, the CLI arguments giving the same run, the part of the record the CLI prints)
CASES = [
    ("info", "bvh", {}, [], None),
    ("info", "imu", {}, [], None),
    ("info", "tsv", {}, [], None),
    ("info", "amc", {"asf": "asf"}, ["--asf", "asf"], None),
    ("compress", "imu", {"method": "sw", "threshold": 0.01}, ["-m", "sw", "--threshold", "0.01"], "signals"),
    ("compress", "bvh", {"method": "fastsw", "max_position_error": 0.5}, ["--max-position-error", "0.5"], None),
    ("filter", "tsv", {"penalty": 50.0, "markers": "base_1,unnamed_7"}, ["--penalty", "50", "--markers",
                                                                        "base_1,unnamed_7"], "signals"),
    ("segment", "amc", {"asf": "asf", "rate": 15.0, "labels": "labels"},
     ["--asf", "asf", "--rate", "15", "--labels", "labels"], None),
]


def _resolve(options: dict, files: dict) -> dict:
    return {k: (files[v] if isinstance(v, str) and v in files and k in ("asf", "labels") else v)
            for k, v in options.items()}


@pytest.mark.parametrize("job,key,options,args,part", CASES, ids=[f"{c[0]}-{c[1]}" for c in CASES])
def test_cli_prints_the_job_record(files, job, key, options, args, part):
    """``mocapkit JOB --json FILE`` prints exactly the job function's record (or its documented part)."""
    rec = _roundtrip(run_job(job, files[key], _resolve(options, files)))
    assert rec["job"] == job and rec["file"] == str(files[key])
    cli_args = [files.get(a, a) for a in args]
    extra = ["--stats-only"] if job == "compress" and key == "imu" else []
    printed = _cli_json(job, files[key], *cli_args, "--json", *extra)
    assert printed == (rec if part is None else rec[part])


@pytest.mark.parametrize("job,key,options", [(c[0], c[1], c[2]) for c in CASES[::2]],
                         ids=[f"{c[0]}-{c[1]}" for c in CASES[::2]])
def test_job_runs_the_same_in_another_process(files, job, key, options):
    """A job is pure: run in a fresh (spawned) process it gives the record it gives here."""
    opts = _resolve(options, files)
    here = _roundtrip(run_job(job, files[key], opts))
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        there = _roundtrip(pool.submit(run_job, job, files[key], opts).result(timeout=600))
    assert there == here


def test_cli_delegates_to_the_job_function(files, monkeypatch):
    """The single-file commands only parse, call the job and print: a replaced job is what they print."""
    import mocapkit.jobs as jobs

    seen = {}

    def fake(path, **kw):
        seen.update(kw, path=path)
        return {"job": "info", "file": str(path), "kind": "imu", "marker": 12345, "warnings": [], "outputs": []}

    monkeypatch.setattr(jobs, "info_job", fake)
    printed = _cli_json("info", files["imu"], "--rate", "50", "--json")
    assert printed["marker"] == 12345 and seen["rate"] == 50.0 and seen["path"] == files["imu"]


def test_every_record_names_its_recording(files):
    for job, key, options, _, _ in CASES:
        rec = run_job(job, files[key], _resolve(options, files))
        r = rec["recording"]
        assert r["path"] == str(files[key]) and r["frames"] > 0 and r["channels"], (job, key)
        assert isinstance(rec["warnings"], list) and isinstance(rec["outputs"], list)


def test_batch_output_places_and_writes(files, tmp_path):
    """Each job writes where ``batch_output`` says; the entries list the written files with their size."""
    base = tmp_path / "out" / "sub" / "take"
    out = batch_output("compress", files["imu"], {}, base)
    assert out == base.with_name("take.points") and out.is_dir()
    rec = run_job("compress", files["imu"], {"max_angle": 1.0}, out)
    (entry,) = rec["outputs"]
    written = out / "ngimu_quaternion.csv"
    assert entry["path"] == str(written) and entry["bytes"] == written.stat().st_size > 0
    assert entry["bound"] == 1.0 and entry["bound_unit"] == "deg"
    assert written.read_text().startswith("time,w,x,y,z\n")
    assert len(written.read_text().splitlines()) == rec["signals"][0]["n_points"] + 1

    out = batch_output("compress", files["bvh"], {}, tmp_path / "b" / "walk")
    assert out.suffix == ".glb" and out.parent.is_dir() and not out.exists()
    rec = run_job("compress", files["bvh"], {"max_position_error": 1.0}, out)
    assert out.stat().st_size == rec["outputs"][0]["bytes"] and rec["outputs"][0]["bound_unit"] == "cm"

    out = batch_output("filter", files["tsv"], {}, tmp_path / "f" / "jug")
    assert out.name == "jug.filtered.csv"
    rec = run_job("filter", files["tsv"], {"penalty": 50.0, "markers": "base_1"}, out)
    rows = out.read_text().splitlines()
    assert len(rows) == 121 and rows[0].startswith("time (s),base_1_x")
    assert batch_output("info", files["bvh"], {}, tmp_path / "i") is None
    assert batch_output("segment", files["amc"], {}, tmp_path / "s") is None


def test_segments_cover_the_take_with_majority_labels(files):
    from mocapkit.io.skeletal.labels import read_reference

    ref = read_reference(files["labels"], 200, 15.0)
    rng = np.random.default_rng(3)
    frame_labels = np.asarray(ref.labels, dtype=object)[ref.frame_labels()]
    for _ in range(20):
        cuts = sorted(set(rng.integers(1, 200, size=rng.integers(0, 6)).tolist()))
        segs = segments_of(cuts, 200, 15.0, ref)
        assert [s["frame0"] for s in segs] == [0, *cuts] and [s["frame1"] for s in segs] == [*cuts, 200]
        for s in segs:  # a naive count of the labels in the segment
            counts = Counter(frame_labels[s["frame0"]:s["frame1"]])
            assert counts[s["label"]] == max(counts.values())
            assert s["t0"] == s["frame0"] / 15.0 and s["t1"] == s["frame1"] / 15.0
    assert all(s["label"] is None for s in segments_of([50], 200, 15.0))


def test_bad_input_and_unknown_job_are_errors(tmp_path, files):
    bad = tmp_path / "broken.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n")
    with pytest.raises(MocapError, match="broken.bvh"):
        run_job("info", bad, {})
    with pytest.raises(InvalidParameterError, match="unknown job"):
        run_job("dance", files["bvh"], {})
    with pytest.raises(InvalidParameterError, match="exactly one"):
        run_job("compress", files["imu"], {"threshold": 0.1, "max_angle": 1.0})
    assert set(JOBS) == {"info", "compress", "filter", "segment", "verify"}


def test_jobs_say_which_inputs_they_do_not_read(files, tests_data):
    from mocapkit.jobs import not_read_by

    expect = {  # (job, file) -> does the job read it, by the commands' own rules
        ("info", "bvh"): True, ("info", "tsv"): True, ("info", "imu"): True, ("info", "amc"): True,
        ("compress", "bvh"): True, ("compress", "imu"): True, ("compress", "tsv"): False,
        ("filter", "tsv"): True, ("filter", "imu"): True, ("filter", "bvh"): False, ("filter", "amc"): False,
        ("segment", "bvh"): True, ("segment", "amc"): True, ("segment", "tsv"): False, ("segment", "imu"): False,
    }
    for (job, key), reads in expect.items():
        why = not_read_by(job, files[key])
        assert (why is None) == reads, (job, key, why)
        if why is not None:
            assert why.startswith(f"{job} reads ")
    # a job refused by not_read_by indeed fails on that input (the rule is not stricter than the job)
    with pytest.raises(MocapError):
        run_job("segment", files["tsv"], {})
    with pytest.raises(MocapError):
        run_job("filter", files["bvh"], {"auto": True})
    assert not_read_by("filter", tests_data / "imu" / "xio") is not None


def test_batch_lists_inputs_the_job_does_not_read_as_skipped(files, tmp_path):
    import shutil

    from mocapkit.batch.engine import run_batch

    src = tmp_path / "in"
    src.mkdir()
    for key in ("amc", "asf", "tsv", "imu"):
        shutil.copy(files[key], src / files[key].name)
    res = run_batch("segment", [src], {"asf": str(src / files["asf"].name), "rate": 15.0}, tmp_path / "out", jobs=1)
    assert [Path(r["input"]).name for r in res.rows] == [files["amc"].name]
    assert res.rows[0]["status"] == "ok", res.rows[0]["error"]
    skipped = {Path(p).name: why for p, why in res.skipped}
    assert set(skipped) == {files["tsv"].name, files["imu"].name, files["asf"].name}
    assert skipped[files["tsv"].name] == "segment reads skeletons; this is a marker file"


def test_segment_finds_the_labels_beside_the_take(files):
    """``labels_beside``: ``TAKE.labels.txt`` next to the take is used as if given with ``labels``."""
    assert files["labels"].name == files["amc"].stem + ".labels.txt"
    opts = {"asf": files["asf"], "rate": 15.0}
    beside = run_job("segment", files["amc"], {**opts, "labels_beside": True})
    given = run_job("segment", files["amc"], {**opts, "labels": files["labels"]})
    plain = run_job("segment", files["amc"], opts)
    assert beside["segments"] == given["segments"] and beside["scores"] == given["scores"]
    assert any(s["label"] for s in beside["segments"]) and all(s["label"] is None for s in plain["segments"])


def test_not_read_by_follows_the_options_and_skips_tables_without_orientation(files, tmp_path):
    from mocapkit.jobs import not_read_by

    assert "skeletons take --max-position-error" in not_read_by("compress", files["bvh"], {"max_angle": 1.0})
    assert "IMU data takes --max-angle" in not_read_by("compress", files["imu"], {"max_position_error": 1.0})
    assert not_read_by("compress", files["bvh"], {"max_position_error": 1.0}) is None
    assert not_read_by("compress", files["imu"], {"threshold": 0.1}) is None
    gyro = tmp_path / "Inertial.csv"  # x-io's gyroscope/accelerometer export: named columns, no orientation
    gyro.write_text("Timestamp (us),Gyroscope X (deg/s),Gyroscope Y (deg/s),Gyroscope Z (deg/s)\n0,1,2,3\n")
    why = not_read_by("info", gyro, {})
    assert why.startswith("no orientation columns (columns: Timestamp (us), Gyroscope X")
    with pytest.raises(MocapError):  # the reason is true: the job fails on it
        run_job("info", gyro, {})
    assert not_read_by("filter", gyro, {}) is None  # filter reads it as plain columns
    for name, content in (("garbage.csv", bytes(range(256))), ("empty.csv", b""), ("nohead.csv", b"1,2,3\n4,5,6\n")):
        (tmp_path / name).write_bytes(content)  # not a table with a header: left to the job, an error row
        assert not_read_by("info", tmp_path / name, {}) is None, name


def test_a_sensor_folder_is_one_input_as_info_reads_it(tests_data, tmp_path):
    """x-io's layout (one sub-folder per sensor, Quaternion.csv + Inertial.csv) is one recording in a batch,
    its sensors named after the sub-folders, and the row equals ``mocapkit info --json FOLDER``."""
    import shutil

    from mocapkit.batch.engine import run_batch
    from mocapkit.jobs.inputs import expand_inputs, is_sensor_folder

    db = tmp_path / "db"
    shutil.copytree(tests_data / "xio", db / "walk" / "xio")
    shutil.copy(tests_data / "bvh" / "walk-meredith-60.bvh", db / "walk" / "walk.bvh")
    assert is_sensor_folder(db / "walk" / "xio") and not is_sensor_folder(db / "walk")
    assert not is_sensor_folder(db / "walk" / "xio" / "pelvis")  # files, no sub-folders
    found = expand_inputs([db])
    assert found.files == [db / "walk" / "walk.bvh", db / "walk" / "xio"]
    res = run_batch("info", [db], {}, tmp_path / "out", jobs=1)
    rec = json.loads(next(r for r in res.rows if r["input"] == str(db / "walk" / "xio"))["record_json"])
    assert sorted(rec["signals"]) == ["left-foot", "pelvis"]
    assert rec == _roundtrip(run_job("info", db / "walk" / "xio", {}))
    (db / "walk" / "xio" / "pelvis" / "notes.bvh").write_text("x")  # another recording inside: a plain folder
    assert not is_sensor_folder(db / "walk" / "xio")
