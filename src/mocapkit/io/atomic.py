"""Safe output: every file mocapkit writes goes through :func:`atomic_writer`; inputs are read here too.

What the writer guarantees, by the kind of the output path:

* **Regular file (new or existing)**: the contents go to an unnamed file (Linux ``O_TMPFILE``) in
  the target's folder, are flushed and fsync'ed, get their mode bits, and only then are linked into
  place: a new file appears complete under its own name (no temporary name ever exists); an existing
  one is replaced by renaming a hidden link made once the data is complete. Where unnamed files or
  linking them are not available, a dot-temporary ``.NAME.XXXXXXXX.tmp`` in the same folder is used
  and removed on any failure (an exception, ``KeyboardInterrupt``). A reader (or a crash) sees the old
  file or the complete new one, never a part.
* **Mode bits**: ``0o666 & ~umask`` for a new file; a replaced file keeps its mode (and, where the
  process may, its owner and group).
* **Character device or named pipe** (``/dev/null``, a FIFO): written *into*, never replaced or
  truncated. A FIFO with no reader is waited for ``FIFO_WAIT_S`` seconds, then refused with an error
  (no hang).
* **Symlink**: followed to its final target, which is written as above; the link stays a link. A
  dangling symlink creates the file it points to when that file's folder exists.
* ``/dev/stdout``, ``/dev/stderr``, ``/dev/fd/N``, ``/proc/self/fd/N``: written through the process's
  own descriptor (shared position, no reopening).
* Folders, sockets and block devices are refused. Every ``OSError`` names the path the caller gave,
  never a temporary name.

:func:`check_output` refuses, before any work, an output that is the same file as an input (same
device and inode, so hard links and symlinks are caught) and an output inside an input folder.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import stat
import sys
import tempfile
import time
from collections.abc import Iterable, Iterator
from typing import IO, Any

FIFO_WAIT_S = 2.0
"""How long :func:`atomic_writer` waits for a reader to open a named pipe before giving up."""

_AT_FDCWD = -100
_AT_EMPTY_PATH = 0x1000
_UNAVAILABLE: set[str] = set()  # ways of linking an unnamed file found not to work in this process
_libc = None


def _named(exc: OSError, path: str | os.PathLike[str]) -> OSError:
    """``exc`` re-issued with the caller's path as its file name (errno kept, so the subclass too)."""
    code = exc.errno if exc.errno is not None else errno.EIO
    return OSError(code, exc.strerror or str(exc), str(path))


def _umask() -> int:
    """The process umask, read without changing it where the platform allows."""
    with contextlib.suppress(OSError, ValueError), open("/proc/self/status", encoding="ascii", errors="replace") as fh:
        for line in fh:
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


# --- where does a path write to? -------------------------------------------------------------------

_PROC_FD = re.compile(r"/proc/(\d+)(?:/task/\d+)?/fd/(\d+)")
_DEV_FD = re.compile(r"/dev/fd/(\d+)")


def _own_descriptor(path: str) -> int | None:
    """The descriptor number when ``path`` names one of this process's open files (``/dev/stdout``,
    ``/dev/fd/1``, ``/proc/self/fd/3``...), else ``None``. Ordinary symlinks are followed one by one,
    so the magic links of ``/proc`` are recognised instead of being read as file names."""
    p = os.path.abspath(path)
    for _ in range(40):
        head, tail = os.path.split(p)
        head = os.path.realpath(head)
        p = os.path.join(head, tail)
        m = _PROC_FD.fullmatch(p)
        if m is not None and int(m[1]) == os.getpid():
            return int(m[2])
        m = _DEV_FD.fullmatch(p)
        if m is not None and not sys.platform.startswith("linux"):
            return int(m[1])
        if not os.path.islink(p):
            return None
        p = os.path.join(head, os.readlink(p))
    return None


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISDIR, "a folder"), (stat.S_ISSOCK, "a socket"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISFIFO, "a named pipe")):
        if test(mode):
            return name
    return "a regular file" if stat.S_ISREG(mode) else "a special file"


