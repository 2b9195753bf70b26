"""What ``catalog query`` lets through, and values its engine would hand to Python changed.

:func:`one_duckdb_read` parses the text with DuckDB's own parser and lets one reading statement through
(``SELECT`` in all its forms — ``WITH``, ``VALUES``, ``FROM t``, ``SHOW``, ``DESCRIBE``, ``SUMMARIZE`` — or
an ``EXPLAIN`` of one); PostgreSQL gets the text inside a server-side cursor, whose ``DECLARE`` itself takes
one ``SELECT``/``VALUES``/``TABLE`` and nothing else (:func:`one_read_statement` only refuses an empty one).

DuckDB gives Python an ``INTERVAL`` as a ``timedelta`` (a month made 30 days), a ``TIMESTAMP_NS`` cut to
microseconds and ``±infinity`` dates as the first/last day of the calendar; :func:`printable_projection`
has DuckDB write those as text first (ISO 8601 for dates and times, ``infinity``, ``1 month 2 days``),
also inside ``STRUCT``, ``LIST``, ``ARRAY`` and ``MAP`` values. On PostgreSQL :func:`use_lenient_loaders`
reads intervals as their text and an infinite date or timestamp as ``infinity`` instead of failing.
"""

from __future__ import annotations

import re

from mocapkit.errors import MocapError

_READS = "a SELECT (WITH, VALUES, SHOW, DESCRIBE, SUMMARIZE) or an EXPLAIN of one"


def one_read_statement(sql: str, shown: str) -> str:
    """``sql`` without surrounding blanks and trailing ``;``; an empty text is refused."""
    text = str(sql).strip().rstrip(";").strip()
    if not text:
        raise MocapError(f"{shown}: the query is empty: give one SQL statement, {_READS}")
    return text


def one_duckdb_read(conn, sql: str, shown: str) -> str:
    """The text of the one reading statement in ``sql``; anything else is a :class:`MocapError` naming
    what it is (parse errors are the caller's engine errors)."""
    one_read_statement(sql, shown)
    stmts = conn.extract_statements(sql)
    if not stmts:
        raise MocapError(f"{shown}: the query holds no statement (only comments or ';'): give {_READS}")
    if len(stmts) > 1:
        raise MocapError(f"{shown}: {len(stmts)} statements given; catalog query runs one ({_READS})")
    kind = stmts[0].type.name
    text = stmts[0].query.strip().rstrip(";")
    if kind == "EXPLAIN":
        inner = re.sub(r"^\s*explain\s+(analy[sz]e\s+)?", "", text, count=1, flags=re.IGNORECASE)
        inner_stmts = conn.extract_statements(inner) if inner != text else []
        if len(inner_stmts) != 1 or inner_stmts[0].type.name != "SELECT":
            raise MocapError(f"{shown}: catalog query only reads: an EXPLAIN of a SELECT, not of this")
    elif kind != "SELECT":
        raise MocapError(f"{shown}: catalog query only reads ({_READS}); a {kind} statement is refused")
    return text


# --------------------------------------------------------------------------------------------------
# DuckDB: an expression per column that writes as text what Python would receive changed
# --------------------------------------------------------------------------------------------------

_ISO = "%Y-%m-%dT%H:%M:%S"
_NESTED = {"struct", "list", "array", "map", "union"}


def _time_text(e: str, fraction: str = "%f", zone: str = "") -> str:
    """ISO 8601 like Python's ``isoformat`` (microseconds left out when zero); ``infinity`` as DuckDB
    writes it. ``fraction`` ``%n``: nanoseconds, always written."""
    whole = f"strftime({e}, '{_ISO}{zone}')"
    parted = f"strftime({e}, '{_ISO}.{fraction}{zone}')"
    if fraction == "%f":
        parted = f"CASE WHEN microsecond({e}) % 1000000 = 0 THEN {whole} ELSE {parted} END"
    return f"CASE WHEN isfinite({e}) THEN {parted} ELSE CAST({e} AS VARCHAR) END"


