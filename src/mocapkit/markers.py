"""Optical marker trajectories: the :class:`Markers` data model and :func:`make_unique_labels`.

A :class:`Markers` holds ``N`` frames of ``M`` labelled 3-D marker positions, ``NaN`` where a marker
is missing (occluded, not reconstructed), plus optional analog channels recorded alongside.

This module touches no file and imports nothing from :mod:`mocapkit.io`. The readers and writers live
there (they all return :class:`Markers` and raise only :class:`mocapkit.errors.MocapFormatError` for
bad files):

* ``.c3d``: :func:`mocapkit.io.markers.c3d.read_c3d` (ezc3d, after a structural pre-check);
* ``.tsv``: :func:`mocapkit.io.markers.qtm.read_qtm_tsv` (Qualisys QTM 3-D TSV export);
* ``.trc``: :func:`mocapkit.io.markers.opensim.read_trc` (OpenSim TRC);
* ``.csv``: :func:`mocapkit.io.markers.vicon_csv.read_vicon_csv` for a Vicon Nexus export (first line
  ``Trajectories`` or ``Devices``), else :func:`mocapkit.io.markers.wide_csv.read_markers_csv`, the wide CSV
  of :func:`mocapkit.io.markers.wide_csv.write_markers_csv`.

:func:`mocapkit.io.load_markers` (these four) and :func:`mocapkit.io.write_markers` (``.c3d``, ``.trc``,
``.csv``) dispatch by suffix.

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

import math
import re
from dataclasses import dataclass, field
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from mocapkit.errors import InvalidSignalError

__all__ = ["Markers", "make_unique_labels"]

_CONTROL_RE = re.compile(r"[\x00-\x1f\x7f\ud800-\udfff]")


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
                       prefix: str = "unnamed") -> tuple[tuple[str, ...], list[dict[str, Any]]]:
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
    fixes: list[dict[str, Any]] = []
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


_A = TypeVar("_A", bound=np.ndarray[Any, Any])


def _readonly(a: _A) -> _A:
    a.setflags(write=False)
    return a


def _check_analog(analog: dict[str, Any], n_frames: int) -> dict[str, Any]:
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

    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    labels: tuple[str, ...]
    rate: float
    units: str = "mm"
    analog: dict[str, Any] | None = field(default=None, compare=False)
    source: str = ""
    meta: dict[str, Any] = field(default_factory=dict, compare=False)

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
            dup = None
            for lab in labels:
                if lab in seen:
                    dup = lab
                    break
                seen.add(lab)
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
    def missing(self) -> NDArray[np.bool_]:
        """``(N, M)`` bool: ``True`` where the marker is missing."""
        gone: NDArray[np.bool_] = np.isnan(self.positions[:, :, 0])
        return gone

    def index(self, label: str) -> int:
        """Column of ``label`` (``KeyError`` naming the known labels when absent)."""
        try:
            return self.labels.index(label)
        except ValueError:
            shown = ", ".join(self.labels[:10]) + (", ..." if len(self.labels) > 10 else "")
            raise KeyError(f"no marker {label!r}; markers: {shown}") from None

    def marker(self, label: str) -> NDArray[np.float64]:
        """``(N, 3)`` read-only view of one marker's trajectory."""
        return self.positions[:, self.index(label), :]
