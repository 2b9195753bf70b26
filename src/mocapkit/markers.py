"""Optical marker trajectories: the :class:`Markers` data model, its CSV writer and the loaders.

A :class:`Markers` holds ``N`` frames of ``M`` labelled 3-D marker positions, ``NaN`` where a marker
is missing (occluded, not reconstructed), plus optional analog channels recorded alongside.

Readers (they all return :class:`Markers` and raise only :class:`mocapkit.errors.MocapFormatError`
for bad files):

=============  ==========================================  =======================================
suffix         reader                                      notes
=============  ==========================================  =======================================
``.c3d``       :func:`mocapkit.io.c3d.read_c3d`            via ezc3d, with a structural pre-check
``.tsv``       :func:`mocapkit.io.qtm.read_qtm_tsv`        Qualisys QTM 3-D TSV export
``.trc``       :func:`mocapkit.io.opensim.read_trc`        OpenSim TRC
``.csv``       :func:`mocapkit.io.vicon_csv.read_vicon_csv` Vicon Nexus export (first line
                                                           ``Trajectories`` or ``Devices``)
``.csv``       :func:`read_markers_csv`                    any other CSV: the wide CSV written by
                                                           :meth:`Markers.to_csv`
=============  ==========================================  =======================================

:func:`load_markers` and :func:`write_markers` (``.c3d``, ``.trc``, ``.csv``) dispatch through
:mod:`mocapkit.io.loaders`, imported lazily inside them.

Labels
------
Labels must be unique, non-empty and free of control characters. Files often break this (QTM exports
unnamed trajectories, C3D files may repeat a label or have fewer labels than markers), so readers
pass the raw labels through :func:`make_unique_labels`, which never drops a marker: an empty label
becomes ``unnamed_<k>`` (``k`` = 1-based marker index in the file), a repeated label gets ``_2``,
``_3``... (the first occurrence keeps the plain name), and every change is recorded in
``meta["label_fixes"]`` as ``{"index", "original", "label", "reason"}``.
"""

from __future__ import annotations

import csv
import io
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mocapkit.errors import InvalidSignalError, MocapFormatError

__all__ = [
    "Markers",
    "load_markers",
    "make_unique_labels",
    "read_markers_csv",
    "write_markers",
]

_CONTROL_RE = re.compile(r"[\x00-\x1f\x7f\ud800-\udfff]")
_AXES = ("x", "y", "z")
_UNIT_RE = re.compile(r"^(.*_[xyzXYZ])\s*\(([^()]+)\)$")  # "<label>_x (mm)"
_MISSING = ("", "nan", "NaN")  # the wide CSV's missing coordinate (to_csv writes "nan")


# --------------------------------------------------------------------------------------------------
# labels
# --------------------------------------------------------------------------------------------------


def _label_problem(label: object) -> str | None:
    if not isinstance(label, str):
        return f"is not a string ({type(label).__name__})"
    if not label:
        return "is empty"
    if label != label.strip():
        return "has leading or trailing white space"
    if _CONTROL_RE.search(label):
        return "contains a control character"
    return None


