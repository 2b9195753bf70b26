"""Per-file options in ``mocapkit batch``: a manifest and sidecars; the command's reading options only fill in
what a file lacks; the catalog keeps every reading of the same bytes; both bounds in one batch; no output
written through a link onto another input of the batch.

The batches run in-process through :func:`mocapkit.cli.main` (their workers are real processes); the
catalogs are DuckDB files and, where ``MOCAPKIT_TEST_PG`` is set, PostgreSQL schemas."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import uuid
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cli_run import run

pytest.importorskip("pyarrow", reason="the batch results need pyarrow (mocapkit[batch])")
pytest.importorskip("duckdb")


def rows_by_name(out: Path) -> dict[str, dict]:
    from mocapkit.batch.results import read_results

    return {Path(r["input"]).name: r for r in read_results(out / "results.parquet")}


def record(row: dict) -> dict:
    assert row["status"] == "ok", row["error"]
    return json.loads(row["record_json"])


@contextlib.contextmanager
def _pg_schema():
    url = os.environ.get("MOCAPKIT_TEST_PG")
    if not url:
        pytest.skip("MOCAPKIT_TEST_PG is not set (start a server: eval \"$(tools/pg_test_server.sh start)\")")
    psycopg = pytest.importorskip("psycopg")
    name = "t_" + uuid.uuid4().hex[:12]
    with psycopg.connect(url, autocommit=True) as c:
        c.execute(f"CREATE SCHEMA {name}")
    try:
        yield url + ("&" if "?" in url else "?") + f"options=-csearch_path%3D{name}"
    finally:
        with psycopg.connect(url, autocommit=True) as c:
            c.execute(f"DROP SCHEMA {name} CASCADE")


@pytest.fixture(params=["duckdb", "postgresql"])
def catalog_url(request, tmp_path):
    if request.param == "duckdb":
        yield str(tmp_path / "motion.duckdb")
    else:
        with _pg_schema() as url:
            yield url


def query(url: str, sql: str, params=()) -> list[tuple]:
    from mocapkit.catalog import open_catalog

    with open_catalog(url) as c:
        return c.query(sql, params)[1]


# --------------------------------------------------------------------------------------------------
# the mixed tree
# --------------------------------------------------------------------------------------------------

MANIFEST = """\
# reading options of the takes that do not carry them
[[files]]
glob = "cmu/*.amc"
rate = 120
asf = "skel/86.asf"

[[files]]
glob = "imu/*.csv"
rate = 100

