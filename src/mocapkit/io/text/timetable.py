"""A plain CSV table with a time column: ``time,<name>,<name>...`` then one row of numbers a line.

This is what ``mocapkit filter`` reads when its input is neither a marker file nor a skeletal one.

- Line 1 is a header: at least two cells, the first naming the time column (a number there means the
  file has no header, and is refused from the first chunk, so an endless pipe fails at once).
- Every other non-blank line has as many cells as the header. Numbers follow the strict grammar of
  :mod:`mocapkit.io.text.numbers`; a value cell may be empty or ``nan``/``NaN`` (a missing sample), a time
  cell may not. Times are strictly increasing.
- A file that ends without a newline has its last row judged against the rows above it
  (:func:`~mocapkit.io.text.input.final_line_verdict`): a cut value is an error, an undecidable one a
  warning.
- Input is read with :func:`~mocapkit.io.text.input.read_input` (a pipe or device in bounded chunks up
  to :data:`~mocapkit.io.text.input.MAX_STREAM_BYTES`); rows are parsed one at a time into one
  preallocated ``float64`` array (no list of lines or of rows is built), after checking that the row
  count times the column count fits the file's size.
"""

from __future__ import annotations

import os
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from mocapkit.errors import MocapFormatError
from mocapkit.io.text.input import (
    MAX_HEADER_LINE,
    check_cells_budget,
    decode_text,
    final_line_verdict,
    read_input,
    report_final_line,
)
from mocapkit.io.text.numbers import NUMBER_RE, parse_number

__all__ = ["TimeTable", "read_time_table"]

_MISSING = ("", "nan", "NaN")
_TAIL_ROWS = 32  # rows kept as text to judge a final line without a newline


@dataclass
class TimeTable:
    """``columns`` (the value columns' names), ``times`` ``(N,)`` s, ``values`` ``(N, len(columns))``
    (NaN for a missing sample), ``source`` and the reader's ``warnings``."""

    columns: list[str]
    times: np.ndarray
    values: np.ndarray
    source: str
    warnings: list[str] = field(default_factory=list)


def _header_cells(line: str) -> list[str]:
    return [h.strip() for h in line.split(",")]


def _check_header(src: str, cells: list[str]) -> None:
    if len(cells) < 2:
        raise MocapFormatError(src, 1, f"only one column ({cells[0][:40]!r}): a time column and at least one "
                               "value column are needed")
    if NUMBER_RE.fullmatch(cells[0]):
        raise MocapFormatError(src, 1, f"the first line starts with a number ({cells[0][:40]!r}), not a column "
                               "name: the CSV needs a header line naming the time column and the value "
                               "columns (e.g. time,x,y)")


def _head_checker(src: str):
    def check(chunk: bytes) -> None:
        if chunk.startswith(b"\xef\xbb\xbf"):
            chunk = chunk[3:]
        if not chunk.strip():
            return  # blank so far: judged after reading ("empty file")
        k = chunk.find(b"\n")
        if k < 0:
            if len(chunk) >= MAX_HEADER_LINE:
                raise MocapFormatError(src, 1, f"the first line is longer than {MAX_HEADER_LINE:,} bytes: "
                                       "not a CSV header")
            return  # the whole input is one line: judged after reading
        line = chunk[:k].decode("utf-8", errors="replace").rstrip("\r")
        _check_header(src, _header_cells(line))
    return check


def _lines(text: str):
    """``(line number, line)`` for every line, without building a list (CR/LF ends accepted)."""
    pos, n, no = 0, len(text), 0
    while pos < n:
        k = text.find("\n", pos)
        if k < 0:
            k = n
        no += 1
        yield no, text[pos:k].rstrip("\r")
        pos = k + 1


def read_time_table(path: str | os.PathLike[str], what: str = "CSV file") -> TimeTable:
    """Read a time table CSV (see the module notes); every problem is a :class:`MocapFormatError`
    naming ``path``, the line and the column."""
    src = str(path)
    data = read_input(path, what, text=True, check_head=_head_checker(src))
    size = len(data)
    text, _enc = decode_text(data)
    del data
    if "\n" not in text and "\r" in text:  # classic Mac line ends
        text = text.replace("\r", "\n")
    if not text.strip():
        raise MocapFormatError(src, None, "empty file")
    lines = _lines(text)
    _, first = next(lines)
    header = _header_cells(first)
    _check_header(src, header)
    C = len(header)
    n_rows = text.count("\n")  # at most this many data rows (the header takes one newline or is alone)
    final_no = n_rows if text.endswith("\n") else n_rows + 1  # number of the last line
    check_cells_budget(src, None, (n_rows + 1) * C, size, "the table")
    out = np.empty((n_rows + 1, C), dtype=np.float64)
    line_of = np.empty(n_rows + 1, dtype=np.int64)
    names = [h or f"column {k + 1}" for k, h in enumerate(header)]
    tail: deque[list[str]] = deque(maxlen=_TAIL_ROWS)
    last_no, last_cells, i = 0, None, 0  # the latest data row (its line and cells)
    for no, ln in lines:
        if not ln.strip():
            continue
        cells = ln.split(",")
        if len(cells) != C:
            if no == final_no and not text.endswith("\n") and last_cells is not None:
                report_final_line(src, no, "fields", None, "", "", [])  # cut short: says so
            raise MocapFormatError(src, no, f"expected {C} columns, got {len(cells)}")
        row = out[i]
        for k, x in enumerate(cells):
            row[k] = parse_number(x.strip(), src, no, names[k], missing=() if k == 0 else _MISSING)
        line_of[i] = no
        if last_cells is not None:
            tail.append(last_cells)
        last_no, last_cells, i = no, cells, i + 1
    if i == 0:
        raise MocapFormatError(src, None, "header only, no data rows")
    warnings_list: list[str] = []
    if text[text.rfind("\n") + 1:].strip() and last_cells is not None:  # the last data row has no newline
        verdict, j = final_line_verdict(list(tail), last_cells)
        jj = len(last_cells) - 1 if j is None else j
        report_final_line(src, last_no, verdict, j, names[jj], last_cells[jj], warnings_list)
    del text
    table = out[:i]
    t = table[:, 0]
    bad = np.flatnonzero(~(np.diff(t) > 0))
    if bad.size:
        r = int(bad[0]) + 1
        raise MocapFormatError(src, int(line_of[r]), f"{names[0]}: {float(t[r])!r} is not after the previous "
                               f"row's {float(t[r - 1])!r}; times must be strictly increasing")
    return TimeTable(header[1:], t, table[:, 1:], src, warnings_list)  # views: no copy of the table
