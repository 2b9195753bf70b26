"""The batch engine: the inputs of a batch through one job on a local process pool or a Dask cluster.

The main process expands the inputs, decides what ``--resume`` keeps, starts the engine, appends each
finished row to the journal (:mod:`mocapkit.batch.journal`), reports progress, writes the result table
(:mod:`mocapkit.batch.results`) and, with ``db``, hands the rows to the catalog. Workers only run
:func:`mocapkit.batch.worker.run_one`; they never touch the journal, the table or the database.

Engines (both yield rows as inputs finish):

- ``local``: :class:`concurrent.futures.ProcessPoolExecutor` with N workers started by ``forkserver``
  (no fork of a main process that may hold threads), at most 2·N inputs in flight. A worker that dies
  (a crash of compiled code, a kill, the OOM killer) breaks the pool: the inputs that were in flight are
  then run again each in a pool of its own, so the one that kills its worker is named in an error row
  and the others get their normal rows; the batch goes on with a new pool.
- ``dask``: :class:`distributed.Client` on ``scheduler`` (``tcp://HOST:PORT``) or on a
  :class:`distributed.LocalCluster` of N single-threaded worker processes on 127.0.0.1. A task the
  cluster cannot finish (``KilledWorker`` after a worker died on it repeatedly, a lost connection)
  becomes an error row.
"""

from __future__ import annotations

import contextlib
import itertools
import os
import time
from collections import deque
from collections.abc import Callable, Generator, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from mocapkit.batch.journal import JOURNAL_NAME, Journal, read_journal
from mocapkit.batch.output_guard import OutputGuard
from mocapkit.batch.results import RESULTS_NAME, read_results, write_results
from mocapkit.batch.worker import configure_numba_cache, failed_row, ignore_interrupts, options_hash, run_one
from mocapkit.errors import InvalidParameterError, MocapError, error_line
from mocapkit.jobs import batch_output
from mocapkit.jobs.inputs import expand_inputs, output_bases

ENGINES = ("local", "dask")
#: a compress job's controls (one per input: a batch may give them per kind or per file)
CONTROLS = ("threshold", "target_icr", "max_angle", "max_position_error")
#: the error of an input whose worker process died while running it (alone in its own pool)
WORKER_DIED = "the worker process died while processing this input (it crashed or was killed)"


#: how long to try reaching a --scheduler (a refused connection is retried by distributed until then)
SCHEDULER_TIMEOUT_S = 10


class BatchInterrupted(KeyboardInterrupt):
    """Ctrl-C stopped a batch: ``done`` of ``total`` inputs ran (their rows are in ``journal``)."""

    def __init__(self, done: int, total: int, journal: Path):
        super().__init__(f"interrupted: {done} of {total} inputs done, their rows are in {journal}; run the same "
                         "command with --resume to finish the rest")
        self.done, self.total, self.journal = done, total, journal


@dataclass
class Task:
    """One input to run: its output ``base``, its own ``options`` and the ``notes`` its record gets."""

    path: Path
    base: Path
    options: dict
    notes: list[str] = field(default_factory=list)


@dataclass
class BatchResult:
    """What a batch did: ``rows`` (one per input, sorted by input), the inputs ``skipped`` while expanding
    ``(path, reason)``, how many rows were ``kept`` from an earlier run (``--resume``), wall ``seconds``
    and the files written."""

    rows: list[dict]
    skipped: list[tuple[str, str]] = field(default_factory=list)
    kept: int = 0
    seconds: float = 0.0
    results_path: Path | None = None
    journal_path: Path | None = None
    numba_cache: str | None = None
    catalog: dict | None = None

    @property
    def errors(self) -> list[dict]:
        return [r for r in self.rows if r["status"] != "ok"]

    @property
    def ok(self) -> int:
        return sum(r["status"] == "ok" for r in self.rows)


#: ``report(row, done, errors, total)`` after each finished row (progress display)
Report = Callable[[dict, int, int, int], None]


