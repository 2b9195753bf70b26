"""The scene ``mocapkit view`` serves and ``--export`` renders: every file named on the command line read
into one JSON-able dict (schema: docs/viewer.md). Skeletons with the joints of an earlier skeleton are
its decode (error per joint); a ``.mkp`` or points CSV after an IMU file is its compressed points."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mocapkit.errors import InvalidParameterError, MocapFormatError
from mocapkit.view import imu_panel as imu
from mocapkit.view.arrays import decode_array, encode_array
from mocapkit.view.marker_panel import fitted_positions, marker_panel, read_filter_json
from mocapkit.view.skeleton_panel import (
    GLTF_SUFFIXES,
    joint_errors,
    load_skeleton,
    same_skeleton,
    skeleton_panel,
    up_axis,
    world_positions,
)

SCHEMA_VERSION = 1


def file_kind(path: Path) -> str:
    """``skeleton``, ``markers``, ``imu``, ``packets`` (``.mkp``) or ``points`` (a points CSV)."""
    from mocapkit.io.loaders import kind_of

    s = path.suffix.lower()
    if not path.exists():
        raise MocapFormatError(str(path), None, "no such file")
    if s == ".mkp":
        return "packets"
    if s in GLTF_SUFFIXES:
        return "skeleton"
    if imu.is_points_csv(path):
        return "points"
    kind = kind_of(path)
    if kind == "table":
        raise InvalidParameterError(f"{path}: a table of values (joint angles...) has nothing to draw in 3-D; "
                                    "the viewer shows skeletons, IMU orientations and markers")
    return {"skeletal": "skeleton"}.get(kind, kind)


def read_segments(path: Path) -> dict:
    """The cuts and segments of a ``segment --json`` output, checked."""
    from mocapkit.view.json_input import read_json

    rec = read_json(path, "segments JSON")
    if not isinstance(rec, dict) or rec.get("job") != "segment" or not isinstance(rec.get("segments"), list):
        raise MocapFormatError(str(path), None, "expected the output of `mocapkit segment --json` (a record with "
                               "job \"segment\", cuts and segments)")
    try:
        cuts = [{"frame": int(c["frame"]), "time_s": float(c["time_s"])} for c in rec.get("cuts", [])]
        segs = [{"t0": float(s["t0"]), "t1": float(s["t1"]), "frame0": int(s["frame0"]), "frame1": int(s["frame1"]),
                 "label": None if s.get("label") is None else str(s["label"]),
                 "action": None if s.get("action") is None else str(s["action"])} for s in rec["segments"]]
        n_frames = int(rec["n_frames"])
    except (KeyError, TypeError, ValueError, OverflowError) as e:
        raise MocapFormatError(str(path), None, f"a cut or segment lacks a field or a number ({e})") from None
    return {"file": str(rec.get("file", "")), "method": rec.get("method"), "n_frames": n_frames,
            "rate_hz": rec.get("rate_hz"), "cuts": cuts, "segments": segs}


def _place_segments(seg: dict, where: Path, timeline: np.ndarray) -> dict:
    """The segments on the timeline: frames index the timeline when the counts agree, else refused."""
    if seg["n_frames"] != len(timeline):
        raise InvalidParameterError(f"{where}: the segmentation is of {seg['n_frames']} frames "
                                    f"({Path(seg['file']).name or 'its file'}), the first file has {len(timeline)}: "
                                    "give the file that was segmented first")
    n = len(timeline)
    for c in seg["cuts"]:
        if not 0 <= c["frame"] < n:
            raise MocapFormatError(str(where), None, f"cut at frame {c['frame']}: outside frames 0..{n - 1}")
    for s in seg["segments"]:
        if not 0 <= s["frame0"] < s["frame1"] <= n:
            raise MocapFormatError(str(where), None, f"segment of frames {s['frame0']}..{s['frame1']}: not a "
                                   f"range within 0..{n} (frame1 excluded)")
    for c in seg["cuts"]:
        c["time_s"] = float(timeline[min(c["frame"], len(timeline) - 1)])
    for s in seg["segments"]:
        s["t0"] = float(timeline[min(s["frame0"], len(timeline) - 1)])
        s["t1"] = float(timeline[min(max(s["frame1"] - 1, 0), len(timeline) - 1)])
    return seg


def _height_hint(pos: np.ndarray, up: str) -> str:
    """A hint when a skeleton drawn with 1 unit = 1 cm is no person's height (first frame, 50 to 250 cm)."""
    if pos.size == 0:
        return ""
    h = float(np.ptp(pos[0, :, "xyz".index(up)]))
    if 50 <= h <= 250 or h == 0:
        return ""
    return f"; it would be {h:.3g} cm tall: give --unit-cm (2.54 for inches, 100 for metres)"


