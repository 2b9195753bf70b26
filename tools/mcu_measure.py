"""The C encoders (``c/mkpla``) on a Cortex-M4 under QEMU: points, instructions per sample, size, RAM.

``c/mcu`` cross-compiles the float32 library (``MKPLA_MAX_DIM`` 4, the sensor build) with
``arm-none-eabi-gcc`` for ``-mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard`` and links it
into a harness that QEMU's ``mps2-an386`` board runs; the harness reads quaternion signals and jobs
from a host file (semihosting), pushes every sample through ``mkpla_encoder_push`` and writes the
points and, per push, the segment length n before it.

1. **Points**: every job's points (index, tick, values, bit for bit) must equal those of the host
   float32 build, :func:`mocapkit.pla.native.encode` with ``precision="float32"`` on the same samples
   (times as microsecond ticks, :func:`mocapkit.pla.native.sensor_ticks`). ``build(strict="")``
   compiles with GCC's default flags instead (gnu17, contraction allowed): the same bits are expected.
2. **Instructions per sample**: QEMU logs every translated block (``-d in_asm``) and every executed
   block (``-d exec,nochain``; no chaining, so no block runs unlogged), restricted with ``-dfilter``
   to the library's code and the C library routines it calls. A call is counted from the block at the
   entry of the method's push function (``mkpla_fastsw_push`` ...) up to the first block outside that
   function and its callees (the return into ``mkpla_encoder_push``); each block adds the number of
   instructions QEMU translated into it (a block runs to its end: it ends at every branch).
   ``--singlestep`` counts one logged instruction at a time instead (slower; the test compares both).
3. **Code size**: bytes of ``text`` of each encoder's ``init``/``push``/``flush`` and the static
   helpers they call (call graph from ``objdump -d``); **RAM**: ``sizeof`` of the state (from the
   harness, on the target) plus the SW/anglesw buffer for a maximum segment length L.

4. **The radio packetiser** (``c/mkpla/mkp.c``) runs in a second harness (``c/mcu/mkp_main.c``):
   ``mkp_init``, one ``mkp_push`` per float32 sample, ``mkp_flush``; its packets must equal
   :func:`mocapkit.pla.packets.packetise` with ``precision="float32"`` byte for byte (the CLI's default
   bits, 20-byte packets). ``mkp_push`` is counted as above, callees (quantiser, anglesw, bit packing,
   CRC) included; ``mkpla_anglesw_push`` is counted in the same run, for what the packetiser adds.

5. **The C tests** (``c/tests/mkpla_selftest.c``) run on the target too (``selftest.elf``: 32-bit
   ``size_t``), :func:`run_selftest`.

    python tools/mcu_measure.py [--opt -O2] [--json docs/mcu.json] [--data ../shared/data]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import queue
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import threading
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
MCU_DIR = ROOT / "c" / "mcu"
DATA = ROOT.parent / "shared" / "data"

METHODS = ("fastsw", "sw", "cplr", "swing", "anglesw")
#: method -> the C library's code (mkpla.h; the same as mocapkit.pla.native.METHOD_CODES)
CODES = {"fastsw": 0, "sw": 1, "cplr": 2, "swing": 3, "anglesw": 4}
#: SSR thresholds (fastSW, SW, CPLR) and Swing bounds of the equality runs
THRESHOLDS = (1e-4, 1e-3, 1e-2, 1e-1)
#: anglesw bounds of the equality runs, degrees
ANGLES_DEG = (0.5, 1.0, 2.0, 5.0)
#: Python's default maximum segment length (mocapkit.pla.base.BOUNDED_BY_DEFAULT); 0 = unbounded
DEFAULT_MAXLEN = {"fastsw": 0, "sw": 1000, "cplr": 0, "swing": 0, "anglesw": 1000}
#: the maximum segment length L the RAM and worst-case figures of SW and anglesw are given for
RAM_L = 1000
#: turn per sample (degrees) of the synthetic sensor of anglesw's fit: past 90 degrees within its segment
TURN_DEG = 0.5
#: the fastSW paper's Table 2 (4-D, Cortex-M4, GCC 11.1 -O3): min and max instructions per sample
PAPER = {"fastsw": (191, 210), "sw": (53, "161 + 35 n"), "cplr": (198, 209), "swing": (252, 420)}
ARCH = "-mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard"
#: c/mcu/Makefile's STRICT (what a sensor build would give; build(strict="") leaves it out: GCC's defaults)
STRICT = "-std=c99 -pedantic -ffp-contract=off -fno-math-errno"
CFLAGS = f"{STRICT} -Wall -Wextra {ARCH} -DMKPLA_FLOAT32"

MAGIC_IN = 0x424A4B4D
MAGIC_OUT = 0x54504B4D
#: the encoders' harness's file version (2: times as uint32 ticks); the packet harness's is MKP_VERSION
VERSION = 2
MKP_VERSION = 1
#: limits of the harness (c/mcu/main.c)
MAX_SIGNALS = 64
MAX_SAMPLES = 32768
MAX_INPUT = 1 << 20
MAX_SEGMENT = 8192


class McuError(RuntimeError):
    """The toolchain, QEMU or the harness failed."""


# --------------------------------------------------------------------------------------------------
# tools and build
# --------------------------------------------------------------------------------------------------


def missing_tools() -> str | None:
    """Why the measurement cannot run here (a missing program), or ``None``."""
    for prog, pkg in (("arm-none-eabi-gcc", "gcc-arm-none-eabi libnewlib-arm-none-eabi"),
                      ("arm-none-eabi-nm", "binutils-arm-none-eabi"),
                      ("arm-none-eabi-objdump", "binutils-arm-none-eabi"),
                      ("qemu-system-arm", "qemu-system-arm"),
                      ("make", "make")):
        if shutil.which(prog) is None:
            return f"{prog} not found (Debian: apt-get install {pkg})"
    return None


def _run(cmd: list[str], **kw) -> subprocess.CompletedProcess:
    res = subprocess.run(cmd, check=False, capture_output=True, text=True, **kw)
    if res.returncode != 0:
        raise McuError(f"{' '.join(cmd)} failed ({res.returncode}): {(res.stderr or res.stdout).strip()[-2000:]}")
    return res


def build(build_dir: Path, opt: str = "-O3", werror: bool = True, mkpla_dir: Path | None = None,
          strict: str | None = None) -> Path:
    """Cross-compile the harnesses into ``build_dir`` (``make -C c/mcu``); the encoders' ELF's path.

    ``werror``: any compiler warning fails the build. ``mkpla_dir``: a folder with another
    ``mkpla.c``/``mkpla.h`` (experiments), default ``c/mkpla``. ``strict``: the Makefile's STRICT flags
    (default :data:`STRICT`; ``""``: GCC's defaults). Returns ``build_dir/harness.elf``.
    """
    build_dir = Path(build_dir).resolve()
    cmd = ["make", "-s", "-B", "-C", str(MCU_DIR), f"BUILD={build_dir}", f"OPT={opt}"]
    if strict is not None:
        cmd.append(f"STRICT={strict}")
    if mkpla_dir is not None:
        cmd.append(f"MKPLA_DIR={Path(mkpla_dir).resolve()}")
    if werror:
        cmd.append("WERROR=-Werror")
    res = _run(cmd)
    if "warning" in (res.stderr + res.stdout).lower():
        raise McuError(f"the build printed warnings:\n{res.stderr}{res.stdout}")
    return build_dir / "harness.elf"


def versions() -> dict[str, str]:
    """First lines of ``arm-none-eabi-gcc --version`` and ``qemu-system-arm --version``."""
    gcc = _run(["arm-none-eabi-gcc", "--version"]).stdout.splitlines()[0]
    qemu = _run(["qemu-system-arm", "--version"]).stdout.splitlines()[0]
    return {"gcc": gcc, "qemu": qemu}


# --------------------------------------------------------------------------------------------------
# the image: symbols, call graph, code size
# --------------------------------------------------------------------------------------------------

_BRANCH = re.compile(r"^\s*([0-9a-f]+):\s+(?:[0-9a-f]{4}\s)+\s*(c?b[a-z.]*)\s+(?:r\d+,\s*)?([0-9a-f]+) <([^>+]+)")


@dataclass
class Image:
    """Function symbols of the harness ELF, which of them come from ``mkpla.o``, and who calls whom."""

    functions: dict[str, tuple[int, int]]   # name -> (start address, size in bytes)
    library: set[str]                        # functions defined in mkpla.o
    calls: dict[str, set[str]] = field(default_factory=dict)

    @classmethod
    def load(cls, elf: Path, objects: tuple[str, ...] = ("mkpla.o",)) -> Image:
        """``objects``: the library's object files (beside the ELF) whose functions are "own" code."""
        funcs: dict[str, tuple[int, int]] = {}
        for line in _run(["arm-none-eabi-nm", "-S", "--size-sort", str(elf)]).stdout.splitlines():
            parts = line.split()
            if len(parts) == 4 and parts[2] in "tTwW":
                funcs[parts[3]] = (int(parts[0], 16) & ~1, int(parts[1], 16))
        lib = set()
        for obj in objects:
            for line in _run(["arm-none-eabi-nm", "--defined-only", str(Path(elf).parent / obj)]).stdout.splitlines():
                parts = line.split()
                if len(parts) == 3 and parts[1] in "tT":
                    lib.add(parts[2])
        missing = lib - set(funcs)
        if missing:
            raise McuError(f"{elf}: no sized symbol for {sorted(missing)}")
        img = cls(funcs, lib)
        current = None
        for line in _run(["arm-none-eabi-objdump", "-d", str(elf)]).stdout.splitlines():
            m = re.match(r"^[0-9a-f]+ <([^>]+)>:", line)
            if m:
                current = m.group(1)
                img.calls.setdefault(current, set())
                continue
            b = _BRANCH.match(line)
            if b and current is not None and b.group(4) != current and b.group(4) in funcs:
                img.calls[current].add(b.group(4))
        return img

    def callers(self, name: str) -> set[str]:
        """The functions that branch to ``name``."""
        return {f for f, cs in self.calls.items() if name in cs}

    def closure(self, names) -> set[str]:
        """The functions and everything they call, transitively."""
        seen: set[str] = set()
        todo = list(names)
        while todo:
            f = todo.pop()
            if f not in seen:
                seen.add(f)
                todo.extend(self.calls.get(f, ()))
        return seen

    def range(self, name: str) -> tuple[int, int]:
        start, size = self.functions[name]
        return start, start + size

    def encoder_functions(self, method: str) -> set[str]:
        """``mkpla_<method>_init/_push/_flush`` with the functions they call."""
        return self.closure(f"mkpla_{method}_{op}" for op in ("init", "push", "flush"))

    def text_bytes(self, method: str, functions: set[str] | None = None) -> tuple[int, dict[str, int]]:
        """Code bytes of the encoder's own functions (mkpla.o), and the C library routines it calls.

        ``functions``: count these (with their own library/libc split) instead of the encoder's."""
        fs = self.encoder_functions(method) if functions is None else functions
        own = sum(self.functions[f][1] for f in fs if f in self.library)
        libc = {f: self.functions[f][1] for f in sorted(fs - self.library)}
        return own, libc


# --------------------------------------------------------------------------------------------------
# signals, jobs, the harness's files
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Signal:
    """A quaternion signal as the sensor build sees it: microsecond ticks since the first sample, float32 values."""

    name: str
    t: np.ndarray   # uint32 (n,) ticks
    q: np.ndarray   # float32 (n, 4)
    t_source: np.ndarray  # the float64 times (for the host reference)
    q_source: np.ndarray  # the float64 values


def as_sensor(name: str, t: np.ndarray, X: np.ndarray) -> Signal:
    """The float32 build's inputs exactly as :class:`mocapkit.pla.native.NativeEncoder` makes them."""
    from mocapkit.pla.native import sensor_ticks

    t = np.asarray(t, dtype=np.float64)
    X = np.asarray(X, dtype=np.float64)
    return Signal(name, sensor_ticks(t, float(t[0])),
                  np.ascontiguousarray(X, dtype=np.float32).reshape(-1, 4), t, X)


@dataclass(frozen=True)
class Job:
    """One signal through one encoder. ``threshold`` in the kernel's unit (radians for anglesw)."""

    signal: int
    method: str
    threshold: float
    maxlen: int
    label: str = ""


@dataclass
class Result:
    """What the harness wrote for a job."""

    index: np.ndarray   # uint32 point indices
    t: np.ndarray       # uint32 point ticks
    v: np.ndarray       # float32 (m, 4) point values
    seglen: np.ndarray  # uint32: segment length before each push


def default_jobs(n_signals: int, methods=METHODS) -> list[Job]:
    """Every signal at every threshold of :data:`THRESHOLDS` / :data:`ANGLES_DEG`, Python's maxlen."""
    jobs = []
    for i in range(n_signals):
        for m in methods:
            if m == "anglesw":
                for deg in ANGLES_DEG:
                    jobs.append(Job(i, m, math.radians(deg), DEFAULT_MAXLEN[m], f"{deg:g} deg"))
            else:
                for th in THRESHOLDS:
                    jobs.append(Job(i, m, th, DEFAULT_MAXLEN[m], f"{th:g}"))
    return jobs


def write_input(path: Path, signals: list[Signal], jobs: list[Job]) -> None:
    """The harness's input file (format in ``c/mcu/main.c``)."""
    if len(signals) > MAX_SIGNALS:
        raise McuError(f"at most {MAX_SIGNALS} signals per run, got {len(signals)}")
    parts = [struct.pack("<4I", MAGIC_IN, VERSION, len(signals), len(jobs))]
    for s in signals:
        if len(s.t) > MAX_SAMPLES:
            raise McuError(f"{s.name}: {len(s.t)} samples, the harness takes {MAX_SAMPLES}")
        parts += [struct.pack("<I", len(s.t)), s.t.astype("<u4").tobytes(), s.q.astype("<f4").tobytes()]
    for j in jobs:
        if j.maxlen > MAX_SEGMENT:
            raise McuError(f"maximum segment length {j.maxlen} above the harness's {MAX_SEGMENT}")
        parts.append(struct.pack("<3If", j.signal, CODES[j.method], j.maxlen, np.float32(j.threshold)))
    data = b"".join(parts)
    if len(data) > MAX_INPUT:
        raise McuError(f"input of {len(data)} bytes, the harness takes {MAX_INPUT}")
    path.write_bytes(data)


def read_output(path: Path, jobs: list[Job], signals: list[Signal]) -> tuple[dict[str, int], list[Result]]:
    """Parse the harness's output: state sizes (``sizeof``, bytes) and one :class:`Result` per job."""
    w = np.fromfile(path, dtype="<u4")
    if len(w) < 9 or w[0] != MAGIC_OUT or w[1] != VERSION or w[2] != len(jobs):
        raise McuError(f"{path}: not a harness output for {len(jobs)} jobs")
    sizes = dict(zip(("fastsw", "sw", "cplr", "swing", "anglesw", "encoder"), (int(x) for x in w[3:9]), strict=True))
    pos = 9
    out = []
    for j in jobs:
        m = int(w[pos])
        rec = w[pos + 1: pos + 1 + 6 * m].reshape(m, 6)
        pos += 1 + 6 * m
        n = int(w[pos])
        if n != len(signals[j.signal].t):
            raise McuError(f"{path}: job {j} reports {n} samples")
        seglen = w[pos + 1: pos + 1 + n].copy()
        pos += 1 + n
        out.append(Result(rec[:, 0].copy(), rec[:, 1].copy(), rec[:, 2:].copy().view("<f4"), seglen))
    if pos != len(w):
        raise McuError(f"{path}: {len(w) - pos} words after the last job")
    return sizes, out


# --------------------------------------------------------------------------------------------------
# QEMU
# --------------------------------------------------------------------------------------------------

_TRACE = re.compile(rb"^Trace \d+: 0x[0-9a-f]+ \[[0-9a-f]+/([0-9a-f]{8})/", re.MULTILINE)
_BLOCK = re.compile(rb"^IN:[^\n]*\n(0x[0-9a-f]+):[^\n]*\n((?:0x[0-9a-f]+:[^\n]*\n)*)", re.MULTILINE)


def _hex8(digits: list[bytes]) -> np.ndarray:
    """Eight-digit lower-case hex numbers to int64, vectorised."""
    if not digits:
        return np.empty(0, np.int64)
    a = np.frombuffer(b"".join(digits), dtype=np.uint8).reshape(-1, 8).astype(np.int64)
    return np.where(a >= 97, a - 87, a - 48) @ (16 ** np.arange(7, -1, -1, dtype=np.int64))


class CallCounter:
    """Instructions per call of one function from QEMU's ``in_asm``/``exec`` log, fed in chunks.

    A call starts at a block beginning at ``entry`` and ends at the first block outside ``inside``
    (address ranges of the function and its callees) or, when ``returns_logged`` is false (the log
    holds nothing but those ranges), where the next call starts. Each block counts the instructions QEMU
    translated into it (``in_asm``; the same address always gave the same block here, checked);
    ``singlestep``: every block is one instruction. Vectorised with NumPy: logs run to millions of
    blocks.
    """

    def __init__(self, entry: int, inside: list[tuple[int, int]], singlestep: bool = False,
                 returns_logged: bool = True):
        self.entry = entry
        self.returns_logged = returns_logged
        self.inside = inside
        self.singlestep = singlestep
        self.sizes: dict[int, int] = {}   # block address -> instructions
        self._keys = np.empty(0, np.int64)
        self._vals = np.empty(0, np.int64)
        self.counts: list[int] = []
        self.current: int | None = None   # instructions so far of a call still running
        self.rest = b""

    def _blocks(self, data: bytes) -> None:
        new = False
        for m in _BLOCK.finditer(data):
            pc = int(m.group(1), 16)
            n = 1 + m.group(2).count(b"\n")
            if self.sizes.setdefault(pc, n) != n:
                raise McuError(f"the block at {pc:#x} was translated with {self.sizes[pc]} and {n} instructions")
            new = True
        if new:
            self._keys = np.array(sorted(self.sizes), dtype=np.int64)
            self._vals = np.array([self.sizes[k] for k in self._keys.tolist()], dtype=np.int64)

    def _size(self, pc: np.ndarray) -> np.ndarray:
        if self.singlestep:
            return np.ones(len(pc), np.int64)
        i = np.searchsorted(self._keys, pc)
        ok = i < len(self._keys)
        ok[ok] = self._keys[i[ok]] == pc[ok]
        if not ok.all():
            raise McuError(f"a block at {int(pc[~ok][0]):#x} ran before its translation was logged")
        return self._vals[i]

    def feed(self, chunk: bytes, final: bool = False) -> None:
        data = self.rest + chunk
        cut = len(data) if final else data.rfind(b"\nTrace ") + 1   # keep a maybe partial last line
        self.rest, data = data[cut:], data[:cut]
        if not data:
            return
        if not self.singlestep and (b"\nIN:" in data or data.startswith(b"IN:")):
            self._blocks(data)
        pcs = _TRACE.findall(data)
        if len(pcs) != data.count(b"Trace "):
            raise McuError("unexpected line in QEMU's exec log")
        pc = _hex8(pcs)
        size = self._size(pc)
        if self.current is not None:   # a call running on from the previous chunk
            pc = np.concatenate([[self.entry], pc])
            size = np.concatenate([[self.current], size])
        inside = np.zeros(len(pc), bool)
        for a, b in self.inside:
            inside |= (pc >= a) & (pc < b)
        entry = pc == self.entry
        starts = np.flatnonzero(entry)
        if len(starts) == 0:
            return
        seg = np.cumsum(entry)                 # call number (1-based) of each block, 0 = before the first
        brk = ~inside
        nbrk = np.cumsum(brk)
        # a block belongs to its call when no block outside came between the call's entry and it
        counted = (seg > 0) & (nbrk == nbrk[starts][np.maximum(seg, 1) - 1])
        sums = np.bincount(seg[counted] - 1, weights=size[counted], minlength=len(starts)).astype(np.int64)
        ended = np.bincount(seg[brk & (seg > 0)] - 1, minlength=len(starts)) > 0
        if not self.returns_logged:
            ended[:-1] = True   # only the function and its callees are logged: the next entry ends a call
        if not ended[:-1].all():
            raise McuError("a call started before the previous one returned")
        self.counts.extend(sums[:-1].tolist())
        if ended[-1]:
            self.counts.append(int(sums[-1]))
            self.current = None
        else:
            self.current = int(sums[-1])

    def finish(self) -> list[int]:
        self.feed(b"", final=True)
        if self.current is not None:
            self.counts.append(self.current)
            self.current = None
        return self.counts


def _qemu_cmd(elf: Path, inp: Path, out: Path) -> list[str]:
    return ["qemu-system-arm", "-M", "mps2-an386", "-cpu", "cortex-m4", "-nographic", "-monitor", "none",
            "-serial", "none", "-semihosting-config",
            f"enable=on,target=native,arg=harness,arg={inp},arg={out}", "-kernel", str(elf)]


def selftest_elf(elf: Path) -> Path:
    """The C tests' image built beside the encoders' harness ``elf`` (``make -C c/mcu`` builds it)."""
    return Path(elf).parent / "selftest.elf"


def run_selftest(elf: Path, timeout: float = 300.0) -> str:
    """Run ``c/tests/mkpla_selftest.c`` on the emulated Cortex-M4; its report (raises on a failure)."""
    cmd = ["qemu-system-arm", "-M", "mps2-an386", "-cpu", "cortex-m4", "-nographic", "-monitor", "none",
           "-serial", "none", "-semihosting-config", "enable=on,target=native,arg=selftest",
           "-kernel", str(selftest_elf(elf))]
    res = subprocess.run(cmd, check=False, capture_output=True, text=True, timeout=timeout)
    report = res.stdout + res.stderr
    if res.returncode != 0 or " 0 failed" not in report:
        raise McuError(f"the C tests failed on the M4 ({res.returncode}): {report.strip()[-3000:]}")
    return report


def run(elf: Path, signals: list[Signal], jobs: list[Job], workdir: Path, *, count: str | None = None,
        image: Image | None = None, singlestep: bool = False, timeout: float = 600.0):
    """Run the jobs on the emulated Cortex-M4.

    Returns ``(sizes, results, counts)``: state sizes, one :class:`Result` per job and, with
    ``count`` (a method name), the instructions of every call of its push function in push order
    (else ``None``).
    """
    for ch in str(workdir):
        if ch in " ,":
            raise McuError(f"{workdir}: QEMU's semihosting arguments cannot hold spaces or commas")
    workdir.mkdir(parents=True, exist_ok=True)
    inp, out = workdir / "jobs.bin", workdir / "points.bin"
    write_input(inp, signals, jobs)
    if out.exists():
        out.unlink()
    cmd = _qemu_cmd(elf, inp, out)
    counts = None
    if count is None:
        res = subprocess.run(cmd, check=False, capture_output=True, text=True, timeout=timeout)
        if res.returncode != 0:
            raise McuError(f"QEMU/harness failed ({res.returncode}): {(res.stderr + res.stdout).strip()[-2000:]}")
    else:
        image = image or Image.load(elf)
        counts = _traced(cmd, image, f"mkpla_{count}_push", singlestep, timeout)
    sizes, results = read_output(out, jobs, signals)
    if counts is not None:
        pushes = sum(len(signals[j.signal].t) for j in jobs)
        if len(counts) != pushes:
            raise McuError(f"counted {len(counts)} calls of mkpla_{count}_push for {pushes} pushes")
    return sizes, results, counts


def _traced(cmd: list[str], image: Image, push: str | tuple[str, ...], singlestep: bool, timeout: float):
    """Instructions of every call of ``push`` (a function name), from one traced QEMU run.

    ``push`` a tuple of names: one list of counts per name, all from the same run."""
    names = (push,) if isinstance(push, str) else tuple(push)
    insides = [[image.range(f) for f in sorted(image.closure([p]))] for p in names]
    closure = image.closure([names[0]])
    if len(names) == 1 and all(image.callers(f) <= closure for f in closure - {names[0]}):
        # nothing outside calls into the push function's callees: log only them, a call ends where
        # the next one starts (the log is shorter, QEMU faster)
        logged, returns_logged = insides[0], False
    else:
        # log the whole library and the push functions' callers too: the return into the caller
        # (mkpla_encoder_push, the packet harness's main) ends a call
        logged = set().union(*map(set, insides)) | {image.range(f) for f in image.library}
        logged |= {image.range(c) for p in names for c in image.callers(p)}
        logged, returns_logged = sorted(logged), True
    dfilter = ",".join(f"{a:#x}+{b - a:#x}" for a, b in logged)
    flags = "exec,nochain" if singlestep else "in_asm,exec,nochain"
    r, w = os.pipe()
    try:
        import fcntl

        fcntl.fcntl(w, fcntl.F_SETPIPE_SZ, 1 << 20)   # Linux: a larger pipe lets QEMU run ahead
    except (ImportError, AttributeError, OSError):
        pass
    full = cmd + (["-singlestep"] if singlestep else []) + ["-d", flags, "-dfilter", dfilter, "-D", f"/dev/fd/{w}"]
    proc = subprocess.Popen(full, stdout=subprocess.PIPE, stderr=subprocess.PIPE, pass_fds=(w,))
    os.close(w)
    counters = [
        CallCounter(image.range(p)[0], ins, singlestep, returns_logged) for p, ins in zip(names, insides, strict=False)
    ]
    chunks: queue.Queue = queue.Queue(maxsize=64)

    def reader() -> None:   # reads while the main thread parses, so QEMU never waits for the parser
        with os.fdopen(r, "rb", buffering=0) as log:
            buf, size = [], 0
            while True:
                chunk = log.read(1 << 20)
                if chunk:
                    buf.append(chunk)
                    size += len(chunk)
                if size >= 1 << 22 or (not chunk and buf):
                    chunks.put(b"".join(buf))
                    buf, size = [], 0
                if not chunk:
                    chunks.put(None)
                    return

    thread = threading.Thread(target=reader, daemon=True)
    thread.start()
    timer = threading.Timer(timeout, proc.kill)
    timer.start()
    try:
        while (chunk := chunks.get()) is not None:
            for counter in counters:
                counter.feed(chunk)
        out, err = proc.communicate()
    finally:
        timer.cancel()
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        thread.join()
    if proc.returncode != 0:
        msg = (err + out).decode(errors="replace")[-2000:]
        raise McuError(f"traced QEMU/harness failed ({proc.returncode}): {msg}")
    counts = [c.finish() for c in counters]
    return counts[0] if isinstance(push, str) else counts


# --------------------------------------------------------------------------------------------------
# the host reference and the comparison
# --------------------------------------------------------------------------------------------------


def host_points(sig: Signal, job: Job):
    """The host float32 build's points for the job (:func:`mocapkit.pla.native.encode`)."""
    from mocapkit.pla import native

    return native.encode(sig.t_source, sig.q_source, job.method, job.threshold, job.maxlen, True, precision="float32")


def differences(signals: list[Signal], jobs: list[Job], results: list[Result]) -> list[str]:
    """Jobs whose QEMU points differ from the host float32 build's (index, time or value bits)."""
    bad = []
    for j, r in zip(jobs, results, strict=False):
        h = host_points(signals[j.signal], j)
        what = None
        if len(h.indices) != len(r.index) or not np.array_equal(h.indices, r.index.astype(np.int64)):
            what = f"indices differ ({len(r.index)} points on the M4, {len(h.indices)} on the host)"
        elif not np.array_equal(h.times.astype(np.uint32), r.t.astype(np.uint32)):
            what = "point ticks differ"
        elif not np.array_equal(h.values.astype(np.float32).view(np.uint32), r.v.view(np.uint32)):
            what = "point values differ"
        if what:
            bad.append(f"{signals[j.signal].name} {j.method} {j.label or j.threshold}: {what}")
    return bad


# --------------------------------------------------------------------------------------------------
# signals
# --------------------------------------------------------------------------------------------------


def quaternion_signals(paths) -> list[Signal]:
    """Every quaternion signal of the files (``mocapkit.io.load_signals``); files without one are passed over."""
    from mocapkit.errors import MocapFormatError
    from mocapkit.io import load_signals

    out = []
    for p in paths:
        try:
            sigs = load_signals(p)
        except MocapFormatError:
            continue   # e.g. x-io Inertial.csv: no orientation columns
        for name, s in sigs.items():
            if s.kind == "quaternion" and len(s) >= 2:
                out.append(as_sensor(f"{Path(p).parent.name}/{Path(p).name}:{name}", s.times, s.values))
    return out


def shared_signals(data: Path = DATA) -> list[Signal]:
    """The quaternion recordings under ``data/imu``."""
    return quaternion_signals(sorted(p for p in (Path(data) / "imu").rglob("*") if p.is_file() and p.suffix != ".md"))


def still_signal(n: int) -> Signal:
    """A sensor lying still at 100 Hz: one constant (non-trivial) unit quaternion."""
    q = np.array([0.9, 0.3, -0.2, 0.2])
    q /= np.linalg.norm(q)
    return as_sensor("synthetic/still", np.arange(n) * 0.01, np.tile(q, (n, 1)))


def turning_signal(n: int, deg_per_sample: float = TURN_DEG) -> Signal:
    """A sensor turning at a constant rate about a fixed axis (100 Hz): every sample on the SLERP arc."""
    a = np.radians(deg_per_sample) * np.arange(n)
    axis = np.array([0.48, 0.6, 0.64])
    q = np.column_stack([np.cos(a / 2), np.outer(np.sin(a / 2), axis)])
    return as_sensor("synthetic/turning", np.arange(n) * 0.01, q)


def shaking_signal(n: int, seed: int = 13) -> Signal:
    """A sensor shaken at random (100 Hz): a new segment at almost every sample for small thresholds."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    return as_sensor("synthetic/shaking", np.arange(n) * 0.01, q)


def last_axis_signal(n: int, seed: int = 17) -> Signal:
    """Only the last component shaken (100 Hz; the samples not normalised, as the SSR and Swing encoders
    take them): the Swing Filter's test passes three dimensions and fails at the fourth, its longest path."""
    rng = np.random.default_rng(seed)
    q = np.tile([0.9, 0.2, -0.2, 0.0], (n, 1))
    q[:, 3] = rng.uniform(-0.5, 0.5, n)
    return as_sensor("synthetic/last-axis", np.arange(n) * 0.01, q)


# --------------------------------------------------------------------------------------------------
# the radio packetiser (c/mkpla/mkp.c) on the M4: the second harness, c/mcu/mkp_main.c
# --------------------------------------------------------------------------------------------------

MKP = "mkp (anglesw + packets)"
MKP_MAGIC_IN = 0x4A504B4D
MKP_MAGIC_OUT = 0x4F504B4D
#: packet size of the equality runs and the counts (the CLI's default, a BLE 4 ATT payload)
MKP_PACKET_BYTES = 20
#: the library's objects in the packet harness
MKP_OBJECTS = ("mkp.o", "mkpla.o")


def mkp_elf(elf: Path) -> Path:
    """The packet harness built beside the encoders' harness ``elf`` (``make -C c/mcu`` builds both)."""
    return Path(elf).parent / "mkp_harness.elf"


@dataclass(frozen=True)
class MkpJob:
    """One signal through the packetiser: bound in degrees, ``bits`` per component (None: the CLI's default)."""

    signal: int
    max_angle_deg: float
    bits: int | None = None
    packet_bytes: int = MKP_PACKET_BYTES
    maxlen: int = DEFAULT_MAXLEN["anglesw"]
    sensor: int = 0

    @property
    def b(self) -> int:
        """The bits per component: the job's, else the one ``mocapkit compress ... .mkp`` chooses."""
        from mocapkit.pla.packets import default_bits

        return default_bits(self.max_angle_deg) if self.bits is None else int(self.bits)

    @property
    def label(self) -> str:
        return f"{self.max_angle_deg:g} deg, {self.b} bits, {self.packet_bytes} B"


@dataclass
class MkpResult:
    """What the packet harness wrote for a job."""

    packets: list[bytes]
    sent_at: np.ndarray  # the sample whose push sent each packet (n: the flush)
    seglen: np.ndarray   # uint32: anglesw's segment length before each push


def mkp_jobs(n_signals: int) -> list[MkpJob]:
    """Every signal at every bound of :data:`ANGLES_DEG`, the CLI's default bits, 20-byte packets, L = 1000."""
    return [MkpJob(i, deg) for i in range(n_signals) for deg in ANGLES_DEG]


def write_mkp_input(path: Path, signals: list[Signal], jobs: list[MkpJob]) -> None:
    """The packet harness's input file (format in ``c/mcu/mkp_main.c``)."""
    if len(signals) > MAX_SIGNALS:
        raise McuError(f"at most {MAX_SIGNALS} signals per run, got {len(signals)}")
    parts = [struct.pack("<4I", MKP_MAGIC_IN, MKP_VERSION, len(signals), len(jobs))]
    for s in signals:
        if len(s.t) > MAX_SAMPLES:
            raise McuError(f"{s.name}: {len(s.t)} samples, the harness takes {MAX_SAMPLES}")
        parts += [struct.pack("<I", len(s.t)), s.q.astype("<f4").tobytes()]
    for j in jobs:
        if j.maxlen > MAX_SEGMENT:
            raise McuError(f"maximum segment length {j.maxlen} above the harness's {MAX_SEGMENT}")
        # the radians as the host binding hands them to the float32 build (a double rounded to float)
        parts.append(struct.pack("<5If", j.signal, j.maxlen, j.b, j.packet_bytes, j.sensor,
                                 np.float32(math.radians(j.max_angle_deg))))
    data = b"".join(parts)
    if len(data) > MAX_INPUT:
        raise McuError(f"input of {len(data)} bytes, the harness takes {MAX_INPUT}")
    path.write_bytes(data)


def read_mkp_output(path: Path, jobs: list[MkpJob], signals: list[Signal]) -> tuple[dict[str, int], list[MkpResult]]:
    """Parse the packet harness's output: ``sizeof`` of the states and one :class:`MkpResult` per job."""
    raw = Path(path).read_bytes()
    w = np.frombuffer(raw, dtype="<u4")
    if len(w) < 5 or w[0] != MKP_MAGIC_OUT or w[1] != MKP_VERSION or w[2] != len(jobs):
        raise McuError(f"{path}: not a packet harness output for {len(jobs)} jobs")
    sizes = {"mkp_packetiser": int(w[3]), "anglesw": int(w[4])}
    pos = 5
    out = []
    for j in jobs:
        npk, nb = int(w[pos]), int(w[pos + 1])
        sent = w[pos + 2: pos + 2 + npk].astype(np.int64)
        lens = w[pos + 2 + npk: pos + 2 + 2 * npk].astype(np.int64)
        pos += 2 + 2 * npk
        if int(lens.sum()) != nb:
            raise McuError(f"{path}: job {j}: packet lengths do not add up to {nb} bytes")
        body = raw[4 * pos: 4 * pos + nb]
        pos += (nb + 3) // 4
        edges = np.concatenate([[0], np.cumsum(lens)])
        packets = [body[a:b] for a, b in zip(edges[:-1].tolist(), edges[1:].tolist(), strict=True)]
        n = int(w[pos])
        if n != len(signals[j.signal].t):
            raise McuError(f"{path}: job {j} reports {n} samples")
        seglen = w[pos + 1: pos + 1 + n].copy()
        pos += 1 + n
        out.append(MkpResult(packets, sent, seglen))
    if pos != len(w):
        raise McuError(f"{path}: {len(w) - pos} words after the last job")
    return sizes, out


def run_mkp(elf: Path, signals: list[Signal], jobs: list[MkpJob], workdir: Path, *,
            count: tuple[str, ...] = (), image: Image | None = None, singlestep: bool = False,
            timeout: float = 600.0):
    """Run packet jobs on the emulated Cortex-M4 (``elf``: the packet harness, :func:`mkp_elf`).

    Returns ``(sizes, results, counts)``: ``counts`` holds, for each function name of ``count``
    (``"mkp_push"``, ``"mkpla_anglesw_push"``), the instructions of its every call in push order,
    all from one traced run.
    """
    for ch in str(workdir):
        if ch in " ,":
            raise McuError(f"{workdir}: QEMU's semihosting arguments cannot hold spaces or commas")
    workdir.mkdir(parents=True, exist_ok=True)
    inp, out = workdir / "mkp_jobs.bin", workdir / "packets.bin"
    write_mkp_input(inp, signals, jobs)
    if out.exists():
        out.unlink()
    cmd = _qemu_cmd(elf, inp, out)
    counts: list[list[int]] = []
    if not count:
        res = subprocess.run(cmd, check=False, capture_output=True, text=True, timeout=timeout)
        if res.returncode != 0:
            raise McuError(
                f"QEMU/packet harness failed ({res.returncode}): {(res.stderr + res.stdout).strip()[-2000:]}"
            )
    else:
        image = image or Image.load(elf, MKP_OBJECTS)
        counts = _traced(cmd, image, tuple(count), singlestep, timeout)
    sizes, results = read_mkp_output(out, jobs, signals)
    pushes = sum(len(signals[j.signal].t) for j in jobs)
    for name, c in zip(count, counts, strict=False):
        if len(c) != pushes:
            raise McuError(f"counted {len(c)} calls of {name} for {pushes} pushes")
    return sizes, results, counts


def host_packets(sig: Signal, job: MkpJob):
    """The host float32 build's packets (:func:`mocapkit.pla.packets.packetise`, as ``mocapkit compress``)."""
    from mocapkit.pla.packets import packetise

    return packetise(sig.q_source, job.max_angle_deg, bits=job.b, packet_bytes=job.packet_bytes,
                     max_segment_length=job.maxlen, sensor=job.sensor, precision="float32")


def mkp_differences(signals: list[Signal], jobs: list[MkpJob], results: list[MkpResult]) -> list[str]:
    """Jobs whose QEMU packets differ from the host float32 build's (bytes, or the sample that sent them)."""
    bad = []
    for j, r in zip(jobs, results, strict=False):
        h = host_packets(signals[j.signal], j)
        what = None
        if len(h.packets) != len(r.packets):
            what = f"{len(r.packets)} packets on the M4, {len(h.packets)} on the host"
        elif h.packets != r.packets:
            k = next(i for i, (a, b) in enumerate(zip(h.packets, r.packets, strict=True)) if a != b)
            what = f"packet {k} differs"
        elif not np.array_equal(h.sent_at, r.sent_at):
            what = "packets sent at other samples"
        if what:
            bad.append(f"{signals[j.signal].name} mkp {j.label}: {what}")
    return bad


def measure_mkp(elf: Path, workdir: Path, signals: list[Signal], synth: list[Signal], *,
                line_budget: int = 3_000_000, fit_length: int = 300, log=print) -> dict:
    """The packetiser's row: packets equality on ``signals``, counts of ``mkp_push`` (callees included),
    code size, RAM. ``synth``: still, turning (:data:`TURN_DEG`), shaking signals as in :func:`measure`."""
    elf = mkp_elf(elf)
    image = Image.load(elf, MKP_OBJECTS)
    entry: dict = {"method": MKP}
    jobs = mkp_jobs(len(signals))
    sizes = None
    data_counts = np.empty(0, np.int64)
    counted = ("mkp_push", "mkpla_anglesw_push")
    if signals:
        sizes, results, _ = run_mkp(elf, signals, jobs, workdir / "mkp-equality")
        bad = mkp_differences(signals, jobs, results)
        entry["equality_jobs"] = len(jobs)
        entry["equality_packets"] = int(sum(len(r.packets) for r in results))
        entry["equality_mismatches"] = bad
        log(f"packets: {len(jobs) - len(bad)}/{len(jobs)} jobs byte for byte equal to the host float32 build "
            f"({entry['equality_packets']} packets)")
        if bad:
            raise McuError("packets differ from the host float32 build: " + "; ".join(bad[:10]))
        # cheapest first while the log budget lasts (~15 blocks per push, ~40 per buffered sample)
        cost = sorted((15 * len(r.seglen) + 40 * int(r.seglen.sum()), k) for k, r in enumerate(results))
        chosen, spent = [], 0
        for c, k in cost:
            if spent + c > line_budget:
                break
            spent += c
            chosen.append(k)
        chosen.sort()
        if chosen:
            used = sorted({jobs[k].signal for k in chosen})
            remap = {s: i for i, s in enumerate(used)}
            tjobs = [MkpJob(remap[jobs[k].signal], jobs[k].max_angle_deg) for k in chosen]
            sizes, _, (c_mkp, c_asw) = run_mkp(elf, [signals[s] for s in used], tjobs,
                                                workdir / "trace-mkp-data", count=counted, image=image)
            data_counts = np.asarray(c_mkp, np.int64)
            entry["data_jobs_traced"] = len(tjobs)
            entry["data_jobs_total"] = len(jobs)
            entry["data_samples_traced"] = len(data_counts)
            over_data = data_counts - np.asarray(c_asw, np.int64)
            log(f"  mkp: {len(data_counts)} calls traced, {int(data_counts.mean())} mean, {int(data_counts.max())} max")
    else:
        over_data = np.empty(0, np.int64)
    # synthetic: the steady turn for the fit in n, then the shaken sensor (a point and a packet at
    # almost every sample) at the smallest and a middle bound
    sjobs = [MkpJob(1, 2.0, maxlen=fit_length), MkpJob(2, 0.5), MkpJob(2, 2.0), MkpJob(0, 2.0, maxlen=20)]
    sizes, sres, (s_mkp, s_asw) = run_mkp(elf, synth, sjobs, workdir / "trace-mkp-synth", count=counted, image=image)
    bad = mkp_differences(synth, sjobs, sres)
    if bad:
        raise McuError("traced run: packets differ from the host float32 build: " + "; ".join(bad[:5]))
    s_mkp, s_asw = np.asarray(s_mkp, np.int64), np.asarray(s_asw, np.int64)
    log(f"  mkp (synthetic): {len(s_mkp)} calls traced, {int(s_mkp.max())} max")
    all_counts = np.concatenate([data_counts, s_mkp])
    over = np.concatenate([over_data, s_mkp - s_asw])
    entry["instructions_per_sample_mean"] = round(float(data_counts.mean()), 1) if len(data_counts) else None
    entry["instructions_per_sample_min"] = int(all_counts.min())
    entry["calls_traced"] = len(all_counts)
    # what the packetiser adds to anglesw's push (quantise, dequantise, the bits, a packet's CRC)
    entry["packetiser_over_anglesw"] = {"mean": round(float(over.mean()), 1), "max": int(over.max()),
                                        "min": int(over.min())}
    n0 = len(synth[1].t)
    n_fit, c_fit = sres[0].seglen.astype(np.int64), s_mkp[:n0]
    L = sjobs[0].maxlen
    arc = (n_fit + 1) * TURN_DEG
    sel = (n_fit >= 1) & (n_fit < L) & (arc > 95)
    a, b, res = fit_linear(n_fit[sel], c_fit[sel])
    entry["fit"] = {"a": round(a, 2), "b": round(b, 3), "max_abs_residual": round(res, 2),
                    "n_range": [int(n_fit[sel].min()), int(n_fit[sel].max())], "signal": synth[1].name,
                    "arc_deg": "> 95", "note": "pushes that close no packet"}
    entry["per_call_by_n"] = {str(k): int(c_fit[(n_fit == k)][0]) for k in (1, 10, 100, 200, 999)
                              if np.any(n_fit == k)}
    # the worst push at L: anglesw's push at n = L - 1 (its own fit, same run) plus the most the
    # packetiser added to any push seen (a packet closed: its CRC)
    a2, b2, _ = fit_linear(n_fit[sel], s_asw[:n0][sel])
    worst = round(a2 + b2 * (RAM_L - 1)) + int(over.max())
    entry["worst_case_at_L"] = {"L": RAM_L, "n": RAM_L - 1, "instructions": worst, "measured": bool(L >= RAM_L),
                                "note": "anglesw's push at n = L - 1 (fit) + the packetiser's largest addition seen"}
    entry["instructions_per_sample_max"] = max(int(all_counts.max()), worst)
    fs = image.closure(f"mkp_{op}" for op in ("init", "push", "flush"))
    own, libc = image.text_bytes(MKP, fs)
    mkp_own = Image.load(elf, ("mkp.o",)).library
    entry["text_bytes"] = own
    entry["text_bytes_mkp_only"] = sum(image.functions[f][1] for f in fs & mkp_own)
    entry["libc_called"] = libc
    entry["functions"] = sorted(f for f in fs if f in image.library)
    entry["ram_bytes"] = sizes["mkp_packetiser"] + 4 * 5 * RAM_L
    entry["ram_note"] = (f"state {sizes['mkp_packetiser']} B (anglesw's {sizes['anglesw']} B and the pending packet's "
                         f"MKP_MAX_PACKET = 255 B inside) + buffer 20 B x L, L = {RAM_L}; "
                         f"the caller's out buffer ({MKP_PACKET_BYTES} B) besides")
    entry["packet_bytes"] = MKP_PACKET_BYTES
    entry["bits"] = {f"{d:g}": MkpJob(0, d).b for d in ANGLES_DEG}
    entry["paper_ic_min_max"] = None
    return entry


# --------------------------------------------------------------------------------------------------
# measurement
# --------------------------------------------------------------------------------------------------


def fit_linear(n: np.ndarray, c: np.ndarray) -> tuple[float, float, float]:
    """Least-squares ``c = a + b n``: ``(a, b, max |residual|)``."""
    A = np.column_stack([np.ones(len(n)), n.astype(float)])
    (a, b), *_ = np.linalg.lstsq(A, c.astype(float), rcond=None)
    return float(a), float(b), float(np.max(np.abs(c - (a + b * n))))


def _count_jobs(elf, image, method, signals, jobs, workdir, log):
    sizes, results, counts = run(elf, signals, jobs, workdir, count=method, image=image)
    seglen = np.concatenate([r.seglen for r in results]).astype(np.int64)
    counts = np.asarray(counts, dtype=np.int64)
    bad = differences(signals, jobs, results)
    if bad:
        raise McuError("traced run: points differ from the host float32 build: " + "; ".join(bad[:5]))
    log(f"  {method}: {len(counts)} calls traced, {int(counts.mean()) if len(counts) else 0} mean, "
        f"{int(counts.max()) if len(counts) else 0} max")
    return sizes, seglen, counts


def measure(elf: Path, workdir: Path, data: Path | None = DATA, *, line_budget: int = 3_000_000,
            sw_fit_length: int = 1000, anglesw_fit_length: int = 300, log=print) -> dict:
    """Points equality and every count; the rows of ``docs/mcu.json`` and the facts behind them.

    ``line_budget``: the shared-recording jobs of a method are traced cheapest first while their
    estimated log (blocks executed) stays within it: all of them for the O(1) methods; SW and
    anglesw jobs with very long segments are left to the synthetic fits.
    ``sw_fit_length`` / ``anglesw_fit_length``: the longest segment of the synthetic fits.
    """
    image = Image.load(elf)
    signals = shared_signals(data) if data is not None else []
    eq_jobs = default_jobs(len(signals))
    facts: dict = {"signals": [s.name for s in signals], "samples": int(sum(len(s.t) for s in signals))}
    sizes = None
    seglens: list[np.ndarray] = []
    if signals:
        sizes, results, _ = run(elf, signals, eq_jobs, workdir / "equality")
        bad = differences(signals, eq_jobs, results)
        facts["equality_jobs"] = len(eq_jobs)
        facts["equality_mismatches"] = bad
        log(f"points: {len(eq_jobs) - len(bad)}/{len(eq_jobs)} jobs equal to the host float32 build")
        if bad:
            raise McuError("points differ from the host float32 build: " + "; ".join(bad[:10]))
        seglens = [r.seglen for r in results]

    still = still_signal(max(sw_fit_length, anglesw_fit_length) + 1)
    turning = turning_signal(anglesw_fit_length + 1, TURN_DEG)
    shaking = shaking_signal(400)
    synth = [still, turning, shaking, last_axis_signal(400)]
    rows = []
    for method in METHODS:
        entry: dict = {"method": method}
        # shared recordings, cheapest jobs first while the budget lasts; estimated log lines (blocks
        # run) of a job: ~10 per push and, per buffered sample, ~3 (SW) or ~40 (anglesw)
        per_n = 40 if method == "anglesw" else 3 if method == "sw" else 0
        cost = sorted(
            (10 * len(sl) + per_n * int(sl.sum()), k)
            for k, (j, sl) in enumerate(zip(eq_jobs, seglens, strict=False))
            if j.method == method
        )
        data_jobs, spent = [], 0
        for c, k in cost:
            if spent + c > line_budget:
                break
            spent += c
            data_jobs.append(eq_jobs[k])
        data_jobs.sort(key=eq_jobs.index)
        data_counts = np.empty(0, np.int64)
        if data_jobs:
            used = sorted({j.signal for j in data_jobs})
            remap = {s: k for k, s in enumerate(used)}
            jobs = [Job(remap[j.signal], j.method, j.threshold, j.maxlen, j.label) for j in data_jobs]
            sizes, _, data_counts = _count_jobs(elf, image, method, [signals[s] for s in used], jobs,
                                                workdir / f"trace-{method}-data", log)
            entry["data_jobs_traced"] = len(jobs)
            entry["data_jobs_total"] = sum(j.method == method for j in eq_jobs)
            entry["data_samples_traced"] = len(data_counts)
        # synthetic: one long segment first (SW: still sensor, anglesw: steady turn, for the fits in
        # n), then still/turning sensors, a bounded segment length and a shaken sensor (a point at
        # almost every sample: the emitting path)
        th_small = math.radians(2.0) if method == "anglesw" else 1e-3
        if method == "sw":
            sjobs = [Job(0, method, 1e-3, sw_fit_length, "still, fit")]
        elif method == "anglesw":
            sjobs = [Job(1, method, math.radians(2.0), anglesw_fit_length, "turning, fit")]
        else:
            sjobs = [Job(0, method, 1e-3, 0, "still"), Job(0, method, 1e-3, 50, "still, maxlen 50"),
                     Job(1, method, 1e-3, 0, "turning")]
        sjobs += [Job(2, method, 0.0, DEFAULT_MAXLEN[method], "shaking, threshold 0"),
                  Job(2, method, th_small, DEFAULT_MAXLEN[method], "shaking")]
        if method not in ("sw", "anglesw"):   # a bounded segment length adds its test to every path
            sjobs += [
                Job(2, method, 0.0, 50, "shaking, threshold 0, maxlen 50"),
                Job(2, method, th_small, 50, "shaking, maxlen 50"),
                Job(1, method, 1e-3, 50, "turning, maxlen 50"),
                Job(3, method, th_small, 0, "last axis shaken"),
                Job(3, method, th_small, 50, "last axis shaken, maxlen 50"),
            ]
        sizes, s_seglen, s_counts = _count_jobs(elf, image, method, synth, sjobs,
                                                workdir / f"trace-{method}-synth", log)
        all_counts = np.concatenate([data_counts, s_counts])
        entry["instructions_per_sample_mean"] = round(float(data_counts.mean()), 1) if len(data_counts) else None
        entry["instructions_per_sample_max"] = int(all_counts.max())
        entry["instructions_per_sample_min"] = int(all_counts.min())
        entry["calls_traced"] = len(all_counts)
        if method in ("sw", "anglesw"):
            L = sjobs[0].maxlen
            n0 = len(synth[sjobs[0].signal].t)
            n_fit, c_fit = s_seglen[:n0], s_counts[:n0]
            # the pushes accepted into the one long segment: n = 1 .. L - 1 samples before the push
            sel = (n_fit >= 1) & (n_fit < L)
            if method == "anglesw":
                # each SLERP check evaluates atan2 of the segment's arc, dearer beyond a 90 degree turn
                # (mk_atan2's second range): the worst case is the wide-arc fit, the small-arc one typical
                arc = (n_fit + 1) * TURN_DEG
                small = sel & (arc < 85)
                a0, b0, r0 = fit_linear(n_fit[small], c_fit[small])
                entry["fit_small_arc"] = {"a": round(a0, 2), "b": round(b0, 3), "max_abs_residual": round(r0, 2),
                                          "n_range": [int(n_fit[small].min()), int(n_fit[small].max())],
                                          "arc_deg": "< 85"}
                sel &= arc > 95
            a, b, res = fit_linear(n_fit[sel], c_fit[sel])
            entry["fit"] = {"a": round(a, 2), "b": round(b, 3), "max_abs_residual": round(res, 2),
                            "n_range": [int(n_fit[sel].min()), int(n_fit[sel].max())],
                            "signal": synth[sjobs[0].signal].name}
            if method == "anglesw":
                entry["fit"]["arc_deg"] = "> 95"
            entry["per_call_by_n"] = {str(k): int(c_fit[(n_fit == k)][0]) for k in (1, 10, 100, 200, 999)
                                      if np.any(n_fit == k)}
            entry["worst_case_at_L"] = {"L": RAM_L, "n": RAM_L - 1, "instructions": round(a + b * (RAM_L - 1)),
                                        "measured": bool(L >= RAM_L)}
            entry["instructions_per_sample_max"] = max(entry["instructions_per_sample_max"],
                                                       entry["worst_case_at_L"]["instructions"])
        rows.append(entry)
    # code size and RAM
    for entry in rows:
        m = entry["method"]
        own, libc = image.text_bytes(m)
        entry["text_bytes"] = own
        entry["libc_called"] = libc
        entry["functions"] = sorted(f for f in image.encoder_functions(m) if f in image.library)
        state = sizes[m]
        if m in ("sw", "anglesw"):
            entry["ram_bytes"] = state + 4 * 5 * RAM_L
            entry["ram_note"] = f"state {state} B + buffer 20 B x L, L = {RAM_L}"
        else:
            entry["ram_bytes"] = state
            entry["ram_note"] = f"state {state} B"
        entry["paper_ic_min_max"] = list(PAPER[m]) if m in PAPER else None
    fast_max = next(e for e in rows if e["method"] == "fastsw")["instructions_per_sample_max"]
    for e in rows:
        if e["method"] == "sw":
            a, b = e["fit"]["a"], e["fit"]["b"]
            e["ratio_to_fastsw_max"] = {str(n): round((a + b * n) / fast_max, 1) for n in (10, 100, 1000)}
            e["paper_ratio"] = {str(n): round((161 + 35 * n) / 210, 1) for n in (10, 100, 1000)}
    if mkp_elf(elf).is_file():
        rows.append(measure_mkp(elf, workdir, signals, synth, line_budget=line_budget,
                                fit_length=anglesw_fit_length, log=log))
    api = [f for f in image.library if f.startswith("mkpla_encoder_")]
    facts["encoder_api_text_bytes"] = sum(image.functions[f][1] for f in api)
    facts["state_sizes"] = sizes
    return {"rows": rows, "facts": facts}


NAMES = {"fastsw": "fastSW", "sw": "SW", "cplr": "CPLR", "swing": "Swing Filter (SF)", "anglesw": "anglesw"}


def _per_call(e: dict) -> str:
    if "fit" not in e:
        return "O(1)"
    return f"{e['fit']['a']:.0f} + {e['fit']['b']:.0f}·n"


def table(rows: list[dict], compare: dict[str, dict] | None = None) -> str:
    """The rows as a Markdown table beside the paper's Table 2 (``compare``: rows of another -O level)."""
    other = next(iter(compare.values()))["opt"] if compare else None
    head = "| encoder | instr./sample mean (data) | min | max | per call, n buffered |"
    rule = "|---|---:|---:|---:|---|"
    if other:
        head += f" max at {other} (synthetic signals) |"
        rule += "---:|"
    out = [head + " paper min | paper max | text bytes | RAM bytes |", rule + "---:|---:|---:|---:|"]
    for e in rows:
        pmin, pmax = e["paper_ic_min_max"] or ("–", "–")
        mean = "–" if e["instructions_per_sample_mean"] is None else f"{e['instructions_per_sample_mean']:.0f}"
        mx = str(e["instructions_per_sample_max"])
        if "worst_case_at_L" in e:
            mx += f" (n = {e['worst_case_at_L']['n']})"
        line = (f"| {NAMES.get(e['method'], e['method'])} | {mean} | {e['instructions_per_sample_min']} | {mx} "
                f"| {_per_call(e)} |")
        if other:
            c = compare[e["method"]]
            line += f" {c['instructions_per_sample_max']}" + (f" ({_per_call(c)})" if "fit" in c else "") + " |"
        ram = f"{e['ram_bytes']}" + (f" (L = {RAM_L})" if e["method"] in ("sw", "anglesw", MKP) else "")
        out.append(line + f" {pmin} | {pmax} | {e['text_bytes']} | {ram} |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--opt", default="-O3", help="optimisation level of the measured build (the paper's -O3)")
    ap.add_argument("--compare-opt", default=None,
                    help="also count another level (e.g. -O2) on the synthetic signals only: its max and fits")
    ap.add_argument("--json", type=Path, help="write the rows here (docs/mcu.json)")
    ap.add_argument("--data", type=Path, default=DATA, help="the shared data folder (its imu/ recordings)")
    ap.add_argument("--build", type=Path, default=ROOT / "build" / "mcu")
    ap.add_argument("--sw-fit-length", type=int, default=1000)
    ap.add_argument("--anglesw-fit-length", type=int, default=300)
    args = ap.parse_args(argv)
    why = missing_tools()
    if why:
        print(f"mcu: {why}", file=sys.stderr)
        return 2
    data = args.data if (args.data / "imu").is_dir() else None
    if data is None:
        print(f"mcu: {args.data}/imu not found: synthetic signals only, no points check on recordings",
              file=sys.stderr)

    def log(msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    try:
        elf = build(args.build / args.opt.lstrip("-"), args.opt)
        log(run_selftest(elf).strip())
        with tempfile.TemporaryDirectory(prefix="mkpla-mcu-") as tmp:
            res = measure(elf, Path(tmp), data, sw_fit_length=args.sw_fit_length,
                          anglesw_fit_length=args.anglesw_fit_length, log=log)
            compare = None
            if args.compare_opt:
                log(f"{args.compare_opt}: synthetic signals only")
                elf2 = build(args.build / args.compare_opt.lstrip("-"), args.compare_opt)
                res2 = measure(elf2, Path(tmp) / "compare", None, sw_fit_length=args.sw_fit_length,
                               anglesw_fit_length=args.anglesw_fit_length, log=log)
                compare = {r["method"]: {"opt": args.compare_opt, "text_bytes": r["text_bytes"],
                                         "instructions_per_sample_max": r["instructions_per_sample_max"],
                                         **({"fit": r["fit"]} if "fit" in r else {})} for r in res2["rows"]}
    except McuError as exc:
        print(f"mcu: {exc}", file=sys.stderr)
        return 1
    print(table(res["rows"], compare))
    if args.json:
        from mocapkit.io.atomic import atomic_write_text

        common = {"opt": args.opt, "cflags": f"{CFLAGS} {args.opt}", **versions(),
                  "equality_jobs": res["facts"].get("equality_jobs", 0), "recordings": res["facts"]["signals"]}
        doc = []
        for r in res["rows"]:
            row = dict(r, **common)
            if compare:
                row["compare"] = compare[r["method"]]
            doc.append(row)
        atomic_write_text(args.json, json.dumps(doc, indent=1, allow_nan=False) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
