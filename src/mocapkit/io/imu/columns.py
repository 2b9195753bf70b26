"""Understand the header of an IMU orientation export: delimiter, time column and its unit, and the
orientation columns, all found from the names the file gives them.

Nothing here reads numbers beyond the first data row (needed to tell an empty column from a used
one and to read the magnitude of a unit-less ``time``); :mod:`mocapkit.io.imu.rows` parses the rows.

Time columns (``name -> unit``; an explicit ``(us)``/``[ms]``/``_ns`` suffix or a units row under the
header always wins):

===========================================================  ==================================
``Timestamp (us)``, ``Time (s)``, ``epoc (ms)``, ``time_ns``   the stated unit
``SampleTimeFine`` (Xsens DOT)                               µs, uint32 device clock (wraps)
``SampleTimeFine`` (MT Manager ``//`` export)                10 kHz ticks; used only without a
                                                             counter (the counter and the stated
                                                             Update Rate are exact)
``time``, ``timestamp`` without a unit                       s up to 4e9; above, by magnitude
                                                             only when it is then an epoch of
                                                             1e9–4e9 s (ms, µs or ns; recorded),
                                                             else an error naming --time-unit;
                                                             a rate outside 2 Hz-10 kHz is warned
                                                             of (:mod:`~mocapkit.io.imu.rows`)
``elapsed (s)``, ``seconds_elapsed``                         s (used only when no other clock)
``PacketCounter``, ``Counter`` (uint16, wraps), ``Packet     a counter: needs a rate (file or
number``, ``Frame``, ``Sample number``                       ``--rate``)
===========================================================  ==================================

Orientation columns: a quaternion set is four columns sharing a prefix and naming the components
``w x y z`` (``W``, ``W Element``, ``Quat_W``, ``qw``, ``quaternion.w``, ``quaternionW``,
``..._Quat_Madge_9DOF_W_CAL``, ``w (number)``, ``<Sensor>/Orientation/Scalar|S|X|Y|Z``) in any
column order, or numbering them (``q0..q3``, ``Quat_q0..3``, ``Element 1..4``: scalar-first unless
``scalar_last``). Without a quaternion: a rotation matrix ``Mat[i][j]`` (row i, column j) or Euler
angles ``Roll, Pitch, Yaw`` (unit from the name, e.g. ``roll (rad)``; unit-less: degrees in Xsens
exports, radians in phone sensor-logger files, which have ``seconds_elapsed``), and in Xsens files
(Xsens / Movella DOT "Euler" exports) ``Euler_X, Euler_Y, Euler_Z`` = roll, pitch, yaw in degrees.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field

from mocapkit.errors import InvalidParameterError, MocapFormatError
from mocapkit.io.text.numbers import NUMBER_RE

__all__ = [
    "classify_time",
    "is_metadata_line",
    "parse_rate",
    "quat_component",
    "ColumnOptions",
    "Orientation",
    "TimeColumn",
    "TIME_UNITS",
    "find_column",
    "find_orientations",
    "choose_time",
    "is_descriptor_row",
    "is_numeric_row",
    "norm",
    "parse_sep_line",
    "rate_in_line",
    "sniff_delimiter",
    "split_fields",
]

#: Divisor turning a time in the unit into seconds (``"tick10k"``: the 10 kHz ticks of
#: ``SampleTimeFine`` in MT Manager exports of MTi/MTw devices).
TIME_UNITS = {"s": 1.0, "ms": 1e3, "us": 1e6, "ns": 1e9, "tick10k": 1e4}

_UNIT_WORDS = {
    "s": "s", "sec": "s", "secs": "s", "second": "s", "seconds": "s",
    "ms": "ms", "msec": "ms", "millisecond": "ms", "milliseconds": "ms",
    "us": "us", "\u00b5s": "us", "\u03bcs": "us", "usec": "us", "microsecond": "us", "microseconds": "us",
    "ns": "ns", "nsec": "ns", "nanosecond": "ns", "nanoseconds": "ns",
}
_COUNTER_NAMES = {
    "packetcounter", "packet counter", "packet_counter", "packet number", "packet_number", "packetnumber",
    "counter", "frame", "frame number", "frame_number", "framenumber", "frame#", "frame #",
    "sample number", "sample_number", "samplenumber", "sample counter",
}
#: Counters that are uint16 on the device (Xsens) and wrap around at 65536.
_U16_COUNTERS = {"packetcounter", "packet counter", "packet_counter", "counter"}
_ELAPSED_NAMES = {"elapsed", "seconds_elapsed", "elapsed time", "elapsed_time", "time elapsed", "time_elapsed"}
_TIME_RE = re.compile(r"(?:(?:^|.*[ _./-])(?:time|timestamp|timestampsync|epoc|epoch)(?:[ _]unix)?|t)")
_UNIT_PAREN_RE = re.compile(r"^(?P<base>.*?)\s*[\(\[](?P<unit>[^\)\]]*)[\)\]]$")
_UNIT_SUFFIX_RE = re.compile(r"^(?P<base>.*?)[ _](?P<unit>s|sec|ms|us|\u00b5s|\u03bcs|ns)$")
_CHANNEL_SUFFIX_RE = re.compile(r"_(?:cal|raw|uncal)$")
_RATE_KEY_RE = re.compile(
    r"(?:^|[,;\t]|//|#)\s*(?P<key>(?:sample|sampling|update|output|data|export frame)[ _]?(?:rate|frequency))"
    r"\s*(?:\(hz\))?\s*[:=]?\s*[,;\t:=]?\s*(?P<rest>.*)$",
    re.IGNORECASE,
)


@dataclass(frozen=True)
class ColumnOptions:
    """The user's corrections when the header is read wrongly (all optional).

    ``time_column``: the name of the time column. ``quaternion_columns``: four names in ``w, x, y, z``
    order (a sequence or one comma-separated string). ``scalar_last``: numbered quaternion columns
    (``q0..q3``, ``Element 1..4``) hold ``x, y, z, w``. ``time_unit``: ``s``, ``ms``, ``us``, ``ns``
    or ``counter`` (then the rate comes from the file or ``--rate``).
    """

    time_column: str | None = None
    quaternion_columns: tuple[str, str, str, str] | None = None
    scalar_last: bool = False
    time_unit: str | None = None

    def __post_init__(self) -> None:
        given: str | tuple[str, ...] | None = self.quaternion_columns  # or "w,x,y,z" from the command line
        if isinstance(given, str):
            given = tuple(p.strip() for p in given.split(","))
        if given is not None:
            q = tuple(str(p).strip() for p in given)
            if len(q) != 4 or not all(q):
                raise InvalidParameterError(
                    f"quaternion columns must be four names in w,x,y,z order, got {self.quaternion_columns!r}"
                )
            object.__setattr__(self, "quaternion_columns", q)
        if self.time_unit is not None:
            word = str(self.time_unit).strip().lower()
            u = "counter" if word == "counter" else _UNIT_WORDS.get(word)
            if u is None:
                raise InvalidParameterError(f"time unit must be one of s, ms, us, ns, counter; got {self.time_unit!r}")
            object.__setattr__(self, "time_unit", u)
        if self.time_column is not None and not str(self.time_column).strip():
            raise InvalidParameterError("time column name is empty")
        if self.scalar_last and self.quaternion_columns is not None:
            raise InvalidParameterError(
                "give --quaternion-columns in w,x,y,z order, or --scalar-last for numbered columns, not both"
            )

    @property
    def any(self) -> bool:
        return bool(self.time_column or self.quaternion_columns or self.scalar_last or self.time_unit)


@dataclass
class TimeColumn:
    """The chosen time column. ``col`` is ``None`` for "row index / rate"."""

    col: int | None
    name: str
    unit: str | None            # "s", "ms", "us", "ns", "counter" or None (row index)
    wrap: int | None = None      # modulus of a device clock/counter that wraps around
    note: str | None = None      # how the unit was decided, when it was not stated
    stated: bool = True          # False: no unit in the name, a units row or --time-unit (guessed)


@dataclass
class Orientation:
    """One signal's orientation columns.

    ``kind`` ``"quaternion"``: ``cols`` in ``w, x, y, z`` order. ``"matrix"``: ``R11, R12, ..., R33``
    (row-major). ``"euler"``: ``roll, pitch, yaw`` (``degrees`` says the unit).
    """

    kind: str
    cols: tuple[int, ...]
    names: tuple[str, ...]
    sensor: str | None = None
    degrees: bool = True
    missing_rows: str = "error"   # "error" or "drop" (a lost rigid body in OptiTrack)
    extra: dict = field(default_factory=dict)


# ------------------------------------------------------------------------------------------------
# text
# ------------------------------------------------------------------------------------------------


def norm(name: str) -> str:
    """Lower case, surrounding quotes and spaces removed, inner white space collapsed."""
    n = name.strip().strip('"').strip("'").strip()
    return " ".join(n.split()).lower()


def parse_sep_line(line: str) -> str | None:
    """The delimiter declared by an Excel ``sep=X`` line (also ``"sep=\\t"``), else ``None``."""
    s = line.strip().strip('"').strip("'")
    if not s.lower().startswith("sep="):
        return None
    d = s[4:]
    if d in ("\\t", "\t") or (d == "" and "\t" in line):
        return "\t"
    return d[:1] if d else None


def sniff_delimiter(line: str) -> str | None:
    """Tab, comma or semicolon (whichever splits the line into the most fields), else ``None``
    (white space)."""
    best, count = None, 0
    for d in ("\t", ",", ";"):
        c = len(split_fields(line, d))
        if c > count:
            best, count = d, c
    return best if count >= 2 else None


def split_fields(line: str, delim: str | None) -> list[str]:
    """Fields of a line; ``delim=None`` splits on runs of white space. Trailing empty fields dropped."""
    if delim is None:
        return line.split()
    fields = line.split(delim)
    while fields and not fields[-1].strip():
        fields.pop()
    return fields


def _is_number(text: str) -> bool:
    try:
        float(text.strip().strip('"'))
    except ValueError:
        return False
    return True


def is_numeric_row(fields: Sequence[str]) -> bool:
    """A data row: its first non-empty field is a number and so are most non-empty fields."""
    cells = [f for f in fields if f.strip()]
    if not cells or not _is_number(cells[0]):
        return False
    return 2 * sum(_is_number(c) for c in cells) >= len(cells)


def is_descriptor_row(fields: Sequence[str], key_cols: Sequence[int]) -> bool:
    """A units / channel-type row under the header (``s,m/s^2,...``, ``CAL``): no number in any of
    the time and orientation cells ``key_cols`` (the first cell alone says nothing: it may be a date)."""
    return not any(_is_number(fields[c]) for c in key_cols if c < len(fields))


def is_metadata_line(fields: Sequence[str], line: str) -> bool:
    """A comment (``//``, ``#``) or a ``Key:,value`` / ``Key: value`` preamble line."""
    s = line.lstrip()
    if s.startswith(("//", "#")):
        return True
    first = fields[0].strip() if fields else ""
    return first.endswith(":") or (len(fields) <= 2 and ":" in first and not _is_number(first))


def rate_in_line(line: str) -> tuple[str, str] | None:
    """``(key, value text)`` when a preamble line states a sample rate (``// Update Rate: 100.0Hz``,
    ``OutputRate:,60Hz``, ``Sample Rate:,128,Hz``, ``...,Export Frame Rate,120.000000,...``)."""
    m = _RATE_KEY_RE.search(line)
    if not m:
        return None
    rest = m.group("rest").strip()
    value = re.split(r"[,;\t]", rest, maxsplit=1)[0].strip() if rest else ""
    value = value.strip('"')
    value = re.sub(r"\s*hz$", "", value, flags=re.IGNORECASE)
    return m.group("key"), value


#: Sample rates (Hz) accepted from a file's preamble: beyond, the times would be absurd.
RATE_RANGE = (1e-6, 1e9)


def parse_rate(value: str) -> float | None:
    """A rate in Hz within :data:`RATE_RANGE` written by the strict number grammar
    (:mod:`mocapkit.io.text.numbers`: no ``1_00``, ``nan``, ``inf``), or ``None``."""
    v = value.strip()
    if not NUMBER_RE.fullmatch(v):
        return None
    r = float(v)
    lo, hi = RATE_RANGE
    return r if lo <= r <= hi else None


# ------------------------------------------------------------------------------------------------
# time column
# ------------------------------------------------------------------------------------------------


def _split_unit(n: str) -> tuple[str, str | None, bool]:
    """``(base, unit, had_unit_text)`` of a normalised name; ``unit`` is a time unit or ``None``."""
    m = _UNIT_PAREN_RE.match(n)
    if m:
        return m.group("base"), _UNIT_WORDS.get(m.group("unit").strip()), True
    m = _UNIT_SUFFIX_RE.match(n)
    if m and _TIME_RE.fullmatch(m.group("base")):
        return m.group("base"), _UNIT_WORDS[m.group("unit")], True
    return n, None, False


@dataclass
class _TimeName:
    kind: str          # "time" or "counter"
    unit: str | None
    tier: int          # 1: a clock, 2: elapsed seconds (derived), 3: counter
    wrap: int | None = None


def classify_time(name: str) -> _TimeName | None:
    """What a column name says about time, or ``None`` when it is not a time column."""
    n = _CHANNEL_SUFFIX_RE.sub("", norm(name))
    base, unit, had = _split_unit(n)
    base = _CHANNEL_SUFFIX_RE.sub("", base)
    if base in _COUNTER_NAMES:
        return _TimeName("counter", None, 3, 65536 if base in _U16_COUNTERS else None)
    if had and unit is None:
        return None                     # "timestamp (-07:00)": a date text, not a clock
    if base == "sampletimefine":
        return _TimeName("time", unit or "us", 1, 2**32)
    if base in _ELAPSED_NAMES:
        return _TimeName("time", unit or "s", 2)
    if _TIME_RE.fullmatch(base):
        return _TimeName("time", unit, 1)
    return None


def _unit_from_rows(col: int, rows: Sequence[Sequence[str]]) -> str | None:
    for r in rows:
        if col < len(r):
            u = _UNIT_WORDS.get(norm(r[col]))
            if u is not None:
                return u
    return None


#: Plausible epochs in seconds since 1970 (2001-09 .. 2096-10): a unit-less clock is read by its
#: magnitude only when one unit puts its first value in this range.
EPOCH_RANGE = (1e9, 4e9)


def _infer_unit(text: str, name: str, src: str, line: int) -> tuple[str, str | None]:
    """Unit of a unit-less ``time`` column from its first value.

    Up to 4e9 the value is read as seconds (an epoch in s, or a clock in s). A larger value is an
    epoch in ms, µs or ns only when that unit gives 1e9–4e9 s since 1970; anything else (e.g. an
    uptime clock in ns, ~1e13) has no safe reading and raises, naming ``--time-unit``.
    """
    try:
        v = abs(float(text.strip().strip('"')))
    except ValueError:
        return "s", None
    lo, hi = EPOCH_RANGE
    if v <= hi:
        return "s", None
    for unit in ("ms", "us", "ns"):
        if lo <= v / TIME_UNITS[unit] <= hi:
            return unit, f"unit {unit} inferred from the magnitude of the first value ({text.strip()}): an epoch"
    raise MocapFormatError(
        src, line, f"the unit of column {name.strip()!r} is unknown: its first value {text.strip()} is no epoch "
        "in s, ms, us or ns (1e9-4e9 s since 1970), e.g. a clock since boot; give --time-unit s|ms|us|ns|counter",
    )


def find_column(names: Sequence[str], wanted: str) -> int | None:
    """Index of the column called ``wanted`` (exact after stripping, then case-insensitive)."""
    w = wanted.strip()
    exact = [i for i, n in enumerate(names) if n.strip().strip('"') == w]
    if len(exact) == 1:
        return exact[0]
    loose = [i for i, n in enumerate(names) if norm(n) == norm(w)]
    return loose[0] if len(loose) == 1 else None


def _listing(names: Sequence[str], limit: int = 40) -> str:
    shown = [repr(n.strip()) for n in names[:limit]]
    more = f", ... ({len(names)} columns)" if len(names) > limit else ""
    return ", ".join(shown) + more


def choose_time(names: Sequence[str], first_row: Sequence[str], unit_rows: Sequence[Sequence[str]],
                opts: ColumnOptions, src: str, line: int, mt_manager: bool = False) -> TimeColumn:
    """The time column of a header (see the module table); ambiguity raises naming the flag.

    ``mt_manager``: an Xsens MT Manager text export, whose ``SampleTimeFine`` counts 10 kHz ticks on
    MTi devices (Xsens MT Low-Level Communication Protocol, data identifier SampleTimeFine; it wraps
    at 2³² on the MTi 1/600 series, after one day on the MTi 10/100 series — reported as an error
    here, not unwrapped), while Xsens DOT counts µs and wraps at 2³² (Xsens DOT User Manual,
    "Timestamp and packet counter").
    """
    def cell(i: int) -> str:
        return first_row[i] if i < len(first_row) else ""

    if opts.time_column is not None:
        i = find_column(names, opts.time_column)
        if i is None:
            raise MocapFormatError(src, line, f"no column named {opts.time_column!r} (--time-column); "
                                   f"columns: {_listing(names)}")
        info = classify_time(names[i])
        stated_unit = _split_unit(_CHANNEL_SUFFIX_RE.sub("", norm(names[i])))[1]
        unit = opts.time_unit or (info.unit if info else stated_unit) or _unit_from_rows(i, unit_rows)
        note = None
        if unit is None and info is not None and info.kind == "counter":
            unit = "counter"
        if unit is None:
            if info is None:
                raise MocapFormatError(src, line, f"the unit of column {names[i].strip()!r} is unknown: "
                                       "give --time-unit s|ms|us|ns|counter")
            unit, note = _infer_unit(cell(i), names[i], src, line)
            return TimeColumn(i, names[i].strip(), unit, info.wrap, note, stated=False)
        return TimeColumn(i, names[i].strip(), unit, info.wrap if info else None, note)

    classified = [(i, classify_time(n)) for i, n in enumerate(names)]
    found = [(i, t) for i, t in classified if t is not None]
    if mt_manager:
        for k, (i, t) in enumerate(found):
            if t.wrap == 2**32 and norm(names[i]) == "sampletimefine":
                found[k] = (i, _TimeName("time", "tick10k", 4, 2**32))
    used = [(i, t) for i, t in found if cell(i).strip()]
    if not used:
        if opts.time_unit is not None and found:
            used = found
        elif opts.time_unit is not None:
            raise MocapFormatError(src, line, "no time column found for --time-unit; name it with --time-column; "
                                   f"columns: {_listing(names)}")
    if not used:
        return TimeColumn(None, "", None)
    best = min(t.tier for _, t in used)
    top = [(i, t) for i, t in used if t.tier == best]
    if len(top) > 1:
        kind = "counter" if best == 3 else "time"
        raise MocapFormatError(
            src, line, f"several {kind} columns: {', '.join(repr(names[i].strip()) for i, _ in top)}; "
            "choose one with --time-column NAME",
        )
    i, t = top[0]
    note = None
    stated = True
    if opts.time_unit is not None:
        unit = opts.time_unit
    elif t.kind == "counter":
        unit = "counter"
    else:
        unit = t.unit or _unit_from_rows(i, unit_rows)
        if unit is None:
            unit, note = _infer_unit(cell(i), names[i], src, line)
            stated = False
    return TimeColumn(i, names[i].strip(), unit, t.wrap, note, stated)


# ------------------------------------------------------------------------------------------------
# orientation columns
# ------------------------------------------------------------------------------------------------

_LETTER_RE = re.compile(r"(?P<pre>.*?)(?P<c>[wxyz])")
_SCALAR_RE = re.compile(r"(?P<pre>.*?)(?:scalar|s|real)")
_INDEX_RE = re.compile(r"(?P<pre>.*?)q(?P<i>[0-4])")
_ELEMENT_LETTER_RE = re.compile(r"(?P<c>[wxyz]) element")
_ELEMENT_INDEX_RE = re.compile(r"element ?(?P<i>[1-4])")
_MATRIX_RE = re.compile(r"(?P<pre>.*?)mat\s*\[(?P<r>[1-3])\]\s*\[(?P<c>[1-3])\]")
_EULER_RE = re.compile(r"(?P<pre>.*?)(?P<a>roll|pitch|yaw)")
#: Xsens DOT / Movella DOT ``Euler_X, Euler_Y, Euler_Z``: roll, pitch, yaw in degrees.
_EULER_XYZ_RE = re.compile(r"(?P<pre>.*?)euler[ _]?(?P<c>[xyz])")
_EULER_AXIS = {"x": "roll", "y": "pitch", "z": "yaw"}
_SEPS = " _./-"


def _quat_prefix_ok(pre: str) -> bool:
    p = pre.rstrip(_SEPS)
    if pre == "" or p == "q" or (len(p) >= 2 and p[-1] == "q" and p[-2] in _SEPS):
        return True
    return "quat" in p or "orient" in p


def quat_component(name: str) -> tuple[str, str | int] | None:
    """``(set key, component)``: component ``"w"``..``"z"`` or an index (0-based ``q0``, 1-based
    ``Element 1``), or ``None`` when the name is not a quaternion component."""
    n = norm(name)
    m = _UNIT_PAREN_RE.match(n)
    if m:
        n = m.group("base")
    n = _CHANNEL_SUFFIX_RE.sub("", n)
    if m := _ELEMENT_LETTER_RE.fullmatch(n):
        return "element", m.group("c")
    if m := _ELEMENT_INDEX_RE.fullmatch(n):
        return "element#", int(m.group("i"))
    if (m := _LETTER_RE.fullmatch(n)) and _quat_prefix_ok(m.group("pre")):
        return m.group("pre"), m.group("c")
    if (m := _SCALAR_RE.fullmatch(n)) and m.group("pre") and _quat_prefix_ok(m.group("pre")) \
            and m.group("pre") not in ("", "q"):
        return m.group("pre"), "w"
    if (m := _INDEX_RE.fullmatch(n)) and (m.group("pre") == "" or m.group("pre")[-1] in _SEPS):
        return m.group("pre") + "q#", int(m.group("i"))
    return None


def _sensor_of(key: str, names: Sequence[str], cols: Sequence[int]) -> str | None:
    if "/" not in key:
        return None
    return names[cols[0]].strip().strip('"').split("/")[0].strip()


def _quaternion_sets(names: Sequence[str], scalar_last: bool, src: str, line: int) -> list[Orientation]:
    groups: dict[str, dict[str | int, list[int]]] = {}
    for i, n in enumerate(names):
        qc = quat_component(n)
        if qc is not None:
            groups.setdefault(qc[0], {}).setdefault(qc[1], []).append(i)
    sets = []
    for key, comps in groups.items():
        if any(len(v) > 1 for v in comps.values()):
            continue
        if set(comps) == {"w", "x", "y", "z"}:
            if scalar_last:
                raise MocapFormatError(
                    src, line, f"--scalar-last applies to numbered columns (q0..q3, Element 1..4); the columns "
                    f"{', '.join(names[comps[c][0]].strip() for c in 'wxyz')} name their components",
                )
            cols = tuple(comps[c][0] for c in "wxyz")
            order = "named"
        elif sorted(comps) in ([0, 1, 2, 3], [1, 2, 3, 4]):
            idx = [comps[k][0] for k in sorted(comps)]
            cols = (idx[3], idx[0], idx[1], idx[2]) if scalar_last else tuple(idx)
            order = "scalar-last" if scalar_last else "scalar-first"
        else:
            continue
        sets.append(Orientation("quaternion", cols, tuple(names[c].strip() for c in cols),
                                sensor=_sensor_of(key, names, cols), extra={"order": order}))
    return sets


def _matrix_sets(names: Sequence[str]) -> list[Orientation]:
    groups: dict[str, dict[tuple[int, int], list[int]]] = {}
    for i, n in enumerate(names):
        if m := _MATRIX_RE.fullmatch(norm(n)):
            groups.setdefault(m.group("pre"), {}).setdefault((int(m.group("r")), int(m.group("c"))), []).append(i)
    out = []
    for key, cells in groups.items():
        if len(cells) == 9 and all(len(v) == 1 for v in cells.values()):
            cols = tuple(cells[(r, c)][0] for r in (1, 2, 3) for c in (1, 2, 3))
            out.append(Orientation("matrix", cols, tuple(names[c].strip() for c in cols),
                                   sensor=_sensor_of(key, names, cols)))
    return out


def _euler_sets(names: Sequence[str], xsens: bool, src: str, line: int) -> list[Orientation]:
    groups: dict[str, dict[str, list[tuple[int, bool | None]]]] = {}
    for i, n in enumerate(names):
        nn = norm(n)
        deg: bool | None = None
        m = _UNIT_PAREN_RE.match(nn)
        if m:
            u = m.group("unit").strip()
            deg = {"deg": True, "degree": True, "degrees": True, "°": True,
                   "rad": False, "radian": False, "radians": False}.get(u)
            if deg is None:
                continue
            nn = m.group("base")
        else:
            for suf, d in (("_deg", True), ("_rad", False)):
                if nn.endswith(suf):
                    nn, deg = nn[: -len(suf)], d
        if (m := _EULER_RE.fullmatch(nn)) and (m.group("pre") == "" or m.group("pre")[-1] in _SEPS):
            groups.setdefault(m.group("pre"), {}).setdefault(m.group("a"), []).append((i, deg))
        elif xsens and (m := _EULER_XYZ_RE.fullmatch(nn)) and (m.group("pre") == "" or m.group("pre")[-1] in _SEPS):
            # only in Xsens files: elsewhere Euler_X may be a heading (e.g. BNO055 x = heading)
            groups.setdefault(m.group("pre") + "euler", {}).setdefault(_EULER_AXIS[m.group("c")], []).append((i, deg))
    out = []
    for key, angles in groups.items():
        if set(angles) != {"roll", "pitch", "yaw"} or any(len(v) > 1 for v in angles.values()):
            continue
        cols = tuple(angles[a][0][0] for a in ("roll", "pitch", "yaw"))
        units = {angles[a][0][1] for a in ("roll", "pitch", "yaw")}
        if len(units) > 1 and None not in units:
            raise MocapFormatError(src, line, "Euler angle columns mix degrees and radians: "
                                   + ", ".join(names[c].strip() for c in cols))
        stated = next((u for u in units if u is not None), None)
        if stated is None and "seconds_elapsed" in (norm(n) for n in names):
            stated = False      # Sensor Logger (Android/iOS) writes roll, pitch, yaw in radians
        if stated is None and not xsens:
            raise MocapFormatError(
                src, line, f"Euler angles {', '.join(names[c].strip() for c in cols)} without a unit: name them "
                "e.g. 'Roll (deg)' or 'roll (rad)', or give --quaternion-columns",
            )
        out.append(Orientation("euler", cols, tuple(names[c].strip() for c in cols),
                               sensor=_sensor_of(key, names, cols), degrees=True if stated is None else stated))
    return out


def _describe(o: Orientation) -> str:
    return "(" + ", ".join(o.names) + ")"


def find_orientations(names: Sequence[str], opts: ColumnOptions, src: str, line: int,
                      xsens: bool = False) -> list[Orientation]:
    """The orientation column sets of a header: one per sensor; ``[]`` when there are none.

    Quaternions win over a rotation matrix, which wins over Euler angles. Several sets that are not
    one per sensor (``Sensor/...`` paths) raise an error naming them and ``--quaternion-columns``.
    """
    if opts.quaternion_columns is not None:
        found = [find_column(names, w) for w in opts.quaternion_columns]
        cols = [c for c in found if c is not None]
        if len(cols) != len(found):
            return []
        return [Orientation("quaternion", tuple(cols), tuple(names[c].strip() for c in cols),
                            extra={"order": "given"})]
    for finder in (lambda: _quaternion_sets(names, opts.scalar_last, src, line), lambda: _matrix_sets(names),
                   lambda: _euler_sets(names, xsens, src, line)):
        sets = finder()
        if not sets:
            continue
        if len(sets) == 1:
            return sets
        sensors = [s.sensor for s in sets]
        if all(sensors) and len(set(sensors)) == len(sensors):
            return sets
        kind = sets[0].kind
        flag = "--quaternion-columns W,X,Y,Z (names in w,x,y,z order)"
        raise MocapFormatError(
            src, line, f"several {kind} column sets: {'; '.join(_describe(s) for s in sets)}; choose one with {flag}",
        )
    return []
