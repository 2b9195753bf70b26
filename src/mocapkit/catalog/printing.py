"""Query results as text: CSV cells, table cells and strict JSON, written as the rows come.

Every value a catalog hands back prints (:mod:`mocapkit.catalog.reading` has the engine write as text what
Python would receive changed):

- numbers exactly: integers of any size, ``DECIMAL``/``NUMERIC`` digit for digit (a JSON number with the
  same digits), doubles by ``repr``; NaN and ±infinity as ``nan``/``inf``/``-inf`` in CSV and tables and as
  the JSON strings ``"NaN"``, ``"Infinity"``, ``"-Infinity"`` (JSON has no such numbers; ``null`` is SQL
  NULL only);
- dates and times in ISO 8601, intervals and ``infinity`` as the engine writes them, UUIDs as text,
  ``BLOB``/``bytea`` as hex;
- ``LIST``/``ARRAY`` as JSON arrays, ``STRUCT`` and ``MAP`` as JSON objects (a map keyed by a list: an
  array of ``{"key", "value"}`` objects); in a CSV or table cell the same JSON, compact.

JSON output is an array of objects, one a line; columns that share a name (``r.path`` and ``c.path`` of a
join) get keys ``path``, ``path_2``... so none is lost (:func:`json_keys`).
"""

from __future__ import annotations

import csv
import datetime as dt
import json
import math
from collections.abc import Iterable
from decimal import Decimal
from typing import TextIO

_NON_FINITE = {"nan": "NaN", "inf": "Infinity", "-inf": "-Infinity"}


def _special_float(v: float) -> str:
    return _NON_FINITE["nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")]


def json_text(v) -> str:
    """``v`` as one strict JSON value (RFC 8259), exactly: see the module's rules."""
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(int(v))
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else f'"{_special_float(v)}"'
    if isinstance(v, Decimal):
        return str(v) if v.is_finite() else f'"{_NON_FINITE.get(str(v).lower(), str(v))}"'
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, dict):
        return "{" + ",".join(f"{json.dumps(k if isinstance(k, str) else cell(k))}:{json_text(x)}"
                              for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ",".join(json_text(x) for x in v) + "]"
    return json.dumps(cell(v))


def cell(v) -> str:
    """``v`` as the text of a CSV or table cell (``None``: ``NULL``; CSV writes it as an empty cell)."""
    if v is None:
        return "NULL"
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else str(v)
    if isinstance(v, (dt.datetime, dt.date, dt.time)):
        return v.isoformat()
    if isinstance(v, (bytes, bytearray, memoryview)):
        return bytes(v).hex()
    if isinstance(v, (list, tuple, dict)):
        return json_text(v)
    if isinstance(v, Decimal) and not v.is_finite():
        return str(v).lower().replace("infinity", "inf")
    return str(v)


def json_keys(columns: list[str]) -> list[str]:
    """One key per column: its name, or for a name already taken ``NAME_2``, ``NAME_3``... (skipping names
    that are themselves columns)."""
    taken, used, keys = set(columns), set(), []
    for c in columns:
        key, n = c, 1
        while key in used or (key != c and key in taken):
            n += 1
            key = f"{c}_{n}"
        used.add(key)
        keys.append(key)
    return keys


def write_json(columns: list[str], chunks: Iterable[list[tuple]], out: TextIO) -> int:
    """Rows as a JSON array of objects (keys from :func:`json_keys`), one object a line, written chunk by
    chunk. Returns the number of rows."""
    names = [json.dumps(k) + ":" for k in json_keys(columns)]
    n = 0
    out.write("[")
    for rows in chunks:
        out.write("".join(("\n" if n == 0 and i == 0 else ",\n") + "{" +
                          ",".join(k + json_text(v) for k, v in zip(names, r, strict=True)) + "}"
                          for i, r in enumerate(rows)))
        n += len(rows)
    out.write("\n]\n" if n else "]\n")
    return n


def write_csv(columns: list[str], chunks: Iterable[list[tuple]], out: TextIO) -> int:
    """A header line, then the rows (NULL as an empty cell), written chunk by chunk. Returns the number of
    rows."""
    w = csv.writer(out, lineterminator="\n")
    if columns:
        w.writerow(columns)
    n = 0
    for rows in chunks:
        w.writerows([["" if v is None else cell(v) for v in r] for r in rows])
        n += len(rows)
    return n
