"""What a recording is, for the catalog: format, rate, frames, duration, subject/take, channels.

:func:`describe` builds the ``"recording"`` dict of every job record (``/work/notes/records11.md``) from an
object a reader already returned; :func:`content_hash` identifies an input by its bytes.

Channels are named as BIDS-Motion's ``*_channels.tsv`` names them (columns ``name``, ``component``,
``type``, ``tracked_point``, ``units``; types ``POS``, ``ORNT``, ``JNTANG``, ``MISC``...; components
``x``/``y``/``z``, ``quat_w``/``quat_x``/``quat_y``/``quat_z`` or ``n/a``):

* skeletal motion with the file's channels: BVH gives one channel per file channel, in file order,
  named ``<joint>_<channel>`` (``Hips_Xposition``), ASF/AMC one per dof of the ASF (``root_tx``,
  ``lfemur_rx``; the bone-length dof ``l`` is ``MISC``); position channels are ``POS`` in the file's length unit
  (from ``Skeleton.meta["length_unit_cm"]``: 100 → ``m``, 1 → ``cm``, 0.1 → ``mm``, 2.54 → ``in``, any other
  known scale ``"<k> cm"``, unknown → ``n/a``), rotation channels ``ORNT`` in ``deg`` (``rad`` when an ASF
  says ``angle rad``). Skeletal motion without file channels (Xsens MVNX, glTF) gives each joint's
  orientation as ``ORNT`` ``quat_w..quat_z`` (units ``n/a``) and, for joints whose position the file
  animates, ``POS`` ``x/y/z``;
* IMU signals (``{sensor: Signal}``): a quaternion signal gives ``ORNT`` ``quat_w..quat_z`` (``n/a``)
  tracked at the sensor, any other signal ``MISC`` channels;
* markers: ``POS`` ``x/y/z`` per marker in the file's units (``mm``...);
* an OpenSim table (:func:`mocapkit.io.markers.opensim.read_table`): with ``in_degrees`` known, every column is a
  ``JNTANG`` in ``deg``/``rad`` except OpenSim's translational coordinates (names ending ``_tx``, ``_ty``,
  ``_tz``), which are ``POS`` in ``m`` (OpenSim works in S.I. units); otherwise ``MISC`` ``n/a``.

``subject``/``take`` are only what the file carries: the C3D ``SUBJECTS:NAMES`` parameter, the MVNX
``<subject label=...>``; for CMU-style file names ``<subject>_<take>`` in digits, whatever the format
(``86_01.amc``, ``07_02.csv``), they come from the **file name** (subject ``"86"``, take ``"01"``). Otherwise ``None``.
"""

from __future__ import annotations

import hashlib
import math
import os
import re
import stat
from pathlib import Path

from mocapkit.errors import MocapFormatError

CHUNK = 1 << 20

#: CMU's ``<subject>_<take>`` file names (its AMC, BVH and C3D files; labs name other formats alike)
_CMU_NAME = re.compile(r"^(\d+)_(\d+)$")
_UNITS_CM = {100.0: "m", 1.0: "cm", 0.1: "mm", 2.54: "in"}


def _channel(name: str, component: str, type_: str, tracked_point: str, units: str) -> dict:
    return {"name": name, "component": component, "type": type_, "tracked_point": tracked_point, "units": units}


def _length_unit(unit_cm) -> str:
    if unit_cm is None:
        return "n/a"
    u = float(unit_cm)
    for k, name in _UNITS_CM.items():
        if math.isclose(u, k, rel_tol=1e-9):
            return name
    return f"{u:.6g} cm"


def _quat_channels(point: str) -> list[dict]:
    return [_channel(f"{point}_quat_{c}", f"quat_{c}", "ORNT", point, "n/a") for c in "wxyz"]


