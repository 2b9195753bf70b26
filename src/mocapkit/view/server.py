"""The viewer's HTTP server (standard library): 127.0.0.1 only, a fixed table of routes built at start.

Routes: ``/`` (the page), ``/static/<file>`` (the files shipped in ``view/static``, three.js among them),
``/scene.json`` and ``/files/<i>/<name>`` (the i-th file named on the command line, as it is on disk).
A request is looked up in the table as sent, never decoded into a path, so ``../``, ``%2e%2e``,
absolute paths and every file not named cannot be reached; a Host header other than the server's own
address (DNS rebinding) is refused, as are methods other than GET and HEAD.
"""

from __future__ import annotations

import base64
import hashlib
import json
import os
import re
import shutil
import threading
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from pathlib import Path
from urllib.parse import quote

from mocapkit.errors import MocapError

HOST = "127.0.0.1"
CONTENT_TYPES = {".html": "text/html; charset=utf-8", ".js": "text/javascript; charset=utf-8",
                 ".css": "text/css; charset=utf-8", ".json": "application/json", ".png": "image/png",
                 ".svg": "image/svg+xml"}
#: nothing but this server: scripts, styles, images and fetches from 'self'; the one inline script, the
#: importmap, is allowed by its hash (:func:`security_headers`)
CSP = ("default-src 'self'; script-src 'self' {hashes}; style-src 'self' 'unsafe-inline'; img-src 'self' data: blob:; "
       "connect-src 'self'; object-src 'none'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'")
_INLINE_SCRIPT = re.compile(rb"<script(?![^>]*\bsrc=)[^>]*>(.*?)</script>", re.DOTALL | re.IGNORECASE)


def security_headers(index_html: bytes) -> dict[str, str]:
    """The headers of every answer; the CSP names the sha256 of each inline script of the page."""
    hashes = " ".join(f"'sha256-{base64.b64encode(hashlib.sha256(m).digest()).decode()}'"
                      for m in _INLINE_SCRIPT.findall(index_html))
    return {"Content-Security-Policy": CSP.format(hashes=hashes).replace("  ", " "), **HEADERS}


HEADERS = {
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
    "Cache-Control": "no-store",
    "Cross-Origin-Resource-Policy": "same-origin",
}


def static_dir() -> Path:
    return Path(str(resources.files("mocapkit.view") / "static"))


def _content_type(name: str) -> str:
    return CONTENT_TYPES.get(Path(name).suffix.lower(), "text/plain; charset=utf-8")


def routes(scene: dict, files: list[Path]) -> dict[str, tuple[str, bytes | Path]]:
    """``{request path: (content type, bytes | Path)}``: everything the server will ever send."""
    root = static_dir()
    table: dict[str, tuple[str, bytes | Path]] = {}
    for f in sorted(root.rglob("*")):
        if f.is_file() and not f.name.startswith("."):
            rel = f.relative_to(root).as_posix()
            table["/static/" + quote(rel)] = (_content_type(rel), f)
    index = root / "index.html"
    table["/"] = table["/index.html"] = (CONTENT_TYPES[".html"], index)
    table["/scene.json"] = ("application/json", json.dumps(scene, allow_nan=False, separators=(",", ":")).encode())
    for i, f in enumerate(files):
        f = Path(f)
        if f.is_file():
            table[f"/files/{i}/{quote(f.name)}"] = ("application/octet-stream", f.resolve())
    return table


