"""Bounded reading of an input file (regular file, pipe or device) for the marker and table readers.

- A regular file is read whole (its size is known, so the callers can check header claims against it).
- A pipe, FIFO or device (``/dev/stdin``, ``/dev/zero``...) is read in 1 MiB chunks up to
  :data:`MAX_STREAM_BYTES`; beyond that the input is refused (save it to a file first). A text reader
  refuses a NUL byte as soon as a chunk shows one, so ``/dev/zero`` fails after the first chunk.
- Text is UTF-8 (a byte-order mark is dropped) or, failing that, Latin-1 (exports of Windows tools):
  decoding never fails.

End of file. A last line written without a newline may be a copy cut short. Its last value ``X`` is
judged against the same column on the rows before it (:func:`mocapkit.io.text.numbers.cut_kind`):

(a) ``X`` ends with ``.``, ``e``, ``E``, ``+`` or ``-`` (``0.`` for ``0.4``): cut, an error (a ``.`` only
    when no earlier value of the column ends with one);
(b) ``X`` has fewer decimals or exponent digits than that column on every earlier row, all written
    with the same decimals (``-0`` or ``-0.12`` for ``-0.124044``): cut, an error (a reader may make it
    a warning in a column it does not use);
(c) otherwise, in a column whose values are written with varying decimals (``repr``, ``%g``), ``X`` has
    fewer significant characters (all but the sign) than the longest value of the column in the rows
    examined (``-0.05344`` for ``-0.053447``): a warning, "the file has no final newline and its last
    value X is shorter than others of its column: it may be cut short". A complete file that merely
    lacks a final newline is never refused; at most it gets this warning.

:func:`cut_cell` applies (a)-(c) to a row (the IMU readers), :func:`final_line_verdict` and
:func:`report_final_line` do it for the marker and table readers (which also warn, under (c), for any
last value of a column with varying decimals that they cannot check). The AMC reader applies
:func:`mocapkit.io.text.numbers.cut_kind` itself (an error under (a), a warning under (b) and (c)) and the BVH
reader :func:`mocapkit.io.text.numbers.looks_cut` (a warning).
"""

from __future__ import annotations

import os
import stat
from collections.abc import Callable
from pathlib import Path

from mocapkit.errors import MocapFormatError
from mocapkit.io.text.numbers import NUMBER_RE, cut_kind

__all__ = ["MAX_STREAM_BYTES", "MAX_HEADER_LINE", "open_error", "read_input", "decode_text", "read_text",
           "split_lines", "cut_cell", "short_value_note", "final_line_verdict",
           "report_final_line", "check_cells_budget", "is_regular"]

#: Largest input accepted from a pipe or device (a regular file is limited by its size only).
MAX_STREAM_BYTES = 256 * 1024 * 1024
#: Longest header line accepted by the text readers.
MAX_HEADER_LINE = 1024 * 1024
_CHUNK = 1024 * 1024


def open_error(src: str, exc: OSError, what: str) -> MocapFormatError:
    """The reader's error for an input that cannot be opened or read (missing, a folder, no permission)."""
    if isinstance(exc, FileNotFoundError):
        return MocapFormatError(src, None, "no such file")
    if isinstance(exc, IsADirectoryError):
        return MocapFormatError(src, None, f"is a folder, not a {what}")
    return MocapFormatError(src, None, f"cannot read: {exc.strerror or exc}")


