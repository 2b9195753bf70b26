"""Atomic file writes: write a temporary file in the target's folder, then ``os.replace`` it.

A reader (or a crash) never sees a half-written output file: either the old file or the complete new
one is there.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO


def _target_mode(path: Path) -> int:
    """Permissions for the new file: those of the file it replaces, else ``0o666 & ~umask``."""
    try:
        return path.stat().st_mode & 0o7777
    except OSError:
        mask = os.umask(0)
        os.umask(mask)
        return 0o666 & ~mask


@contextlib.contextmanager
def atomic_writer(path: str | os.PathLike[str], *, binary: bool = False,
                  encoding: str = "utf-8") -> Iterator[IO]:
    """Context manager yielding a file object; on a clean exit the file replaces ``path``.

    The data goes to a temporary file in the same folder (so ``os.replace`` is atomic), is flushed and
    fsync'ed, and then renamed onto ``path``. If the block raises, the temporary file is removed and
    ``path`` is left untouched. Text mode writes ``"\\n"`` line ends unchanged on every platform.
    """
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    if target.is_dir():
        raise IsADirectoryError(21, "is a folder, not a file", str(target))
    try:
        fd, tmp_name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=folder)
    except OSError as e:  # name the file the user asked for, not the temporary one
        raise type(e)(e.errno, e.strerror, str(target)) from None
    tmp = Path(tmp_name)
    try:
        if binary:
            fh = os.fdopen(fd, "wb")
        else:
            fh = os.fdopen(fd, "w", encoding=encoding, newline="")
        with fh:
            yield fh
            try:
                fh.flush()
                os.fsync(fh.fileno())
            except OSError as e:  # e.g. a full disk: name the user's file, not the temporary one
                raise type(e)(e.errno, e.strerror, str(target)) from None
        try:
            os.chmod(tmp, _target_mode(target))
            os.replace(tmp, target)
        except OSError as e:
            raise type(e)(e.errno, e.strerror, str(target)) from None
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def atomic_write_text(path: str | os.PathLike[str], text: str, encoding: str = "utf-8") -> None:
    """Write ``text`` to ``path`` atomically (``"\\n"`` is written as is, no newline translation)."""
    with atomic_writer(path, encoding=encoding) as fh:
        fh.write(text)


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to ``path`` atomically."""
    with atomic_writer(path, binary=True) as fh:
        fh.write(data)


def read_file_bytes(path: str | os.PathLike[str], what: str = "file") -> bytes:
    """The bytes of ``path``; a missing, unreadable or folder path raises ``MocapFormatError``
    naming it (``what`` says what was expected, e.g. ``"C3D file"``)."""
    from mocapkit.errors import MocapFormatError

    src = str(path)
    try:
        return Path(path).read_bytes()
    except FileNotFoundError:
        raise MocapFormatError(src, None, "no such file") from None
    except IsADirectoryError:
        raise MocapFormatError(src, None, f"is a folder, not a {what}") from None
    except OSError as exc:
        raise MocapFormatError(src, None, f"cannot read: {exc.strerror or exc}") from None


def read_text_lines(path: str | os.PathLike[str], what: str = "file") -> tuple[list[str], str]:
    """The lines of a text file and the encoding used: a UTF-8 BOM is dropped, CR/LF and CR line ends
    become line breaks, UTF-8 is tried first, then Latin-1 (exports of Windows tools)."""
    data = read_file_bytes(path, what)
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    try:
        text, enc = data.decode("utf-8"), "utf-8"
    except UnicodeDecodeError:
        text, enc = data.decode("latin-1"), "latin-1"
    return text.replace("\r\n", "\n").replace("\r", "\n").split("\n"), enc
