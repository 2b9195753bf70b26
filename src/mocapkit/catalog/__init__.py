"""The motion catalog: recordings, runs and their results in DuckDB (a file) or PostgreSQL (a server).

``open_catalog(url)`` opens it (a ``postgresql://`` URL or a DuckDB file path) and makes the tables of
:mod:`mocapkit.catalog.schema`; :func:`mocapkit.catalog.ingest.add_rows` writes batch rows (only the main
process writes); :func:`mocapkit.catalog.register.import_folder` registers recordings without a job;
``Catalog.query(sql)`` returns ``(columns, rows)``.
"""

from mocapkit.catalog.engine import Catalog, connect

open_catalog = connect

__all__ = ["Catalog", "connect", "open_catalog"]