def read_input(path: str | os.PathLike[str], what: str = "file", *, text: bool = True,
               max_stream_bytes: int | None = None,
               check_head: Callable[[bytes], None] | None = None) -> bytes | bytearray:
    """The bytes of ``path``, read in bounded chunks when it is not a regular file.

    ``text=True`` refuses a NUL byte (no text format holds one; UTF-16 is not read) naming its line.
    ``check_head`` is called with the first chunk (up to 1 MiB) before anything more is read, so a
    binary reader can refuse a wrong magic number on an endless device at once. Every failure is a
    :class:`MocapFormatError` naming ``path``. ``max_stream_bytes`` defaults to :data:`MAX_STREAM_BYTES`
    (read at call time). A pipe's bytes come back as one ``bytearray`` (no second copy).
    """
    src = str(path)
    cap = MAX_STREAM_BYTES if max_stream_bytes is None else max_stream_bytes
    try:
        fh = open(path, "rb")  # noqa: SIM115 - closed below
    except OSError as exc:
        raise open_error(src, exc, what) from None
    with fh:
        try:
            st = os.fstat(fh.fileno())
            if stat.S_ISDIR(st.st_mode):
                raise MocapFormatError(src, None, f"is a folder, not a {what}")
            if stat.S_ISREG(st.st_mode):
                if check_head is not None:
                    check_head(fh.read(_CHUNK))
                    fh.seek(0)
                data: bytes | bytearray = fh.read()
            else:
                buf = bytearray()
                while True:
                    chunk = fh.read(_CHUNK)
                    if not chunk:
                        break
                    if text and b"\0" in chunk:
                        offset = len(buf) + chunk.index(b"\0")
                        line = buf.count(b"\n") + chunk.count(b"\n", 0, offset - len(buf)) + 1
                        raise MocapFormatError(src, line, f"a NUL byte (byte {offset}): not a text {what}")
                    if check_head is not None and not buf:
                        check_head(chunk)
                    if len(buf) + len(chunk) > cap:
                        raise MocapFormatError(src, None, f"more than {cap:,} bytes from a pipe or device; "
                                               "save it to a regular file first")
                    buf += chunk
                data = buf
        except MocapFormatError:
            raise
        except OSError as exc:
            raise open_error(src, exc, what) from None
    if text:
        k = data.find(b"\0")
        if k >= 0:
            raise MocapFormatError(src, data.count(b"\n", 0, k) + 1,
                                   f"a NUL byte (byte {k}): not a text {what} (UTF-16 text is not read; "
                                   "save it as UTF-8)")
    return data


def decode_text(data: bytes | bytearray) -> tuple[str, str]:
    """``(text, encoding)``: UTF-8 (BOM dropped) or else Latin-1, which decodes any byte."""
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    try:
        return data.decode("utf-8"), "utf-8"
    except UnicodeDecodeError:
        return data.decode("latin-1"), "latin-1"


def split_lines(text: str) -> tuple[list[str], bool]:
    """``(lines, ends_with_newline)``: CR/LF and CR ends become line breaks; a final empty piece is dropped."""
    text = text.replace("\r\n", "\n").replace("\r", "\n")
    ends = text.endswith("\n")
    lines = text.split("\n")
    if ends:
        lines.pop()
    return lines, ends


def read_text(path: str | os.PathLike[str], what: str = "file") -> tuple[list[str], bool, str, int]:
    """``(lines, ends_with_newline, encoding, size in bytes)`` of a text input (see :func:`read_input`)."""
    data = read_input(path, what, text=True)
    text, enc = decode_text(data)
    lines, ends = split_lines(text)
    return lines, ends, enc, len(data)


def _shape(tok: str) -> tuple[int, int] | None:
    """``(decimals, exponent digits)`` of a plain number token, ``None`` when it is not one."""
    t = tok.strip()
    if not NUMBER_RE.fullmatch(t):
        return None
    mant, _, exp = t.lower().partition("e")
    dec = len(mant.split(".", 1)[1]) if "." in mant else 0
    return dec, len(exp.lstrip("+-"))


def cut_cell(prev_rows: list[list[str]], last: list[str]) -> tuple[int, str] | None:
    """``(j, verdict)`` for the last non-empty cell ``j`` of ``last`` (the final line, written without a
    newline) when it looks cut short, else ``None``.

    ``verdict`` is ``"cut"`` under rules (a) and (b) of the module docstring (it ends with ``.``, ``e``,
    ``E``, ``+`` or ``-``; or it has fewer decimals or exponent digits than that column on every earlier
    row of ``prev_rows``, all written alike) and ``"short"`` under rule (c) (fewer significant
    characters than the longest value of a column written with varying decimals: maybe cut).
    """
    j = len(last) - 1
    while j >= 0 and not last[j].strip():
        j -= 1
    if j < 0:
        return None
    column = [r[j] for r in prev_rows if j < len(r)]
    kind = cut_kind(last[j], column)
    if kind == "end":
        return j, "cut"
    if kind == "shorter":
        shapes = {_shape(c) for c in column}
        shapes.discard(None)
        return j, ("cut" if len(shapes) == 1 else "short")
    if kind == "short":
        return j, "short"
    return None