class _Handler(BaseHTTPRequestHandler):
    server_version = "mocapkit-view"
    sys_version = ""
    protocol_version = "HTTP/1.1"
    timeout = 60  # an idle keep-alive connection is closed after a minute
    server: ViewServer

    def _end_headers(self) -> None:
        """The shared headers, then the end of the head. A request that came with a body (never read) ends the
        connection, so its bytes are never taken for a next request."""
        for k, v in self.server.answer_headers.items():
            self.send_header(k, v)
        if self.headers.get("Content-Length", "0").strip() not in ("", "0") or "Transfer-Encoding" in self.headers:
            self.close_connection = True
            self.send_header("Connection", "close")
        self.end_headers()

    def _refuse(self, status: HTTPStatus, why: str) -> None:
        body = f"{status.value} {status.phrase}: {why}\n".encode()
        self.send_response(status)
        self.send_header("Content-Type", "text/plain; charset=utf-8")
        self.send_header("Content-Length", str(len(body)))
        self._end_headers()
        if self.command != "HEAD":
            self.wfile.write(body)

    def _serve(self, head: bool) -> None:
        if self.request_version == "HTTP/0.9":  # an answer without headers (no CSP): none at all
            self.close_connection = True
            return None
        hosts = self.headers.get_all("Host") or [""]
        if len(hosts) > 1:
            return self._refuse(HTTPStatus.BAD_REQUEST, f"{len(hosts)} Host headers")
        host = hosts[0]
        if host not in self.server.allowed_hosts:
            return self._refuse(HTTPStatus.FORBIDDEN, f"host {host!r} is not this server")
        target = self.path.split("?", 1)[0].split("#", 1)[0]
        entry = self.server.table.get(target)
        if entry is None:
            return self._refuse(HTTPStatus.NOT_FOUND, "only the viewer's page and the files named on the command "
                                                      "line are served")
        ctype, body = entry
        if not isinstance(body, Path):
            return self._send(ctype, len(body), head, lambda: self.wfile.write(body))
        try:
            fh = open(body, "rb")  # noqa: SIM115 - closed by the with below; a named file is streamed
        except OSError as e:
            return self._refuse(HTTPStatus.NOT_FOUND, f"{e.strerror}")
        with fh:
            size = os.fstat(fh.fileno()).st_size
            self._send(ctype, size, head, lambda: shutil.copyfileobj(fh, self.wfile, 1 << 20))

    def _send(self, ctype: str, size: int, head: bool, write) -> None:
        self.send_response(HTTPStatus.OK)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(size))
        self._end_headers()
        if not head:
            write()

    def do_GET(self) -> None:
        self._serve(head=False)

    def do_HEAD(self) -> None:
        self._serve(head=True)

    def _not_allowed(self) -> None:
        self._refuse(HTTPStatus.METHOD_NOT_ALLOWED, "the viewer is read-only (GET, HEAD)")

    do_POST = do_PUT = do_DELETE = do_PATCH = do_OPTIONS = _not_allowed

    def log_message(self, format, *args) -> None:
        if self.server.log is not None:
            self.server.log(f"{self.address_string()} {format % args}")


class ViewServer(ThreadingHTTPServer):
    """``ViewServer(scene, files, port=0)``: bound to 127.0.0.1 (a free port when ``port`` is 0). With
    ``scene=None`` the port is taken at once and :meth:`publish` gives the scene later (nothing is served
    before: a busy port is found before the files are read)."""

    daemon_threads = True

    def __init__(self, scene: dict | None, files: list[Path], port: int = 0, log=None):
        self.table = {} if scene is None else routes(scene, files)
        self.answer_headers = security_headers((static_dir() / "index.html").read_bytes())
        self.log = log
        try:
            super().__init__((HOST, int(port)), _Handler)
        except OSError as e:
            raise MocapError(f"cannot listen on {HOST}:{port}: {e.strerror or e}") from None
        p = self.server_address[1]
        self.allowed_hosts = {f"{HOST}:{p}", f"localhost:{p}"}

    def publish(self, scene: dict, files: list[Path]) -> None:
        """Serve ``scene`` and ``files`` (the route table is replaced as a whole)."""
        self.table = routes(scene, files)

    @property
    def url(self) -> str:
        return f"http://{HOST}:{self.server_address[1]}/"

    def start_thread(self) -> threading.Thread:
        """Serve on a background thread (tests); stop with ``shutdown()`` then ``server_close()``."""
        t = threading.Thread(target=self.serve_forever, name="mocapkit-view", daemon=True)
        t.start()
        return t
