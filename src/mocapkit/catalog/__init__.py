"""The motion catalog: recordings, runs and their results in DuckDB (a file) or PostgreSQL (a server).

``open_catalog(url)`` opens it (a ``postgresql://`` URL or a DuckDB file path) and makes the tables of
:mod:`mocapkit.catalog.schema`; :func:`mocapkit.catalog.ingest.add_rows` writes batch rows (only the main
process writes); :func:`mocapkit.catalog.register.import_folder` registers recordings without a job;
``Catalog.query(sql)`` returns ``(columns, rows)``.
"""

import importlib as _importlib

TYPE_CHECKING = False
if TYPE_CHECKING:  # what __getattr__ loads on first use, for type checkers and tests/import_graph.py
    from mocapkit.catalog.engine import Catalog, connect

    open_catalog = connect

#: name -> (module, its name there): the database drivers load on first use (PEP 562)
_WHERE = {"Catalog": ("mocapkit.catalog.engine", "Catalog"), "connect": ("mocapkit.catalog.engine", "connect"),
          "open_catalog": ("mocapkit.catalog.engine", "connect")}


def __getattr__(name: str):
    """A name of ``__all__``, imported from its module on first use and then kept."""
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    module, attr = _WHERE[name]
    value = getattr(_importlib.import_module(module), attr)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))

__all__ = ["Catalog", "connect", "open_catalog"]
