"""mocapkit batch as a real process: kill -9 in the middle and --resume loses no row and duplicates none;
a worker killed in the middle of a batch costs no row; the workers share the numba cache folder."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mocapkit.batch.journal import read_journal
from mocapkit.batch.results import read_results

pytest.importorskip("pyarrow", reason="the batch results need pyarrow (mocapkit[batch])")

MOCAPKIT = [sys.executable, "-m", "mocapkit"]
N_TAKES = 24


@pytest.fixture
def takes(tests_data, tmp_path) -> Path:
    """24 AMC takes (their ASF beside them) in two sub-folders, each a little different."""
    db = tmp_path / "db"
    text = (tests_data / "cmu" / "86_01_15hz_first1600.amc").read_text()
    for i in range(N_TAKES):
        d = db / f"s{i % 2}"
        d.mkdir(parents=True, exist_ok=True)
        (d / f"86_{i:02d}.amc").write_text(f"# copy {i}\n" + text)
        if not (d / "86.asf").exists():
            shutil.copy(tests_data / "cmu" / "86.asf", d / "86.asf")
    return db


def _env(tmp_path: Path, **extra) -> dict:
    """The batch's environment: its temporary files (the forkserver's socket folder, which a kill -9
    leaves behind) go to the test's own folder."""
    (tmp_path / "tmp").mkdir(exist_ok=True)
    return {**os.environ, "TMPDIR": str(tmp_path / "tmp"), **extra}


def _sigint_as_in_a_terminal() -> None:
    # a shell's background job (e.g. a CI script run with `&`) inherits SIGINT *ignored*, and Python keeps
    # an ignored SIGINT: the batch under test would never see the Ctrl-C this file sends it
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _start(args, env) -> subprocess.Popen:
    return subprocess.Popen([*MOCAPKIT, *map(str, args)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            start_new_session=True, env=env, preexec_fn=_sigint_as_in_a_terminal)


def _wait_rows(journal: Path, proc: subprocess.Popen, n: int, timeout: float = 180.0) -> list[dict]:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        rows = read_journal(journal) if journal.exists() else []
        if len(rows) >= n:
            return rows
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.02)
    raise AssertionError(f"no {n} journal rows within {timeout} s")


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGKILL)
    proc.communicate()


def test_resume_after_kill_9_loses_and_duplicates_no_row(takes, tmp_path):
    out = tmp_path / "out"
    cache = tmp_path / "numba"  # a fresh numba cache: the workers compile into it (and it slows the start)
    args = ["batch", "compress", takes, "--out", out, "-t", "0.01", "--jobs", "2"]
    env = _env(tmp_path, NUMBA_CACHE_DIR=str(cache))
    proc = _start(args, env)
    try:
        _wait_rows(out / "journal.jsonl", proc, 1)
        os.killpg(proc.pid, signal.SIGKILL)  # the main process, its forkserver and its workers
        proc.communicate()
    finally:
        _stop(proc)
    before = read_journal(out / "journal.jsonl")
    assert 1 <= len(before) < N_TAKES, "the kill must come in the middle of the batch"
    assert not (out / "results.parquet").exists()
    # the workers compiled into the one cache folder given to the main process
    assert list(cache.rglob("*.nbi")), "no numba index in NUMBA_CACHE_DIR"

    done = subprocess.run([*MOCAPKIT, *map(str, args), "--resume"], capture_output=True, text=True,
                          env=env, timeout=600)
    assert done.returncode == 0, done.stderr
    assert f"{len(before)} kept from an earlier run" in done.stdout
    rows = read_results(out / "results.parquet")
    inputs = sorted(str(p) for p in takes.rglob("*.amc"))
    assert [r["input"] for r in rows] == inputs  # every input once, none lost, none twice
    assert all(r["status"] == "ok" for r in rows)
    by_input = {r["input"]: r for r in rows}
    for r in before:  # the rows finished before the kill are kept as they were, not run again
        assert by_input[r["input"]] == r
    for r in rows:  # and every output is there, whole
        out_file = Path(json.loads(r["record_json"])["outputs"][0]["path"])
        assert out_file.stat().st_size == json.loads(r["record_json"])["outputs"][0]["bytes"] > 0
        assert out_file.read_bytes()[:4] == b"glTF"


def _children(pid: int) -> list[int]:
    kids = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as f:
                    ppid = int(f.read().rsplit(")", 1)[1].split()[1])
            except OSError:
                continue
            if ppid == pid:
                kids.append(int(d))
    return kids