def short_value_note(cell: str) -> str:
    """The rule-(c) warning text for a last value ``cell`` (see the module docstring)."""
    shown = cell.strip()
    shown = repr(shown if len(shown) <= 40 else shown[:37] + "...")
    return (f"the file has no final newline and its last value {shown} is shorter than others of its column: "
            "it may be cut short")


def final_line_verdict(prev_rows: list[list[str]], last: list[str], *,
                       count: bool = True) -> tuple[str, int | None]:
    """Judge the final line of a file that ends without a newline against the rows before it.

    Returns ``("fields", None)`` when it has another number of cells than the row before it (with
    ``count``), ``("cut", j)`` when cell ``j`` is evidently cut (it ends with ``.``, ``e``, ``E``, ``+`` or
    ``-``; fewer decimals than that column has on every earlier row; or empty where every earlier row
    has a value), ``("complete", j)`` when its
    last value has that column's fixed number of decimals, and ``("unknown", j)`` when the column's
    decimals vary (``%g``/``repr`` writers) so that a cut cannot be told from a short number.
    """
    if not prev_rows:
        return "unknown", None
    if count and len(last) != len(prev_rows[-1]):
        return "fields", None
    j = len(last) - 1
    while j >= 0 and not last[j].strip():
        if all(j < len(r) and r[j].strip() for r in prev_rows):
            return "cut", j  # a whole value (or more) is missing at the end
        j -= 1
    if j < 0:
        return "unknown", None
    if cut_kind(last[j], [r[j] for r in prev_rows if j < len(r)]) == "end":
        return "cut", j  # rule (a): '0.' for '0.4', '1e' for '1e-05'
    mine = _shape(last[j])
    shapes: set[tuple[int, int]] = set()
    for r in prev_rows:
        shape = _shape(r[j]) if j < len(r) else None
        if shape is not None:
            shapes.add(shape)
    if mine is None or len(shapes) != 1:
        return "unknown", j
    dec, exp = shapes.pop()
    if mine[0] < dec or mine[1] < exp:
        return "cut", j
    return "complete", j


def report_final_line(src: str, line: int, verdict: str, j: int | None, field: str,
                      cell: str, warnings_list: list[str]) -> None:
    """Act on :func:`final_line_verdict`: raise for ``"fields"``/``"cut"``, warn for ``"unknown"``.

    The warning goes to ``warnings_list`` (a reader's ``meta["warnings"]``) and to
    :func:`warnings.warn` (:class:`~mocapkit.errors.MocapWarning`).
    """
    if verdict == "fields":
        raise MocapFormatError(src, line, "the file ends in this line without a newline and it has another "
                               "number of values than the line before: it was cut short (delete this line "
                               "to read the rest)")
    if verdict == "cut":
        shown = repr(cell.strip()[:40]) if cell.strip() else "an empty cell"
        how = ("ends like a number cut short" if cell.strip().endswith((".", "e", "E", "+", "-"))
               else "is shorter than that column on the rows before")
        raise MocapFormatError(src, line, f"{field}: {shown} {how} and the file ends there without a newline: "
                               "it was cut short (delete this line to read the rest)")
    if verdict == "unknown":
        import warnings

        from mocapkit.errors import MocapWarning

        msg = (f"line {line}, the last of the file, has no newline and its last value ({field}: "
               f"{cell.strip()[:40]!r}) cannot be checked against its column: it may be cut short")
        warnings_list.append(msg)
        warnings.warn(f"{src}: {msg}", MocapWarning, stacklevel=4)


def check_cells_budget(src: str, line: int | None, cells: int, file_bytes: int, what: str) -> None:
    """Refuse to allocate ``cells`` float64 values when the file (``file_bytes``) cannot hold them.

    A value takes at least one byte in a text file (a delimiter), so more cells than
    ``4 x file_bytes + 2**22`` (room for rows padded with gaps) means a header claim or a layout that
    would cost far more memory than the file justifies.
    """
    if cells > 4 * file_bytes + (1 << 22):
        raise MocapFormatError(src, line, f"{what} would need {cells:,} values from a file of "
                               f"{file_bytes:,} bytes; the header or layout cannot be right")


def is_regular(path: str | os.PathLike[str]) -> bool:
    """True for a regular file (following symlinks)."""
    try:
        return stat.S_ISREG(os.stat(Path(path)).st_mode)
    except OSError:
        return False
