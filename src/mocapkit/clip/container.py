"""The ``.mkc`` clip container as bytes: preamble, header, block table, checksums (a block's payload is
:mod:`mocapkit.clip.codec`; reading and writing the file is :mod:`mocapkit.io.formats.mkc`).

Layout (little-endian; the full specification is ``docs/mkc.md``)::

    offset  size  field
    0       4     magic b"MKC\\0"
    4       2     format version (1)
    6       2     flags (0; readers refuse other values)
    8       4     H, the header's stored length
    12      4     CRC-32 of the H header bytes
    16      H     header: zstd frame of UTF-8 JSON (the skeleton, the track table, the block table)
    16+H    D     blocks, back to back (each: one codec byte + entropy-coded payload)
    16+H+D  4     CRC-32 of every byte before it

``D`` is the sum of the blocks' stored lengths in the block table. Each block table row is
``[first_frame, n_frames, stored_length, raw_length, crc32]``; blocks are contiguous in frame order
and cover all frames. A reader that wants one block (random access) checks the header's CRC, the file
size and that block's CRC; a reader of the whole clip also checks the final CRC. Any mismatch,
truncation or malformed field is a :class:`~mocapkit.errors.MocapFormatError` naming the file (the name
the caller gives with the bytes: this module opens no file).
"""

from __future__ import annotations

import json
import os
import struct
import zlib
from dataclasses import dataclass

from mocapkit.errors import MocapFormatError

MAGIC = b"MKC\x00"
VERSION = 1
PREAMBLE = struct.Struct("<4sHHII")
MAX_HEADER_JSON = 64 << 20  # bytes of header JSON accepted at most
#: what ``bound.metric`` may name (the writer's error metrics, :mod:`mocapkit.clip.metric`)
BOUND_METRICS = ("joint+end", "joint", "shell")


@dataclass(frozen=True)
class BlockEntry:
    first: int
    frames: int
    offset: int  # from the start of the file
    stored: int
    raw: int
    crc: int


def mkc_bytes(header: dict, blocks: list[tuple[int, int, int, bytes]]) -> bytes:
    """The file's bytes. ``blocks``: ``(first_frame, n_frames, raw_length, stored bytes)``."""
    import zstandard

    head = dict(header)
    head["blocks"] = [[f, n, len(b), raw, zlib.crc32(b)] for f, n, raw, b in blocks]
    text = json.dumps(head, allow_nan=False, separators=(",", ":"), ensure_ascii=False).encode()
    hz = zstandard.ZstdCompressor(level=9).compress(text)
    out = bytearray(PREAMBLE.pack(MAGIC, VERSION, 0, len(hz), zlib.crc32(hz)))
    out += hz
    for *_, b in blocks:
        out += b
    out += struct.pack("<I", zlib.crc32(out))
    return bytes(out)


def _int(v, what: str, where: str, lo: int = 0) -> int:
    if type(v) is not int or v < lo:
        raise MocapFormatError(where, None, f"header field {what} must be an integer >= {lo}, got {v!r}")
    return v


def parse_header(pre: bytes, read_header, file_size: int, where: str) -> tuple[dict, list[BlockEntry]]:
    """Check the preamble and the header (``read_header(n)`` gives the next ``n`` bytes)."""
    import zstandard

    if len(pre) < PREAMBLE.size:
        raise MocapFormatError(where, None, f"not a mocapkit clip: {len(pre)} bytes, shorter than the 16-byte preamble")
    magic, version, flags, hlen, hcrc = PREAMBLE.unpack(pre[:PREAMBLE.size])
    if magic != MAGIC:
        raise MocapFormatError(where, None, f"not a mocapkit clip (magic {magic!r}, expected {MAGIC!r})")
    if version != VERSION:
        raise MocapFormatError(
            where, None, f"clip format version {version} is not supported (this mocapkit reads {VERSION})"
        )
    if flags != 0:
        raise MocapFormatError(where, None, f"unknown flags {flags:#06x}")
    if PREAMBLE.size + hlen + 4 > file_size:
        raise MocapFormatError(
            where, None, f"truncated: the header alone needs {PREAMBLE.size + hlen + 4} bytes, the file has {file_size}"
        )
    hz = read_header(hlen)
    if len(hz) != hlen or zlib.crc32(hz) != hcrc:
        raise MocapFormatError(where, None, "the header's checksum does not match (corrupt file)")
    try:
        size = zstandard.frame_content_size(hz)
        if not (0 <= size <= MAX_HEADER_JSON):
            raise MocapFormatError(where, None, f"the header declares {size} bytes of JSON")
        text = zstandard.ZstdDecompressor().decompress(hz)
        head = json.loads(text.decode("utf-8"), parse_constant=_no_constant)
    except MocapFormatError:
        raise
    except Exception as e:  # zstd, UTF-8 or JSON errors after a matching CRC: a writer bug or forgery
        raise MocapFormatError(where, None, f"the header does not decode: {e}") from None
    if not isinstance(head, dict) or not isinstance(head.get("blocks"), list):
        raise MocapFormatError(where, None, "the header has no block table")
    entries = []
    offset = PREAMBLE.size + hlen
    frame = 0
    for i, row in enumerate(head["blocks"]):
        if not (isinstance(row, list) and len(row) == 5):
            raise MocapFormatError(where, None, f"block table row {i} is not [first, frames, stored, raw, crc]")
        first, n, stored, raw, crc = (_int(v, f"blocks[{i}]", where) for v in row)
        if first != frame or n < 1 or stored < 1 or crc >= 1 << 32:
            raise MocapFormatError(where, None, f"block {i}: frames {first}+{n} do not follow frame {frame}")
        entries.append(BlockEntry(first, n, offset, stored, raw, crc))
        offset += stored
        frame += n
    if offset + 4 != file_size:
        what = "truncated" if offset + 4 > file_size else "has trailing bytes"
        raise MocapFormatError(
            where, None, f"{what}: the header describes {offset + 4} bytes, the file has {file_size}"
        )
    return head, entries


def _no_constant(name: str):
    raise ValueError(f"{name} is not a number in strict JSON")


class ClipFile:
    """A clip's bytes: the checked header and block table, blocks handed out on demand. ``name`` (a file's
    path, or any label) only names the clip in errors."""

    def __init__(self, name: str | os.PathLike, *, data: bytes) -> None:
        self.path = str(name)
        self._data = data
        pos = [PREAMBLE.size]

        def take(n: int) -> bytes:
            b = data[pos[0]:pos[0] + n]
            pos[0] += n
            return b

        self.header, self.blocks = parse_header(data[:PREAMBLE.size], take, len(data), self.path)
        self._whole_checked = False

    @property
    def size(self) -> int:
        return len(self._data)

    def check_all(self) -> None:
        """The final CRC-32 over the whole file (done once)."""
        if not self._whole_checked:
            (crc,) = struct.unpack("<I", self._data[-4:])
            if zlib.crc32(self._data[:-4]) != crc:
                raise MocapFormatError(self.path, None, "the file's checksum does not match (corrupt file)")
            self._whole_checked = True

    def block(self, i: int) -> bytes:
        """Block ``i``'s stored bytes, its CRC checked."""
        e = self.blocks[i]
        b = self._data[e.offset:e.offset + e.stored]
        if zlib.crc32(b) != e.crc:
            raise MocapFormatError(
                self.path,
                None,
                f"block {i} (frames {e.first}..{e.first + e.frames - 1}): checksum does not match (corrupt file)",
            )
        return b
