"""``mocapkit stream``: CSV rows from a line source through an :class:`~mocapkit.pla.Encoder` in batches.

A reader thread parses rows as they arrive; the encoder takes whatever has arrived in one
``push_many`` call (up to ``batch`` samples), so a fast producer costs one call into C per batch while
a slow one still sees each point the moment its sample arrives (a batch is never waited for).
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable, Iterable

import numpy as np

from mocapkit.errors import InvalidSignalError
from mocapkit.io.imu.stream import iter_samples
from mocapkit.pla import Encoder
from mocapkit.pla.native import Points

_END = object()


def _reader(lines: Iterable[str], source: str, rate, columns: dict, q: queue.Queue) -> None:
    try:
        for _lineno, t, x in iter_samples(lines, source, rate, **columns):
            q.put((t, x))
    except BaseException as e:  # handed to the encoding thread, raised there after the rows before it
        q.put(e)
    q.put(_END)


def _push(enc: Encoder, t: list, x: list) -> Points:
    try:
        return enc.push_many(np.array(t), np.array(x, dtype=np.float64).reshape(len(t), enc.dim))
    except InvalidSignalError:
        # a batch with a bad sample is refused whole: encode its good prefix one by one (the same
        # points a sample-by-sample stream would have sent), then fail on the bad sample
        for ti, xi in zip(t, x, strict=True):
            enc.push(ti, xi)
        raise


def run_stream(lines: Iterable[str], enc: Encoder, emit: Callable[[Points], None], source: str = "<stdin>",
               rate: float | None = None, batch: int = 4096, **columns) -> int:
    """Encode every sample of ``lines``; ``emit(points)`` after each batch and after the final flush.

    Returns the number of samples. Errors of the input are raised after the samples before them
    were encoded and the stream flushed (the last point is never lost).
    """
    q: queue.Queue = queue.Queue(maxsize=16 * batch)
    th = threading.Thread(target=_reader, args=(lines, source, rate, columns, q), daemon=True)
    th.start()
    n = 0
    try:
        done = False
        while not done:
            item = q.get()
            t: list = []
            x: list = []
            while True:
                if item is _END:
                    done = True
                    break
                if isinstance(item, BaseException):
                    if t:
                        emit(_push(enc, t, x))
                        n += len(t)
                    raise item
                t.append(item[0])
                x.append(item[1])
                if len(t) >= batch:
                    break
                try:
                    item = q.get_nowait()
                except queue.Empty:
                    break
            if t:
                emit(_push(enc, t, x))
                n += len(t)
    finally:
        pts = enc.flush()
        emit(Points(np.array([p.index for p in pts], dtype=np.int64), np.array([p.time for p in pts]),
                    np.array([p.values for p in pts], dtype=np.float64).reshape(len(pts), enc.dim)))
    return n