def _resolve(path: str) -> tuple[str, object, os.stat_result | None]:
    """``("fd", n, None)``, ``("special", path, st)`` or ``("file", final_path, st_or_None)``."""
    try:
        own = _own_descriptor(path)
    except (OSError, ValueError):  # an unreadable link: the checks below name the problem
        own = None
    if own is not None:
        return "fd", own, None
    try:
        st = os.stat(path)  # follows every symlink (loops and bad components raise here)
    except FileNotFoundError:
        st = None
    except OSError as e:
        raise _named(e, path) from None
    if st is not None:
        if stat.S_ISDIR(st.st_mode):
            raise IsADirectoryError(errno.EISDIR, "is a folder, not a file", path)
        if stat.S_ISCHR(st.st_mode) or stat.S_ISFIFO(st.st_mode):
            return "special", path, st
        if not stat.S_ISREG(st.st_mode):
            raise OSError(errno.EINVAL, f"is {_kind(st.st_mode)}; outputs are regular files, character devices "
                                        "or named pipes", path)
        real = os.path.realpath(path)
        try:
            same = os.path.samestat(os.stat(real), st)
        except OSError:
            same = False
        if not same:  # e.g. another process's /proc/PID/fd/N: no name to replace it by
            raise OSError(errno.EINVAL, "resolves (through /proc) to a file without a usable name; give the "
                                        "file's own path", path)
        return "file", real, st
    real = os.path.realpath(path)
    folder = os.path.dirname(real) or "."
    if not os.path.isdir(folder):
        if os.path.islink(path):
            raise FileNotFoundError(errno.ENOENT, f"is a symlink to {real}, whose folder does not exist", path)
        raise FileNotFoundError(errno.ENOENT, f"the folder {os.path.dirname(path) or '.'} does not exist", path)
    return "file", real, None


# --- unnamed files (Linux) -------------------------------------------------------------------------

def _link_empty_path(fd: int, dest: str) -> None:
    """``linkat(fd, "", AT_FDCWD, dest, AT_EMPTY_PATH)`` (allowed without privileges since Linux 6.10)."""
    global _libc
    import ctypes

    if _libc is None:
        _libc = ctypes.CDLL(None, use_errno=True)
        _libc.linkat.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_int]
        _libc.linkat.restype = ctypes.c_int
    if _libc.linkat(fd, b"", _AT_FDCWD, os.fsencode(dest), _AT_EMPTY_PATH) != 0:
        code = ctypes.get_errno()
        raise OSError(code, os.strerror(code), dest)


def _link_proc(fd: int, dest: str) -> None:
    """``linkat`` of ``/proc/self/fd/N`` following the magic link (older kernels, no privilege)."""
    os.link(f"/proc/self/fd/{fd}", dest, follow_symlinks=True)


_NOT_AVAILABLE = {errno.ENOENT, errno.EXDEV, errno.EPERM, errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP}


def _link_unnamed(fd: int, dest: str) -> bool:
    """Give the unnamed file ``fd`` the name ``dest``; ``False`` when no way of doing it works here.
    Real failures (the name exists, no space, read-only file system...) raise."""
    for name, fn in (("empty_path", _link_empty_path), ("proc", _link_proc)):
        if name in _UNAVAILABLE:
            continue
        try:
            fn(fd, dest)
            return True
        except (OSError, AttributeError) as e:
            if isinstance(e, OSError) and e.errno not in _NOT_AVAILABLE:
                raise
            if not os.path.isdir(os.path.dirname(dest) or "."):
                raise  # the folder went away: a real error, not a missing feature
            _UNAVAILABLE.add(name)
    return False


