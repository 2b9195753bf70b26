"""What kind of file is this, and load it: skeletal motion (BVH, ASF/AMC, Xsens MVNX), markers (C3D, Qualisys
TSV) or IMU orientation streams (CSV/text exports)."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

from mocapkit.errors import MocapFormatError

TYPE_CHECKING = False
if TYPE_CHECKING:  # annotations only: importing the dispatcher loads no model, reader or numpy
    from mocapkit.skeleton import Motion

SKELETAL_SUFFIXES = (".bvh", ".amc", ".mvnx", ".mkc")
MARKER_SUFFIXES = (".c3d", ".tsv", ".trc")
#: OpenSim tables: ``"imu"`` for an OpenSense orientation STO, else ``"table"`` (joint angles...).
TABLE_SUFFIXES = (".mot", ".sto")
#: Suffix -> reader of a skeletal file whose decoder is an algorithm above io (the ``.mkc`` clip's is
#: :mod:`mocapkit.clip`), registered by the package root (``mocapkit/__init__.py``) so io imports none.
MOTION_READERS: dict[str, Callable[[Path], Motion]] = {}


def register_motion_reader(suffix: str, read: Callable[[Path], Motion]) -> None:
    """Make :func:`load_motion` read files ending in ``suffix`` (lower case, with the dot) by ``read(path)``."""
    MOTION_READERS[suffix.lower()] = read


def kind_of(path: str | Path) -> str:
    """``"skeletal"``, ``"markers"``, ``"table"`` or ``"imu"`` (folders and everything else are IMU data).

    A ``.csv`` is ``"markers"`` when it is a Vicon Nexus export (first line ``Trajectories`` or
    ``Devices``) or the wide CSV of :func:`~mocapkit.io.markers.wide_csv.write_markers_csv`
    (``time (s),<m>_x (mm),...``); a ``.mot``/``.sto`` is ``"imu"`` when it holds OpenSense orientations
    (``DataType=Quaternion``), else ``"table"`` (one vector signal, e.g. joint angles).
    """
    p = Path(path)
    if p.exists() and not p.is_file() and not p.is_dir():  # a pipe or device: by suffix, nothing sniffed
        s = p.suffix.lower()
        if s in MARKER_SUFFIXES:
            return "markers"
        if s in TABLE_SUFFIXES:  # read_opensim_signals reads it once and tells tables and orientations apart
            return "table"
    if p.is_file() or not p.exists():
        s = p.suffix.lower()
        if s in SKELETAL_SUFFIXES:
            return "skeletal"
        if s in MARKER_SUFFIXES:
            return "markers"
        if s == ".csv" and p.is_file() and _marker_csv(p):
            return "markers"
        if s in TABLE_SUFFIXES:
            from mocapkit.io.markers.opensim import table_kind

            return "imu" if table_kind(p) == "orientations" else "table"
    return "imu"


def load_motion(
    path: str | Path, asf: str | Path | None = None, rate: float | None = None, strict: bool = True
) -> Motion:
    """Read a BVH file, or an AMC file with its ASF skeleton (``asf``, or ``<stem>.asf`` /
    ``<subject>.asf`` beside it, CMU naming)."""
    p = Path(path)
    if not p.exists():
        raise MocapFormatError(str(p), None, "no such file")
    s = p.suffix.lower()
    if s == ".bvh":
        from mocapkit.io.skeletal.bvh import read_bvh

        if rate is not None:
            raise MocapFormatError(str(p), None, "a BVH file has its own Frame Time; do not give --rate")
        return read_bvh(p, strict=strict)
    if s == ".amc":
        from mocapkit.io.skeletal.amc import load_amc_for_cli

        return load_amc_for_cli(p, asf=asf, rate=rate)
    if s == ".mvnx":
        from mocapkit.io.skeletal.mvnx import read_mvnx

        if rate is not None or asf is not None:
            raise MocapFormatError(
                str(p), None, "an MVNX file has its own frameRate and skeleton; do not give --rate or --asf"
            )
        return read_mvnx(p)
    if s == ".mkc" and s in MOTION_READERS:
        if rate is not None or asf is not None:
            raise MocapFormatError(
                str(p), None, "a mocapkit clip has its own frame times and skeleton; do not give --rate or --asf"
            )
        return MOTION_READERS[s](p)
    raise MocapFormatError(str(p), None, f"not a skeletal motion file (expected {', '.join(SKELETAL_SUFFIXES)})")


def companions(path: str | Path, *, asf: str | Path | None = None,
               labels_beside: bool = False) -> list[Path]:
    """The files read implicitly with ``path`` (inputs too: an output must never replace them).

    The ASF beside a CMU-named AMC (``<stem>.asf`` / ``<subject>.asf``) when no ``asf`` is given; the
    ``<stem>.labels.txt`` of a take with ``labels_beside`` (``segment``); the external buffer of a
    ``.gltf``; a legacy x-io file's ``<prefix>_Registers.csv``; a sensor folder's ``Session.xml`` and
    ``*_Registers.csv`` (:func:`mocapkit.io.imu.sessions.folder_companions`). Files that do not
    exist are not listed; nothing here raises for bad content (the reader reports it).
    """
    p = Path(path)
    out: list[Path] = []
    try:
        if p.is_dir():
            from mocapkit.io.imu.sessions import folder_companions

            return folder_companions(p)
        if not p.is_file():
            return []
        s = p.suffix.lower()
        if s == ".amc" and asf is None:
            from mocapkit.io.skeletal.amc import companion_asf

            found = companion_asf(p)
            out += [found] if found is not None else []
        if labels_beside and p.with_name(p.stem + ".labels.txt").is_file():
            out.append(p.with_name(p.stem + ".labels.txt"))
        if s == ".gltf":
            from mocapkit.io.formats.gltf import gltf_buffer_files

            out += gltf_buffer_files(p)
        if s in (".csv", ".txt"):
            from mocapkit.io.imu.sessions import registers_file
            from mocapkit.io.imu.signals import detect_format

            regs = registers_file(p)
            if regs is not None and detect_format(p) == "x-io-legacy":
                out.append(regs)
    except OSError:
        pass
    return out


def inputs_with_companions(inputs) -> list[Path]:
    """``inputs`` (paths or ``None``) followed by the companions of each (:func:`companions`); an ``.asf``
    among the inputs is the skeleton given with ``--asf``, so no AMC's beside-ASF is added."""
    given = [Path(i) for i in inputs if i is not None]
    asf = next((i for i in given if i.suffix.lower() == ".asf"), None)
    out = list(given)
    for i in given:
        out += [c for c in companions(i, asf=asf) if c not in out]
    return out


