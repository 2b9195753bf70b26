"""Classify a run, and the checks that need more than its exit code.

Outcomes, worst first (a case gets the worst that applies):

``input_modified``  an input file's bytes changed (the catalog of ``catalog query`` included);
``written_outside`` a file or folder appeared outside the case's output folder (a name read from a file,
                    a query or a manifest used as a path), or outside the folder the command was given;
``device_replaced`` an output that was a device, a FIFO or a symlink is no longer one, or a FIFO's
                    reader got nothing on success;
``crash``           a traceback, a signal, or an exit code other than 0 and 2;
``memory``          ``MemoryError`` under the address-space limit;
``hang``            still running at the timeout;
``silent_wrong``    exit 0 with an invalid result: non-strict JSON, ``nan``/``inf`` printed, a written
                    file that does not read back or holds non-finite values, a missing or partial output,
                    or data read differently from a mutated number without a warning (see
                    :mod:`tests.trial.mutators`);
``bad_error``       exit 2 but not one ``error:`` line (a usage box, several lines);
``error_unnamed``   one ``error:`` line that names neither the input file nor an option;
``error``           a clean error; ``ok`` a valid result;
``exceeded``        ``verify`` exit 1 whose record (or last line) says the bound is exceeded (the error it
                    reports is checked against an independent computation for points CSVs);
``partial``         ``batch`` exit 1: some inputs got error rows (the journal says which).
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import warnings
from pathlib import Path

import numpy as np

ORDER = ["input_modified", "written_outside", "device_replaced", "crash", "memory", "hang", "silent_wrong", "bad_error",
         "error_unnamed", "error", "partial", "exceeded", "ok"]
FAILING = {"input_modified", "written_outside", "device_replaced", "crash", "memory", "hang", "silent_wrong"}

_NONFINITE_WORD = re.compile(r"(?<![\w.])[-+]?(nan|NaN|NAN|inf|Inf|INF|Infinity|-Infinity)(?![\w])")


def worst(*outcomes: str) -> str:
    return min(outcomes, key=ORDER.index)


def sha(path: Path) -> str | None:
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError:
        return None


def classify_run(run, names: list[str]) -> tuple[str, str]:
    """``(outcome, detail)`` from the exit status and stderr alone."""
    err = run.err_text
    if run.timed_out:
        return "hang", f"no result after {run.seconds:.0f} s"
    if "MemoryError" in err or "out of memory" in err:  # the CLI may turn MemoryError into a message
        return "memory", f"exit {run.returncode} after {run.seconds:.1f} s, {run.maxrss_mb:.0f} MB: " + \
            run.first_error_line()
    if run.signal is not None:
        return "crash", f"killed by signal {run.signal}"
    if "Traceback (most recent call last)" in err:
        tail = [ln for ln in err.splitlines() if ln.strip()]
        return "crash", (tail[-1] if tail else "traceback")[:300]
    if run.returncode == 0:
        return "ok", ""
    if run.returncode == 1 and run.argv and run.argv[0] == "verify":
        return _verify_exit_1(run)
    if run.returncode == 1 and run.argv and run.argv[0] == "batch":
        last = [ln for ln in err.splitlines() if ln.strip()]
        if any(re.search(r"\b[1-9]\d* errors?\b", ln) for ln in last[-5:]):
            return "partial", " | ".join(last[-3:])[:300]
        return "crash", f"batch exit 1 without error rows: {' | '.join(last[-3:])[:250]}"
    if run.returncode == 2:
        lines = [ln for ln in err.splitlines() if ln.strip()]
        errs = [ln for ln in lines if ln.startswith("error:")]
        boxed = any(c in err for c in "╭╰│")
        if len(errs) != 1 or not lines or not lines[-1].startswith("error:") or boxed:
            return "bad_error", " | ".join(lines[-3:])[:300]
        line = errs[0]
        variants = set(names)
        for n in names:
            if n.startswith("--"):  # "--time-unit" may be named "time unit" or "time_unit"
                variants |= {n[2:], n[2:].replace("-", " "), n[2:].replace("-", "_")}
        if any(n and n in line for n in variants) or "--" in line:
            return "error", line[:300]
        return "error_unnamed", line[:300]
    return "crash", f"exit {run.returncode}: {run.first_error_line()}"


def _verify_exit_1(run) -> tuple[str, str]:
    """``verify`` exits 1 only for a bound exceeded: the JSON record says ``within_bound: false``, or the
    last line of the text says ``EXCEEDED``."""
    if "--json" in run.argv:
        try:
            rec = strict_json(run.out_text)
        except ValueError as e:
            return "crash", f"verify exit 1 and its stdout is not strict JSON: {str(e)[:120]}"
        if isinstance(rec, dict) and rec.get("within_bound") is False:
            return "exceeded", f"max {rec.get('max_error')} > bound {rec.get('bound')}"
        return "crash", f"verify exit 1 but the record says within_bound={rec.get('within_bound')!r}"
    text = (run.out_text + run.err_text).strip().splitlines()
    if any("EXCEEDED" in ln for ln in text):
        return "exceeded", next(ln for ln in text if "EXCEEDED" in ln)[:300]
    return "crash", f"verify exit 1 without a bound exceeded: {run.first_error_line()}"


def strict_json(text: str):
    """``json.loads`` refusing ``NaN``/``Infinity``; raises ``ValueError``."""
    def bad(c):
        raise ValueError(f"non-standard JSON constant {c}")

    return json.loads(text, parse_constant=bad)


def check_stdout(run) -> str | None:
    """A problem with a successful run's stdout, or ``None``."""
    out = run.out_text
    if run.argv[:2] == ["catalog", "query"]:  # the values the user's SQL asked for, NaN included
        if "--format" in run.argv and run.argv[run.argv.index("--format") + 1:][:1] == ["json"]:
            try:
                strict_json(out)
            except ValueError as e:
                return f"stdout is not strict JSON: {str(e)[:120]}"
        return None
    if "--json" in run.argv:
        try:
            strict_json(out)
        except ValueError as e:
            return f"stdout is not strict JSON: {str(e)[:120]}"
    elif run.argv and run.argv[0] == "stream":
        for i, ln in enumerate(out.splitlines()):
            cells = ln.split(",")
            try:
                vals = [float(c) for c in cells]
            except ValueError:
                if i == 0:
                    continue  # a header
                return f"stream line {i + 1} is not numbers: {ln[:80]!r}"
            if not all(math.isfinite(v) for v in vals):
                return f"stream line {i + 1} not finite: {ln[:80]!r}"
            if len(vals) == 5 and sum(v * v for v in vals[1:]) == 0.0:
                return f"stream line {i + 1} has a zero quaternion: {ln[:80]!r}"
        return None
    m = _NONFINITE_WORD.search(out)
    if m:
        return f"stdout shows {m.group()!r}: ...{out[max(0, m.start() - 60):m.end() + 20]!r}"
    return None