def _open_unnamed(folder: str) -> int | None:
    """An unnamed file in ``folder`` opened read-write (mode 0o600 until committed), or ``None``."""
    flag = getattr(os, "O_TMPFILE", 0)
    if not flag or len(_UNAVAILABLE) == 2:
        return None
    try:
        return os.open(folder, flag | os.O_RDWR | getattr(os, "O_CLOEXEC", 0), 0o600)
    except OSError as e:
        if e.errno in (errno.EOPNOTSUPP, errno.EISDIR, errno.EINVAL, errno.ENOSYS):
            return None  # this file system (or kernel) has no unnamed files
        raise


def _hidden_name(folder: str, base: str) -> str:
    return os.path.join(folder, f".{base}.{os.urandom(4).hex()}.tmp")


def _ours(exc: OSError, folder: str) -> bool:
    """Whether ``exc`` is about the output being written (no file name, the target or one of the
    writer's temporary names), so that it is re-issued under the caller's path."""
    if exc.filename is None:
        return True
    name = os.fsdecode(exc.filename) if isinstance(exc.filename, bytes) else str(exc.filename)
    return os.path.dirname(os.path.abspath(name)) == os.path.abspath(folder)


# --- the writers -----------------------------------------------------------------------------------

def _wrap(fd: int, binary: bool, encoding: str, closefd: bool) -> IO[Any]:
    if binary:
        return os.fdopen(fd, "wb", closefd=closefd)
    return os.fdopen(fd, "w", encoding=encoding, newline="", closefd=closefd)


def _fsync_folder(folder: str) -> None:
    with contextlib.suppress(OSError, AttributeError):
        dfd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)


def _finish(fd: int, mode: int, old: os.stat_result | None, name: str | None = None) -> None:
    """fsync, then the owner of a replaced file (where allowed) and the mode bits."""
    os.fsync(fd)
    if old is not None and hasattr(os, "fchown") and (old.st_uid, old.st_gid) != (os.getuid(), os.getgid()):
        with contextlib.suppress(OSError):
            os.fchown(fd, old.st_uid, old.st_gid)  # before fchmod: a chown clears set-id bits
    if hasattr(os, "fchmod"):
        os.fchmod(fd, mode)
    elif name is not None:  # platforms without fchmod (Windows)
        os.chmod(name, mode)


def _commit_named(fd: int, tmp: str, dest: str, mode: int, old: os.stat_result | None) -> None:
    _finish(fd, mode, old, tmp)
    os.replace(tmp, dest)


def _commit_unnamed(fd: int, dest: str, mode: int, old: os.stat_result | None) -> bool:
    """Link the unnamed file into place; ``False`` when linking is not available here."""
    _finish(fd, mode, old)
    folder, base = os.path.split(dest)
    if old is None:
        try:  # a new file appears complete under its own name: no temporary name at all
            return _link_unnamed(fd, dest)
        except FileExistsError:
            pass  # created meanwhile by someone else: replace it like an existing file
    hidden = _hidden_name(folder, base)
    if not _link_unnamed(fd, hidden):
        return False
    try:
        os.replace(hidden, dest)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(hidden)
        raise
    return True


def _copy_to_named(fd: int, dest: str, mode: int, old: os.stat_result | None) -> None:
    """Fallback when an unnamed file cannot be linked: copy it to a dot-temporary and rename that."""
    folder, base = os.path.split(dest)
    tfd, tmp = tempfile.mkstemp(prefix=f".{base}.", suffix=".tmp", dir=folder or ".")
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        while chunk := os.read(fd, 1 << 20):
            view = memoryview(chunk)
            while view:
                view = view[os.write(tfd, view):]
        _commit_named(tfd, tmp, dest, mode, old)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    finally:
        os.close(tfd)