def make_unique_labels(raw: list[str] | tuple[str, ...], count: int | None = None,
                       prefix: str = "unnamed") -> tuple[tuple[str, ...], list[dict]]:
    """Turn the labels of a file into ``count`` unique, valid labels, deterministically.

    Parameters
    ----------
    raw
        The labels as found in the file (may be too few, too many, empty, repeated).
    count
        The number of markers; default ``len(raw)``. Missing labels count as empty; labels beyond
        ``count`` are ignored (and reported with ``reason="extra"``, ``index >= count``).
    prefix
        Stem of the names made for empty labels: ``f"{prefix}_{k}"`` with ``k`` the 1-based index.

    Returns
    -------
    labels, fixes
        ``fixes`` lists every change as ``{"index": i (0-based), "original": str | None,
        "label": str | None, "reason": "empty" | "missing" | "duplicate" | "cleaned" | "extra"}``.
    """
    n = len(raw) if count is None else int(count)
    fixes: list[dict] = []
    cleaned: list[str] = []
    reasons: list[str | None] = []
    for i in range(n):
        if i >= len(raw):
            cleaned.append("")
            reasons.append("missing")
            continue
        orig = raw[i] if isinstance(raw[i], str) else str(raw[i])
        lab = _CONTROL_RE.sub("?", orig).strip()
        cleaned.append(lab)
        reasons.append(None if lab == orig else "cleaned")
    for i in range(n, len(raw)):
        fixes.append({"index": i, "original": raw[i], "label": None, "reason": "extra"})

    used: set[str] = set()
    first_owner: dict[str, int] = {}
    for i, lab in enumerate(cleaned):
        if lab and lab not in first_owner:
            first_owner[lab] = i
            used.add(lab)

    out: list[str] = []
    for i, lab in enumerate(cleaned):
        original = raw[i] if i < len(raw) else None
        if lab and first_owner.get(lab) == i:
            out.append(lab)
            if reasons[i] == "cleaned":
                fixes.append({"index": i, "original": original, "label": lab, "reason": "cleaned"})
            continue
        if not lab:
            base = f"{prefix}_{i + 1}"
            reason = reasons[i] or "empty"
            if reason == "cleaned":
                reason = "empty"
            k = 1
            name = base
        else:
            base = lab
            reason = "duplicate"
            k = 2
            name = f"{base}_{k}"
        while name in used:
            k += 1
            name = f"{base}_{k}"
        used.add(name)
        out.append(name)
        fixes.append({"index": i, "original": original, "label": name, "reason": reason})
    fixes.sort(key=lambda f: (f["index"], f["reason"]))
    return tuple(out), fixes


# --------------------------------------------------------------------------------------------------
# the data model
# --------------------------------------------------------------------------------------------------


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


def _check_analog(analog: dict, n_frames: int) -> dict:
    if not isinstance(analog, dict):
        raise InvalidSignalError(f"analog must be a dict or None, got {type(analog).__name__}")
    missing = [k for k in ("labels", "rate", "values") if k not in analog]
    if missing:
        raise InvalidSignalError(f"analog dict lacks {', '.join(missing)}")
    labels = tuple(analog["labels"])
    for i, lab in enumerate(labels):
        prob = _label_problem(lab)
        if prob:
            raise InvalidSignalError(f"analog label {i} ({lab!r}) {prob}")
    if len(set(labels)) != len(labels):
        raise InvalidSignalError("analog labels must be unique")
    try:
        rate = float(analog["rate"])
    except (TypeError, ValueError):
        raise InvalidSignalError(f"analog rate must be a number, got {analog['rate']!r}") from None
    if not (math.isfinite(rate) and rate > 0):
        raise InvalidSignalError(f"analog rate must be finite and > 0, got {rate!r}")
    values = np.array(analog["values"], dtype=np.float64)
    if values.ndim != 2 or values.shape[1] != len(labels):
        raise InvalidSignalError(
            f"analog values must be (A, K) with K = {len(labels)} labels, got shape {values.shape}"
        )
    out = dict(analog)
    out["labels"] = labels
    out["rate"] = rate
    out["values"] = _readonly(values)
    return out