# --------------------------------------------------------------------------------------------------
# digests: what a reader returned, to compare runs (executed in a forked child)
# --------------------------------------------------------------------------------------------------


def _arr_digest(a) -> list:
    a = np.ascontiguousarray(np.asarray(a, dtype=float))
    a = np.where(np.isnan(a), np.nan, a) + 0.0  # one NaN pattern; -0 -> 0
    return [list(a.shape), hashlib.sha256(a.tobytes()).hexdigest()[:16]]


def digest(path: str, fmt: str, options: dict | None = None) -> dict:
    """Load ``path`` with the library and summarise what came back (run it in a child)."""
    from mocapkit.errors import MocapError

    options = dict(options or {})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            if fmt in ("glb", "gltf"):
                from mocapkit.io.formats.gltf import read_gltf

                obj = read_gltf(path)
            elif fmt == "points":
                from mocapkit.io.imu.signals import read_imu_csv

                obj = {"points": read_imu_csv(path)}
            elif fmt == "mkpoints":  # a tick-column points CSV, as verify (its one reader) reads it
                from mocapkit.jobs.verify import _read_points_csv

                pts = _read_points_csv(Path(path), "points")
                obj = {"table": {"times": pts.times, "values": np.column_stack(
                    [pts.values, pts.ticks, np.asarray(pts.gap_before, dtype=float)])}}
            elif fmt == "mkp":
                from mocapkit.jobs.readers import read_mkp

                pf = read_mkp(path)
                caught_losses = pf.losses()
                obj = {name: {"times": s.ticks, "values": s.values} for name, s in pf.streams.items()}
            elif fmt == "mkc":
                from mocapkit.jobs.readers import read_mkc

                obj = read_mkc(path)
            elif fmt == "c3d_out":
                from mocapkit.io.markers.c3d import read_c3d

                obj = read_c3d(path)
            else:
                import mocapkit

                obj = mocapkit.load(path, **options)
        except MocapError as e:
            return {"status": "error", "message": str(e)[:300]}
    arrays: dict[str, list] = {}
    nonfinite: list[str] = []
    warns = [str(w.message)[:200] for w in caught]

    def add(name, a, allow_nan=False):
        a = np.asarray(a, dtype=float)
        arrays[name] = _arr_digest(a)
        bad = ~np.isfinite(a)
        if allow_nan:
            bad &= ~np.isnan(a)
        if bad.any():
            nonfinite.append(name)

    meta_sources = []
    if fmt == "mkp":
        warns += [w[:200] for w in caught_losses]
    if isinstance(obj, dict):
        for k in sorted(obj):
            s = obj[k]
            if isinstance(s, dict):  # plain arrays (packets, a points table)
                add(f"{k}.times", s["times"], allow_nan=True)
                add(f"{k}.values", s["values"], allow_nan=True)
                continue
            add(f"{k}.times", s.times)
            add(f"{k}.values", s.values)
            meta_sources.append(s.meta)
    elif hasattr(obj, "skeleton"):
        add("times", obj.times)
        add("rotations", obj.rotations)
        add("translations", obj.translations)
        add("offsets", obj.skeleton.offsets)
        if obj.channel_values is not None:
            add("channel_values", obj.channel_values)
        meta_sources += [obj.meta, obj.skeleton.meta]
    elif hasattr(obj, "positions"):
        add("times", obj.times)
        add("positions", obj.positions, allow_nan=True)
        if getattr(obj, "rate", None) is not None:
            add("rate", [obj.rate])
        meta_sources.append(obj.meta)
    for meta in meta_sources:
        warns += [str(w)[:200] for w in (meta or {}).get("warnings", [])]
    return {"status": "ok", "arrays": arrays, "nonfinite": nonfinite, "warnings": warns}