[[files]]
path = "imu/legacy.csv"
rate = 50
"""


def mixed_tree(root: Path, tests_data: Path) -> Path:
    """A BVH (its own frame time and skeleton), two AMC takes whose skeleton lies in another folder (so
    only the manifest names it; 86_02 is a 15 Hz excerpt with a sidecar saying so), an IMU CSV with its
    own clock, one without a clock (the manifest gives 50 Hz), one without a clock the command's --rate
    serves. Returns the manifest."""
    for d in ("bvh", "cmu", "skel", "imu"):
        (root / d).mkdir(parents=True)
    shutil.copy(tests_data / "bvh" / "walk-meredith-60.bvh", root / "bvh" / "walk.bvh")
    shutil.copy(tests_data / "cmu" / "86_01_first60.amc", root / "cmu" / "86_01.amc")
    shutil.copy(tests_data / "cmu" / "86_01_15hz_first1600.amc", root / "cmu" / "86_02.amc")
    shutil.copy(tests_data / "cmu" / "86.asf", root / "skel" / "86.asf")
    (root / "cmu" / "86_02.mocapkit.toml").write_text("rate = 15  # every 8th frame of 86_01\n")
    shutil.copy(tests_data / "formats" / "ngimu.csv", root / "imu" / "ngimu.csv")
    shutil.copy(tests_data / "formats" / "legacy_xio.csv", root / "imu" / "legacy.csv")
    shutil.copy(tests_data / "formats" / "xsens_wrap.txt", root / "imu" / "wrap.txt")
    (root / "manifest.toml").write_text(MANIFEST)
    return root / "manifest.toml"


def test_global_rate_and_asf_do_not_turn_files_with_their_own_clock_or_skeleton_into_errors(tmp_path, tests_data):
    """``--rate 128 --asf 86.asf`` over a BVH, an IMU file with timestamps and one without: every row is ok;
    the option serves the file that lacks a clock, the others keep theirs and say so in a warning."""
    tree = tmp_path / "tree"
    tree.mkdir()
    shutil.copy(tests_data / "bvh" / "walk-meredith-60.bvh", tree / "walk.bvh")
    shutil.copy(tests_data / "formats" / "ngimu.csv", tree / "ngimu.csv")
    shutil.copy(tests_data / "formats" / "xsens_wrap.txt", tree / "wrap.txt")
    asf = tests_data / "cmu" / "86.asf"
    code, out, err = run("batch", "info", tree, "--rate", 128, "--asf", asf, "--out", tmp_path / "o", "-j", 2)
    assert code == 0, out + err
    rows = rows_by_name(tmp_path / "o")
    walk, ngimu, wrap = record(rows["walk.bvh"]), record(rows["ngimu.csv"]), record(rows["wrap.txt"])
    assert walk["rate_hz"] == pytest.approx(1 / 0.008333)
    assert ngimu["signals"]["ngimu"]["stated_rate_hz"] is None
    assert wrap["recording"]["rate_hz"] == 128.0
    assert "--rate 128 not used: the file gives its Frame Time" in walk["warnings"]
    assert any(w.startswith("--asf ") and "not used" in w for w in walk["warnings"])
    assert "--rate 128 not used: the file gives its time column 'Time (s)'" in ngimu["warnings"]
    assert not any("not used" in w for w in wrap["warnings"])
    assert json.loads(rows["walk.bvh"]["options_json"])["rate"] is None
    assert json.loads(rows["wrap.txt"]["options_json"])["rate"] == 128.0
    # compress of IMU data with a skeleton's options given for the whole batch: used by no IMU file
    code, out, err = run("batch", "compress", tree / "ngimu.csv", tree / "wrap.txt", "--max-angle", 2, "--rate", 128,
                         "--asf", asf, "--unit-cm", 2.54, "--out", tmp_path / "c", "-j", 2)
    assert code == 0, out + err
    assert {n: r["status"] for n, r in rows_by_name(tmp_path / "c").items()} == {"ngimu.csv": "ok", "wrap.txt": "ok"}


def test_mixed_tree_with_manifest_and_sidecar(catalog_url, tmp_path, tests_data):
    """Every row ok, each recording at its own rate in the catalog, the options each row used shown by
    ``catalog query``; the sidecar and the manifest are no inputs; --resume keeps every row."""
    tree = tmp_path / "tree"
    manifest = mixed_tree(tree, tests_data)
    args = ("batch", "info", tree, "--rate", 128, "--manifest", manifest, "--out", tmp_path / "o", "--db", catalog_url,
            "-j", 2)
    code, out, err = run(*args)
    assert code == 0, out + err
    rows = rows_by_name(tmp_path / "o")
    assert set(rows) == {"walk.bvh", "86_01.amc", "86_02.amc", "ngimu.csv", "legacy.csv", "wrap.txt"}
    assert all(r["status"] == "ok" for r in rows.values())
    skipped = out[out.index("skipped:"):]
    assert f"{tree / 'cmu' / '86_02.mocapkit.toml'}: reading options" in skipped
    assert f"{manifest}: the batch's manifest" in skipped
    asf = str(tree / "skel" / "86.asf")
    expected = {  # rate in the catalog, reading options
        "walk.bvh": (pytest.approx(1 / 0.008333), {}),
        "86_01.amc": (120.0, {"asf": asf, "rate": 120.0}),  # the manifest (the command said 128)
        "86_02.amc": (15.0, {"asf": asf, "rate": 15.0}),  # the sidecar over the manifest
        "legacy.csv": (50.0, {"rate": 50.0}),  # the last matching manifest entry
        "ngimu.csv": (pytest.approx(record(rows["ngimu.csv"])["recording"]["rate_hz"]), {}),  # its own clock
        "wrap.txt": (128.0, {"rate": 128.0}),  # the command's option, for the file lacking a clock
    }
    got = {Path(p).name: (rate, json.loads(reading)) for p, rate, reading in
           query(catalog_url, "SELECT path, rate_hz, reading_json FROM recordings")}
    assert got == expected
    warned = record(rows["ngimu.csv"])["warnings"]
    assert f"rate = 100 ({manifest}:9) not used: the file gives its time column 'Time (s)'" in warned
    # the runs show the options each file ran with, and join their recording
    runs = {Path(p).name: (json.loads(o), rate) for p, o, rate in query(
        catalog_url, "SELECT r.path, r.options_json, rec.rate_hz FROM runs r JOIN recordings rec "
                     "ON rec.path = r.path AND rec.content_hash = r.content_hash "
                     "AND rec.reading_hash = r.reading_hash")}
    assert {n: (o["rate"], rate) for n, (o, rate) in runs.items()} == {
        n: (reading.get("rate"), rate) for n, (rate, reading) in expected.items()}
    code, shown, _ = run("catalog", "query", "SELECT path, rate_hz, reading_json FROM recordings ORDER BY path",
                         "--db", catalog_url, "--format", "json")
    assert code == 0
    assert {Path(r["path"]).name: json.loads(r["reading_json"]) for r in json.loads(shown)} == \
        {n: reading for n, (_, reading) in expected.items()}
    code, out, err = run(*args, "--resume")
    assert code == 0 and "6 kept from an earlier run" in out, out + err


def test_amc_read_at_another_rate_is_a_new_recording_never_an_overwrite(catalog_url, tmp_path, tests_data):
    """The same AMC bytes registered at 120 Hz, then at 60 Hz: two recording rows, the first unchanged."""
    tree = tmp_path / "tree"
    tree.mkdir()
    shutil.copy(tests_data / "cmu" / "86_01_first60.amc", tree / "86_01.amc")
    shutil.copy(tests_data / "cmu" / "86.asf", tree / "86.asf")
    assert run("batch", "info", tree, "--out", tmp_path / "a", "--db", catalog_url, "-j", 1)[0] == 0
    first = query(catalog_url, "SELECT rate_hz, frames, duration_s, registered_at FROM recordings")
    assert [r[:3] for r in first] == [(120.0, 60, 0.5)]
    assert run("batch", "info", tree, "--rate", 60, "--out", tmp_path / "b", "--db", catalog_url, "-j", 1)[0] == 0
    rows = query(catalog_url, "SELECT rate_hz, frames, duration_s, registered_at FROM recordings ORDER BY rate_hz")
    assert rows == [(60.0, 60, 1.0, rows[0][3]), first[0]]
    assert len(query(catalog_url, "SELECT run_id FROM runs")) == 2


def test_both_bounds_in_one_batch_each_applied_to_its_kind(tmp_path, tests_data):
    """``--max-angle`` bounds the IMU files, ``--max-position-error`` the skeletons; a sidecar's bound
    replaces the command's for its file; each output is checked against its own bound."""
    tree = tmp_path / "tree"
    tree.mkdir()
    shutil.copy(tests_data / "cmu" / "86_01_15hz_first1600.amc", tree / "86_02.amc")
    shutil.copy(tests_data / "cmu" / "86.asf", tree / "86.asf")
    (tree / "86_02.mocapkit.toml").write_text("rate = 15\nmax_position_error = 2.5\n")
    shutil.copy(tests_data / "formats" / "ngimu.csv", tree / "ngimu.csv")
    shutil.copy(tests_data / "formats" / "xsens_wrap.txt", tree / "wrap.txt")
    (tree / "wrap.mocapkit.toml").write_text("max_angle = 0.5\nmax_position_error = 3.0\n")
    code, out, err = run("batch", "compress", tree, "--max-angle", 2, "--max-position-error", 1, "--rate", 128,
                         "--out", tmp_path / "o", "-j", 2)
    assert code == 0, out + err
    rows = rows_by_name(tmp_path / "o")
    bounds = {n: [(o["bound"], o["bound_unit"]) for o in record(r)["outputs"]] for n, r in rows.items()}
    assert bounds == {"86_02.amc": [(2.5, "cm")], "ngimu.csv": [(2.0, "deg")], "wrap.txt": [(0.5, "deg")]}
    amc = record(rows["86_02.amc"])
    assert amc["max_position_error_cm"] <= 2.5
    for n, bound in (("ngimu.csv", 2.0), ("wrap.txt", 0.5)):
        assert all(s["max_deg"] <= bound for s in record(rows[n])["signals"])
    opts = {n: json.loads(r["options_json"]) for n, r in rows.items()}
    assert (opts["86_02.amc"]["max_angle"], opts["ngimu.csv"]["max_position_error"]) == (None, None)
    assert any(w.startswith(f"max_position_error = 3 ({tree / 'wrap.mocapkit.toml'}:2) not used: it is for skeletons")
               for w in record(rows["wrap.txt"])["warnings"])
    # without a bound for its kind, an input is skipped with the reason, as before
    shutil.copy(tests_data / "bvh" / "walk-meredith-60.bvh", tree / "walk.bvh")
    code, out, err = run("batch", "compress", tree / "ngimu.csv", tree / "walk.bvh", "--max-angle", 2, "--out",
                         tmp_path / "p", "-j", 1)
    assert code == 0, out + err
    assert f"{tree / 'walk.bvh'}: --max-angle is a bound for IMU data; skeletons take --max-position-error CM" in out
    assert set(rows_by_name(tmp_path / "p")) == {"ngimu.csv"}


