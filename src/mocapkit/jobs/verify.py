"""The ``verify`` job: an original recording against any file mocapkit wrote from it, on every sample.

The compressed file is decoded on its own documented path — IMU points (the ``time,w,x,y,z`` CSV of
``compress``, the ``time,w,x,y,z,tick,gap_before`` CSV of ``decompress X.mkp``, or a ``.mkp`` file) by SLERP
at every sample of the original, never across a lost packet; skeletons (``.mkc``, ``.glb``/``.gltf``, a
decoded ``.bvh``) by their readers — and compared by :mod:`mocapkit.verify`'s own SLERP, angle and forward
kinematics. A bound (``max_angle`` deg for IMU data, ``max_position_error`` cm for skeletons) is checked;
the record says where the largest error is. Nothing is written.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mocapkit.errors import InvalidParameterError, MocapFormatError
from mocapkit.jobs.common import Progress, imu_columns, no_progress, recording

#: relative slack of a bound (rounding of two float64 computations of the same decode)
BOUND_TOL = 1e-9
#: the header of the points CSV ``mocapkit decompress X.mkp -o POINTS.csv`` writes
TICK_POINTS_HEADER = ("time", "w", "x", "y", "z", "tick", "gap_before")
#: what a skeletal bound is checked on: every joint (the guarantee of ``compress --max-position-error``), every
#: joint and End Site, or ACL's shell metric; the record holds all three
METRICS = {"joint+end": "positions", "joint": "joint_positions", "shell": "shell"}
#: suffixes of the skeletal files ``verify`` decodes
SKELETAL_OUTPUTS = (".mkc", ".glb", ".gltf", ".bvh")


def check_options(max_angle=None, max_position_error=None, error_metric="joint+end", shell_distance=3.0,
                  skeletal_format=None) -> None:
    """The checks that need no file: bounds in range (both may be given: each bounds its kind, as in a
    mixed batch), a known metric, a positive shell distance."""
    if skeletal_format not in (None, "glb", "mkc"):
        raise InvalidParameterError(f"--skeletal-format {skeletal_format!r}: glb or mkc")
    for name, v, lo, hi in (("--max-angle", max_angle, 0.0, 180.0), ("--max-position-error", max_position_error,
                                                                      0.0, 1e9)):
        if v is not None and not (math.isfinite(v) and lo < v <= hi):
            raise InvalidParameterError(f"{name} {v!r}: a positive number up to {hi:g}")
    if error_metric not in METRICS:
        raise InvalidParameterError(f"--error-metric {error_metric!r}: one of {', '.join(METRICS)}")
    if not (math.isfinite(shell_distance) and shell_distance > 0):
        raise InvalidParameterError(f"--shell-distance {shell_distance!r}: a positive number of cm")


def verify_job(path: Path, output: Path | None = None, *, compressed: Path | None = None,
               max_angle: float | None = None, max_position_error: float | None = None, error_metric: str = "joint+end",
               shell_distance: float = 3.0, unit_cm: float | None = None, asf: Path | None = None,
               rate: float | None = None, strict: bool = True, time_column: str | None = None,
               quaternion_columns: str | None = None, scalar_last: bool = False, time_unit: str | None = None,
               compressed_dir: str | None = None, out: str | None = None, skeletal_format: str | None = None,
               progress: Progress = no_progress) -> dict:
    """Compare the original ``path`` with ``compressed`` (in a batch: ``output``, the file
    :func:`mocapkit.jobs.batch_output` found under ``compressed_dir``) and return the record.

    ``max_angle`` (deg) bounds IMU data, ``max_position_error`` (cm) skeletons in ``error_metric`` ``"joint"``
    (every joint), ``"joint+end"`` (every joint and End Site, the default: what ``compress`` bounds) or
    ``"shell"`` (ACL's: points ``shell_distance`` cm along each joint's axes).
    ``unit_cm``, ``asf``, ``rate``, ``strict`` and the IMU column options are those of the original's reader.
    """
    from mocapkit.io.loaders import kind_of

    check_options(max_angle, max_position_error, error_metric, shell_distance, skeletal_format)
    path = Path(path)
    given = compressed if compressed is not None else output
    compressed = Path(given) if given is not None and (compressed or output) else None
    if compressed is None:
        raise InvalidParameterError(f"{path}: give the compressed file to verify")
    if not compressed.exists():
        raise MocapFormatError(str(compressed), None, "no such file")
    kind = kind_of(path)
    with progress(f"verifying {compressed.name}", None):
        if kind == "skeletal":
            if max_angle is not None and max_position_error is None:
                raise InvalidParameterError("--max-angle is a bound for IMU data; "
                                            "skeletons take --max-position-error CM")
            return _skeletal(path, compressed, max_position_error, error_metric, shell_distance, unit_cm, asf, rate,
                             strict)
        if kind != "imu":
            raise InvalidParameterError(f"{path}: verify reads IMU data and skeletons (BVH, AMC, MVNX); this is "
                                        f"{'a marker file' if kind == 'markers' else 'a table'}")
        if max_position_error is not None and max_angle is None:
            raise InvalidParameterError("--max-position-error is a bound for skeletons; IMU data takes --max-angle DEG")
        return _imu(path, compressed, max_angle, rate, imu_columns(time_column, quaternion_columns, scalar_last,
                                                                   time_unit))


def _within(value: float | None, bound: float | None) -> bool | None:
    if bound is None or value is None:
        return None
    return bool(value <= bound * (1 + BOUND_TOL))


# ---- IMU -----------------------------------------------------------------------------------------------

class _Points:
    """One sensor's compressed points: placed at sample indices (``ticks``) or at times."""

    def __init__(self, name, values, *, ticks=None, times=None, gap_before=None, t0=None, rate=None, samples=None):
        self.name, self.values, self.ticks, self.times = name, np.asarray(values, dtype=np.float64), ticks, times
        self.gap_before, self.t0, self.rate, self.samples = gap_before, t0, rate, samples