def _check_pairing(path: Path, opath: Path, name: str, pts, times: np.ndarray) -> None:
    """Refuse compressed points that are not of this recording: a stream of another length (when the
    file says), a tick beyond the last sample, or a first point whose time is not that sample's."""
    n = len(times)
    if pts.samples is not None and pts.samples != n:
        raise InvalidParameterError(f"{path}: its stream {name} has {pts.samples} samples, {opath} has {n}: "
                                    "not a compression of this file")
    if len(pts.ticks) == 0:
        return
    if pts.ticks[-1] >= n:
        raise InvalidParameterError(f"{path}: {name} reaches sample {int(pts.ticks[-1])}, {opath} has "
                                    f"{n}: not a compression of this file")
    k = int(pts.ticks[0])
    t_file, t_orig = float(pts.own_times(pts.ticks[:1])[0]), float(times[k])
    step = float(np.median(np.diff(times))) if n > 1 else 0.0
    if abs(t_file - t_orig) > max(step / 2, 1e-6):
        raise InvalidParameterError(f"{path}: {name}'s sample {k} is at {t_file:.6g} s, in {opath} at {t_orig:.6g} s: "
                                    "not a compression of this file")


class _Builder:
    def __init__(self, asf, unit_cm, strict, rate, columns):
        self.asf, self.unit_cm, self.strict, self.rate = asf, unit_cm, strict, rate
        self.columns = {k: v for k, v in (columns or {}).items() if v is not None and v is not False}
        self.panels: list[dict] = []
        self.notes: list[str] = []
        # originals: id, path, motion, unit (cm), positions in file units (forward kinematics done once)
        self.skeletons: list[tuple[str, Path, object, float, np.ndarray]] = []
        self.imus: list[tuple[str, Path, dict]] = []                        # originals: id, path, signals
        self.paired: set[str] = set()                                        # IMU panels holding a decode
        self.assumed: set[str] = set()                                       # skeletons of no known unit

    def pid(self) -> str:
        return f"p{len(self.panels)}"

    def skeleton(self, path: Path) -> None:
        amc = path.suffix.lower() == ".amc"
        motion, unit, bound = load_skeleton(path, self.asf if amc else None, self.strict, self.rate if amc else None)
        orig = next((o for o in reversed(self.skeletons) if same_skeleton(o[2], motion)), None)
        if orig is None:
            u = self.unit_cm or unit or 1.0
            fk = world_positions(motion, 1.0)
            pos = fk * u
            if self.unit_cm is None and unit is None:
                self.notes.append(f"{path.name}: no length unit in the file; 1 unit = 1 cm assumed (--unit-cm)"
                                  + _height_hint(pos, up_axis(motion)))
            pid = self.pid()
            if self.unit_cm is None and unit is None:
                self.assumed.add(pid)
            self.skeletons.append((pid, path, motion, u, fk))
            self.panels.append(skeleton_panel(pid, path, motion, pos, bound=bound))
            return
        opid, opath, omotion, ou, ofk = orig
        # one unit for both (their lengths are the same file units): the original's, unless it was assumed and
        # the decode knows it; a bound follows the unit the decode is drawn in
        if opid in self.assumed and unit is not None and unit != ou:
            self.notes = [n for n in self.notes if not n.startswith(f"{opath.name}: no length unit")]
            self.notes.append(f"{opath.name}: no length unit in the file; drawn in the unit of {path.name} "
                              f"({unit:g} cm), which it decodes")
            ou = unit
            self.assumed.discard(opid)
            self._rescale(opid, ou)
        elif unit is not None and unit != ou and self.unit_cm is None:
            self.notes.append(f"{path.name}: its unit ({unit:g} cm) differs from {opath.name}'s ({ou:g} cm); both are "
                              f"drawn in {opath.name}'s")
        if bound is not None and unit is not None and unit != ou:
            bound = bound / unit * ou
        u = ou
        pos = world_positions(motion, u)
        err = None
        if motion.n_frames == omotion.n_frames and np.allclose(motion.times, omotion.times, atol=1e-6, rtol=0):
            err = joint_errors(ofk * ou, pos)
        else:
            self.notes.append(f"{path.name}: {motion.n_frames} frames, {opath.name} {omotion.n_frames}: "
                              "no error per joint (the frames differ)")
        self.panels.append(skeleton_panel(self.pid(), path, motion, pos, role="decoded", decoded_from=opid,
                                          error=err, bound=bound, up=up_axis(omotion)))  # a clip keeps no axis

    def _rescale(self, pid: str, unit: float) -> None:
        fk = next(f for i, *_, f in self.skeletons if i == pid)
        for k, p in enumerate(self.panels):
            if p["id"] == pid:
                self.panels[k]["positions"] = encode_array(fk * unit)
        self.skeletons = [(i, pa, m, unit if i == pid else u, f) for i, pa, m, u, f in self.skeletons]

    def imu_file(self, path: Path) -> None:
        from mocapkit.io import load_signals

        if imu.is_compress_points(path) and self.imus:  # `compress -o` points: own times, no reading options
            signals = load_signals(path)
            _, opath, osigs = self.imus[-1]
            if len(signals) == 1 and len(osigs) == 1:
                pts = imu.points_of(next(iter(signals.values())), next(iter(osigs.values())).times)
                if pts is not None:
                    self.notes.append(f"{path.name}: {len(pts.ticks)} samples of {opath.name} at their times: drawn as "
                                      "its compression's points (decoded by SLERP)")
                    self.compressed(path, "points", {path.stem: pts})
                    return
        else:
            signals = load_signals(path, rate=self.rate, **self.columns)
        pid = self.pid()
        sensors = []
        for name, sig in signals.items():
            if sig.kind != "quaternion":
                raise InvalidParameterError(f"{path}: {name} holds no orientations")
            sensors.append(imu.sensor_entry(name, sig.times, sig.values, None, [], None))
        self.imus.append((pid, path, signals))
        self.panels.append(imu.imu_panel(pid, path, sensors, next(iter(signals.values())).times))

    def compressed(self, path: Path, kind: str, points: dict | None = None) -> None:
        if points is None:
            points, losses = imu.read_packets(path) if kind == "packets" else imu.read_points_csv(path)
            self.notes.extend(losses)
        orig = self.imus[-1] if self.imus else None
        if orig is not None:
            opid, opath, signals = orig
            names = list(points)
            if kind == "points" and len(points) == 1 and len(signals) == 1:
                points = {next(iter(signals)): next(iter(points.values()))}
            elif not set(points) & set(signals):
                raise InvalidParameterError(f"{path}: its sensors ({', '.join(names)}) are not those of {opath} "
                                            f"({', '.join(signals)}): give the original IMU file before it")
            panel = next(p for p in self.panels if p["id"] == opid)
            if opid in self.paired:  # a second compression of the same file: a panel of its own
                panel = {**panel, "id": self.pid(), "file": str(opath),
                         "name": opath.name, "sensors": [imu.sensor_entry(n, s.times, s.values, None, [], None)
                                                         for n, s in signals.items()]}
                self.panels.append(panel)
            self.paired.add(opid)
            by_name = {s["name"]: k for k, s in enumerate(panel["sensors"])}
            for name in signals:
                if name not in points:
                    self.notes.append(
                        f"{path.name}: no points of sensor {name} of {opath.name}; its decode is not drawn"
                    )
            for name, pts in points.items():
                if name not in signals:
                    self.notes.append(f"{path.name}: sensor {name} is not in {opath.name}; not drawn")
                    continue
                sig = signals[name]
                _check_pairing(path, opath, name, pts, sig.times)
                _, dec, kt = imu.decode(pts, len(sig), sig.times)
                entry = imu.sensor_entry(name, sig.times, sig.values, dec, sig.times[kt.astype(np.int64)],
                                         pts.bound_deg)
                panel["sensors"][by_name[name]] = entry
            panel["file"] = f"{panel['file']} + {path}"
            panel["name"] = f"{panel['name']} + {path.name}"
            return
        pid, sensors, first = self.pid(), [], None
        for name, pts in points.items():
            u, dec, kt = imu.decode(pts, None)
            times = pts.own_times(u)
            first = times if first is None else first
            sensors.append(imu.sensor_entry(name, times, None, dec, pts.own_times(kt), pts.bound_deg))
        if first is None:
            raise MocapFormatError(str(path), None, "no sensor stream")
        self.panels.append(imu.imu_panel(pid, path, sensors, first))

    def markers(self, path: Path, filter_json: Path | None) -> None:
        from mocapkit.io.loaders import load_markers

        mk = load_markers(path)
        fitted: np.ndarray | None = None
        knots: list[dict[str, Any]] = []
        if filter_json is not None:
            fitted, knots = fitted_positions(mk, read_filter_json(filter_json), str(filter_json))
        self.panels.append(marker_panel(self.pid(), path, mk, fitted, knots))


