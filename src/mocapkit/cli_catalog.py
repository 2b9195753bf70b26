"""``mocapkit catalog query|import``: read the motion catalog with SQL, register recordings without a job.

Thin like ``cli.py``: parse, call :mod:`mocapkit.catalog`, print. Results on stdout as they come (a rich
table, CSV or a strict JSON array of objects: :mod:`mocapkit.catalog.printing`), diagnostics on stderr.
"""

from __future__ import annotations

import sys
from enum import Enum
from typing import Annotated

import typer

from mocapkit.cli_options import AsfOpt, _progress, console, err

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


#: rows a rich table shows; the rest are counted, not kept (CSV and JSON write every row)
TABLE_ROWS = 1000
#: characters of one value a table cell shows (CSV and JSON write it whole)
TABLE_CELL_CHARS = 2000


def _table_cell(v) -> str:
    from mocapkit.catalog import printing

    text = printing.cell(v)
    if len(text) <= TABLE_CELL_CHARS:
        return text
    return f"{text[:TABLE_CELL_CHARS]}… ({len(text)} characters; --format csv or json writes them all)"


def _one_statement(sql: str) -> str:
    if not sql.strip():
        raise typer.BadParameter("the query is empty: give one SQL statement")
    return sql


@catalog_app.command("query")
def query(
    sql: Annotated[str, typer.Argument(help="One SQL statement that reads, e.g. \"SELECT kind, count(*) FROM "
                                            "recordings GROUP BY kind\".", callback=_one_statement)],
    db: DbOpt,
    fmt: Annotated[Format, typer.Option("--format", help="table (rich, on stdout; the first 1000 rows, 2000 "
                                                         "characters of a value), csv, "
                                                         "or json (an array of objects, one a line).")] = Format.table,
) -> None:
    """Run one reading SQL statement on the catalog (opened read-only; COPY, ATTACH, INSTALL/LOAD, PRAGMA,
    SET, DDL and DML are refused) and print its result as it comes."""
    from mocapkit.catalog import open_catalog, printing

    with open_catalog(db, read_only=True) as cat, cat.read(sql) as (cols, chunks):
        if fmt is Format.json:
            keys = printing.json_keys(cols)
            renamed = [f"{c} -> {k}" for c, k in zip(cols, keys, strict=True) if c != k]
            if renamed:
                err.print(f"note: columns of one name get JSON keys {', '.join(renamed)}", markup=False,
                          highlight=False, soft_wrap=True)
            printing.write_json(cols, chunks, sys.stdout)
            return
        if fmt is Format.csv:
            printing.write_csv(cols, chunks, sys.stdout)
            return
        shown: list[tuple] = []
        total = 0
        for rows in chunks:
            shown += rows[:TABLE_ROWS - len(shown)]
            total += len(rows)
    from rich.table import Table
    from rich.text import Text

    cut = total > len(shown)
    tab = Table(caption=None if cut else f"{total} row{'s' if total != 1 else ''}")
    for c in cols:
        tab.add_column(Text(c), overflow="fold")
    for r in shown:
        tab.add_row(*(Text(_table_cell(v)) for v in r))  # Text: a value is never read as rich markup
    console.print(tab)
    if cut:
        console.print(f"the first {len(shown)} of {total} rows shown (--format csv or json writes them all)",
                      markup=False, highlight=False, soft_wrap=True)


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
    from mocapkit.catalog import open_catalog
    from mocapkit.catalog.engine import redact
    from mocapkit.catalog.register import import_folder
    from mocapkit.jobs.inputs import expand_inputs

    n = len(expand_inputs(inputs).files)  # names nothing -> one-line error before the catalog is opened
    with open_catalog(db) as cat, _progress("registering", n) as update:
        done = [0]

        def on_file(path: str, error: str | None) -> None:
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
