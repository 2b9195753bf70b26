"""The batch's result table ``OUT/results.parquet``: one row per input (the batch row of the contract),
sorted by input path, written atomically through :mod:`mocapkit.io.atomic`."""

from __future__ import annotations

from pathlib import Path

from mocapkit.batch.worker import ROW_FIELDS

RESULTS_NAME = "results.parquet"


def _pyarrow():
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:  # pragma: no cover - pyarrow is in the batch extra
        from mocapkit.errors import MocapError

        raise MocapError("the batch results need pyarrow: pip install 'mocapkit[batch]'") from None
    return pa, pq


def schema():
    """The Parquet schema of a batch row (every column nullable where the contract allows None)."""
    pa, _ = _pyarrow()
    types = {"seconds": pa.float64()}
    return pa.schema([pa.field(name, types.get(name, pa.string()),
                               nullable=name in ("error", "content_hash", "record_json"))
                      for name in ROW_FIELDS])


def write_results(path: Path, rows: list[dict]) -> None:
    """Write ``rows`` (sorted by input, then job) as Parquet to ``path``, atomically."""
    pa, pq = _pyarrow()
    from mocapkit.io.atomic import atomic_write_bytes

    rows = sorted(rows, key=lambda r: (r["input"], r["job"]))
    table = pa.Table.from_pylist([{k: r.get(k) for k in ROW_FIELDS} for r in rows], schema=schema())
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    atomic_write_bytes(path, sink.getvalue().to_pybytes())


def read_results(path: Path) -> list[dict]:
    """The rows of a results table (empty when the file does not exist)."""
    _, pq = _pyarrow()
    p = Path(path)
    if not p.exists():
        return []
    return pq.read_table(p).to_pylist()
