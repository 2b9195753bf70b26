"""Issue 10 trial, output paths: devices, FIFOs and symlinks are written into, never replaced; an output
that is an input (same file by any path) or inside an input folder is refused; ``kill -9`` never leaves
a partial target; outputs get normal mode bits.

Every command runs in a child of a clean server process (``trial.server``) with a timeout and a 2 GB
address-space limit; ``trial.checks`` classifies what happened.
"""

from __future__ import annotations

import os
import shutil
import stat
from pathlib import Path

import pytest

from trial import checks, oracle, server

pytestmark = pytest.mark.skipif(os.name != "posix", reason="devices, FIFOs and fork are POSIX")


@pytest.fixture(scope="module")
def trial():
    return server.shared_client()


@pytest.fixture
def files(tmp_path, tests_data) -> dict[str, Path]:
    """Inputs copied into ``tmp_path/in`` (tests/data stays untouched whatever happens)."""
    d = tmp_path / "in"
    d.mkdir()
    src = {"imu": tests_data / "xio" / "pelvis" / "Quaternion.csv", "bvh": tests_data / "bvh" / "walk-meredith-60.bvh",
           "trc": tests_data / "opensim" / "walk_free_01-first20.trc",
           "tsv": tests_data / "markers" / "juggling-qualisys-300hz-first120.tsv"}
    out = {k: d / v.name for k, v in src.items()}
    for k, v in src.items():
        shutil.copyfile(v, out[k])
    (tmp_path / "out").mkdir()
    return out


def _regular_output(trial, argv_with_out, out: Path) -> bytes:
    r = trial.run(argv_with_out(out))
    checks.assert_ok(r)
    return out.read_bytes()


def test_device_output_is_written_into_or_refused_never_replaced(trial, files, tmp_path):
    dev = tmp_path / "out" / "null.csv"
    try:
        os.mknod(dev, stat.S_IFCHR | 0o666, os.makedev(1, 3))  # a private /dev/null
    except (PermissionError, OSError) as e:
        pytest.skip(f"cannot make a device node here: {e}")
    r = trial.run(["compress", files["imu"], "-t", "0.001", "-o", dev])
    checks.assert_no_failure(r, "null.csv")
    assert stat.S_ISCHR(os.lstat(dev).st_mode), f"the device was replaced: {checks.describe(r)}"


def test_fifo_output_gets_the_data_and_stays_a_fifo(trial, files, tmp_path):
    expected = _regular_output(trial, lambda o: ["compress", files["imu"], "-t", "0.001", "-o", o],
                               tmp_path / "out" / "regular.csv")
    fifo = tmp_path / "out" / "pipe.csv"
    os.mkfifo(fifo)
    fd = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)  # a reader, so the writer's open does not block
    try:
        r = trial.run(["compress", files["imu"], "-t", "0.001", "-o", fifo], timeout=60)
        got = b""
        while True:
            try:
                chunk = os.read(fd, 1 << 16)
            except BlockingIOError:
                break
            if not chunk:
                break
            got += chunk
    finally:
        os.close(fd)
    kind = checks.assert_no_failure(r, "pipe.csv")
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode), f"the FIFO was replaced: {checks.describe(r)}"
    if kind == "ok":
        assert got == expected


@pytest.mark.parametrize("dangling", [False, True])
def test_symlink_output_writes_its_target(trial, files, tmp_path, dangling):
    expected = _regular_output(trial, lambda o: ["compress", files["imu"], "-t", "0.001", "-o", o],
                               tmp_path / "out" / "regular.csv")
    real = tmp_path / "elsewhere" / "target.csv"
    real.parent.mkdir()
    if not dangling:
        real.write_text("old content\n")
    link = tmp_path / "out" / "link.csv"
    link.symlink_to(real)
    r = trial.run(["compress", files["imu"], "-t", "0.001", "-o", link])
    checks.assert_ok(r)
    assert link.is_symlink(), "the symlink was replaced by a file"
    assert real.read_bytes() == expected


SAME_FILE_COMMANDS = {
    "imu": lambda p, o: ["compress", p, "-t", "0.001", "-o", o],
    "bvh": lambda p, o: ["compress", p, "-t", "0.01", "-o", o],
    "trc": lambda p, o: ["convert", p, o],
    "tsv": lambda p, o: ["filter", p, "--auto", "-o", o],
}


@pytest.mark.parametrize("how", ["same", "dot", "symlink", "hardlink"])
@pytest.mark.parametrize("fmt", sorted(SAME_FILE_COMMANDS))
def test_output_that_is_the_input_is_refused_and_the_input_kept(trial, files, tmp_path, fmt, how):
    inp = files[fmt]
    before = inp.read_bytes()
    if how == "same":
        out = inp
    elif how == "dot":
        out = Path(f"{inp.parent}/./{inp.name}")
    else:
        out = tmp_path / "out" / inp.name
        (out.symlink_to if how == "symlink" else out.hardlink_to)(inp)
    r = trial.run(SAME_FILE_COMMANDS[fmt](inp, out))
    checks.assert_clean_error(r, inp.name, out.name)
    assert inp.read_bytes() == before, "the input was modified"


def test_output_folder_inside_the_input_folder_is_refused(trial, tests_data, tmp_path):
    folder = tmp_path / "sensors"
    shutil.copytree(tests_data / "xio", folder)
    before = sorted((str(p.relative_to(folder)), oracle.sha(p)) for p in folder.rglob("*") if p.is_file())
    for out in (folder / "points", folder, folder / "pelvis"):
        r = trial.run(["compress", folder, "-t", "0.001", "-o", out])
        checks.assert_clean_error(r, "sensors", out.name)
    after = sorted((str(p.relative_to(folder)), oracle.sha(p)) for p in folder.rglob("*") if p.is_file())
    assert after == before, "the input folder changed"


@pytest.mark.parametrize("kill_after", [0.05, 0.2, 0.4, 0.8, 1.5])
def test_kill_9_never_leaves_a_partial_target(trial, files, tmp_path, kill_after):
    out = tmp_path / "out" / "clip.glb"
    out.write_bytes(b"previous result")
    r = trial.run(["compress", files["bvh"], "-o", out, "--max-position-error", "1", "--unit-cm", "1"],
                  kill_after=kill_after)
    data = out.read_bytes()
    if data == b"previous result":
        return  # killed before the rename: the old target is intact
    assert r.extra.get("killed_at") is None or data[:4] == b"glTF"
    rep = trial.digest(out, "glb")
    assert rep["status"] == "ok" and not rep["nonfinite"], f"partial or invalid target after kill -9: {rep}"


def test_outputs_have_normal_mode_bits(trial, files, tmp_path):
    mask = os.umask(0)
    os.umask(mask)
    out = tmp_path / "out" / "p.csv"
    checks.assert_ok(trial.run(["compress", files["imu"], "-t", "0.001", "-o", out]))
    assert stat.S_IMODE(out.stat().st_mode) == 0o666 & ~mask
