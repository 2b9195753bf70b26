"""Line-by-line parsing of an IMU CSV stream (``mocapkit stream`` reads stdin with it).

The header is found exactly as for files (:mod:`mocapkit.io.imu.layout`: any layout with one sensor,
the same overrides); the lines before the first data row are buffered, then every row is parsed and
yielded at once (a data row is told from a units row by its time and orientation cells, so a first
column holding a date is data; at most :data:`MAX_HEAD_LINES` lines are buffered). When the first
line is numeric, the rows are headerless ``time,w,x,y,z`` (seconds).
Counters become times with the first counter step (a file reader uses the most frequent step).
Blank lines are skipped, and so are the frames in which an OptiTrack rigid body is lost (empty
cells; the file reader counts them in ``meta["warnings"]``). Every row follows the file reader's
rules (:mod:`mocapkit.io.imu.rows`: strict finite numbers, time steps of at least 1 ns), so no
``nan``/``inf`` or out-of-range sample is ever yielded. Lines are read with a bounded ``readline``
(at most 1 MiB: ``/dev/zero`` or a pipe without line ends fails at once), a NUL byte or
undecodable bytes are errors, and a last line without a line end (after lines with one) is checked
for a number cut short by the file reader's rules (a)-(c) (:mod:`mocapkit.io.imu.rows`): an error
when it ends with ``.``, ``e``, ``E``, ``+`` or ``-`` or has fewer decimals than its fixed-decimal
column, a :class:`~mocapkit.errors.MocapWarning` (:func:`warnings.warn`; a stream has no ``meta``)
when it is only shorter than others of a column with varying decimals. Memory stays constant: only
the last 20 rows' text is kept.
Every problem raises :class:`~mocapkit.errors.MocapFormatError` with the line number, after the
samples before it have been yielded (so a live consumer has already used them).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Iterator

from mocapkit.errors import MocapFormatError
from mocapkit.io.imu.columns import (
    ColumnOptions,
    Orientation,
    TimeColumn,
    find_orientations,
    is_metadata_line,
    is_numeric_row,
    sniff_delimiter,
    split_fields,
)
from mocapkit.io.imu.layout import Layout, find_layout
from mocapkit.io.imu.lines import MAX_LINE_BYTES, check_line
from mocapkit.io.imu.rows import CUT_CONTEXT, RowReader

__all__ = ["MAX_HEAD_LINES", "iter_samples"]

#: Non-blank lines buffered before the first data row at most; then the header must be found (or an error).
MAX_HEAD_LINES = 1000


def _names_orientation(fields: list[str], opts: ColumnOptions, source: str, lineno: int) -> bool:
    """May this line be the header (are orientation columns named in it)? A cheap gate for
    :func:`_data_started`; an ambiguous header counts (the layout then reports it)."""
    try:
        return bool(find_orientations([f.strip() for f in fields], opts, source, lineno, xsens=True))
    except MocapFormatError:
        return True


def _data_started(head: list[str], source: str, opts: ColumnOptions) -> bool:
    """Does ``head`` hold a header and a first data row (which may start with a date or text)?
    ``True`` as well when the layout is wrong: the caller then reads it and reports the error."""
    try:
        lay = find_layout(head, len(head), source, None, opts, probe=True)
    except MocapFormatError:
        return True
    return lay.data_index < len(head)


def _headerless(line: str, delim: str | None, source: str, lineno: int, rate: float | None,
                opts: ColumnOptions) -> Layout:
    n = len(split_fields(line, delim))
    if n != 5:
        raise MocapFormatError(source, lineno,
                               f"a stream without a header must have rows time,w,x,y,z; got {n} columns")
    if rate is not None or opts.any:
        raise MocapFormatError(source, lineno, "headerless time,w,x,y,z rows have timestamps in seconds: "
                               "do not give --rate or column options")
    names = ["time", "w", "x", "y", "z"]
    return Layout("generic", delim, names, lineno - 2, lineno - 1, TimeColumn(0, "time", "s"),
                  [Orientation("quaternion", (1, 2, 3, 4), ("w", "x", "y", "z"))], None)


def _bounded(lines: Iterable[str], source: str) -> Iterator[str]:
    """The lines of ``lines``; a file object is read with ``readline(limit)`` so that no line (e.g. from
    ``/dev/zero`` or a pipe without line ends) is read beyond :data:`~mocapkit.io.imu.lines.MAX_LINE_BYTES`."""
    readline = getattr(lines, "readline", None)
    if readline is None:
        yield from lines
        return
    n = 0
    while True:
        try:
            line = readline(MAX_LINE_BYTES + 1)
        except UnicodeDecodeError as exc:
            raise MocapFormatError(source, n + 1, f"not UTF-8 text ({exc.reason})") from None
        except OSError as exc:
            raise MocapFormatError(source, n + 1, f"cannot read: {exc.strerror or exc}") from None
        if not line:
            return
        n += 1
        yield line


def _not_utf8(line: str) -> bool:
    """Undecodable bytes read with ``surrogateescape`` (stdin in a POSIX locale) show as lone surrogates."""
    try:
        line.encode("utf-8")
    except UnicodeEncodeError:
        return True
    return False


def iter_samples(
    lines: Iterable[str], source: str = "<stdin>", rate: float | None = None, *,
    options: ColumnOptions | None = None, **columns,
) -> Iterator[tuple[int, float, tuple[float, float, float, float]]]:
    """Yield ``(line_number, time_s, (w, x, y, z))`` for each data row of a CSV stream.

    ``lines``: a text file object (read with a bounded ``readline``) or any iterable of lines.
    ``columns``: ``time_column``, ``quaternion_columns``, ``scalar_last``, ``time_unit`` (or one
    :class:`~mocapkit.io.imu.columns.ColumnOptions` as ``options``).
    """
    opts = options if options is not None else ColumnOptions(
        **{k: v for k, v in columns.items() if v is not None and v is not False})
    head: list[str] = []
    reader: RowReader | None = None
    seen_text = False
    header_seen = False
    n_text = 0      # non-blank lines buffered
    ended = False   # a line with a line end was seen (then one without is the input's last, maybe cut)
    tail: deque[str] = deque(maxlen=CUT_CONTEXT)
    for lineno, raw in enumerate(_bounded(lines, source), start=1):
        has_end = raw.endswith("\n")
        line = raw.rstrip("\r\n")
        check_line(line, source, lineno)
        if not line.isascii() and _not_utf8(line):
            raise MocapFormatError(source, lineno, "not UTF-8 text (undecodable bytes)")
        if lineno == 1:
            line = line.lstrip("\ufeff")
        cut_check = ended and not has_end
        ended = ended or has_end
        if reader is None:
            head.append(line)
            if not line.strip():
                continue
            n_text += 1
            fields = split_fields(line, sniff_delimiter(line))
            if is_metadata_line(fields, line):
                seen_text = True
                continue
            if not is_numeric_row(fields) and n_text <= MAX_HEAD_LINES:
                if not header_seen:     # a title or the header line
                    header_seen = _names_orientation(fields, opts, source, lineno)
                    seen_text = True
                    continue
                if not _data_started(head, source, opts):   # a units row under the header
                    continue
            if not seen_text:
                lay = _headerless(line, sniff_delimiter(line), source, lineno, rate, opts)
            else:
                lay = find_layout(head, len(head), source, rate, opts)
            if len(lay.sensors) != 1:
                raise MocapFormatError(source, lay.header_line, f"a stream carries one sensor; this header has "
                                       f"{len(lay.sensors)} ({', '.join(str(s.sensor) for s in lay.sensors)})")
            reader = RowReader(lay, source, online=True)
            for k in range(lay.data_index, len(head)):
                if head[k].strip():
                    if cut_check and k == len(head) - 1:
                        reader.check_cut_line([reader.split(x) for x in tail], head[k], k + 1)
                    yield from _emit(reader, head[k], k + 1)
                    tail.append(head[k])
            head = []
            continue
        if not line.strip():
            continue
        if cut_check:
            reader.check_cut_line([reader.split(x) for x in tail], line, lineno)
        yield from _emit(reader, line, lineno)
        tail.append(line)
    if reader is None:
        end = len(head)
        while end > 0 and not head[end - 1].strip():
            end -= 1
        if end == 0:
            raise MocapFormatError(source, 1, "empty input (expected a header line such as 'Timestamp (us),W,X,Y,Z')")
        find_layout(head, end, source, rate, opts)  # raises: header only, or no header
        raise MocapFormatError(source, end, "no data rows")  # pragma: no cover - find_layout raised


def _emit(reader: RowReader, line: str, lineno: int):
    out = reader.feed(line, lineno)
    assert out is not None
    t, qs = out
    q = qs[0]
    if q is None:       # an OptiTrack rigid body lost in this frame (empty cells): no sample
        return
    yield lineno, t, (float(q[0]), float(q[1]), float(q[2]), float(q[3]))
