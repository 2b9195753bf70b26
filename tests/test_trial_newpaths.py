"""Issue 10 trial on the paths added since: ``.mkp`` radio packets, ``.mkc`` clips, ``verify``, ``catalog
query``, ``batch`` manifests and sidecars, glTF buffer URIs and sensor names read from a file.

Every command runs in a child of the clean server process (``trial.server``). The oracle's new rules are
tested on hand-made runs first (so a clean campaign means something): ``verify`` may exit 1 only when its
record says the bound is exceeded, and its error must equal an independent SLERP decode (scipy); a
damaged ``.mkp`` must be reported; a file may not appear outside the output folder.
"""

from __future__ import annotations

import base64
import hashlib
import json
import os
import random
import shutil
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from trial import cases, checks, oracle, server
from trial.runner import Run

pytestmark = pytest.mark.skipif(os.name != "posix", reason="the trial forks")

FAST = settings(max_examples=8, deadline=None, suppress_health_check=list(HealthCheck))


@pytest.fixture(scope="module")
def trial():
    return server.shared_client()


@pytest.fixture(scope="module")
def made(tmp_path_factory, tests_data, trial) -> dict[str, Path]:
    """An IMU original, its points CSV, .mkp and tick points CSV; a BVH, its .gltf and .mkc; a catalog."""
    d = tmp_path_factory.mktemp("newpaths")
    imu = d / "Quaternion.csv"
    shutil.copyfile(tests_data / "xio" / "pelvis" / "Quaternion.csv", imu)
    bvh = d / "walk.bvh"
    shutil.copyfile(tests_data / "bvh" / "walk-meredith-60.bvh", bvh)
    out = {"imu": imu, "bvh": bvh, "points": d / "p.csv", "mkp": d / "x.mkp", "ticks": d / "pts.csv",
           "gltf": d / "c.gltf", "catalog": d / "catalog.duckdb", "mkc": d / "c.mkc"}
    for argv in (["compress", imu, "-t", "0.001", "-o", out["points"]],
                 ["compress", imu, "--max-angle", "2", "-o", out["mkp"]],
                 ["decompress", out["mkp"], "-o", out["ticks"]],
                 ["compress", bvh, "-o", out["gltf"], "-t", "0.01", "--unit-cm", "1"],
                 ["catalog", "import", imu, bvh, "--db", out["catalog"]],
                 ["compress", bvh, "--max-position-error", "2", "-o", out["mkc"]]):
        checks.assert_ok(trial.run(argv, timeout=300))
    return out


def _run(rc, out="", err="", argv=("verify", "a.csv", "b.csv", "--json")) -> Run:
    return Run(list(argv), rc, None, out.encode(), err.encode(), 0.1, 10.0)


# --------------------------------------------------------------------------------------------------
# the oracle's new rules, on hand-made runs
# --------------------------------------------------------------------------------------------------


def test_verify_exit_1_counts_only_with_a_bound_exceeded():
    assert oracle.classify_run(_run(1, json.dumps({"within_bound": False, "max_error": 3, "bound": 2})),
                               [])[0] == "exceeded"
    assert oracle.classify_run(_run(1, json.dumps({"within_bound": True})), [])[0] == "crash"
    assert oracle.classify_run(_run(1, "{nope"), [])[0] == "crash"
    text = ("verify", "a.csv", "b.csv", "--max-angle", "1")
    assert oracle.classify_run(_run(1, "b.csv: max angle error 2°; bound 1°: EXCEEDED\n", argv=text), [])[0] == \
        "exceeded"
    assert oracle.classify_run(_run(1, "", "something\n", argv=text), [])[0] == "crash"
    assert oracle.classify_run(_run(1, json.dumps({"within_bound": False}), argv=("info", "x")), [])[0] == "crash"


def test_batch_exit_1_is_partial_only_with_error_rows():
    argv = ("batch", "compress", "t", "--out", "o")
    assert oracle.classify_run(_run(1, "", "batch compress: 2 ok, 1 errors, 0 skipped in 3 s\n", argv=argv),
                               [])[0] == "partial"
    assert oracle.classify_run(_run(1, "", "batch compress: 3 ok, 0 errors\n", argv=argv), [])[0] == "crash"


def test_damage_reported_reads_counts_and_loss_lines():
    assert oracle.damage_reported(_run(0, "", "x.mkp: 1 sensor -> d.csv; 1 packets lost, 0 damaged\n"))
    assert oracle.damage_reported(_run(0, '{"damaged_packets": 2, "lost_packets": 0}'))
    assert oracle.damage_reported(_run(0, "", "warning: x.mkp: packet 3 (byte 40, 12 bytes): CRC; dropped\n"))
    assert not oracle.damage_reported(_run(0, "", "x.mkp: 1 sensor -> d.csv; 0 packets lost, 0 damaged\n"))
    assert not oracle.damage_reported(_run(0, '{"damaged_packets": 0, "lost_packets": 0, "warnings": []}'))


