"""The safe writer (``mocapkit.io.atomic``) case by case, and the command line's output checks.

Each case writes, then checks the contents *and* the kind of every path involved (a device stays a
device, a pipe a pipe, a link a link), that an input is never modified and that no temporary file is
left in the folder.
"""

from __future__ import annotations

import errno
import os
import stat
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from mocapkit.errors import InvalidParameterError
from mocapkit.io import atomic
from mocapkit.io.atomic import atomic_write_bytes, atomic_write_text, atomic_writer, check_output

LINUX_UNNAMED = sys.platform.startswith("linux") and hasattr(os, "O_TMPFILE")
EXE = [sys.executable, "-m", "mocapkit.cli"]


def run(*args, cwd: Path | None = None, timeout: float = 120) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "COLUMNS"}
    return subprocess.run([*EXE, *map(str, args)], capture_output=True, text=True, cwd=cwd, timeout=timeout, env=env)


def listing(folder: Path) -> list[str]:
    return sorted(os.listdir(folder))


@pytest.fixture
def umask022():
    old = os.umask(0o022)
    try:
        yield
    finally:
        os.umask(old)


@pytest.fixture
def named_fallback(monkeypatch):
    """Force the portable path: a dot-temporary in the target's folder."""
    monkeypatch.setattr(atomic, "_open_unnamed", lambda folder: None)


class Reader(threading.Thread):
    """Reads a named pipe to its end in the background."""

    def __init__(self, path: Path):
        super().__init__(daemon=True)
        self.path, self.data = path, None

    def run(self) -> None:
        with open(self.path, "rb") as fh:
            self.data = fh.read()


# --- regular files -----------------------------------------------------------------------------

@pytest.mark.parametrize("mask", [0o022, 0o077, 0o002])
def test_new_file_has_contents_and_the_umask_mode(tmp_path, mask):
    old = os.umask(mask)
    try:
        atomic_write_text(tmp_path / "a.csv", "x,y\n1,2\n")
    finally:
        os.umask(old)
    st = os.lstat(tmp_path / "a.csv")
    assert stat.S_ISREG(st.st_mode)
    assert stat.S_IMODE(st.st_mode) == 0o666 & ~mask
    assert (tmp_path / "a.csv").read_bytes() == b"x,y\n1,2\n"
    assert listing(tmp_path) == ["a.csv"]


@pytest.mark.parametrize("mode", [0o600, 0o640, 0o755])
def test_replaced_file_keeps_its_mode_and_old_readers_keep_the_old_contents(tmp_path, umask022, mode):
    p = tmp_path / "a.bin"
    p.write_bytes(b"old contents")
    os.chmod(p, mode)
    with open(p, "rb") as old_reader:
        atomic_write_bytes(p, b"new")
        assert old_reader.read() == b"old contents"  # replaced by rename: the old inode is untouched
    assert p.read_bytes() == b"new"
    st = os.lstat(p)
    assert stat.S_ISREG(st.st_mode) and stat.S_IMODE(st.st_mode) == mode
    assert listing(tmp_path) == ["a.bin"]


def test_text_mode_writes_newlines_unchanged_and_the_encoding_asked(tmp_path):
    atomic_write_text(tmp_path / "t.txt", "é\r\nb\n", encoding="latin-1")
    assert (tmp_path / "t.txt").read_bytes() == b"\xe9\r\nb\n"


@pytest.mark.skipif(not LINUX_UNNAMED, reason="unnamed files (O_TMPFILE) are Linux only")
def test_no_temporary_name_is_visible_while_writing_on_linux(tmp_path):
    (tmp_path / "old.csv").write_text("old\n")
    for name in ("new.csv", "old.csv"):
        before = listing(tmp_path)
        with atomic_writer(tmp_path / name) as fh:
            fh.write("data\n")
            fh.flush()
            assert listing(tmp_path) == before  # no name appears before the commit
        assert (tmp_path / name).read_text() == "data\n"
    assert listing(tmp_path) == ["new.csv", "old.csv"]
    assert "empty_path" not in atomic._UNAVAILABLE or "proc" not in atomic._UNAVAILABLE


def test_the_fallback_temporary_is_hidden_and_removed(tmp_path, named_fallback, umask022):
    p = tmp_path / "a.csv"
    with atomic_writer(p) as fh:
        fh.write("1\n")
        during = listing(tmp_path)
    assert len(during) == 1 and during[0].startswith(".a.csv.") and during[0].endswith(".tmp")
    assert listing(tmp_path) == ["a.csv"] and p.read_text() == "1\n"
    assert stat.S_IMODE(p.stat().st_mode) == 0o644


