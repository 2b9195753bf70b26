"""Our own binary formats read from a path: the file's bytes (:mod:`mocapkit.io.formats`) decoded by the
algorithm that wrote them (:mod:`mocapkit.clip`, :mod:`mocapkit.pla.packet_layout`), which open no file.

Every error names the file: one that cannot be read, and one whose bytes do not decode.
"""

from __future__ import annotations

from pathlib import Path

from mocapkit.clip.decoder import Clip
from mocapkit.io.formats.mkc import read_mkc_bytes
from mocapkit.io.formats.mkp import read_mkp_bytes
from mocapkit.pla.packet_layout import PacketFile, decode_mkp
from mocapkit.skeleton import Motion


def open_clip(path: str | Path, *, data: bytes | None = None) -> Clip:
    """The ``.mkc`` clip at ``path`` (header checked, blocks decoded on demand); ``data``: its bytes when
    already in memory (``path`` then only names it)."""
    return Clip(str(path), data=read_mkc_bytes(path) if data is None else data)


def read_mkc(path: str | Path) -> Motion:
    """The decoded motion of a ``.mkc`` clip (every checksum checked)."""
    return open_clip(path).decode()


def read_mkp(path: str | Path, *, data: bytes | None = None) -> PacketFile:
    """Read a ``.mkp`` file: every sensor's points that arrived, the damaged and lost packets; ``data``: its
    bytes when already in memory (``path`` then only names it)."""
    return decode_mkp(read_mkp_bytes(path) if data is None else data, str(path))
