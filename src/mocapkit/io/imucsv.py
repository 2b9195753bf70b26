"""Readers and writers of IMU orientation exports (quaternion CSV/text files).

Every reader returns a :class:`mocapkit.motion.Signal` of kind ``"quaternion"``: ``times`` in float64
seconds (strictly increasing, irregular sampling kept as is) and ``values`` ``(N, 4)`` float64,
scalar-first ``w, x, y, z`` exactly as parsed by :func:`float` (never normalised, sign-flipped or
reordered).

The format is recognised from the header line:

==============  =========================================================  ==============================
format          header                                                     time
==============  =========================================================  ==============================
``x-io``        ``Timestamp (us),W,X,Y,Z``                                 ``us / 1e6``
``ngimu``       ``Time (s),W,X,Y,Z``                                       seconds as written
``x-io-legacy`` ``Packet number,Element 1,Element 2,Element 3,Element 4``  ``(packet - first) / rate``
``xsens``       ``//`` lines, then a tab-separated header with             ``(counter - first) / rate`` or
                ``Quat_w Quat_x Quat_y Quat_z`` (or ``Quat_q0..Quat_q3``)   ``row / rate``
                and optionally ``PacketCounter`` / ``Counter``
``generic``     ``time,w,x,y,z`` (any case, spaces allowed)                seconds as written
==============  =========================================================  ==============================

Anything wrong with the content raises :class:`mocapkit.errors.MocapFormatError` naming the file and
the 1-based line.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

import numpy as np

from mocapkit.errors import (
    InvalidParameterError,
    InvalidSignalError,
    MocapFormatError,
)
from mocapkit.io.atomic import atomic_write_text, read_file_bytes
from mocapkit.motion import Signal

__all__ = [
    "ACCEPTED_HEADERS",
    "READERS",
    "detect_format",
    "format_row",
    "load_signals",
    "read_imu_csv",
    "read_imu_text",
    "read_sensor_folder",
    "register_reader",
    "sample_data_path",
    "write_signal_csv",
]

#: Human-readable list of the accepted headers (used in error messages).
ACCEPTED_HEADERS = (
    "'Timestamp (us),W,X,Y,Z' (x-io)",
    "'Time (s),W,X,Y,Z' (NGIMU)",
    "'Packet number,Element 1,Element 2,Element 3,Element 4' (legacy x-io; needs --rate HZ)",
    "a tab-separated Xsens MT Manager header with Quat_w Quat_x Quat_y Quat_z "
    "(or Quat_q0..Quat_q3) and optionally PacketCounter/Counter",
    "'time,w,x,y,z' (generic, seconds)",
)

#: Suffixes of files that may hold sensor data inside a sensor folder.
DATA_SUFFIXES = (".csv", ".txt")

#: A decrease of a uint16 counter counts as a wrap-around when the unwrapped step is at most this
#: (serial-number arithmetic: half of the counter range) and the next row continues from it.
MAX_WRAP_STEP = 32768
_U16 = 65536

_BOM = "\ufeff"
_RATE_RE = re.compile(
    r"^\s*//\s*(?:sample|update|output)\s*(?:rate|frequency)\s*:\s*(?P<value>.*?)\s*$", re.IGNORECASE
)
_HZ_RE = re.compile(r"\s*hz\s*$", re.IGNORECASE)

# format name -> (normalised header names, time kind)
_COMMA_FORMATS: dict[tuple[str, ...], tuple[str, str]] = {
    ("timestamp (us)", "w", "x", "y", "z"): ("x-io", "us"),
    ("time (s)", "w", "x", "y", "z"): ("ngimu", "s"),
    ("packet number", "element 1", "element 2", "element 3", "element 4"): ("x-io-legacy", "counter"),
    ("time", "w", "x", "y", "z"): ("generic", "s"),
}
_XSENS_QUAT = (("quat_w", "quat_x", "quat_y", "quat_z"), ("quat_q0", "quat_q1", "quat_q2", "quat_q3"))
_XSENS_COUNTER = ("packetcounter", "counter")


def _norm(name: str) -> str:
    return " ".join(name.split()).lower()


def _short(text: str, limit: int = 80) -> str:
    return repr(text if len(text) <= limit else text[:limit] + "...")


class _Layout:
    """Where the columns of one recognised header are."""

    def __init__(self, fmt: str, delim: str, names: list[str], time_kind: str | None,
                 time_col: int | None, quat_cols: tuple[int, int, int, int]):
        self.fmt = fmt
        self.delim = delim
        self.names = names            # column names as written (stripped)
        self.time_kind = time_kind    # "us", "s", "counter" or None (row index)
        self.time_col = time_col
        self.quat_cols = quat_cols


def _identify(header: str) -> _Layout | None:
    """Return the layout of a header line, or ``None`` when it is not a quaternion format."""
    comma = [c.strip() for c in header.split(",")]
    spec = _COMMA_FORMATS.get(tuple(_norm(c) for c in comma))
    if spec is not None:
        fmt, kind = spec
        return _Layout(fmt, ",", comma, kind, 0, (1, 2, 3, 4))
    delim = "\t" if "\t" in header else ","
    names = [c.strip() for c in header.split(delim)]
    lowered = [_norm(c) for c in names]
    for quat in _XSENS_QUAT:
        if all(lowered.count(q) == 1 for q in quat):
            cols = tuple(lowered.index(q) for q in quat)
            counter = next((lowered.index(c) for c in _XSENS_COUNTER if lowered.count(c) == 1), None)
            return _Layout("xsens", delim, names, "counter" if counter is not None else None,
                           counter, cols)  # type: ignore[arg-type]
    return None


def _check_rate_arg(rate: float | None) -> float | None:
    if rate is None:
        return None
    try:
        r = float(rate)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"rate must be a number of Hz, got {rate!r}") from None
    if not (math.isfinite(r) and r > 0):
        raise InvalidParameterError(f"rate must be a finite positive number of Hz, got {rate!r}")
    return r


def _split_lines(text: str) -> list[str]:
    if text.startswith(_BOM):
        text = text[1:]
    lines = text.split("\n")
    return [ln[:-1] if ln.endswith("\r") else ln for ln in lines]


def _decode(data: bytes, src: str) -> str:
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise MocapFormatError(
            src, line, f"not UTF-8 text: byte 0x{data[exc.start]:02x} cannot be decoded"
        ) from None


def _default_name(source: str) -> str:
    if source.startswith("<") and source.endswith(">"):
        return source[1:-1]
    return Path(source).stem


# --------------------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------------------


def read_imu_csv(path: str | Path, rate: float | None = None, name: str | None = None) -> Signal:
    """Read one IMU orientation export (format recognised from its header).

    Parameters
    ----------
    path
        The file.
    rate
        Sample rate in Hz; needed by the legacy x-io format and by Xsens exports without a
        ``// Sample rate:`` line, refused by formats with timestamps.
    name
        The signal's name; default: the file's stem.
    """
    p = Path(path)
    src = str(p)
    data = read_file_bytes(p, "file")
    text = _decode(data, src)
    return read_imu_text(text, src, rate=rate, name=p.stem if name is None else name)


def read_imu_text(text: str, source: str, rate: float | None = None,
                  name: str | None = None) -> Signal:
    """Parse the text of an IMU orientation export (e.g. read from stdin).

    ``source`` labels the text in messages (a path or ``"<stdin>"``); ``name`` defaults to the
    source's stem (``"stdin"`` for ``"<stdin>"``).
    """
    r = _check_rate_arg(rate)
    src = str(source)
    lines = _split_lines(text)
    return _parse(lines, src, r, _default_name(src) if name is None else name)


def _find_header(lines: list[str], src: str) -> tuple[int, int, list[tuple[int, str]]]:
    """Return ``(end, header_index, preamble)``; ``preamble`` holds ``(index, line)`` of ``//`` lines."""
    end = len(lines)
    while end > 0 and not lines[end - 1].strip():
        end -= 1
    if end == 0:
        raise MocapFormatError(src, 1, "empty file (expected a header line such as 'Timestamp (us),W,X,Y,Z')")
    i = 0
    preamble: list[tuple[int, str]] = []
    while i < end and (not lines[i].strip() or lines[i].lstrip().startswith("//")):
        if lines[i].strip():
            preamble.append((i, lines[i]))
        i += 1
    if i >= end:
        raise MocapFormatError(src, end, "only '//' comment lines: no header line and no data")
    return end, i, preamble


