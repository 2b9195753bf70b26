"""The catalog's tables, one portable schema for DuckDB and PostgreSQL.

Column types are the SQL both engines spell alike (``TEXT``, ``BIGINT``, ``DOUBLE PRECISION``, ``BOOLEAN``,
``TIMESTAMP``); times are UTC without a zone. ``schema_version`` holds :data:`SCHEMA_VERSION`; a catalog
written by another version is refused rather than guessed at.

Tables (``recording`` = ``(path, content_hash)``; a file that changes is a new recording, the old one stays):

``recordings``
    one row per recording: the ``"recording"`` dict of the job records
    (:func:`mocapkit.jobs.recording.describe`) plus the size in ``bytes`` and when it was first
    ``registered_at``.
``channels``
    the recording's channels as BIDS-Motion's ``channels.tsv`` names them, ``idx`` = 0-based position.
``runs``
    one row per job run (a batch row of the contract): ``run_id`` (see
    :func:`mocapkit.catalog.ingest.run_id`), job, the record's ``method`` (compress, segment; else NULL),
    input ``path`` and ``content_hash`` (``NULL`` when the
    input could not be read), options as canonical JSON and its hash, mocapkit version, ``started_at``,
    ``seconds``, ``status`` (``ok``/``error``), the one-line ``error`` and the record's ``warnings`` (what the
    reader or the job found odd but handled, a JSON list; NULL when none).
``metrics``
    the numeric scalar fields of a run's record (``signal`` NULL) and of each item of its ``signals``
    (``signal`` = the item's name): ``icr``, ``aad_deg``, ``max_position_error_cm``, ``n_knots``...
``segments``
    a segment run's segments: ``idx``, ``t0``/``t1`` (s), ``frame0``/``frame1``, ``label`` (NULL unless
    reference labels were given) and the segmenter ``method``.
``filter_pieces``
    a filter run's polynomial pieces per signal: ``idx``, ``t0``/``t1`` (s), ``poly_order``, ``coeffs_json``
    (the coefficients as JSON); the knots are the ``t0`` of the pieces after the first.
``outputs``
    files a run wrote: ``path``, ``bytes``, ``format``, the guaranteed ``bound`` and its ``bound_unit``.
"""

from __future__ import annotations

SCHEMA_VERSION = 1

T, I, F, B, TS = "TEXT", "BIGINT", "DOUBLE PRECISION", "BOOLEAN", "TIMESTAMP"

#: table -> ((column, type), ...) in insert order
TABLES: dict[str, tuple[tuple[str, str], ...]] = {
    "recordings": (("path", T), ("content_hash", T), ("format", T), ("kind", T), ("rate_hz", F),
                   ("frames", I), ("duration_s", F), ("subject", T), ("take", T), ("bytes", I),
                   ("registered_at", TS)),
    "channels": (("path", T), ("content_hash", T), ("idx", I), ("name", T), ("component", T), ("type", T),
                 ("tracked_point", T), ("units", T)),
    "runs": (("run_id", T), ("job", T), ("method", T), ("path", T), ("content_hash", T), ("options_json", T),
             ("options_hash", T), ("mocapkit_version", T), ("started_at", TS), ("seconds", F), ("status", T),
             ("error", T), ("warnings", T)),
    "metrics": (("run_id", T), ("signal", T), ("name", T), ("value", F)),
    "segments": (("run_id", T), ("idx", I), ("t0", F), ("t1", F), ("frame0", I), ("frame1", I), ("label", T),
                 ("method", T)),
    "filter_pieces": (("run_id", T), ("signal", T), ("idx", I), ("t0", F), ("t1", F), ("poly_order", I),
                      ("coeffs_json", T)),
    "outputs": (("run_id", T), ("idx", I), ("path", T), ("bytes", I), ("format", T), ("bound", F),
                ("bound_unit", T)),
}

#: primary keys (NOT NULL columns); metrics has none (``signal`` is NULL for the record's own fields)
PRIMARY_KEYS = {
    "recordings": ("path", "content_hash"),
    "channels": ("path", "content_hash", "idx"),
    "runs": ("run_id",),
    "segments": ("run_id", "idx"),
    "filter_pieces": ("run_id", "signal", "idx"),
    "outputs": ("run_id", "idx"),
}

#: tables whose rows belong to one run (replaced together when the run is added again)
RUN_TABLES = ("metrics", "segments", "filter_pieces", "outputs")

INDEXES = (
    "CREATE INDEX IF NOT EXISTS runs_recording ON runs (path, content_hash)",
    "CREATE INDEX IF NOT EXISTS metrics_run ON metrics (run_id)",
)


def ddl() -> list[str]:
    """``CREATE TABLE IF NOT EXISTS`` statements of every table, then the indexes."""
    out = ["CREATE TABLE IF NOT EXISTS schema_version (version BIGINT NOT NULL)"]
    for table, cols in TABLES.items():
        key = PRIMARY_KEYS.get(table, ())
        parts = [f"{c} {t}" + (" NOT NULL" if c in key else "") for c, t in cols]
        if key:
            parts.append(f"PRIMARY KEY ({', '.join(key)})")
        out.append(f"CREATE TABLE IF NOT EXISTS {table} ({', '.join(parts)})")
    return out + list(INDEXES)


def columns(table: str) -> tuple[str, ...]:
    return tuple(c for c, _ in TABLES[table])