def unit_cm(motion: Motion, given: float | None) -> tuple[float, bool]:
    """Centimetres per file length unit: the user's value, else the file's (ASF), else 1 (assumed)."""
    if given is not None:
        return float(given), False
    u = motion.skeleton.meta.get("length_unit_cm")
    if u is not None:
        return float(u), False
    return 1.0, True


def load(path: str | Path, **options):
    """Read any supported file (or sensor folder) into its model object.

    Returns a :class:`~mocapkit.skeleton.Motion` for skeletal files (BVH, ASF/AMC and the other skeletal
    formats of :func:`kind_of`), a :class:`~mocapkit.markers.Markers` for marker files (C3D, TSV...), and
    ``{name: Signal}`` for IMU orientation files and sensor folders. ``options`` are passed to the reader:
    ``asf``, ``rate``, ``strict`` for skeletal files; ``rate`` and the column overrides for IMU files.
    """
    kind = kind_of(path)
    if kind == "skeletal":
        allowed = {"asf", "rate", "strict"}
        bad = sorted(set(options) - allowed)
        if bad:
            raise TypeError(f"load() of a skeletal file takes {sorted(allowed)}, not {bad}")
        return load_motion(path, **options)
    if kind == "markers":
        if options:
            raise TypeError(f"load() of a marker file takes no options, got {sorted(options)}")
        return load_markers(path)
    from mocapkit.io.imu.signals import load_signals

    register_opensim_readers()
    return load_signals(path, **options)