def _distributed():
    try:
        import distributed
    except ImportError:
        raise MocapError("--engine dask needs the distributed package: pip install 'mocapkit[dask]'") from None
    return distributed


def check_options(job: str, engine: str, jobs: int, scheduler: str | None) -> None:
    """Refuse, before any work, an unknown job or engine, a worker count below 1, a scheduler without
    ``--engine dask`` or one that is not ``tcp://HOST:PORT``."""
    from mocapkit.jobs import JOBS

    if job not in JOBS:
        raise InvalidParameterError(f"unknown job {job!r}; choose from {', '.join(JOBS)}")
    if engine not in ENGINES:
        raise InvalidParameterError(f"--engine must be one of {', '.join(ENGINES)}, got {engine!r}")
    if not isinstance(jobs, int) or jobs < 1:
        raise InvalidParameterError(f"--jobs must be >= 1, got {jobs}")
    if scheduler is not None:
        if engine != "dask":
            raise InvalidParameterError("--scheduler is for --engine dask")
        host, _, port = scheduler.removeprefix("tcp://").rpartition(":")
        if not scheduler.startswith("tcp://") or not host or not port.isdigit():
            raise InvalidParameterError(f"--scheduler must be tcp://HOST:PORT, got {scheduler!r}")
    if engine == "dask":
        _distributed()


def _prepare_out(out: Path) -> Path:
    out = Path(os.path.abspath(out))
    if out.exists() and not out.is_dir():
        raise InvalidParameterError(f"--out {out}: not a folder")
    out.mkdir(parents=True, exist_ok=True)
    if not os.access(out, os.W_OK | os.X_OK):
        raise InvalidParameterError(f"--out {out}: folder not writable")
    return out


def previous_rows(out: Path) -> list[dict]:
    """The rows an earlier batch left in ``out``: the result table, then the journal (later rows win)."""
    return [*read_results(out / RESULTS_NAME), *read_journal(out / JOURNAL_NAME)]


