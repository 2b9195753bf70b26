"""The catalog's tables, one portable schema for DuckDB and PostgreSQL.

Column types are the SQL both engines spell alike (``TEXT``, ``BIGINT``, ``DOUBLE PRECISION``, ``BOOLEAN``,
``TIMESTAMP``); times are UTC without a zone. ``schema_version`` holds :data:`SCHEMA_VERSION`; a catalog
written by another version is refused rather than guessed at.

Tables (``recording`` = ``(path, content_hash, reading_hash)``: a file that changes, or the same bytes read
with other reading options — another rate, another skeleton —, is a new recording; the old one stays):

``recordings``
    one row per recording: the ``"recording"`` dict of the job records
    (:func:`mocapkit.jobs.recording.describe`) plus the size in ``bytes`` and when it was first
    ``registered_at``; ``reading_json`` the reading options it was read with
    (:func:`mocapkit.jobs.common.reading_options` as canonical JSON: ``{"asf": ..., "rate": 120.0}``,
    ``{}`` for none) and ``reading_hash`` its hash (:func:`reading_hash`). Rows of a version-1 catalog,
    whose reading options were not kept, have ``reading_json`` NULL and ``reading_hash`` ``'v1'``.
``channels``
    the recording's channels as BIDS-Motion's ``channels.tsv`` names them, ``idx`` = 0-based position.
``runs``
    one row per job run (a batch row of the contract): ``run_id`` (see
    :func:`mocapkit.catalog.ingest.run_id`), job, the record's ``method`` (compress, segment; else NULL),
    input ``path`` and ``content_hash`` (``NULL`` when the
    input could not be read), the ``reading_hash`` of the recording it read (join ``recordings`` on
    ``path, content_hash, reading_hash``), options as canonical JSON and its hash, mocapkit version, ``started_at``,
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

SCHEMA_VERSION = 2

# one-letter column types keep the table below readable
T, I, F, B, TS = "TEXT", "BIGINT", "DOUBLE PRECISION", "BOOLEAN", "TIMESTAMP"  # noqa: E741

#: table -> ((column, type), ...) in insert order
TABLES: dict[str, tuple[tuple[str, str], ...]] = {
    "recordings": (("path", T), ("content_hash", T), ("reading_hash", T), ("reading_json", T), ("format", T),
                   ("kind", T), ("rate_hz", F), ("frames", I), ("duration_s", F), ("subject", T), ("take", T),
                   ("bytes", I), ("registered_at", TS)),
    "channels": (("path", T), ("content_hash", T), ("reading_hash", T), ("idx", I), ("name", T), ("component", T),
                 ("type", T), ("tracked_point", T), ("units", T)),
    "runs": (("run_id", T), ("job", T), ("method", T), ("path", T), ("content_hash", T), ("reading_hash", T),
             ("options_json", T),
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
    "recordings": ("path", "content_hash", "reading_hash"),
    "channels": ("path", "content_hash", "reading_hash", "idx"),
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


def create_table(table: str, name: str | None = None) -> str:
    """``CREATE TABLE IF NOT EXISTS`` of ``table``'s columns and key, under ``name`` (default: ``table``)."""
    key = PRIMARY_KEYS.get(table, ())
    parts = [f"{c} {t}" + (" NOT NULL" if c in key else "") for c, t in TABLES[table]]
    if key:
        parts.append(f"PRIMARY KEY ({', '.join(key)})")
    return f"CREATE TABLE IF NOT EXISTS {name or table} ({', '.join(parts)})"


def ddl() -> list[str]:
    """``CREATE TABLE IF NOT EXISTS`` statements of every table, then the indexes."""
    return ["CREATE TABLE IF NOT EXISTS schema_version (version BIGINT NOT NULL)",
            *(create_table(t) for t in TABLES), *INDEXES]


def columns(table: str) -> tuple[str, ...]:
    return tuple(c for c, _ in TABLES[table])


#: ``reading_hash`` of the rows a version-1 catalog holds (read with options that were not kept)
V1_READING = "v1"


def reading_hash(reading_json: str) -> str:
    """The key of a recording's reading options: the first 32 hex digits of the sha256 of their JSON."""
    import hashlib

    return hashlib.sha256(reading_json.encode()).hexdigest()[:32]


def upgrade(from_version: int) -> list[str]:
    """The statements that bring a catalog of ``from_version`` to :data:`SCHEMA_VERSION` (run in one
    transaction by the catalog's engine); ``[]`` when there is no way (the catalog is then refused).

    1 -> 2: ``recordings`` and ``channels`` are rebuilt with ``reading_hash`` in their key (``'v1'``:
    options not kept; ``reading_json`` NULL), ``runs`` gets ``reading_hash`` = ``'v1'`` so its old rows
    still join their recordings."""
    if from_version != 1:
        return []
    out = ["DROP INDEX IF EXISTS runs_recording"]
    for table, keep in (("recordings", [c for c in columns("recordings") if c not in ("reading_hash", "reading_json")]),
                        ("channels", [c for c in columns("channels") if c != "reading_hash"])):
        out.append(create_table(table, f"{table}_v2"))
        out.append(f"INSERT INTO {table}_v2 (reading_hash, {', '.join(keep)}) SELECT '{V1_READING}', "
                   f"{', '.join(keep)} FROM {table}")
        out.append(f"DROP TABLE {table}")
        out.append(f"ALTER TABLE {table}_v2 RENAME TO {table}")
    out.append("ALTER TABLE runs ADD COLUMN reading_hash TEXT")
    out.append(f"UPDATE runs SET reading_hash = '{V1_READING}' WHERE content_hash IS NOT NULL")
    out += list(INDEXES)
    out.append(f"UPDATE schema_version SET version = {SCHEMA_VERSION}")
    return out
