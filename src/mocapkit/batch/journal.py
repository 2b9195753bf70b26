"""The batch journal: one JSON line per finished row in ``OUT/journal.jsonl``, flushed and fsync'ed, so
a killed batch loses no finished row and ``--resume`` knows what is done.

Each row is appended with one ``write`` on an ``O_APPEND`` descriptor and then ``fsync``: a kill can
at most leave a last line without its newline, which :func:`read_journal` ignores and
:class:`Journal` cuts off before appending.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from mocapkit.errors import MocapFormatError

JOURNAL_NAME = "journal.jsonl"


def read_journal(path: Path) -> list[dict]:
    """The rows of a journal, in the order they finished. A last line without a newline (a write cut
    by a kill) is ignored; any other line that is not a JSON object is a ``MocapFormatError``."""
    p = Path(path)
    if not p.exists():
        return []
    data = p.read_bytes()
    lines = data.split(b"\n")
    complete = lines[:-1]  # the part after the last newline is either empty or a cut write
    rows = []
    for i, line in enumerate(complete, 1):
        if not line.strip():
            continue
        try:
            row = json.loads(line)
        except ValueError as e:
            raise MocapFormatError(str(p), i, f"not a journal row ({e}); move the file away to start afresh") from None
        if not isinstance(row, dict) or "input" not in row or "status" not in row:
            raise MocapFormatError(str(p), i, "not a journal row (a JSON object with input and status)")
        rows.append(row)
    return rows


class Journal:
    """Append-only journal. ``fresh=True`` starts an empty journal (the previous one is replaced);
    otherwise rows are appended after the complete lines of the existing one."""

    def __init__(self, path: Path, *, fresh: bool) -> None:
        from mocapkit.io.atomic import atomic_write_bytes

        self.path = Path(path)
        if fresh or not self.path.exists():
            atomic_write_bytes(self.path, b"")
        else:
            data = self.path.read_bytes()
            keep = data.rfind(b"\n") + 1
            if keep != len(data):  # a cut last line: drop it so the next row starts on its own line
                os.truncate(self.path, keep)
        self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND)

    def append(self, row: dict) -> None:
        """Write ``row`` as one line, then fsync."""
        line = (json.dumps(row, allow_nan=False, separators=(",", ":")) + "\n").encode()
        view = memoryview(line)
        while view:
            n = os.write(self._fd, view)
            view = view[n:]
        os.fsync(self._fd)

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1

    def __enter__(self) -> Journal:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
