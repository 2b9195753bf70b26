"""Issue 10: the plain time-table CSV that ``mocapkit filter`` reads (io/text/timetable.py) — strict,
bounded, one-line errors; an endless header-less pipe is refused at once within bounded memory."""

from __future__ import annotations

import contextlib
import csv
import json
import math
import os
import resource
import subprocess
import sys
import threading
import time
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mocapkit.errors import MocapFormatError, MocapWarning
from mocapkit.io.text.timetable import read_time_table

EXE = [sys.executable, "-m", "mocapkit.cli"]


def _reference(path):
    """Independent parse with the csv module and float(): (names, times, values with NaN for '')."""
    with open(path, newline="") as fh:
        rows = [r for r in csv.reader(fh) if any(c.strip() for c in r)]
    head = [h.strip() for h in rows[0]]
    body = [[float(c) if c.strip() not in ("", "nan", "NaN") else math.nan for c in r] for r in rows[1:]]
    a = np.array(body, dtype=float).reshape(len(body), len(head))
    return head[1:], a[:, 0], a[:, 1:]


@given(
    n=st.integers(1, 40), c=st.integers(1, 4), crlf=st.booleans(),
    vals=st.lists(st.one_of(st.floats(-1e6, 1e6, allow_nan=False), st.just(math.nan)), min_size=200, max_size=200),
)
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_read_time_table_equals_an_independent_parse(tmp_path, n, c, crlf, vals):
    nl = "\r\n" if crlf else "\n"
    lines = ["time," + ",".join(f"s{k}" for k in range(c))]
    it = iter(vals * 2)
    for i in range(n):
        cells = [repr(0.01 * i)] + ["" if math.isnan(v := next(it)) else repr(v) for _ in range(c)]
        lines.append(",".join(cells))
    p = tmp_path / "t.csv"
    p.write_bytes((nl.join(lines) + nl).encode())
    tab = read_time_table(p)
    names, t, v = _reference(p)
    assert tab.columns == names and tab.warnings == []
    assert np.array_equal(tab.times, t) and np.array_equal(tab.values, v, equal_nan=True)


@pytest.mark.parametrize("text,line,fragment", [
    ("1.0,2.0,3.0\n4.0,5.0,6.0\n", 1, "starts with a number ('1.0'), not a column name"),
    ("time\n1\n2\n", 1, "only one column"),
    ("time,x\n0,1\n0.1,0_5\n", 3, "x: '0_5' is not a number"),
    ("time,x\n0,1\n0.1,1e308\n", 3, "out of range"),
    ("time,x\n0,1\n0.1,inf\n", 3, "x: 'inf' is not a number"),
    ("time,x\n0,1\n,2\n", 3, "time: "),  # a time cell may not be missing
    ("time,x\n0,1\n0.1,2,3\n", 3, "expected 2 columns, got 3"),
    ("time,x\n0,1\n0,2\n", 3, "time: 0.0 is not after the previous row's 0.0"),
    ("time,x\n0,1.00\n0.1,2.00\n0.2,3", 4, "cut short"),  # a number cut at the end of the file
    ("time,x,y\n0,1,2\n0.1,2,3\n0.2,3", 4, "cut short"),  # a row cut at the end of the file
    ("time,x\n", None, "header only"),
    ("\n\n", None, "empty file"),
])
def test_bad_tables_are_errors_naming_file_line_and_column(tmp_path, text, line, fragment):
    p = tmp_path / "bad.csv"
    p.write_text(text)
    with pytest.raises(MocapFormatError) as ei:
        read_time_table(p)
    assert ei.value.path == str(p) and ei.value.line == line and fragment in ei.value.problem, ei.value


def test_final_line_without_newline_complete_or_undecidable(tmp_path):
    p = tmp_path / "a.csv"
    p.write_text("time,x\n0,1.00\n0.1,2.00\n0.2,3.00")  # fixed decimals, complete: no word
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert read_time_table(p).values[-1, 0] == 3.0
    p.write_text("time,x\n0,1.5\n0.1,2.25\n0.2,3.1")  # decimals vary: cannot tell, so a warning
    with pytest.warns(MocapWarning, match="may be cut short"):
        tab = read_time_table(p)
    assert len(tab.warnings) == 1 and tab.values[-1, 0] == 3.1


