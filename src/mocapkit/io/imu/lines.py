"""Bounded reading of an IMU text export: blocks of whole lines from a file, a pipe, a device or a string.

The IMU readers never hold a whole file: a file (regular or not: a FIFO, ``/dev/stdin``,
``/dev/zero``) is read in chunks of :data:`CHUNK_BYTES` and handed on as :class:`Block` objects of
complete lines, so the memory of the text is bounded by a chunk whatever the size of the input.

What is refused, as soon as it is seen (a :class:`~mocapkit.errors.MocapFormatError` naming the
line):

- a NUL byte (no text export holds one: a binary file, ``/dev/zero``, UTF-16 text);
- a line longer than :data:`MAX_LINE_BYTES` (1 MiB; the widest real header, APDM with a dozen
  sensors, is a few KB): the reading stops after that many bytes without a line end;
- bytes that are not UTF-8 (the error names the byte; the exports of the supported vendors are
  ASCII or UTF-8).

A UTF-8 byte-order mark at the start is dropped; ``\\r\\n`` line ends become ``\\n``. A block says
whether the input ends with it and whether its last line had a line end (a file that stops without
one may have been cut short: see :mod:`mocapkit.io.imu.rows`).
"""

from __future__ import annotations

import os
import stat
from collections.abc import Iterator
from dataclasses import dataclass
from typing import BinaryIO

from mocapkit.errors import MocapFormatError
from mocapkit.io.text.input import open_error

__all__ = ["CHUNK_BYTES", "MAX_LINE_BYTES", "Block", "check_line", "file_blocks", "open_input", "text_blocks"]

#: Longest line accepted (bytes, or characters for text given as a string).
MAX_LINE_BYTES = 1 << 20
#: Bytes read at a time (not more than MAX_LINE_BYTES: then only the first line of a chunk can be
#: too long, the one continuing from the chunk before).
CHUNK_BYTES = MAX_LINE_BYTES

_BOM = b"\xef\xbb\xbf"


@dataclass
class Block:
    """Complete lines of the input: ``text`` holds ``n_lines`` lines, each ended by ``\\n`` except the
    input's last line when ``terminated`` is false; ``first_line`` is the 1-based number of its first
    line; ``final`` says that nothing follows."""

    text: str
    first_line: int
    n_lines: int
    final: bool
    terminated: bool


def _too_long(src: str, line: int) -> MocapFormatError:
    return MocapFormatError(src, line, f"line longer than {MAX_LINE_BYTES} bytes without a line end: not a "
                            "text export (or a binary file)")


def _nul(src: str, line: int) -> MocapFormatError:
    return MocapFormatError(src, line, "a NUL byte: not a text export (a binary file or device; UTF-16 text "
                            "is not read, save it as UTF-8)")


def check_line(line: str, src: str, ln: int) -> None:
    """Refuse a NUL character or an over-long line in text already decoded (streams, strings)."""
    if "\0" in line:
        raise _nul(src, ln)
    if len(line) > MAX_LINE_BYTES:
        raise _too_long(src, ln)


def open_input(path: str | os.PathLike[str], what: str = "file") -> tuple[BinaryIO, int | None]:
    """``(binary file object, size of a regular file or None)``; errors name ``path``."""
    src = str(path)
    try:
        fh = open(path, "rb")  # noqa: SIM115 - the caller closes it
    except OSError as exc:
        raise open_error(src, exc, what) from None
    try:
        st = os.fstat(fh.fileno())
    except OSError as exc:  # pragma: no cover - fstat of an open file does not fail in practice
        fh.close()
        raise open_error(src, exc, what) from None
    if stat.S_ISDIR(st.st_mode):
        fh.close()
        raise MocapFormatError(src, None, f"is a folder, not a {what}")
    return fh, (st.st_size if stat.S_ISREG(st.st_mode) else None)


def _decode(data: bytes, src: str, first_line: int) -> str:
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = first_line + data.count(b"\n", 0, exc.start)
        raise MocapFormatError(src, line, f"not UTF-8 text: byte 0x{data[exc.start]:02x} cannot be decoded") from None


def _block(data: bytes, src: str, first_line: int, final: bool) -> Block:
    terminated = data.endswith(b"\n") or not data
    if b"\r" in data:
        data = data.replace(b"\r\n", b"\n")
        if final and not terminated and data.endswith(b"\r"):
            data = data[:-1]
    n = data.count(b"\n") + (0 if terminated or not data else 1)
    return Block(_decode(data, src, first_line), first_line, n, final, terminated)


def file_blocks(fh: BinaryIO, src: str, chunk: int = CHUNK_BYTES) -> Iterator[Block]:
    """Blocks of whole lines read from a binary file object in chunks of ``chunk`` bytes
    (``chunk <= MAX_LINE_BYTES``).

    The last block has ``final=True`` (an empty input gives one empty final block).
    """
    carry = b""
    line = 1
    start = True
    while True:
        try:
            data = fh.read(chunk)
        except OSError as exc:
            raise MocapFormatError(src, None, f"cannot read: {exc.strerror or exc}") from None
        if start and data:
            buf = carry + data
            if len(buf) < 3 and _BOM.startswith(buf):
                carry = buf
                continue
            if buf.startswith(_BOM):
                buf = buf[3:]
            carry, data, start = b"", buf, False
        if not data:
            yield _block(carry, src, line, True)
            return
        k = data.find(b"\0")
        if k >= 0:
            raise _nul(src, line + carry.count(b"\n") + data.count(b"\n", 0, k))
        first = data.find(b"\n")
        if first < 0:
            carry += data
            if len(carry) > MAX_LINE_BYTES:
                raise _too_long(src, line)
            continue
        if len(carry) + first > MAX_LINE_BYTES:
            raise _too_long(src, line)
        cut = data.rfind(b"\n")
        block = carry + data[: cut + 1]
        carry = data[cut + 1:]
        b = _block(block, src, line, False)
        line += b.n_lines
        yield b


def text_blocks(text: str, src: str, chunk: int = CHUNK_BYTES) -> Iterator[Block]:
    """The same blocks from text already in memory (``read_imu_text``)."""
    if text.startswith("\ufeff"):
        text = text[1:]
    if "\0" in text:
        k = text.index("\0")
        raise _nul(src, 1 + text.count("\n", 0, k))
    pos = 0
    line = 1
    n = len(text)
    while True:
        end = min(pos + chunk, n)
        if end < n:
            cut = text.rfind("\n", pos, end)
            if cut < 0:
                cut = text.find("\n", end)
                if cut < 0:
                    cut = n - 1
            end = cut + 1
        part = text[pos:end]
        final = end >= n
        terminated = part.endswith("\n") or not part
        if "\r" in part:
            part = part.replace("\r\n", "\n")
            if final and not terminated and part.endswith("\r"):
                part = part[:-1]
        cnt = part.count("\n") + (0 if terminated or not part else 1)
        if len(part) > MAX_LINE_BYTES:   # a chunk stretched to its first line end: one line may be too long
            for i, ln in enumerate(part.split("\n")):
                if len(ln) > MAX_LINE_BYTES:
                    raise _too_long(src, line + i)
        yield Block(part, line, cnt, final, terminated)
        if final:
            return
        line += cnt
        pos = end
