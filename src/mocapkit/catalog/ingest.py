"""Batch rows (the issue-11 contract) into the catalog's tables.

Only the main process calls :func:`add_rows`: the batch's workers return rows, and the process that owns
the catalog writes them, in one transaction per call. Adding a row again replaces what it wrote before
(same :func:`run_id`): nothing is duplicated. A recording is keyed by its path, content hash and the
reading options it was read with (:func:`reading_key`), so the same bytes read at another rate or with
another skeleton are another recording row, never an overwrite.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import math
from collections.abc import Iterable

from mocapkit.catalog import schema
from mocapkit.catalog.engine import Catalog, utc_naive

#: the record's own fields that are not metrics (structure, not numbers)
_NOT_METRICS = {"recording", "signals", "segments", "outputs", "cuts", "warnings", "reference_cuts"}
_CHUNK = 500


def run_id(row: dict) -> str:
    """The run's key: ``row["run_id"]`` when the row has one, else the first 32 hex digits of the sha256
    of ``[job, input, content_hash, options_hash, mocapkit_version]`` — so the same job with the same
    options on the same bytes by the same version is one run (its latest row wins), and a changed file,
    option or version is a new run."""
    if row.get("run_id"):
        return str(row["run_id"])
    key = [row.get("job"), row.get("input"), row.get("content_hash"), row.get("options_hash"),
           row.get("mocapkit_version")]
    return hashlib.sha256(json.dumps(key, separators=(",", ":")).encode()).hexdigest()[:32]


def _number(v) -> float | None:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    v = float(v)
    return v if math.isfinite(v) else None


def _scalars(d: dict, skip=()) -> Iterable[tuple[str, float]]:
    """Numeric scalar fields of ``d`` (booleans are flags, not metrics); a nested dict of numbers (e.g.
    ``scores``) gives ``<field>.<key>``."""
    for k, v in d.items():
        if k in skip:
            continue
        x = _number(v)
        if x is not None:
            yield str(k), x
        elif isinstance(v, dict):
            for k2, v2 in v.items():
                x = _number(v2)
                if x is not None:
                    yield f"{k}.{k2}", x


def _signal_items(record: dict) -> list[tuple[str, dict]]:
    sig = record.get("signals")
    if isinstance(sig, dict):  # info on IMU data: {sensor: {...}}
        return [(str(k), v) for k, v in sig.items() if isinstance(v, dict)]
    if isinstance(sig, list):  # compress/filter: [{"name": ..., ...}]
        return [(str(v.get("name", k)), v) for k, v in enumerate(sig) if isinstance(v, dict)]
    return []


def reading_key(options: dict | str | None) -> tuple[str, str]:
    """``(reading_json, reading_hash)`` of a job's options (a dict, or their canonical JSON): the options of
    :func:`mocapkit.jobs.common.reading_options` as canonical JSON (``{}`` when none)."""
    from mocapkit.jobs.common import reading_options

    if isinstance(options, str):
        try:
            options = json.loads(options)
        except ValueError:
            options = None
    got = reading_options(options if isinstance(options, dict) else {})
    text = json.dumps(got, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return text, schema.reading_hash(text)


def recording_row(rec: dict, content_hash: str, reading: tuple[str, str], nbytes: int | None,
                  registered_at: dt.datetime) -> tuple:
    return (rec["path"], content_hash, reading[1], reading[0], rec.get("format"), rec.get("kind"),
            _number(rec.get("rate_hz")), rec.get("frames"), _number(rec.get("duration_s")), rec.get("subject"),
            rec.get("take"), nbytes, registered_at)


def channel_rows(rec: dict, content_hash: str, reading: tuple[str, str]) -> list[tuple]:
    return [(rec["path"], content_hash, reading[1], i, c.get("name"), c.get("component"), c.get("type"),
             c.get("tracked_point"), c.get("units")) for i, c in enumerate(rec.get("channels") or ())]


def _now() -> dt.datetime:
    return dt.datetime.now(dt.UTC).replace(tzinfo=None)


def put_recordings(catalog: Catalog, items: list[tuple]) -> int:
    """Insert or update recordings ``(R, content_hash, bytes, reading)`` (``reading``:
    :func:`reading_key`; ``(R, content_hash, bytes)`` means read without options) and their channels (call
    inside a transaction). A recording already present keeps its ``registered_at``. Returns the number
    written."""
    latest = {}
    for item in items:
        r, h, b = item[:3]
        reading = item[3] if len(item) > 3 else reading_key({})
        if h:
            latest[(r["path"], h, reading[1])] = (r, h, b, reading)
    if not latest:
        return 0
    keys = list(latest)
    first = {}
    for k in range(0, len(keys), _CHUNK):
        part = keys[k:k + _CHUNK]
        marks = ", ".join("?" for _ in part)
        _, rows = catalog.query(f"SELECT path, content_hash, reading_hash, registered_at FROM recordings WHERE "
                                f"content_hash IN ({marks})", [key[1] for key in part])
        first.update({(p, h, rh): t for p, h, rh, t in rows})
    key_cols = (("path", "TEXT"), ("content_hash", "TEXT"), ("reading_hash", "TEXT"))
    catalog.delete_keys("channels", key_cols, keys)
    catalog.delete_keys("recordings", key_cols, keys)
    now = _now()
    catalog.insert("recordings", [recording_row(r, h, rd, b, first.get((r["path"], h, rd[1]), now))
                                  for r, h, b, rd in latest.values()])
    catalog.insert("channels", [c for r, h, _, rd in latest.values() for c in channel_rows(r, h, rd)])
    return len(latest)


def input_bytes(path: str) -> int | None:
    """Size of an input as it is now: a file's bytes, a folder's regular files' bytes, else None."""
    import os
    import stat

    try:
        st = os.stat(path)
    except OSError:
        return None
    if stat.S_ISREG(st.st_mode):
        return st.st_size
    if not stat.S_ISDIR(st.st_mode):
        return None
    total = 0
    for d, _, names in os.walk(path):
        for n in names:
            try:
                s = os.stat(os.path.join(d, n))
            except OSError:
                continue
            if stat.S_ISREG(s.st_mode):
                total += s.st_size
    return total