def test_latin1_bom_and_blank_lines(tmp_path):
    p = tmp_path / "l.csv"
    p.write_bytes(b"\xef\xbb\xbftime,x\n0,1\n\n0.1,2\n\n")
    tab = read_time_table(p)
    assert tab.columns == ["x"] and tab.times.tolist() == [0.0, 0.1]
    p.write_bytes("time,\u00e9l\u00e9ment\n0,1\n".encode("latin-1"))
    assert read_time_table(p).columns == ["\u00e9l\u00e9ment"]


def _limit_memory():
    resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))


def _feed_forever(fifo, stop: threading.Event, line: bytes) -> None:
    try:
        fd = os.open(fifo, os.O_WRONLY)
    except OSError:
        return
    block = line * 4096
    try:
        while not stop.is_set():
            os.write(fd, block)
    except OSError:  # the reader closed the pipe (EPIPE): done
        pass
    finally:
        os.close(fd)


@pytest.mark.parametrize("line,fragment", [
    (b"1.0,2.0,3.0,4.0,5.0\n", "starts with a number ('1.0'), not a column name"),
    (b"x" * 1000, "the first line is longer than"),  # no newline ever
])
def test_endless_fifo_without_header_is_refused_at_once_in_bounded_memory(tmp_path, line, fragment):
    fifo = tmp_path / "endless.csv"
    os.mkfifo(fifo)
    stop = threading.Event()
    writer = threading.Thread(target=_feed_forever, args=(fifo, stop, line), daemon=True)
    writer.start()
    t0 = time.monotonic()
    try:
        r = subprocess.run([*EXE, "filter", str(fifo), "--auto", "--json"], capture_output=True, text=True,
                           timeout=120, preexec_fn=_limit_memory, cwd=tmp_path)
    finally:
        stop.set()
        with contextlib.suppress(OSError):  # unblock a writer still waiting for a reader
            os.close(os.open(fifo, os.O_RDONLY | os.O_NONBLOCK))
        writer.join(10)
    assert r.returncode == 2, r.stderr[-2000:]
    assert r.stderr.startswith(f"error: {fifo}:") and r.stderr.count("\n") == 1 and fragment in r.stderr, r.stderr
    assert r.stdout == "" and time.monotonic() - t0 < 60


def test_endless_fifo_with_header_stops_at_the_pipe_cap(tmp_path, monkeypatch):
    """A header then endless rows: refused when the pipe cap is reached (lowered here to keep it quick)."""
    import mocapkit.io.text.input as ti

    monkeypatch.setattr(ti, "MAX_STREAM_BYTES", 8 << 20)
    fifo = tmp_path / "endless.csv"
    os.mkfifo(fifo)
    stop = threading.Event()

    def feed():
        try:
            fd = os.open(fifo, os.O_WRONLY)
        except OSError:
            return
        try:
            os.write(fd, b"time,x\n")
            k = 0
            while not stop.is_set():
                os.write(fd, b"".join(b"%d,1.0\n" % (k + i) for i in range(4096)))
                k += 4096
        except OSError:
            pass
        finally:
            os.close(fd)

    w = threading.Thread(target=feed, daemon=True)
    w.start()
    try:
        with pytest.raises(MocapFormatError, match="bytes from a pipe or device"):
            read_time_table(fifo)
    finally:
        stop.set()
        w.join(10)


def test_cli_filter_reads_the_table_and_prints_strict_json(tmp_path):
    t = np.arange(200) / 100.0
    y = np.where(t < 1.0, 0.0, 1.0) + 0.01 * np.sin(37 * t)
    p = tmp_path / "step.csv"
    p.write_text("time,y\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(t, y, strict=True)))
    r = subprocess.run([*EXE, "filter", str(p), "--auto", "--json"], capture_output=True, text=True,
                       timeout=300, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    rec = json.loads(r.stdout, parse_constant=lambda c: pytest.fail(f"non-finite {c}"))
    assert rec[0]["name"] == "y" and rec[0]["pieces"][0]["t0"] == 0.0 and rec[0]["pieces"][-1]["t1"] == t[-1]