def _is_tick_csv(path: Path) -> bool:
    with open(path, "rb") as fh:
        head = fh.readline(256).decode("utf-8", "replace").strip()
    return tuple(c.strip() for c in head.split(",")) == TICK_POINTS_HEADER


def _read_points_csv(path: Path, name: str) -> _Points:
    """A points CSV: of ``decompress X.mkp`` (ticks, lost-packet marks) or of ``compress`` (times)."""
    if _is_tick_csv(path):
        from mocapkit.io.text.timetable import read_time_table

        tab = read_time_table(path, "points CSV")
        col = {c: tab.values[:, k] for k, c in enumerate(tab.columns)}
        if np.isnan(tab.values).any():
            raise MocapFormatError(str(path), None, "a points CSV has no missing values")
        ticks = col["tick"]
        if np.any(ticks != np.round(ticks)) or np.any(np.diff(ticks) <= 0) or (len(ticks) and ticks[0] < 0):
            raise MocapFormatError(str(path), None, "the tick column must hold increasing whole sample indices")
        q = np.column_stack([col["w"], col["x"], col["y"], col["z"]])
        return _Points(name, q, ticks=ticks, times=tab.times, gap_before=col["gap_before"] != 0)
    from mocapkit.io import read_imu_csv

    sig = read_imu_csv(path)
    if sig.kind != "quaternion":
        raise MocapFormatError(str(path), None, "holds no orientations (expected segment points time,w,x,y,z)")
    return _Points(name, sig.values, times=sig.times)


def _read_compressed_imu(compressed: Path, names: list[str]) -> tuple[dict[str, _Points], str, list[str]]:
    """``({sensor: points}, format, warnings)`` of a ``.mkp`` file, a points CSV or a folder of them."""
    if compressed.suffix.lower() == ".mkp":
        from mocapkit.jobs.readers import read_mkp

        pf = read_mkp(compressed)
        return ({n: _Points(n, s.values, ticks=s.ticks.astype(np.float64), gap_before=s.gap_before, t0=s.sensor.t0,
                            rate=s.sensor.rate, samples=s.samples) for n, s in pf.streams.items()}, "mkp", pf.losses())
    if compressed.is_dir():  # one CSV per sensor, named after it (never a path made from a sensor name)
        files = {f.stem: f for f in sorted(compressed.iterdir()) if f.suffix.lower() == ".csv" and f.is_file()}
        if not files:
            raise MocapFormatError(str(compressed), None, "no points CSV (<sensor>.csv) in this folder")
        return {n: _read_points_csv(f, n) for n, f in files.items()}, "points_csv", []
    if compressed.suffix.lower() != ".csv":
        raise InvalidParameterError(f"{compressed}: compressed IMU data is a points CSV, a folder of them or a .mkp "
                                    "file")
    if len(names) != 1:
        raise InvalidParameterError(f"{compressed}: one points CSV, but the original holds {len(names)} sensors "
                                    f"({', '.join(names[:6])}): give the folder of one CSV per sensor")
    return {names[0]: _read_points_csv(compressed, names[0])}, "points_csv", []