def run_batch(job: str, inputs: Sequence[str | os.PathLike[str]], options: dict, out: str | os.PathLike[str], *,
              jobs: int = 1, engine: str = "local", scheduler: str | None = None, resume: bool = False,
              db: str | None = None, report: Report | None = None,
              manifest: str | os.PathLike[str] | None = None) -> BatchResult:
    """Run ``job`` with ``options`` on every input and return the :class:`BatchResult`.

    ``inputs`` are expanded by :func:`mocapkit.jobs.inputs.expand_inputs`; each input runs with its own
    options (:func:`mocapkit.batch.file_options.resolve`: ``manifest``, its sidecar, what the file states)
    and its output goes to ``mocapkit.jobs.batch_output(job, path, its options, OUT/<relative dir>/<stem>)``,
    unless that output is (a link to) an input of the batch or a file read with one (an error row).
    ``resume=True`` keeps the ok rows of an earlier batch in ``out`` whose job, input, content hash and
    options hash match, and runs the rest. Every usage error (a bad manifest or sidecar too) is raised
    before any work.
    """
    from mocapkit.batch.file_options import load_manifest
    from mocapkit.jobs import check_options as check_job_options

    t0 = time.perf_counter()
    check_options(job, engine, jobs, scheduler)
    check_job_options(job, options, per_file=True)
    out = Path(os.path.abspath(out))
    if out.exists() and not out.is_dir():
        raise InvalidParameterError(f"--out {out}: not a folder")
    _refuse_inputs_in_out(inputs, out)
    man = None if manifest is None else load_manifest(manifest)
    found = expand_inputs(list(inputs), out)
    if man is not None:  # in the tree: named for what it is
        found.skipped = [(p, "the batch's manifest" if p == str(man.path) else why) for p, why in found.skipped]
    per_file = _per_file(job, found.files, options, man)
    found.files = _read_by_job(job, found, per_file)
    previous = previous_rows(out) if resume and out.is_dir() else []
    if not found.files:
        why = "; ".join(f"{p}: {w}" for p, w in found.skipped[:3]) + (" ..." if len(found.skipped) > 3 else "")
        raise InvalidParameterError(f"no input that {job} reads" + (f" (skipped: {why})" if why else ""))
    catalog = _open_catalog(db) if db is not None else None
    out = _prepare_out(out)
    kept: dict[Path, dict] = {}
    if resume:
        done: dict[tuple[str, str | None], dict | None] = {}
        for r in previous:
            if r.get("job") == job:
                done[(r["input"], r.get("options_hash"))] = r if r.get("status") == "ok" else None
        for f in found.files:
            ok = done.get((str(f), options_hash(per_file[f].options)))
            if ok is not None and ok.get("content_hash") and _hash_or_none(f) == ok["content_hash"]:
                kept[f] = ok
    bases = output_bases(found.files, out)
    guard = OutputGuard([*found.files, *(p for p, _ in found.skipped), *([] if man is None else [man.path]),
                         *(x for fo in per_file.values() for x in fo.files)])
    tasks, refused = [], []
    for f in found.files:
        if f in kept:
            continue
        fo = per_file[f]
        try:
            output = batch_output(job, f, fo.options, bases[f], make=False)
        except MocapError as e:  # this input's own problem (verify: no compressed output found): its row only
            refused.append(failed_row(job, f, fo.options, error_line(e)))
            continue
        # verify's "output" is the compressed file it reads, never written
        problem = None if output is None or job == "verify" else guard.problem(output)
        if problem is None:
            tasks.append(Task(f, bases[f], fo.options, fo.notes))
        else:
            refused.append(failed_row(job, f, fo.options, problem))
    cache = configure_numba_cache()
    rows = list(kept.values())
    total, n_err = len(found.files), 0
    journal = Journal(out / JOURNAL_NAME, fresh=not resume)
    feed = _CatalogFeed(catalog, rows)  # the rows kept by --resume first, then the new ones as they come
    runner = _local(job, tasks, jobs) if engine == "local" else _dask(job, tasks, jobs, scheduler)
    try:
        for row in itertools.chain(refused, runner):
            journal.append(row)
            rows.append(row)
            feed.add(row)
            n_err += row["status"] != "ok"
            if report is not None:
                report(row, len(rows), n_err, total)
    except KeyboardInterrupt:
        previous = hold_interrupts()  # a second Ctrl-C while stopping must not cut the stop short
        try:
            runner.close()  # the workers stop now
            journal.close()
            feed.close()  # the rows finished so far reach the catalog too
        finally:
            hold_interrupts(previous)
            raise BatchInterrupted(len(rows) - len(kept), total - len(kept), out / JOURNAL_NAME) from None
    finally:
        runner.close()
        journal.close()
    write_results(out / RESULTS_NAME, rows)
    rows.sort(key=lambda r: r["input"])
    added = feed.close()
    return BatchResult(rows, found.skipped, len(kept), time.perf_counter() - t0, out / RESULTS_NAME,
                       out / JOURNAL_NAME, cache, added)