def test_unnamed_file_that_cannot_be_linked_is_copied_into_place(tmp_path, monkeypatch, umask022):
    if not LINUX_UNNAMED:
        pytest.skip("unnamed files are Linux only")
    monkeypatch.setattr(atomic, "_link_unnamed", lambda fd, dest: False)
    p = tmp_path / "a.csv"
    p.write_text("old\n")
    os.chmod(p, 0o604)
    atomic_write_text(p, "new " * 100_000)
    assert p.read_text() == "new " * 100_000
    assert stat.S_IMODE(p.stat().st_mode) == 0o604
    assert listing(tmp_path) == ["a.csv"]


@pytest.mark.parametrize("fallback", [False, True])
@pytest.mark.parametrize("exc", [RuntimeError("boom"), KeyboardInterrupt()])
def test_failure_inside_the_block_leaves_the_old_file_and_no_temporary(tmp_path, monkeypatch, fallback, exc):
    if fallback:
        monkeypatch.setattr(atomic, "_open_unnamed", lambda folder: None)
    p = tmp_path / "a.csv"
    p.write_text("old\n")
    with pytest.raises(type(exc)), atomic_writer(p) as fh:
        fh.write("half of the new contents")
        raise exc
    assert p.read_text() == "old\n"
    assert listing(tmp_path) == ["a.csv"]
    # a new file is not created either
    with pytest.raises(RuntimeError), atomic_writer(tmp_path / "b.csv") as fh:
        fh.write("x")
        raise RuntimeError
    assert listing(tmp_path) == ["a.csv"]


