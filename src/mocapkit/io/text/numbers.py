"""Strict numbers for every text reader: one grammar, finite values, sizes that cannot overflow.

Python's ``float`` accepts more than any motion-capture format writes (``"0_5"`` is 5, ``"nan"``,
``"inf"``, ``"1e999"`` and surrounding blanks are accepted), so a corrupted file would be read as
different numbers without a word. Readers parse tokens here instead:

- the grammar is a plain decimal number: optional sign, digits with at most one point, optional
  exponent (``[+-]?(\\d+\\.?\\d*|\\.\\d+)([eE][+-]?\\d+)?``); nothing else, no underscores;
- a format's own missing-value spelling (``NaN`` in a C3D-derived CSV, an empty cell) is accepted
  only where the reader asks for it and becomes ``nan``;
- ``|value| > MAX_ABS`` is refused: squaring or summing such values would overflow float64
  (``1e308`` offsets gave ``inf``/``nan`` errors that then reported "success").

The last value of a file that ends without a newline may have been cut short by a truncated copy;
:func:`cut_kind` tells how it looks against the values above it (see :mod:`mocapkit.io.text.input`
for the rule the readers apply).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mocapkit.errors import MocapFormatError

# the model's limit on any value read (re-exported: readers import it here)
from mocapkit.motion import MAX_ABS as MAX_ABS

NUMBER_RE = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?", re.ASCII)  # ASCII: no other digits
_fullmatch = NUMBER_RE.fullmatch


def _describe(tok: str) -> str:
    shown = tok if len(tok) <= 40 else tok[:37] + "..."
    return repr(shown)


def parse_number(tok: str, src: str, line: int | None, field: str, *,
                 missing: Sequence[str] = (), limit: float = MAX_ABS) -> float:
    """One token as a float by the strict grammar; ``missing`` spellings give ``nan``.

    Raises :class:`MocapFormatError` naming ``src``, ``line`` and ``field`` for anything else, for
    non-finite results and for ``|value| > limit``.
    """
    if tok in missing:
        return float("nan")
    if not _fullmatch(tok):
        raise MocapFormatError(src, line, f"{field}: {_describe(tok)} is not a number")
    v = float(tok)
    if not abs(v) <= limit:  # also catches inf from an exponent like 1e999
        raise MocapFormatError(src, line, f"{field}: {_describe(tok)} is out of range (|value| > {limit:g})")
    return v


def parse_numbers(toks: Iterable[str], src: str, line: int | None, field: str, *,
                  missing: Sequence[str] = (), limit: float = MAX_ABS) -> list[float]:
    """:func:`parse_number` over several tokens (``field`` gets the 1-based position appended)."""
    out = []
    for i, tok in enumerate(toks):
        if tok in missing:
            out.append(float("nan"))
            continue
        if not _fullmatch(tok):
            raise MocapFormatError(src, line, f"{field} {i + 1}: {_describe(tok)} is not a number")
        v = float(tok)
        if not abs(v) <= limit:
            raise MocapFormatError(src, line,
                                   f"{field} {i + 1}: {_describe(tok)} is out of range (|value| > {limit:g})")
        out.append(v)
    return out


def check_finite_array(values: NDArray[Any], src: str, field: str, *, first_line: int | None = None,
                       allow_nan: bool = False, limit: float = MAX_ABS) -> None:
    """Refuse ``inf`` (and ``nan`` unless ``allow_nan``) or ``|value| > limit`` in an array parsed in bulk.

    ``first_line`` is the file line of row 0 (rows are the first axis), so the error names the line.
    """
    a = np.asarray(values, dtype=float)
    bad = ~(np.abs(a) <= limit)
    if allow_nan:
        bad &= ~np.isnan(a)
    if not bad.any():
        return
    flat = int(np.flatnonzero(bad.reshape(len(a), -1).any(axis=1))[0]) if a.ndim else 0
    row = a.reshape(len(a), -1)[flat] if a.ndim else a.reshape(1)
    v = float(row[~(np.abs(row) <= limit) & (~np.isnan(row) if allow_nan else True)][0])
    line = None if first_line is None else first_line + flat
    what = "not finite" if not np.isfinite(v) else f"out of range (|value| > {limit:g})"
    raise MocapFormatError(src, line, f"{field}: {v!r} is {what}")


def token_shape(tok: str) -> tuple[int, int]:
    """``(decimals, exponent digits)`` of a number token: ``"-0.1240e-05"`` → ``(4, 2)``."""
    mant, _, exp = tok.lower().partition("e")
    return (len(mant) - mant.index(".") - 1 if "." in mant else 0), len(exp.lstrip("+-"))


#: Last characters of a token that a complete number does not end with: a number cut after its point,
#: its exponent mark or a sign (``0.`` for ``0.4``, ``1e`` for ``1e-05``, ``-`` for ``-0.12``).
CUT_ENDINGS = (".", "e", "E", "+", "-")


def significant_length(tok: str) -> int:
    """Characters of a number token other than blanks and its sign: ``"-0.05344"`` -> 7, ``"1e-300"`` -> 6."""
    return len(tok.strip().lstrip("+-"))


def cut_kind(last: str, column: Iterable[str]) -> str | None:
    """How ``last`` — the final token of a file that ends without a newline — looks cut short, judged
    against ``column`` (the same field on the lines before it; tokens that are not numbers are ignored):

    - ``"end"``: it ends with one of :data:`CUT_ENDINGS` (a ``.`` only when no earlier value of the
      column ends with one: some writers put ``1.`` for whole numbers);
    - ``"shorter"``: it has fewer decimals, or fewer exponent digits, than *every* value of the column;
    - ``"short"``: the column's values do not all have the same decimals and exponent digits (a ``repr``
      or ``%g`` writer) and it has fewer significant characters (:func:`significant_length`) than the
      longest of them. Such values may simply be short, so this one is a doubt, not proof (a column
      with fixed decimals is judged by ``"shorter"`` alone: ``2.500000`` under ``-12.500000`` is whole);
    - ``None``: nothing says it is cut (always ``None`` for a ``column`` without numbers, except ``"end"``).
    """
    t = last.strip()
    col = [c.strip() for c in column]
    col = [c for c in col if _fullmatch(c)]
    if t.endswith(CUT_ENDINGS) and not (t.endswith(".") and any(c.endswith(".") for c in col)):
        return "end"
    if not col or not _fullmatch(t):
        return None
    shapes = [token_shape(c) for c in col]
    dec, ex = token_shape(t)
    if dec < min(s[0] for s in shapes) or ex < min(s[1] for s in shapes):
        return "shorter"
    if len(set(shapes)) > 1 and significant_length(t) < max(significant_length(c) for c in col):
        return "short"
    return None


def looks_cut(last: str, column: Iterable[str]) -> bool:
    """True when :func:`cut_kind` finds ``last`` — the final token of a file that ends without a newline —
    possibly cut short against ``column`` (the same field on the lines before it): it ends with a point,
    an exponent mark or a sign, has fewer decimals or exponent digits than every token of ``column``
    (``-0`` where the column reads ``-0.124044``), or fewer significant characters than the longest one
    (``-0.05344`` where a ``repr`` column holds ``-0.053447``). An empty ``column`` gives False unless
    ``last`` ends like a cut number."""
    return cut_kind(last, column) is not None
