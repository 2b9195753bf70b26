"""One small interface over the catalog's two engines: DuckDB (a file, embedded) and PostgreSQL (a server).

:func:`connect` takes ``postgresql://user[:password]@host[:port]/database`` (or ``postgres://``) for a
server, anything else as the path of a DuckDB file (``duckdb:PATH`` also works). :class:`Catalog` hides
what differs: placeholders (write ``?``; PostgreSQL gets ``%s``), transactions, bulk inserts (DuckDB reads
an Arrow table, PostgreSQL a ``COPY``) and result values (``Decimal`` → ``float``). The tables are made
when missing (:mod:`mocapkit.catalog.schema`); a database that holds tables but is not a mocapkit catalog
is refused before anything is written to it. :meth:`Catalog.read` runs one read-only query and streams
its rows (:mod:`mocapkit.catalog.reading`).

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
from typing import Any
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


def _clean(message: str | BaseException, url: str) -> str:
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
    def read(self, sql: str, chunk_rows: int = 10_000):
        """Run one read-only statement (a ``SELECT``, ``WITH``, ``VALUES``, ``SHOW``/``DESCRIBE`` or
        ``EXPLAIN`` of one); yields ``(columns, chunks)``: the column names (duplicates kept) and an
        iterator of lists of at most ``chunk_rows`` rows, fetched as they are consumed. Anything else — a
        second statement, ``COPY``, ``ATTACH``, ``INSTALL``/``LOAD``, ``PRAGMA``, ``SET``, DDL or DML —
        is a :class:`MocapError` before it runs. Values are made printable by the engine where Python's
        would lose something (:func:`mocapkit.catalog.reading.printable_projection`)."""
        from mocapkit.catalog import reading

        shown = redact(self.url)
        with self._reported():
            if self.engine == "postgresql":
                reading.use_lenient_loaders(self._conn)
                with self._conn.transaction():
                    self._conn.execute("SET TRANSACTION READ ONLY")
                    # a server-side cursor: DECLARE takes one SELECT/VALUES/TABLE, nothing else
                    with self._conn.cursor(name="mocapkit_read") as cur:
                        cur.execute(reading.one_read_statement(sql, shown))
                        cols = [d.name for d in cur.description or ()]
                        yield cols, self._chunks(cur, chunk_rows)
            else:
                text = reading.one_duckdb_read(self._conn, sql, shown)
                rel = self._conn.sql(text)  # bound, not run: the names and types of the result
                cols = list(rel.columns)
                exprs = reading.printable_projection(rel.types)
                if exprs:  # positional references: columns of one name stay apart
                    text = f"SELECT {', '.join(exprs)} FROM (\n{text}\n) AS q"
                cur = self._conn.execute(text)
                yield cols, self._chunks(cur, chunk_rows)

    def _chunks(self, cur, chunk_rows: int):
        while True:
            with self._reported():
                rows = cur.fetchmany(chunk_rows)
            if not rows:
                return
            yield rows

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
            with self._conn.cursor() as cur, cur.copy(f"COPY {table} ({', '.join(cols)}) FROM STDIN") as cp:
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

    def __enter__(self) -> Catalog:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Catalog({redact(self.url)!r}, engine={self.engine!r})"

    # -- schema ------------------------------------------------------------------------------------
    def ensure_schema(self, read_only: bool = False) -> None:
        """Make the tables when missing (``read_only``: only check); refuse a catalog of another schema
        version, and a database with tables that is not a mocapkit catalog, before writing anything."""
        with self.transaction():
            self._refuse_foreign()
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
                how = (" (upgraded in place by the next command that writes to it: `mocapkit catalog import` or "
                       "`mocapkit batch ... --db`)" if read_only and len(rows) == 1 and schema.upgrade(rows[0][0])
                       else "")
                raise MocapError(f"{redact(self.url)}: catalog schema version "
                                 f"{', '.join(str(r[0]) for r in rows)}; this mocapkit reads version "
                                 f"{schema.SCHEMA_VERSION}{how}")

    def _tables(self) -> dict[str, set[str]]:
        """The tables of the catalog's own schema (DuckDB ``main``, PostgreSQL ``current_schema()``) and
        their columns, lower case."""
        where = ("table_catalog = current_database() AND table_schema = 'main'" if self.engine == "duckdb"
                 else "table_schema = current_schema()")
        _, rows = self.query(f"SELECT table_name, column_name FROM information_schema.columns WHERE {where}")
        out: dict[str, set[str]] = {}
        for t, c in rows:
            out.setdefault(str(t).lower(), set()).add(str(c).lower())
        return out

    def _refuse_foreign(self) -> None:
        """A database that has tables but no mocapkit ``schema_version``, or (at this schema version) a
        catalog table without its key columns, is someone else's: refused before anything is written.
        A catalog of another version is left to the version check."""
        tables = self._tables()
        if not tables:
            return
        shown = redact(self.url)
        if "schema_version" not in tables or "version" not in tables["schema_version"]:
            names = ", ".join(sorted(tables)[:5]) + (" ..." if len(tables) > 5 else "")
            raise MocapError(f"{shown}: not a mocapkit catalog (it has tables {names} but no schema_version); "
                             "give a new file or database")
        _, rows = self.query("SELECT version FROM schema_version")
        if rows != [(schema.SCHEMA_VERSION,)]:
            return
        for table, cols in KEY_COLUMNS.items():
            missing = [c for c in cols if table in tables and c not in tables[table]]
            if missing:
                raise MocapError(f"{shown}: not a mocapkit catalog: its table {table} has no column "
                                 f"{', '.join(missing)}")


#: the columns a catalog table must have to be taken for mocapkit's (its key; metrics has none)
KEY_COLUMNS = {**schema.PRIMARY_KEYS, "metrics": ("run_id", "name", "value")}


def _duckdb_path(url: str) -> str:
    return url[len("duckdb:"):] if url.startswith("duckdb:") else url


def connect(url: str | os.PathLike, create: bool = True, read_only: bool = False) -> Catalog:
    """Open the catalog at ``url`` (a ``postgresql://`` URL or a DuckDB file path) and make its tables.

    ``create=False`` refuses a DuckDB file that does not exist yet (``catalog query`` on a typo'd path)
    instead of making an empty catalog. ``read_only=True`` (``catalog query``) opens it so that a statement
    cannot change it (DuckDB ``read_only`` with external access disabled and the configuration locked;
    PostgreSQL ``default_transaction_read_only``): a guard against a slip, not a permission. Raises :class:`MocapError`
    naming the URL (password hidden).
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
            extra: dict[str, Any] = {}
            if read_only:  # added to the URL's own options (a search_path, say)
                from psycopg.conninfo import conninfo_to_dict

                given = conninfo_to_dict(url).get("options") or ""
                extra["options"] = f"{given} -c default_transaction_read_only=on".strip()
            pg_conn = psycopg.connect(url, connect_timeout=CONNECT_TIMEOUT_S, autocommit=True, **extra)
        except (psycopg.Error, ValueError) as e:
            raise MocapError(f"{shown}: cannot open the catalog: {_clean(e, url)}") from None
        errors: tuple = (psycopg.Error,)
        cat = Catalog(url, "postgresql", pg_conn, errors)
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
        if path.exists() and not path.is_file():  # opening a FIFO waits for a writer
            raise MocapError(f"{shown}: not a regular file (a device, FIFO or socket), not a DuckDB catalog file")
        if not create and not path.exists():
            raise MocapError(f"{shown}: no such catalog file")
        if not path.parent.is_dir():
            raise MocapError(f"{shown}: the folder {path.parent} does not exist")
        # never a progress bar on stdout (a long query would draw one into the CSV); read-only: no file but
        # this one (no COPY TO, ATTACH, read_csv, INSTALL/LOAD), and the settings locked
        config: dict[str, str | bool | int | float | list[str]]
        config = ({"enable_external_access": False, "autoinstall_known_extensions": False,
                   "autoload_known_extensions": False} if read_only else {})
        try:
            conn = duckdb.connect(str(path), read_only=read_only, config=config)
        except duckdb.Error as e:
            text = _clean(e, url)
            if "lock" in text.lower():
                text = f"the file is in use by another process (DuckDB allows one writer): {text}"
            raise MocapError(f"{shown}: cannot open the catalog: {text}") from None
        errors = (duckdb.Error,)
        cat = Catalog(url, "duckdb", conn, errors)
    try:
        if cat.engine == "duckdb":
            cat.execute("SET enable_progress_bar = false")  # session settings: not in connect's config
            if read_only:
                cat.execute("SET lock_configuration = true")
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
    return t.astimezone(dt.UTC).replace(tzinfo=None) if t.tzinfo else t