def _file_rate(preamble: list[tuple[int, str]], src: str) -> tuple[float | None, int | None]:
    rate: float | None = None
    rate_line: int | None = None
    for idx, line in preamble:
        m = _RATE_RE.match(line)
        if not m:
            continue
        value = _HZ_RE.sub("", m.group("value"))
        try:
            r = float(value)
        except ValueError:
            raise MocapFormatError(src, idx + 1, f"cannot read the sample rate {m.group('value')!r}") from None
        if not (math.isfinite(r) and r > 0):
            raise MocapFormatError(src, idx + 1, f"the sample rate must be a positive number of Hz, got {m.group('value')!r}")
        if rate is not None and r != rate:
            raise MocapFormatError(src, idx + 1, f"sample rate {r:g} Hz contradicts {rate:g} Hz on line {rate_line}")
        rate, rate_line = r, idx + 1
    return rate, rate_line


def _parse(lines: list[str], src: str, rate: float | None, name: str) -> Signal:
    end, hidx, preamble = _find_header(lines, src)
    header = lines[hidx]
    hln = hidx + 1
    layout = _identify(header)
    if layout is None:
        raise MocapFormatError(
            src, hln, f"unrecognised header {_short(header)}; accepted headers: " + "; ".join(ACCEPTED_HEADERS)
        )
    fmt = layout.fmt
    if preamble and fmt != "xsens":
        raise MocapFormatError(
            src, preamble[0][0] + 1,
            f"'//' comment lines are only expected before an Xsens MT Manager header, not in a {fmt} file",
        )

    # the effective sample rate
    eff_rate: float | None = None
    if fmt == "xsens":
        file_rate, rate_line = _file_rate(preamble, src)
        if file_rate is not None and rate is not None and file_rate != rate:
            raise MocapFormatError(
                src, rate_line,
                f"the file's sample rate is {file_rate:g} Hz but a rate of {rate:g} Hz was given; "
                "drop --rate or correct the file",
            )
        eff_rate = file_rate if file_rate is not None else rate
        if eff_rate is None:
            raise MocapFormatError(
                src, hln, "Xsens export without a '// Sample rate: ...Hz' line: pass the sample rate with --rate HZ"
            )
    elif fmt == "x-io-legacy":
        if rate is None:
            raise MocapFormatError(
                src, hln, "legacy x-io export (Packet number, Element 1..4) has no timestamps: "
                "pass the sample rate with --rate HZ",
            )
        eff_rate = rate
    elif rate is not None:
        raise MocapFormatError(
            src, hln, f"this {fmt} file has its own timestamps; a sample rate ({rate:g} Hz) must not be given",
        )

    ncols = len(layout.names)
    delim = layout.delim
    qcols = layout.quat_cols
    qnames = [layout.names[j] for j in qcols]
    kind = layout.time_kind
    tcol = layout.time_col
    tname = layout.names[tcol] if tcol is not None else ""
    wrap = fmt == "xsens"

    values: list[tuple[float, float, float, float]] = []
    times: list[float] = []       # for "us" and "s"
    counters: list[int] = []      # unwrapped, for "counter"
    line_nos: list[int] = []
    prev_t = 0.0
    prev_text = ""
    prev_raw = 0
    offset = 0
    pending_wrap: tuple[int, int, int] | None = None   # (line before, raw before, raw at wrap)

    for k in range(hidx + 1, end):
        line = lines[k]
        ln = k + 1
        if not line.strip():
            raise MocapFormatError(src, ln, "empty line inside the data (only trailing empty lines are allowed)")
        fields = line.split(delim)
        if len(fields) != ncols:
            sep = "tab" if delim == "\t" else "comma"
            raise MocapFormatError(
                src, ln, f"expected {ncols} {sep}-separated columns like the header on line {hln}, got {len(fields)}"
            )

        # time column
        if kind == "us" or kind == "s":
            text = fields[tcol].strip()  # type: ignore[index]
            try:
                if kind == "us":
                    try:
                        raw: float | int = int(text)
                    except ValueError:
                        raw = float(text)
                    t = raw / 1e6
                else:
                    t = float(text)
            except ValueError:
                raise MocapFormatError(src, ln, f"column {tname}: {_short(text)} is not a number") from None
            except OverflowError:
                raise MocapFormatError(src, ln, f"column {tname}: {_short(text)} is out of range") from None
            if math.isnan(t):
                raise MocapFormatError(src, ln, f"column {tname} is NaN")
            if math.isinf(t):
                raise MocapFormatError(src, ln, f"column {tname} is infinite ({_short(text)})")
            if times:
                if t == prev_t:
                    raise MocapFormatError(
                        src, ln, f"duplicate timestamp: line {ln} has {tname} {_short(text)} ({t!r} s), "
                        f"the same time as line {line_nos[-1]} ({_short(prev_text)})",
                    )
                if t < prev_t:
                    raise MocapFormatError(
                        src, ln, f"timestamps must increase: line {ln} has {tname} {_short(text)} ({t!r} s), "
                        f"earlier than line {line_nos[-1]} with {_short(prev_text)} ({prev_t!r} s)",
                    )
            times.append(t)
            prev_t, prev_text = t, text
        elif kind == "counter":
            text = fields[tcol].strip()  # type: ignore[index]
            try:
                c = int(text)
            except ValueError:
                raise MocapFormatError(src, ln, f"column {tname}: {_short(text)} is not an integer") from None
            if c < 0:
                raise MocapFormatError(src, ln, f"column {tname}: {c} is negative")
            if counters:
                u = c + offset
                prev_u = counters[-1]
                if pending_wrap is not None:
                    before_ln, before_raw, wrap_raw = pending_wrap
                    if not (prev_u < u <= prev_u + MAX_WRAP_STEP):
                        raise MocapFormatError(
                            src, ln, f"{tname} drops from {before_raw} (line {before_ln}) to {wrap_raw} "
                            f"(line {line_nos[-1]}) but line {ln} ({c}) does not continue from {wrap_raw}: "
                            "not a uint16 wrap-around",
                        )
                    pending_wrap = None
                if u == prev_u:
                    raise MocapFormatError(
                        src, ln, f"duplicate {tname} {c} on lines {line_nos[-1]} and {ln}"
                    )
                if u < prev_u:
                    step = c + _U16 - prev_raw
                    if wrap and c < _U16 and prev_raw < _U16 and 1 <= step <= MAX_WRAP_STEP:
                        offset = prev_u - prev_raw + _U16
                        u = c + offset
                        pending_wrap = (line_nos[-1], prev_raw, c)
                    else:
                        raise MocapFormatError(
                            src, ln, f"{tname} must increase: line {ln} has {c}, less than {prev_raw} on line "
                            f"{line_nos[-1]}" + (" (not a uint16 wrap-around)" if wrap else ""),
                        )
                counters.append(u)
            else:
                counters.append(c)
            prev_raw = c

        # quaternion columns
        q = []
        for col, qname in zip(qcols, qnames):
            text = fields[col]
            try:
                v = float(text)
            except ValueError:
                raise MocapFormatError(src, ln, f"column {qname}: {_short(text.strip())} is not a number") from None
            if v != v:
                raise MocapFormatError(src, ln, f"column {qname} is NaN")
            if v in (math.inf, -math.inf):
                raise MocapFormatError(src, ln, f"column {qname} is infinite ({_short(text.strip())})")
            q.append(v)
        if q[0] * q[0] == 0.0 and q[1] * q[1] == 0.0 and q[2] * q[2] == 0.0 and q[3] * q[3] == 0.0:
            raise MocapFormatError(
                src, ln, f"zero-norm quaternion ({', '.join(qnames)} = {', '.join(repr(v) for v in q)})"
            )
        values.append((q[0], q[1], q[2], q[3]))
        line_nos.append(ln)

    if not values:
        raise MocapFormatError(src, hln, "header only: no data rows after the header")

    if kind == "counter":
        first = counters[0]
        try:
            times = [(u - first) / eff_rate for u in counters]  # type: ignore[operator]
        except OverflowError:
            raise MocapFormatError(src, None, f"{tname} values are too large") from None
    elif kind is None:
        times = [i / eff_rate for i in range(len(values))]  # type: ignore[operator]
    if kind in ("counter", None):
        # guard against rounding collapsing distinct counters (absurd rates)
        for i in range(1, len(times)):
            if not (times[i] > times[i - 1]) or not math.isfinite(times[i]):
                raise MocapFormatError(
                    src, line_nos[i], f"time {times[i]!r} s (from the sample rate {eff_rate:g} Hz) is not after "
                    f"{times[i - 1]!r} s on line {line_nos[i - 1]}",
                )

    meta = {"format": fmt, "rate": eff_rate, "header": header, "header_line": hln}
    try:
        return Signal(
            np.array(times, dtype=np.float64),
            np.array(values, dtype=np.float64).reshape(-1, 4),
            kind="quaternion",
            name=name,
            source=src,
            meta=meta,
        )
    except InvalidSignalError as exc:  # pragma: no cover - the checks above should catch everything
        raise MocapFormatError(src, None, str(exc)) from None


