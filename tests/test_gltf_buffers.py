"""The buffer a ``.gltf`` names by URI is read within bounds: at most ``byteLength`` bytes, of a regular
file inside the ``.gltf``'s folder; a data URI longer than ``byteLength`` needs is refused unread. Every
refusal is one clean error naming the file; a device or FIFO never blocks the reader."""

from __future__ import annotations

import base64
import contextlib
import io
import json
import os
import threading

import numpy as np
import pytest

from mocapkit import cli
from mocapkit.errors import MocapFormatError
from mocapkit.io.formats.gltf import read_gltf, write_gltf
from mocapkit.io.loaders import load_motion
from mocapkit.jobs.gltf_out import every_frame


@pytest.fixture(scope="module")
def embedded(tests_data, tmp_path_factory) -> tuple[dict, bytes, object]:
    """The JSON document and buffer bytes of a ``.gltf`` written with its buffer as a data URI, and the motion."""
    m = load_motion(tests_data / "bvh" / "perception-neuron-freya-12.bvh")
    path = write_gltf(tmp_path_factory.mktemp("g") / "freya.gltf", every_frame(m), rotations="float")
    doc = json.loads(path.read_text())
    blob = base64.b64decode(doc["buffers"][0]["uri"].split(",", 1)[1])
    assert doc["buffers"][0]["byteLength"] == len(blob)
    return doc, blob, m


def _gltf(folder, doc, uri, byte_length=None):
    d = json.loads(json.dumps(doc))
    d["buffers"][0]["uri"] = uri
    if byte_length is not None:
        d["buffers"][0]["byteLength"] = byte_length
    path = folder / "clip.gltf"
    path.write_text(json.dumps(d))
    return path


def _read_within(path, seconds=20.0):
    """``read_gltf(path)`` in a daemon thread: ``("ok", motion)``, ``("error", exc)`` or ``("hung", None)``."""
    out = {}

    def run():
        try:
            out["r"] = ("ok", read_gltf(path))
        except Exception as exc:  # noqa: BLE001 - reported to the test
            out["r"] = ("error", exc)

    t = threading.Thread(target=run, daemon=True)
    t.start()
    t.join(seconds)
    return out.get("r", ("hung", None))


def test_an_external_buffer_beside_the_file_still_decodes(embedded, tmp_path):
    doc, blob, m = embedded
    (tmp_path / "freya data.bin").write_bytes(blob + b"\0" * 5)  # longer than byteLength: only byteLength is read
    status, back = _read_within(_gltf(tmp_path, doc, "freya%20data.bin"))
    assert status == "ok", back
    ref = read_gltf(tmp_path / "ref.gltf", data=json.dumps(doc).encode())
    assert np.array_equal(back.rotations, ref.rotations) and np.array_equal(back.translations, ref.translations)
    assert back.n_frames == m.n_frames
    sub = tmp_path / "bufs"
    sub.mkdir()
    (sub / "b.bin").write_bytes(blob)
    assert _read_within(_gltf(tmp_path, doc, "bufs/b.bin"))[0] == "ok"


def _refused(path, *fragments):
    status, exc = _read_within(path)
    assert status == "error", (status, exc)
    assert isinstance(exc, MocapFormatError), repr(exc)
    msg = str(exc)
    assert str(path) in msg and all(f in msg for f in fragments), msg
    assert "\n" not in msg


def test_dev_zero_is_not_read(embedded, tmp_path):
    doc, blob, _ = embedded
    _refused(_gltf(tmp_path, doc, "/dev/zero", byte_length=3 << 30), "buffer 0")
    _refused(_gltf(tmp_path, doc, "/dev/zero"), "relative path")
    (tmp_path / "zero.bin").symlink_to("/dev/zero")  # a link inside the folder to a device outside
    _refused(_gltf(tmp_path, doc, "zero.bin"), "out of the glTF file's folder")


def test_a_fifo_never_blocks(embedded, tmp_path):
    doc, _, _ = embedded
    os.mkfifo(tmp_path / "pipe.bin")
    _refused(_gltf(tmp_path, doc, "pipe.bin"), "not a regular file")