def _quoted(name: str) -> str:
    return '"' + name.replace('"', '""') + '"'


def _field(e: str, name: str) -> str:
    return f"struct_extract({e}, '{name.replace(chr(39), chr(39) * 2)}')"


def _fix(t, e: str, depth: int) -> str | None:
    """An expression of ``e`` (of DuckDB type ``t``) whose Python value loses nothing; None: ``e`` is fine."""
    kind = t.id
    if kind in ("interval", "date"):  # '1 month 2 days'; YYYY-MM-DD, infinity or a year past 9999
        return f"CAST({e} AS VARCHAR)"
    if kind in ("timestamp", "timestamp_s", "timestamp_ms"):
        return _time_text(e)
    if kind == "timestamp_ns":
        return _time_text(e, "%n")
    if kind == "timestamp with time zone":
        return _time_text(e, "%f", "%z")
    if kind == "struct":
        fields = [(str(n), _fix(ct, _field(e, str(n)), depth + 1)) for n, ct in t.children]
        if all(f is None for _, f in fields):
            return None
        parts = ", ".join(f"{_quoted(n)} := {f or _field(e, n)}" for n, f in fields)
        return f"CASE WHEN {e} IS NULL THEN NULL ELSE struct_pack({parts}) END"
    if kind in ("list", "array"):
        x = f"x{depth}"
        inner = _fix(dict(t.children)["child"], x, depth + 1)
        return None if inner is None else f"list_transform({e}, lambda {x}: {inner})"
    if kind == "map":
        key_t, value_t = dict(t.children)["key"], dict(t.children)["value"]
        x = f"x{depth}"
        k = _fix(key_t, f"{x}.key", depth + 1)
        v = _fix(value_t, f"{x}.value", depth + 1)
        if key_t.id in _NESTED:  # Python cannot key a dict by a list: the entries, as {key, value} pairs
            if k is None and v is None:
                return f"map_entries({e})"
            return (f"list_transform(map_entries({e}), lambda {x}: struct_pack(key := {k or f'{x}.key'}, "
                    f"value := {v or f'{x}.value'}))")
        if k is None and v is None:
            return None
        return (f"map_from_entries(list_transform(map_entries({e}), lambda {x}: "
                f"struct_pack(key := {k or f'{x}.key'}, value := {v or f'{x}.value'})))")
    if kind == "union":
        members = [_fix(ct, "NULL", depth + 1) for _, ct in t.children[1:]]
        return None if all(m is None for m in members) else f"CAST({e} AS VARCHAR)"
    return None


def printable_projection(types) -> list[str]:
    """One expression per result column (``#1``, ``#2``... positional, so duplicate names stay apart), or
    ``[]`` when every column reaches Python unchanged."""
    fixed = [_fix(t, f"#{i}", 0) for i, t in enumerate(types, 1)]
    if all(f is None for f in fixed):
        return []
    return [f if f is not None else f"#{i}" for i, f in enumerate(fixed, 1)]


# --------------------------------------------------------------------------------------------------
# PostgreSQL: loaders that keep what psycopg's would refuse or change
# --------------------------------------------------------------------------------------------------

def use_lenient_loaders(conn) -> None:
    """On ``conn``: intervals read as PostgreSQL's text (a month stays a month), and a date or timestamp
    Python cannot hold (``infinity``, a year past 9999) read as its text instead of an error."""
    import psycopg
    from psycopg.types import datetime as pgdt
    from psycopg.types.string import TextLoader

    def lenient(base):
        class Lenient(base):
            def load(self, data):
                try:
                    return super().load(data)
                except psycopg.DataError:
                    return bytes(data).decode()

        return Lenient

    conn.adapters.register_loader("interval", TextLoader)
    conn.adapters.register_loader("date", lenient(pgdt.DateLoader))
    conn.adapters.register_loader("timestamp", lenient(pgdt.TimestampLoader))
    conn.adapters.register_loader("timestamptz", lenient(pgdt.TimestamptzLoader))