# --------------------------------------------------------------------------------------------------
# folders and dispatch
# --------------------------------------------------------------------------------------------------


def detect_format(path: str | Path) -> str | None:
    """The quaternion format of a file from its header (``"x-io"``, ``"xsens"``...), or ``None``.

    Never raises for bad content: an unreadable or undecodable file is simply not a quaternion file.
    """
    try:
        with open(path, "rb") as fh:
            head = fh.read(65536)
    except OSError:
        return None
    text = head.decode("utf-8", errors="replace")
    lines = _split_lines(text)
    if len(head) == 65536 and len(lines) > 1:
        lines = lines[:-1]  # the last line may be cut
    try:
        _, hidx, preamble = _find_header(lines, str(path))
    except MocapFormatError:
        return None
    layout = _identify(lines[hidx])
    if layout is None or (preamble and layout.fmt != "xsens"):
        return None
    return layout.fmt


def _visible(p: Path) -> bool:
    return not p.name.startswith(".") and p.name != "__pycache__"


def _data_files(folder: Path) -> list[Path]:
    return sorted(
        (f for f in folder.iterdir() if f.is_file() and _visible(f) and f.suffix.lower() in DATA_SUFFIXES),
        key=lambda f: f.name,
    )


def read_sensor_folder(path: str | Path, rate: float | None = None) -> dict[str, Signal]:
    """Read a folder of sensors, sorted by name.

    Either one sub-folder per sensor (name = sub-folder name), each holding exactly one file whose
    header is a quaternion format (other files, such as x-io ``Inertial.csv``, are ignored), or one
    file per sensor (``*.csv``, ``*.txt``; name = file stem).
    """
    folder = Path(path)
    src = str(folder)
    if not folder.exists():
        raise MocapFormatError(src, None, "no such file or folder")
    if not folder.is_dir():
        raise MocapFormatError(src, None, "not a folder")
    try:
        entries = [e for e in folder.iterdir() if _visible(e)]
        subdirs = sorted((e for e in entries if e.is_dir()), key=lambda e: e.name)
        files = _data_files(folder)
    except OSError as exc:
        raise MocapFormatError(src, None, f"cannot list the folder: {exc.strerror or exc}") from None

    out: dict[str, Signal] = {}
    if subdirs:
        if files:
            raise MocapFormatError(
                src, None, "has both sensor sub-folders and data files ("
                + ", ".join(f.name for f in files[:5]) + "); use one sub-folder per sensor or one file per sensor",
            )
        for sub in subdirs:
            try:
                candidates = _data_files(sub)
            except OSError as exc:
                raise MocapFormatError(str(sub), None, f"cannot list the folder: {exc.strerror or exc}") from None
            quat = [f for f in candidates if detect_format(f) is not None]
            if not quat:
                looked = ", ".join(f.name for f in candidates) or "no *.csv or *.txt files"
                raise MocapFormatError(
                    str(sub), None, f"sensor folder without a quaternion file (looked at: {looked}); "
                    "accepted headers: " + "; ".join(ACCEPTED_HEADERS),
                )
            if len(quat) > 1:
                raise MocapFormatError(
                    str(sub), None, "sensor folder with several quaternion files ("
                    + ", ".join(f.name for f in quat) + "); keep exactly one",
                )
            out[sub.name] = read_imu_csv(quat[0], rate=rate, name=sub.name)
        return out

    if not files:
        raise MocapFormatError(
            src, None, "no sensors: expected one sub-folder per sensor or one *.csv/*.txt file per sensor"
        )
    quat_files = [f for f in files if detect_format(f) is not None]
    skipped = [f.name for f in files if f not in quat_files]
    if not quat_files:
        raise MocapFormatError(
            src, None, "no quaternion file among " + ", ".join(f.name for f in files)
            + "; accepted headers: " + "; ".join(ACCEPTED_HEADERS),
        )
    for f in quat_files:  # other CSVs (e.g. x-io Inertial.csv) are not orientation data: listed in meta
        if f.stem in out:
            raise MocapFormatError(src, None, f"two files for sensor {f.stem!r}; keep one")
        out[f.stem] = read_imu_csv(f, rate=rate, name=f.stem)
        if skipped:
            out[f.stem].meta["skipped_files"] = skipped
    return dict(sorted(out.items()))


