"""Files read implicitly with an input (an AMC's ASF, a take's labels, a legacy x-io file's registers, a
.gltf's buffer, a session's Session.xml) are inputs: an output that is the same file (a symlink or a hard
link to it) is refused before any work, and the companion's bytes stay as they were."""

from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path

import pytest

from mocapkit.errors import InvalidParameterError
from mocapkit.io.loaders import companions
from test_robust_cli import assert_one_line_error, cli_run

DATA = Path(__file__).resolve().parent / "data"


def _digest(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest()


@pytest.fixture
def cmu(tmp_path) -> Path:
    d = tmp_path / "cmu"
    d.mkdir()
    shutil.copy(DATA / "cmu" / "86.asf", d / "86.asf")
    shutil.copy(DATA / "cmu" / "86_01_15hz_first1600.amc", d / "86_01.amc")
    shutil.copy(DATA / "cmu" / "86_01_15hz_first1600.labels.txt", d / "86_01.labels.txt")
    return d


def _link(kind: str, target: Path, at: Path) -> Path:
    if kind == "symlink":
        at.symlink_to(target)
    else:
        os.link(target, at)
    return at


@pytest.mark.parametrize("kind", ["symlink", "hardlink"])
@pytest.mark.parametrize("command", [
    lambda amc, out: ("compress", amc, "-o", out, "--max-position-error", "0.5"),
    lambda amc, out: ("convert", amc, out),
])
def test_output_onto_the_implicit_asf_is_refused(cmu, tmp_path, kind, command):
    asf = cmu / "86.asf"
    before = _digest(asf)
    out = _link(kind, asf, tmp_path / "out.bvh")
    r = cli_run(*command(cmu / "86_01.amc", out))
    assert_one_line_error(r, str(out), "86.asf")
    assert _digest(asf) == before


def test_explicit_asf_elsewhere_leaves_the_beside_one_free(cmu, tmp_path):
    """With --asf given, the ASF beside the AMC is not read: it is no input (the other one is)."""
    other = tmp_path / "other.asf"
    shutil.copy(cmu / "86.asf", other)
    assert companions(cmu / "86_01.amc", asf=other) == []
    assert companions(cmu / "86_01.amc") == [cmu / "86.asf"]
    out = _link("symlink", other, tmp_path / "out.bvh")
    r = cli_run("convert", cmu / "86_01.amc", out, "--asf", other)
    assert_one_line_error(r, "other.asf")


def test_plot_onto_the_labels_beside_a_take_is_refused(cmu, tmp_path):
    from mocapkit.jobs.segment import segment_job

    labels = cmu / "86_01.labels.txt"
    before = _digest(labels)
    plot = _link("symlink", labels, tmp_path / "cuts.png")
    with pytest.raises(InvalidParameterError, match="--plot"):
        segment_job(cmu / "86_01.amc", method="pca", labels_beside=True, plot=plot)
    assert _digest(labels) == before


def test_output_onto_the_registers_of_a_legacy_xio_file_is_refused(tmp_path):
    d = tmp_path / "xio"
    shutil.copytree(DATA / "formats" / "xio-legacy-session", d)
    regs = d / "00000_Registers.csv"
    before = _digest(regs)
    assert companions(d / "00000_Quaternion.csv") == [regs]
    out = _link("symlink", regs, tmp_path / "points.csv")
    r = cli_run("compress", d / "00000_Quaternion.csv", "--threshold", "1e-3", "-o", out)
    assert_one_line_error(r, str(out), "00000_Registers.csv")
    assert _digest(regs) == before


def test_folder_companions_are_listed():
    ngimu = DATA / "formats" / "ngimu-session"
    assert companions(ngimu) == [ngimu / "Session.xml"]
    legacy = DATA / "formats" / "xio-legacy-session"
    assert companions(legacy) == [legacy / "00000_Registers.csv"]


def test_output_onto_a_session_xml_is_refused(tmp_path):
    d = tmp_path / "session"
    shutil.copytree(DATA / "formats" / "ngimu-session", d)
    xml = d / "Session.xml"
    before = _digest(xml)
    out = _link("hardlink", xml, tmp_path / "view.gif")
    r = cli_run("view", d, "--export", out)
    assert_one_line_error(r, str(out))
    assert _digest(xml) == before


def test_output_onto_a_gltf_buffer_is_refused(tmp_path):
    clip = tmp_path / "walk.gltf"
    r = cli_run("compress", DATA / "bvh" / "walk-meredith-60.bvh", "-o", clip, "--max-position-error", "0.5",
                "--unit-cm", "2.54")
    assert r.code == 0, r.err
    import base64
    import json

    doc = json.loads(clip.read_text())                  # its buffer moved to a file beside it
    (tmp_path / "walk.bin").write_bytes(base64.b64decode(doc["buffers"][0]["uri"].split(",", 1)[1]))
    doc["buffers"][0]["uri"] = "walk.bin"
    clip.write_text(json.dumps(doc))
    assert cli_run("decompress", clip, "-o", tmp_path / "ok.bvh").code == 0
    buf = companions(clip)
    assert len(buf) == 1 and buf[0].is_file(), buf
    before = _digest(buf[0])
    out = _link("symlink", buf[0], tmp_path / "decoded.bvh")
    assert_one_line_error(cli_run("decompress", clip, "-o", out), str(out))
    assert _digest(buf[0]) == before
