"""Run one ``mocapkit`` command (or one Python call) in a child with a timeout and a memory limit.

Two ways to run the CLI, with the same result record (:class:`Run`):

- ``mode="fork"``: the calling process has imported :mod:`mocapkit.cli` once; each case is an
  ``os.fork()`` whose child redirects its standard streams, sets ``RLIMIT_AS`` and calls
  ``mocapkit.cli.main()`` with ``sys.argv`` set, exactly what the console script does. 50-100× cheaper
  than a fresh interpreter, which makes thousands of cases possible on two cores;
- ``mode="subprocess"``: ``.venv/bin/mocapkit`` (the real console script) with ``preexec_fn`` setting the
  same limit.

The parent never runs numba code and starts no thread, so a fork is safe.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import resource
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
MOCAPKIT = ROOT / ".venv" / "bin" / "mocapkit"
DEFAULT_MEM = 2 << 30  # 2 GiB of address space per case
DEFAULT_TIMEOUT = 30.0


@dataclass
class Run:
    """What one child did."""

    argv: list[str]
    returncode: int | None  # None: killed by us at the timeout
    signal: int | None  # the signal that ended the child (not ours), if any
    stdout: bytes
    stderr: bytes
    seconds: float
    maxrss_mb: float
    timed_out: bool = False
    extra: dict = field(default_factory=dict)

    @property
    def err_text(self) -> str:
        return self.stderr.decode("utf-8", "replace")

    @property
    def out_text(self) -> str:
        return self.stdout.decode("utf-8", "replace")

    def first_error_line(self) -> str:
        lines = [ln for ln in self.err_text.splitlines() if ln.strip()]
        for ln in lines:
            if ln.startswith("error:") or "Error" in ln or "Traceback" in ln:
                return ln[:300]
        return (lines[-1] if lines else "")[:300]


def _limit(mem: int | None) -> None:
    if mem:
        resource.setrlimit(resource.RLIMIT_AS, (mem, mem))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


def _fresh_consoles() -> None:
    """The CLI's rich consoles were made in the parent; make them again for the child's streams."""
    cli = sys.modules.get("mocapkit.cli")
    if cli is not None and hasattr(cli, "_console"):
        for name, stderr in (("err", True), ("console", False)):
            if hasattr(cli, name):
                setattr(cli, name, cli._console(stderr=stderr))


def _child_cli(argv: list[str]) -> int:
    import mocapkit.cli as cli

    sys.argv = ["mocapkit", *argv]
    try:
        cli.main()
        return 0
    except SystemExit as e:
        code = e.code
        if code is None:
            return 0
        if isinstance(code, int):
            return code
        sys.stderr.write(f"{code}\n")
        return 1
    except KeyboardInterrupt:
        return 130
    except BaseException:  # what the interpreter would print for an uncaught exception
        traceback.print_exc()
        return 1


def _fork(target, argv: list[str], stdin: str | Path | None, cwd: str | Path | None, timeout: float,
          mem: int | None, env: dict | None, kill_after: float | None = None) -> Run:
    with tempfile.TemporaryFile() as fo, tempfile.TemporaryFile() as fe:
        sys.stdout.flush()
        sys.stderr.flush()
        t0 = time.monotonic()
        pid = os.fork()
        if pid == 0:  # child
            code = 1
            try:
                os.setpgid(0, 0)
                fin = os.open(stdin if stdin is not None else os.devnull, os.O_RDONLY)
                os.dup2(fin, 0)
                os.dup2(fo.fileno(), 1)
                os.dup2(fe.fileno(), 2)
                sys.stdin = io.TextIOWrapper(io.BufferedReader(io.FileIO(0, "r", closefd=False)))
                sys.stdout = io.TextIOWrapper(io.BufferedWriter(io.FileIO(1, "w", closefd=False)), write_through=True)
                sys.stderr = io.TextIOWrapper(io.BufferedWriter(io.FileIO(2, "w", closefd=False)),
                                              write_through=True, errors="backslashreplace")
                if cwd is not None:
                    os.chdir(cwd)
                if env:
                    os.environ.update(env)
                _limit(mem)
                _fresh_consoles()
                code = target(argv)
            except BaseException:
                with contextlib.suppress(BaseException):
                    traceback.print_exc()
            finally:
                try:
                    sys.stdout.flush()
                    sys.stderr.flush()
                except BaseException:
                    pass
                os._exit(code if isinstance(code, int) and 0 <= code < 256 else 1)
        timed_out = False
        status = None
        rusage = None
        deadline = t0 + timeout
        killed_by_us = False
        delay = 0.001
        while True:
            wpid, st, ru = os.wait4(pid, os.WNOHANG)
            if wpid == pid:
                status, rusage = st, ru
                break
            now = time.monotonic()
            if kill_after is not None and not killed_by_us and now - t0 >= kill_after:
                os.kill(pid, signal.SIGKILL)
                killed_by_us = True
            if now >= deadline and not killed_by_us:
                timed_out = True
                killed_by_us = True
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(pid, signal.SIGKILL)
            time.sleep(delay)
            delay = min(delay * 1.5, 0.02)
        seconds = time.monotonic() - t0
        fo.seek(0)
        fe.seek(0)
        out, errb = fo.read(), fe.read()
    sig = os.WTERMSIG(status) if os.WIFSIGNALED(status) else None
    rc = os.WEXITSTATUS(status) if os.WIFEXITED(status) else None
    run = Run(argv, rc, None if killed_by_us else sig, out, errb, seconds, rusage.ru_maxrss / 1024.0, timed_out)
    if killed_by_us and not timed_out:
        run.extra["killed_at"] = kill_after
    return run


def run_cli(argv: list[str], *, stdin: str | Path | None = None, cwd: str | Path | None = None,
            timeout: float = DEFAULT_TIMEOUT, mem: int | None = DEFAULT_MEM, mode: str = "fork",
            env: dict | None = None, kill_after: float | None = None) -> Run:
    """Run ``mocapkit *argv`` in a child (see the module docstring for ``mode``)."""
    argv = [str(a) for a in argv]
    if mode == "fork":
        import mocapkit.cli  # noqa: F401  (imported once, in the parent)

        return _fork(_child_cli, argv, stdin, cwd, timeout, mem, env, kill_after)
    return _subprocess(argv, stdin, cwd, timeout, mem, env, kill_after)


def _subprocess(argv, stdin, cwd, timeout, mem, env, kill_after) -> Run:
    full_env = dict(os.environ, COLUMNS="100000", **(env or {}))
    fin = open(stdin, "rb") if stdin is not None else subprocess.DEVNULL  # noqa: SIM115 - optional; closed below
    t0 = time.monotonic()
    try:
        proc = subprocess.Popen([str(MOCAPKIT), *argv], stdin=fin, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                cwd=cwd, env=full_env, preexec_fn=lambda: (_limit(mem), os.setpgid(0, 0)))
        wait = timeout if kill_after is None else min(timeout, kill_after)
        try:
            out, errb = proc.communicate(timeout=wait)
            timed_out = False
            killed = False
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            out, errb = proc.communicate()
            timed_out = kill_after is None or kill_after >= timeout
            killed = True
    finally:
        if stdin is not None:
            fin.close()
    seconds = time.monotonic() - t0
    rc = proc.returncode
    sig = -rc if rc is not None and rc < 0 else None
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)  # cumulative: an upper bound only
    run = Run(argv, None if killed else (rc if rc >= 0 else None), None if killed else sig, out, errb, seconds,
              ru.ru_maxrss / 1024.0, timed_out)
    if killed and not timed_out:
        run.extra["killed_at"] = kill_after
    return run


def preload() -> None:
    """Import every mocapkit module once, so forked children start with them loaded."""
    import importlib
    import pkgutil

    import mocapkit

    for m in pkgutil.walk_packages(mocapkit.__path__, "mocapkit."):
        if m.name.endswith("__main__"):
            continue
        with contextlib.suppress(Exception):  # a module broken mid-edit: the cases will show it
            importlib.import_module(m.name)


def warm_up(argvs: list[list[str]], stdins: list | None = None) -> None:
    """Run valid commands in this process (streams sent to /dev/null) so their numba functions are
    compiled here once and every forked child inherits them. No command here runs parallel numba code."""
    import mocapkit.cli as cli

    preload()
    saved = [os.dup(0), os.dup(1), os.dup(2)]
    saved_std = (sys.stdin, sys.stdout, sys.stderr, sys.argv)
    null = os.open(os.devnull, os.O_RDWR)
    try:
        for k, argv in enumerate(argvs):
            stdin = stdins[k] if stdins else None
            fin = os.open(stdin, os.O_RDONLY) if stdin else null
            os.dup2(fin, 0)
            os.dup2(null, 1)
            os.dup2(null, 2)
            sys.stdin = io.TextIOWrapper(io.BufferedReader(io.FileIO(0, "r", closefd=False)))
            sys.stdout = io.TextIOWrapper(io.BufferedWriter(io.FileIO(1, "w", closefd=False)), write_through=True)
            sys.stderr = io.TextIOWrapper(io.BufferedWriter(io.FileIO(2, "w", closefd=False)), write_through=True)
            sys.argv = ["mocapkit", *[str(a) for a in argv]]
            _fresh_consoles()
            with contextlib.suppress(BaseException):
                cli.main()
            for f in (sys.stdout, sys.stderr, saved_std[1], saved_std[2]):
                with contextlib.suppress(OSError, ValueError):
                    f.flush()  # while fds 1 and 2 still point to /dev/null
            if fin != null:
                os.close(fin)
    finally:
        for fd, s in zip((0, 1, 2), saved, strict=True):
            os.dup2(s, fd)
            os.close(s)
        os.close(null)
        sys.stdin, sys.stdout, sys.stderr, sys.argv = saved_std
        _fresh_consoles()


def _child_call(payload) -> int:
    fn, args, out_path = payload
    try:
        res = fn(*args)
        status = 0
    except BaseException as e:  # reported, never raised: the parent classifies it
        res = {"status": "exception", "type": type(e).__name__, "message": str(e)[:500],
               "traceback": traceback.format_exc()[-3000:]}
        status = 3
    with open(out_path, "w") as fh:
        json.dump(res, fh)
    return status


def call_in_child(fn, *args, timeout: float = DEFAULT_TIMEOUT, mem: int | None = DEFAULT_MEM) -> dict:
    """``fn(*args)`` in a forked child; returns its JSON-able result, or a record of how it failed
    (``{"status": "hang"|"signal"|"exception"|...}``)."""
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "result.json")
        run = _fork(_child_call, (fn, args, out), None, None, timeout, mem, None)
        if run.timed_out:
            return {"status": "hang", "seconds": run.seconds}
        if run.signal is not None:
            return {"status": "signal", "signal": run.signal, "stderr": run.err_text[-2000:]}
        try:
            with open(out) as fh:
                res = json.load(fh)
        except (OSError, ValueError):
            return {"status": "died", "returncode": run.returncode, "stderr": run.err_text[-2000:]}
        if isinstance(res, dict):
            res.setdefault("maxrss_mb", run.maxrss_mb)
            res.setdefault("seconds", run.seconds)
        return res