def _decode_sensor(pts: _Points, sig, where: Path, original: Path) -> np.ndarray:
    """``(n, 4)`` decode at every sample of ``sig`` (NaN rows: left out, a lost packet or past the stream);
    points of another recording are refused."""
    from mocapkit.verify.compare import decode_runs

    n, times = len(sig), sig.times
    step = float(np.median(np.diff(times))) if n > 1 else 0.0
    if len(pts.values) == 0:
        return np.full((n, 4), np.nan)
    if pts.ticks is not None:  # tick k = sample k of the original
        if pts.samples is not None and pts.samples != n:
            raise InvalidParameterError(f"{where}: {pts.name} has {pts.samples} samples, {original} {n}: not a "
                                        "compression of this file")
        if pts.ticks[-1] >= n:
            raise InvalidParameterError(f"{where}: {pts.name} reaches sample {int(pts.ticks[-1])}, {original} has {n}: "
                                        "not a compression of this file")
        k = int(pts.ticks[0])
        t_file = float(pts.times[0]) if pts.times is not None else pts.t0 + k / pts.rate
        if abs(t_file - float(times[k])) > max(step / 2, 1e-6):
            raise InvalidParameterError(f"{where}: {pts.name}'s sample {k} is at {t_file:.6g} s, in {original} at "
                                        f"{float(times[k]):.6g} s: not a compression of this file")
        return decode_runs(np.arange(n, dtype=np.float64), pts.ticks, pts.values, pts.gap_before)
    pt = np.asarray(pts.times, dtype=np.float64)
    slack = 1e-9 * max(1.0, abs(float(times[0])), abs(float(times[-1])))
    if pt[0] - slack > times[0] or pt[-1] + slack < times[-1]:
        raise InvalidParameterError(f"{where}: {pts.name}'s points span {pt[0]:.9g}..{pt[-1]:.9g} s, {original}'s "
                                    f"samples {float(times[0]):.9g}..{float(times[-1]):.9g} s: not a compression of "
                                    "this file")
    at = np.clip(times, pt[0], pt[-1])
    return decode_runs(at, pt, pts.values)


def _imu(path: Path, compressed: Path, max_angle, rate, columns) -> dict:
    from mocapkit.io import load_signals
    from mocapkit.verify.compare import compare_imu

    signals = load_signals(path, rate=rate, **columns)
    for name, sig in signals.items():
        if sig.kind != "quaternion":
            raise InvalidParameterError(f"{sig.source}: {name} holds no orientations")
    points, fmt, warnings = _read_compressed_imu(compressed, list(signals))
    missing, extra = [n for n in signals if n not in points], [n for n in points if n not in signals]
    if missing or extra:
        raise InvalidParameterError(
            f"{compressed}: its sensors ({', '.join(list(points)[:6])}) are not those of {path} "
            f"({', '.join(list(signals)[:6])}): " + (f"no points of {', '.join(missing[:6])}" if missing else
                                                     f"{', '.join(extra[:6])} not in the original"))
    sensors = []
    for name, sig in signals.items():
        cmp = compare_imu(name, sig.times, sig.values, _decode_sensor(points[name], sig, compressed, path))
        sensors.append((cmp, cmp.summary()))
    compared = sum(s["compared_samples"] for _, s in sensors)
    if compared == 0:
        raise InvalidParameterError(f"{compressed}: no sample of {path} could be decoded (every packet lost?)")
    worst_cmp, worst = max(((c, s) for c, s in sensors if s["max_deg"] is not None), key=lambda x: x[1]["max_deg"])
    total = sum(float(np.nansum(c.errors_deg)) for c, _ in sensors)
    left_out = sum(s["samples_not_decoded"] for _, s in sensors)
    if left_out:
        warnings.append(f"{compressed}: {left_out} samples not decoded (a lost packet or a stream cut short): "
                        "not compared")
    for sig in signals.values():
        warnings += [f"{sig.source}: {w}" for w in sig.meta.get("warnings", []) if f"{sig.source}: {w}" not in warnings]
    return {"job": "verify", "file": str(path), "compressed": str(compressed), "kind": "imu", "format": fmt,
            "metric": "angle", "error_unit": "deg", "max_error": worst["max_deg"], "mean_error": total / compared,
            "where": {"sensor": worst_cmp.name, **worst["max_at"]}, "bound": max_angle,
            "bound_unit": "deg" if max_angle is not None else None,
            "within_bound": _within(worst["max_deg"], max_angle), "compared_samples": compared,
            "samples_not_decoded": left_out, "sensors": [s for _, s in sensors], "warnings": warnings,
            "outputs": [], "recording": recording(signals, path)}