Reader = Callable[..., dict[str, Signal]]
"""A reader takes ``(path: Path, *, rate: float | None)`` and returns ``{name: Signal}``."""


def _read_imu_file(path: Path, *, rate: float | None = None) -> dict[str, Signal]:
    return {path.stem: read_imu_csv(path, rate=rate)}


#: File suffix (lower case, with the dot) -> reader. Unknown suffixes fall back to the IMU CSV reader.
READERS: dict[str, Reader] = {".csv": _read_imu_file, ".txt": _read_imu_file}


def register_reader(suffix: str, reader: Reader) -> None:
    """Register ``reader(path, *, rate=None) -> dict[str, Signal]`` for files ending in ``suffix``."""
    s = suffix.lower()
    READERS[s if s.startswith(".") else "." + s] = reader


def load_signals(path: str | Path, rate: float | None = None) -> dict[str, Signal]:
    """Load every signal from a file or a sensor folder, as ``{name: Signal}``.

    A folder goes to :func:`read_sensor_folder`; a file to the reader registered for its suffix in
    :data:`READERS` (the IMU CSV reader for ``.csv``, ``.txt`` and unknown suffixes).
    """
    p = Path(path)
    if not p.exists():
        raise MocapFormatError(str(p), None, "no such file or folder")
    if p.is_dir():
        return read_sensor_folder(p, rate=rate)
    reader = READERS.get(p.suffix.lower(), _read_imu_file)
    return reader(p, rate=rate)