def test_written_outside_lists_files_outside_the_output_folder(tmp_path):
    case = cases.Case("c", "paths", "x", "sto", tmp_path, ["compress"], outputs=[tmp_path / "out" / "sensors"])
    (tmp_path / "out").mkdir()
    case.confined = tmp_path / "out" / "sensors"
    before = cases._entries(tmp_path)
    (tmp_path / "out" / "sensors").mkdir()
    (tmp_path / "out" / "sensors" / "a.csv").write_text("x")
    assert cases._written_outside(case, before) == []
    (tmp_path / "victim.csv").write_text("x")
    (tmp_path / "out" / "b.csv").write_text("x")
    assert sorted(cases._written_outside(case, before)) == [str(tmp_path / "out" / "b.csv"),
                                                           str(tmp_path / "victim.csv")]


def test_verify_reference_agrees_with_verify_and_catches_a_wrong_record(trial, made):
    for comp in ("points", "ticks"):
        r = trial.run(["verify", made["imu"], made[comp], "--max-angle", "3", "--json"])
        checks.assert_ok(r)
        rec = json.loads(r.out_text)
        ref = oracle.verify_reference(str(made["imu"]), str(made[comp]))
        assert ref["status"] == "ok" and ref["compared"] == 300
        assert oracle.verify_disagreement(rec, ref, 3.0) is None
        assert oracle.verify_disagreement({**rec, "max_error": rec["max_error"] + 1e-3}, ref, 3.0)
        assert oracle.verify_disagreement({**rec, "compared_samples": 299}, ref, 3.0)
        lower = ref["max_deg"] / 2  # a record claiming "within" a bound the decode exceeds
        assert oracle.verify_disagreement({**rec, "within_bound": True}, ref, lower)


def _with_point_changed(src: Path, dst: Path, row: int, col: int, delta: float) -> None:
    lines = src.read_text().splitlines()
    cells = lines[row].split(",")
    cells[col] = repr(float(cells[col]) + delta)
    lines[row] = ",".join(cells)
    dst.write_text("\n".join(lines) + "\n")


@given(row=st.integers(1, 25), col=st.integers(1, 4), delta=st.floats(-0.5, 0.5),
       bound=st.sampled_from([1.0, 2.0, 5.0]), ticks=st.booleans())
@FAST
def test_verify_on_a_mutated_points_csv_equals_an_independent_decode(trial, made, tmp_path_factory, row, col, delta,
                                                                      bound, ticks):
    """A point of the compressed file moved: verify's max error and its verdict are those of scipy's SLERP
    of the file's points at the original's samples (exit 1 exactly when that exceeds the bound)."""
    src = made["ticks" if ticks else "points"]
    dst = tmp_path_factory.mktemp("verify") / src.name
    _with_point_changed(src, dst, row, col, delta)
    r = trial.run(["verify", made["imu"], dst, "--max-angle", str(bound), "--json"])
    got = checks.outcome(r)
    ref = oracle.verify_reference(str(made["imu"]), str(dst))
    if got == "error":
        return  # refused (a point that is no rotation...)
    assert got in ("ok", "exceeded"), checks.describe(r)
    rec = json.loads(r.out_text)
    assert oracle.verify_disagreement(rec, ref, bound) is None, checks.describe(r)
    if ref["status"] == "ok":
        assert (got == "exceeded") == (ref["max_deg"] > bound), (ref, rec["max_error"])


# --------------------------------------------------------------------------------------------------
# .mkp and .mkc: every byte under a CRC
# --------------------------------------------------------------------------------------------------


@given(seed=st.integers(0, 10**6), cmd=st.sampled_from(["points", "decode", "info", "verify"]))
@FAST
def test_mkp_mutation_is_reported_refused_or_harmless(trial, made, tmp_path_factory, seed, cmd):
    data = bytearray(made["mkp"].read_bytes())
    rng = random.Random(seed)
    for _ in range(rng.randint(1, 4)):
        data[rng.randrange(len(data))] = rng.randrange(256)
    d = tmp_path_factory.mktemp("mkp")
    f = d / "m.mkp"
    f.write_bytes(bytes(data))
    argv = {"points": ["decompress", f, "-o", d / "p.csv"], "decode": ["decompress", f, "-o", d / "d.csv",
                                                                      "--times-from", made["imu"]],
            "info": ["info", f, "--json"], "verify": ["verify", made["imu"], f, "--max-angle", "2", "--json"]}[cmd]
    r = trial.run(argv)
    got = checks.outcome(r, "m.mkp")
    assert got in ("ok", "error", "exceeded"), checks.describe(r)
    if got != "error":
        rep = trial.digest(f, "mkp")
        ref = trial.digest(made["mkp"], "mkp")
        assert rep["status"] == "ok"
        if rep["warnings"]:
            assert oracle.damage_reported(r), f"packets lost but not said: {rep['warnings']}\n{checks.describe(r)}"
        else:
            assert oracle.same_data(rep, ref), "a .mkp read as other points without a damaged packet"