# ---- skeletons -----------------------------------------------------------------------------------------

def _read_decoded(compressed: Path, strict: bool):
    suffix = compressed.suffix.lower()
    if suffix not in SKELETAL_OUTPUTS:
        raise InvalidParameterError(f"{compressed}: a compressed skeleton is .mkc, .glb, .gltf or a decoded .bvh")
    if suffix == ".mkc":
        from mocapkit.jobs.readers import read_mkc

        return read_mkc(compressed)
    if suffix in (".glb", ".gltf"):
        from mocapkit.io.formats.gltf import read_gltf

        return read_gltf(compressed)
    from mocapkit.io.skeletal.bvh import read_bvh

    return read_bvh(compressed, strict=strict)


def _same_shape(a, b, path: Path, compressed: Path) -> None:
    """Refuse a decode of another skeleton or of another number of frames (or other frame times)."""
    sa, sb = a.skeleton, b.skeleton
    if list(sa.names) != list(sb.names):
        k = next((i for i, (x, y) in enumerate(zip(sa.names, sb.names, strict=False)) if x != y),
                 min(sa.n_joints, sb.n_joints))
        what = (f"joint {k} is {sa.names[k]!r} in {path}, {sb.names[k]!r} in {compressed}"
                if k < min(sa.n_joints, sb.n_joints)
                else f"{sa.n_joints} joints in {path}, {sb.n_joints} in {compressed}")
        raise InvalidParameterError(f"{compressed}: not a decode of {path}'s skeleton ({what})")
    if not np.array_equal(sa.parents, sb.parents):
        k = int(np.flatnonzero(sa.parents != sb.parents)[0])
        raise InvalidParameterError(f"{compressed}: not a decode of {path}'s skeleton (joint {sa.names[k]!r} hangs "
                                    "from another parent)")
    if [int(j) for j, _ in sa.end_sites] != [int(j) for j, _ in sb.end_sites]:
        raise InvalidParameterError(f"{compressed}: not a decode of {path}'s skeleton ({len(sa.end_sites)} End Sites "
                                    f"in {path}, {len(sb.end_sites)} in {compressed}, or on other joints)")
    if a.n_frames != b.n_frames:
        raise InvalidParameterError(f"{compressed}: {b.n_frames} frames, {path} {a.n_frames}: not a decode of it")
    step = float(np.median(np.diff(a.times))) if a.n_frames > 1 else 1.0
    dt = np.abs(a.times - b.times)
    # a BVH writes its Frame Time to ~7 digits: a decoded BVH's times drift by that rounding (1e-6 relative)
    slack = np.maximum(1e-3 * step, 1e-9) + 1e-6 * np.abs(a.times - a.times[0]) if a.n_frames else 0.0
    if a.n_frames and (dt > slack).any():
        k = int(np.argmax(dt - slack))
        raise InvalidParameterError(f"{compressed}: frame {k} is at {float(b.times[k]):.9g} s, in {path} at "
                                    f"{float(a.times[k]):.9g} s: not a decode of it")