def test_a_big_sparse_file_is_read_only_to_byte_length(embedded, tmp_path):
    doc, blob, _ = embedded
    big = tmp_path / "big.bin"
    with open(big, "wb") as fh:
        fh.write(blob)
        fh.truncate(3 << 30)  # 3 GiB, sparse: takes no disk
    status, back = _read_within(_gltf(tmp_path, doc, "big.bin"))
    assert status == "ok", back  # byteLength bytes read, not 3 GiB
    _refused(_gltf(tmp_path, doc, "big.bin", byte_length=3 << 30), "byteLength")  # beyond what is ever read


def test_paths_out_of_the_folder_are_refused(embedded, tmp_path):
    doc, blob, _ = embedded
    inner = tmp_path / "in"
    inner.mkdir()
    (tmp_path / "outside.bin").write_bytes(blob)
    _refused(_gltf(inner, doc, "../outside.bin"), "out of the glTF file's folder")
    _refused(_gltf(inner, doc, "..%2Foutside.bin"), "out of the glTF file's folder")
    _refused(_gltf(inner, doc, str(tmp_path / "outside.bin")), "relative path")
    _refused(_gltf(inner, doc, "file://" + str(tmp_path / "outside.bin")), "relative path")
    (inner / "link.bin").symlink_to(tmp_path / "outside.bin")
    _refused(_gltf(inner, doc, "link.bin"), "out of the glTF file's folder")
    _refused(_gltf(inner, doc, "missing.bin"), "cannot read")
    (inner / "short.bin").write_bytes(blob[:-1])
    _refused(_gltf(inner, doc, "short.bin"), "fewer than byteLength")
    (inner / "dir.bin").mkdir()
    _refused(_gltf(inner, doc, "dir.bin"), "buffer 0")


def test_data_uris_are_bounded_by_byte_length(embedded, tmp_path):
    doc, blob, _ = embedded
    enc = base64.b64encode(blob).decode()
    pre = "data:application/octet-stream;base64,"
    assert _read_within(_gltf(tmp_path, doc, pre + enc))[0] == "ok"
    long = pre + base64.b64encode(blob + b"\0" * 4096).decode()
    _refused(_gltf(tmp_path, doc, long), "more than byteLength")
    _refused(_gltf(tmp_path, doc, pre + enc, byte_length=len(blob) + 1), "fewer than byteLength")
    _refused(_gltf(tmp_path, doc, "data:application/octet-stream," + enc), "not base64")


def test_the_command_line_gives_one_line_and_exit_2(embedded, tmp_path):
    doc, _, _ = embedded
    path = _gltf(tmp_path, doc, "../../../../../../dev/zero", byte_length=3 << 30)
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()), pytest.raises(SystemExit) as e:
        cli.main(["decompress", str(path), "-o", str(tmp_path / "out.bvh")])
    assert e.value.code == 2
    lines = err.getvalue().strip().splitlines()
    assert len(lines) == 1 and "clip.gltf" in lines[0] and "buffer 0" in lines[0], lines
    assert not (tmp_path / "out.bvh").exists()


def test_decompress_never_overwrites_the_buffer_file(embedded, tmp_path):
    """The buffer a ``.gltf`` names is an input: ``decompress X.gltf -o`` that file is refused before any
    work (also through a percent-encoded name and a link), and the file is unchanged."""
    doc, blob, _ = embedded
    buf = tmp_path / "buf a.bvh"
    buf.write_bytes(blob)
    (tmp_path / "alias.bvh").symlink_to(buf)
    for uri, out in (("buf a.bvh", buf), ("buf%20a.bvh", buf), ("buf a.bvh", tmp_path / "alias.bvh")):
        path = _gltf(tmp_path, doc, uri)
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()), pytest.raises(SystemExit) as e:
            cli.main(["decompress", str(path), "-o", str(out)])
        assert e.value.code == 2, err.getvalue()
        assert "input" in err.getvalue() and len(err.getvalue().strip().splitlines()) == 1
        assert buf.read_bytes() == blob
    with contextlib.redirect_stderr(io.StringIO()), pytest.raises(SystemExit) as e:
        cli.main(["decompress", str(path), "-o", str(tmp_path / "back.bvh")])
    assert e.value.code == 0 and (tmp_path / "back.bvh").stat().st_size > 0
