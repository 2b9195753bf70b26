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

from mocapkit import cli
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
        for q, (a, b) in zip(QUERIES + ["counts"], zip(answers[duck], answers[pg])):
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


def cli_run(*args) -> tuple[int, str, str]:
    out, errs = io.StringIO(), io.StringIO()
    code = None
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(errs):
            cli.main([str(a) for a in args])
    except SystemExit as e:
        code = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
    assert code is not None
    return code, out.getvalue(), errs.getvalue()


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
    for line, r in zip(table[1:], rows):
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