def same_data(a: dict, b: dict) -> bool:
    return a.get("status") == b.get("status") == "ok" and a["arrays"] == b["arrays"]


OUTPUT_FMT = {".bvh": "bvh", ".csv": None, ".c3d": "c3d_out", ".trc": "trc", ".mot": "mot", ".sto": "sto",
              ".glb": "glb", ".gltf": "gltf", ".mkp": "mkp", ".mkc": "mkc"}


def output_format(path: Path, argv: list[str]) -> str:
    """How to read an output back: points CSV of compress, marker CSV of convert/filter, or by suffix."""
    s = path.suffix.lower()
    if s == ".csv":
        if argv[0] == "compress":
            return "points"
        return "any"
    return OUTPUT_FMT.get(s) or "any"


# --------------------------------------------------------------------------------------------------
# verify, checked independently: the SLERP decode of a points CSV at the original's samples (scipy)
# --------------------------------------------------------------------------------------------------


def _plain_points(path: str) -> tuple[list[str], np.ndarray] | None:
    """The header and numbers of a points CSV parsed with plain Python (``None``: not a plain table)."""
    try:
        lines = [ln.strip() for ln in Path(path).read_text(encoding="utf-8").splitlines() if ln.strip()]
    except (OSError, UnicodeDecodeError):
        return None
    if len(lines) < 2:
        return None
    head = [c.strip() for c in lines[0].split(",")]
    try:
        rows = [[float(c) for c in ln.split(",")] for ln in lines[1:]]
    except ValueError:
        return None
    if any(len(r) != len(head) for r in rows):
        return None
    a = np.array(rows, dtype=float)
    return (head, a) if np.isfinite(a).all() else None