@contextlib.contextmanager
def _regular(user: str, dest: str, old: os.stat_result | None, binary: bool, encoding: str) -> Iterator[IO[Any]]:
    folder = os.path.dirname(dest) or "."
    mode = (old.st_mode & 0o7777) if old is not None else (0o666 & ~_umask())
    tmp = None
    try:
        fd = _open_unnamed(folder)
        if fd is None:
            fd, tmp = tempfile.mkstemp(prefix=f".{os.path.basename(dest)}.", suffix=".tmp", dir=folder)
    except OSError as e:
        raise _named(e, user) from None
    try:
        fh = _wrap(fd, binary, encoding, closefd=False)
        try:
            yield fh
            fh.flush()
        finally:
            with contextlib.suppress(Exception):
                fh.close()  # closefd=False: the descriptor stays open for the commit
        if tmp is not None:
            _commit_named(fd, tmp, dest, mode, old)
            tmp = None
        elif not _commit_unnamed(fd, dest, mode, old):
            _copy_to_named(fd, dest, mode, old)
        _fsync_folder(folder)
    except OSError as e:
        if _ours(e, folder):
            raise _named(e, user) from None
        raise
    finally:
        os.close(fd)
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)


def _open_fifo(user: str, wait: float) -> int:
    flags = os.O_WRONLY | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0)
    deadline = time.monotonic() + wait
    while True:
        try:
            fd = os.open(user, flags | os.O_NONBLOCK)
            break
        except OSError as e:
            if e.errno != errno.ENXIO:
                raise
            if time.monotonic() >= deadline:
                raise OSError(errno.ENXIO, f"is a named pipe nobody reads (waited {wait:g} s); start the reading "
                                           "side first", user) from None
            time.sleep(0.02)
    os.set_blocking(fd, True)  # a full pipe makes the writer wait, as usual
    return fd


@contextlib.contextmanager
def _into(user: str, fd: int, binary: bool, encoding: str) -> Iterator[IO[Any]]:
    """Write into an open device, pipe or own descriptor (nothing is replaced)."""
    try:
        fh = _wrap(fd, binary, encoding, closefd=True)
    except BaseException:
        os.close(fd)
        raise
    try:
        with fh:
            yield fh
            fh.flush()
    except OSError as e:
        if e.filename is None:
            raise _named(e, user) from None
        raise


@contextlib.contextmanager
def atomic_writer(path: str | os.PathLike[str], *, binary: bool = False,
                  encoding: str = "utf-8") -> Iterator[IO[Any]]:
    """Context manager yielding a file object that writes ``path`` safely (see the module docstring).

    A regular file (or the final target of a symlink) is replaced atomically on a clean exit and left
    untouched when the block raises; a character device or named pipe is written into; ``/dev/stdout``
    and its kin use the process's own descriptor. Text mode writes ``"\\n"`` line ends unchanged on
    every platform. An ``OSError`` names ``path`` as given.
    """
    user = os.fspath(path)
    user = user if isinstance(user, str) else os.fsdecode(user)
    how, where, st = _resolve(user)
    if how == "fd":
        assert isinstance(where, int)  # _resolve gives the descriptor's number for "fd"
        n = where
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                if stream is not None and stream.fileno() == n:
                    stream.flush()
        try:
            fd = os.dup(n)
        except OSError as e:
            raise _named(e, user) from None
        with _into(user, fd, binary, encoding) as fh:
            yield fh
    elif how == "special":
        try:
            if stat.S_ISFIFO(st.st_mode):  # type: ignore[union-attr]
                fd = _open_fifo(user, FIFO_WAIT_S)
            else:
                fd = os.open(user, os.O_WRONLY | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0))
        except OSError as e:
            raise _named(e, user) from None
        with _into(user, fd, binary, encoding) as fh:
            yield fh
    else:
        with _regular(user, str(where), st, binary, encoding) as fh:
            yield fh


