"""``mocapkit ARGS`` run in-process for the tests: exit code, stdout, stderr."""

from __future__ import annotations

import contextlib
import io

from mocapkit import cli


def run(*args) -> tuple[int, str, str]:
    """``mocapkit ARGS`` in-process: exit code, stdout, stderr."""
    out, errs = io.StringIO(), io.StringIO()
    code = None
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(errs):
            cli.main([str(a) for a in args])
    except SystemExit as e:
        code = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
    assert code is not None
    return code, out.getvalue(), errs.getvalue()
