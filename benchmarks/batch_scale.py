"""``mocapkit batch`` at scale: 1,000 recordings and 10 corrupt files (benchmarks/batch_db.py), measured in one
run on this machine.

Prints and writes (``--json``) the wall time of ``batch info`` and ``batch compress`` with 1 and 2 local
workers (the speed-up), the Dask engine's time against the local pool with the same workers (its overhead),
the peak memory of the batch's main process, the catalog's size and the time of a typical query (mean angular
error per method per subject) on DuckDB and, when ``--pg URL`` or ``MOCAPKIT_TEST_PG`` names a server, on
PostgreSQL.

    python benchmarks/batch_scale.py [--n 1000] [--work build/batch-bench] [--pg postgresql://...] [--json F]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from batch_db import generate  # noqa: E402

#: runs the CLI and writes the main process's peak resident memory (VmHWM, kB) to the file in argv[1]
WRAPPER = """
import sys
from mocapkit.cli import main
peak_file = sys.argv[1]
try:
    main(sys.argv[2:])
finally:
    hwm = next(l for l in open('/proc/self/status') if l.startswith('VmHWM'))
    open(peak_file, 'w').write(hwm.split()[1])
"""

QUERY = """SELECT rec.subject, ru.method, avg(m.value) AS mean_aad_deg, count(*) AS n
FROM metrics m JOIN runs ru ON ru.run_id = m.run_id
JOIN recordings rec ON rec.path = ru.path AND rec.content_hash = ru.content_hash AND rec.reading_hash = ru.reading_hash
WHERE m.name = 'aad_deg' AND ru.status = 'ok'
GROUP BY rec.subject, ru.method ORDER BY rec.subject, ru.method"""


def batch(args: list[str], work: Path) -> dict:
    """One ``mocapkit batch ...`` run: wall time, exit code, main-process peak memory, rows."""
    peak = work / "peak.txt"
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-c", WRAPPER, str(peak), "batch", *args], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if r.returncode not in (0, 1):  # 1 = some rows are errors (the corrupt files)
        raise SystemExit(f"batch {' '.join(args)} failed ({r.returncode}):\n{r.stderr[-3000:]}")
    import pyarrow.parquet as pq

    out = Path(args[args.index("--out") + 1])
    tab = pq.read_table(out / "results.parquet").to_pylist()
    return {"wall_s": wall, "exit": r.returncode, "peak_rss_mb": int(peak.read_text()) / 1024,
            "rows": len(tab), "errors": sum(row["status"] == "error" for row in tab)}


def query_time(url: str, repeat: int = 20) -> tuple[float, list[tuple]]:
    """Mean time of :data:`QUERY` over ``repeat`` runs after one warm-up, and its rows."""
    from mocapkit.catalog import open_catalog

    with open_catalog(url) as cat:
        cat.query(QUERY)  # warm
        t0 = time.perf_counter()
        for _ in range(repeat):
            cols, rows = cat.query(QUERY)
        return (time.perf_counter() - t0) / repeat, rows


def pg_size(url: str) -> int:
    from mocapkit.catalog import open_catalog

    with open_catalog(url) as cat:
        _, rows = cat.query("SELECT sum(pg_total_relation_size(c.oid)) FROM pg_class c JOIN pg_namespace n "
                            "ON n.oid = c.relnamespace WHERE n.nspname = current_schema() AND c.relkind = 'r'")
        return int(rows[0][0])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--work", type=Path, default=Path("build/batch-bench"))
    ap.add_argument("--pg", default=os.environ.get("MOCAPKIT_TEST_PG"))
    ap.add_argument("--json", type=Path, default=None)
    a = ap.parse_args()
    work = a.work.resolve()
    db = work / "db"
    t0 = time.perf_counter()
    counts = generate(db, a.n, 10)
    print(f"database: {counts} in {time.perf_counter() - t0:.1f} s", flush=True)
    res: dict = {"recordings": a.n, "corrupt": 10, "cpus": os.cpu_count(), "runs": {}}

    def run(name: str, *args: str) -> dict:
        out = work / f"out-{name}"
        shutil.rmtree(out, ignore_errors=True)
        r = batch([*args, "--out", str(out)], work)
        res["runs"][name] = r
        print(f"{name:28s} {r['wall_s']:8.1f} s  rows {r['rows']:5d}  errors {r['errors']:3d}  "
              f"main peak {r['peak_rss_mb']:.0f} MB", flush=True)
        return r

    duck = work / "motion.duckdb"
    duck.unlink(missing_ok=True)
    info1 = run("info-local-1", "info", str(db), "--jobs", "1")
    info2 = run("info-local-2", "info", str(db), "--jobs", "2")
    infod = run("info-dask-2", "info", str(db), "--jobs", "2", "--engine", "dask")
    comp = ["compress", str(db), "--method", "fastsw", "--threshold", "0.05"]
    c1 = run("compress-local-1", *comp, "--jobs", "1")
    c2 = run("compress-local-2", *comp, "--jobs", "2", "--db", str(duck))
    cd = run("compress-dask-2", *comp, "--jobs", "2", "--engine", "dask")
    run("compress-sw-local-2", "compress", str(db), "--method", "sw", "--threshold", "0.05", "--jobs", "2",
        "--db", str(duck))
    res["speedup_info_2_workers"] = info1["wall_s"] / info2["wall_s"]
    res["speedup_compress_2_workers"] = c1["wall_s"] / c2["wall_s"]
    res["dask_over_local_info"] = infod["wall_s"] / info2["wall_s"]
    res["dask_over_local_compress"] = cd["wall_s"] / c2["wall_s"]
    q, duck_rows = query_time(str(duck))
    n = len(duck_rows)
    res["duckdb"] = {"bytes": duck.stat().st_size, "query_s": q, "query_rows": n}
    print(f"duckdb: {duck.stat().st_size / 1e6:.1f} MB, mean error per method per subject: {q * 1e3:.1f} ms "
          f"({n} rows)")
    if a.pg:
        from mocapkit.catalog import open_catalog

        with open_catalog(a.pg) as cat, cat.transaction():  # an empty catalog for this benchmark
            for t in ("metrics", "segments", "filter_pieces", "outputs", "channels", "runs", "recordings"):
                cat.execute(f"DELETE FROM {t}")
        for name in ("compress-fastsw-pg", "compress-sw-pg"):
            m = "fastsw" if "fastsw" in name else "sw"
            run(name, "compress", str(db), "--method", m, "--threshold", "0.05", "--jobs", "2",
                "--db", a.pg)
        q, pg_rows = query_time(a.pg)
        n = len(pg_rows)
        same = len(pg_rows) == len(duck_rows) and all(
            x[:2] == y[:2] and x[3] == y[3] and abs(x[2] - y[2]) <= 1e-12 * max(1.0, abs(x[2]))
            for x, y in zip(duck_rows, pg_rows, strict=True))
        res["postgresql"] = {"bytes": pg_size(a.pg), "query_s": q, "query_rows": n,
                             "same_answer_as_duckdb": same}
        print(f"postgresql: {res['postgresql']['bytes'] / 1e6:.1f} MB, same query: {q * 1e3:.1f} ms ({n} rows, "
              f"{'the same answer as' if same else 'NOT the same answer as'} DuckDB)")
    print(f"speed-up with 2 workers: info {res['speedup_info_2_workers']:.2f}x, compress "
          f"{res['speedup_compress_2_workers']:.2f}x; dask / local: info {res['dask_over_local_info']:.2f}, "
          f"compress {res['dask_over_local_compress']:.2f}")
    if a.json:
        a.json.write_text(json.dumps(res, indent=1) + "\n")


if __name__ == "__main__":
    main()