def hold_interrupts(handler=None):
    """Ignore SIGINT (a terminal's further Ctrl-C while a batch stops), or restore ``handler``; returns the
    handler it replaced. Outside the main thread (where signals cannot be set) it does nothing."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        return None
    return signal.signal(signal.SIGINT, signal.SIG_IGN if handler is None else handler)


def _hash_or_none(path: Path) -> str | None:
    from mocapkit.jobs.recording import content_hash

    try:
        return content_hash(path)
    except (OSError, MocapError):
        return None


# --------------------------------------------------------------------------------------------------
# the catalog (mocapkit.catalog): opened before the batch, written by the main process after it
# --------------------------------------------------------------------------------------------------

def _open_catalog(url: str):
    """Open the catalog at ``url`` before any work, so a wrong URL fails at once."""
    from mocapkit.catalog import open_catalog

    return open_catalog(url)


class _CatalogFeed:
    """The main process hands finished rows to the catalog (workers never write the database) in chunks of
    :attr:`CHUNK` rows or every :attr:`EVERY_S` seconds, so a long batch fills it as it goes and a killed
    one loses at most the last chunk there (its rows are in the journal; ``--resume`` adds them)."""

    CHUNK, EVERY_S = 200, 30.0

    def __init__(self, catalog, first: list[dict]):
        self.catalog, self.pending = catalog, list(first)
        self.added: dict[str, int] = {}
        self.last = time.monotonic()

    def add(self, row: dict) -> None:
        if self.catalog is None:
            return
        self.pending.append(row)
        if len(self.pending) >= self.CHUNK or time.monotonic() - self.last >= self.EVERY_S:
            self.flush()

    def flush(self) -> None:
        from mocapkit.catalog.ingest import add_rows

        if self.pending:
            for table, n in add_rows(self.catalog, self.pending).items():
                self.added[table] = self.added.get(table, 0) + n
        self.pending, self.last = [], time.monotonic()

    def close(self) -> dict | None:
        """Write what is left, close the catalog; the rows written per table (None without a catalog)."""
        if self.catalog is None:
            return None
        try:
            self.flush()
            return self.added
        finally:
            self.catalog.close()


def _refuse_inputs_in_out(inputs, out: Path) -> None:
    """An OUT folder that is an input folder or holds an input is refused before any work: the batch never
    enters OUT (it holds its own outputs), so those inputs would silently not run."""
    for a in inputs:
        p = os.path.abspath(a)
        if os.path.exists(p) and (p == str(out) or p.startswith(str(out).rstrip(os.sep) + os.sep)):
            raise InvalidParameterError(f"--out {out}: holds the input {a}; choose a folder outside the inputs "
                                        "(the outputs mirror their tree under it)")


def _per_file(job: str, files: list[Path], options: dict, manifest) -> dict:
    """Each input's :class:`~mocapkit.batch.file_options.FileOptions` (a bad sidecar raises, before any work)."""
    from mocapkit.batch.file_options import resolve

    sidecars: dict = {}
    return {f: resolve(job, f, options, manifest, sidecars) for f in files}


def _read_by_job(job: str, found, per_file: dict) -> list[Path]:
    """The inputs ``job`` reads (with their own options); the others join ``found.skipped`` with the reason
    (:func:`mocapkit.jobs.not_read_by`: ``segment`` on a C3D file, ``compress`` on markers...)."""
    from mocapkit.jobs import not_read_by

    keep = []
    for f in found.files:
        opts = per_file[f].options
        try:
            why = not_read_by(job, f, opts)
        except (OSError, MocapError):  # unreadable: the job reports it in its row
            why = None
        if why is None and job == "compress" and all(opts.get(k) is None for k in CONTROLS):
            why = ("no bound for this file: give --max-angle (IMU data), --max-position-error (skeletons), "
                   "--threshold or --target-icr, or the bound in the manifest or a sidecar")
        if why is None:
            keep.append(f)
        else:
            found.skipped.append((str(f), why))
    return keep


# --------------------------------------------------------------------------------------------------
# engines
# --------------------------------------------------------------------------------------------------

def _context():
    import multiprocessing

    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(["mocapkit.batch.worker"])
    return ctx


def _submit(pool, job: str, t: Task, **kw):
    return pool.submit(run_one, job, str(t.path), t.options, str(t.base), t.notes, **kw)


