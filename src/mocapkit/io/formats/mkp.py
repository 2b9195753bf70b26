"""The ``.mkp`` radio packet file: its bytes read (an error naming the file) and written atomically.

The header and packet layout and the quantisation are :mod:`mocapkit.pla.packet_layout`;
``mocapkit.jobs.readers.read_mkp`` joins reading and decoding.
"""

from __future__ import annotations

from pathlib import Path

from mocapkit.errors import MocapFormatError
from mocapkit.io.atomic import atomic_write_bytes


def read_mkp_bytes(path: str | Path) -> bytes:
    """The file's bytes; a file that cannot be read is a :class:`~mocapkit.errors.MocapFormatError`."""
    try:
        return Path(path).read_bytes()
    except OSError as e:
        raise MocapFormatError(str(path), None, f"cannot read: {e.strerror or e}") from None


def write_mkp(path: str | Path, data: bytes) -> None:
    """Write a packet file's bytes atomically (:func:`mocapkit.io.atomic.atomic_write_bytes`)."""
    atomic_write_bytes(path, data)
