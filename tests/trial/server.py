"""A clean process that runs trial cases for the test suite (``python -m tests.trial.server``).

The pytest process may have started threads (numba, other tests); forking it is not safe. This server
is a fresh interpreter: it imports mocapkit, compiles the commands' numba code once (``--warm`` argv
lists on its first request), then forks one child per request. Protocol: one JSON object per line on
stdin, one JSON reply per line on stdout.

Requests: ``{"op": "cli", "argv": [...], "stdin": path|null, "timeout": s, "kill_after": s|null, "cwd": path|null}`` →
the :class:`~tests.trial.runner.Run` fields; ``{"op": "digest", "path", "fmt", "options"}`` → the
:func:`~tests.trial.oracle.digest` record; ``{"op": "warm", "argvs": [[...]], "stdins": [...]}``.
"""

from __future__ import annotations

import base64
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def serve() -> None:
    sys.path.insert(0, str(ROOT))
    from tests.trial import oracle, runner  # run as python -m tests.trial.server

    out = os.fdopen(os.dup(1), "w")  # the reply channel; anything else written to fd 1 is dropped
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)
    os.close(null)
    runner.preload()
    for line in sys.stdin:
        req = json.loads(line)
        op = req["op"]
        if op == "cli":
            r = runner.run_cli(req["argv"], stdin=req.get("stdin"), timeout=req.get("timeout", 60),
                               kill_after=req.get("kill_after"), mem=req.get("mem", runner.DEFAULT_MEM),
                               cwd=req.get("cwd"))
            rep = {"argv": r.argv, "returncode": r.returncode, "signal": r.signal, "timed_out": r.timed_out,
                   "seconds": r.seconds, "maxrss_mb": r.maxrss_mb, "extra": r.extra,
                   "stdout": base64.b64encode(r.stdout).decode(), "stderr": base64.b64encode(r.stderr).decode()}
        elif op == "digest":
            rep = runner.call_in_child(oracle.digest, req["path"], req["fmt"], req.get("options") or {},
                                       timeout=req.get("timeout", 60))
        elif op == "warm":
            runner.warm_up(req["argvs"], req.get("stdins"))
            rep = {"status": "ok"}
        else:
            rep = {"status": "unknown op"}
        out.write(json.dumps(rep) + "\n")
        out.flush()


class Client:
    """The test suite's handle on a server process."""

    def __init__(self) -> None:
        env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
        self.proc = subprocess.Popen([sys.executable, "-m", "tests.trial.server"], cwd=ROOT, env=env,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)

    def _ask(self, req: dict) -> dict:
        self.proc.stdin.write(json.dumps(req) + "\n")
        self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError("the trial server died")
        return json.loads(line)

    def run(self, argv, *, stdin=None, timeout: float = 60, kill_after: float | None = None, cwd=None):
        from .runner import Run

        rep = self._ask({"op": "cli", "argv": [str(a) for a in argv], "stdin": None if stdin is None else str(stdin),
                         "timeout": timeout, "kill_after": kill_after, "cwd": None if cwd is None else str(cwd)})
        return Run(rep["argv"], rep["returncode"], rep["signal"], base64.b64decode(rep["stdout"]),
                   base64.b64decode(rep["stderr"]), rep["seconds"], rep["maxrss_mb"], rep["timed_out"], rep["extra"])

    def digest(self, path, fmt: str, options: dict | None = None, timeout: float = 60) -> dict:
        return self._ask({"op": "digest", "path": str(path), "fmt": fmt, "options": options or {},
                          "timeout": timeout})

    def warm(self, argvs, stdins=None) -> None:
        self._ask({"op": "warm", "argvs": [[str(a) for a in v] for v in argvs],
                   "stdins": [None if s is None else str(s) for s in stdins] if stdins else None})

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.stdin.close()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


_CLIENT: Client | None = None


def shared_client() -> Client:
    """One server for the whole test session (closed at exit)."""
    import atexit

    global _CLIENT
    if _CLIENT is None or _CLIENT.proc.poll() is not None:
        _CLIENT = Client()
        atexit.register(_CLIENT.close)
        _warm(_CLIENT)
    return _CLIENT


def _warm(client: Client) -> None:
    """Compile the usual commands' numba code once in the server (outputs in a temporary folder)."""
    import tempfile

    data = ROOT / "tests" / "data"
    with tempfile.TemporaryDirectory(prefix="mocapkit-warm-") as d:
        imu, bvh = data / "xio" / "pelvis" / "Quaternion.csv", data / "bvh" / "walk-meredith-60.bvh"
        tsv = data / "markers" / "juggling-qualisys-300hz-first120.tsv"
        client.warm([["compress", imu, "-t", "0.001", "-o", f"{d}/p.csv"],
                     ["compress", imu, "--max-angle", "1", "--json"],
                     ["decompress", f"{d}/p.csv", "-o", f"{d}/d.csv", "--rate", "50"],
                     ["compress", bvh, "-o", f"{d}/c.glb", "--max-position-error", "1", "--unit-cm", "1"],
                     ["decompress", f"{d}/c.glb", "-o", f"{d}/d.bvh"],
                     ["convert", bvh, f"{d}/o.bvh"], ["info", bvh, "--json"],
                     ["segment", bvh, "-m", "pca", "--json"], ["filter", tsv, "--auto", "--json"]])


if __name__ == "__main__":
    serve()
