"""The ``filter`` job: piecewise polynomials fitted to marker trajectories or CSV columns
(:mod:`mocapkit.filters`), keeping discontinuities such as catches, throws and heel strikes."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mocapkit.errors import InvalidParameterError
from mocapkit.jobs.common import Progress, check_outputs, no_progress, output_entry, recording


def _inputs(path: Path, kind: str, markers: str | None, columns: str | None):
    """``([(name, times, values (N, D), component names)], loaded object)`` to filter; ``kind`` is
    :func:`mocapkit.io.loaders.kind_of` of ``path``."""
    out = []
    if markers is not None and columns is not None:
        raise InvalidParameterError("give --markers or --columns, not both")
    is_markers = kind == "markers"
    if is_markers and columns is not None and path.suffix.lower() == ".csv":
        from mocapkit.io.markers.vicon_csv import is_vicon_csv

        is_markers = is_vicon_csv(path)  # --columns reads a wide marker CSV as plain columns
    if is_markers and columns is not None:
        raise InvalidParameterError(f"{path} is a marker file: choose markers with --markers NAME[:xyz],... "
                                    "(--columns is for plain CSV files)")
    if is_markers:
        from mocapkit.io.loaders import load_markers

        mk = load_markers(path)
        wanted = [w.strip() for w in markers.split(",")] if markers else list(mk.labels)
        for w in wanted:
            # labels may contain ':' themselves (Vicon's "Subject:Marker"): a suffix is a component
            # selection only when the whole string is not a label
            name, comp = (w, "") if w in mk.labels else (w.rpartition(":")[0] or w,
                                                         w.rpartition(":")[2] if ":" in w else "")
            if name not in mk.labels:
                raise InvalidParameterError(f"{path}: no marker {name!r} (markers: {', '.join(mk.labels[:12])}...)")
            comps = comp.lower() or "xyz"
            if any(c not in "xyz" for c in comps):
                raise InvalidParameterError(f"{w!r}: components are x, y, z (e.g. {name}:z)")
            cols = ["xyz".index(c) for c in comps]
            out.append((w, mk.times, mk.positions[:, mk.labels.index(name)][:, cols],
                        [f"{name}_{c}" for c in comps]))
        return out, mk
    if markers is not None:
        raise InvalidParameterError(f"{path}: --markers needs a C3D, Qualisys TSV or marker CSV file")
    if kind not in ("imu", "table") or path.suffix.lower() not in (".csv", ".txt"):
        raise InvalidParameterError(f"{path}: filter reads marker files (C3D, TSV, TRC, marker CSV) or a CSV "
                                    "with a time column; for skeletal motion, convert it or segment it")
    # a plain CSV with a header: a time column (first) and named columns (strict, bounded: io/text/timetable.py)
    from mocapkit.io.text.timetable import read_time_table

    tab = read_time_table(path)
    names = [c.strip() for c in columns.split(",")] if columns else tab.columns
    for c in names:
        if c not in tab.columns:
            raise InvalidParameterError(f"{path}: no column {c!r} (columns: {', '.join(tab.columns)})")
        out.append((c, tab.times, tab.values[:, [tab.columns.index(c)]], [c]))
    return out, tab


def _table_recording(tab, path: Path) -> dict:
    """The catalog's description of a plain time table (no model object holds one): one MISC channel
    per column, in BIDS-Motion's terms (the file says nothing of units)."""
    t = np.asarray(tab.times, dtype=float)
    steps = np.diff(t)
    return {"path": str(path), "format": "csv", "kind": "table",
            "rate_hz": float(1.0 / np.median(steps)) if len(steps) else None, "frames": int(len(t)),
            "duration_s": float(t[-1] - t[0]) if len(t) else 0.0, "subject": None, "take": None,
            "channels": [{"name": c, "component": "n/a", "type": "MISC", "tracked_point": "n/a", "units": "n/a"}
                         for c in tab.columns]}


def check_options(order: int = 2, penalty: float | None = None, auto: bool = False, solver: str = "exact",
                  markers: str | None = None, columns: str | None = None) -> None:
    """The option checks that need no file."""
    if (penalty is None) == (not auto):
        raise InvalidParameterError("give exactly one of --penalty K or --auto")
    if order < 0:
        raise InvalidParameterError("--order must be >= 0")
    if solver not in ("exact", "iterative"):
        raise InvalidParameterError(f"--solver {solver!r}: exact or iterative")
    if markers is not None and columns is not None:
        raise InvalidParameterError("give --markers or --columns, not both")