def _skeletal(m) -> tuple[list[dict], str | None, str | None]:
    sk = m.skeleton
    length = _length_unit(sk.meta.get("length_unit_cm", m.meta.get("length_unit_cm")))
    angle = "rad" if str(m.meta.get("angle_unit", "deg")).lower().startswith("rad") else "deg"
    out = []
    asf = sk.meta.get("asf")
    if isinstance(asf, dict) and asf.get("bones") is not None:  # ASF/AMC: the file's channels are the dofs
        dofs = [("root", tuple(asf.get("root", {}).get("order", ())))]
        bone_order = asf["bone_order"] if "bone_order" in asf else asf["bones"]
        dofs += [(b, tuple(asf["bones"][b].get("dofs", ()))) for b in bone_order]
        for bone, names in dofs:
            for d in names:
                d = d.lower()
                if d[0] == "t":
                    out.append(_channel(f"{bone}_{d}", d[1], "POS", bone, length))
                elif d[0] == "r":
                    out.append(_channel(f"{bone}_{d}", d[1], "ORNT", bone, angle))
                else:  # "l": bone length
                    out.append(_channel(f"{bone}_{d}", "n/a", "MISC", bone, length))
    elif m.channel_values is not None:
        for j, name in enumerate(sk.names):
            for ch in sk.channels[j]:
                axis = ch[0].lower()
                if ch.endswith("position"):
                    out.append(_channel(f"{name}_{ch}", axis, "POS", name, length))
                elif ch.endswith("rotation"):
                    out.append(_channel(f"{name}_{ch}", axis, "ORNT", name, angle))
                else:  # pragma: no cover - readers only produce the six BVH channel names
                    out.append(_channel(f"{name}_{ch}", "n/a", "MISC", name, "n/a"))
    else:
        for j, name in enumerate(sk.names):
            out += _quat_channels(name)
            if sk.has_position(j):
                out += [_channel(f"{name}_pos_{c}", c, "POS", name, length) for c in "xyz"]
    subject = m.meta.get("subject")
    return out, (str(subject) if subject not in (None, "") else None), None


def _markers(mk, path: Path) -> tuple[list[dict], str | None, str | None]:
    units = mk.units or "n/a"
    out = [_channel(f"{lab}_{c}", c, "POS", lab, units) for lab in mk.labels for c in "xyz"]
    names = [n.strip() for n in (mk.meta.get("subjects") or ()) if n and n.strip()]
    return out, (", ".join(names) if names else None), None


def _table(sig) -> list[dict]:
    deg = sig.meta.get("in_degrees")
    labels = list(sig.meta.get("labels") or [f"c{k + 1}" for k in range(sig.dim)])
    out = []
    for lab in labels:
        trans = re.search(r"_t([xyz])$", lab)
        if deg is None:
            out.append(_channel(lab, "n/a", "MISC", lab, "n/a"))
        elif trans:
            out.append(_channel(lab, trans.group(1), "POS", lab[:trans.start()], "m"))
        else:
            out.append(_channel(lab, "n/a", "JNTANG", lab, "deg" if deg else "rad"))
    return out


def _imu(sigs: dict) -> list[dict]:
    out = []
    for sensor, s in sigs.items():
        if s.kind == "quaternion":
            out += _quat_channels(sensor)
        else:
            out += [_channel(f"{sensor}_{k + 1}", "n/a", "MISC", sensor, "n/a") for k in range(s.dim)]
    return out


def _cmu_name(path: Path) -> tuple[str | None, str | None]:
    m = _CMU_NAME.match(path.stem)
    return (m.group(1), m.group(2)) if m else (None, None)


