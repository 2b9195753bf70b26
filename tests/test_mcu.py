"""The C encoders on a Cortex-M4 under QEMU (tools/mcu_measure.py, c/mcu): the emulated sensor gives
the host float32 build's points, and its instruction counts behave as the fastSW paper's Table 2.

Skipped with a reason where the ARM toolchain or QEMU is missing (Debian: gcc-arm-none-eabi,
libnewlib-arm-none-eabi, qemu-system-arm).
"""

from __future__ import annotations

import importlib.util
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _load_tool():
    spec = importlib.util.spec_from_file_location("mcu_measure", ROOT / "tools" / "mcu_measure.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("mcu_measure", mod)   # dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


M = _load_tool()
_MISSING = M.missing_tools()
pytestmark = pytest.mark.skipif(_MISSING is not None,
                                reason=f"Cortex-M4 tests need the ARM toolchain and QEMU: {_MISSING}")


@pytest.fixture(scope="module")
def elf(tmp_path_factory) -> Path:
    """The harness as `make mcu` measures it (-O3), built with -Werror."""
    return M.build(tmp_path_factory.mktemp("mcu-O3"), "-O3", werror=True)


@pytest.fixture(scope="module")
def image(elf):
    return M.Image.load(elf)


@pytest.fixture(scope="module")
def excerpts(tests_data) -> list:
    paths = sorted(p for d in ("imu", "xio") for p in (tests_data / d).rglob("*") if p.is_file() and p.suffix != ".md")
    sigs = M.quaternion_signals(paths)
    assert len(sigs) >= 10
    return sigs


# ---- build --------------------------------------------------------------------------------------


def test_o2_build_is_warning_free_too(tmp_path):
    elf = M.build(tmp_path, "-O2", werror=True)   # raises on any warning (and -Werror fails the build)
    assert elf.is_file()


def test_fpu_is_enabled_before_any_float_instruction(elf):
    """Reset_Handler sets CP10/CP11 in CPACR (0xE000ED88), then DSB/ISB, before any VFP instruction runs."""
    dis = subprocess.run(["arm-none-eabi-objdump", "-d", str(elf)], capture_output=True, text=True, check=True).stdout
    body = dis[dis.index("<Reset_Handler>:"):]
    body = body[: body.index("\n\n")]
    insns = [ln.split("\t")[2] if ln.count("\t") >= 2 else "" for ln in body.splitlines()[1:]]
    first_bl = next(i for i, s in enumerate(insns) if s.startswith("bl"))
    assert not any(s.startswith("v") for s in insns[:first_bl])
    order = [next(i for i, s in enumerate(insns) if s.startswith(k)) for k in ("orr", "str", "dsb", "isb")]
    assert order == sorted(order) and order[-1] < first_bl
    assert "e000ed88" in dis.lower().replace("0x", "")


# ---- points -------------------------------------------------------------------------------------


def test_points_equal_host_float32_on_test_excerpts(elf, excerpts, tmp_path):
    jobs = M.default_jobs(len(excerpts))
    _, results, _ = M.run(elf, excerpts, jobs, tmp_path)
    assert sum(len(r.index) for r in results) > len(jobs)   # points were made, not only the first
    assert M.differences(excerpts, jobs, results) == []


@pytest.mark.shared
def test_points_equal_host_float32_on_shared_recordings(elf, shared_data, tmp_path):
    sigs = M.shared_signals(shared_data)
    assert len(sigs) >= 10
    jobs = M.default_jobs(len(sigs))
    _, results, _ = M.run(elf, sigs, jobs, tmp_path)
    assert M.differences(sigs, jobs, results) == []


def test_a_changed_point_is_noticed(elf, excerpts, tmp_path):
    """The comparison can fail: one bit of one point value flipped is reported."""
    jobs = [M.Job(0, "fastsw", 1e-4, 0)]
    _, results, _ = M.run(elf, excerpts, jobs, tmp_path)
    results[0].v.view(np.uint32)[0, 1] ^= 1
    assert len(M.differences(excerpts, jobs, results)) == 1


# ---- GCC's default flags, the C tests on the target ---------------------------------------------------


@pytest.fixture(scope="module")
def default_flags_elf(tmp_path_factory) -> Path:
    """The harnesses built with GCC's defaults (gnu17, -ffp-contract=fast, math errno) plus -Werror."""
    return M.build(tmp_path_factory.mktemp("mcu-default"), "-O3", werror=True, strict="")


def test_default_flags_build_has_no_fused_multiply_add(default_flags_elf):
    """The FPv4 has vfma; GCC contracts a*b + c into it by default: the sources forbid it themselves."""
    for obj in ("mkpla.o", "mkp.o"):
        dis = subprocess.run(["arm-none-eabi-objdump", "-d", str(default_flags_elf.parent / obj)],
                             capture_output=True, text=True, check=True).stdout
        assert "vmul.f32" in dis
        assert not any(k in dis for k in ("vfma", "vfms", "vfnma", "vfnms")), obj


def test_default_flags_build_gives_the_host_float32_points(default_flags_elf, excerpts, tmp_path):
    jobs = M.default_jobs(len(excerpts))
    _, results, _ = M.run(default_flags_elf, excerpts, jobs, tmp_path / "enc")
    assert sum(len(r.index) for r in results) > len(jobs)
    assert M.differences(excerpts, jobs, results) == []
    mjobs = M.mkp_jobs(len(excerpts))
    _, mres, _ = M.run_mkp(M.mkp_elf(default_flags_elf), excerpts, mjobs, tmp_path / "mkp")
    assert M.mkp_differences(excerpts, mjobs, mres) == []


@pytest.mark.parametrize("which", ["strict", "default flags"])
def test_c_selftest_on_the_m4(elf, default_flags_elf, which):
    """c/tests/mkpla_selftest.c on the Cortex-M4 (32-bit size_t): sizes that would wrap, refused samples
    changing nothing, mkp refusing NaN/Inf, ticks deciding alike after 36 h and across the wrap."""
    report = M.run_selftest(elf if which == "strict" else default_flags_elf)
    assert " 0 failed (size_t of 32 bits)" in report
    assert int(report.split("mkpla selftest: ")[1].split()[0]) > 500


def test_points_do_not_depend_on_the_first_tick(elf, excerpts, tmp_path):
    """The same recording starting at tick 0, after 36 h of a microsecond clock (wrapped 30 times) and
    just before the counter wraps: the same point indices and values on the M4."""
    sig = max(excerpts, key=lambda s: float(np.ptp(s.q_source, axis=0).sum()) * len(s.t))   # long, moving
    jobs = [M.Job(0, m, th, M.DEFAULT_MAXLEN[m]) for m, th in
            (("fastsw", 1e-6), ("sw", 1e-6), ("cplr", 1e-6), ("swing", 1e-3), ("anglesw", math.radians(0.2)))]
    base = None
    for t0 in (0, int(36 * 3600 * 1e6), 2**32 - 50_000):
        shifted = M.Signal(sig.name, ((sig.t.astype(np.int64) + t0) % 2**32).astype(np.uint32), sig.q,
                           sig.t_source, sig.q_source)
        _, results, _ = M.run(elf, [shifted], jobs, tmp_path / str(t0))
        got = [(r.index.tolist(), r.v.tobytes(), ((r.t.astype(np.int64) - t0) % 2**32).tolist()) for r in results]
        if base is None:
            base = got
            assert all(len(g[0]) > 2 for g in got)
        assert got == base, t0


# ---- instruction counts -------------------------------------------------------------------------


def _emitted(signals, jobs, results) -> np.ndarray:
    """Per push: did it return a point (the first push, or the previous sample became a point)."""
    out = []
    for j, r in zip(jobs, results, strict=True):
        n = len(signals[j.signal].t)
        e = np.zeros(n, bool)
        e[0] = True
        nxt = r.index.astype(np.int64) + 1
        e[nxt[(nxt > 0) & (nxt < n)]] = True
        out.append(e)
    return np.concatenate(out)


def test_fastsw_worst_case_within_the_papers_210(elf, image, excerpts, tmp_path):
    synth = [M.still_signal(120), M.shaking_signal(120)]
    sigs = excerpts + synth
    k = len(excerpts)
    jobs = [j for j in M.default_jobs(len(excerpts), ["fastsw"])]
    jobs += [M.Job(k, "fastsw", 1e-3, 0), M.Job(k, "fastsw", 1e-3, 25), M.Job(k + 1, "fastsw", 0.0, 0)]
    _, results, counts = M.run(elf, sigs, jobs, tmp_path, count="fastsw", image=image)
    counts = np.asarray(counts)
    emitted = _emitted(sigs, jobs, results)
    assert len(counts) == len(emitted)
    # both paths were counted: samples taken into a segment and samples that ended one
    assert (~emitted).sum() > 100 and emitted[1:].sum() > 100
    assert counts.max() <= 210
    # O(1): the still sensor's long segment costs what a short one does
    assert counts[~emitted].max() - counts[~emitted].min() <= 4


def test_sw_count_grows_linearly_with_the_segment(elf, image, tmp_path):
    L = 150
    sigs = [M.still_signal(L + 1)]
    _, results, counts = M.run(elf, sigs, [M.Job(0, "sw", 1e-3, L)], tmp_path, count="sw", image=image)
    n = results[0].seglen.astype(np.int64)
    c = np.asarray(counts)
    sel = (n >= 1) & (n < L)          # pushes into the one growing segment
    assert sel.sum() == L - 1
    _, b, res = M.fit_linear(n[sel], c[sel])
    assert res <= 0.5                 # exactly a + b n: every buffered sample costs the same
    assert 4 * 4 <= b <= 4 * 30       # four dimensions, a handful of instructions each
    assert np.all(np.diff(c[sel]) > 0)


def test_block_counts_equal_single_step_counts(elf, image, tmp_path):
    """Counting QEMU's translated blocks gives what one-instruction-at-a-time logging gives."""
    sigs = [M.still_signal(40), M.shaking_signal(40), M.turning_signal(25)]
    cases = {"fastsw": [M.Job(0, "fastsw", 1e-3, 10), M.Job(1, "fastsw", 1e-3, 0)],
             "sw": [M.Job(0, "sw", 1e-3, 30), M.Job(1, "sw", 1e-3, 30)],
             "anglesw": [M.Job(2, "anglesw", math.radians(2), 20), M.Job(1, "anglesw", math.radians(2), 20)]}
    for method, jobs in cases.items():
        _, _, blocks = M.run(elf, sigs, jobs, tmp_path / method, count=method, image=image)
        _, _, single = M.run(elf, sigs, jobs, tmp_path / method, count=method, image=image, singlestep=True)
        assert blocks == single, method


def test_call_counter_parses_a_log_split_anywhere():
    """Hand-made log: calls of a function at 0x100 (callee 0x200), the caller at 0x50 in between."""
    def block(pc, n):
        lines = "".join(f"0x{pc + 2 * i:08x}:  bf00       nop\n" for i in range(n))
        return f"----------------\nIN: f\n{lines}\n"

    def run(pc):
        return f"Trace 0: 0x7f0000{pc:06x} [00000000/{pc:08x}/00000000/ff000000] f\n"

    log = (block(0x50, 3) + run(0x50) + block(0x100, 4) + run(0x100) + block(0x200, 5) + run(0x200)
           + block(0x108, 2) + run(0x108) + block(0x54, 1) + run(0x54) + run(0x100) + run(0x200) + run(0x108)
           + run(0x200) + run(0x108) + run(0x54) + run(0x50) + run(0x100))
    expected = [4 + 5 + 2, 4 + 5 + 2 + 5 + 2, 4]
    data = log.encode()
    for cut in [None, 7, 50, 333, len(data) // 2, len(data) - 3]:
        c = M.CallCounter(0x100, [(0x100, 0x110), (0x200, 0x220)])
        if cut is None:
            c.feed(data)
        else:
            c.feed(data[:cut])
            c.feed(data[cut:])
        assert c.finish() == expected


def test_call_counter_refuses_an_unknown_block():
    c = M.CallCounter(0x100, [(0x100, 0x110)])
    with pytest.raises(M.McuError, match="before its translation"):
        c.feed(b"Trace 0: 0x7f0000000100 [00000000/00000100/00000000/ff000000] f\n", final=True)


def test_code_size_and_ram_come_from_the_image(elf, image, tmp_path):
    sizes, _, _ = M.run(elf, [M.still_signal(3)], [M.Job(0, "fastsw", 1e-3, 0)], tmp_path)
    # the state as the target lays it out: 4 words, th/ta/tp/t2m, 4 arrays of MKPLA_MAX_DIM = 4 floats
    assert sizes["fastsw"] == 4 * 4 + 4 * 4 + 4 * 4 * 4
    # every function of mkpla.o is counted for an encoder or is the generic mkpla_encoder_* layer
    # (a helper the call graph missed would be in neither)
    counted = set().union(*(image.encoder_functions(m) for m in M.METHODS))
    rest = {f for f in image.library - counted if not f.startswith("mkpla_encoder_")}
    assert rest == set()
    for helper in ("mk_sin", "mk_atan2"):   # where not inlined, the float32 maths counts for anglesw
        assert helper not in image.functions or helper in image.encoder_functions("anglesw")
    for m in M.METHODS:
        own, _ = image.text_bytes(m)
        assert own == sum(image.functions[f][1] for f in image.encoder_functions(m) if f in image.library)


# ---- the radio packetiser (c/mkpla/mkp.c, harness c/mcu/mkp_main.c) ------------------------------


@pytest.fixture(scope="module")
def mkp_elf(elf) -> Path:
    return M.mkp_elf(elf)


@pytest.fixture(scope="module")
def mkp_image(mkp_elf):
    return M.Image.load(mkp_elf, M.MKP_OBJECTS)


def test_mkp_packets_equal_host_float32_on_test_excerpts(mkp_elf, excerpts, tmp_path):
    jobs = M.mkp_jobs(len(excerpts))   # 0.5/1/2/5 degrees, the CLI's default bits, 20-byte packets
    assert {j.b for j in jobs} == {9, 10, 11, 12}
    _, results, _ = M.run_mkp(mkp_elf, excerpts, jobs, tmp_path)
    assert sum(len(r.packets) for r in results) > 2 * len(jobs)   # more than the first and the last
    assert all(len(p) <= 20 for r in results for p in r.packets)
    assert M.mkp_differences(excerpts, jobs, results) == []


@pytest.mark.shared
def test_mkp_packets_equal_host_float32_on_shared_recordings(mkp_elf, shared_data, tmp_path):
    sigs = M.shared_signals(shared_data)
    assert len(sigs) >= 10
    jobs = M.mkp_jobs(len(sigs))
    _, results, _ = M.run_mkp(mkp_elf, sigs, jobs, tmp_path)
    assert M.mkp_differences(sigs, jobs, results) == []


def test_mkp_a_changed_packet_is_noticed(mkp_elf, excerpts, tmp_path):
    """The comparison can fail: one bit of one packet byte flipped, or a packet sent a sample late."""
    jobs = [M.MkpJob(0, 1.0)]
    _, results, _ = M.run_mkp(mkp_elf, excerpts, jobs, tmp_path)
    p = bytearray(results[0].packets[0])
    p[5] ^= 1
    flipped = M.MkpResult([bytes(p)] + results[0].packets[1:], results[0].sent_at, results[0].seglen)
    late = M.MkpResult(results[0].packets, results[0].sent_at + 1, results[0].seglen)
    assert len(M.mkp_differences(excerpts, jobs, [flipped])) == 1
    assert len(M.mkp_differences(excerpts, jobs, [late])) == 1


def test_mkp_push_count_includes_anglesw_and_the_packet_work(mkp_elf, mkp_image, excerpts, tmp_path):
    """mkp_push's count includes its callees: never below anglesw's push in the same call, and a
    push that sends a packet (its CRC) costs more above anglesw than one that sends none."""
    sigs = excerpts[:3] + [M.shaking_signal(150)]
    k = len(sigs) - 1
    jobs = [M.MkpJob(i, 2.0) for i in range(k)] + [M.MkpJob(k, 0.5), M.MkpJob(k, 5.0, bits=6)]
    _, results, (c_mkp, c_asw) = M.run_mkp(mkp_elf, sigs, jobs, tmp_path, count=("mkp_push", "mkpla_anglesw_push"),
                                           image=mkp_image)
    c_mkp, c_asw = np.asarray(c_mkp), np.asarray(c_asw)
    assert len(c_mkp) == len(c_asw) == sum(len(sigs[j.signal].t) for j in jobs)
    assert np.all(c_asw > 0)
    over = c_mkp - c_asw
    assert over.min() >= 100          # quantise + dequantise (4 floors, sqrts) at least
    sent = np.zeros(len(c_mkp), bool)
    start = 0
    for j, r in zip(jobs, results, strict=True):
        n = len(sigs[j.signal].t)
        at = r.sent_at[r.sent_at < n]
        sent[start + at] = True
        start += n
    assert sent.sum() > 20 and (~sent).sum() > 20
    # a packet closed: at least 16 bytes through the bitwise CRC, 8 steps each
    assert np.median(over[sent]) > np.median(over[~sent]) + 16 * 8


def test_mkp_block_counts_equal_single_step_counts(mkp_elf, mkp_image, tmp_path):
    sigs = [M.turning_signal(30), M.shaking_signal(30)]
    jobs = [M.MkpJob(0, 2.0, maxlen=20), M.MkpJob(1, 0.5)]
    _, _, blocks = M.run_mkp(mkp_elf, sigs, jobs, tmp_path / "b", count=("mkp_push",), image=mkp_image)
    _, _, single = M.run_mkp(mkp_elf, sigs, jobs, tmp_path / "s", count=("mkp_push",), image=mkp_image,
                             singlestep=True)
    assert blocks == single


def test_mkp_code_size_and_ram_come_from_the_image(mkp_elf, mkp_image, tmp_path):
    sizes, _, _ = M.run_mkp(mkp_elf, [M.still_signal(3)], [M.MkpJob(0, 2.0)], tmp_path)
    # the state holds the anglesw state and the pending packet's MKP_MAX_PACKET bytes
    assert sizes["mkp_packetiser"] >= sizes["anglesw"] + 255
    fs = mkp_image.closure(["mkp_init", "mkp_push", "mkp_flush"])
    assert {"mkp_push", "mkpla_anglesw_push"} <= fs
    own, libc = mkp_image.text_bytes(M.MKP, fs)
    assert own == sum(mkp_image.functions[f][1] for f in fs if f in mkp_image.library)
    assert own > mkp_image.functions["mkpla_anglesw_push"][1] + mkp_image.functions["mkp_push"][1]