@pytest.mark.parametrize("where", ["header", "middle", "last"])
def test_mkc_byte_flip_is_refused(trial, made, tmp_path, where):
    data = bytearray(made["mkc"].read_bytes())
    k = {"header": 20, "middle": len(data) // 2, "last": len(data) - 6}[where]
    data[k] ^= 0x5A
    bad = tmp_path / "bad.mkc"
    bad.write_bytes(bytes(data))
    for argv in (["decompress", bad, "-o", tmp_path / "d.bvh"], ["info", bad, "--json"]):
        checks.assert_clean_error(trial.run(argv), "bad.mkc")


# --------------------------------------------------------------------------------------------------
# catalog query: hostile SQL never writes
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("sql", [
    "COPY recordings TO '{cwd}/x.csv'", "ATTACH '{cwd}/y.duckdb' AS y", "INSTALL httpfs", "LOAD httpfs",
    "PRAGMA enable_profiling", "CREATE TABLE t(a INT)", "INSERT INTO recordings SELECT * FROM recordings",
    "SET threads=1", "SELECT * FROM read_csv('{cwd}/../victim.csv')", "SELECT 1; DROP TABLE recordings", " ",
    "EXPLAIN ANALYZE DELETE FROM recordings", "WITH x AS (SELECT 1) DELETE FROM recordings", "CHECKPOINT",
    "EXPORT DATABASE '{cwd}/exp'", "SELECT '" + "x" * 100000 + "'", "SELECT " + "9" * 5000,
    "SELECT 'NaN'::DOUBLE", "SELECT * FROM recordings",
])
def test_catalog_query_keeps_the_catalog_byte_identical(trial, made, tmp_path, sql):
    cat = tmp_path / "catalog.duckdb"
    shutil.copyfile(made["catalog"], cat)
    (tmp_path / "victim.csv").write_text("a\n1\n")
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    before = hashlib.sha256(cat.read_bytes()).hexdigest()
    listing = sorted(p.name for p in tmp_path.rglob("*"))
    r = trial.run(["catalog", "query", "--db", cat, sql.replace("{cwd}", str(cwd)), "--format", "json"], cwd=cwd)
    got = checks.outcome(r, "catalog.duckdb", "--db", "sql")
    assert got in ("ok", "error"), checks.describe(r)
    if got == "ok":
        oracle.strict_json(r.out_text)
    assert hashlib.sha256(cat.read_bytes()).hexdigest() == before, "the catalog changed"
    assert sorted(p.name for p in tmp_path.rglob("*")) == listing, "a query wrote a file"


# --------------------------------------------------------------------------------------------------
# batch manifests and sidecars: checked before any work
# --------------------------------------------------------------------------------------------------


@pytest.fixture
def tree(tmp_path, tests_data) -> Path:
    t = tmp_path / "tree"
    (t / "cmu").mkdir(parents=True)
    shutil.copyfile(tests_data / "cmu" / "86.asf", t / "cmu" / "86.asf")
    shutil.copyfile(tests_data / "cmu" / "86_01_first60.amc", t / "cmu" / "86_01_first60.amc")
    return t


@pytest.mark.parametrize("line", ['asf = "{fifo}"', 'asf = "/dev/zero"', 'asf = "{zero_link}"', 'glob = "../../*"',
                                  "rate = " + "[" * 3000 + "]" * 3000, "rate = 1e999", 'rate = "fast"',
                                  "foo = 1", 'asf = "/"'])
@pytest.mark.parametrize("where", ["manifest", "sidecar"])
def test_hostile_manifest_or_sidecar_stops_the_batch_before_any_work(trial, tree, tmp_path, line, where):
    fifo = tmp_path / "asf.fifo"
    os.mkfifo(fifo)
    (tmp_path / "zero.asf").symlink_to("/dev/zero")
    line = line.replace("{fifo}", str(fifo)).replace("{zero_link}", str(tmp_path / "zero.asf"))
    argv = ["batch", "compress", tree, "--out", tmp_path / "out", "-j", "1", "-t", "0.01"]
    if where == "manifest":
        m = tmp_path / "m.toml"
        m.write_text(f'[[files]]\nglob = "tree/cmu/*.amc"\n{line}\n')
        argv += ["--manifest", m]
    else:
        (tree / "cmu" / "86_01_first60.mocapkit.toml").write_text(line + "\n")
    r = trial.run(argv, timeout=120)
    checks.assert_clean_error(r, "m.toml", "86_01_first60.mocapkit.toml", "--manifest")
    assert not [p for p in (tmp_path / "out").rglob("*") if p.is_file()], "work was written before the error"


# --------------------------------------------------------------------------------------------------
# glTF buffer URIs and sensor names: no hang, no file outside the output folder
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("uri", ["/dev/zero", "{fifo}", "../x.bin", "{abs}", "file:///dev/zero", ".",
                                 "/proc/self/mem", "{huge_length}", "{long_data}"])
@pytest.mark.parametrize("command", ["info", "decompress"])
def test_hostile_gltf_buffer_uri_is_a_clean_error_or_the_clip(trial, made, tmp_path, uri, command):
    doc = json.loads(made["gltf"].read_text())
    buf = doc["buffers"][0]
    head, _, b64 = buf["uri"].partition(",")
    raw = base64.b64decode(b64)
    d = tmp_path / "in"
    d.mkdir()
    (d / "clip.bin").write_bytes(raw)
    (tmp_path / "x.bin").write_bytes(raw)
    fifo = d / "b.fifo"
    os.mkfifo(fifo)
    value = uri.replace("{fifo}", str(fifo)).replace("{abs}", str(d / "clip.bin"))
    if uri == "{huge_length}":
        value, buf["byteLength"] = "clip.bin", 10**15
    elif uri == "{long_data}":
        value = head + "," + base64.b64encode(raw + b"\0" * 4096).decode()
    buf["uri"] = value
    f = d / "clip.gltf"
    f.write_text(json.dumps(doc))
    argv = {"info": ["info", f, "--json"], "decompress": ["decompress", f, "-o", tmp_path / "d.bvh"]}[command]
    r = trial.run(argv, timeout=8)
    got = checks.outcome(r, "clip.gltf")
    assert got not in oracle.FAILING, f"{got}: {checks.describe(r)}"
    if got == "ok":
        checks.assert_ok(r)


@pytest.mark.parametrize("names", [["../victim"], ["../../victim"], ["{abs}/abs"], [".."], ["a/b"],
                                   ["victim/../../../v2"], ["", "."], ["pelvis_imu"], ["/"]])
def test_sensor_names_from_a_sto_never_leave_the_output_folder(trial, tests_data, tmp_path, names):
    src = (tests_data / "opensim" / "myComplexTasksTrial_orientations.sto").read_text().split("\n")
    k = next(n for n, ln in enumerate(src) if ln.startswith("time\t"))
    cols = src[k].split("\t")
    work = tmp_path / "w"
    (work / "in").mkdir(parents=True)
    (work / "out").mkdir()
    for j, name in enumerate(names, start=2):
        cols[j] = name.replace("{abs}", str(work))
    src[k] = "\t".join(cols)
    sto = work / "in" / "t.sto"
    sto.write_text("\n".join(src))
    before = {str(p) for p in work.rglob("*")}
    folder = work / "out" / "sensors"
    r = trial.run(["compress", sto, "-t", "0.001", "-o", folder], cwd=work / "in")
    checks.assert_no_failure(r, "t.sto")
    new = {str(p) for p in work.rglob("*")} - before
    outside = sorted(p for p in new if not p.startswith(str(folder)))
    assert not outside, f"written outside {folder}: {outside}"
    if r.returncode == 0:
        assert len([p for p in folder.iterdir() if p.suffix == ".csv"]) == len(cols) - 1



@pytest.mark.parametrize("db", ["fifo", "/dev/zero", "/dev/null"])
def test_catalog_that_is_a_fifo_or_a_device_is_refused_at_once(trial, tmp_path, db):
    """A FIFO as ``--db`` made ``catalog query`` wait forever for a writer."""
    if db == "fifo":
        db = tmp_path / "catalog.duckdb"
        os.mkfifo(db)
    r = trial.run(["catalog", "query", "--db", db, "SELECT 1"], timeout=15, cwd=tmp_path)
    checks.assert_clean_error(r, Path(db).name, "--db")


def test_catalog_table_of_one_huge_value_stays_small(trial, made, tmp_path):
    """A 20 MB value in the table view: rich folded all of it into the table (100 MB took a minute and ran
    out of a 2 GB address space); CSV keeps it whole."""
    sql = "SELECT repeat('x', 20000000) AS big, 1 AS n"
    r = trial.run(["catalog", "query", "--db", made["catalog"], sql], timeout=30, cwd=tmp_path)
    checks.assert_ok(r)
    assert r.seconds < 10 and len(r.stdout) < 100_000, (r.seconds, len(r.stdout))
    assert "20000000 characters" in r.out_text
    r = trial.run(["catalog", "query", "--db", made["catalog"], sql, "--format", "csv"], timeout=30, cwd=tmp_path)
    checks.assert_ok(r)
    assert r.out_text.splitlines()[1] == "x" * 20_000_000 + ",1"