def _cmdline(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            return f.read().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


def test_a_killed_worker_costs_no_row(takes, tmp_path):
    out = tmp_path / "out"
    proc = _start(["batch", "compress", takes, "--out", out, "-t", "0.01", "--jobs", "2"], _env(tmp_path))
    try:
        _wait_rows(out / "journal.jsonl", proc, 1)
        server = [p for p in _children(proc.pid) if "forkserver" in _cmdline(p)]
        assert len(server) == 1, [(_cmdline(p)) for p in _children(proc.pid)]
        workers = _children(server[0])
        assert workers, "no worker process found"
        n_before = len(read_journal(out / "journal.jsonl"))
        os.kill(workers[0], signal.SIGKILL)
        stdout, stderr = proc.communicate(timeout=600)
    finally:
        _stop(proc)
    assert proc.returncode == 0, stderr.decode()
    assert n_before < N_TAKES, "the worker must be killed in the middle of the batch"
    rows = read_results(out / "results.parquet")
    assert [r["input"] for r in rows] == sorted(str(p) for p in takes.rglob("*.amc"))
    assert all(r["status"] == "ok" for r in rows), [r["error"] for r in rows if r["status"] != "ok"]


def _group(pid: int) -> set[int]:
    """Every live process of the batch's process group (its forkserver and workers)."""
    out = set()
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                if os.getpgid(int(d.name)) == pid and int(d.name) != pid:
                    out.add(int(d.name))
            except (ProcessLookupError, PermissionError):
                pass
    return out


def test_ctrl_c_twice_stops_at_once_says_how_to_resume_and_resume_finishes(takes, tmp_path):
    """Ctrl-C as a terminal sends it (SIGINT to the whole process group), twice: the batch exits 130 at once
    with one line naming --resume, its workers are gone, and --resume runs only the rest."""
    out = tmp_path / "out"
    args = ["batch", "compress", takes, "--out", out, "-t", "0.01", "--jobs", "2"]
    env = _env(tmp_path)
    proc = _start(args, env)
    try:
        _wait_rows(out / "journal.jsonl", proc, 2)
        os.killpg(proc.pid, signal.SIGINT)
        time.sleep(0.3)
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)
        t0 = time.monotonic()
        _, stderr = proc.communicate(timeout=30)
        assert time.monotonic() - t0 < 10  # no hang, no waiting for the inputs in flight
    finally:
        _stop(proc)
    assert proc.returncode == 130, stderr
    last = stderr.decode().strip().splitlines()[-1]
    assert last.startswith("interrupted: ") and "--resume" in last and str(out / "journal.jsonl") in last
    deadline = time.monotonic() + 5  # the forkserver and resource tracker end when they see the main gone
    while _group(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.1)
    left = {p: Path(f"/proc/{p}/cmdline").read_bytes().replace(b"\0", b" ")[:200] for p in _group(proc.pid)}
    assert not left  # no worker left running
    done = read_journal(out / "journal.jsonl")
    assert 2 <= len(done) < N_TAKES and all(r["status"] == "ok" for r in done)
    r = subprocess.run([*MOCAPKIT, *map(str, args), "--resume"], capture_output=True, text=True, env=env,
                       timeout=600)
    assert r.returncode == 0, r.stderr
    assert f"{len(done)} kept from an earlier run" in r.stdout
    rows = read_results(out / "results.parquet")
    assert len(rows) == N_TAKES == len({x["input"] for x in rows})
    kept = {x["input"]: x for x in done}
    for x in rows:  # the rows finished before Ctrl-C are the ones kept, unchanged
        if x["input"] in kept:
            assert x == kept[x["input"]]


class _BreaksAtSubmit:
    """A real process pool whose workers are all killed just before its ``k``-th submit, so that submit
    meets a pool already broken (the race between ``wait`` and ``submit`` a dying worker opens)."""

    def __init__(self, pool, k: int):
        self.pool, self.k, self.submits = pool, k, 0

    def submit(self, *args, **kw):
        self.submits += 1
        if self.submits == self.k:
            for p in list(self.pool._processes.values()):
                p.kill()
            deadline = time.monotonic() + 60
            while not self.pool._broken and time.monotonic() < deadline:
                time.sleep(0.01)
            assert self.pool._broken, "the pool did not notice its killed workers"
        return self.pool.submit(*args, **kw)

    def __getattr__(self, name):
        return getattr(self.pool, name)


def test_a_pool_broken_between_wait_and_submit_costs_no_row(takes, tmp_path, monkeypatch):
    """The first pool breaks at a submit (not while waiting): the batch still gives one ok row per input."""
    from concurrent.futures.process import BrokenProcessPool

    from mocapkit.batch import engine

    real_pool, made = engine._pool, []

    def pool(n, ctx):
        p = real_pool(n, ctx)
        made.append(p)
        return _BreaksAtSubmit(p, 6) if len(made) == 1 else p

    monkeypatch.setattr(engine, "_pool", pool)
    options = {"asf": None, "rate": None, "time_column": None, "quaternion_columns": None, "scalar_last": False,
               "time_unit": None, "strict": True}
    res = engine.run_batch("info", [takes], options, tmp_path / "out", jobs=2)
    assert made[0]._broken, "the first pool must have broken"
    with pytest.raises(BrokenProcessPool):
        made[0].submit(print)
    assert [r["input"] for r in res.rows] == sorted(str(p) for p in takes.rglob("*.amc"))
    assert all(r["status"] == "ok" for r in res.rows), [r["error"] for r in res.rows if r["status"] != "ok"]
