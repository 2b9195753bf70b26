"""One small interface over the catalog's two engines: DuckDB (a file, embedded) and PostgreSQL (a server).

:func:`connect` takes ``postgresql://user[:password]@host[:port]/database`` (or ``postgres://``) for a
server, anything else as the path of a DuckDB file (``duckdb:PATH`` also works). :class:`Catalog` hides
what differs: placeholders (write ``?``; PostgreSQL gets ``%s``), transactions, bulk inserts (DuckDB reads
an Arrow table, PostgreSQL a ``COPY``) and result values (``Decimal`` → ``float``). The tables are made
when missing (:mod:`mocapkit.catalog.schema`).

Every failure to open — a malformed URL, an unreachable server, a refused login, a DuckDB file locked by
another process, a folder given as the file, a missing driver — is one :class:`MocapError` naming the URL
with its password hidden.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import os
import re
from decimal import Decimal
from pathlib import Path
from urllib.parse import unquote, urlsplit, urlunsplit

from mocapkit.catalog import schema
from mocapkit.errors import MocapError

CONNECT_TIMEOUT_S = 10


def is_postgres(url: str) -> bool:
    return str(url).startswith(("postgresql://", "postgres://"))


def redact(url: str) -> str:
    """``url`` with its password (if any) replaced by ``***``."""
    url = str(url)
    if not is_postgres(url):
        return url
    try:
        parts = urlsplit(url)
        if parts.password is not None:
            user = parts.username or ""
            host = parts.netloc.rsplit("@", 1)[1]
            url = urlunsplit(parts._replace(netloc=f"{user}:***@{host}"))
    except ValueError:
        pass
    return _hide_in_text(url)


def _clean(message: str, url: str) -> str:
    """An engine's error on one line, without the URL's password."""
    text = " ".join(part.strip() for part in str(message).splitlines() if part.strip())
    if not is_postgres(url):
        return text
    m = re.match(r"^[A-Za-z]+://[^:/@]*:([^@]*)@", url)  # the password as written (even in a malformed URL)
    secrets = {m.group(1)} if m and m.group(1) else set()
    secrets |= set(re.findall(r"password=([^&\s]+)", url))
    with contextlib.suppress(ValueError):
        if urlsplit(url).password:
            secrets.add(urlsplit(url).password)
    secrets |= {unquote(pw) for pw in secrets}
    for pw in sorted(secrets, key=len, reverse=True):
        text = text.replace(pw, "***")
    return _hide_in_text(text)


def _hide_in_text(text: str) -> str:
    text = re.sub(r"(://[^:/@\s]*:)[^@\s]*@", r"\1***@", text)
    return re.sub(r"(password=)[^&\s]+", r"\1***", text)


def _plain(v):
    """A result value as plain Python: exact decimals as int/float, the rest unchanged."""
    if isinstance(v, Decimal):
        return int(v) if v == v.to_integral_value() and v.as_tuple().exponent >= 0 else float(v)
    return v


class Catalog:
    """An open catalog. Use as a context manager (closes) and :meth:`transaction` for atomic writes."""

    def __init__(self, url: str, engine: str, conn, errors: tuple = ()):
        self.url, self.engine, self._conn = url, engine, conn
        self._errors = errors  # the driver's exception classes, reported as MocapError
        self._in_tx = False

    @contextlib.contextmanager
    def _reported(self):
        try:
            yield
        except self._errors as e:
            raise MocapError(f"{redact(self.url)}: {_clean(e, self.url)}") from None

    # -- plumbing --------------------------------------------------------------------------------
    def _sql(self, sql: str, params) -> str:
        if self.engine == "postgresql" and params:
            return sql.replace("%", "%%").replace("?", "%s")
        return sql

    def execute(self, sql: str, params=()) -> None:
        """Run one statement (``?`` placeholders)."""
        with self._reported():
            if self.engine == "postgresql":
                with self._conn.cursor() as cur:
                    cur.execute(self._sql(sql, params), params or None)
            else:
                self._conn.execute(sql, list(params) if params else None)

    def query(self, sql: str, params=()) -> tuple[list[str], list[tuple]]:
        """``(columns, rows)`` of a query; values are plain Python (``Decimal`` made ``int``/``float``).
        A statement without a result gives ``([], [])``; an engine error is a :class:`MocapError`."""
        with self._reported():
            if self.engine == "postgresql":
                with self._conn.cursor() as cur:
                    cur.execute(self._sql(sql, params), params or None)
                    if cur.description is None:
                        return [], []
                    cols = [d.name for d in cur.description]
                    rows = cur.fetchall()
            else:
                cur = self._conn.execute(sql, list(params) if params else None)
                if cur.description is None:
                    return [], []
                cols = [d[0] for d in cur.description]
                rows = cur.fetchall()
        return cols, [tuple(_plain(v) for v in r) for r in rows]

    @contextlib.contextmanager
    def transaction(self):
        """Everything inside is committed together, or rolled back on any exception."""
        if self._in_tx:
            yield self
            return
        self._in_tx = True
        try:
            if self.engine == "postgresql":
                with self._conn.transaction():
                    yield self
            else:
                self._conn.execute("BEGIN TRANSACTION")
                try:
                    yield self
                except BaseException:
                    self._conn.execute("ROLLBACK")
                    raise
                self._conn.execute("COMMIT")
        finally:
            self._in_tx = False

    def insert(self, table: str, rows: list[tuple]) -> None:
        """Append ``rows`` (tuples in the column order of :data:`schema.TABLES`) to ``table``."""
        if not rows:
            return
        cols = schema.columns(table)
        with self._reported():
            self._insert(table, cols, rows)

    def _insert(self, table: str, cols: tuple[str, ...], rows: list[tuple]) -> None:
        if self.engine == "postgresql":
            with self._conn.cursor() as cur:
                with cur.copy(f"COPY {table} ({', '.join(cols)}) FROM STDIN") as cp:
                    for r in rows:
                        cp.write_row(r)
        else:
            self._register_arrow("_mocapkit_rows", schema.TABLES[table], rows)
            try:
                self._conn.execute(f"INSERT INTO {table} ({', '.join(cols)}) SELECT {', '.join(cols)} "
                                   "FROM _mocapkit_rows")
            finally:
                self._conn.unregister("_mocapkit_rows")

    def delete_keys(self, table: str, key: tuple[tuple[str, str], ...], keys: list[tuple]) -> None:
        """Delete the rows of ``table`` whose ``key`` columns (``(name, type)`` pairs) equal one of ``keys``."""
        if not keys:
            return
        with self._reported():
            self._delete_keys(table, key, keys)

    def _delete_keys(self, table: str, key, keys: list[tuple]) -> None:
        match = " AND ".join(f"k.{c} = {table}.{c}" for c, _ in key)
        if self.engine == "postgresql":
            tmp = f"_mocapkit_keys_{'_'.join(c for c, _ in key)}"
            with self._conn.cursor() as cur:
                cur.execute(f"CREATE TEMP TABLE IF NOT EXISTS {tmp} ({', '.join(f'{c} {t}' for c, t in key)})")
                cur.execute(f"TRUNCATE {tmp}")
                with cur.copy(f"COPY {tmp} ({', '.join(c for c, _ in key)}) FROM STDIN") as cp:
                    for k in keys:
                        cp.write_row(k)
                cur.execute(f"DELETE FROM {table} WHERE EXISTS (SELECT 1 FROM {tmp} k WHERE {match})")
        else:
            self._register_arrow("_mocapkit_keys", key, keys)
            try:
                self._conn.execute(f"DELETE FROM {table} WHERE EXISTS (SELECT 1 FROM _mocapkit_keys k "
                                   f"WHERE {match})")
            finally:
                self._conn.unregister("_mocapkit_keys")

    def _register_arrow(self, name: str, cols, rows) -> None:
        import pyarrow as pa

        types = {"TEXT": pa.string(), "BIGINT": pa.int64(), "DOUBLE PRECISION": pa.float64(),
                 "BOOLEAN": pa.bool_(), "TIMESTAMP": pa.timestamp("us")}
        arrays = [pa.array([r[k] for r in rows], type=types[t]) for k, (_, t) in enumerate(cols)]
        self._conn.register(name, pa.Table.from_arrays(arrays, names=[c for c, _ in cols]))

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self._conn.close()

    def __enter__(self) -> "Catalog":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Catalog({redact(self.url)!r}, engine={self.engine!r})"

    # -- schema ------------------------------------------------------------------------------------
    def ensure_schema(self, read_only: bool = False) -> None:
        """Make the tables when missing (``read_only``: only check); refuse a catalog of another schema
        version."""
        with self.transaction():
            if not read_only:
                for stmt in schema.ddl():
                    self.execute(stmt)
            _, rows = self.query("SELECT version FROM schema_version")
            if not rows and read_only:
                raise MocapError(f"{redact(self.url)}: an empty catalog (no schema version): nothing to query")
            if not rows:
                self.execute("INSERT INTO schema_version (version) VALUES (?)", (schema.SCHEMA_VERSION,))
            elif len(rows) == 1 and not read_only and schema.upgrade(rows[0][0]):
                for stmt in schema.upgrade(rows[0][0]):
                    self.execute(stmt)
            elif len(rows) != 1 or rows[0][0] != schema.SCHEMA_VERSION:
                raise MocapError(f"{redact(self.url)}: catalog schema version "
                                 f"{', '.join(str(r[0]) for r in rows)}; this mocapkit reads version "
                                 f"{schema.SCHEMA_VERSION}")


def _duckdb_path(url: str) -> str:
    return url[len("duckdb:"):] if url.startswith("duckdb:") else url


def connect(url: str | os.PathLike, create: bool = True, read_only: bool = False) -> Catalog:
    """Open the catalog at ``url`` (a ``postgresql://`` URL or a DuckDB file path) and make its tables.

    ``create=False`` refuses a DuckDB file that does not exist yet (``catalog query`` on a typo'd path)
    instead of making an empty catalog. ``read_only=True`` (``catalog query``) opens it so that a statement
    cannot change it (DuckDB ``read_only``; PostgreSQL ``default_transaction_read_only``): a guard against
    a slip, not a permission. Raises :class:`MocapError` naming the URL (password hidden).
    """
    if read_only:
        create = False
    url = os.fspath(url)
    shown = redact(url)
    if not url:
        raise MocapError("the catalog URL is empty: give a DuckDB file or postgresql://user@host/db")
    if is_postgres(url):
        try:
            import psycopg
        except ImportError:
            raise MocapError(f"{shown}: a PostgreSQL catalog needs psycopg: pip install "
                             "'mocapkit[postgres]'") from None
        try:
            extra = {}
            if read_only:  # added to the URL's own options (a search_path, say)
                from psycopg.conninfo import conninfo_to_dict

                given = conninfo_to_dict(url).get("options") or ""
                extra["options"] = f"{given} -c default_transaction_read_only=on".strip()
            conn = psycopg.connect(url, connect_timeout=CONNECT_TIMEOUT_S, autocommit=True, **extra)
        except (psycopg.Error, ValueError) as e:
            raise MocapError(f"{shown}: cannot open the catalog: {_clean(e, url)}") from None
        errors: tuple = (psycopg.Error,)
        cat = Catalog(url, "postgresql", conn, errors)
    elif re.match(r"^[A-Za-z][A-Za-z0-9+.-]*://", url):
        raise MocapError(f"{shown}: unknown catalog URL scheme (use postgresql://... or a DuckDB file path)")
    else:
        try:
            import duckdb
        except ImportError:
            raise MocapError(f"{shown}: the embedded catalog needs duckdb: pip install 'mocapkit[batch]'") from None
        path = Path(_duckdb_path(url))
        if path.is_dir():
            raise MocapError(f"{shown}: is a folder, not a DuckDB catalog file")
        if not create and not path.exists():
            raise MocapError(f"{shown}: no such catalog file")
        if not path.parent.is_dir():
            raise MocapError(f"{shown}: the folder {path.parent} does not exist")
        try:
            conn = duckdb.connect(str(path), read_only=read_only)
        except duckdb.Error as e:
            text = _clean(e, url)
            if "lock" in text.lower():
                text = f"the file is in use by another process (DuckDB allows one writer): {text}"
            raise MocapError(f"{shown}: cannot open the catalog: {text}") from None
        errors = (duckdb.Error,)
        cat = Catalog(url, "duckdb", conn, errors)
    try:
        cat.ensure_schema(read_only)
    except BaseException:
        cat.close()
        raise
    return cat


def utc_naive(text: str | None) -> dt.datetime | None:
    """An ISO-8601 time (``...+00:00``/``Z`` or naive UTC) as a naive UTC ``datetime`` (``TIMESTAMP``)."""
    if text is None:
        return None
    t = dt.datetime.fromisoformat(str(text).replace("Z", "+00:00"))
    return t.astimezone(dt.timezone.utc).replace(tzinfo=None) if t.tzinfo else t