@dataclass(frozen=True, eq=False)
class Markers:
    """Labelled 3-D marker trajectories.

    Attributes
    ----------
    times
        ``(N,)`` float64 seconds, finite and strictly increasing, ``N >= 1``.
    positions
        ``(N, M, 3)`` float64 in ``units``; ``NaN`` marks a missing marker (a frame has either all
        three coordinates or none: a partly-NaN triple is made all-NaN). Infinite values are refused.
    labels
        ``M`` unique, non-empty labels without control characters or surrounding white space (see
        :func:`make_unique_labels`).
    rate
        Nominal frame rate in Hz (finite, ``> 0``).
    units
        Length unit of ``positions`` as given by the file (``"mm"``, ``"m"``...).
    analog
        ``None`` or a dict with at least ``"labels"`` (tuple of ``K`` unique labels), ``"rate"`` (Hz)
        and ``"values"`` (``(A, K)`` float64, read-only); readers may add ``"units"``, ``"t0"``...
    source
        Where it came from (a path), for messages.
    meta
        Anything else the reader found (header fields, label fixes, discrepancies...).

    All arrays are stored read-only. Equality is identity (``eq=False``): compare arrays yourself.
    """

    times: np.ndarray
    positions: np.ndarray
    labels: tuple[str, ...]
    rate: float
    units: str = "mm"
    analog: dict | None = field(default=None, compare=False)
    source: str = ""
    meta: dict = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        where = f"markers from {self.source}" if self.source else "markers"
        t = np.array(self.times, dtype=np.float64)
        p = np.array(self.positions, dtype=np.float64)
        if t.ndim != 1:
            raise InvalidSignalError(f"{where}: times must be 1-D, got shape {t.shape}")
        n = t.shape[0]
        if n == 0:
            raise InvalidSignalError(f"{where}: no frames")
        if p.ndim != 3 or p.shape[0] != n or p.shape[2] != 3:
            raise InvalidSignalError(
                f"{where}: positions must be (N, M, 3) with N = len(times) = {n}, got {p.shape}"
            )
        if not np.all(np.isfinite(t)):
            i = int(np.flatnonzero(~np.isfinite(t))[0])
            raise InvalidSignalError(f"{where}: time of frame {i} is not finite")
        bad = np.flatnonzero(np.diff(t) <= 0)
        if bad.size:
            i = int(bad[0])
            raise InvalidSignalError(
                f"{where}: times must be strictly increasing; frame {i + 1} (t={float(t[i + 1])!r}) "
                f"is not after frame {i} (t={float(t[i])!r})"
            )
        if np.isinf(p).any():
            f, m, _ = (int(v) for v in np.argwhere(np.isinf(p))[0])
            raise InvalidSignalError(f"{where}: frame {f}, marker {m} has an infinite coordinate")
        partial = np.isnan(p).any(axis=2)
        p[partial] = np.nan

        if isinstance(self.labels, str):
            raise InvalidSignalError(f"{where}: labels must be a sequence of strings, not a string")
        labels = tuple(self.labels)
        if len(labels) != p.shape[1]:
            raise InvalidSignalError(
                f"{where}: {len(labels)} labels for {p.shape[1]} markers"
            )
        for i, lab in enumerate(labels):
            prob = _label_problem(lab)
            if prob:
                raise InvalidSignalError(f"{where}: label {i} ({lab!r}) {prob}")
        if len(set(labels)) != len(labels):
            seen: set[str] = set()
            dup = next(lab for lab in labels if lab in seen or seen.add(lab))
            raise InvalidSignalError(f"{where}: label {dup!r} is repeated; labels must be unique")

        try:
            rate = float(self.rate)
        except (TypeError, ValueError):
            raise InvalidSignalError(f"{where}: rate must be a number, got {self.rate!r}") from None
        if not (math.isfinite(rate) and rate > 0):
            raise InvalidSignalError(f"{where}: rate must be finite and > 0, got {self.rate!r}")
        if not isinstance(self.units, str) or not self.units.strip():
            raise InvalidSignalError(f"{where}: units must be a non-empty string, got {self.units!r}")
        analog = None if self.analog is None else _check_analog(self.analog, n)
        if not isinstance(self.meta, dict):
            raise InvalidSignalError(f"{where}: meta must be a dict")

        object.__setattr__(self, "times", _readonly(t))
        object.__setattr__(self, "positions", _readonly(p))
        object.__setattr__(self, "labels", labels)
        object.__setattr__(self, "rate", rate)
        object.__setattr__(self, "units", self.units.strip())
        object.__setattr__(self, "analog", analog)
        object.__setattr__(self, "source", str(self.source))

    # ---------------------------------------------------------------------------------------------

    def __len__(self) -> int:
        return int(self.times.shape[0])

    def __repr__(self) -> str:
        return (f"Markers({self.n_frames} frames x {self.n_markers} markers, {self.rate:g} Hz, "
                f"{self.units}, source={self.source!r})")

    @property
    def n_frames(self) -> int:
        return int(self.positions.shape[0])

    @property
    def n_markers(self) -> int:
        return int(self.positions.shape[1])

    @property
    def duration(self) -> float:
        return float(self.times[-1] - self.times[0])

    @property
    def missing(self) -> np.ndarray:
        """``(N, M)`` bool: ``True`` where the marker is missing."""
        return np.isnan(self.positions[:, :, 0])

    def index(self, label: str) -> int:
        """Column of ``label`` (``KeyError`` naming the known labels when absent)."""
        try:
            return self.labels.index(label)
        except ValueError:
            shown = ", ".join(self.labels[:10]) + (", ..." if len(self.labels) > 10 else "")
            raise KeyError(f"no marker {label!r}; markers: {shown}") from None

    def marker(self, label: str) -> np.ndarray:
        """``(N, 3)`` read-only view of one marker's trajectory."""
        return self.positions[:, self.index(label), :]

    # ---------------------------------------------------------------------------------------------

    def csv_header(self) -> list[str]:
        """Column names of :meth:`to_csv`: ``time (s)`` then ``<label>_x (<units>)``, ``_y``, ``_z``..."""
        return ["time (s)"] + [f"{lab}_{ax} ({self.units})" for lab in self.labels for ax in _AXES]

    def to_csv(self, path: str | Path) -> None:
        """Write a wide CSV atomically: ``time (s),<label>_x (mm),<label>_y (mm),...`` (one row a frame;
        the length unit is part of every coordinate's name, so it survives the round trip).

        Numbers are written as ``repr(float)`` (shortest text that reads back bit-exactly); a missing
        marker is written as ``nan`` in its three cells (``float("nan")``, numpy and pandas all read
        it back as NaN). Header cells holding a comma or a quote are quoted as per RFC 4180. Line ends
        are ``\\n``. :func:`read_markers_csv` reads the file back.
        """
        from mocapkit.io.atomic import atomic_write_text  # the model imports io lazily only

        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerow(self.csv_header())
        flat = self.positions.reshape(self.n_frames, -1)
        rows = [buf.getvalue()]
        for t, row in zip(self.times.tolist(), flat.tolist()):
            rows.append(",".join([repr(t)] + [repr(v) for v in row]))
            rows.append("\n")
        atomic_write_text(path, "".join(rows))


