"""Readers and writers of IMU orientation exports (CSV/text files), driven by the file's own header.

Every reader returns :class:`mocapkit.motion.Signal` objects of kind ``"quaternion"``: ``times`` in
float64 seconds (strictly increasing, irregular sampling kept as is) and ``values`` ``(N, 4)``
float64, scalar-first ``w, x, y, z`` exactly as written (never normalised or sign-flipped; scalar-last
files are reordered; a rotation matrix or Euler angles are converted, see
:mod:`mocapkit.io.imu.orientation`). Numbers follow the strict grammar of :mod:`mocapkit.io.text.numbers`
(no ``0_5``, no ``nan``/``inf``; orientation values within ``MAX_ABS``, clocks within ``MAX_ABS``
seconds in their own unit, so an epoch in ns is read); see :mod:`~mocapkit.io.imu.rows`.

Memory and input: a file, a FIFO or a device is read in chunks of whole lines
(:mod:`~mocapkit.io.imu.lines`: NUL bytes, lines over 1 MiB and non-UTF-8 bytes are errors at once),
the layout is found in the first :data:`MAX_HEAD_LINES` lines, and the rows go block by block into
growing float64 arrays: the peak memory stays near the size of the returned arrays (an 800 MB
export with a time and four quaternion columns peaks at about 1.4x its numbers;
``benchmarks/imu_memory.py``).

How a file is read (details in the modules named):

- :mod:`~mocapkit.io.imu.columns`: the delimiter (``sep=`` line, else tab / comma / semicolon /
  white space by sniffing), the time column and its unit from its name (or a units row), the
  quaternion / matrix / Euler columns from their names.
- :mod:`~mocapkit.io.imu.layout`: preamble (``//``, ``#``, ``Key:,value`` lines, read for the
  sample rate), header, units rows, first data row.
- :mod:`~mocapkit.io.imu.vendors`: OptiTrack Motive's multi-row header; the vendor label in
  ``meta["format"]``.
- :mod:`~mocapkit.io.imu.rows`: the rows (column counts, strict finite numbers, time order and step,
  counter wrap and step, a last line cut short).

When the guess is wrong, keyword arguments (CLI flags) override it: ``time_column``
(``--time-column``), ``quaternion_columns`` (``--quaternion-columns W,X,Y,Z``), ``scalar_last``
(``--scalar-last``), ``time_unit`` (``--time-unit s|ms|us|ns|counter``); ``rate`` (``--rate``) gives
the sample rate of files with a counter or no time column. An ambiguous file (two clocks, several
quaternion sets, no time and no rate) raises an error naming the columns and the flag.

``Signal.meta`` holds ``format`` (vendor label), ``rate`` (Hz, stated or given; ``None`` when the file
has timestamps and states none), ``header``, ``header_line``, ``time_column``, ``time_unit``,
``orientation_columns``, ``conversion`` (how a matrix / Euler angles became quaternions, or the
order in which numbered quaternion columns were read; else ``None``), ``sensor`` (files with several
sensors) and ``warnings`` (list of text).

Numbered quaternion columns (``q0..q3``, ``Quat_q0..3``, ``Element 1..4``) are read scalar-first,
the vendors' convention (Xsens, x-io); ``meta["conversion"]`` says so and names ``--scalar-last``.
The values cannot tell the order: any reordering of a unit quaternion is a unit quaternion, the
angle between successive samples is the same in every order, and the scalar part of a real recording
crosses zero as often as a vector part does (the x-io lower-body walk turns through 180°; its
``W`` changes sign while its ``Z`` keeps one sign), so no check on the numbers is made.

A time column without a stated unit is checked for plausibility: a median sample interval outside
:data:`mocapkit.io.imu.rows.PLAUSIBLE_RATE` (2 Hz to 10 kHz) is recorded in ``meta["warnings"]``
naming the column, the rate and ``--time-unit`` (milliseconds read as seconds), never changed.

Anything wrong with the content raises :class:`mocapkit.errors.MocapFormatError` naming the file and
the 1-based line.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path

import numpy as np

from mocapkit.errors import (
    InvalidParameterError,
    InvalidSignalError,
    MocapFormatError,
)
from mocapkit.io.atomic import atomic_write_text
from mocapkit.io.imu.columns import ColumnOptions
from mocapkit.io.imu.layout import EXPECTED, Layout, find_layout
from mocapkit.io.imu.lines import Block, file_blocks, open_input, text_blocks
from mocapkit.io.imu.rows import MIN_STEP, RowReader
from mocapkit.io.imu.sessions import drop_derived, legacy_xio_rate, missing_devices, registers_file, session_file
from mocapkit.io.text.numbers import MAX_ABS
from mocapkit.motion import Signal

__all__ = [
    "ACCEPTED_HEADERS",
    "ColumnOptions",
    "READERS",
    "detect_format",
    "format_row",
    "load_signals",
    "read_imu_csv",
    "read_imu_file",
    "read_imu_text",
    "read_sensor_folder",
    "register_reader",
    "sample_data_path",
    "write_signal_csv",
]

#: What the header-driven reader recognises (used in error messages and help texts).
ACCEPTED_HEADERS = (
    "a time column named like 'Timestamp (us)', 'Time (s)', 'epoc (ms)', 'time' (s, or an epoch in "
    "ms/us/ns), 'SampleTimeFine' (us), 'elapsed (s)', 'seconds_elapsed', or a counter ('PacketCounter', "
    "'Packet number', 'Frame') with a stated or given rate",
    EXPECTED,
    "Xsens MT Manager / DOT, x-io (x-IMU3, NGIMU, legacy), APDM, OptiTrack Motive, Shimmer, MetaWear, "
    "phone sensor loggers; delimiter comma, tab, semicolon or white space",
)

#: Suffixes of files that may hold sensor data inside a sensor folder.
DATA_SUFFIXES = (".csv", ".txt")

_BOM = "\ufeff"

#: The layout is read from at most this many first lines (or :data:`MAX_HEAD_BYTES` characters).
MAX_HEAD_LINES = 1000
MAX_HEAD_BYTES = 1 << 23


def _check_rate_arg(rate: float | None) -> float | None:
    if rate is None:
        return None
    try:
        r = float(rate)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"rate must be a number of Hz, got {rate!r}") from None
    if not (math.isfinite(r) and r > 0):
        raise InvalidParameterError(f"rate must be a finite positive number of Hz, got {rate!r}")
    if r > 1 / MIN_STEP:
        raise InvalidParameterError(f"rate must be at most {1 / MIN_STEP:g} Hz, got {rate!r}")
    return r


def _options(opts: ColumnOptions | None, kw: dict) -> ColumnOptions:
    if opts is not None and kw:
        raise InvalidParameterError("give either options= or the column keyword arguments, not both")
    if opts is not None:
        return opts
    unknown = set(kw) - {"time_column", "quaternion_columns", "scalar_last", "time_unit"}
    if unknown:
        raise TypeError(f"unexpected keyword arguments: {', '.join(sorted(unknown))}")
    return ColumnOptions(**{k: v for k, v in kw.items() if v is not None and v is not False})


def split_lines(text: str) -> list[str]:
    """Lines without their ``\\n`` / ``\\r\\n`` ends (a leading BOM removed)."""
    if text.startswith(_BOM):
        text = text[1:]
    lines = text.split("\n")
    return [ln[:-1] if ln.endswith("\r") else ln for ln in lines]


def _default_name(source: str) -> str:
    if source.startswith("<") and source.endswith(">"):
        return source[1:-1]
    return Path(source).stem


def _content_end(lines: list[str]) -> int:
    end = len(lines)
    while end > 0 and not lines[end - 1].strip():
        end -= 1
    return end


# --------------------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------------------


def _read(blocks: Iterator[Block], src: str, rate: float | None, name: str, opts: ColumnOptions,
          size_hint: int | None = None) -> dict[str, Signal]:
    """Read an export from its blocks of lines: the layout from the first lines (at most
    :data:`MAX_HEAD_LINES` or :data:`MAX_HEAD_BYTES`), then the rows block by block."""
    head: list[Block] = []
    n_lines = n_chars = 0
    for b in blocks:
        head.append(b)
        n_lines += b.n_lines
        n_chars += len(b.text)
        if b.final or n_lines >= MAX_HEAD_LINES or n_chars >= MAX_HEAD_BYTES:
            break
    final = head[-1].final
    text = "".join(b.text for b in head)
    terminated = not text or text.endswith("\n")
    lines = text.split("\n")
    if text.endswith("\n"):
        lines.pop()
    end = _content_end(lines)
    if end == 0:
        if final:
            raise MocapFormatError(src, 1, "empty file (expected a header line such as 'Timestamp (us),W,X,Y,Z')")
        raise MocapFormatError(src, 1, f"only empty lines in the first {len(lines)} lines: not an IMU export")
    lay = find_layout(lines, end, src, rate, opts)
    reader = RowReader(lay, src, size_hint=size_hint)
    rest = lines[lay.data_index:]
    if rest:
        ends = not final or terminated
        reader.feed_block("\n".join(rest) + ("\n" if ends else ""), lay.data_index + 1, len(rest), final, ends)
    del head, text, lines, rest
    for b in blocks:
        reader.feed_block(b.text, b.first_line, b.n_lines, b.final, b.terminated)
    times, per_sensor, warnings = reader.finish()
    out: dict[str, Signal] = {}
    for o, (rows, q, how), dropped in zip(lay.sensors, per_sensor, reader.dropped, strict=False):
        sig_name = o.sensor if o.sensor is not None else name
        notes = list(lay.warnings) + warnings
        if dropped:
            notes.append(f"{dropped} of {len(times)} rows dropped for {o.sensor or sig_name}: empty cells in "
                         f"{', '.join(o.names)} (body not tracked)")
        meta = _meta(lay, o, how, notes)
        if sig_name in out:
            raise MocapFormatError(src, lay.header_line, f"two sensors named {sig_name!r}")
        try:
            out[sig_name] = Signal(times if rows is None else times[rows], q, kind="quaternion", name=sig_name,
                                   source=src, meta=meta)
        except InvalidSignalError as exc:  # pragma: no cover - the row checks should catch everything
            raise MocapFormatError(src, None, str(exc)) from None
    return out


def _order_note(o) -> str | None:
    """How numbered quaternion columns (``q0..q3``, ``Element 1..4``) were ordered: their names do not
    say which one is the scalar, and the values cannot tell (see the module docstring)."""
    order = o.extra.get("order") if o.kind == "quaternion" else None
    if order == "scalar-first":
        return (f"numbered columns {', '.join(o.names)} read as w,x,y,z (scalar first); "
                "use --scalar-last if they hold x,y,z,w")
    if order == "scalar-last":
        w, x, y, z = o.names
        return f"numbered columns {x}, {y}, {z}, {w} read as x,y,z,w (--scalar-last)"
    return None


def _meta(lay: Layout, o, how: str | None, warnings: list[str]) -> dict:
    how = how if how is not None else _order_note(o)
    meta = {
        "format": lay.fmt, "rate": lay.rate, "header": lay.names and _header_text(lay), "header_line": lay.header_line,
        "time_column": lay.time.name or None, "time_unit": lay.time.unit, "orientation_columns": list(o.names),
        "conversion": how, "warnings": warnings,
    }
    if o.sensor is not None:
        meta["sensor"] = o.sensor
    return meta


def _header_text(lay: Layout) -> str:
    d = lay.delim if lay.delim is not None else " "
    return d.join(lay.names)


def read_imu_file(path: str | Path, rate: float | None = None, *, options: ColumnOptions | None = None,
                  **columns) -> dict[str, Signal]:
    """Read every sensor of one IMU export as ``{name: Signal}`` (one entry unless the file holds
    several sensors, e.g. APDM or OptiTrack; then named after the sensors).

    ``columns``: ``time_column``, ``quaternion_columns``, ``scalar_last``, ``time_unit`` (or one
    :class:`ColumnOptions` as ``options``).
    """
    p = Path(path)
    src = str(p)
    opts = _options(options, columns)
    r = _check_rate_arg(rate)
    fh, size = open_input(p, "file")
    with fh:
        return _read(file_blocks(fh, src), src, r, p.stem, opts, size)


def _one(signals: dict[str, Signal], src: str) -> Signal:
    if len(signals) != 1:
        raise MocapFormatError(src, None, f"holds {len(signals)} sensors ({', '.join(signals)}); read it with "
                               "load_signals / read_imu_file")
    return next(iter(signals.values()))


def read_imu_csv(path: str | Path, rate: float | None = None, name: str | None = None, *,
                 options: ColumnOptions | None = None, **columns) -> Signal:
    """Read a single-sensor IMU orientation export (layout found from its header).

    Parameters
    ----------
    path
        The file.
    rate
        Sample rate in Hz, for files with a counter or no time column and no stated rate; refused
        when the file has timestamps.
    name
        The signal's name; default: the file's stem.
    options, columns
        Header overrides: ``time_column``, ``quaternion_columns`` (``w,x,y,z`` order),
        ``scalar_last``, ``time_unit`` (see :class:`ColumnOptions`).
    """
    p = Path(path)
    sigs = read_imu_file(p, rate, options=options, **columns)
    sig = _one(sigs, str(p))
    if name is not None and name != sig.name:
        sig = Signal(sig.times, sig.values, kind=sig.kind, name=name, source=sig.source, meta=sig.meta)
    return sig


def read_imu_text(text: str, source: str, rate: float | None = None, name: str | None = None, *,
                  options: ColumnOptions | None = None, **columns) -> Signal:
    """Parse the text of a single-sensor IMU orientation export (e.g. read from stdin).

    ``source`` labels the text in messages (a path or ``"<stdin>"``); ``name`` defaults to the
    source's stem (``"stdin"`` for ``"<stdin>"``).
    """
    r = _check_rate_arg(rate)
    src = str(source)
    opts = _options(options, columns)
    sigs = _read(text_blocks(text, src), src, r, _default_name(src) if name is None else name, opts, len(text))
    return _one(sigs, src)


# --------------------------------------------------------------------------------------------------
# folders and dispatch
# --------------------------------------------------------------------------------------------------


def detect_format(path: str | Path, options: ColumnOptions | None = None) -> str | None:
    """The vendor label of an orientation file from its header (``"x-io"``, ``"xsens"``...), or
    ``None`` when no orientation columns are found.

    Never raises for bad content: an unreadable or undecodable file is simply not a quaternion file.
    """
    try:
        with open(path, "rb") as fh:
            head = fh.read(65536)
    except OSError:
        return None
    text = head.decode("utf-8", errors="replace")
    lines = split_lines(text)
    if len(head) == 65536 and len(lines) > 1:
        lines = lines[:-1]  # the last line may be cut
    try:
        lay = find_layout(lines, _content_end(lines), str(path), None, options or ColumnOptions(), probe=True)
    except MocapFormatError:
        return None
    return lay.fmt


def stated_clock(path: str | Path, options: ColumnOptions | None = None) -> str | None:
    """What gives the file (or every sensor file of a sensor folder) its times without a ``rate``: ``"its
    time column 'Time (s)'"`` or ``"its sample rate (50 Hz)"``; ``None`` when it needs a rate (a counter or
    no time column, and no rate line) or when its header cannot be read (the reader then says why)."""
    p = Path(path)
    try:
        files = [p]
        if p.is_dir():  # a folder of sensor files, or of sensor sub-folders
            subs = sorted(e for e in p.iterdir() if e.is_dir() and _visible(e))
            files = [f for d in [p, *subs] for f in _data_files(d) if detect_format(f, options) is not None]
    except OSError:
        return None
    said = []
    for f in files:
        try:
            with open(f, "rb") as fh:
                head = fh.read(65536)
            lines = split_lines(head.decode("utf-8", errors="replace"))
            if len(head) == 65536 and len(lines) > 1:
                lines = lines[:-1]
            lay = find_layout(lines, _content_end(lines), str(f), None, options or ColumnOptions(), probe=True)
        except (OSError, MocapFormatError):
            return None
        if lay.time.col is not None and lay.time.unit not in ("counter", None):
            said.append(f"its time column {lay.time.name!r}")
        elif lay.file_rate is not None:
            said.append(f"its sample rate ({lay.file_rate:g} Hz)")
        else:
            return None
    return said[0] if said else None


def _visible(p: Path) -> bool:
    return not p.name.startswith(".") and p.name != "__pycache__"


def _data_files(folder: Path) -> list[Path]:
    return sorted(
        (f for f in folder.iterdir() if f.is_file() and _visible(f) and f.suffix.lower() in DATA_SUFFIXES),
        key=lambda f: f.name,
    )


def _named(sigs: dict[str, Signal], name: str) -> dict[str, Signal]:
    """One signal -> ``{name: signal renamed}``; several -> ``{name/sensor: signal}``."""
    if len(sigs) == 1:
        s = next(iter(sigs.values()))
        return {name: Signal(s.times, s.values, kind=s.kind, name=name, source=s.source, meta=s.meta)}
    return {f"{name}/{k}": s for k, s in sigs.items()}


def _read_sensor_file(f: Path, rate: float | None, opts: ColumnOptions) -> dict[str, Signal]:
    """One orientation file of a folder; a legacy x-io file takes its rate from ``<prefix>_Registers.csv``."""
    regs = registers_file(f) if detect_format(f, opts) == "x-io-legacy" else None
    if regs is None:
        return read_imu_file(f, rate, options=opts)
    r, how = legacy_xio_rate(regs)
    if rate is not None and _check_rate_arg(rate) != r:
        raise MocapFormatError(str(regs), None, f"the registers state a quaternion rate of {r:g} Hz but "
                               f"--rate {rate:g} was given; drop --rate or correct the file")
    sigs = read_imu_file(f, r, options=opts)
    for sig in sigs.values():
        sig.meta["rate_from"] = how
    return sigs


def read_sensor_folder(path: str | Path, rate: float | None = None, *, options: ColumnOptions | None = None,
                       **columns) -> dict[str, Signal]:
    """Read a folder of sensors, sorted by name.

    Either one sub-folder per sensor (name = sub-folder name), each holding exactly one file with
    orientation columns (other files, such as x-io ``Inertial.csv``, are ignored), or one file per
    sensor (``*.csv``, ``*.txt``; name = file stem, ``stem/sensor`` for files holding several).

    x-io files (:mod:`~mocapkit.io.imu.sessions`): an Euler or matrix file beside the quaternion file
    of the same prefix is skipped; a legacy ``<prefix>_Quaternion.csv`` takes its rate from
    ``<prefix>_Registers.csv``; an NGIMU ``Session.xml`` listing devices without a sub-folder adds a
    warning naming them to every signal's ``meta["warnings"]``.
    """
    folder = Path(path)
    src = str(folder)
    opts = _options(options, columns)
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
        session = session_file(folder)
        lost = missing_devices(session, [d.name for d in subdirs]) if session is not None else None
        for sub in subdirs:
            try:
                candidates = _data_files(sub)
            except OSError as exc:
                raise MocapFormatError(str(sub), None, f"cannot list the folder: {exc.strerror or exc}") from None
            quat, derived = drop_derived([f for f in candidates if detect_format(f, opts) is not None])
            if not quat:
                looked = ", ".join(f.name for f in candidates) or "no *.csv or *.txt files"
                raise MocapFormatError(
                    str(sub), None, f"sensor folder without a quaternion file (looked at: {looked}); "
                    f"looked for {EXPECTED}",
                )
            if len(quat) > 1:
                raise MocapFormatError(
                    str(sub), None, "sensor folder with several quaternion files ("
                    + ", ".join(f.name for f in quat) + "); keep exactly one",
                )
            for key, sig in _named(_read_sensor_file(quat[0], rate, opts), sub.name).items():
                if derived:
                    sig.meta["skipped_files"] = derived
                if lost:
                    sig.meta["warnings"].append(lost)
                out[key] = sig
        return out

    if not files:
        raise MocapFormatError(
            src, None, "no sensors: expected one sub-folder per sensor or one *.csv/*.txt file per sensor"
        )
    quat_files, derived = drop_derived([f for f in files if detect_format(f, opts) is not None])
    skipped = [f.name for f in files if f not in quat_files]
    if not quat_files:
        raise MocapFormatError(
            src, None, "no quaternion file among " + ", ".join(f.name for f in files) + f"; looked for {EXPECTED}",
        )
    for f in quat_files:  # other CSVs (e.g. x-io Inertial.csv) are not orientation data: listed in meta
        for key, sig in _named(_read_sensor_file(f, rate, opts), f.stem).items():
            if key in out:
                raise MocapFormatError(src, None, f"two files for sensor {key!r}; keep one")
            if skipped:
                sig.meta["skipped_files"] = skipped
            out[key] = sig
    return dict(sorted(out.items()))


Reader = Callable[..., dict[str, Signal]]
"""A reader takes ``(path: Path, *, rate: float | None)`` and returns ``{name: Signal}``."""


def _read_imu_file(path: Path, *, rate: float | None = None, **columns) -> dict[str, Signal]:
    return read_imu_file(path, rate, **columns)


#: File suffix (lower case, with the dot) -> reader. Unknown suffixes fall back to the IMU CSV reader.
READERS: dict[str, Reader] = {".csv": _read_imu_file, ".txt": _read_imu_file}


def register_reader(suffix: str, reader: Reader) -> None:
    """Register ``reader(path, *, rate=None) -> dict[str, Signal]`` for files ending in ``suffix``."""
    s = suffix.lower()
    READERS[s if s.startswith(".") else "." + s] = reader


def load_signals(path: str | Path, rate: float | None = None, *, options: ColumnOptions | None = None,
                 **columns) -> dict[str, Signal]:
    """Load every signal from a file or a sensor folder, as ``{name: Signal}``.

    A folder goes to :func:`read_sensor_folder`; a file to the reader registered for its suffix in
    :data:`READERS` (the IMU CSV reader for ``.csv``, ``.txt`` and unknown suffixes; a legacy x-io
    ``<prefix>_Quaternion.csv`` takes its rate from ``<prefix>_Registers.csv`` beside it). The column
    overrides (``time_column``, ``quaternion_columns``, ``scalar_last``, ``time_unit``, or
    ``options``) apply to IMU CSV files only.
    """
    p = Path(path)
    opts = _options(options, columns)
    if not p.exists():
        raise MocapFormatError(str(p), None, "no such file or folder")
    if p.is_dir():
        return read_sensor_folder(p, rate=rate, options=opts)
    reader = READERS.get(p.suffix.lower(), _read_imu_file)
    if reader is _read_imu_file:
        return _read_sensor_file(p, rate, opts)
    if opts.any:
        raise InvalidParameterError(
            f"{p}: --time-column/--quaternion-columns/--scalar-last/--time-unit apply to IMU CSV files only"
        )
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

    NaN, infinity and magnitudes beyond :data:`~mocapkit.io.text.numbers.MAX_ABS` are refused
    (:class:`~mocapkit.errors.InvalidSignalError`): the readers would refuse the file.

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
    if not (np.all(np.abs(t) <= MAX_ABS) and np.all(np.abs(v) <= MAX_ABS)):
        raise InvalidSignalError(f"cannot write values beyond ±{MAX_ABS:g} (the readers refuse them)")
    parts = [",".join(header), "\n"]
    for ti, row in zip(t.tolist(), v.tolist(), strict=True):
        parts.append(format_row(ti, row))
        parts.append("\n")
    atomic_write_text(path, "".join(parts))


def sample_data_path() -> Path:
    """The bundled x-io lower-body recording (7 sensor sub-folders with ``Quaternion.csv``)."""
    from importlib.resources import files

    return Path(str(files("mocapkit") / "data" / "imu" / "xio-lower-body"))