def _trc_tree(tmp_path: Path, tests_data: Path) -> tuple[Path, Path]:
    tree, out = tmp_path / "tree", tmp_path / "out"
    for d in ("a", "b", "c"):
        (tree / d).mkdir(parents=True)
        (out / d).mkdir(parents=True)
    for p in ("a/walk.trc", "b/other.trc", "c/third.trc"):
        shutil.copy(tests_data / "opensim" / "walk_free_01-first20.trc", tree / p)
    return tree, out


def test_an_output_linked_onto_another_input_of_the_batch_is_refused(tmp_path, tests_data):
    """``OUT/a/walk.filtered.csv`` is a symlink to the input ``b/other.trc``: that input gets an error row
    and the target keeps its bytes; the other inputs run."""
    tree, out = _trc_tree(tmp_path, tests_data)
    os.symlink(tree / "b" / "other.trc", out / "a" / "walk.filtered.csv")
    before = (tree / "b" / "other.trc").read_bytes()
    code, stdout, err = run("batch", "filter", tree, "--penalty", 1, "--out", out, "-j", 1)
    assert code == 1, stdout + err
    rows = rows_by_name(out)
    assert rows["other.trc"]["status"] == "ok" and rows["third.trc"]["status"] == "ok"
    assert rows["walk.trc"]["error"] == (f"{out / 'a' / 'walk.filtered.csv'}: "
                                         f"is (a link to) {tree / 'b' / 'other.trc'}, "
                                         "an input of this batch; remove it from the output folder")
    assert (tree / "b" / "other.trc").read_bytes() == before