def add_rows(catalog: Catalog, batch_rows: Iterable[dict]) -> dict:
    """Write batch rows (and the records in their ``record_json``) to the catalog in one transaction.

    Returns the number of rows written per table. Rows with the same :func:`run_id` replace each other
    (the last one given wins) and replace what an earlier call wrote for that run.
    """
    by_id: dict[str, dict] = {}
    for row in batch_rows:
        by_id[run_id(row)] = row
    metrics: list[tuple[str, str | None, str, float]]  # (run, signal or None, name, value)
    runs, metrics, segments, pieces, outputs, recs = [], [], [], [], [], []
    for rid, row in by_id.items():
        record = json.loads(row["record_json"]) if row.get("record_json") else None
        method = record.get("method") if isinstance(record, dict) else None
        warned = record.get("warnings") if isinstance(record, dict) else None
        reading = reading_key(row.get("options_json"))
        runs.append((rid, row.get("job"), method if isinstance(method, str) else None, row.get("input"),
                     row.get("content_hash"), reading[1] if row.get("content_hash") else None,
                     row.get("options_json"), row.get("options_hash"),
                     row.get("mocapkit_version"), utc_naive(row.get("started_at")), _number(row.get("seconds")),
                     row.get("status"), row.get("error"),
                     json.dumps(warned, allow_nan=False) if isinstance(warned, list) and warned else None))
        if not isinstance(record, dict):
            continue
        r = record.get("recording")
        if isinstance(r, dict) and row.get("content_hash"):
            r = {**r, "path": row.get("input") or r.get("path")}
            recs.append((r, row["content_hash"], input_bytes(r["path"]), reading))
        metrics += [(rid, None, k, v) for k, v in _scalars(record, _NOT_METRICS)]
        for name, item in _signal_items(record):
            metrics += [(rid, name, k, v) for k, v in _scalars(item, ("pieces",))]
            order = item.get("order")
            for i, p in enumerate(item.get("pieces") or ()):
                coeffs = p.get("coeffs")
                po = order if isinstance(order, int) else (len(coeffs) - 1 if isinstance(coeffs, list) else None)
                pieces.append((rid, name, i, _number(p.get("t0")), _number(p.get("t1")), po,
                               json.dumps(coeffs, allow_nan=False, separators=(",", ":"))))
        for i, s in enumerate(record.get("segments") or ()):
            segments.append((rid, i, _number(s.get("t0")), _number(s.get("t1")), s.get("frame0"), s.get("frame1"),
                             s.get("label"), record.get("method")))
        for i, o in enumerate(record.get("outputs") or ()):
            outputs.append((rid, i, o.get("path"), o.get("bytes"), o.get("format"), _number(o.get("bound")),
                            o.get("bound_unit")))
    ids = [(rid,) for rid in by_id]
    with catalog.transaction():
        for table in (*schema.RUN_TABLES, "runs"):
            catalog.delete_keys(table, (("run_id", "TEXT"),), ids)
        n_rec = put_recordings(catalog, recs)
        catalog.insert("runs", runs)
        catalog.insert("metrics", metrics)
        catalog.insert("segments", segments)
        catalog.insert("filter_pieces", pieces)
        catalog.insert("outputs", outputs)
    return {"runs": len(runs), "recordings": n_rec, "metrics": len(metrics), "segments": len(segments),
            "filter_pieces": len(pieces), "outputs": len(outputs)}
