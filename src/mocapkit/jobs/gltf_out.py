"""Skeletal keyframes written as glTF with the position bound checked on the file.

The bound of ``compress ... -o OUT.glb --max-position-error CM`` is a guarantee on what a reader of
the file gets, not on the keyframes in memory: glTF stores key times and translations as float32 and
rotations as float32 or normalized SHORT (:mod:`mocapkit.io.formats.gltf`), which adds a small error of its
own. :func:`compress_to_gltf` therefore

1. bounds that storage error before compressing — :func:`storage_error_bound`, a worst case from the
   per-key angle of the rotation format, the float32 rounding of times and translations and every
   joint's distance to its ancestors — and measures it on the original motion stored with every frame
   a key (:func:`every_frame`, written and read back: ``q0``);
2. compresses to the smaller bound ``E − min(Q, 1.5·q0)`` and decodes the bytes it is about to write
   with :func:`~mocapkit.io.formats.gltf.read_gltf` (forward kinematics of every joint in every frame against
   the original);
3. when that misses ``E``, compresses once more to ``E − Q`` (the worst case: safe) or, where ``Q``
   leaves too little, to ``E − 2·q`` with ``q`` the storage error measured on the first file;
4. with SHORT rotations, when the storage error would take more than half the bound (halving the bound
   costs more keys than SHORT saves) or both attempts miss, compresses with FLOAT rotations instead and
   keeps the smaller of that file and the SHORT file with every frame a key (when its measured error
   ``q0`` is within the bound: at tight bounds few frames can be dropped anyway), saying which in the
   record; a file that misses the bound is never written (:class:`BoundViolationError`). At any bound,
   the SHORT file with every frame a key is written instead when it is within the bound and smaller
   (keyframes cost a float32 time each; every frame shares one time accessor).

After writing, a regular output file is read back from disk and checked again.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mocapkit.errors import BoundViolationError, InvalidParameterError

if TYPE_CHECKING:
    from mocapkit.pla.skeletal import SkeletalCompressed

#: part of the bound the storage error may take before SHORT rotations are given up for FLOAT
SHORT_MAX_SHARE = 0.5
#: margin on the storage error measured with every frame a key (sparse keys mix errors differently)
MEASURED_MARGIN = 1.5


def every_frame(motion):
    """A :class:`~mocapkit.pla.skeletal.SkeletalCompressed` holding every frame of every animated track
    as a key (the uncompressed motion in the form the glTF writer takes); a track whose samples are all
    equal keeps only its first and last frames (the same motion, between and beyond them)."""
    from mocapkit.pla.base import Compressed
    from mocapkit.pla.skeletal import SkeletalCompressed, animated_tracks

    rot, tr = animated_tracks(motion)
    n = motion.n_frames
    idx = np.arange(n)

    def track(kind, values):
        k = idx[[0, -1]] if n > 1 and np.all(values == values[:1]) else idx
        return Compressed("every_frame", 0.0, None, kind, n, k, motion.times[k], values[k])

    out = SkeletalCompressed(motion, "every_frame")
    out.rotations = {j: track("quaternion", motion.rotations[:, j]) for j in rot}
    out.translations = {j: track("vector", motion.translations[:, j]) for j in tr}
    out.info = {"mode": "every_frame"}
    return out


def storage_error_bound(motion, rotations: str, bound: float = 0.0, end_sites: bool = False) -> float:
    """Worst-case world-position error (file units) that storing keyframes of ``motion`` in glTF adds.

    Per joint ``i`` with a rotation track: the key angle of the format (``SHORT_KEY_ANGLE`` or
    ``FLOAT_KEY_ANGLE``) times ``√2`` (SLERP between rounded keys, at most 180° apart) plus the float32
    rounding ``τ ≤ max|t|·2⁻²⁴`` of the key times, which shifts where the decoder samples by up to ``2τ``
    at the track's largest angular speed ``ω_i`` (consecutive frames; SLERP between samples is never
    faster). Per joint with a translation track: float32 rounding ``√3·max|T_i|·2⁻²⁴`` plus ``2τ`` at its
    largest speed. A rotation error ``δ_i`` moves a joint ``k`` below ``i`` by at most
    ``δ_i·|p_k − p_i|``, with ``|p_k − p_i|`` at most the sum of the bone lengths between them (largest
    over frames) plus ``2·bound`` (the decoded motion's joints are within ``bound`` of the original's);
    a translation error moves its joint's subtree by itself; errors of a chain add (triangle inequality,
    rotations keep distances). One pass over the joints, parents first. With ``end_sites`` the End
    Sites too: each is a bone of its offset's length below its joint, moved by that joint's rotation.
    """
    from mocapkit.io.formats.gltf import FLOAT_KEY_ANGLE, ROTATION_FORMATS, SHORT_KEY_ANGLE
    from mocapkit.pla.skeletal import animated_tracks
    from mocapkit.quat import angular_distance
    from mocapkit.skeleton import forward_kinematics

    if rotations not in ROTATION_FORMATS:
        raise InvalidParameterError(f"rotations must be one of {', '.join(ROTATION_FORMATS)}, got {rotations!r}")
    sk = motion.skeleton
    rot, tr = animated_tracks(motion)
    P = forward_kinematics(motion)[0]
    t = motion.times
    tau = float(np.abs(t).max()) * 2.0**-24
    dt = float(np.diff(t).min()) if len(t) > 1 else 1.0
    key = math.sqrt(2.0) * (SHORT_KEY_ANGLE if rotations == "short" else FLOAT_KEY_ANGLE)
    w = np.zeros(sk.n_joints)  # rotation error (radians) of each joint's local rotation
    v = np.zeros(sk.n_joints)  # translation error (file units) of each joint's local translation
    for j in rot:
        q = motion.rotations[:, j]
        omega = float(angular_distance(q[1:], q[:-1]).max()) / dt if len(q) > 1 else 0.0
        w[j] = key + 2.0 * tau * omega
    for j in tr:
        x = motion.translations[:, j]
        speed = float(np.linalg.norm(np.diff(x, axis=0), axis=-1).max()) / dt if len(x) > 1 else 0.0
        v[j] = math.sqrt(3.0) * float(np.abs(x).max()) * 2.0**-24 + 2.0 * tau * speed
    W = np.zeros(sk.n_joints)  # sum of the rotation errors of the strict ancestors
    Q = np.zeros(sk.n_joints)  # bound on the joint's world error (bone paths as levers)
    for k, p in enumerate(sk.parents.tolist()):  # topological order: parents first
        if p < 0:
            Q[k] = v[k]
            continue
        bone = float(np.linalg.norm(P[:, k] - P[:, p], axis=-1).max())
        W[k] = W[p] + w[p]
        Q[k] = Q[p] + W[k] * bone + v[k]
    worst = float((Q + 2.0 * bound * W).max())
    for j, off in sk.end_sites if end_sites else ():
        lever = W[j] + w[j]
        worst = max(worst, float(Q[j] + lever * (float(np.linalg.norm(off)) + 2.0 * bound)))
    return worst


def readback_error(motion, path: Path, data: bytes | None = None, end_sites: bool = False) -> float:
    """Largest world-position distance (file units) between ``motion`` and the glTF ``path`` (or its
    bytes ``data``) decoded by :func:`~mocapkit.io.formats.gltf.read_gltf`, over every joint (and End Site with
    ``end_sites``) and frame."""
    from mocapkit.io.formats.gltf import read_gltf
    from mocapkit.pla.skeletal import position_errors

    back = read_gltf(path, data=data)
    if back.n_frames != motion.n_frames or back.skeleton.names != motion.skeleton.names:
        raise BoundViolationError(f"{path}: the written clip does not decode to the input's frames and joints")
    if end_sites and [j for j, _ in back.skeleton.end_sites] != [j for j, _ in motion.skeleton.end_sites]:
        raise BoundViolationError(f"{path}: the written clip does not decode to the input's End Sites")
    return float(position_errors(motion, back, end_sites).max())


def compress_to_gltf(motion, bound: float, output: Path, *, rotations: str = "short", unit_m: float = 0.01,
                     name: str = "mocapkit", method: str = "fastsw", max_segment_length=None, progress=None,
                     end_sites: bool = False):
    """Compress ``motion`` with every joint (and End Site with ``end_sites``) within ``bound`` (file
    units) on the decoded file, and write
    it to ``output`` (``.glb``/``.gltf``; module notes). Returns the compression and a dict of what was
    done (``rotations`` used, the bounds compressed to, storage error bound and measured, read-back
    error, attempts, warnings)."""
    from mocapkit.io.atomic import is_device_or_pipe
    from mocapkit.io.formats.gltf import gltf_bytes, write_gltf
    from mocapkit.pla.skeletal import compress_motion

    suffix = output.suffix.lower()
    warnings: list[str] = []

    def encode(comp, fmt):
        return gltf_bytes(comp, suffix, unit_m=unit_m, name=name, rotations=fmt)

    def attempt(e_c, fmt):
        comp = compress_motion(motion, method, max_position_error=e_c, max_segment_length=max_segment_length,
                               progress=progress, end_sites=end_sites)
        encoded = encode(comp, fmt)
        return comp, encoded, readback_error(motion, output, encoded, end_sites)

    # [(comp, bytes, error)] of SHORT with every frame a key, when within the bound (set by plan)
    full_short: list[tuple[SkeletalCompressed, bytes, float]] = []

    def plan(fmt):
        Q = storage_error_bound(motion, fmt, bound, end_sites)
        full = every_frame(motion)
        encoded = encode(full, fmt)
        q0 = readback_error(motion, output, encoded, end_sites)
        if fmt == "short" and q0 <= bound:
            full.info = {"mode": "max_position_error", "bound": 0.0, "keys": "every frame"}
            full_short[:] = [(full, encoded, q0)]
        return Q, q0, bound - min(Q, MEASURED_MARGIN * q0)

    fmt = rotations
    Q, q0, e1 = plan(fmt)
    if fmt == "short" and e1 < (1.0 - SHORT_MAX_SHARE) * bound:
        warnings.append(f"SHORT rotations would take {100 * (bound - e1) / bound:.0f}% of the bound "
                        "(more keys than SHORT saves): compressed with FLOAT rotations")
        fmt = "float"
        Q, q0, e1 = plan(fmt)
    tried = []
    while True:
        if not e1 > 0:
            raise BoundViolationError(f"storing keys in glTF alone takes the whole bound ({bound:g}; "
                                      f"measured {q0:.3g}, worst case {Q:.3g} in file units)")
        comp, data, err = attempt(e1, fmt)
        tried.append({"rotations": fmt, "compress_bound": e1, "readback_error": err})
        if err <= bound:
            break
        q = err - float(comp.info.get("max_position_error", 0.0))
        e2 = bound - Q if Q <= SHORT_MAX_SHARE * bound else bound - 2.0 * max(q, q0, err - bound)
        if sum(a["rotations"] == fmt for a in tried) < 2 and 0 < e2 < e1:
            e1 = e2
            continue
        if fmt != "short":
            raise BoundViolationError(f"the decoded glTF is {err:.6g} from the input, above the bound {bound:g}, "
                                      "after a tighter retry")
        warnings.append(f"SHORT rotations missed the bound on the decoded file ({err:.6g} > {bound:g}) "
                        "after a tighter retry: compressed with FLOAT rotations")
        fmt = "float"
        Q, q0, e1 = plan(fmt)
    if full_short and len(full_short[0][1]) < len(data):
        warnings.append(f"every frame kept as a SHORT key ({len(full_short[0][1]):,} bytes, "
                        f"error {full_short[0][2]:.4g}) "
                        f"is smaller than the keyframes ({len(data):,} bytes): written that way")
        comp, data, err = full_short[0]
        fmt, e1 = "short", 0.0
        tried.append({"rotations": fmt, "compress_bound": 0.0, "readback_error": err})
    write_gltf(output, comp, unit_m=unit_m, name=name, rotations=fmt, data=data)
    if not is_device_or_pipe(output):
        err_file = readback_error(motion, output, end_sites=end_sites)
        if err_file > bound:
            output.unlink(missing_ok=True)
            raise BoundViolationError(f"{output}: read back from disk it is {err_file:.6g} from the input, "
                                      f"above the bound {bound:g} (removed)")
        err = err_file
    return comp, {"rotations": fmt, "compress_bound": e1, "storage_error_bound": Q, "storage_error_measured": q0,
                  "readback_error": err, "attempts": tried, "warnings": warnings}


def write_checked(motion, comp, output: Path, *, rotations: str = "short", unit_m: float = 0.01,
                  name: str = "mocapkit") -> dict:
    """Write ``comp`` (compressed without a bound) and measure the read-back error of the file."""
    from mocapkit.io.atomic import is_device_or_pipe
    from mocapkit.io.formats.gltf import gltf_bytes, write_gltf

    data = gltf_bytes(comp, output.suffix, unit_m=unit_m, name=name, rotations=rotations)
    err = readback_error(motion, output, data)
    write_gltf(output, comp, unit_m=unit_m, name=name, rotations=rotations, data=data)
    if not is_device_or_pipe(output):
        err = readback_error(motion, output)
    return {"rotations": rotations, "readback_error": err, "warnings": []}