def test_an_output_linked_onto_the_manifest_or_a_sidecar_is_refused(tmp_path, tests_data):
    tree, out = _trc_tree(tmp_path, tests_data)
    manifest = tree / "m.toml"
    manifest.write_text('[[files]]\nglob = "*/*.trc"\nrate = 100\n')
    side = tree / "b" / "other.mocapkit.toml"
    side.write_text("rate = 100\n")
    os.symlink(manifest, out / "a" / "walk.filtered.csv")
    os.link(side, out / "b" / "other.filtered.csv")  # a hard link too
    before = {p: p.read_bytes() for p in (manifest, side)}
    code, stdout, err = run("batch", "filter", tree, "--penalty", 1, "--manifest", manifest, "--out", out, "-j", 1)
    assert code == 1, stdout + err
    rows = rows_by_name(out)
    assert rows["third.trc"]["status"] == "ok"
    assert str(manifest) in rows["walk.trc"]["error"] and str(side) in rows["other.trc"]["error"]
    assert {p: p.read_bytes() for p in before} == before


def test_a_points_folder_linked_onto_a_folder_of_inputs_is_refused(tmp_path, tests_data):
    tree, out = tmp_path / "tree", tmp_path / "out"
    (tree / "a").mkdir(parents=True)
    (tree / "b").mkdir()
    shutil.copy(tests_data / "formats" / "ngimu.csv", tree / "a" / "ngimu.csv")
    shutil.copy(tests_data / "formats" / "ngimu.csv", tree / "b" / "ngimu.csv")
    (tree / "notes.md").write_text("two takes\n")  # (without it, the tree would be one sensor folder)
    (out / "a").mkdir(parents=True)
    os.symlink(tree / "b", out / "a" / "ngimu.points")  # the points would land on b/ngimu.csv
    before = (tree / "b" / "ngimu.csv").read_bytes()
    code, stdout, err = run("batch", "compress", tree, "--max-angle", 2, "--out", out, "-j", 1)
    assert code == 1, stdout + err
    from mocapkit.batch.results import read_results

    errors = [r for r in read_results(out / "results.parquet") if r["status"] == "error"]
    assert [r["input"] for r in errors] == [str(tree / "a" / "ngimu.csv")]
    assert "an input of this batch" in errors[0]["error"]
    assert (tree / "b" / "ngimu.csv").read_bytes() == before