def _skeletal(path, compressed, bound, metric, shell_distance, unit_cm, asf, rate, strict) -> dict:
    from mocapkit.io.loaders import load_motion
    from mocapkit.verify.compare import compare_skeletal

    original = load_motion(path, asf=asf, rate=rate, strict=strict)
    decoded = _read_decoded(compressed, strict)
    _same_shape(original, decoded, path, compressed)
    warnings = list(original.meta.get("warnings", []))
    known = original.skeleton.meta.get("length_unit_cm")
    declared = decoded.skeleton.meta.get("length_unit_cm")
    # both hold lengths in the original's file unit (the readers undo the unit a writer applied): one
    # unit converts both to cm — the user's, else the original's, else the one the decode declares
    unit = unit_cm if unit_cm is not None else known if known is not None else declared
    assumed = unit is None
    if assumed:
        unit = 1.0
        warnings.append(f"{path}: no length unit in the file; 1 unit = 1 cm assumed (give --unit-cm)")
    elif unit_cm is None and known is not None and declared is not None and not math.isclose(known, declared,
                                                                                              rel_tol=1e-9):
        warnings.append(f"{compressed} declares {declared:g} cm per unit, {path} {known:g}: compared in {path}'s")
    cmp = compare_skeletal(original, decoded, float(unit), shell_distance)
    s = cmp.summary()
    s = {"positions": s["positions"], "joint_positions": s["joints"], "end_site_positions": s["end_sites"],
         "shell": s["shell"]}
    chosen = s[METRICS[metric]]
    if bound is not None and metric == "joint" and not _within(s["end_site_positions"]["max_cm"], bound) \
            and s["end_site_positions"]["max_cm"] is not None:
        at = s["end_site_positions"]["max_at"]
        warnings.append(f"{compressed}: End Sites are not within {bound:g} cm (the bound covers joints): "
                        f"{at['point']} is {s['end_site_positions']['max_cm']:.4g} cm off at frame {at['frame']} "
                        "(--error-metric joint+end checks them)")
    return {"job": "verify", "file": str(path), "compressed": str(compressed), "kind": "skeletal",
            "format": compressed.suffix.lower()[1:], "metric": metric,
            "error_unit": "cm", "max_error": chosen["max_cm"], "mean_error": chosen["mean_cm"],
            "where": chosen["max_at"], "bound": bound, "bound_unit": "cm" if bound is not None else None,
            "within_bound": _within(chosen["max_cm"], bound), "unit_cm": float(unit), "unit_cm_assumed": assumed,
            "frames": original.n_frames, "joints": original.skeleton.n_joints,
            "end_sites": len(original.skeleton.end_sites), **s, "warnings": warnings,
            "outputs": [], "recording": recording(original, path)}


# ---- in a batch ----------------------------------------------------------------------------------------

#: what a ``compress`` batch writes for an input, by kind (``jobs.batch_output``)
COMPRESSED_SUFFIXES = {"imu": (".points",), "skeletal": (".glb", ".mkc")}


def compressed_output(path: Path, options: dict, base: Path) -> Path:
    """The output a ``mocapkit batch compress ... --out COMPRESSED_DIR`` wrote for ``path``: ``base`` is
    ``OUT/<relative dir>/<stem>`` of this batch (``options["out"]``), so the same relative place under
    ``options["compressed_dir"]`` with the suffix of its kind (``.points`` folder; ``.glb`` or ``.mkc``,
    ``options["skeletal_format"]`` choosing when both are there)."""
    from mocapkit.io.loaders import kind_of

    out, root = options.get("out"), options.get("compressed_dir")
    if not out or not root:
        raise InvalidParameterError("a batch verify needs the folder of the compressed outputs (--compressed DIR)")
    rel = Path(base).relative_to(Path(out))
    stem = Path(root) / rel
    fmt = options.get("skeletal_format")
    wanted = (f".{fmt}",) if fmt and kind_of(path) == "skeletal" else COMPRESSED_SUFFIXES.get(kind_of(path), ())
    found = [stem.with_name(stem.name + s) for s in wanted if stem.with_name(stem.name + s).exists()]
    if not found:
        looked = ", ".join(stem.name + s for s in wanted) or "nothing: not IMU data or a skeleton"
        raise InvalidParameterError(f"{path}: no compressed output under {root} (looked for {looked} in {stem.parent})")
    if len(found) > 1:
        raise InvalidParameterError(f"{path}: both {' and '.join(f.name for f in found)} under {stem.parent}: give "
                                    "--skeletal-format glb|mkc")
    return found[0]
