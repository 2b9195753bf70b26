"""The viewer's server: 127.0.0.1 only, the page, its assets, the scene and the named files — nothing else
(path traversal, absolute paths, unnamed files, directory listings, other hosts and methods refused)."""

from __future__ import annotations

import http.client
import json
import os
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from mocapkit.view.server import HOST, ViewServer, static_dir

DATA = Path(__file__).parent / "data"
BVH = DATA / "bvh" / "walk-meredith-60.bvh"
CLIP = DATA / "clip" / "walk-meredith-60.mkc"
SCENE = {"mocapkit_view": 1, "panels": [], "note": "a scene"}


@pytest.fixture()
def server(tmp_path):
    named = tmp_path / "named.bvh"
    named.write_bytes(BVH.read_bytes())
    (tmp_path / "secret.txt").write_text("not named on the command line\n")
    srv = ViewServer(SCENE, [named, CLIP])
    srv.start_thread()
    yield srv, named, tmp_path
    srv.shutdown()
    srv.server_close()


def _raw(srv, target: str, method: str = "GET", host: str | None = None) -> tuple[int, bytes]:
    """One request with the target exactly as given (no client-side normalisation)."""
    port = srv.server_address[1]
    with socket.create_connection((HOST, port), timeout=10) as s:
        h = host if host is not None else f"{HOST}:{port}"
        s.sendall(f"{method} {target} HTTP/1.1\r\nHost: {h}\r\nConnection: close\r\n\r\n".encode("latin-1"))
        data = b""
        while chunk := s.recv(65536):
            data += chunk
    head, _, body = data.partition(b"\r\n\r\n")
    return int(head.split()[1]), body


def test_binds_loopback_only_on_a_free_port(server):
    srv, _, _ = server
    assert srv.server_address[0] == "127.0.0.1"
    assert srv.server_address[1] > 0
    assert srv.url == f"http://127.0.0.1:{srv.server_address[1]}/"
    # every non-loopback address of this machine refuses the port
    others = set()
    try:
        for info in socket.getaddrinfo(socket.gethostname(), None, socket.AF_INET):
            others.add(info[4][0])
    except socket.gaierror:
        pass
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as u:
        try:
            u.connect(("192.0.2.1", 9))  # no packet is sent: only picks the outgoing interface's address
            others.add(u.getsockname()[0])
        except OSError:
            pass
    others = {a for a in others if not a.startswith("127.") and a != "0.0.0.0"}
    for addr in others:
        with pytest.raises(OSError):
            socket.create_connection((addr, srv.server_address[1]), timeout=2).close()


def test_serves_the_page_assets_scene_and_named_files(server):
    srv, named, _ = server
    status, body = _raw(srv, "/scene.json")
    assert status == 200 and json.loads(body) == SCENE
    status, body = _raw(srv, "/static/vendor/three/LICENSE")
    assert status == 200 and body == (static_dir() / "vendor" / "three" / "LICENSE").read_bytes()
    status, body = _raw(srv, "/files/0/named.bvh")
    assert status == 200 and body == named.read_bytes()
    status, body = _raw(srv, "/files/1/walk-meredith-60.mkc")
    assert status == 200 and body == CLIP.read_bytes()
    status, body = _raw(srv, "/scene.json?x=1")
    assert status == 200


@pytest.mark.parametrize("target", [
    "/../secret.txt", "/files/0/../secret.txt", "/files/0/..%2fsecret.txt", "/files/0/secret.txt",
    "/files/2/secret.txt", "/files/-1/named.bvh", "/files/0/", "/files/", "/static/", "/static/vendor/",
    "/static/vendor/three", "/static/../scene.json", "/static/%2e%2e/scene.json", "/static/..%5c..%5cscene.json",
    "/static/../../../../../../etc/passwd", "//etc/passwd", "/etc/passwd", "/%2fetc%2fpasswd",
    "/static//etc/passwd", "/static/vendor/three/../../index.html", "/STATIC/vendor/three/LICENSE",
    "/static/vendor/three/LICENSE/", "/static/vendor/three/LICENSE%00", "/scene.json/..", "/proc/self/environ",
])
def test_refuses_everything_not_in_the_table(server, target):
    srv, named, _tmp = server
    status, body = _raw(srv, target)
    assert status == 404, (target, status)
    assert b"not named" not in body and b"root:" not in body and named.read_bytes()[:20] not in body


def test_absolute_form_and_unnamed_files_are_refused(server):
    srv, _, tmp = server
    port = srv.server_address[1]
    for target in (f"http://{HOST}:{port}/etc/passwd", f"http://{HOST}:{port}{tmp}/secret.txt",
                   f"{tmp}/secret.txt", str(BVH.resolve())):
        status, body = _raw(srv, target)
        assert status == 404, target
        assert b"not named" not in body


def test_other_hosts_and_methods_are_refused(server):
    srv, _, _ = server
    assert _raw(srv, "/scene.json", host="evil.example:80")[0] == 403  # DNS rebinding
    assert _raw(srv, "/scene.json", host="")[0] == 403
    assert _raw(srv, "/scene.json", host=f"localhost:{srv.server_address[1]}")[0] == 200
    for method in ("POST", "PUT", "DELETE", "OPTIONS"):
        assert _raw(srv, "/scene.json", method=method)[0] == 405
    conn = http.client.HTTPConnection(HOST, srv.server_address[1], timeout=10)
    conn.request("HEAD", "/scene.json")
    r = conn.getresponse()
    assert r.status == 200 and r.read() == b"" and int(r.getheader("Content-Length")) > 0
    csp = r.getheader("Content-Security-Policy")
    script_src = next(d for d in csp.split(";") if d.strip().startswith("script-src"))
    assert "default-src 'self'" in csp and "'unsafe-inline'" not in script_src and "'sha256-" in script_src
    conn.close()