# --------------------------------------------------------------------------------------------------
# the wide CSV
# --------------------------------------------------------------------------------------------------


def read_markers_csv(path: str | Path, rate: float | None = None, units: str | None = None) -> Markers:
    """Read a wide marker CSV as written by :meth:`Markers.to_csv`.

    The header must be ``time`` (or ``time (s)``) followed by ``<label>_x, <label>_y, <label>_z``
    triples, each optionally with its unit, ``<label>_x (mm)``. ``nan`` (or an empty cell) is a missing
    coordinate. ``rate`` defaults to the mean rate ``(N - 1) / (t[-1] - t[0])`` (1 Hz for a single
    frame): pass it when you know it. The length unit is the header's; ``units`` gives it for a file
    that does not state it (default ``"mm"``, recorded as an assumption in ``meta["warnings"]``) and
    must agree with the header when both exist.

    Numbers follow the strict grammar of :mod:`mocapkit.io.numbers` (``nan``/``NaN``/empty are the
    only missing spellings; ``inf``, ``0_5`` and ``|value| > 1e12`` are errors naming line and column).
    A last line written without a newline whose last value has fewer decimals than that column on
    the rows before it is an error (the file was cut short); when that cannot be told (``repr``
    numbers vary in length) the row is read with a warning. Pipes are read in bounded chunks.
    """
    from mocapkit.io.numbers import parse_number  # the model imports io lazily only
    from mocapkit.io.textinput import check_cells_budget, final_line_verdict, read_input, report_final_line

    p = Path(path)
    src = str(p)
    data = read_input(p, "CSV file")
    ends_with_newline = data.endswith((b"\n", b"\r"))
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise MocapFormatError(src, line, "not UTF-8 text") from None
    lines = [ln[:-1] if ln.endswith("\r") else ln for ln in text.split("\n")]
    while lines and not lines[-1].strip():
        lines.pop()
        ends_with_newline = True
    if not lines:
        raise MocapFormatError(src, 1, "empty file (expected a header 'time,<label>_x,...')")
    try:
        header = next(csv.reader([lines[0]]))
    except csv.Error as exc:
        raise MocapFormatError(src, 1, f"cannot parse the header: {exc}") from None
    header = [h.strip() for h in header]
    if header and header[0].lower() in ("time (s)", "time(s)"):
        header[0] = "time"
    if not header or header[0].lower() != "time":
        raise MocapFormatError(src, 1, f"the first column must be 'time', got {header[0] if header else ''!r}")
    if (len(header) - 1) % 3:
        raise MocapFormatError(src, 1, f"{len(header) - 1} coordinate columns is not a multiple of 3")
    stated = []
    for j in range(1, len(header)):
        m = _UNIT_RE.match(header[j])
        if m:
            header[j] = m.group(1).rstrip()
            stated.append(m.group(2).strip())
    if stated and len(stated) != len(header) - 1:
        raise MocapFormatError(src, 1, "some coordinate columns state a unit, e.g. '(mm)', and others do not")
    if len(set(stated)) > 1:
        raise MocapFormatError(src, 1, f"the coordinate columns state different units: {sorted(set(stated))}")
    warnings = []
    if stated:
        if units is not None and units != stated[0]:
            raise MocapFormatError(src, 1, f"the header says the unit is {stated[0]!r}, but {units!r} was given")
        units = stated[0]
    elif units is None:
        units = "mm"
        warnings.append("the header states no length unit; mm assumed")
    labels = []
    for j in range(1, len(header), 3):
        trio = header[j:j + 3]
        stems = []
        for h, ax in zip(trio, _AXES):
            if not h.lower().endswith("_" + ax):
                raise MocapFormatError(src, 1, f"column {j + _AXES.index(ax) + 1} ({h!r}) should end in '_{ax}'")
            stems.append(h[:-2])
        if len(set(stems)) != 1:
            raise MocapFormatError(src, 1, f"columns {j + 1}-{j + 3} ({', '.join(trio)}) are not one marker's x, y, z")
        labels.append(stems[0])
    ncol = len(header)
    check_cells_budget(src, 1, (len(lines) - 1) * ncol, len(data), f"{len(lines) - 1} rows of {ncol} columns")
    values = np.empty((len(lines) - 1, ncol), dtype=np.float64)
    fields = [f"column {j + 1} ({h})" for j, h in enumerate(header)]
    last = len(lines) - 2
    for i, ln in enumerate(lines[1:]):
        cells = ln.split(",")
        if len(cells) != ncol:
            cut = (" (the file ends in this line without a newline: it was cut short)"
                   if i == last and not ends_with_newline else "")
            raise MocapFormatError(src, i + 2, f"expected {ncol} comma-separated values, found {len(cells)}{cut}")
        if i == last and not ends_with_newline:
            verdict, j = final_line_verdict([r.split(",") for r in lines[max(1, i - 19):i + 1]], cells)
            report_final_line(src, i + 2, verdict, j, fields[j] if j is not None else "the last value",
                              cells[j] if j is not None else "", warnings)
        for j, c in enumerate(cells):
            values[i, j] = parse_number(c.strip(), src, i + 2, fields[j], missing=_MISSING)
    if values.shape[0] == 0:
        raise MocapFormatError(src, 1, "no data rows")
    times = values[:, 0]
    if np.isnan(times).any():
        raise MocapFormatError(src, int(np.flatnonzero(np.isnan(times))[0]) + 2, "missing time")
    if rate is None:
        span = float(times[-1] - times[0]) if len(times) > 1 else 0.0
        rate = (len(times) - 1) / span if span > 0 else 1.0
    try:
        return Markers(times, values[:, 1:].reshape(len(times), -1, 3), tuple(labels), rate,
                       units=units, source=src, meta={"format": "csv", "warnings": warnings})
    except InvalidSignalError as exc:
        raise MocapFormatError(src, None, str(exc)) from None


# --------------------------------------------------------------------------------------------------
# dispatch
# --------------------------------------------------------------------------------------------------


def load_markers(path: str | Path) -> Markers:
    """Read a marker file (``.c3d``, ``.tsv``, ``.trc``, ``.csv``): see
    :func:`mocapkit.io.loaders.load_markers`, where the dispatch lives (the model imports no reader)."""
    from mocapkit.io.loaders import load_markers as _load

    return _load(path)


def write_markers(markers: Markers, path: str | Path, *, analog: bool = True) -> None:
    """Write markers by suffix (``.c3d``, ``.trc``, ``.csv``): see
    :func:`mocapkit.io.loaders.write_markers`."""
    from mocapkit.io.loaders import write_markers as _write

    _write(markers, path, analog=analog)
