"""The motion catalog on DuckDB and on a real PostgreSQL server (``MOCAPKIT_TEST_PG``, started by
``tools/pg_test_server.sh`` in CI; skipped with a reason where absent).

Batch rows are made the way the batch makes them (:func:`mocapkit.batch.worker.run_one`, which runs
:func:`mocapkit.jobs.run_job` on each input). Shown: the same queries give the same answers on both engines
and equal a computation made here from the rows; the catalog survives being reopened; adding rows again
duplicates nothing; a folder with corrupt files imports the good ones; the query command's three formats.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import shutil
import subprocess
import sys
import textwrap
import uuid
from collections import defaultdict
from pathlib import Path

import pytest

from cli_run import run as cli_run
from mocapkit.errors import MocapError

pytest.importorskip("duckdb")
pytest.importorskip("pyarrow")

ENGINES = ["duckdb", "postgresql"]
TABLES = ("recordings", "channels", "runs", "metrics", "segments", "filter_pieces", "outputs")


# ---------------------------------------------------------------------------------------------------
# fixtures
# ---------------------------------------------------------------------------------------------------


def _pg_base() -> str:
    url = os.environ.get("MOCAPKIT_TEST_PG")
    if not url:
        pytest.skip("MOCAPKIT_TEST_PG is not set (start a server: eval \"$(tools/pg_test_server.sh start)\")")
    psycopg = pytest.importorskip("psycopg")
    try:
        psycopg.connect(url, connect_timeout=3).close()
    except psycopg.Error as e:
        pytest.skip(f"PostgreSQL at MOCAPKIT_TEST_PG is unreachable: {str(e).splitlines()[0]}")
    return url


@contextlib.contextmanager
def _pg_schema():
    """A fresh schema on the test server; the URL selects it (libpq ``options=-csearch_path=...``)."""
    import psycopg

    base = _pg_base()
    name = "t_" + uuid.uuid4().hex[:12]
    with psycopg.connect(base, autocommit=True) as c:
        c.execute(f"CREATE SCHEMA {name}")
    try:
        yield base + ("&" if "?" in base else "?") + f"options=-csearch_path%3D{name}"
    finally:
        with psycopg.connect(base, autocommit=True) as c:
            c.execute(f"DROP SCHEMA {name} CASCADE")


@pytest.fixture(params=ENGINES)
def catalog_url(request, tmp_path):
    """A new, empty catalog on each engine."""
    if request.param == "duckdb":
        yield str(tmp_path / "motion.duckdb")
    else:
        with _pg_schema() as url:
            yield url


@pytest.fixture(scope="module")
def dataset(tmp_path_factory, tests_data):
    """A small database with CMU-style names (subject/take from the name) and the batch rows of several
    jobs over it, made by the batch's own worker function; plus a corrupt BVH, an empty file and a
    missing input, whose rows are errors."""
    from mocapkit.batch.worker import run_one

    root = tmp_path_factory.mktemp("db")
    shutil.copy(tests_data / "bvh" / "walk-meredith-60.bvh", root / "07_01.bvh")
    shutil.copy(tests_data / "bvh" / "perception-neuron-freya-12.bvh", root / "07_02.bvh")
    shutil.copy(tests_data / "cmu" / "86_01_first60.amc", root / "86_01.amc")
    shutil.copy(tests_data / "cmu" / "86_01_15hz_first1600.amc", root / "86_02.amc")
    shutil.copy(tests_data / "cmu" / "86.asf", root / "86.asf")
    shutil.copy(tests_data / "cmu" / "86_01_15hz_first1600.labels.txt", root / "86_02.labels.txt")
    shutil.copytree(tests_data / "xio", root / "imu" / "xio")
    shutil.copy(tests_data / "mvnx" / "86_01_xsens_60hz.mvnx", root / "xsens.mvnx")
    shutil.copy(tests_data / "opensim" / "walk_free_01-first20.trc", root / "walk.trc")
    (root / "broken.bvh").write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0\n")
    (root / "empty.bvh").write_bytes(b"")
    asf = str(root / "86.asf")
    jobs = []
    for p in ("07_01.bvh", "07_02.bvh", "86_01.amc", "imu/xio", "xsens.mvnx", "walk.trc", "broken.bvh",
              "empty.bvh", "missing.bvh"):
        jobs.append(("info", p, {"asf": asf} if p.endswith(".amc") else {}))
    for method in ("fastsw", "sw", "cplr"):
        for p in ("07_01.bvh", "07_02.bvh", "86_01.amc", "imu/xio"):
            opts = {"method": method, "threshold": 0.05}
            if p.endswith(".amc"):
                opts["asf"] = asf
            jobs.append(("compress", p, opts))
    jobs.append(("segment", "86_02.amc", {"asf": asf, "method": "pca", "labels": str(root / "86_02.labels.txt")}))
    jobs.append(("filter", "walk.trc", {"order": 2, "auto": True}))
    jobs.append(("compress", "broken.bvh", {"method": "fastsw", "threshold": 0.05}))
    out = tmp_path_factory.mktemp("out")
    rows = []
    for job, p, opts in jobs:
        base = out / f"{Path(p).name}-{len(rows)}" if job == "compress" else None
        rows.append(run_one(job, root / p, opts, base))
    return root, rows


def _open(url):
    from mocapkit.catalog import open_catalog

    return open_catalog(url)


def _add(url, rows):
    from mocapkit.catalog.ingest import add_rows

    with _open(url) as c:
        return add_rows(c, rows)


def _counts(url) -> dict:
    with _open(url) as c:
        return {t: c.query(f"SELECT count(*) FROM {t}")[1][0][0] for t in TABLES}


# ---------------------------------------------------------------------------------------------------
# the queries and an independent computation of their answers from the rows
# ---------------------------------------------------------------------------------------------------

MEAN_ERROR = """
SELECT rec.subject, ru.method, avg(m.value) AS mean_aad_deg, count(*) AS n
FROM runs ru
JOIN recordings rec ON rec.path = ru.path AND rec.content_hash = ru.content_hash AND rec.reading_hash = ru.reading_hash
JOIN metrics m ON m.run_id = ru.run_id
WHERE ru.job = 'compress' AND m.name = 'aad_deg'
GROUP BY rec.subject, ru.method
"""

QUERIES = [
    MEAN_ERROR,
    "SELECT kind, format, count(*), sum(frames), sum(bytes) FROM recordings GROUP BY kind, format",
    "SELECT type, units, count(*) FROM channels GROUP BY type, units",
    "SELECT job, status, count(*) FROM runs GROUP BY job, status",
    "SELECT signal, count(*) - 1 AS knots, min(t0), max(t1) FROM filter_pieces GROUP BY signal",
    "SELECT idx, t0, t1, frame0, frame1, label, method FROM segments",
    "SELECT subject, take, count(*) FROM recordings GROUP BY subject, take",
    "SELECT path, frames, rate_hz, duration_s FROM recordings",
    ("SELECT r.path, count(o.path), sum(o.bytes) FROM runs r LEFT JOIN outputs o ON o.run_id = r.run_id "
     "WHERE r.job = 'compress' GROUP BY r.path"),
]


def _norm(rows):
    """Rows in a canonical order (None first), floats compared to 12 digits."""
    out = []
    for r in rows:
        out.append(tuple(float(f"{v:.12g}") if isinstance(v, float) else v for v in r))
    return sorted(out, key=lambda r: tuple((v is not None, repr(v)) for v in r))


def _mean_error_from_rows(rows) -> list[tuple]:
    """MEAN_ERROR computed from the batch rows themselves (no catalog)."""
    subject = {}
    for row in rows:
        if row["status"] == "ok":
            r = json.loads(row["record_json"])["recording"]
            subject[row["input"]] = r["subject"]
    acc = defaultdict(list)
    for row in rows:
        if row["job"] != "compress" or row["status"] != "ok":
            continue
        rec = json.loads(row["record_json"])
        vals = [rec["aad_deg"]] if "aad_deg" in rec else []
        vals += [s["aad_deg"] for s in rec.get("signals", []) if "aad_deg" in s]
        acc[(subject[row["input"]], rec["method"])] += vals
    return _norm([(s, m, sum(v) / len(v), len(v)) for (s, m), v in acc.items()])


# ---------------------------------------------------------------------------------------------------
# tests
# ---------------------------------------------------------------------------------------------------


def test_dataset_rows_are_what_the_batch_makes(dataset):
    _, rows = dataset
    bad = {Path(r["input"]).name for r in rows if r["status"] == "error"}
    assert bad == {"broken.bvh", "empty.bvh", "missing.bvh"}
    assert all(r["error"] for r in rows if r["status"] == "error")


def test_ingest_maps_every_table(catalog_url, dataset):
    _, rows = dataset
    n = _add(catalog_url, rows)
    ok = [r for r in rows if r["status"] == "ok"]
    counts = _counts(catalog_url)
    assert counts["runs"] == n["runs"] == len(rows)
    inputs_ok = {r["input"] for r in ok}
    assert counts["recordings"] == len(inputs_ok)
    expected_channels = {r["input"]: len(json.loads(r["record_json"])["recording"]["channels"]) for r in ok}
    assert counts["channels"] == sum(expected_channels.values())
    with _open(catalog_url) as c:
        _, per = c.query("SELECT path, count(*) FROM channels GROUP BY path")
        assert dict(per) == expected_channels
        # segments of the segment run, in order, with the method
        seg_row = next(r for r in rows if r["job"] == "segment")
        seg = json.loads(seg_row["record_json"])
        _, got = c.query("SELECT idx, t0, t1, frame0, frame1, label, method FROM segments ORDER BY idx")
        assert got == [(i, s["t0"], s["t1"], s["frame0"], s["frame1"], s["label"], seg["method"])
                       for i, s in enumerate(seg["segments"])]
        # scores against the reference labels become metrics named scores.<key>
        _, sc = c.query("SELECT name, value FROM metrics WHERE name LIKE 'scores.%'")
        assert {k: v for k, v in sc} == {f"scores.{k}": float(v) for k, v in seg.get("scores", {}).items()
                                         if isinstance(v, (int, float)) and not isinstance(v, bool)}
        # filter pieces: knots are the t0 of the pieces after the first
        frow = json.loads(next(r for r in rows if r["job"] == "filter")["record_json"])
        item = next(s for s in frow["signals"] if s.get("pieces"))
        _, pcs = c.query("SELECT idx, t0, t1, poly_order, coeffs_json FROM filter_pieces WHERE signal = ? "
                         "ORDER BY idx", (item["name"],))
        assert [(t0, t1, json.loads(cj)) for _, t0, t1, _, cj in pcs] == \
               [(p["t0"], p["t1"], p["coeffs"]) for p in item["pieces"]]
        assert {po for *_, po, _ in pcs} == {frow["order"]}
        _, knots = c.query("SELECT count(*) - 1 FROM filter_pieces WHERE signal = ?", (item["name"],))
        assert knots[0][0] == item["n_knots"]
        # outputs of the compress runs that wrote something, with their size and bound
        written = [(o["path"], o["bytes"], o["format"]) for r in ok if r["job"] == "compress"
                   for o in json.loads(r["record_json"])["outputs"]]
        assert written
        _, outs = c.query("SELECT path, bytes, format FROM outputs")
        assert sorted(outs) == sorted(written)
        # an error row: status and error, no recording
        _, err = c.query("SELECT status, error, content_hash FROM runs WHERE path LIKE ?", ("%missing.bvh",))
        assert err[0][0] == "error" and "missing.bvh" in err[0][1] and err[0][2] is None
        # subject/take from CMU file names; MVNX subject from the file
        _, st = c.query("SELECT path, subject, take FROM recordings")
        st = {Path(p).name: (s, t) for p, s, t in st}
        assert st["07_01.bvh"] == ("07", "01") and st["86_01.amc"] == ("86", "01")
        assert st["xsens.mvnx"] == ("CMU subject 86", None) and st["walk.trc"] == (None, None)


def test_mean_error_per_method_per_subject_matches_the_rows(catalog_url, dataset):
    _, rows = dataset
    _add(catalog_url, rows)
    with _open(catalog_url) as c:
        _, got = c.query(MEAN_ERROR)
    want = _mean_error_from_rows(rows)
    assert len(want) == 9  # subjects 07, 86 and none (IMU) x 3 methods
    assert _norm(got) == want


def test_same_answers_on_duckdb_and_postgresql(dataset, tmp_path):
    _, rows = dataset
    duck = str(tmp_path / "motion.duckdb")
    with _pg_schema() as pg:
        _add(duck, rows)
        _add(pg, rows)
        answers = {}
        for url in (duck, pg):
            with _open(url) as c:
                answers[url] = [(c.query(q)[0], _norm(c.query(q)[1])) for q in QUERIES]
                answers[url].append(([], [_counts(url)[t] for t in TABLES]))
        for q, (a, b) in zip(QUERIES + ["counts"], zip(answers[duck], answers[pg], strict=True), strict=True):
            assert a[1] == b[1], f"engines disagree on: {q}"
            assert a[1] or q == QUERIES[5], f"query gave nothing (nothing compared): {q}"


def test_catalog_survives_reopening_and_ingest_is_idempotent(catalog_url, dataset):
    _, rows = dataset
    first = _add(catalog_url, rows)
    before = _counts(catalog_url)
    with _open(catalog_url) as c:
        _, reg0 = c.query("SELECT path, content_hash, registered_at FROM recordings")
    # reopened (a new connection, a new process would see the same): the same rows, added again
    again = _add(catalog_url, rows)
    assert again == first
    assert _counts(catalog_url) == before
    # duplicates inside one call count once
    _add(catalog_url, rows + rows[:5])
    assert _counts(catalog_url) == before
    with _open(catalog_url) as c:
        _, reg1 = c.query("SELECT path, content_hash, registered_at FROM recordings")
    assert sorted(reg1) == sorted(reg0)  # registration time kept
    # another option is another run; the recording is the same
    row = dict(next(r for r in rows if r["job"] == "compress" and r["status"] == "ok"))
    row["options_json"], row["options_hash"] = '{"method":"fastsw","threshold":0.5}', "f" * 64
    _add(catalog_url, [row])
    after = _counts(catalog_url)
    assert after["runs"] == before["runs"] + 1 and after["recordings"] == before["recordings"]
    assert after["metrics"] > before["metrics"]


def test_a_changed_file_is_a_new_recording(catalog_url, tmp_path, tests_data):
    from mocapkit.batch.worker import run_one

    p = tmp_path / "take.bvh"
    shutil.copy(tests_data / "bvh" / "walk-meredith-60.bvh", p)
    r1 = run_one("info", p, {}, None)
    p.write_text(p.read_text().replace("Frame Time: 0.008333", "Frame Time: 0.01"))
    r2 = run_one("info", p, {}, None)
    assert r1["content_hash"] != r2["content_hash"]
    _add(catalog_url, [r1])
    _add(catalog_url, [r2])
    with _open(catalog_url) as c:
        _, got = c.query("SELECT rate_hz FROM recordings WHERE path = ? ORDER BY rate_hz", (str(p),))
    assert [round(v, 6) for (v,) in got] == [100.0, round(1 / 0.008333, 6)]


def test_rollback_leaves_nothing_half_written(catalog_url, dataset, monkeypatch):
    from mocapkit.catalog.engine import Catalog
    from mocapkit.catalog.ingest import add_rows

    _, rows = dataset
    real = Catalog.insert

    def failing(self, table, rows_):
        if table == "outputs":  # the last table written: everything before it must be rolled back
            raise RuntimeError("disk full (simulated)")
        real(self, table, rows_)

    with _open(catalog_url) as c:
        monkeypatch.setattr(Catalog, "insert", failing)
        with pytest.raises(RuntimeError, match="simulated"):
            add_rows(c, rows)
        monkeypatch.setattr(Catalog, "insert", real)
        assert {t: c.query(f"SELECT count(*) FROM {t}")[1][0][0] for t in TABLES} == dict.fromkeys(TABLES, 0)
        add_rows(c, rows)  # the connection is usable after the rollback
    assert _counts(catalog_url)["runs"] == len(rows)


def test_schema_version_is_checked(catalog_url):
    with _open(catalog_url) as c:
        c.execute("UPDATE schema_version SET version = 99")
    with pytest.raises(MocapError, match="schema version 99"):
        _open(catalog_url)


# ---------------------------------------------------------------------------------------------------
# errors: one MocapError naming the URL, never the password
# ---------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("url, shown", [
    ("postgresql://alice:s3cretpw@127.0.0.1:1/motion", "postgresql://alice:***@127.0.0.1:1/motion"),
    ("postgres://alice:s3cretpw@127.0.0.1:notaport/motion", "postgres://alice:***@127.0.0.1:notaport/motion"),
    ("postgresql://alice:s3cretpw@[::1/motion", "postgresql://alice:***@[::1/motion"),  # malformed: libpq quotes it
    ("postgresql://alice@127.0.0.1:1/motion?password=s3cretpw&sslmode=disable",
     "postgresql://alice@127.0.0.1:1/motion?password=***&sslmode=disable"),
])
def test_unreachable_or_malformed_server_url_is_one_clear_error_without_password(url, shown):
    from mocapkit.catalog import open_catalog

    with pytest.raises(MocapError) as e:
        open_catalog(url)
    msg = str(e.value)
    assert msg.startswith(shown + ": ") and "s3cretpw" not in msg
    assert "\n" not in msg


def test_wrong_password_and_unknown_database_on_the_server():
    from mocapkit.catalog import open_catalog

    base = _pg_base()
    from urllib.parse import urlsplit

    parts = urlsplit(base)
    url = f"postgresql://{parts.username}:pw123456@{parts.hostname}:{parts.port}/no_such_db_{uuid.uuid4().hex[:6]}"
    with pytest.raises(MocapError) as e:
        open_catalog(url)
    assert "no_such_db" in str(e.value) and "pw123456" not in str(e.value)


@pytest.mark.parametrize("url, words", [
    ("mysql://u@h/db", "unknown catalog URL scheme"),
    ("", "empty"),
])
def test_bad_urls(url, words):
    from mocapkit.catalog import open_catalog

    with pytest.raises(MocapError, match=words):
        open_catalog(url)


def test_duckdb_folder_and_missing_folder(tmp_path):
    from mocapkit.catalog import open_catalog

    with pytest.raises(MocapError, match="is a folder"):
        open_catalog(str(tmp_path))
    with pytest.raises(MocapError, match="does not exist"):
        open_catalog(str(tmp_path / "nope" / "motion.duckdb"))
    with pytest.raises(MocapError, match="no such catalog file"):
        open_catalog(str(tmp_path / "motion.duckdb"), create=False)
    assert not (tmp_path / "motion.duckdb").exists()


def test_locked_duckdb_file(tmp_path):
    from mocapkit.catalog import open_catalog

    db = tmp_path / "motion.duckdb"
    holder = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(f"""
            import sys, duckdb
            c = duckdb.connect({str(db)!r}); c.execute("CREATE TABLE x (a INT)")
            print("ready", flush=True); sys.stdin.readline()
        """)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "ready"
        with pytest.raises(MocapError) as e:
            open_catalog(str(db))
        assert str(db) in str(e.value) and "another process" in str(e.value)
    finally:
        holder.stdin.close()
        holder.wait(timeout=30)


# ---------------------------------------------------------------------------------------------------
# import and the command line
# ---------------------------------------------------------------------------------------------------


def _import_folder(root: Path, tests_data: Path) -> None:
    shutil.copy(tests_data / "bvh" / "walk-meredith-60.bvh", root / "07_01.bvh")
    shutil.copy(tests_data / "markers" / "juggling-qualisys-300hz-first120.tsv", root / "juggle.tsv")
    (root / "sub").mkdir()
    shutil.copy(tests_data / "cmu" / "86_01_first60.amc", root / "sub" / "86_01.amc")
    shutil.copy(tests_data / "cmu" / "86.asf", root / "sub" / "86.asf")
    (root / "sub" / "corrupt.bvh").write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 x\n")
    (root / "sub" / "cut.tsv").write_text("NO_OF_FRAMES\t5\n")


def test_import_a_folder_with_corrupt_files(catalog_url, tmp_path, tests_data):
    from mocapkit.catalog.register import import_folder

    root = tmp_path / "lab"
    root.mkdir()
    _import_folder(root, tests_data)
    with _open(catalog_url) as c:
        res = import_folder(c, [root])
        assert sorted(Path(p).name for p in res.registered) == ["07_01.bvh", "86_01.amc", "juggle.tsv"]
        assert sorted(Path(p).name for p, _ in res.errors) == ["corrupt.bvh", "cut.tsv"]
        assert all(Path(p).name in e for p, e in res.errors)
        assert [Path(p).name for p, _ in res.skipped] == ["86.asf"]
        _, got = c.query("SELECT path, content_hash, kind, frames, subject, take, bytes FROM recordings")
        _, runs = c.query("SELECT count(*) FROM runs")
    from mocapkit.jobs.recording import content_hash

    got = {Path(p).name: (h, k, f, s, t, b) for p, h, k, f, s, t, b in got}
    bvh = root / "07_01.bvh"
    assert got["07_01.bvh"] == (content_hash(bvh), "skeletal", 60, "07", "01", bvh.stat().st_size)
    assert got["86_01.amc"][3:5] == ("86", "01") and got["juggle.tsv"][1:3] == ("markers", 120)
    assert runs == [(0,)]  # no job was run


def test_cli_import_and_query_formats(tmp_path, tests_data):
    root = tmp_path / "lab"
    root.mkdir()
    _import_folder(root, tests_data)
    db = tmp_path / "motion.duckdb"
    code, out, err = cli_run("catalog", "import", root, "--db", db)
    assert code == 0, err
    assert "3 recordings registered, 2 errors" in out
    err_lines = [s for s in err.splitlines() if s.startswith("error: ")]
    assert len(err_lines) == 2 and any("corrupt.bvh" in s for s in err_lines) and any("cut.tsv" in s for s in err_lines)
    sql = "SELECT path, kind, frames, rate_hz, subject, registered_at FROM recordings ORDER BY path"
    with _open(str(db)) as c:
        cols, rows = c.query(sql)
    # JSON: a strict list of objects
    code, out, err = cli_run("catalog", "query", "--db", db, sql, "--format", "json")
    assert code == 0, err
    got = json.loads(out, parse_constant=lambda s: pytest.fail(f"non-strict JSON {s}"))
    assert [list(o) for o in got] == [cols] * len(rows)
    assert [[o[k] for k in cols[:5]] for o in got] == [list(r[:5]) for r in rows]
    assert [o["registered_at"] for o in got] == [r[5].isoformat() for r in rows]
    # CSV: a header, then the rows (NULL as an empty cell, floats exact)
    code, out, err = cli_run("catalog", "query", "--db", db, sql, "--format", "csv")
    assert code == 0, err
    table = list(csv.reader(io.StringIO(out)))
    assert table[0] == cols and len(table) == len(rows) + 1
    for line, r in zip(table[1:], rows, strict=True):
        assert line[0] == r[0] and int(line[2]) == r[2] and float(line[3]) == r[3]
        assert line[4] == ("" if r[4] is None else r[4])
    # table: every value on stdout, a row count caption
    code, out, err = cli_run("catalog", "query", "--db", db, sql)
    assert code == 0, err
    assert all(Path(r[0]).name in out for r in rows) and f"{len(rows)} rows" in out
    # a bad statement: one line, exit 2
    code, out, err = cli_run("catalog", "query", "--db", db, "SELECT nope FROM recordings")
    assert code == 2 and err.count("\n") == 1 and err.startswith("error: ") and str(db) in err


def test_cli_import_with_nothing_good_exits_2(tmp_path):
    (tmp_path / "in").mkdir()
    (tmp_path / "in" / "bad.bvh").write_text("not a bvh\n")
    code, out, err = cli_run("catalog", "import", tmp_path / "in", "--db", tmp_path / "m.duckdb")
    assert code == 2 and "bad.bvh" in err and "0 recordings registered, 1 error" in out
    code, out, err = cli_run("catalog", "import", tmp_path / "nothing-here", "--db", tmp_path / "m.duckdb")
    assert code == 2 and "nothing-here" in err


def test_cli_on_postgresql(tmp_path, tests_data):
    with _pg_schema() as url:
        root = tmp_path / "lab"
        root.mkdir()
        _import_folder(root, tests_data)
        code, out, err = cli_run("catalog", "import", root, "--db", url)
        assert code == 0, err
        code, out, err = cli_run("catalog", "query", "--db", url, "SELECT kind, count(*) AS n FROM recordings "
                                 "GROUP BY kind ORDER BY kind", "--format", "json")
        assert code == 0, err
        assert json.loads(out) == [{"kind": "markers", "n": 1}, {"kind": "skeletal", "n": 2}]


def test_cli_query_cannot_change_the_catalog(catalog_url, dataset):
    """``catalog query`` opens the catalog read-only: a DELETE is an error and every row stays."""
    _, rows = dataset
    _add(catalog_url, rows)
    before = _counts(catalog_url)
    assert before["runs"] > 0
    code, out, err = cli_run("catalog", "query", "--db", catalog_url, "DELETE FROM runs")
    assert code == 2 and err.startswith("error: ") and err.count("\n") == 1, err
    assert _counts(catalog_url) == before
    code, out, err = cli_run("catalog", "query", "--db", catalog_url, "SELECT count(*) AS n FROM runs",
                             "--format", "json")
    assert code == 0 and json.loads(out) == [{"n": before["runs"]}], err


def test_cli_import_reports_files_read_with_warnings(tmp_path, tests_data):
    """A file read with a warning (here a TRC whose header counts more frames than it holds) is registered,
    and the warning is printed, not lost."""
    from mocapkit.jobs import run_job

    root = tmp_path / "lab"
    root.mkdir()
    trc = root / "walk.trc"
    shutil.copy(tests_data / "opensim" / "walk_free_01-first20.trc", trc)
    shutil.copy(tests_data / "bvh" / "walk-meredith-60.bvh", root / "walk.bvh")
    warnings = run_job("info", trc, {})["warnings"]
    assert warnings and not run_job("info", root / "walk.bvh", {})["warnings"]
    code, out, err = cli_run("catalog", "import", root, "--db", tmp_path / "m.duckdb")
    assert code == 0, err
    assert "2 recordings registered (1 with warnings), 0 errors" in out
    for w in warnings:
        assert f"warning: {trc}: {w}" in err


# ---------------------------------------------------------------------------------------------------
# catalog query reads and never writes; it streams; every type prints
# ---------------------------------------------------------------------------------------------------


def _small_catalog(path: Path) -> Path:
    """A catalog file with one recording (made through the catalog's own insert)."""
    from mocapkit.catalog.ingest import put_recordings

    with _open(str(path)) as c, c.transaction():
        put_recordings(c, [({"path": "/data/07_01.bvh", "format": "bvh", "kind": "skeletal", "frames": 60,
                             "channels": [{"name": "Hips_Xposition", "type": "POS"}]}, "ab" * 32, 10)])
    return path


def _state(path: Path) -> tuple:
    return path.read_bytes(), path.stat().st_mtime_ns, sorted(os.listdir(path.parent))


ATTEMPTS = [
    "COPY recordings TO '{d}/out.csv'",
    "COPY (SELECT 1) TO '{d}/motion.duckdb'",
    "ATTACH '{d}/other.duckdb' AS other",
    "INSTALL httpfs",
    "LOAD httpfs",
    "PRAGMA enable_profiling",
    "PRAGMA table_info('recordings')",
    "CREATE TABLE x (a INT)",
    "CREATE TEMP TABLE x (a INT)",
    "INSERT INTO recordings (path, content_hash) VALUES ('a', 'b')",
    "DELETE FROM recordings",
    "SET enable_external_access = true",
    "SELECT * FROM read_csv('/etc/passwd')",
    "SELECT * FROM glob('{d}/*')",
    "SELECT 1; DELETE FROM recordings",
    "EXPLAIN ANALYZE DELETE FROM recordings",
    "CHECKPOINT",
    "EXPORT DATABASE '{d}/exported'",
    "DETACH motion",
    "USE memory",
]


@pytest.mark.parametrize("sql", ATTEMPTS)
def test_cli_query_never_writes_the_duckdb_file(tmp_path, sql):
    db = _small_catalog(tmp_path / "motion.duckdb")
    before = _state(db)
    code, out, err = cli_run("catalog", "query", "--db", db, sql.format(d=tmp_path))
    assert code == 2, (code, out, err)
    assert err.startswith("error: ") and err.count("\n") == 1 and str(db) in err, err
    assert _state(db) == before  # bytes, mtime and no new file next to it


@pytest.mark.parametrize("sql", [
    "COPY recordings TO '{d}/out.csv'", "SET enable_external_access = true", "ATTACH '{d}/o.duckdb' AS o",
    "SELECT * FROM read_csv('/etc/passwd')", "LOAD httpfs", "INSERT INTO recordings (path, content_hash) "
    "VALUES ('a', 'b')",
])
def test_duckdb_read_only_connection_refuses_writes_by_itself(tmp_path, sql):
    """The connection ``catalog query`` opens refuses these even without the statement check."""
    from mocapkit.catalog import open_catalog

    db = _small_catalog(tmp_path / "motion.duckdb")
    before = _state(db)
    with open_catalog(str(db), read_only=True) as c, pytest.raises(MocapError):
        c.query(sql.format(d=tmp_path))
    assert _state(db) == before


@pytest.mark.parametrize("sql", [
    "SHOW TABLES", "DESCRIBE recordings", "EXPLAIN SELECT * FROM recordings", "FROM recordings",
    "WITH r AS (SELECT path FROM recordings) SELECT * FROM r;", "SELECT path FROM recordings -- a comment",
    "SUMMARIZE recordings", "VALUES (1)",
])
def test_cli_query_reads_in_every_form(tmp_path, sql):
    db = _small_catalog(tmp_path / "motion.duckdb")
    before = _state(db)
    code, out, err = cli_run("catalog", "query", "--db", db, sql, "--format", "json")
    assert code == 0, err
    assert json.loads(out)
    assert _state(db) == before


@pytest.mark.parametrize("sql", ["", "   \n\t"])
def test_cli_empty_query_is_a_usage_error(tmp_path, sql):
    db = _small_catalog(tmp_path / "motion.duckdb")
    code, out, err = cli_run("catalog", "query", "--db", db, sql)
    assert code == 2 and err.startswith("error: ") and err.count("\n") == 1 and "empty" in err, err
    assert "catalog query --help" in err and out == ""


@pytest.mark.parametrize("sql", [";", "-- only a comment", " ; ; "])
def test_cli_query_without_a_statement_is_refused(tmp_path, sql):
    db = _small_catalog(tmp_path / "motion.duckdb")
    code, out, err = cli_run("catalog", "query", "--db", db, sql)
    assert code == 2 and err.startswith("error: ") and err.count("\n") == 1, err


def test_cli_query_refuses_writes_on_postgresql(tmp_path):
    with _pg_schema() as url:
        with _open(url) as c:
            c.execute("INSERT INTO recordings (path, content_hash, reading_hash, kind) "
                      "VALUES ('a', 'b', 'h', 'markers')")
        for sql in ["DELETE FROM recordings", "CREATE TABLE x (a INT)", "SELECT 1; DELETE FROM recordings",
                    "WITH d AS (DELETE FROM recordings RETURNING 1) SELECT * FROM d",
                    "COPY recordings TO STDOUT", "SET default_transaction_read_only = off",
                    "SELECT set_config('transaction_read_only', 'off', true)", "", ";"]:
            code, out, err = cli_run("catalog", "query", "--db", url, sql)
            assert code == 2 and err.startswith("error: ") and err.count("\n") == 1, (sql, err)
        with _open(url) as c:
            assert c.query("SELECT path, content_hash FROM recordings")[1] == [("a", "b")]
            assert c.query("SELECT count(*) FROM information_schema.tables WHERE table_schema = "
                           "current_schema()")[1] == [(len(TABLES) + 1,)]
        code, out, err = cli_run("catalog", "query", "--db", url, "SELECT path, path FROM recordings",
                                 "--format", "json")
        assert code == 0 and json.loads(out) == [{"path": "a", "path_2": "a"}], err


def test_cli_query_while_a_writer_holds_the_file(tmp_path):
    db = _small_catalog(tmp_path / "motion.duckdb")
    holder = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(f"""
            import sys, duckdb
            c = duckdb.connect({str(db)!r})
            print("ready", flush=True); sys.stdin.readline()
        """)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "ready"
        code, out, err = cli_run("catalog", "query", "--db", db, "SELECT 1")
        assert code == 2 and "another process" in err and err.count("\n") == 1, err
    finally:
        holder.stdin.close()
        holder.wait(timeout=30)


# every DuckDB type: (column, SQL, its JSON value, its CSV text); the table shows the CSV text
UUID_TEXT = "550e8400-e29b-41d4-a716-446655440000"
TYPES = [
    ("dec", "1.25::DECIMAL(10,2)", 1.25, "1.25"),
    ("dec_big", "12345678901234567890.123456789::DECIMAL(38,9)", "12345678901234567890.123456789",
     "12345678901234567890.123456789"),
    ("huge", "170141183460469231731687303715884105727::HUGEINT", 170141183460469231731687303715884105727,
     "170141183460469231731687303715884105727"),
    ("uhuge", "340282366920938463463374607431768211455::UHUGEINT", 340282366920938463463374607431768211455,
     "340282366920938463463374607431768211455"),
    ("ivl", "INTERVAL '1 month 2 days 3 hours'", "1 month 2 days 03:00:00", "1 month 2 days 03:00:00"),
    ("ivl_neg", "INTERVAL '-1 year'", "-1 year", "-1 year"),
    ("uid", f"'{UUID_TEXT}'::UUID", UUID_TEXT, UUID_TEXT),
    ("blob", "'\\xAA\\x00'::BLOB", "aa00", "aa00"),
    ("day", "DATE '2024-02-29'", "2024-02-29", "2024-02-29"),
    ("day_inf", "'infinity'::DATE", "infinity", "infinity"),
    ("tod", "TIME '12:34:56.5'", "12:34:56.500000", "12:34:56.500000"),
    ("ts", "TIMESTAMP '2024-01-02 03:04:05.123456'", "2024-01-02T03:04:05.123456", "2024-01-02T03:04:05.123456"),
    ("ts_whole", "TIMESTAMP '2024-01-02 03:04:05'", "2024-01-02T03:04:05", "2024-01-02T03:04:05"),
    ("ts_inf", "'-infinity'::TIMESTAMP", "-infinity", "-infinity"),
    ("ts_ns", "TIMESTAMP_NS '2024-01-02 03:04:05.123456789'", "2024-01-02T03:04:05.123456789",
     "2024-01-02T03:04:05.123456789"),
    ("ts_tz", "TIMESTAMPTZ '2024-01-02 03:04:05+00'", None, None),  # checked as an instant below
    ("lst", "[1, 2, NULL]", [1, 2, None], "[1,2,null]"),
    ("arr", "[1, 2, 3]::INTEGER[3]", [1, 2, 3], "[1,2,3]"),
    ("st", f"{{'a': 1.5::DECIMAL(4,2), 'b': INTERVAL 3 DAY, 'c': '{UUID_TEXT}'::UUID}}",
     {"a": 1.5, "b": "3 days", "c": UUID_TEXT}, f'{{"a":1.50,"b":"3 days","c":"{UUID_TEXT}"}}'),
    ("mp", "MAP {'k': 1, 'j': 2}", {"k": 1, "j": 2}, '{"k":1,"j":2}'),
    ("mp_int", "MAP {1: INTERVAL 1 MONTH}", {"1": "1 month"}, '{"1":"1 month"}'),
    ("mp_list", "MAP {[1]: 'x'}", [{"key": [1], "value": "x"}], '[{"key":[1],"value":"x"}]'),
    ("nested", "[{'x': [1, 2], 'd': DATE '2024-01-01'}]", [{"x": [1, 2], "d": "2024-01-01"}],
     '[{"x":[1,2],"d":"2024-01-01"}]'),
    ("enm", "'happy'::ENUM('sad', 'happy')", "happy", "happy"),
    ("nan", "'nan'::DOUBLE", "NaN", "nan"),
    ("inf", "'inf'::DOUBLE", "Infinity", "inf"),
    ("ninf", "'-inf'::FLOAT", "-Infinity", "-inf"),
    ("dbl", "0.1::DOUBLE", 0.1, "0.1"),
    ("flag", "true", True, "True"),
    ("bits", "'101'::BIT", "101", "101"),
    ("uni", "union_value(n := 2)", 2, "2"),
    ("txt", "'a \"quoted\", [b]'", 'a "quoted", [b]', 'a "quoted", [b]'),
    ("nul", "NULL::INTEGER", None, ""),
]
TYPES_SQL = "SELECT " + ", ".join(f"{sql} AS {col}" for col, sql, _, _ in TYPES)


def _tz_instant(text: str):
    import datetime as dt

    t = dt.datetime.fromisoformat(text if text[-3] in "+-" and ":" not in text[-6:] else text)
    return t.astimezone(dt.UTC)


def test_cli_query_prints_every_duckdb_type_as_json(tmp_path):
    import datetime as dt
    from decimal import Decimal

    db = _small_catalog(tmp_path / "motion.duckdb")
    code, out, err = cli_run("catalog", "query", "--db", db, TYPES_SQL, "--format", "json")
    assert code == 0, err
    rows = json.loads(out, parse_constant=lambda s: pytest.fail(f"non-strict JSON {s}"))
    exact = json.loads(out, parse_float=Decimal)[0]
    (row,) = rows
    assert list(row) == [c for c, *_ in TYPES]
    for col, _, want, _ in TYPES:
        if col == "dec_big":
            assert exact[col] == Decimal(want)  # every digit, as a JSON number
        elif col == "ts_tz":
            assert _tz_instant(row[col]) == dt.datetime(2024, 1, 2, 3, 4, 5, tzinfo=dt.UTC)
        else:
            assert row[col] == want, col


def test_cli_query_prints_every_duckdb_type_as_csv(tmp_path):
    import datetime as dt

    db = _small_catalog(tmp_path / "motion.duckdb")
    code, out, err = cli_run("catalog", "query", "--db", db, TYPES_SQL, "--format", "csv")
    assert code == 0, err
    header, line = list(csv.reader(io.StringIO(out)))
    assert header == [c for c, *_ in TYPES]
    for (col, _, _, want), got in zip(TYPES, line, strict=True):
        if col == "ts_tz":
            assert _tz_instant(got) == dt.datetime(2024, 1, 2, 3, 4, 5, tzinfo=dt.UTC)
        else:
            assert got == want, col


@pytest.mark.parametrize("col, sql, want", [(c, s, w) for c, s, _, w in TYPES if c != "ts_tz"])
def test_cli_query_prints_every_duckdb_type_as_a_table(tmp_path, col, sql, want):
    db = tmp_path / "motion.duckdb"
    if not db.exists():
        _small_catalog(db)
    code, out, err = cli_run("catalog", "query", "--db", db, f"SELECT {sql} AS {col}")
    assert code == 0, err
    flat = "".join(ch for line in out.splitlines() for ch in line.strip("│ ┃") if ch not in "│┃")
    assert (want or "NULL") in flat.replace(" ", "") or (want or "NULL") in out, out


def test_cli_json_keeps_columns_of_one_name(tmp_path):
    db = _small_catalog(tmp_path / "motion.duckdb")
    sql = ("SELECT r.path, c.path, c.name, 'x' AS path_2 FROM recordings r "
           "JOIN channels c ON c.path = r.path AND c.content_hash = r.content_hash")
    code, out, err = cli_run("catalog", "query", "--db", db, sql, "--format", "json")
    assert code == 0, err
    assert json.loads(out) == [{"path": "/data/07_01.bvh", "path_3": "/data/07_01.bvh",
                                "name": "Hips_Xposition", "path_2": "x"}]
    assert "path -> path_3" in err
    code, out, err = cli_run("catalog", "query", "--db", db, sql, "--format", "csv")
    assert code == 0 and out.splitlines()[0] == "path,path,name,path_2", err


def test_cli_query_table_shows_the_first_rows_and_counts_all(tmp_path):
    from mocapkit.cli_catalog import TABLE_ROWS

    db = _small_catalog(tmp_path / "motion.duckdb")
    n = TABLE_ROWS + 234
    code, out, err = cli_run("catalog", "query", "--db", db, f"SELECT i FROM range({n}) t(i) ORDER BY i DESC")
    assert code == 0, err
    assert f"the first {TABLE_ROWS} of {n} rows" in out
    assert f" {n - 1} " in out and f" {n - TABLE_ROWS} " in out and f" {n - TABLE_ROWS - 1} " not in out
    code, out, err = cli_run("catalog", "query", "--db", db, f"SELECT i FROM range({n}) t(i) ORDER BY i DESC",
                             "--format", "csv")
    assert out.splitlines() == ["i"] + [str(i) for i in range(n - 1, -1, -1)]


_PEAK = textwrap.dedent("""
    import atexit, resource, sys
    atexit.register(lambda: print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr))
    from mocapkit import cli
    cli.main(["catalog", "query", "--db", sys.argv[1], sys.argv[2], "--format", sys.argv[3]])
""")


def _peak_kb(db: Path, n: int, fmt: str) -> tuple[int, int]:
    """Peak resident memory (kB) of ``catalog query`` over ``n`` rows in a fresh process, and the lines
    it wrote."""
    sql = f"SELECT i, i * 0.5 AS x, 'row ' || i AS s FROM range({n}) t(i)"
    p = subprocess.Popen([sys.executable, "-c", _PEAK, str(db), sql, fmt], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    lines = 0
    while chunk := p.stdout.read(1 << 20):
        lines += chunk.count(b"\n")
    err = p.stderr.read().decode()
    assert p.wait(timeout=300) == 0, err
    return int(err.strip().splitlines()[-1]), lines


@pytest.mark.parametrize("fmt", ["csv", "json"])
def test_cli_query_streams_its_rows(tmp_path, fmt):
    """Peak memory does not grow with the rows: 1.2 M rows take less than 40 MB more than 0.2 M (all in
    memory at once they took ~250 MB more)."""
    db = _small_catalog(tmp_path / "motion.duckdb")
    small, n_small = _peak_kb(db, 200_000, fmt)
    large, n_large = _peak_kb(db, 1_200_000, fmt)
    extra = 1 + (fmt == "json")  # the header; JSON's "[" and "]" lines
    assert (n_small, n_large) == (200_000 + extra, 1_200_000 + extra)
    assert large - small < 40_000, (small, large)


def _foreign_duckdb(path: Path, kind: str) -> None:
    import duckdb

    from mocapkit.catalog.schema import SCHEMA_VERSION

    c = duckdb.connect(str(path))
    if kind == "no_schema_version":
        c.execute("CREATE TABLE recordings (id INTEGER, name TEXT)")
        c.execute("INSERT INTO recordings VALUES (1, 'theirs')")
    else:  # a schema_version table, and a recordings table of another shape
        c.execute("CREATE TABLE schema_version (version BIGINT)")
        c.execute(f"INSERT INTO schema_version VALUES ({SCHEMA_VERSION})")
        c.execute("CREATE TABLE recordings (path TEXT, size BIGINT)")
    c.close()


@pytest.mark.parametrize("kind", ["no_schema_version", "recordings_of_another_shape"])
def test_a_foreign_duckdb_file_is_refused_before_any_write(tmp_path, tests_data, kind):
    db = tmp_path / "theirs.duckdb"
    _foreign_duckdb(db, kind)
    lab = tmp_path / "lab"
    lab.mkdir()
    shutil.copy(tests_data / "bvh" / "walk-meredith-60.bvh", lab / "07_01.bvh")
    before = _state(db)
    for args in (["catalog", "import", lab, "--db", db],
                 ["batch", "info", lab, "--out", tmp_path / "out", "--db", db],
                 ["catalog", "query", "--db", db, "SELECT * FROM recordings"]):
        code, out, err = cli_run(*args)
        assert code == 2, (args, out, err)
        assert err.startswith("error: ") and "not a mocapkit catalog" in err and err.count("\n") == 1, err
        assert _state(db) == before, args
    assert not (tmp_path / "out").exists()


def test_a_foreign_postgresql_schema_is_refused_before_any_write():
    import psycopg

    with _pg_schema() as url:
        with psycopg.connect(url, autocommit=True) as c:
            c.execute("CREATE TABLE recordings (id INTEGER, name TEXT)")
        from mocapkit.catalog import open_catalog

        with pytest.raises(MocapError, match="not a mocapkit catalog"):
            open_catalog(url)
        with psycopg.connect(url, autocommit=True) as c:
            names = c.execute("SELECT table_name FROM information_schema.tables WHERE table_schema = "
                              "current_schema()").fetchall()
        assert names == [("recordings",)]


def test_query_values_from_postgresql_print(tmp_path):
    with _pg_schema() as url:
        _open(url).close()
        sql = ("SELECT INTERVAL '1 year 2 mons' AS ivl, 'infinity'::date AS day, 'NaN'::numeric AS nnum, "
               "'-Infinity'::float8 AS ninf, 1.50::numeric(4,2) AS dec, "
               f"'{UUID_TEXT}'::uuid AS uid, '\\xaa00'::bytea AS b, ARRAY[1, 2] AS arr, "
               "'{\"a\": 1}'::jsonb AS js, TIMESTAMP '2024-01-02 03:04:05' AS ts")
        code, out, err = cli_run("catalog", "query", "--db", url, sql, "--format", "json")
        assert code == 0, err
        assert json.loads(out) == [{"ivl": "1 year 2 mons", "day": "infinity", "nnum": "NaN", "ninf": "-Infinity",
                                    "dec": 1.5, "uid": UUID_TEXT, "b": "aa00", "arr": [1, 2], "js": {"a": 1},
                                    "ts": "2024-01-02T03:04:05"}]
        code, out, err = cli_run("catalog", "query", "--db", url, sql, "--format", "csv")
        assert code == 0, err
        assert list(csv.reader(io.StringIO(out)))[1][:4] == ["1 year 2 mons", "infinity", "nan", "-inf"]