# --------------------------------------------------------------------------------------------------
# writing
# --------------------------------------------------------------------------------------------------


def format_row(t: float, values: Iterable[float]) -> str:
    """One CSV row (no line end): every number as ``repr(float(v))`` (shortest round-trip text)."""
    return ",".join([repr(float(t))] + [repr(float(v)) for v in values])


def write_signal_csv(path: str | Path, signal_times: Sequence[float] | np.ndarray,
                     values: Sequence[Sequence[float]] | np.ndarray,
                     header: Sequence[str] = ("time", "w", "x", "y", "z")) -> None:
    """Write ``time,w,x,y,z`` CSV atomically; the numbers read back bit-exactly.

    With the default header the file is read back by :func:`read_imu_csv` (generic format).
    """
    t = np.asarray(signal_times, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    if v.ndim == 1:
        v = v[:, None]
    if t.ndim != 1 or v.ndim != 2 or v.shape[0] != t.shape[0]:
        raise InvalidSignalError(f"times must be (N,) and values (N, D); got {t.shape} and {v.shape}")
    if v.shape[1] + 1 != len(header):
        raise InvalidSignalError(f"header has {len(header)} columns but rows have {v.shape[1] + 1}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
        raise InvalidSignalError("cannot write NaN or infinite values")
    parts = [",".join(header), "\n"]
    for ti, row in zip(t.tolist(), v.tolist()):
        parts.append(format_row(ti, row))
        parts.append("\n")
    atomic_write_text(path, "".join(parts))


def sample_data_path() -> Path:
    """The bundled x-io lower-body recording (7 sensor sub-folders with ``Quaternion.csv``)."""
    from importlib.resources import files

    return Path(str(files("mocapkit") / "data" / "imu" / "xio-lower-body"))
