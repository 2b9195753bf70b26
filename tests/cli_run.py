"""``mocapkit ARGS`` run in-process for the tests: exit code, stdout, stderr.

In-process runs share the interpreter's imports and compiled kernels with the other tests of a worker;
a test whose point is the real process (exit status of the binary, pipes, signals, memory of a fresh
interpreter) starts ``python -m mocapkit`` itself."""

from __future__ import annotations

import contextlib
import io
import subprocess
import sys

from mocapkit import cli


def run(*args, stdin: str | None = None) -> tuple[int, str, str]:
    """``mocapkit ARGS`` in-process (``stdin`` as its standard input): exit code, stdout, stderr."""
    out, errs = io.StringIO(), io.StringIO()
    code = None
    old_stdin = sys.stdin
    try:
        if stdin is not None:
            sys.stdin = io.StringIO(stdin)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(errs):
            cli.main([str(a) for a in args])
    except SystemExit as e:
        code = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
    finally:
        sys.stdin = old_stdin
    assert code is not None
    return code, out.getvalue(), errs.getvalue()


def completed(*args, stdin: str | None = None) -> subprocess.CompletedProcess:
    """:func:`run` as a :class:`subprocess.CompletedProcess` (``returncode``, ``stdout``, ``stderr``)."""
    code, out, err = run(*args, stdin=stdin)
    return subprocess.CompletedProcess([str(a) for a in args], code, out, err)