@pytest.mark.parametrize("fallback", [False, True])
def test_full_disk_names_the_users_path_and_leaves_the_old_file(tmp_path, monkeypatch, fallback):
    if fallback:
        monkeypatch.setattr(atomic, "_open_unnamed", lambda folder: None)

    def no_space(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(atomic.os, "fsync", no_space)
    p = tmp_path / "a.csv"
    p.write_text("old\n")
    with pytest.raises(OSError) as ei:
        atomic_write_text(p, "new\n" * 1000)
    assert ei.value.errno == errno.ENOSPC and ei.value.filename == str(p)
    assert p.read_text() == "old\n"
    assert listing(tmp_path) == ["a.csv"]


def test_a_failing_rename_names_the_users_path(tmp_path, monkeypatch, named_fallback):
    def read_only(src, dst):
        raise OSError(errno.EROFS, "Read-only file system", src, None, dst)

    monkeypatch.setattr(atomic.os, "replace", read_only)
    p = tmp_path / "a.csv"
    with pytest.raises(OSError) as ei:
        atomic_write_text(p, "x\n")
    assert ei.value.errno == errno.EROFS and ei.value.filename == str(p)
    assert ".tmp" not in str(ei.value)
    assert listing(tmp_path) == []


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_a_read_only_folder_names_the_users_path(tmp_path):
    d = tmp_path / "ro"
    d.mkdir()
    os.chmod(d, 0o555)
    try:
        with pytest.raises(PermissionError) as ei:
            atomic_write_text(d / "a.csv", "x")
        assert ei.value.filename == str(d / "a.csv")
    finally:
        os.chmod(d, 0o755)


def test_a_folder_or_a_missing_folder_is_an_error_naming_the_path(tmp_path):
    with pytest.raises(IsADirectoryError) as ei:
        atomic_write_text(tmp_path, "x")
    assert ei.value.filename == str(tmp_path)
    with pytest.raises(FileNotFoundError) as ei:
        atomic_write_text(tmp_path / "no" / "a.csv", "x")
    assert ei.value.filename == str(tmp_path / "no" / "a.csv")
    assert listing(tmp_path) == []


# --- devices and pipes -------------------------------------------------------------------------

def test_dev_null_is_written_into_and_stays_a_character_device():
    before = os.stat("/dev/null")
    atomic_write_bytes("/dev/null", b"discarded" * 1000)
    with atomic_writer("/dev/null") as fh:
        fh.write("text too\n")
    after = os.stat("/dev/null")
    assert stat.S_ISCHR(after.st_mode) and after.st_rdev == before.st_rdev and after.st_ino == before.st_ino


def test_a_private_character_device_stays_one(tmp_path):
    dev = tmp_path / "null"
    try:
        os.mknod(dev, stat.S_IFCHR | 0o666, os.stat("/dev/null").st_rdev)
        with open(dev, "wb") as fh:
            fh.write(b"probe")
    except (PermissionError, OSError) as e:  # not root, or a nodev mount
        pytest.skip(f"cannot make a device node here: {e}")
    atomic_write_text(dev, "x\n")
    assert stat.S_ISCHR(os.lstat(dev).st_mode)
    assert listing(tmp_path) == ["null"]


def test_a_fifo_with_a_reader_receives_everything_and_stays_a_fifo(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    payload = os.urandom(1 << 20)  # much more than a pipe buffer: the writer must block, not fail
    reader = Reader(fifo)
    reader.start()
    atomic_write_bytes(fifo, payload)
    reader.join(30)
    assert reader.data == payload
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert listing(tmp_path) == ["pipe"]


def test_a_fifo_without_reader_is_a_clear_error_not_a_hang(tmp_path, monkeypatch):
    monkeypatch.setattr(atomic, "FIFO_WAIT_S", 0.2)
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    t0 = time.monotonic()
    with pytest.raises(OSError) as ei:
        atomic_write_text(fifo, "x\n")
    assert time.monotonic() - t0 < 5
    assert ei.value.errno == errno.ENXIO and ei.value.filename == str(fifo)
    assert "nobody reads" in ei.value.strerror
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode) and listing(tmp_path) == ["pipe"]


def test_a_reader_starting_late_is_waited_for(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    reader = Reader(fifo)
    threading.Timer(0.3, reader.start).start()
    atomic_write_text(fifo, "late\n")
    reader.join(10)
    assert reader.data == b"late\n"


def test_dev_stdout_writes_through_the_process_descriptor(capfd):
    print("before", flush=True)
    atomic_write_text("/dev/stdout", "via /dev/stdout\n")
    atomic_write_text(f"/proc/self/fd/{sys.stdout.fileno()}" if sys.platform.startswith("linux") else "/dev/stdout",
                      "via proc\n")
    out = capfd.readouterr().out
    assert out == "before\nvia /dev/stdout\nvia proc\n"
    assert os.path.islink("/dev/stdout") or not sys.platform.startswith("linux")


def test_block_devices_and_sockets_are_refused(tmp_path):
    import socket

    s = socket.socket(socket.AF_UNIX)
    try:
        s.bind(str(tmp_path / "sock"))
        with pytest.raises(OSError) as ei:
            atomic_write_text(tmp_path / "sock", "x")
        assert "socket" in ei.value.strerror and ei.value.filename == str(tmp_path / "sock")
        assert stat.S_ISSOCK(os.lstat(tmp_path / "sock").st_mode)
    finally:
        s.close()


# --- symlinks ----------------------------------------------------------------------------------

def test_a_symlink_stays_a_link_and_its_target_gets_the_data(tmp_path, umask022):
    target = tmp_path / "real.csv"
    target.write_text("old\n")
    os.chmod(target, 0o640)
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    atomic_write_text(link, "new\n")
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert target.read_text() == "new\n" and stat.S_IMODE(target.stat().st_mode) == 0o640
    assert listing(tmp_path) == ["link.csv", "real.csv"]


def test_a_relative_symlink_chain_into_another_folder(tmp_path, monkeypatch):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "t.csv").write_text("old\n")
    os.symlink("../b/t.csv", tmp_path / "a" / "l1")  # relative to a/, not to the working folder
    os.symlink("l1", tmp_path / "a" / "l2")
    monkeypatch.chdir(tmp_path / "b")  # a working folder where "../b/t.csv" means something else
    atomic_write_text(tmp_path / "a" / "l2", "new\n")
    assert (tmp_path / "b" / "t.csv").read_text() == "new\n"
    assert os.readlink(tmp_path / "a" / "l1") == "../b/t.csv" and os.readlink(tmp_path / "a" / "l2") == "l1"
    assert listing(tmp_path / "a") == ["l1", "l2"] and listing(tmp_path / "b") == ["t.csv"]


def test_a_dangling_symlink_creates_its_target(tmp_path, umask022):
    (tmp_path / "out").mkdir()
    link = tmp_path / "link.csv"
    os.symlink("out/made.csv", link)
    atomic_write_text(link, "made\n")
    assert link.is_symlink() and (tmp_path / "out" / "made.csv").read_text() == "made\n"
    assert stat.S_IMODE((tmp_path / "out" / "made.csv").stat().st_mode) == 0o644


def test_a_dangling_symlink_into_a_missing_folder_is_a_clear_error(tmp_path):
    link = tmp_path / "link.csv"
    os.symlink("nowhere/made.csv", link)
    with pytest.raises(FileNotFoundError) as ei:
        atomic_write_text(link, "x")
    assert ei.value.filename == str(link) and "symlink" in ei.value.strerror
    assert link.is_symlink() and listing(tmp_path) == ["link.csv"]


def test_a_symlink_loop_is_an_error_naming_the_path(tmp_path):
    os.symlink("b", tmp_path / "a")
    os.symlink("a", tmp_path / "b")
    with pytest.raises(OSError) as ei:
        atomic_write_text(tmp_path / "a", "x")
    assert ei.value.errno == errno.ELOOP and ei.value.filename == str(tmp_path / "a")
    assert listing(tmp_path) == ["a", "b"]


def test_a_symlink_to_dev_null_writes_into_the_device(tmp_path):
    os.symlink("/dev/null", tmp_path / "sink")
    atomic_write_text(tmp_path / "sink", "x" * 10_000)
    assert (tmp_path / "sink").is_symlink() and stat.S_ISCHR(os.stat(tmp_path / "sink").st_mode)
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)


