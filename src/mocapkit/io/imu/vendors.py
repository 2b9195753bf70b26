"""Vendor layouts that a single header line cannot describe, and the vendor label of a file.

- **OptiTrack Motive CSV** (format version 1.2x): a metadata line of ``key,value`` pairs (``Export
  Frame Rate``, ``Rotation Type``), then rows of column type (``Rigid Body``, ``Rigid Body Marker``,
  ``Marker``), name, ID (optional) and kind (``Rotation``, ``Position``, ``Error Per Marker``), then
  the axis row ``Frame,Time,X,Y,Z,W,...``. Each rigid body's ``Rotation`` ``X,Y,Z,W`` (scalar-last)
  becomes one signal; markers and positions are ignored. A body that is lost in a frame has empty
  cells: that frame is dropped for that body and counted in ``meta["warnings"]``. Only ``Rotation
  Type,Quaternion`` exports are read (Euler exports use a user-chosen order: an error says so).
  The layout is that of the real Motive 1.21 export in ``../shared/data/imu/optitrack``; the rows
  above the axis row are found by content (first = type, second = name, last = kind), so an extra
  ID row or a leading ``Type``/``Name`` cell does not move them.

- **APDM CSV ``Format=7``** (the older Opal / Mobility Lab export; layout as described by OpenSim's
  APDM reader): three header rows: ``Format=7,I1,,,<sensor>,,...`` (a group label ``I<n>`` three cells
  before each sensor's name), ``Time,Accelerometer,,,Gyroscope,,,Magnetometer,,,Barometer,Orientation,,,``
  (each quantity over its columns) and ``,X,Y,Z,...,,S,X,Y,Z`` (the components; ``S`` the scalar).
  They are merged into ``<sensor>/<quantity>/<component>`` names, so each sensor's
  ``Orientation`` ``S,X,Y,Z`` becomes one signal (scalar first). The file states no rate; the ``Time``
  column follows the rules of a unit-less ``time`` (an epoch in µs is recognised by its magnitude).

APDM Motion Studio CSV (``Sample Rate:,128,Hz`` preamble, a units row under the header,
``<Sensor>/Orientation/Scalar|X|Y|Z``) and Shimmer Consensys CSV (``"sep=\\t"``, a ``CAL``/``RAW`` row
and a units row under the header) need no special code: :mod:`mocapkit.io.imu.layout` reads the
rows under the header for the time unit and groups ``Sensor/...`` columns into one signal per sensor.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

from mocapkit.errors import MocapFormatError
from mocapkit.io.imu.columns import ColumnOptions, Orientation, find_orientations, norm, parse_rate, split_fields

__all__ = ["apdm7_columns", "is_apdm7", "is_optitrack", "optitrack_columns", "vendor_label"]

_APDM_FORMAT_RE = re.compile(r"format\s*=\s*(?P<v>\S*)")
_APDM_GROUP_RE = re.compile(r"i\d+")


def is_optitrack(line: str) -> bool:
    """Is this the first line of an OptiTrack Motive CSV export?"""
    return norm(line.split(",")[0]) == "format version"


def _pairs(line: str) -> dict[str, tuple[str, int]]:
    cells = [c.strip() for c in line.split(",")]
    return {norm(cells[k]): (cells[k + 1], k) for k in range(0, len(cells) - 1, 2)}


def optitrack_columns(lines: Sequence[str], first: int, end: int, src: str,
                      opts: ColumnOptions) -> tuple[int, list[str], list[Orientation], float | None, list[str]]:
    """``(axis_row_index, column names, one Orientation per rigid body, export rate, warnings)``."""
    meta = _pairs(lines[first])
    warnings: list[str] = []
    rot_type = meta.get("rotation type", ("Quaternion", 0))[0]
    if norm(rot_type) != "quaternion":
        raise MocapFormatError(src, first + 1, f"OptiTrack export with Rotation Type {rot_type!r}: only "
                               "quaternion exports are read (export again with Rotation Type Quaternion)")
    rate = None
    if "export frame rate" in meta:
        rate = parse_rate(meta["export frame rate"][0])
        if rate is None:
            raise MocapFormatError(src, first + 1,
                                   f"cannot read the Export Frame Rate {meta['export frame rate'][0]!r}")
    rows: list[int] = []
    axis = None
    for i in range(first + 1, end):
        if not lines[i].strip():
            continue
        cells = split_fields(lines[i], ",")
        if cells and norm(cells[0]) == "frame":
            axis = i
            break
        rows.append(i)
    if axis is None or len(rows) < 3:
        raise MocapFormatError(src, first + 1, "OptiTrack export without the type / name / kind rows and the "
                               "'Frame,Time,...' row")
    axis_cells = lines[axis].split(",")
    n = len(axis_cells)

    def row(i: int) -> list[str]:
        c = [x.strip().strip('"') for x in lines[i].split(",")]
        return c + [""] * (n - len(c))

    types, names, kinds = row(rows[0]), row(rows[1]), row(rows[-1])
    col_names = []
    bodies: dict[str, dict[str, int]] = {}
    for j in range(n):
        ax = axis_cells[j].strip()
        if j < 2 or not names[j]:
            col_names.append(ax)
            continue
        col_names.append(f"{names[j]}/{kinds[j]}/{ax}")
        if norm(types[j]) == "rigid body" and norm(kinds[j]) == "rotation":
            comp = norm(ax)
            if comp in ("x", "y", "z", "w"):
                if comp in bodies.setdefault(names[j], {}):
                    raise MocapFormatError(src, axis + 1, f"rigid body {names[j]!r} has two Rotation {ax} columns")
                bodies[names[j]][comp] = j
    sensors = []
    for body, comps in bodies.items():
        if set(comps) != {"w", "x", "y", "z"}:
            raise MocapFormatError(src, axis + 1, f"rigid body {body!r} lacks Rotation columns "
                                   f"{', '.join(c.upper() for c in 'xyzw' if c not in comps)}")
        cols = tuple(comps[c] for c in "wxyz")
        sensors.append(Orientation("quaternion", cols, tuple(col_names[c] for c in cols), sensor=body,
                                   missing_rows="drop", extra={"order": "scalar-last X,Y,Z,W"}))
    if not sensors:
        raise MocapFormatError(src, axis + 1, "OptiTrack export without rigid-body Rotation columns "
                               "(markers alone carry no orientation)")
    if opts.quaternion_columns is not None or opts.scalar_last:
        raise MocapFormatError(src, axis + 1, "--quaternion-columns/--scalar-last do not apply to OptiTrack "
                               "exports (rigid bodies are found from the type and kind rows)")
    return axis, col_names, sensors, rate, warnings


def is_apdm7(line: str) -> bool:
    """Is this the first line of an APDM ``Format=N`` CSV export (any N; only 7 is read)?"""
    return _APDM_FORMAT_RE.fullmatch(norm(line.split(",")[0])) is not None


def _cells(line: str, n: int) -> list[str]:
    c = [x.strip().strip('"').strip() for x in line.split(",")]
    return c + [""] * (n - len(c))


def apdm7_columns(lines: Sequence[str], first: int, end: int, src: str,
                  opts: ColumnOptions) -> tuple[int, list[str], list[Orientation], list[str]]:
    """``(component row index, merged column names, one Orientation per sensor, warnings)`` of an APDM
    ``Format=7`` export whose first line is ``lines[first]``."""
    version = _APDM_FORMAT_RE.fullmatch(norm(lines[first].split(",")[0])).group("v")  # type: ignore[union-attr]
    if version != "7":
        raise MocapFormatError(src, first + 1, f"APDM CSV Format={version}: only Format=7 is read (or the "
                               "newer export with 'Sample Rate:' and Sensor/Orientation/Scalar columns)")
    rows = [i for i in range(first + 1, end) if lines[i].strip()][:2]
    if len(rows) < 2:
        raise MocapFormatError(src, first + 1, "APDM Format=7 export without its two header rows under the first "
                               "(quantities 'Time,Accelerometer,...' and components ',X,Y,Z,...')")
    q_row, c_row = rows
    n = max(len(lines[i].split(",")) for i in (first, q_row, c_row))
    groups, quantities, comps = _cells(lines[first], n), _cells(lines[q_row], n), _cells(lines[c_row], n)
    starts = [j for j in range(1, n) if _APDM_GROUP_RE.fullmatch(groups[j].lower())]
    sensor_of: list[str | None] = [None] * n
    if starts:
        for k, j0 in enumerate(starts):
            j1 = starts[k + 1] if k + 1 < len(starts) else n
            named = [groups[j] for j in range(j0 + 1, j1) if groups[j]]
            if len(named) != 1:
                raise MocapFormatError(src, first + 1, f"APDM group {groups[j0]!r} (column {j0 + 1}) names "
                                       f"{len(named)} sensors ({', '.join(named) or 'none'}); expected one")
            if "/" in named[0]:
                raise MocapFormatError(src, first + 1, f"APDM sensor name {named[0]!r} holds a '/'")
            for j in range(j0, j1):
                sensor_of[j] = named[0]
    else:  # no I<n> labels: each name covers the columns up to the next one
        cur = None
        for j in range(1, n):
            cur = groups[j] or cur
            sensor_of[j] = cur
    names: list[str] = []
    qty: list[str] = []
    for j in range(n):
        if j == 0 or j in starts or sensor_of[j] != sensor_of[j - 1]:
            qty.append(quantities[j])
        else:
            qty.append(quantities[j] or qty[j - 1])
        names.append("/".join(p for p in (sensor_of[j], qty[j], comps[j]) if p))
    if opts.quaternion_columns is None:
        for sensor in dict.fromkeys(s for s in sensor_of if s):
            got = [comps[j].upper() for j in range(n) if sensor_of[j] == sensor and norm(qty[j]) == "orientation"]
            if got and sorted(got) != ["S", "X", "Y", "Z"]:
                raise MocapFormatError(src, c_row + 1, f"APDM sensor {sensor!r}: Orientation columns "
                                       f"{', '.join(got)}; expected S, X, Y, Z")
    sensors = find_orientations(names, opts, src, c_row + 1)
    if not sensors:
        raise MocapFormatError(src, c_row + 1, "APDM Format=7 export without Orientation S,X,Y,Z columns")
    return c_row, names, sensors, []


def vendor_label(names: Sequence[str], preamble: Sequence[str], sensors: Sequence[Orientation],
                 optitrack: bool = False) -> str:
    """A short name of the exporting software for ``meta["format"]`` (informative only)."""
    low = [norm(n) for n in names]
    pre = " ".join(norm(p) for p in preamble)
    if optitrack:
        return "optitrack"
    if any(s.sensor for s in sensors) and any("/orientation" in n for n in low):
        return "apdm"
    if any(n.startswith("shimmer_") for n in low):
        return "shimmer"
    if "devicetag" in pre or ("sampletimefine" in low and "sep=" in pre):
        return "xsens-dot"
    if "sampletimefine" in low or "packetcounter" in low or any(n.startswith("quat_") or n.startswith("mat[")
                                                                 for n in low) or pre.startswith("//"):
        return "xsens"
    if "w element" in low:
        return "x-imu3"
    if "packet number" in low and "element 1" in low:
        return "x-io-legacy"
    if "timestamp (us)" in low and "w" in low:
        return "x-io"
    if "time (s)" in low and "w" in low:
        return "ngimu"
    if "epoc (ms)" in low:
        return "metawear"
    if "seconds_elapsed" in low:
        return "sensor-logger"
    if "loggingtime(txt)" in low:
        return "sensorlog"
    return "generic"
