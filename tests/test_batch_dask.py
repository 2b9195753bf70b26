"""The local pool, a Dask LocalCluster and a real ``dask scheduler`` with two ``dask worker`` processes on
127.0.0.1 give identical result tables (all but the timing columns) and identical outputs."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("distributed", reason="--engine dask needs distributed (mocapkit[dask])")
pa = pytest.importorskip("pyarrow", reason="the batch results need pyarrow (mocapkit[batch])")
import pyarrow.parquet as pq  # noqa: E402

from mocapkit import cli  # noqa: E402
from mocapkit.batch.worker import TIMING_FIELDS  # noqa: E402

BIN = Path(sys.executable).parent


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _terminate(procs) -> None:
    for p in procs:
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
    for p in procs:
        try:
            p.wait(timeout=20)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


@pytest.fixture
def scheduler(tmp_path):
    """``tcp://127.0.0.1:PORT`` of a real scheduler with two single-threaded workers (stopped after)."""
    if not (BIN / "dask").exists():
        pytest.skip(f"no dask command in {BIN}")
    from distributed import Client

    port = _free_port()
    addr = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "DASK_TEMPORARY_DIRECTORY": str(tmp_path / "dask-tmp")}
    with open(tmp_path / "dask.log", "wb") as logs:
        procs = [subprocess.Popen([str(BIN / "dask"), "scheduler", "--host", "127.0.0.1", "--port", str(port),
                                   "--no-dashboard"], stdout=logs, stderr=logs, env=env)]
        try:
            for i in range(2):
                procs.append(subprocess.Popen([str(BIN / "dask"), "worker", addr, "--nthreads", "1", "--nworkers", "1",
                                               "--host", "127.0.0.1", "--no-dashboard", "--local-directory",
                                               str(tmp_path / f"worker{i}")], stdout=logs, stderr=logs, env=env))
            t0 = time.monotonic()
            while True:  # the scheduler listens, then both workers register
                try:
                    with Client(addr, timeout="5s") as c:
                        c.wait_for_workers(2, timeout=120)
                    break
                except OSError:
                    if time.monotonic() - t0 > 120 or procs[0].poll() is not None:
                        raise
                    time.sleep(0.5)
            yield addr
        finally:
            _terminate(procs[::-1])


def _batch(*args) -> int:
    try:
        cli.main([str(a) for a in args])
    except SystemExit as e:
        return e.code
    raise AssertionError("main() must end with SystemExit")


def _table(out: Path):
    return pq.read_table(out / "results.parquet").drop_columns(list(TIMING_FIELDS))


def test_local_pool_local_cluster_and_real_scheduler_give_identical_tables(tests_data, tmp_path, scheduler,
                                                                           monkeypatch):
    import dask

    db = tmp_path / "db"
    (db / "imu").mkdir(parents=True)
    (db / "skel").mkdir()
    shutil.copy(tests_data / "formats" / "ngimu.csv", db / "imu" / "ngimu.csv")
    shutil.copy(tests_data / "imu" / "xio" / "ximu3_Quaternion.csv", db / "imu" / "ximu3.csv")
    shutil.copy(tests_data / "bvh" / "walk-meredith-60.bvh", db / "skel" / "walk.bvh")
    shutil.copy(tests_data / "cmu" / "86_01_first60.amc", db / "skel" / "86_01.amc")
    shutil.copy(tests_data / "cmu" / "86.asf", db / "skel" / "86.asf")
    (db / "skel" / "broken.bvh").write_text("HIERARCHY\nROOT\n")
    (db / "imu" / "empty.csv").write_bytes(b"")
    tables, outputs = {}, {}
    with dask.config.set({"temporary-directory": str(tmp_path / "dask-local")}):
        for name, extra in [("local", ["--engine", "local"]), ("cluster", ["--engine", "dask"]),
                            ("scheduler", ["--engine", "dask", "--scheduler", scheduler])]:
            out = tmp_path / name
            # the same OUT path for every engine (the record names its outputs): run, then move aside
            work = tmp_path / "out"
            code = _batch("batch", "compress", db, "--out", work, "-t", "0.01", "--jobs", "2", *extra)
            assert code == 1  # the broken and the empty file are error rows
            work.rename(out)
            tables[name] = _table(out)
            outputs[name] = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()
                             and p.name not in ("results.parquet", "journal.jsonl")}
    assert tables["local"].num_rows == 6
    assert tables["local"].column("status").to_pylist().count("ok") == 4
    assert tables["cluster"].equals(tables["local"])
    assert tables["scheduler"].equals(tables["local"])
    assert outputs["local"] and outputs["cluster"] == outputs["local"] and outputs["scheduler"] == outputs["local"]


def test_unreachable_scheduler_is_a_usage_error(tmp_path, tests_data):
    db = tmp_path / "db"
    db.mkdir()
    shutil.copy(tests_data / "formats" / "ngimu.csv", db / "a.csv")
    port = _free_port()  # nobody listens there
    import contextlib
    import io

    import dask

    errs = io.StringIO()
    with contextlib.redirect_stderr(errs), dask.config.set({"distributed.comm.timeouts.connect": "2s"}):
        code = _batch("batch", "info", db, "--out", tmp_path / "out", "--engine", "dask", "--scheduler",
                      f"tcp://127.0.0.1:{port}")
    assert code == 2
    assert errs.getvalue().startswith(f"error: --scheduler tcp://127.0.0.1:{port}: cannot connect")
