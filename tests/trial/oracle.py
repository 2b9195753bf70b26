"""Classify a run, and the checks that need more than its exit code.

Outcomes, worst first (a case gets the worst that applies):

``input_modified``  an input file's bytes changed;
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
``error``           a clean error; ``ok`` a valid result.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import warnings
from pathlib import Path

import numpy as np

ORDER = ["input_modified", "device_replaced", "crash", "memory", "hang", "silent_wrong", "bad_error",
         "error_unnamed", "error", "ok"]
FAILING = {"input_modified", "device_replaced", "crash", "memory", "hang", "silent_wrong"}

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


def strict_json(text: str):
    """``json.loads`` refusing ``NaN``/``Infinity``; raises ``ValueError``."""
    def bad(c):
        raise ValueError(f"non-standard JSON constant {c}")

    return json.loads(text, parse_constant=bad)


def check_stdout(run) -> str | None:
    """A problem with a successful run's stdout, or ``None``."""
    out = run.out_text
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
                from mocapkit.io.gltf import read_gltf

                obj = read_gltf(path)
            elif fmt == "points":
                from mocapkit.io.imucsv import read_imu_csv

                obj = {"points": read_imu_csv(path)}
            elif fmt == "c3d_out":
                from mocapkit.io.c3d import read_c3d

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
    if isinstance(obj, dict):
        for k in sorted(obj):
            s = obj[k]
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
              ".glb": "glb", ".gltf": "gltf"}


def output_format(path: Path, argv: list[str]) -> str:
    """How to read an output back: points CSV of compress, marker CSV of convert/filter, or by suffix."""
    s = path.suffix.lower()
    if s == ".csv":
        if argv[0] == "compress":
            return "points"
        return "any"
    return OUTPUT_FMT.get(s) or "any"