def describe(obj, path, fmt: str | None = None) -> dict:
    """The record's ``"recording"`` dict of an already loaded ``obj`` read from ``path``.

    Parameters
    ----------
    obj
        A skeletal :class:`~mocapkit.skeleton.Motion`, a :class:`~mocapkit.markers.Markers`, a dict
        ``{sensor: Signal}`` of IMU signals, or one table :class:`~mocapkit.motion.Signal` (OpenSim
        ``read_table``).
    path
        Where it was read from.
    fmt
        The format's name; default: the reader's ``meta["format"]``, else the file's suffix (``"folder"``
        for a sensor folder).

    Returns
    -------
    dict
        ``path``, ``format``, ``kind`` (``skeletal``/``markers``/``imu``/``table``), ``rate_hz`` (the
        rate the file states, else the mean rate; IMU: the sensors' common stated rate, else the mean rate
        of the sensor with most samples; ``None`` for a single sample), ``frames`` (IMU: the most samples
        of any sensor), ``duration_s`` (frames × frame time for skeletal and marker files, last − first
        time otherwise; IMU: over all sensors), ``subject``, ``take`` and ``channels`` (see the module
        docstring).
    """
    from mocapkit.markers import Markers
    from mocapkit.motion import Signal
    from mocapkit.skeleton import Motion

    p = Path(path)
    subject = take = None
    rate: float | None
    if isinstance(obj, Motion):
        kind, meta = "skeletal", {**obj.skeleton.meta, **obj.meta}
        frames, rate = obj.n_frames, obj.rate
        duration = frames * obj.frame_time
        channels, subject, take = _skeletal(obj)
    elif isinstance(obj, Markers):
        kind, meta = "markers", obj.meta
        frames, rate = int(obj.times.shape[0]), float(obj.rate)
        duration = frames / rate
        channels, subject, take = _markers(obj, p)
    elif isinstance(obj, Signal):
        kind, meta = "table", obj.meta
        frames = len(obj)
        rate = obj.meta.get("rate") or (obj.mean_rate if frames > 1 else None)
        duration = obj.duration
        channels = _table(obj)
    elif isinstance(obj, dict) and obj and all(isinstance(s, Signal) for s in obj.values()):
        kind = "imu"
        sigs = list(obj.values())
        longest = max(sigs, key=len)
        meta = longest.meta
        frames = len(longest)
        stated = {s.meta.get("rate") for s in sigs}
        rate = stated.pop() if len(stated) == 1 and None not in stated else (
            longest.mean_rate if frames > 1 else None)
        duration = max(float(s.times[-1]) for s in sigs) - min(float(s.times[0]) for s in sigs)
        channels = _imu(obj)
    else:
        raise TypeError(f"describe() takes a Motion, Markers, a Signal or a non-empty {{name: Signal}} dict, "
                        f"not {type(obj).__name__}")
    if subject is None and take is None:
        subject, take = _cmu_name(p)
    if fmt is None:
        fmt = meta.get("format") or (p.suffix.lower().lstrip(".") or ("folder" if p.is_dir() else "n/a"))
    rate = None if rate is None or not math.isfinite(float(rate)) else float(rate)
    return {"path": str(p), "format": str(fmt), "kind": kind, "rate_hz": rate, "frames": int(frames),
            "duration_s": float(duration), "subject": subject, "take": take, "channels": channels}


def _hash_file(h, path: Path) -> None:
    with open(path, "rb") as fh:
        while True:
            block = fh.read(CHUNK)
            if not block:
                return
            h.update(block)


def content_hash(path) -> str:
    """SHA-256 hex digest of a file's bytes (read in 1 MiB chunks).

    For a folder (an IMU sensor folder) the digest covers its regular files at any depth, in the sorted
    order of their relative POSIX names: for each, the name (UTF-8), a NUL byte, the size as 8 bytes and
    the bytes. Folder symlinks are not followed; hidden files count like any other. A pipe, device or
    socket cannot be hashed without consuming it: :class:`~mocapkit.errors.MocapFormatError`.
    """
    p = Path(path)
    st = os.stat(p)
    h = hashlib.sha256()
    if stat.S_ISREG(st.st_mode):
        _hash_file(h, p)
        return h.hexdigest()
    if not stat.S_ISDIR(st.st_mode):
        raise MocapFormatError(str(p), None, "not a regular file or folder: its content cannot be hashed")
    files = []
    for d, dirs, names in os.walk(p):
        dirs.sort()
        for n in names:
            f = Path(d) / n
            try:
                if stat.S_ISREG(os.stat(f).st_mode):
                    files.append((f.relative_to(p).as_posix(), f))
            except OSError:  # a dangling link: not a file of the recording
                continue
    for rel, f in sorted(files):
        h.update(rel.encode("utf-8", "surrogateescape") + b"\0")
        h.update(os.stat(f).st_size.to_bytes(8, "little"))
        _hash_file(h, f)
    return h.hexdigest()