def filter_job(path: Path, *, order: int = 2, penalty: float | None = None, auto: bool = False,
               solver: str = "exact", markers: str | None = None, columns: str | None = None,
               output: Path | None = None, plot: Path | None = None, progress: Progress = no_progress) -> dict:
    """Fit piecewise polynomials of ``order`` with knot cost ``penalty`` (or ``auto``) and return the
    record: ``signals`` holds ``mocapkit filter --json``'s items (knots and polynomial pieces).

    ``output``: the filtered values at the input times (``.csv``; ``.c3d``/``.trc`` for a marker file, the
    input's markers with the filtered ones replaced). ``plot``: a PNG of the first filtered signal.
    """
    from mocapkit.filters.api import fit
    from mocapkit.io.atomic import is_device_or_pipe
    from mocapkit.io.loaders import kind_of

    check_options(order, penalty, auto, solver, markers, columns)
    path = Path(path)
    output = None if output is None else Path(output)
    check_outputs(path, (output, "--output"), (None if plot is None else Path(plot), "--plot"))
    suffix = None if output is None else output.suffix.lower()
    # /dev/null, /dev/stdout, a FIFO: written into, as CSV
    if output is not None and suffix == "" and is_device_or_pipe(output):
        suffix = ".csv"
    if suffix not in (None, ".csv", ".c3d", ".trc"):
        raise InvalidParameterError(f"{output}: filter writes .csv, or .c3d/.trc for a marker file")
    marker_out = suffix in (".c3d", ".trc")
    kind = kind_of(path)  # sniffs a CSV's first lines: once
    if marker_out and (kind != "markers" or columns is not None):
        raise InvalidParameterError(f"{output}: a .c3d/.trc output needs a marker file as input")
    signals, loaded = _inputs(path, kind, markers, columns)
    if marker_out and any(comps != [f"{c[:-2]}_x", f"{c[:-2]}_y", f"{c[:-2]}_z"] for (_, _, _, comps) in signals
                          for c in comps[:1]):
        raise InvalidParameterError(f"{output}: a .c3d/.trc output needs whole markers (x, y, z), not components")
    results, warnings, notes, outputs = [], [], [], []
    with progress(f"filtering {path.name}", len(signals)) as update:
        for i, (name, t, Y, comps) in enumerate(signals):
            try:
                r = fit(t, Y, order, penalty, solver)
            except InvalidParameterError as e:  # e.g. a marker that is (almost) never seen: report, go on
                warnings.append(f"{name}: not filtered ({e}); written as missing")
                r = None
            results.append((name, t, Y, comps, r))
            update(i + 1)
    if all(r is None for *_, r in results):
        raise InvalidParameterError(f"{path}: no signal could be filtered ({'; '.join(warnings)})")
    for name, _t, _Y, _comps, r in results:
        for a, b in (r.unfitted if r is not None else []):
            warnings.append(f"{name}: samples at {a:g}..{b:g} s lie between long gaps and are too few to "
                            f"fit with order {order}: left out (NaN in the output)")

    def filtered(t, Y, r) -> np.ndarray:
        return np.full(Y.shape, np.nan) if r is None else np.asarray(r.evaluate(t)).reshape(Y.shape)

    is_marker_file = kind == "markers" and columns is None
    if marker_out:
        # the input's markers with the filtered ones replaced; labels, rate, units, gaps and analog kept
        from mocapkit.io.loaders import write_markers
        from mocapkit.markers import Markers

        assert output is not None and suffix is not None  # a .c3d/.trc suffix is an output's
        mk = loaded
        pos = np.array(mk.positions)
        done = []
        for _name, t, Y, comps, r in results:
            j = mk.labels.index(comps[0][:-2])
            pos[:, j] = np.where(np.isnan(Y), np.nan, filtered(t, Y, r))
            done.append(j)
        write_markers(Markers(mk.times, pos, mk.labels, mk.rate, units=mk.units, analog=mk.analog,
                              source=str(output), meta={"filtered_from": str(path)}), output)
        kept = len(mk.labels) - len(set(done))
        if kept:
            notes.append(f"{output}: {len(set(done))} markers filtered, {kept} copied unfiltered")
        outputs.append(output_entry(output, suffix[1:]))
    elif output is not None:
        from mocapkit.io.atomic import atomic_write_text

        t = results[0][1]
        cols = [filtered(tt, Y, r) for (_, tt, Y, _, r) in results]
        head = ["time"] + [c for (_, _, _, comps, _) in results for c in comps]
        if is_marker_file:  # keep the length unit in the column names
            head = ["time (s)"] + [f"{c} ({loaded.units})" for c in head[1:]]
        body = np.column_stack([t] + cols)
        atomic_write_text(output, ",".join(head) + "\n"
                          + "\n".join(",".join(repr(float(v)) for v in row) for row in body) + "\n")
        outputs.append(output_entry(output, "csv"))
    recs = []
    for name, _t, Y, comps, r in results:
        D = Y.shape[1]
        if r is None:
            recs.append({"name": name, "components": comps, "order": order, "error": "not filtered"})
            continue
        recs.append({
            "name": name, "components": comps, "order": order, "penalty": r.penalty, "solver": r.solver,
            "loss": r.loss, "iterative_loss": r.iterative_loss, "knot_cost": r.knot_cost, "n_knots": r.n_knots,
            "pieces": [{"t0": p.t0, "t1": p.t1,
                        "coeffs": p.coeffs[:, 0].tolist() if D == 1 else [p.coeffs[:, d].tolist() for d in range(D)]}
                       for p in r.pieces],
        })
    if plot is not None:
        from mocapkit.plot import plot_ppa

        name, t, Y, comps, r = next(x for x in results if x[4] is not None)
        plot_ppa(t, Y[:, -1], r, Path(plot), title=f"{path.name}: {comps[-1]}")
        outputs.append(output_entry(Path(plot), "png"))
    from mocapkit.io.text.timetable import TimeTable

    if isinstance(loaded, TimeTable):
        described, read_warnings = _table_recording(loaded, path), list(loaded.warnings)
    else:
        described, read_warnings = recording(loaded, path), list(loaded.meta.get("warnings", []))
    return {"job": "filter", "file": str(path), "kind": "markers" if is_marker_file else "table",
            "order": order, "solver": solver, "auto": auto, "signals": recs, "warnings": read_warnings + warnings,
            "notes": notes, "outputs": outputs, "recording": described}
