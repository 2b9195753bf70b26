"""Xsens MVNX (the XML that MVN Analyze / MVN Animate export, MVNX version 4) as a skeletal motion.

Layout read
-----------
``<mvnx version="4">`` (any XML namespace; Xsens writes a default one) holding one ``<subject
frameRate="…">`` with

* ``<segments>``: ``<segment label="Pelvis">`` … each with ``<points>`` of named ``<point
  label="jL5S1"><pos_b>x y z</pos_b></point>`` — positions in the segment's body frame, metres;
* ``<joints>``: ``<joint label="jL5S1"><connector1>Pelvis/jL5S1</connector1><connector2>L5/jL5S1
  </connector2></joint>`` — the parent segment's point that meets the child segment's point;
* ``<frames>``: ``<frame type="identity|tpose|tpose-isb">`` calibration frames first (skipped and
  counted in ``meta["skipped_frames"]``), then ``<frame time="ms" index="k" tc="…" ms="…"
  type="normal">`` with ``<orientation>`` (4 numbers per segment, ``q0 q1 q2 q3`` scalar first, the
  rotation from the segment's body frame to the global frame) and ``<position>`` (3 per segment,
  the global position of the segment origin, metres), in the order of ``<segments>``. Every other
  element (velocities, sensor data, joint angles, centre of mass, …) is ignored. A frame without a
  ``type`` is taken as a normal frame.

These elements are read only at the paths above. One found under its usual parent elsewhere (a
``<segment>`` with ``<points>`` outside ``<segments>``, a ``<frames>`` block inside a frame) or an
element inside a text element (``<pos_b>``, ``<orientation>``…) is refused rather than dropped.

The file is read with the streaming expat parser (the parser under ``xml.etree``), keeping only the
two numeric arrays of the normal frames: a long recording costs 7 floats per segment and frame. The
expat parser is used directly (not ``iterparse``) because it reports the line of every element, so
that a missing or malformed element is reported with its line. Anything malformed raises
:class:`~mocapkit.errors.MocapFormatError` with the path and the line.

Model mapping
-------------
* One joint per segment, named with the segment's label and placed at the segment origin (where the
  file's ``<position>`` is). The parent of a segment is the segment of ``connector1`` of the joint
  whose ``connector2`` names it; segments that no joint names as a child are roots (normally only
  ``Pelvis``) and get ``Xposition Yposition Zposition`` channels with the file's position.
* Local rotation ``L = G_parent⁻¹ · G_child`` from the normalised global quaternions (roots: ``G``).
* Offset (rest translation) of a child = ``connector1`` point in the parent's body frame minus the
  ``connector2`` point in the child's body frame (Xsens puts the child's origin at its joint, so the
  second term is zero in MVN files).
* Soft body: the file's own local translation ``G_parent⁻¹ (p_child − p_parent)`` is compared with
  the offset over all frames (``meta["joint_gap_m"]``). A joint whose gap stays within
  ``gap_tolerance_m`` (default 0.1 mm — thirty times the rounding of the file's six decimals and far
  below any mocap accuracy) keeps its constant offset; a joint beyond it gets position channels
  holding the file's per-frame translation (listed in ``meta["animated_offsets"]``, with a line in
  ``meta["warnings"]``), so forward kinematics reproduces every segment position of the file.
* Leaf segments get an end site at their point farthest from the origin (``pTopOfHead``,
  ``pRightTopOfHand``, ``pRightToe`` in MVN files).
* Units and axes stay as in the file: metres (``Skeleton.meta["length_unit_cm"] = 100``), Z up
  (``meta["up_axis"]``).
* Times: ``frameRate`` and the frames' ``index`` give ``t = t0 + (index − index0) / rate`` when
  every frame's ``time`` (whole ms) agrees with it to the ms rounding; otherwise the ``time``
  attribute is used (with a warning), and without ``frameRate`` the ``time`` attribute alone.

Numbers and sizes
-----------------
Numbers (element text and the ``frameRate``/``time``/``index`` attributes) follow the strict grammar
of :mod:`mocapkit.io.text.numbers`: no ``nan``/``inf`` (MVNX has no missing-value convention), no ``0_5``,
``|value| > MAX_ABS`` (1e12) refused, each error naming the line, the element and the segment and
component (``<orientation> of segment 'Pelvis' q0``). ``frameRate`` must lie in [1e-6, 1e9] Hz.
Declared counts (``segmentCount``...) size nothing: memory follows the frames actually read. A pipe
or device is read in bounded chunks (at most 256 MiB; a NUL byte is malformed XML at once).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import NoReturn
from xml.parsers import expat

import numpy as np

from mocapkit.errors import InvalidSignalError, MocapFormatError
from mocapkit.io.text import input as textinput
from mocapkit.io.text.input import is_regular
from mocapkit.io.text.numbers import MAX_ABS, parse_number
from mocapkit.quat import multiply
from mocapkit.skeleton import Motion, Skeleton, quat_to_matrix

__all__ = ["CALIBRATION_FRAME_TYPES", "GAP_TOLERANCE_M", "JOINT_CHANNELS", "ROOT_CHANNELS", "read_mvnx"]

ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
JOINT_CHANNELS = ("Zrotation", "Xrotation", "Yrotation")
ANIMATED_CHANNELS = ("Xposition", "Yposition", "Zposition") + JOINT_CHANNELS
#: Frame types MVN writes before the recording (skipped).
CALIBRATION_FRAME_TYPES = ("identity", "tpose", "tpose-isb")
#: Largest difference (m) between a joint's offset and the file's own local translation that is
#: still a rigid segment (see the module docstring).
GAP_TOLERANCE_M = 1e-4

# Where the elements read sit (local names from the root). An element with one of these names whose
# parent has the expected name but whose path differs (a <segment> with <points> outside <segments>,
# a <frames> block inside a frame...) is refused: its data would otherwise be dropped or misfiled.
_SUBJECT = ("mvnx", "subject")
_SEGMENT = _SUBJECT + ("segments", "segment")
_POINT = _SEGMENT + ("points", "point")
_JOINT = _SUBJECT + ("joints", "joint")
_FRAMES = _SUBJECT + ("frames",)
_FRAME = _FRAMES + ("frame",)
_PLACES = {"subject": _SUBJECT, "segment": _SEGMENT, "point": _POINT, "joint": _JOINT, "frame": _FRAME}
#: Elements holding numbers or a connector (text only), by the path of their parent.
_TEXT_ELEMENTS = {"pos_b": _POINT, "connector1": _JOINT, "connector2": _JOINT,
                  "orientation": _FRAME, "position": _FRAME}


#: Range accepted for ``frameRate`` (Hz).
RATE_RANGE = (1e-6, 1e9)
_NOT_NUMERIC = re.compile(r"[^0-9eE.+\-\s]")
_INDEX_RE = re.compile(r"[+-]?\d{1,18}", re.ASCII)


class _Bounded:
    """A binary file object that refuses to deliver more than ``limit`` bytes (pipes, devices)."""

    def __init__(self, fh, src: str, limit: int):
        self.fh, self.src, self.limit, self.total = fh, src, limit, 0

    def read(self, n: int = -1) -> bytes:
        chunk = self.fh.read(n if n and n > 0 else 1 << 20)
        self.total += len(chunk)
        if self.total > self.limit:
            raise MocapFormatError(self.src, None, f"more than {self.limit:,} bytes from a pipe or device; "
                                   "save it to a regular file first")
        return chunk


def _local(name: str) -> str:
    """Element name without a namespace (``{uri}frame`` / ``ns:frame`` -> ``frame``)."""
    return name.rsplit("}", 1)[-1].rsplit(":", 1)[-1]


class _Reader:
    """Expat handlers that collect the skeleton description and the normal frames."""

    def __init__(self, src: str, parser) -> None:
        self.src = src
        self.p = parser
        self.stack: list[str] = []
        self.text: list[str] | None = None
        self.text_tag = ""
        self.text_line = 0
        self.version = None
        self.mvn_version = None
        self.subject: dict | None = None
        self.subject_line = 0
        self.segments: list[dict] = []
        self.seg_index: dict[str, int] = {}
        self.point: dict | None = None
        self.joints: list[dict] = []
        self.joint: dict | None = None
        self.frames_seen = False
        self.skipped: dict[str, int] = {}
        self.frame: dict | None = None
        self.orient: list[np.ndarray] = []
        self.pos: list[np.ndarray] = []
        self.times_ms: list[float | None] = []
        self.indices: list[int | None] = []
        self.frame_lines: list[int] = []

    # -- helpers -----------------------------------------------------------------------------------
    def fail(self, problem: str, line: int | None = None) -> NoReturn:
        raise MocapFormatError(self.src, self.p.CurrentLineNumber if line is None else line, problem)

    def numbers(self, text: str, what: str, line: int, per: int = 0) -> np.ndarray:
        """The numbers of an element's text by the strict grammar; ``per`` values a segment name the
        segment and component of a bad value."""
        toks = text.split()
        v = None
        if not _NOT_NUMERIC.search(text):
            try:
                v = np.array(toks, dtype=np.float64)
            except ValueError:
                v = None
        if v is None or not np.all(np.abs(v) <= MAX_ABS):
            for i, t in enumerate(toks):
                if t.lower().lstrip("+-") in ("nan", "inf", "infinity"):
                    self.fail(f"{self._component(what, i, per)}: {t!r} is NaN or infinite (MVNX has no "
                              "missing-value convention)", line)
                parse_number(t, self.src, line, self._component(what, i, per))
            # the strict grammar refuses whatever the bulk parse or the range check did
            assert v is not None
        return v

    def _component(self, what: str, i: int, per: int) -> str:
        if per and i // per < len(self.segments):
            comp = ("q0", "q1", "q2", "q3")[i % per] if per == 4 else "xyz"[i % per]
            return f"{what} of segment {self.segments[i // per]['label']!r} {comp}"
        return f"{what} value {i + 1}"

    def attr_float(self, attrs: dict, key: str, what: str) -> float | None:
        if key not in attrs or attrs[key].strip() == "":
            return None
        return parse_number(attrs[key].strip(), self.src, self.p.CurrentLineNumber, f"{what} {key}")

    # -- handlers ----------------------------------------------------------------------------------
    def start(self, name: str, attrs: dict) -> None:
        tag = _local(name)
        if self.text is not None:
            self.fail(f"<{tag}> inside <{self.text_tag}> (line {self.text_line}), which holds text only")
        parent = self.stack[-1] if self.stack else None
        self.stack.append(tag)
        if parent is None:
            if tag != "mvnx":
                self.fail(f"not an MVNX file: the root element is <{tag}>, expected <mvnx>")
            self.version = attrs.get("version")
            return
        path = tuple(self.stack)
        place = _PLACES.get(tag)
        if place is not None and path != place and parent == place[-2]:
            self.fail(f"<{tag}> at {'/'.join(path)}: a <{parent}> outside {'/'.join(place[:-1])}")
        if tag == "mvn" and len(path) == 2:
            self.mvn_version = attrs.get("version")
        elif path == _SUBJECT:
            if self.subject is not None:
                self.fail(f"a second <subject> (the first is on line {self.subject_line}): files with several "
                          "subjects are not supported")
            self.subject = dict(attrs)
            self.subject_line = self.p.CurrentLineNumber
            rate = self.attr_float(attrs, "frameRate", "<subject>")
            if rate is not None and not RATE_RANGE[0] <= rate <= RATE_RANGE[1]:
                self.fail(f"<subject> frameRate={attrs['frameRate']!r} must be positive (between "
                          f"{RATE_RANGE[0]:g} and {RATE_RANGE[1]:g} Hz)")
            self.subject["_rate"] = rate
        elif path == _SEGMENT:
            label = attrs.get("label", "").strip()
            if not label:
                self.fail("<segment> without a label")
            if label in self.seg_index:
                self.fail(
                    f"segment {label!r} is defined twice (first on line {self.segments[self.seg_index[label]]['line']})"
                )
            if self.frames_seen:
                self.fail(f"segment {label!r} after the frames")
            self.seg_index[label] = len(self.segments)
            self.segments.append({"label": label, "line": self.p.CurrentLineNumber, "points": {}})
        elif path == _POINT:
            label = attrs.get("label", "").strip()
            if not label:
                self.fail(f"<point> without a label in segment {self.segments[-1]['label']!r}")
            self.point = {"label": label, "line": self.p.CurrentLineNumber, "pos": None}
        elif path == _JOINT:
            self.joint = {"label": attrs.get("label", "?"), "line": self.p.CurrentLineNumber}
        elif path == _FRAMES:
            self.frames_seen = True
        elif path == _FRAME:
            ftype = attrs.get("type", "normal").strip()
            line = self.p.CurrentLineNumber
            if ftype != "normal":
                self.skipped[ftype] = self.skipped.get(ftype, 0) + 1
                self.frame = None
                return
            if not self.segments:
                self.fail("a normal frame before any <segment> definition")
            t = self.attr_float(attrs, "time", "<frame>")
            idx = attrs.get("index")
            if idx is not None and idx.strip() != "":
                if not _INDEX_RE.fullmatch(idx.strip()):
                    self.fail(f"<frame> index={idx[:40]!r} is not an integer")
                idx = int(idx)
            else:
                idx = None
            self.frame = {"line": line, "time": t, "index": idx, "orientation": None, "position": None}
        elif tag in _TEXT_ELEMENTS and path[:-1] == _TEXT_ELEMENTS[tag] and self._wants_text(tag):
            self.text = []
            self.text_tag = tag
            self.text_line = self.p.CurrentLineNumber

    def _wants_text(self, tag: str) -> bool:
        if tag == "pos_b":
            return self.point is not None
        if tag in ("connector1", "connector2"):
            return self.joint is not None
        return self.frame is not None

    def chars(self, data: str) -> None:
        if self.text is not None:
            self.text.append(data)

    def end(self, name: str) -> None:
        path = tuple(self.stack)
        tag = self.stack.pop()
        if self.text is not None:  # nothing can open inside a text element: this one closes it
            text = "".join(self.text)
            self.text = None
            self._text_element(tag, text, self.text_line)
        if path == _POINT and self.point is not None:
            seg = self.segments[-1]
            if self.point["pos"] is None:
                self.fail(
                    f"point {self.point['label']!r} of segment {seg['label']!r} has no <pos_b>", self.point["line"]
                )
            seg["points"].setdefault(self.point["label"], self.point["pos"])
            self.point = None
        elif path == _JOINT and self.joint is not None:
            for c in ("connector1", "connector2"):
                if c not in self.joint:
                    self.fail(f"joint {self.joint['label']!r} has no <{c}>", self.joint["line"])
            self.joints.append(self.joint)
            self.joint = None
        elif path == _FRAME and self.frame is not None:
            f = self.frame
            for key in ("orientation", "position"):
                if f[key] is None:
                    self.fail(f"normal frame (index {f['index']}) has no <{key}>", f["line"])
            self.orient.append(f["orientation"])
            self.pos.append(f["position"])
            self.times_ms.append(f["time"])
            self.indices.append(f["index"])
            self.frame_lines.append(f["line"])
            self.frame = None

    def _text_element(self, tag: str, text: str, line: int) -> None:
        if tag == "pos_b":
            assert self.point is not None  # _wants_text collects it inside a <point> only
            v = self.numbers(text, f"<pos_b> of point {self.point['label']!r}", line)
            if v.size != 3:
                self.fail(f"<pos_b> of point {self.point['label']!r}: expected 3 numbers, got {v.size}", line)
            self.point["pos"] = v
        elif tag in ("connector1", "connector2"):
            assert self.joint is not None  # inside a <joint> only
            seg, sep, pt = text.strip().partition("/")
            if not sep or not seg or not pt:
                self.fail(f"joint {self.joint['label']!r}: <{tag}> {text.strip()[:60]!r} is not 'Segment/point'", line)
            self.joint[tag] = (seg, pt, line)
        else:
            assert self.frame is not None  # inside a <frame> only
            S = len(self.segments)
            k = 4 if tag == "orientation" else 3
            v = self.numbers(text, f"<{tag}>", line, k)
            if v.size != k * S:
                self.fail(f"<{tag}> holds {v.size} numbers, expected {k} per segment × {S} segments = {k * S}", line)
            self.frame[tag] = v.reshape(S, k)


def read_mvnx(path: str | Path, gap_tolerance_m: float = GAP_TOLERANCE_M) -> Motion:
    """Read an Xsens MVNX file into a :class:`~mocapkit.skeleton.Motion` (see the module docstring).

    Parameters
    ----------
    path
        The ``.mvnx`` file.
    gap_tolerance_m
        Largest difference (metres) between a joint's offset from the connector points and the
        file's own per-frame local translation for the joint to keep a constant offset; beyond it
        the joint gets position channels (soft body).
    """
    src = str(path)
    parser = expat.ParserCreate()
    parser.buffer_text = True
    r = _Reader(src, parser)
    parser.StartElementHandler = r.start
    parser.EndElementHandler = r.end
    parser.CharacterDataHandler = r.chars
    try:
        with open(path, "rb") as fh:
            parser.ParseFile(fh if is_regular(path) else _Bounded(fh, src, textinput.MAX_STREAM_BYTES))
    except expat.ExpatError as e:
        raise MocapFormatError(
            src, e.lineno, f"malformed XML: {expat.ErrorString(e.code)} (column {e.offset + 1})"
        ) from None
    except (FileNotFoundError, IsADirectoryError, PermissionError) as e:
        raise MocapFormatError(src, None, e.strerror or str(e)) from None
    except (LookupError, UnicodeError, ValueError) as e:  # e.g. an unknown encoding in the XML declaration
        raise MocapFormatError(src, None, f"cannot decode the XML: {e}") from None
    return _build(r, src, float(gap_tolerance_m))


def _build(r: _Reader, src: str, tol: float) -> Motion:
    if r.subject is None:
        raise MocapFormatError(src, None, "no <subject> element")
    if not r.segments:
        raise MocapFormatError(src, r.subject_line, "no <segments>/<segment> definitions in the subject")
    if not r.orient:
        kinds = ", ".join(f"{v} {k}" for k, v in r.skipped.items()) or "none"
        raise MocapFormatError(src, None, f"no normal frames (type=\"normal\") in <frames> (other frames: {kinds})")
    segs = r.segments
    S = len(segs)
    labels = [s["label"] for s in segs]
    warnings: list[str] = []

    # hierarchy from the joints
    parent = [-1] * S
    offset = np.zeros((S, 3))
    joint_of: dict[int, dict] = {}
    for jt in r.joints:
        (ps, pp, l1), (cs, cp, l2) = jt["connector1"], jt["connector2"]
        for seg, pt, ln in ((ps, pp, l1), (cs, cp, l2)):
            if seg not in r.seg_index:
                raise MocapFormatError(
                    src, ln, f"joint {jt['label']!r}: no segment {seg!r} (segments: {', '.join(labels[:6])}, …)"
                )
            if pt not in segs[r.seg_index[seg]]["points"]:
                raise MocapFormatError(src, ln, f"joint {jt['label']!r}: segment {seg!r} has no point {pt!r}")
        p, c = r.seg_index[ps], r.seg_index[cs]
        if p == c:
            raise MocapFormatError(src, l2, f"joint {jt['label']!r} connects segment {ps!r} to itself")
        if parent[c] >= 0:
            raise MocapFormatError(src, l2, f"joint {jt['label']!r}: segment {cs!r} already has the parent "
                                             f"{labels[parent[c]]!r} (joint {joint_of[c]['label']!r})")
        parent[c] = p
        joint_of[c] = jt
        offset[c] = segs[p]["points"][pp] - segs[c]["points"][cp]
    if not r.joints:
        warnings.append("no <joints>: every segment is a root with its own position channels")

    # topological order, file order where possible
    order: list[int] = []
    placed: set[int] = set()
    while len(order) < S:
        added = False
        for s in range(S):
            if s not in placed and (parent[s] < 0 or parent[s] in placed):
                order.append(s)
                placed.add(s)
                added = True
        if not added:
            cyc = [labels[s] for s in range(S) if s not in placed]
            raise MocapFormatError(src, joint_of[next(s for s in range(S) if s not in placed)]["line"],
                                   f"the joints form a cycle through segments {', '.join(cyc)}")

    G = np.stack(r.orient)  # (N, S, 4) in file segment order
    P = np.stack(r.pos)     # (N, S, 3)
    N = G.shape[0]
    norm = np.linalg.norm(G, axis=-1)
    if np.any(norm < 1e-6):
        n, s = map(int, np.argwhere(norm < 1e-6)[0])
        raise MocapFormatError(src, r.frame_lines[n], f"segment {labels[s]!r}: zero orientation quaternion")
    G = G / norm[..., None]

    times, rate, times_from = _times(r, r.subject.get("_rate"), src, warnings)

    new_index = {s: k for k, s in enumerate(order)}
    rot = np.empty((N, S, 4))
    trans = np.empty((N, S, 3))
    gaps: dict[str, float] = {}
    animated: list[str] = []
    channels: list[tuple[str, ...]] = []
    offsets = np.zeros((S, 3))
    for k, s in enumerate(order):
        p = parent[s]
        if p < 0:
            rot[:, k] = G[:, s]
            trans[:, k] = P[:, s]
            offsets[k] = P[0, s]
            channels.append(ROOT_CHANNELS)
            continue
        conj = G[:, p] * np.array([1.0, -1.0, -1.0, -1.0])
        rot[:, k] = multiply(conj, G[:, s])
        Rp = quat_to_matrix(G[:, p])
        local_t = np.einsum("nba,nb->na", Rp, P[:, s] - P[:, p])  # R_p^T (p_s - p_p)
        gap = float(np.linalg.norm(local_t - offset[s], axis=-1).max())
        gaps[labels[s]] = gap
        offsets[k] = offset[s]
        if gap > tol:
            trans[:, k] = local_t
            animated.append(labels[s])
            channels.append(ANIMATED_CHANNELS)
        else:
            trans[:, k] = offset[s]
            channels.append(JOINT_CHANNELS)
    if animated:
        worst = max(animated, key=lambda s: gaps[s])
        warnings.append(
            f"segment lengths vary: {len(animated)} joint(s) move up to {gaps[worst] * 1000:.3g} mm ({worst}) "
            f"away from their connector points (tolerance {tol * 1000:g} mm); they get position channels so that "
            "forward kinematics reproduces the file's segment positions"
        )

    children = {parent[s] for s in range(S) if parent[s] >= 0}
    end_sites = []
    for k, s in enumerate(order):
        if s in children:
            continue
        own = joint_of[s]["connector2"][1] if s in joint_of else None
        pts = [(float(np.linalg.norm(v)), name, v) for name, v in segs[s]["points"].items() if name != own]
        if pts:
            d, _, v = max(pts, key=lambda x: x[0])
            if d > 0:
                x, y, z = (float(c) for c in v)
                end_sites.append((k, (x, y, z)))

    sk = Skeleton(
        names=tuple(labels[s] for s in order),
        parents=np.array([-1 if parent[s] < 0 else new_index[parent[s]] for s in order]),
        offsets=offsets,
        channels=tuple(channels),
        end_sites=tuple(end_sites),
        meta={"format": "mvnx", "length_unit_cm": 100.0, "up_axis": "Z",
              "points": {labels[s]: {n: tuple(map(float, v)) for n, v in segs[s]["points"].items()} for s in order}},
    )
    meta = {
        "format": "mvnx",
        "frame_time": 1.0 / rate,
        "length_unit_cm": 100.0,
        "up_axis": "Z",
        "mvnx_version": r.version,
        "mvn_version": r.mvn_version,
        "subject": r.subject.get("label"),
        "configuration": r.subject.get("configuration"),
        "skipped_frames": dict(r.skipped),
        "n_skipped_frames": int(sum(r.skipped.values())),
        "times_from": times_from,
        "joint_gap_m": gaps,
        "max_joint_gap_m": max(gaps.values(), default=0.0),
        "gap_tolerance_m": tol,
        "animated_offsets": animated,
        "warnings": warnings,
    }
    try:
        return Motion(sk, times, rot, trans, None, src, meta)
    except InvalidSignalError as exc:
        raise MocapFormatError(src, None, str(exc)) from None


def _times(r: _Reader, rate: float | None, src: str, warnings: list[str]) -> tuple[np.ndarray, float, str]:
    """Frame times (s), the rate and where they came from (``rate``: the subject's frameRate, if any)."""
    N = len(r.orient)
    has_t = all(t is not None for t in r.times_ms)
    t_file = np.array(r.times_ms, dtype=np.float64) / 1000.0 if has_t else None
    if t_file is not None and N > 1:
        bad = np.flatnonzero(np.diff(t_file) <= 0)
        if bad.size:
            n = int(bad[0]) + 1
            raise MocapFormatError(src, r.frame_lines[n], f"frame time {r.times_ms[n]:g} ms is not after the previous "
                                                         f"frame's {r.times_ms[n - 1]:g} ms")
    if rate is None:
        if t_file is None:
            raise MocapFormatError(src, r.subject_line, "no frameRate on <subject> and no time attribute on the frames")
        if N < 2:
            raise MocapFormatError(
                src, r.subject_line, "no frameRate on <subject> and a single frame: the rate is unknown"
            )
        return t_file, 1.0 / float(np.median(np.diff(t_file))), "time attribute (no frameRate)"
    if all(i is not None for i in r.indices):
        k = np.array(r.indices, dtype=np.float64)
        if N > 1 and np.any(np.diff(k) <= 0):
            n = int(np.flatnonzero(np.diff(k) <= 0)[0]) + 1
            raise MocapFormatError(
                src, r.frame_lines[n], f"frame index {r.indices[n]} does not follow index {r.indices[n - 1]}"
            )
        k -= k[0]
    else:
        k = np.arange(N, dtype=np.float64)
    t0 = t_file[0] if t_file is not None else 0.0
    ideal = t0 + k / rate
    if t_file is not None:
        dev = float(np.abs(t_file - ideal).max())
        if dev > 0.0005 + 1e-9:  # whole milliseconds round by at most 0.5 ms
            warnings.append(f"frame times differ from frameRate {rate:g} Hz by up to {dev * 1000:.3g} ms; "
                            "the frames' time attribute is used")
            return t_file, rate, "time attribute"
    if not np.all(np.isfinite(ideal)):
        raise MocapFormatError(src, r.subject_line, f"frameRate {rate!r} gives non-finite frame times")
    return ideal, rate, "frameRate"