def verify_reference(original: str, compressed: str, options: dict | None = None) -> dict:
    """The largest angle between the original's samples and the SLERP of the points of ``compressed`` (a
    points CSV: ``time,w,x,y,z`` placed at the original's times, or ``time,w,x,y,z,tick,gap_before`` placed at
    sample indices, never across a lost packet), with scipy's ``Slerp`` and ``Rotation``. ``{"status":
    "skip"}`` where the file is not a plain table of increasing times/ticks (verify must then refuse it or
    read it otherwise; not checked here)."""
    from scipy.spatial.transform import Rotation, Slerp

    import mocapkit
    from mocapkit.errors import MocapError

    parsed = _plain_points(compressed)
    if parsed is None:
        return {"status": "skip", "why": "not a plain numeric table"}
    head, a = parsed
    col = {c: k for k, c in enumerate(head)}
    if set(head) not in ({"time", "w", "x", "y", "z"}, {"time", "w", "x", "y", "z", "tick", "gap_before"}) \
            or len(set(head)) != len(head):
        return {"status": "skip", "why": f"header {head}"}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sig = mocapkit.load(original, **(options or {}))
    except MocapError as e:
        return {"status": "skip", "why": f"original: {e}"}
    if isinstance(sig, dict):
        if len(sig) != 1:
            return {"status": "skip", "why": "not one sensor"}
        sig = next(iter(sig.values()))
    q = a[:, [col["w"], col["x"], col["y"], col["z"]]]
    norms = np.linalg.norm(q, axis=1)
    if (norms < 1e-6).any() or (norms > 1e6).any():
        return {"status": "skip", "why": "a point that is no rotation"}
    orig = np.asarray(sig.values, dtype=float)
    if orig.ndim != 2 or orig.shape[1] != 4 or not np.isfinite(orig).all():
        return {"status": "skip", "why": "original is not quaternions"}
    ticks = "tick" in col
    at = np.arange(len(orig), dtype=float) if ticks else np.asarray(sig.times, dtype=float)
    place = a[:, col["tick"]] if ticks else a[:, col["time"]]
    if np.any(np.diff(place) <= 0) or (ticks and (np.any(place != np.round(place)) or place[0] < 0)):
        return {"status": "skip", "why": "points not increasing"}
    runs = [0, *(np.flatnonzero(a[1:, col["gap_before"]] != 0) + 1 if ticks else []), len(place)]
    err = np.full(len(at), np.nan)
    for lo, hi in zip(runs[:-1], runs[1:], strict=True):
        inside = (at >= place[lo]) & (at <= place[hi - 1])
        if not inside.any():
            continue
        rots = Rotation.from_quat(q[lo:hi][:, [1, 2, 3, 0]])
        dec = rots[np.zeros(inside.sum(), dtype=int)] if hi - lo == 1 else Slerp(place[lo:hi], rots)(at[inside])
        o = Rotation.from_quat(orig[inside][:, [1, 2, 3, 0]])
        err[inside] = np.degrees((o.inv() * dec).magnitude())
    ok = np.isfinite(err)
    return {"status": "ok", "max_deg": float(err[ok].max()) if ok.any() else None,
            "compared": int(ok.sum()), "samples": len(at)}


def verify_disagreement(rec: dict, ref: dict, bound: float | None, tol_deg: float = 1e-6) -> str | None:
    """What ``verify``'s record gets wrong against :func:`verify_reference`, or ``None``."""
    if ref.get("status") != "ok":
        return None
    if rec.get("compared_samples") != ref["compared"]:
        return f"verify compared {rec.get('compared_samples')} samples, an independent decode {ref['compared']}"
    mine, theirs = ref["max_deg"], rec.get("max_error")
    if mine is None or theirs is None:
        return None if mine is theirs else f"verify's max error {theirs}, independent {mine}"
    if abs(mine - theirs) > tol_deg + 1e-9 * abs(mine):
        return f"verify's max error {theirs:.9g} deg, an independent SLERP decode gives {mine:.9g} deg"
    if bound is not None and rec.get("within_bound") and mine > bound + tol_deg:
        return f"verify says within {bound} deg, the decode is {mine:.9g} deg off"
    return None


#: what a command on a damaged ``.mkp`` must say (in its text or its record) when the file lost packets
_DAMAGE_WORDS = ("dropped", "lost packet sequence", "stream is missing", "cut short")


def damage_reported(run) -> bool:
    """The command told the user about lost or damaged packets: a non-zero count or a loss line."""
    text = run.out_text + run.err_text
    if re.search(r"\b[1-9]\d* (packets? )?(lost|damaged)", text) or re.search(r"[1-9]\d* damaged", text):
        return True
    if re.search(r'"(damaged_packets|lost_packets|samples_not_decoded)": [1-9]', text):
        return True
    return any(w in text for w in _DAMAGE_WORDS)