# --------------------------------------------------------------------------------------------------
# bad manifests and sidecars: one line naming the file, the line and the key, before any work
# --------------------------------------------------------------------------------------------------

BAD_MANIFESTS = [
    ('[[files]]\nglob = "*.bvh"\nrte = 120\n', 3, "files[1]: unknown key 'rte'"),
    ('[[files]]\nglob = "*.bvh"\nrate = "fast"\n', 3, "files[1]: rate = 'fast': must be a number"),
    ('[[files]]\nglob = "*.bvh"\n\n[[files]]\nglob = "*.bvh"\nrate = -5\n', 6, "files[2]: rate = -5: must be a finite"),
    ('[[files]]\nglob = "*.bvh"\nrate = true\n', 3, "rate = True: must be a number"),
    ('[[files]]\nglob = "*.bvh"\nmax_angle = 180\n', 3, "max_angle = 180: must be a finite number > 0 and < 180"),
    ('[[files]]\nglob = "*.bvh"\nasf = "../nope.asf"\n', 3, "asf = '../nope.asf':"),
    ('[[files]]\nglob = "*.bvh"\nasf = "sub"\n', 3, "is not a regular file"),
    ('[[files]]\nglob = "*.bvhh"\n', 2, "files[1]: glob = '*.bvhh' matches no file"),
    ('[[files]]\nrate = 120\n', 1, "files[1]: give exactly one of glob"),
    ('[[files]]\nglob = "*.bvh"\ntime_unit = "hours"\n', 3, "must be one of s, ms, us, ns, counter"),
    ('[[files]]\nglob = "*.bvh"\nscalar_last = "yes"\n', 3, "must be true or false"),
    ('[[files]]\nglob = "*.bvh"\nquaternion_columns = "W,X"\n', 3, "must be four column names"),
    ('[[files]\nglob = "*.bvh"\n', 1, "not valid TOML"),
    ('rate = 5\n', 1, "unknown top-level key 'rate'"),
]


@pytest.mark.parametrize("text, line, words", BAD_MANIFESTS)
def test_bad_manifest_is_one_line_naming_file_line_and_key(tmp_path, tests_data, text, line, words):
    tree = tmp_path / "tree"
    (tree / "sub").mkdir(parents=True)
    shutil.copy(tests_data / "bvh" / "walk-meredith-60.bvh", tree / "walk.bvh")
    manifest = tree / "m.toml"
    manifest.write_text(text)
    code, out, err = run("batch", "info", tree, "--manifest", manifest, "--out", tmp_path / "o")
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith(f"error: {manifest}:{line}: "), err
    assert words in err
    assert not (tmp_path / "o").exists()  # before any work


@pytest.mark.parametrize("text, line, words", [
    ("rate = 0\n", 1, "rate = 0: must be a finite number >= 1e-06"),
    ("# the take's clock\nrate = 120\nglob = \"*.amc\"\n", 3, "unknown key 'glob'"),
    ("[files]\nrate = 1\n", 1, "a sidecar holds keys only"),
    ("asf = \"86.asf\"\n", 1, "is not a regular file"),
    ("rate = 1\xff\n", 1, "not UTF-8"),
])
def test_bad_sidecar_is_one_line_before_any_work(tmp_path, tests_data, text, line, words):
    tree = tmp_path / "tree"
    tree.mkdir()
    shutil.copy(tests_data / "bvh" / "walk-meredith-60.bvh", tree / "walk.bvh")
    shutil.copy(tests_data / "cmu" / "86_01_first60.amc", tree / "86_01.amc")
    side = tree / "86_01.mocapkit.toml"
    side.write_bytes(text.encode("latin-1"))
    code, out, err = run("batch", "info", tree, "--out", tmp_path / "o")
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith(f"error: {side}:{line}: "), err
    assert words in err
    assert not (tmp_path / "o").exists()


