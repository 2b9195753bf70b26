"""``mocapkit catalog query|import``: read the motion catalog with SQL, register recordings without a job.

Thin like ``cli.py``: parse, call :mod:`mocapkit.catalog`, print. Results on stdout (a rich table, CSV or a
strict JSON list of objects), diagnostics on stderr.
"""

from __future__ import annotations

import csv
import datetime as dt
import io
import math
import sys
from enum import Enum
from typing import Annotated, Optional

import typer

from mocapkit.cli_options import AsfOpt, _json, _progress, console, err

catalog_app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    help="The motion catalog (DuckDB file or PostgreSQL server): query it with SQL, register recordings.",
)

DbOpt = Annotated[str, typer.Option("--db", help="The catalog: a DuckDB file (motion.duckdb) or "
                                                 "postgresql://user@host:port/database.")]


class Format(str, Enum):
    table = "table"
    csv = "csv"
    json = "json"


def _value(v):
    """A result value for CSV/JSON: times as ISO-8601, everything else as it is."""
    if isinstance(v, (dt.datetime, dt.date, dt.time)):
        return v.isoformat()
    if isinstance(v, (bytes, bytearray, memoryview)):
        return bytes(v).hex()
    return v


def _cell(v) -> str:
    if v is None:
        return "NULL"
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else str(v)
    return str(_value(v))


@catalog_app.command("query")
def query(
    sql: Annotated[str, typer.Argument(help="One SQL statement, e.g. \"SELECT kind, count(*) FROM recordings "
                                            "GROUP BY kind\".")],
    db: DbOpt,
    fmt: Annotated[Format, typer.Option("--format", help="table (rich, on stdout), csv, or json (a list of "
                                                         "objects).")] = Format.table,
) -> None:
    """Run one SQL query on the catalog (opened read-only) and print its result."""
    from mocapkit.catalog import open_catalog

    with open_catalog(db, read_only=True) as cat:
        cols, rows = cat.query(sql)
    if fmt is Format.json:
        print(_json([{c: _value(v) for c, v in zip(cols, r)} for r in rows], "catalog query --format json"))
    elif fmt is Format.csv:
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        if cols:
            w.writerow(cols)
        w.writerows([["" if v is None else _cell(v) for v in r] for r in rows])
        sys.stdout.write(buf.getvalue())
    else:
        from rich.table import Table
        from rich.text import Text

        tab = Table(caption=f"{len(rows)} row{'s' if len(rows) != 1 else ''}")
        for c in cols:
            tab.add_column(Text(c), overflow="fold")
        for r in rows:
            tab.add_row(*(Text(_cell(v)) for v in r))  # Text: a value is never read as rich markup
        console.print(tab)


@catalog_app.command("import")
def import_cmd(
    inputs: Annotated[list[str], typer.Argument(help="Folders (walked recursively), files and quoted globs.")],
    db: DbOpt,
    asf: AsfOpt = None,
) -> None:
    """Register recordings (format, rate, frames, subject/take, BIDS-Motion channels) without running a job.

    A file that cannot be read is reported with its error on stderr and the others go on. Exit 0 when
    at least one recording was registered, else 2.
    """
    from mocapkit.jobs.inputs import expand_inputs
    from mocapkit.catalog import open_catalog
    from mocapkit.catalog.engine import redact
    from mocapkit.catalog.register import import_folder

    n = len(expand_inputs(inputs).files)  # names nothing -> one-line error before the catalog is opened
    with open_catalog(db) as cat, _progress("registering", n) as update:
        done = [0]

        def on_file(path: str, error: Optional[str]) -> None:
            done[0] += 1
            update(done[0])
            if error is not None:
                err.print(f"error: {error}", markup=False, highlight=False, soft_wrap=True)

        res = import_folder(cat, inputs, asf=asf, on_file=on_file)
    for path, w in res.warnings:
        err.print(f"warning: {path}: {w}", markup=False, highlight=False, soft_wrap=True)
    for path, why in res.skipped:
        err.print(f"skipped: {path}: {why}", markup=False, highlight=False, soft_wrap=True)
    n_warned = len({p for p, _ in res.warnings})
    console.print(f"{len(res.registered)} recording{'s' if len(res.registered) != 1 else ''} registered"
                  f"{f' ({n_warned} with warnings)' if n_warned else ''}, "
                  f"{len(res.errors)} error{'s' if len(res.errors) != 1 else ''}, {len(res.skipped)} skipped "
                  f"in {redact(db)}", markup=False, highlight=False)
    if not res.registered:
        raise typer.Exit(2)