# --- outputs that would destroy inputs ---------------------------------------------------------

def test_output_equal_to_an_input_is_refused_through_links(tmp_path):
    src = tmp_path / "q.csv"
    src.write_text("data\n")
    os.link(src, tmp_path / "hard.csv")
    os.symlink(src, tmp_path / "soft.csv")
    os.symlink("q.csv", tmp_path / "rel.csv")
    for out in (src, tmp_path / "hard.csv", tmp_path / "soft.csv", tmp_path / "rel.csv"):
        with pytest.raises(InvalidParameterError) as ei:
            check_output(out, [src])
        msg = str(ei.value)
        assert msg.startswith(f"--output {out}: is the input file {src}") and "\n" not in msg
    with pytest.raises(InvalidParameterError):  # the input given through a link to the output
        check_output(src, [tmp_path / "soft.csv"], option="--plot")
    assert src.read_text() == "data\n"
    check_output(tmp_path / "other.csv", [src])  # a different file is fine
    check_output("/dev/null", [src])  # so is a device


def test_output_inside_an_input_folder_is_refused(tmp_path):
    inp = tmp_path / "sensors"
    (inp / "pelvis").mkdir(parents=True)
    os.symlink(inp, tmp_path / "alias")
    cases = [(inp, True, "is the input folder"), (inp / "out", True, "is inside the input folder"),
             (inp / "new" / "deeper", True, "is inside the input folder"),
             (inp / "pelvis" / "x.csv", False, "is inside the input folder"),
             (tmp_path / "alias" / "out", True, "is inside the input folder")]
    for out, folder, what in cases:
        with pytest.raises(InvalidParameterError) as ei:
            check_output(out, [None, inp], folder=folder, option="--out")
        assert str(ei.value).startswith(f"--out {out}: {what} {inp}"), str(ei.value)
    check_output(tmp_path / "results", [inp], folder=True, option="--out")  # beside it is fine


def test_check_output_keeps_the_old_checks(tmp_path):
    (tmp_path / "f.csv").write_text("x")
    with pytest.raises(InvalidParameterError, match="is a folder; give a file name"):
        check_output(tmp_path, [])
    with pytest.raises(InvalidParameterError, match="expected a folder"):
        check_output(tmp_path / "f.csv", [], folder=True)
    with pytest.raises(InvalidParameterError, match="does not exist"):
        check_output(tmp_path / "no" / "x.csv", [])
    os.symlink("no/x.csv", tmp_path / "dangling")
    with pytest.raises(InvalidParameterError, match="whose folder does not exist"):
        check_output(tmp_path / "dangling", [])
    check_output(None, [tmp_path])


# --- the command line --------------------------------------------------------------------------

@pytest.fixture
def q(tests_data, tmp_path) -> Path:
    p = tmp_path / "q.csv"
    p.write_bytes((tests_data / "xio" / "pelvis" / "Quaternion.csv").read_bytes())
    return p


def one_line_error(r: subprocess.CompletedProcess) -> str:
    assert r.returncode == 2, (r.stdout, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in r.stderr, r.stderr
    return lines[0]


def test_cli_compress_to_dev_null_keeps_the_device(q):
    before = q.read_bytes()
    r = run("compress", q, "--threshold", "0.001", "-o", "/dev/null")
    assert r.returncode == 0, r.stderr
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode) and q.read_bytes() == before


def test_cli_compress_to_dev_stdout_prints_the_points(q):
    r = run("compress", q, "--threshold", "0.001", "-o", "/dev/stdout", "--json")
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("time,w,x,y,z\n")  # the points, then the JSON record
    assert '"n_points"' in r.stdout


