"""``mocapkit batch``: one job over a whole database of recordings, on a local process pool or a Dask
cluster, with a journal, a Parquet result table and ``--resume`` (see :mod:`mocapkit.batch.engine`)."""

import importlib as _importlib

TYPE_CHECKING = False
if TYPE_CHECKING:  # what __getattr__ loads on first use, for type checkers and tests/import_graph.py
    from mocapkit.batch.engine import BatchResult, run_batch
    from mocapkit.batch.worker import run_one
    from mocapkit.jobs.inputs import Inputs, expand_inputs

#: module -> the names it gives the package on first use
_LAZY = {
    "mocapkit.batch.engine": ("BatchResult", "run_batch"),
    "mocapkit.jobs.inputs": ("Inputs", "expand_inputs"),
    "mocapkit.batch.worker": ("run_one",),
}
_WHERE = {name: module for module, names in _LAZY.items() for name in names}


def __getattr__(name: str):
    """A name of ``__all__``, imported from its module on first use (PEP 562) and then kept."""
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(_importlib.import_module(_WHERE[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


__all__ = ["BatchResult", "Inputs", "expand_inputs", "run_batch", "run_one"]