def test_version_1_catalog_is_upgraded_keeping_its_rows(catalog_url, tmp_path, tests_data):
    """A catalog written before reading options were kept opens as version 2: its recordings keep their
    values (reading_hash 'v1', reading_json NULL) and still join their runs; new rows are added beside."""
    v1 = [
        "CREATE TABLE schema_version (version BIGINT NOT NULL)",
        "INSERT INTO schema_version (version) VALUES (1)",
        "CREATE TABLE recordings (path TEXT NOT NULL, content_hash TEXT NOT NULL, format TEXT, kind TEXT, "
        "rate_hz DOUBLE PRECISION, frames BIGINT, duration_s DOUBLE PRECISION, subject TEXT, take TEXT, bytes BIGINT, "
        "registered_at TIMESTAMP, PRIMARY KEY (path, content_hash))",
        "CREATE TABLE channels (path TEXT NOT NULL, content_hash TEXT NOT NULL, idx BIGINT NOT NULL, name TEXT, "
        "component TEXT, type TEXT, tracked_point TEXT, units TEXT, PRIMARY KEY (path, content_hash, idx))",
        "CREATE TABLE runs (run_id TEXT NOT NULL, job TEXT, method TEXT, path TEXT, content_hash TEXT, "
        "options_json TEXT, options_hash TEXT, mocapkit_version TEXT, started_at TIMESTAMP, seconds DOUBLE PRECISION, "
        "status TEXT, error TEXT, warnings TEXT, PRIMARY KEY (run_id))",
        "CREATE INDEX runs_recording ON runs (path, content_hash)",
        "INSERT INTO recordings VALUES ('/x/86_01.amc', 'h1', 'amc', 'skeletal', 120, 60, 0.5, '86', '01', 10, "
        "TIMESTAMP '2025-01-02 03:04:05')",
        "INSERT INTO channels VALUES ('/x/86_01.amc', 'h1', 0, 'root_Xposition', 'x', 'POS', 'root', 'cm')",
        "INSERT INTO runs VALUES ('r1', 'info', NULL, '/x/86_01.amc', 'h1', '{}', 'oh', '0.1', "
        "TIMESTAMP '2025-01-02 03:04:05', 1.0, 'ok', NULL, NULL)",
    ]
    if catalog_url.startswith("postgresql"):
        import psycopg

        with psycopg.connect(catalog_url, autocommit=True) as c:
            for s in v1:
                c.execute(s)
    else:
        import duckdb

        c = duckdb.connect(catalog_url)
        for s in v1:
            c.execute(s)
        c.close()
    got = query(catalog_url, "SELECT rec.path, rec.reading_hash, rec.reading_json, rec.rate_hz, rec.frames, "
                             "ch.name, r.run_id FROM recordings rec JOIN channels ch USING (path, content_hash, "
                             "reading_hash) JOIN runs r USING (path, content_hash, reading_hash)")
    assert got == [("/x/86_01.amc", "v1", None, 120.0, 60, "root_Xposition", "r1")]
    assert query(catalog_url, "SELECT version FROM schema_version") == [(2,)]
    tree = tmp_path / "tree"
    tree.mkdir()
    shutil.copy(tests_data / "cmu" / "86_01_first60.amc", tree / "86_01.amc")
    shutil.copy(tests_data / "cmu" / "86.asf", tree / "86.asf")
    assert run("batch", "info", tree, "--out", tmp_path / "o", "--db", catalog_url, "-j", 1)[0] == 0
    assert len(query(catalog_url, "SELECT path FROM recordings")) == 2


