"""Marker panels of the scene: positions, and the piecewise polynomials of ``mocapkit filter --json``
evaluated at the marker file's times with their knots (the start of every piece after the first)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mocapkit.errors import MocapFormatError
from mocapkit.markers import Markers
from mocapkit.view.arrays import encode_array


def read_filter_json(path: Path) -> list[dict]:
    """The signals of a ``filter --json`` output (its list, or a record with ``signals``)."""
    from mocapkit.view.json_input import read_json

    doc = read_json(path, "filter JSON")
    sigs = doc.get("signals") if isinstance(doc, dict) else doc
    if not isinstance(sigs, list) or not all(isinstance(s, dict) for s in sigs):
        raise MocapFormatError(str(path), None, "expected the output of `mocapkit filter --json` (a list of signals)")
    return sigs


def _evaluate(pieces: list[dict], axis: int, n_axes: int, t: np.ndarray, where: str) -> np.ndarray:
    """One axis of the pieces at times ``t`` (NaN outside every piece: gaps are not bridged)."""
    out = np.full(len(t), np.nan)
    for p in pieces:
        try:
            t0, t1 = float(p["t0"]), float(p["t1"])
            c = p["coeffs"]
            c = np.asarray(c[axis] if n_axes > 1 else c, dtype=np.float64)
        except (KeyError, TypeError, ValueError, IndexError):
            raise MocapFormatError(where, None, "a piece needs t0, t1 and coeffs (as `filter --json` writes)") from None
        if c.ndim != 1 or not np.isfinite(c).all():
            if c.ndim == 1 and np.isnan(c).all():
                continue  # a chunk with no sample (all missing): nothing to draw
            raise MocapFormatError(where, None, f"piece at t0 = {t0}: coefficients must be finite numbers")
        sel = (t >= t0) & (t <= t1)
        out[sel] = np.polynomial.polynomial.polyval(t[sel] - t0, c)
    return out


def fitted_positions(mk: Markers, signals: list[dict], where: str) -> tuple[np.ndarray, list[dict]]:
    """``(fitted (n, M, 3) NaN where not fitted, knots per marker)`` from the filter's signals."""
    n, M = mk.positions.shape[:2]
    fitted = np.full((n, M, 3), np.nan)
    knot_times: dict[int, set] = {}
    t = np.asarray(mk.times, dtype=np.float64)
    for s in signals:
        if "pieces" not in s:
            continue  # a signal the filter could not fit
        comps = s.get("components") or []
        for axis, comp in enumerate(comps):
            label, _, ax = str(comp).rpartition("_")
            if label not in mk.labels or ax not in ("x", "y", "z"):
                raise MocapFormatError(where, None, f"signal {s.get('name')!r}: component {comp!r} is no marker axis "
                                       f"of this file (markers: {', '.join(mk.labels[:8])}...)")
            m = mk.labels.index(label)
            vals = _evaluate(s["pieces"], axis, len(comps), t, where)
            if np.isfinite(vals).any() and (t[0] > float(s["pieces"][0]["t0"]) + 1e-6
                                            or t[-1] < float(s["pieces"][-1]["t1"]) - 1e-6):
                raise MocapFormatError(where, None, f"signal {s.get('name')!r} spans "
                                       f"{s['pieces'][0]['t0']}..{s['pieces'][-1]['t1']} s, beyond the marker file's "
                                       f"{t[0]:g}..{t[-1]:g} s: not a filter of this file")
            fitted[:, m, "xyz".index(ax)] = vals
            knot_times.setdefault(m, set()).update(float(p["t0"]) for p in s["pieces"][1:])
    knots: list[dict[str, Any]] = []
    for m, tset in sorted(knot_times.items()):
        ts = np.array(sorted(tset))
        idx = np.clip(np.searchsorted(t, ts - 1e-9), 0, n - 1)
        knots.append({"marker": m, "times": ts.tolist(),
                      "positions": [[None if not np.isfinite(v) else float(v) for v in fitted[i, m]] for i in idx]})
    return fitted, knots


def marker_panel(pid: str, path: Path, mk: Markers, fitted: np.ndarray | None, knots: list[dict]) -> dict:
    # a C3D says which axis is up on screen (POINT:Y_SCREEN); OpenSim's TRC files are y-up; Qualisys and
    # Vicon exports (and C3D files that do not say) z-up
    axis = str(mk.meta.get("up_axis", "")).lstrip("+-").lower()
    up = axis if axis in ("y", "z") else ("y" if path.suffix.lower() == ".trc" else "z")
    return {"id": pid, "kind": "markers", "file": str(path), "name": path.name, "up": up,
            "times": encode_array(mk.times, "float64"), "labels": list(mk.labels), "unit": mk.units,
            "positions": encode_array(mk.positions), "fitted": None if fitted is None else encode_array(fitted),
            "knots": knots}
