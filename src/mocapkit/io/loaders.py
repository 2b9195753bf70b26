"""What kind of file is this, and load it: skeletal motion (BVH, ASF/AMC), markers (C3D, Qualisys
TSV) or IMU orientation streams (CSV/text exports)."""

from __future__ import annotations

from pathlib import Path

from mocapkit.errors import MocapFormatError
from mocapkit.skeleton import Motion

SKELETAL_SUFFIXES = (".bvh", ".amc")
MARKER_SUFFIXES = (".c3d", ".tsv")


def kind_of(path: str | Path) -> str:
    """``"skeletal"``, ``"markers"`` or ``"imu"`` (folders and everything else are IMU data)."""
    p = Path(path)
    if p.is_file() or not p.exists():
        s = p.suffix.lower()
        if s in SKELETAL_SUFFIXES:
            return "skeletal"
        if s in MARKER_SUFFIXES:
            return "markers"
    return "imu"


def load_motion(path: str | Path, asf: str | Path | None = None, rate: float | None = None, strict: bool = True) -> Motion:
    """Read a BVH file, or an AMC file with its ASF skeleton (``asf``, or ``<stem>.asf`` /
    ``<subject>.asf`` beside it, CMU naming)."""
    p = Path(path)
    if not p.exists():
        raise MocapFormatError(str(p), None, "no such file")
    s = p.suffix.lower()
    if s == ".bvh":
        from mocapkit.io.bvh import read_bvh

        if rate is not None:
            raise MocapFormatError(str(p), None, "a BVH file has its own Frame Time; do not give --rate")
        return read_bvh(p, strict=strict)
    if s == ".amc":
        from mocapkit.io.amc import load_amc_for_cli

        return load_amc_for_cli(p, asf=asf, rate=rate)
    raise MocapFormatError(str(p), None, f"not a skeletal motion file (expected {', '.join(SKELETAL_SUFFIXES)})")


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
        from mocapkit.markers import load_markers

        if options:
            raise TypeError(f"load() of a marker file takes no options, got {sorted(options)}")
        return load_markers(path)
    from mocapkit.io.imucsv import load_signals

    return load_signals(path, **options)