def test_compress_with_bounds_only_in_the_manifest_skips_the_files_without_one(tmp_path, tests_data):
    tree = tmp_path / "tree"
    tree.mkdir()
    shutil.copy(tests_data / "formats" / "ngimu.csv", tree / "ngimu.csv")
    shutil.copy(tests_data / "bvh" / "walk-meredith-60.bvh", tree / "walk.bvh")
    (tree / "m.toml").write_text('[[files]]\nglob = "*.csv"\nmax_angle = 1.5\n')
    code, out, err = run("batch", "compress", tree, "--manifest", tree / "m.toml", "--out", tmp_path / "o", "-j", 1)
    assert code == 0, out + err
    assert f"{tree / 'walk.bvh'}: no bound for this file" in out
    rows = rows_by_name(tmp_path / "o")
    assert set(rows) == {"ngimu.csv"}
    assert [o["bound"] for o in record(rows["ngimu.csv"])["outputs"]] == [1.5]
    # without a manifest, the command still asks for a control
    code, _, err = run("batch", "compress", tree, "--out", tmp_path / "p")
    assert code == 2 and "exactly one of" in err


# --------------------------------------------------------------------------------------------------
# precedence as a property: sidecar > last matching manifest entry > the command's option; a file's own
# clock over all of them
# --------------------------------------------------------------------------------------------------

RATES = st.one_of(st.none(), st.sampled_from([25.0, 50.0, 60.0, 100.0, 120.0]))
NAMES = ("86_01.amc", "legacy.csv", "ngimu.csv", "walk.bvh")
OWN_CLOCK = {"ngimu.csv": "its time column 'Time (s)'", "walk.bvh": "its Frame Time"}


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(command=RATES, entries=st.lists(st.tuples(st.sampled_from(["*", *NAMES]), RATES), max_size=3),
       sidecars=st.fixed_dictionaries({n: RATES for n in NAMES}))
def test_rate_precedence_property(tmp_path, tests_data, command, entries, sidecars):
    from mocapkit.batch.file_options import load_manifest, resolve

    tree = tmp_path / "prop"
    if not tree.exists():
        tree.mkdir()
        shutil.copy(tests_data / "cmu" / "86_01_first60.amc", tree / "86_01.amc")
        shutil.copy(tests_data / "cmu" / "86.asf", tree / "86.asf")
        shutil.copy(tests_data / "formats" / "legacy_xio.csv", tree / "legacy.csv")
        shutil.copy(tests_data / "formats" / "ngimu.csv", tree / "ngimu.csv")
        shutil.copy(tests_data / "bvh" / "walk-meredith-60.bvh", tree / "walk.bvh")
    text = "".join(f'[[files]]\n{"glob" if g == "*" else "path"} = "{g}"\n' + (f"rate = {r}\n" if r else "")
                   for g, r in entries)
    (tree / "m.toml").write_text(text)
    for n, r in sidecars.items():
        side = tree / (Path(n).stem + ".mocapkit.toml")
        side.unlink(missing_ok=True)
        if r is not None:
            side.write_text(f"rate = {r}\n")
    manifest = load_manifest(tree / "m.toml")
    for n in NAMES:
        fo = resolve("info", tree / n, {"rate": command, "asf": None}, manifest)
        wanted = sidecars[n]
        if wanted is None:
            wanted = next((r for g, r in reversed(entries) if g in ("*", n) and r is not None), command)
        if n in OWN_CLOCK:
            assert fo.options["rate"] is None
            if wanted is None:
                assert fo.notes == []
            else:
                (note,) = fo.notes
                assert note.startswith((f"--rate {wanted:g} not used", f"rate = {wanted:g} ("))
                assert note.endswith(f"not used: the file gives {OWN_CLOCK[n]}")
        else:
            assert fo.options["rate"] == wanted and fo.notes == []


def test_catalog_query_on_a_version_1_catalog_says_how_it_is_upgraded(tmp_path):
    """``catalog query`` opens read-only, so it cannot upgrade: it says which command will, and writes nothing."""
    import duckdb

    url = str(tmp_path / "v1.duckdb")
    c = duckdb.connect(url)
    c.execute("CREATE TABLE schema_version (version BIGINT NOT NULL)")
    c.execute("INSERT INTO schema_version (version) VALUES (1)")
    c.close()
    before = Path(url).read_bytes()
    code, out, err = run("catalog", "query", "--db", url, "SELECT 1")
    assert code == 2 and "upgraded in place by the next command that writes to it" in err, err
    assert Path(url).read_bytes() == before