def test_cli_compress_into_a_fifo(q, tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    reader = Reader(fifo)
    reader.start()
    r = run("compress", q, "--threshold", "0.001", "-o", fifo)
    reader.join(30)
    assert r.returncode == 0, r.stderr
    lines = reader.data.decode().splitlines()
    assert lines[0] == "time,w,x,y,z" and len(lines) > 2 and all(len(x.split(",")) == 5 for x in lines)
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


def test_cli_fifo_without_reader_is_a_one_line_error(q, tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    line = one_line_error(run("compress", q, "--threshold", "0.001", "-o", fifo, timeout=60))
    assert str(fifo) in line and "nobody reads" in line
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


def test_cli_compress_through_a_symlink(q, tmp_path):
    (tmp_path / "res").mkdir()
    target = tmp_path / "res" / "points.csv"
    target.write_text("old\n")
    link = tmp_path / "latest.csv"
    os.symlink("res/points.csv", link)
    r = run("compress", q, "--threshold", "0.001", "-o", link)
    assert r.returncode == 0, r.stderr
    assert link.is_symlink() and target.read_text().startswith("time,w,x,y,z\n")
    assert listing(tmp_path / "res") == ["points.csv"]


@pytest.mark.parametrize("how", ["same", "hard", "soft"])
def test_cli_output_that_is_the_input_is_refused(q, tmp_path, how):
    out = {"same": q, "hard": tmp_path / "hard.csv", "soft": tmp_path / "soft.csv"}[how]
    if how == "hard":
        os.link(q, out)
    elif how == "soft":
        os.symlink(q, out)
    before = q.read_bytes()
    for args in (("compress", q, "--threshold", "0.001", "-o", out), ("decompress", q, "--rate", "50", "-o", out),
                 ("decompress", tmp_path / "other.csv", "--times-from", q, "-o", out)):
        if args[1] != q:
            (tmp_path / "other.csv").write_text("time,w,x,y,z\n0,1,0,0,0\n1,1,0,0,0\n")
        line = one_line_error(run(*args))
        assert f"--output {out}: is the input file" in line
        assert q.read_bytes() == before and (how == "same" or out.exists())


def test_cli_output_inside_the_input_sensor_folder_is_refused(tests_data, tmp_path):
    src = tmp_path / "sensors"
    for s in ("pelvis", "left-foot"):
        (src / s).mkdir(parents=True)
        (src / s / "Quaternion.csv").write_bytes((tests_data / "xio" / s / "Quaternion.csv").read_bytes())
    before = sorted(str(p.relative_to(src)) for p in src.rglob("*"))
    for args in (("compress", src, "--threshold", "0.001", "-o", src / "out"),
                 ("compress", src, "--threshold", "0.001", "-o", src),
                 ("compress", src / "pelvis" / "Quaternion.csv", "--threshold", "0.001", "-o",
                  src / "pelvis" / "Quaternion.csv"),
                 ("sweep", src, "--out", src / "sweep"),
                 ("sweep", src / "pelvis", "--out", src / "pelvis" / "sweep")):
        line = one_line_error(run(*args))
        assert "input" in line and (" --output " in line or " --out " in line), line
    assert sorted(str(p.relative_to(src)) for p in src.rglob("*")) == before
    r = run("compress", src, "--threshold", "0.001", "-o", tmp_path / "out")  # beside the input: fine
    assert r.returncode == 0, r.stderr
    assert listing(tmp_path / "out") == ["left-foot.csv", "pelvis.csv"]


def test_cli_convert_and_plot_outputs_are_checked(tests_data, tmp_path):
    bvh = tmp_path / "m.bvh"
    bvh.write_bytes((tests_data / "bvh" / "walk-meredith-60.bvh").read_bytes())
    os.symlink(bvh, tmp_path / "alias.bvh")
    before = bvh.read_bytes()
    assert "OUTPUT" in one_line_error(run("convert", bvh, tmp_path / "alias.bvh"))
    assert "--output" in one_line_error(run("compress", bvh, "--threshold", "0.01", "-o", bvh))
    assert "--plot" in one_line_error(run("segment", bvh, "--plot", tmp_path / "alias.bvh"))
    assert bvh.read_bytes() == before and (tmp_path / "alias.bvh").is_symlink()
    r = run("convert", bvh, tmp_path / "copy.bvh")
    assert r.returncode == 0, r.stderr
    assert listing(tmp_path) == ["alias.bvh", "copy.bvh", "m.bvh"]


def test_cli_filter_to_dev_null(tests_data):
    tsv = tests_data / "markers" / "juggling-qualisys-300hz-first120.tsv"
    names = next(ln for ln in tsv.read_text().splitlines() if ln.startswith("MARKER_NAMES")).split("\t")[1]
    r = run("filter", tsv, "--auto", "--markers", names, "-o", "/dev/null")
    assert r.returncode == 0, r.stderr
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