def _is_compressed(path: Path, kind: str) -> bool:
    """A file that only a compression writes: a ``.mkc`` clip, a glTF, a ``.mkp``, a points CSV."""
    return kind in ("packets", "points") or path.suffix.lower() in (".mkc", *GLTF_SUFFIXES)


def build_scene(files, *, segments: Path | None = None, filter_json: Path | None = None, asf: Path | None = None,
                unit_cm: float | None = None, strict: bool = True, rate: float | None = None,
                columns: dict | None = None) -> dict:
    """Read ``files`` into the scene of docs/viewer.md: originals in the order given, then the compressed
    files (``.mkc``, glTF, ``.mkp``, points CSV), each paired with the original it decodes.

    ``segments``: a ``segment --json`` output of the first file (its cuts and labels go on the timeline);
    ``filter_json``: a ``filter --json`` output of the (first) marker file; ``asf`` and ``rate`` (Hz) for
    AMC files (CMU's 120 Hz when not given); ``rate`` and ``columns`` (``time_column``,
    ``quaternion_columns``, ``scalar_last``, ``time_unit``) read IMU files as ``compress`` does.
    """
    files = [Path(f) for f in files]
    if not files:
        raise InvalidParameterError("give at least one file to view")
    b = _Builder(asf, unit_cm, strict, rate, columns)
    fitted_for = None
    kinds = {path: file_kind(path) for path in files}
    # compressed files follow the originals they decode, whatever order they were given in
    files = sorted(files, key=lambda f: _is_compressed(f, kinds[f]))
    n_skeletons = sum(k == "skeleton" for k in kinds.values())
    for path in files:
        kind = kinds[path]
        if kind == "skeleton":
            before = len(b.skeletons)
            b.skeleton(path)
            if _is_compressed(path, kind) and len(b.skeletons) > before and n_skeletons > 1:
                b.notes.append(f"{path.name}: a compressed clip whose joints are those of no other file given: drawn "
                               "as an original (no error)")
        elif kind == "imu":
            b.imu_file(path)
        elif kind in ("packets", "points"):
            b.compressed(path, kind)
        else:
            b.markers(path, filter_json if fitted_for is None else None)
            fitted_for = path
    if filter_json is not None and fitted_for is None:
        raise InvalidParameterError(f"--filter {filter_json}: no marker file (C3D, TSV, TRC, marker CSV) to draw it on")
    first = b.panels[0]
    times = (decode_array(first["sensors"][0]["times"]) if first["kind"] == "imu" and first["sensors"]
             else decode_array(first["times"]))
    rate = float(1.0 / np.median(np.diff(times))) if len(times) > 1 else None
    seg = None
    if segments is not None:
        if first["kind"] != "skeleton":
            raise InvalidParameterError(f"--segments {segments}: cuts are drawn on a skeleton's timeline; "
                                        f"the first file, {files[0]}, is not a skeleton")
        seg = _place_segments(read_segments(segments), segments, times)
        if seg["file"] and Path(seg["file"]).name != files[0].name:
            b.notes.append(f"{segments.name}: a segmentation of {Path(seg['file']).name}, drawn on {files[0].name} "
                           "(same frame count)")
    return {"mocapkit_view": SCHEMA_VERSION, "title": " · ".join(p.name for p in files),
            "timeline": {"times": encode_array(times, "float64"), "frames": len(times), "rate_hz": rate,
                         "source": first["id"]},
            "segments": seg, "notes": b.notes, "panels": b.panels}