def _local(job: str, tasks: list[Task], n: int) -> Generator[dict, None, None]:
    """The local engine: a process pool of ``n`` workers (see the module docstring)."""
    from concurrent.futures import FIRST_COMPLETED, wait
    from concurrent.futures.process import BrokenProcessPool

    ctx = _context()
    pending = deque(tasks)
    pool = _pool(n, ctx)
    inflight: dict = {}
    finished = False
    idle_breaks = 0
    try:
        while pending or inflight:
            broken = False
            while pending and len(inflight) < 2 * n:
                t = pending.popleft()
                try:
                    inflight[_submit(pool, job, t)] = t
                except BrokenProcessPool:  # a worker died since the last wait: this input never ran
                    pending.appendleft(t)
                    broken = True
                    break
            suspects = []
            if not broken:
                done, _ = wait(inflight, return_when=FIRST_COMPLETED)
                for f in done:
                    t = inflight.pop(f)
                    try:
                        yield f.result()
                    except BrokenProcessPool:
                        suspects.append(t)
                    except Exception as e:  # noqa: BLE001 - e.g. a result that could not be sent back
                        yield failed_row(job, t.path, t.options, f"the worker could not run this input: "
                                                                 f"{type(e).__name__}: {e}")
            if broken or suspects:  # the pool is broken: every input in flight fails with it
                for f in wait(inflight).done:
                    t = inflight.pop(f)
                    try:
                        yield f.result()
                    except Exception:  # noqa: BLE001
                        suspects.append(t)
                pool.shutdown(wait=True)
                idle_breaks = 0 if suspects else idle_breaks + 1
                if idle_breaks > 3:
                    raise MocapError("the process pool breaks with no input running: "
                                     "workers cannot start on this machine")
                yield from _isolated(job, suspects, n, ctx)
                pool = _pool(n, ctx)
        finished = True
    finally:
        if finished:
            pool.shutdown(wait=True)
        else:  # Ctrl-C, or the caller stopped: the workers are killed, not waited for
            _stop(pool)


def _pool(n: int, ctx):
    from concurrent.futures import ProcessPoolExecutor

    return ProcessPoolExecutor(n, mp_context=ctx, initializer=ignore_interrupts)


def _stop(pool) -> None:
    """Kill a pool's workers at once (their inputs are not journaled and run again on ``--resume``)."""
    for p in list((getattr(pool, "_processes", None) or {}).values()):
        with contextlib.suppress(OSError, AttributeError):
            p.kill()
    pool.shutdown(wait=False, cancel_futures=True)


def _isolated(job: str, tasks: list[Task], n: int, ctx) -> Iterator[dict]:
    """Run each of ``tasks`` in a pool of its own (``n`` at a time): an input whose worker dies is named."""
    from concurrent.futures import FIRST_COMPLETED, wait
    from concurrent.futures.process import BrokenProcessPool

    pending = deque(tasks)
    running: dict = {}
    try:
        while pending or running:
            while pending and len(running) < n:
                t = pending.popleft()
                pool = _pool(1, ctx)
                running[_submit(pool, job, t)] = (t, pool)
            done, _ = wait(running, return_when=FIRST_COMPLETED)
            for f in done:
                t, pool = running.pop(f)
                try:
                    row = f.result()
                except BrokenProcessPool:
                    row = failed_row(job, t.path, t.options, WORKER_DIED)
                except Exception as e:  # noqa: BLE001
                    row = failed_row(job, t.path, t.options, f"the worker could not run this input: "
                                                             f"{type(e).__name__}: {e}")
                pool.shutdown(wait=True)
                yield row
    finally:
        for _, pool in running.values():
            _stop(pool)


def _dask(job: str, tasks: list[Task], n: int, scheduler: str | None) -> Generator[dict, None, None]:
    """The Dask engine: the same :func:`run_one` on a cluster (see the module docstring)."""
    import logging

    distributed = _distributed()
    cluster = None
    if scheduler is not None:
        try:
            client = distributed.Client(scheduler, timeout=SCHEDULER_TIMEOUT_S)
        except (OSError, TimeoutError) as e:
            raise MocapError(f"--scheduler {scheduler}: cannot connect ({e})") from None
    else:
        cluster = distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                                           dashboard_address=None, silence_logs=logging.ERROR)
        client = distributed.Client(cluster)
    try:
        futures = {_submit(client, job, t, pure=False, retries=0): t for t in tasks}
        for f in distributed.as_completed(list(futures)):
            t = futures.pop(f)
            try:
                row = f.result()
            except Exception as e:  # noqa: BLE001 - KilledWorker, a lost connection...
                row = failed_row(job, t.path, t.options, f"the Dask cluster could not run this input: "
                                                         f"{type(e).__name__}: {e}")
            f.release()
            yield row
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