def atomic_write_text(path: str | os.PathLike[str], text: str, encoding: str = "utf-8") -> None:
    """Write ``text`` to ``path`` safely (``"\\n"`` is written as is, no newline translation)."""
    with atomic_writer(path, encoding=encoding) as fh:
        fh.write(text)


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to ``path`` safely."""
    with atomic_writer(path, binary=True) as fh:
        fh.write(data)


def is_device_or_pipe(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` (followed through symlinks) is a character device or a named pipe, which
    :func:`atomic_writer` writes into (``/dev/null``, ``/dev/stdout`` on a terminal or pipe, a FIFO)."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return False
    return stat.S_ISCHR(mode) or stat.S_ISFIFO(mode)


# --- outputs that would destroy inputs -------------------------------------------------------------

def _stat(p: str) -> os.stat_result | None:
    try:
        return os.stat(p)
    except (OSError, ValueError):
        return None


def _ancestors(p: str) -> Iterator[tuple[str, os.stat_result]]:
    """``p`` (resolved) and each folder above it that exists, with its stat."""
    cur = os.path.realpath(p)
    while True:
        st = _stat(cur)
        if st is not None:
            yield cur, st
        parent = os.path.dirname(cur)
        if parent == cur:
            return
        cur = parent


def check_output(path: str | os.PathLike[str] | None, inputs: Iterable[str | os.PathLike[str] | None] = (), *,
                 folder: bool = False, option: str = "--output") -> None:
    """Refuse, before any work, an output that would overwrite or pollute an input, or cannot be written.

    Refused (``InvalidParameterError`` naming ``option`` and ``path``): the same file as an input
    (same device and inode: also through hard links and symlinks); a file output inside an input folder;
    with ``folder=True``, an output folder that is, or is inside, an input folder; a file
    output that is a folder; an output whose folder is missing or not writable. Character devices and
    named pipes (``/dev/null``, a FIFO) are accepted as file outputs.
    """
    from mocapkit.errors import InvalidParameterError

    if path is None:
        return
    p = os.fspath(path)
    p = p if isinstance(p, str) else os.fsdecode(p)
    where = f"{option} {p}"
    ins = [os.fspath(i) for i in inputs if i is not None]
    out_st = _stat(p)
    for i in ins:
        ist = _stat(i)
        if ist is None or stat.S_ISDIR(ist.st_mode):
            continue  # folders: below
        if out_st is not None and os.path.samestat(out_st, ist):
            how = "" if os.path.abspath(p) == os.path.abspath(i) else " (a link to it)"
            raise InvalidParameterError(f"{where}: is the input file {i}{how}; write the result elsewhere")
    special = out_st is not None and (stat.S_ISCHR(out_st.st_mode) or stat.S_ISFIFO(out_st.st_mode))
    if special and not folder:
        return  # written into, never replaced: nothing of an input can be lost
    if out_st is None and os.path.islink(p) and not os.path.isdir(os.path.dirname(os.path.realpath(p)) or "."):
        raise InvalidParameterError(f"{where}: is a symlink to {os.path.realpath(p)}, whose folder does not exist")
    for i in ins:
        ist = _stat(i)
        if ist is None or not stat.S_ISDIR(ist.st_mode):
            continue
        for anc, ast in _ancestors(p):
            if os.path.samestat(ast, ist):
                what = "is the input folder" if anc == os.path.realpath(p) else "is inside the input folder"
                raise InvalidParameterError(f"{where}: {what} {i}; write the results elsewhere")
    if folder:
        if out_st is not None and not stat.S_ISDIR(out_st.st_mode):
            raise InvalidParameterError(f"{where}: expected a folder for the outputs")
        parent = p if out_st is not None else (os.path.dirname(p) or ".")
    else:
        if out_st is not None and stat.S_ISDIR(out_st.st_mode):
            raise InvalidParameterError(f"{where}: is a folder; give a file name")
        parent = os.path.dirname(os.path.realpath(p)) if out_st is not None or os.path.islink(p) \
            else (os.path.dirname(p) or ".")
    if not os.path.isdir(parent):
        raise InvalidParameterError(f"{where}: the folder {parent} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InvalidParameterError(f"{where}: the folder {parent} is not writable")
