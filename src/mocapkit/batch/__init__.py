"""``mocapkit batch``: one job over a whole database of recordings, on a local process pool or a Dask
cluster, with a journal, a Parquet result table and ``--resume`` (see :mod:`mocapkit.batch.engine`)."""

from mocapkit.batch.engine import BatchResult, run_batch
from mocapkit.jobs.inputs import Inputs, expand_inputs
from mocapkit.batch.worker import run_one

__all__ = ["BatchResult", "Inputs", "expand_inputs", "run_batch", "run_one"]