# --------------------------------------------------------------------------------------------------
# markers: read and write by suffix (and by content for .csv)
# --------------------------------------------------------------------------------------------------


def _marker_csv(path: Path) -> str | None:
    """``"vicon"`` for a Vicon Nexus CSV export, ``"wide"`` for the CSV of ``write_markers_csv``."""
    from mocapkit.io.markers.vicon_csv import is_vicon_csv

    if is_vicon_csv(path):
        return "vicon"
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            head = fh.readline(1 << 20).lstrip("\ufeff").strip()  # bounded: a file may hold no newline
    except OSError:
        return None
    cols = [re.sub(r"\s*\([^()]*\)$", "", c.strip().strip('"')).lower() for c in head.split(",")]  # drop "(mm)"
    if len(cols) >= 4 and cols[0] == "time" and (len(cols) - 1) % 3 == 0 and all(
            c.endswith("_" + "xyz"[k % 3]) for k, c in enumerate(cols[1:])):
        return "wide"
    return None


def load_markers(path: str | Path):
    """Read a marker file: ``.c3d`` (ezc3d), ``.tsv`` (Qualisys), ``.trc`` (OpenSim), ``.csv`` (a Vicon
    Nexus export when its first line is ``Trajectories``/``Devices``, else the wide CSV of
    :func:`mocapkit.io.markers.wide_csv.write_markers_csv`). Raises :class:`MocapFormatError` for a missing file, an
    unknown suffix or bad content."""
    p = Path(path)
    if not p.exists():
        raise MocapFormatError(str(p), None, "no such file")
    if p.is_dir():
        raise MocapFormatError(str(p), None, "is a folder, not a marker file")
    s = p.suffix.lower()
    if s == ".c3d":
        from mocapkit.io.markers.c3d import read_c3d

        return read_c3d(p)
    if s == ".tsv":
        from mocapkit.io.markers.qtm import read_qtm_tsv

        return read_qtm_tsv(p)
    if s == ".trc":
        from mocapkit.io.markers.opensim import read_trc

        return read_trc(p)
    if s == ".csv":
        if _marker_csv(p) == "vicon":
            from mocapkit.io.markers.vicon_csv import read_vicon_csv

            return read_vicon_csv(p)
        from mocapkit.io.markers.wide_csv import read_markers_csv

        return read_markers_csv(p)
    raise MocapFormatError(str(p), None, f"unknown marker file suffix {p.suffix!r}; expected one of "
                           ".c3d, .csv, .trc, .tsv")


MARKER_WRITE_SUFFIXES = (".c3d", ".csv", ".trc")


def write_markers(markers, path: str | Path, *, analog: bool = True) -> None:
    """Write markers by suffix: ``.c3d`` (ezc3d, float32; ``analog`` channels too when True), ``.trc``
    (OpenSim) or ``.csv`` (the wide CSV). Labels, rate, units and missing samples are kept."""
    from mocapkit.errors import InvalidParameterError

    s = Path(path).suffix.lower()
    if s == ".c3d":
        from mocapkit.io.markers.c3d import write_c3d

        write_c3d(markers, path, analog=analog)
    elif s == ".trc":
        from mocapkit.io.markers.opensim import write_trc

        write_trc(markers, path)
    elif s == ".csv":
        from mocapkit.io.markers.wide_csv import write_markers_csv

        write_markers_csv(markers, path)
    else:
        raise InvalidParameterError(f"{path}: markers are written to {', '.join(MARKER_WRITE_SUFFIXES)}")


def _read_opensim_signals(path, *, rate=None):
    from mocapkit.io.markers.opensim import read_opensim_signals

    return read_opensim_signals(path, rate=rate)


def register_opensim_readers() -> None:
    """Put the OpenSim table reader in :data:`mocapkit.io.imu.signals.READERS` for ``.sto``/``.mot``. Called
    on first use, not on import (that would load the IMU readers): by :func:`load` and by the names
    :mod:`mocapkit.io` takes from ``io.imu.signals``."""
    from mocapkit.io.imu.signals import READERS, register_reader

    for suffix in TABLE_SUFFIXES:
        if suffix not in READERS:
            register_reader(suffix, _read_opensim_signals)