def test_a_busy_port_is_a_clear_error():
    from mocapkit.errors import MocapError

    with socket.socket() as s:
        s.bind((HOST, 0))
        s.listen()
        with pytest.raises(MocapError, match=r"cannot listen on 127\.0\.0\.1:\d+"):
            ViewServer(SCENE, [], port=s.getsockname()[1])


def test_the_command_serves_and_stops_on_sigint_and_sigterm(tmp_path):
    for sig in (signal.SIGINT, signal.SIGTERM):
        p = subprocess.Popen([sys.executable, "-m", "mocapkit", "view", str(BVH), str(CLIP), "--no-browser"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             env={**os.environ, "MOCAPKIT_DEBUG": "1"})
        try:
            line = p.stdout.readline()
            assert line.startswith("serving on http://127.0.0.1:"), line + p.stderr.read()
            url = line.split()[-1]
            port = int(url.rsplit(":", 1)[1].strip("/"))
            conn = http.client.HTTPConnection(HOST, port, timeout=10)
            conn.request("GET", "/scene.json")
            scene = json.loads(conn.getresponse().read())
            conn.close()
            assert scene["timeline"]["frames"] == 60 and [q["role"] for q in scene["panels"]] == ["original", "decoded"]
            p.send_signal(sig)
            _out, errs = p.communicate(timeout=20)
        finally:
            if p.poll() is None:
                p.kill()
                p.communicate()
        assert p.returncode == 0, errs
        assert "stopped" in errs and "Traceback" not in errs


def test_the_command_refuses_bad_options_before_serving(tmp_path):
    def run(*args):
        return subprocess.run([sys.executable, "-m", "mocapkit", "view", *args], capture_output=True, text=True,
                              timeout=60, check=False)

    r = run(str(BVH), "--port", "70000", "--no-browser")
    assert r.returncode == 2 and "--port" in r.stderr
    r = run(str(tmp_path / "missing.bvh"), "--no-browser")
    assert r.returncode == 2 and "missing.bvh" in r.stderr and "no such file" in r.stderr
    r = run(str(BVH), "--frames", "5:2", "--no-browser")
    assert r.returncode == 2 and "--frames" in r.stderr


def test_the_command_opens_the_browser_on_its_url(tmp_path):
    """Without --no-browser the URL goes to the user's browser ($BROWSER, which webbrowser honours)."""
    opened = tmp_path / "opened.txt"
    fake = tmp_path / "fake-browser"
    fake.write_text(f"#!{sys.executable}\nimport sys\nopen({str(opened)!r}, 'w').write(sys.argv[1])\n")
    fake.chmod(0o755)
    p = subprocess.Popen([sys.executable, "-m", "mocapkit", "view", str(BVH)], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, env={**os.environ, "BROWSER": f"{fake} %s"})
    try:
        url = p.stdout.readline().split()[-1]
        import time

        for _ in range(200):
            if opened.exists() and opened.read_text():
                break
            time.sleep(0.05)
        assert opened.read_text() == url
        p.send_signal(signal.SIGINT)
        p.communicate(timeout=20)
    finally:
        if p.poll() is None:
            p.kill()
            p.communicate()
    assert p.returncode == 0


def _exchange(srv, data: bytes) -> bytes:
    """``data`` sent as is on one connection; everything the server answers until it closes."""
    with socket.create_connection((HOST, srv.server_address[1]), timeout=10) as s:
        s.sendall(data)
        out = b""
        while chunk := s.recv(65536):
            out += chunk
    return out


def test_a_request_body_is_never_read_as_a_request(server):
    """A refused POST (or a GET) carrying a body: one answer, then the connection ends, so the body (here a
    request for the scene) is not answered as a second request on the same connection."""
    srv, _, _ = server
    host = f"Host: {HOST}:{srv.server_address[1]}\r\n".encode()
    inner = b"GET /scene.json HTTP/1.1\r\n" + host + b"\r\n"
    for method in (b"POST", b"GET"):
        out = _exchange(srv, method + b" /x HTTP/1.1\r\n" + host + b"Content-Length: %d\r\n\r\n" % len(inner) + inner)
        assert out.count(b"HTTP/1.1 ") == 1 and b'"mocapkit_view"' not in out, out
        assert b"Connection: close" in out


def test_two_host_headers_and_http09_are_refused(server):
    srv, _, _ = server
    ours = f"Host: {HOST}:{srv.server_address[1]}\r\n".encode()
    for hosts in (ours + b"Host: evil.example\r\n", b"Host: evil.example\r\n" + ours):
        out = _exchange(srv, b"GET /scene.json HTTP/1.1\r\n" + hosts + b"Connection: close\r\n\r\n")
        assert out.startswith(b"HTTP/1.1 400 ") and b"mocapkit_view" not in out, out
    # HTTP/0.9 has no answer headers (no Content-Security-Policy, no nosniff): nothing is sent
    assert _exchange(srv, b"GET /scene.json\r\n" + ours + b"\r\n") == b""


def test_a_busy_port_is_found_before_the_files_are_read(tmp_path):
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT\n")  # would fail to read
    with socket.socket() as s:
        s.bind((HOST, 0))
        s.listen()
        r = subprocess.run([sys.executable, "-m", "mocapkit", "view", str(bad), "--port", str(s.getsockname()[1]),
                            "--no-browser"], capture_output=True, text=True, timeout=60, check=False)
    assert r.returncode == 2 and "cannot listen on 127.0.0.1" in r.stderr and "bad.bvh" not in r.stderr
