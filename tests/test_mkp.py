"""The radio packet format (c/mkpla/mkp.c encoder, mocapkit.pla.packet_layout decoder, docs/mkp.md).

- The smallest-three quantiser: C codes = a NumPy quantiser, each kept component on its nearest
  level; C dequantisation = Python's bit for bit; the bound delta(B) holds against brute force on
  random and adversarial quaternions (measured with scipy) and is nearly tight where it is worst.
- The packetiser: the decoder gets back exactly the points the C encoder logged (ticks and codes, both
  builds); the float64 points equal the Python anglesw kernel run on the dequantised samples with the
  budget max_angle - delta(B) - EPS; packets respect their size, sequence and last-packet rules.
- The end-to-end bound on every sample of every shared IMU quaternion recording at 0.5/1/2/5 degrees
  (full-rate decode at the original samples, angle by scipy), float64 and float32 builds.
- Losses: a dropped, a bit-flipped and a truncated packet are reported with the right sequence number,
  the points after them are marked and the decode leaves the gap out; the rest decodes as before.
- The reader: every container or content problem is a MocapFormatError; fuzzed files never raise
  anything else.
- The command line: compress -o OUT.mkp and decompress (points, --times-from, --rate, losses on stderr).
"""

from __future__ import annotations

import binascii
import math
import struct
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from mocapkit import cli
from mocapkit.errors import InvalidParameterError, MocapFormatError
from mocapkit.io import load_signals
from mocapkit.jobs.packet_compress import compress_packets_job
from mocapkit.jobs.packets import decode_at, decompress_packets_job
from mocapkit.jobs.readers import read_mkp
from mocapkit.pla import anglesw
from mocapkit.pla.packet_layout import (
    Header,
    Sensor,
    crc16,
    delta_bound,
    dequantise,
    half_step,
    mkp_bytes,
    parse_packet,
)
from mocapkit.pla.packets import EPS, default_bits, packetise

DATA = Path(__file__).resolve().parent / "data"
ANGLES = (0.5, 1.0, 2.0, 5.0)
BITS = tuple(range(6, 17))


def _lib(precision="float64"):
    if precision == "float64":
        from mocapkit import _mkpla64 as mod
    else:
        from mocapkit import _mkpla32 as mod
    return mod.ffi, mod.lib


def c_quantise(q: np.ndarray, bits: int, precision="float64") -> np.ndarray:
    ffi, lib = _lib(precision)
    x = ffi.new("mkpla_real[4]")
    c = ffi.new("uint16_t[4]")
    out = np.empty((len(q), 4), dtype=np.int64)
    for i, row in enumerate(q):
        for d in range(4):
            x[d] = float(row[d])
        assert lib.mkp_quantise(x, bits, c) == 0
        out[i] = list(c)
    return out


def c_dequantise(codes: np.ndarray, bits: int) -> np.ndarray:
    ffi, lib = _lib()
    c = ffi.new("uint16_t[4]")
    x = ffi.new("mkpla_real[4]")
    out = np.empty((len(codes), 4))
    for i, row in enumerate(codes):
        for d in range(4):
            c[d] = int(row[d])
        lib.mkp_dequantise(c, bits, x)
        out[i] = list(x)
    return out


def np_quantise(q: np.ndarray, bits: int) -> np.ndarray:
    """Reference: normalise, drop the first largest-magnitude component made positive, round each
    kept component to the nearest of 2^B levels spanning [-1/sqrt2, 1/sqrt2]."""
    q = np.asarray(q, dtype=np.float64)
    m = (1 << bits) - 1
    nrm = np.sqrt(q[:, 0] * q[:, 0] + q[:, 1] * q[:, 1] + q[:, 2] * q[:, 2] + q[:, 3] * q[:, 3])
    i = np.argmax(np.abs(q), axis=1)
    sg = np.where(q[np.arange(len(q)), i] < 0, -1.0, 1.0)
    out = np.empty((len(q), 4), dtype=np.int64)
    out[:, 0] = i
    k = math.sqrt(2.0) * m
    for r in range(len(q)):
        kept = [d for d in range(4) if d != i[r]]
        for j, d in enumerate(kept):
            x = sg[r] * q[r, d] / nrm[r]
            out[r, j + 1] = min(max(math.floor((x * k + m) * 0.5 + 0.5), 0), m)
    return out


def angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation angle (radians) between scalar-first quaternions, by scipy."""
    ra = Rotation.from_quat(np.asarray(a)[:, [1, 2, 3, 0]])
    rb = Rotation.from_quat(np.asarray(b)[:, [1, 2, 3, 0]])
    return (ra.inv() * rb).magnitude()


def random_unit(n: int, rng) -> np.ndarray:
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def adversarial(bits: int, rng, n: int = 400) -> np.ndarray:
    """Worst cases: the dropped component near 1/2 (all four near 1/2) and every kept component just
    past a rounding midpoint away from zero, so the kept part grows by ~sqrt3 h and the dropped one
    shrinks the most; random signs and positions of the dropped component."""
    h = half_step(bits)
    m = (1 << bits) - 1
    out = []
    for _ in range(n):
        c = math.ceil((0.5 / h + m) / 2) + rng.integers(-3, 1)   # the level at or just below 1/2
        a = (2 * c - m) * h - h * (1 - 1e-9)                     # just above the midpoint below it
        kept = np.full(3, a) * rng.choice([-1.0, 1.0], 3)
        big = math.sqrt(1 - float(kept @ kept))
        pos = int(rng.integers(4))
        q = np.insert(kept, pos, big) * rng.choice([-1.0, 1.0])
        out.append(q)
    return np.array(out)


# ---- quantisation -------------------------------------------------------------------------------

def test_crc16_is_ccitt_false():
    _, lib = _lib()
    assert lib.mkp_crc16(b"123456789", 9) == 0x29B1 == crc16(b"123456789")
    rng = np.random.default_rng(1)
    for n in (0, 1, 7, 64, 255):
        b = rng.integers(0, 256, n, dtype=np.uint8).tobytes()
        assert lib.mkp_crc16(b, n) == binascii.crc_hqx(b, 0xFFFF)


@pytest.mark.parametrize("bits", BITS)
def test_c_quantiser_matches_numpy_and_rounds_to_the_nearest_level(bits):
    rng = np.random.default_rng(bits)
    q = np.concatenate([random_unit(300, rng) * rng.uniform(0.5, 2.0, (300, 1)), adversarial(bits, rng, 100),
                        np.eye(4), -np.eye(4), np.full((1, 4), 0.5), [[0.5, -0.5, 0.5, -0.5]]])
    codes = c_quantise(q, bits)
    assert np.array_equal(codes, np_quantise(q, bits))
    # property, independent of the formula: each kept component on a level within h of it
    u = q / np.linalg.norm(q, axis=1, keepdims=True)
    h = half_step(bits)
    m = (1 << bits) - 1
    for r in range(len(q)):
        i = codes[r, 0]
        assert abs(u[r, i]) == np.abs(u[r]).max()
        kept = np.delete(u[r] * np.sign(u[r, i]), i)
        assert np.all(np.abs(kept - (2 * codes[r, 1:] - m) * h) <= h * (1 + 1e-9))


@pytest.mark.parametrize("bits", BITS)
def test_dequantise_python_equals_c_bit_for_bit(bits):
    rng = np.random.default_rng(100 + bits)
    m = (1 << bits) - 1
    codes = np.column_stack([rng.integers(0, 4, 500), rng.integers(0, m + 1, (500, 3))])
    codes = codes[(dequantise(codes, bits)[:, :] ** 2).sum(1) > 0]
    assert np.array_equal(dequantise(codes, bits), c_dequantise(codes, bits))


@pytest.mark.parametrize("bits", BITS)
def test_delta_bound_holds_by_brute_force_and_is_nearly_tight(bits):
    _, lib = _lib()
    assert lib.mkp_delta(bits) == pytest.approx(delta_bound(bits), rel=1e-14)
    rng = np.random.default_rng(200 + bits)
    for precision in ("float64", "float32"):
        q_rand = random_unit(3000, rng)
        q_adv = adversarial(bits, rng)
        for q in (q_rand, q_adv):
            codes = c_quantise(q, bits, precision)
            measured = angle(q, dequantise(codes, bits))
            assert measured.max() <= delta_bound(bits), (precision, measured.max(), delta_bound(bits))
        # the worst case reaches the bound (to first order in h): a bound 10% too small would fail here
        assert measured.max() >= (0.9 if bits < 8 else 0.97) * delta_bound(bits)


def test_delta_bound_formula_and_default_bits():
    for b in BITS:  # about 2 sqrt(6) / (2^B - 1) radians for large B
        assert delta_bound(b) == pytest.approx(2 * math.sqrt(6) / ((1 << b) - 1), rel=0.15)
    assert [default_bits(a) for a in ANGLES] == [12, 11, 10, 9]
    for a in ANGLES:
        b = default_bits(a)
        assert delta_bound(b) <= 0.15 * math.radians(a) < delta_bound(b - 1)
    with pytest.raises(ValueError):
        delta_bound(5)


# ---- the packetiser -----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def excerpt():
    return load_signals(DATA / "xio")


def _file(packets, bits, angle_deg, names=("s",), rates=(50.0,), pbytes=20) -> bytes:
    hdr = Header(bits, pbytes, angle_deg, 1000, tuple(Sensor(n, r, 0.0) for n, r in zip(names, rates, strict=True)))
    return mkp_bytes(hdr, packets)


@pytest.mark.parametrize("precision", ["float64", "float32"])
@pytest.mark.parametrize("deg,pbytes", [(0.5, 20), (1.0, 20), (2.0, 64), (5.0, 255), (2.0, 16)])
def test_decoder_recovers_the_points_the_c_encoder_emitted(excerpt, precision, deg, pbytes):
    for sig in excerpt.values():
        bits = default_bits(deg) if pbytes > 16 else 8
        pk = packetise(sig.values, deg, bits=bits, packet_bytes=pbytes, precision=precision)
        f = read_mkp("mem", data=_file(pk.packets, bits, deg, pbytes=pbytes))
        s = f.streams["s"]
        assert np.array_equal(s.ticks, pk.ticks) and np.array_equal(s.codes, pk.codes)
        assert s.ended and not s.lost and not f.damaged and not s.gap_before.any()
        assert s.ticks[0] == 0 and s.ticks[-1] == len(sig) - 1 and len(s.ticks) < len(sig) / 2
        assert all(len(p) <= pbytes for p in pk.packets)
        assert [p[1] | p[2] << 8 for p in pk.packets] == list(range(len(pk.packets)))
        assert [bool(p_[_count_pos(p_)] & 0x80) for p_ in pk.packets] == [False] * (len(pk.packets) - 1) + [True]
        assert np.all(np.diff(pk.sent_at) >= 0) and pk.sent_at[-1] == len(sig)
        # every packet but the last is full: no further 1-byte-delta point would have fitted
        for p in pk.packets[:-1]:
            head = _count_pos(p) + 1
            assert len(p) == head + (_bits_used(p, bits) + 7) // 8 + 2
            smallest_next = 8 + 2 + 3 * bits
            assert head + (_bits_used(p, bits) + smallest_next + 7) // 8 + 2 > pbytes or p[head - 1] & 0x7F == 127


def _count_pos(p: bytes) -> int:
    """Offset of the count byte (after the sensor id, the sequence number and the first tick)."""
    pos = 3
    while p[pos] & 0x80:
        pos += 1
    return pos + 1


def _bits_used(p: bytes, bits: int) -> int:
    pk = parse_packet(p, bits)
    deltas = np.diff(pk.ticks)
    return sum(8 * max(1, math.ceil(int(d).bit_length() / 7)) for d in deltas) + len(pk.ticks) * (2 + 3 * bits)


def test_float64_points_equal_python_anglesw_on_the_quantised_samples(excerpt):
    for deg in ANGLES:
        bits = default_bits(deg)
        for sig in excerpt.values():
            pk = packetise(sig.values, deg, bits=bits)
            deq = dequantise(np_quantise(sig.values, bits), bits)
            budget = math.radians(deg) - delta_bound(bits) - EPS
            idx = anglesw.batch(np.arange(len(sig), dtype=np.float64), deq, budget, 1000)
            assert np.array_equal(idx, pk.ticks)
            assert np.array_equal(dequantise(pk.codes, bits), deq[idx])


def test_packetiser_refuses_impossible_options(excerpt):
    v = next(iter(excerpt.values())).values
    with pytest.raises(InvalidParameterError, match="--packet-bits 6"):
        packetise(v, 2.0, bits=6)              # delta(6) ~ 4.8 degrees > 2
    with pytest.raises(InvalidParameterError, match="--packet-bits"):
        packetise(v, 2.0, bits=17)
    with pytest.raises(InvalidParameterError, match="--packet-bytes"):
        packetise(v, 2.0, bits=10, packet_bytes=300)
    with pytest.raises(InvalidParameterError, match="--packet-bytes 16: too small"):
        packetise(v, 0.1, bits=16, packet_bytes=16)
    with pytest.raises(Exception, match="sample 3: zero-norm"):
        packetise(np.vstack([v[:3], np.zeros((1, 4)), v[3:10]]), 2.0, bits=10)


@pytest.mark.parametrize("precision", ["float64", "float32"])
@pytest.mark.parametrize("bad,code,msg", [((1.0, math.inf, 0.0, 0.0), -7, "NaN or infinite"),
                                          ((-math.inf, 0.0, 0.0, 0.0), -7, "NaN or infinite"),
                                          ((0.5, 0.5, math.nan, 0.5), -7, "NaN or infinite"),
                                          ((0.0, 0.0, 0.0, 0.0), -4, "zero-norm"),
                                          ((1e30, 1e30, 0.0, 0.0), -4, "zero-norm")])
def test_c_packetiser_refuses_non_finite_and_zero_quaternions(excerpt, precision, bad, code, msg):
    """mkp_quantise gives the code; the packetiser names the sample and sends nothing made of it."""
    if precision == "float64" and bad[0] == 1e30:
        bad = (1e160, 1e160, 0.0, 0.0)   # a squared norm beyond double's range
    ffi, lib = _lib(precision)
    x = ffi.new("mkpla_real[4]", list(bad))
    c = ffi.new("uint16_t[4]")
    assert lib.mkp_quantise(x, 12, c) == code
    v = next(iter(excerpt.values())).values
    with pytest.raises(Exception, match=f"sample 3: {msg}"):
        packetise(np.vstack([v[:3], np.array([bad]), v[3:10]]), 2.0, bits=10, precision=precision)


# ---- the bound on every shared sample -------------------------------------------------------------

def _shared_quaternion_signals(shared_data):
    out = {}
    for p in sorted(x for x in (shared_data / "imu").rglob("*") if x.is_file() and x.suffix in (".csv", ".txt")):
        try:
            sigs = load_signals(p)
        except MocapFormatError:  # Inertial.csv: no orientation
            continue
        for k, s in sigs.items():
            if s.kind == "quaternion":
                out[f"{p.parent.name}/{p.name}:{k}"] = s
    return out


@pytest.mark.shared
@pytest.mark.parametrize("precision", ["float64", "float32"])
def test_max_angle_holds_after_quantisation_on_every_shared_sample(shared_data, precision):
    sigs = _shared_quaternion_signals(shared_data)
    assert len(sigs) >= 13, sorted(sigs)
    worst = {}
    for name, sig in sigs.items():
        for deg in ANGLES:
            bits = default_bits(deg)
            pk = packetise(sig.values, deg, bits=bits, precision=precision)
            s = read_mkp("mem", data=_file(pk.packets, bits, deg)).streams["s"]
            assert np.array_equal(s.ticks, pk.ticks) and np.array_equal(s.codes, pk.codes)
            keep, dec = decode_at(s.ticks, s.values, s.gap_before, np.arange(len(sig), dtype=np.float64))
            assert keep.all()
            err = np.degrees(angle(sig.values / np.linalg.norm(sig.values, axis=1, keepdims=True), dec))
            assert err.max() <= deg, (name, deg, err.max())
            worst[deg] = max(worst.get(deg, 0.0), err.max() / deg)
    assert min(worst.values()) > 0.8  # the budget is used, not wasted


@pytest.mark.shared
def test_compress_job_on_the_walk_meets_the_radio_goal(shared_data, tmp_path):
    rec = compress_packets_job(shared_data / "imu" / "xio-lower-body", tmp_path / "walk.mkp", max_angle=2.0)
    assert len(rec["signals"]) == 7
    total = sum(r["bytes"] for r in rec["signals"])
    raw = sum(16 * r["n_samples"] for r in rec["signals"])
    assert total <= raw / 10
    assert all(r["max_deg"] <= 2.0 for r in rec["signals"])
    f = read_mkp(tmp_path / "walk.mkp")
    from mocapkit.pla.packet_layout import header_bytes

    assert (tmp_path / "walk.mkp").stat().st_size == len(header_bytes(f.header)) + total + sum(
        r["packets"] for r in rec["signals"])


# ---- losses -----------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def two_sensors(excerpt):
    """The packets of the two excerpt sensors at 1 degree, interleaved, and each stream's packets."""
    per = {n: packetise(s.values, 1.0, bits=11, sensor=i) for i, (n, s) in enumerate(excerpt.items())}
    order = sorted(((int(t), i, k) for i, pk in enumerate(per.values()) for k, t in enumerate(pk.sent_at)))
    pks = list(per.values())
    packets = [pks[i].packets[k] for _, i, k in order]
    who = [(list(per)[i], k) for _, i, k in order]
    return per, packets, who


def _read(packets, names) -> object:
    return read_mkp("mem", data=_file(packets, 11, 1.0, names=tuple(names), rates=(50.0,) * len(names)))


def _check_loss(per, excerpt, f, sensor, seq, damaged_index=None):
    s = f.streams[sensor]
    assert s.lost == [seq]
    assert f.lost_packets == 1
    if damaged_index is not None:
        assert [d.index for d in f.damaged] == [damaged_index]
    lost_ticks = set(parse_packet(per[sensor].packets[seq], 11).ticks)
    want = [t for t in per[sensor].ticks.tolist() if t not in lost_ticks]
    assert s.ticks.tolist() == want
    # the first point after the loss is marked, and no other
    first_after = min(t for t in want if t > max(lost_ticks)) if max(lost_ticks) < want[-1] else None
    assert [int(t) for t in s.ticks[s.gap_before]] == ([first_after] if first_after is not None else [])
    # the decode leaves out exactly the samples between the points around the gap; the rest is unchanged
    n = len(excerpt[sensor])
    u = np.arange(n, dtype=np.float64)
    keep, dec = decode_at(s.ticks, s.values, s.gap_before, u)
    full = _read(per[sensor].packets, per).streams[sensor]
    _, d0 = decode_at(full.ticks, full.values, full.gap_before, u)
    before = max([t for t in want if t < min(lost_ticks)], default=-1)  # -1: the stream's first packet was lost
    gone = (u > before) & (u < (first_after if first_after is not None else n))
    assert np.array_equal(~keep, gone)
    assert np.array_equal(dec, d0[keep])
    other = next(x for x in f.streams if x != sensor)
    assert not f.streams[other].lost and f.streams[other].ended
    assert np.array_equal(f.streams[other].ticks, per[other].ticks)
    return f


@pytest.mark.parametrize("which", [0, 5, "middle", "last"])
def test_a_dropped_packet_is_reported_with_its_sequence_number(excerpt, two_sensors, which):
    per, packets, who = two_sensors
    j = {"middle": len(packets) // 2, "last": len(packets) - 1}.get(which, which)
    sensor, seq = who[j]
    f = _read(packets[:j] + packets[j + 1:], per)
    if seq == len(per[sensor].packets) - 1:  # the stream's last packet: its end is reported missing
        assert f.streams[sensor].lost == [] and not f.streams[sensor].ended and f.lost_packets == 1
        assert any("end of the stream is missing" in x for x in f.losses())
        return
    _check_loss(per, excerpt, f, sensor, seq)
    assert any(f"{sensor}: lost packet sequence number {seq}" in x for x in f.losses())


@pytest.mark.parametrize("how", ["flip", "flip-header", "truncate", "empty"])
def test_a_corrupted_packet_is_reported_and_the_others_decode(excerpt, two_sensors, how):
    per, packets, who = two_sensors
    j = len(packets) // 3
    sensor, seq = who[j]
    p = bytearray(packets[j])
    if how == "flip":
        p[len(p) // 2] ^= 0x10
    elif how == "flip-header":
        p[1] ^= 0x01  # the sequence number itself
    elif how == "truncate":
        p = p[:len(p) - 3]
    else:
        p = p[:1]
    f = _read(packets[:j] + [bytes(p)] + packets[j + 1:], per)
    _check_loss(per, excerpt, f, sensor, seq, damaged_index=j)
    assert f.damaged[0].problem in ("CRC-16 does not match", f"{len(p)} bytes, too short for a packet")


def test_decompress_job_leaves_the_gap_out_and_counts_it(excerpt, two_sensors, tmp_path):
    per, packets, who = two_sensors
    j = len(packets) // 2
    path = tmp_path / "lossy.mkp"
    path.write_bytes(_file(packets[:j] + packets[j + 1:], 11, 1.0, names=tuple(per), rates=(50.0, 50.0)))
    rec = decompress_packets_job(path, tmp_path / "pts")
    assert rec["lost_packets"] == 1 and rec["mode"] == "points"
    sensor, seq = who[j]
    r = {x["name"]: x for x in rec["sensors"]}
    assert r[sensor]["lost_sequence_numbers"] == [seq] and r[sensor]["gaps"] == 1
    text = (tmp_path / "pts" / f"{sensor}.csv").read_text().splitlines()
    assert text[0] == "time,w,x,y,z,tick,gap_before"
    assert sum(line.endswith(",1") for line in text[1:]) == 1
    rec = decompress_packets_job(path, tmp_path / "full", times_from=DATA / "xio")
    r = {x["name"]: x for x in rec["sensors"]}
    assert r[sensor]["samples_left_out"] > 0 and r[sensor]["samples"] + r[sensor]["samples_left_out"] == 300
    other = next(x for x in per if x != sensor)
    assert r[other]["samples"] == 300 and r[other]["samples_left_out"] == 0
    got = load_signals(tmp_path / "full" / f"{sensor}.csv")
    sig = next(iter(got.values()))
    assert len(sig) == r[sensor]["samples"]
    assert np.all(np.isin(sig.times, excerpt[sensor].times))


def test_decode_at_is_scipy_slerp_within_runs_and_nothing_across_a_gap():
    from scipy.spatial.transform import Slerp

    rng = np.random.default_rng(7)
    ticks = np.array([0, 4, 10, 11, 30, 37])
    vals = random_unit(len(ticks), rng)
    gap = np.array([False, False, False, False, True, False])   # a loss between ticks 11 and 30
    u = np.linspace(0, 37, 371)
    keep, dec = decode_at(ticks, vals, gap, u)
    assert np.array_equal(keep, (u <= 11) | (u >= 30))
    ref = np.empty((0, 4))
    for a, b in ((0, 4), (4, 6)):  # the two runs: points 0..3 and 4..5
        r = Rotation.from_quat(vals[a:b][:, [1, 2, 3, 0]])
        m = (u >= ticks[a]) & (u <= ticks[b - 1])
        ref = np.vstack([ref, Slerp(ticks[a:b].astype(float), r)(u[m]).as_quat()[:, [3, 0, 1, 2]]])
    assert angle(dec, ref).max() < 1e-7


# ---- the strict reader ----------------------------------------------------------------------------

def _packet(sensor, seq, first, count_byte, body: bytes) -> bytes:
    v, head = first, bytearray([sensor, seq & 0xFF, seq >> 8])
    while v >= 0x80:
        head.append(0x80 | (v & 0x7F))
        v >>= 7
    head.append(v)
    head.append(count_byte)
    p = bytes(head) + body
    return p + struct.pack("<H", crc16(p))


def _one_point(bits=11, index=0, codes=(1024, 1024, 1024)) -> bytes:
    v = index
    for c in codes:
        v = (v << bits) | c
    n = 2 + 3 * bits
    pad = (-n) % 8
    return (v << pad).to_bytes((n + pad) // 8, "big")


@pytest.mark.parametrize("mutate,message", [
    (lambda d: b"MKQ" + d[3:], "not a mocapkit packet file"),
    (lambda d: d[:4] + b"\x02" + d[5:], "version 2"),
    (lambda d: d[:9] + bytes([d[9] ^ 1]) + d[10:], "header's CRC-32"),
    (lambda d: d[:20], "shorter than its header"),
    (lambda d: d[:26], "truncated header"),
])
def test_container_problems_are_format_errors(excerpt, mutate, message):
    pk = packetise(next(iter(excerpt.values())).values, 2.0, bits=10)
    data = _file(pk.packets, 10, 2.0)
    read_mkp("mem", data=data)
    with pytest.raises(MocapFormatError, match=message):
        read_mkp("mem", data=mutate(data))


@pytest.mark.parametrize("packets,message", [
    ([_packet(3, 0, 0, 0x81, _one_point())], "sensor id 3"),
    ([_packet(0, 0, 0, 0x01, _one_point()), _packet(0, 0, 5, 0x81, _one_point())], "repeats or goes back"),
    ([_packet(0, 0, 4, 0x01, _one_point())], "sequence 0 starts at tick 4"),
    ([_packet(0, 0, 0, 0x01, _one_point()), _packet(0, 1, 0, 0x81, _one_point())], "tick 0 is not after"),
    ([_packet(0, 0, 0, 0x00, b"")], "without points that is not the last"),
    ([_packet(0, 0, 0, 0x02, _one_point())], "ends inside point 1"),
    ([_packet(0, 0, 0, 0x81, _one_point() + b"\x00")], "bytes after the last point"),
    ([_packet(0, 0, 0, 0x81, _one_point()[:-1] + bytes([_one_point()[-1] | 1]))], "non-zero padding"),
    ([_packet(0, 0, 0, 0x81, _one_point()), _packet(0, 1, 9, 0x81, _one_point())], "after the stream's last"),
    ([_packet(0, 0, 0, 0x81, _one_point(codes=(0, 0, 0)))], "outside the unit sphere"),
    ([_packet(0, 0, 2 ** 32, 0x81, _one_point())], "does not fit 32 bits"),
])
def test_impossible_packets_with_a_good_crc_are_format_errors(packets, message):
    with pytest.raises(MocapFormatError, match=r"mem: packet \d+ \(byte \d+\).*" + message):
        read_mkp("mem", data=_file(packets, 11, 1.0))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_fuzzed_files_give_results_or_format_errors(excerpt, data):
    sigs = list(excerpt.values())
    per = [packetise(s.values[:120], 1.0, bits=11, sensor=i) for i, s in enumerate(sigs)]
    raw = bytearray(_file([p for pk in per for p in pk.packets], 11, 1.0, names=("a", "b"), rates=(50.0, 50.0)))
    for _ in range(data.draw(st.integers(0, 4))):
        raw[data.draw(st.integers(0, len(raw) - 1))] ^= 1 << data.draw(st.integers(0, 7))
    cut = data.draw(st.integers(0, len(raw)))
    raw = raw[:cut] if data.draw(st.booleans()) else raw
    try:
        f = read_mkp("fuzz", data=bytes(raw))
    except MocapFormatError:
        return
    for s in f.streams.values():
        assert np.allclose(np.linalg.norm(s.values, axis=1), 1.0) if len(s.values) else True
        if len(s.ticks):
            keep, dec = decode_at(s.ticks, s.values, s.gap_before, np.arange(int(s.ticks[-1]) + 1, dtype=float))
            assert len(dec) == keep.sum()
        f.losses()


# ---- the command line ---------------------------------------------------------------------------

def test_cli_compress_and_decompress(tmp_path, capsys):
    src = DATA / "xio" / "pelvis" / "Quaternion.csv"
    out = tmp_path / "pelvis.mkp"
    assert _cli(["compress", str(src), "--max-angle", "1", "-o", str(out), "--json"]) == 0
    import json

    rec = json.loads(capsys.readouterr().out)
    assert rec[0]["n_samples"] == 300 and rec[0]["max_deg"] <= 1.0 and rec[0]["bytes"] > 0
    assert _cli(["decompress", str(out), "-o", str(tmp_path / "pts.csv")]) == 0
    assert "0 packets lost" in capsys.readouterr().err
    assert _cli(["decompress", str(out), "-o", str(tmp_path / "full.csv"), "--times-from", str(src)]) == 0
    dec = load_signals(tmp_path / "full.csv")["full"]
    orig = load_signals(src)
    o = next(iter(orig.values()))
    assert np.array_equal(dec.times, o.times)
    assert np.degrees(angle(o.values / np.linalg.norm(o.values, axis=1, keepdims=True), dec.values)).max() <= 1.0
    assert _cli(["decompress", str(out), "-o", str(tmp_path / "grid.csv"), "--rate", "100"]) == 0
    # a lost packet: a warning naming its sequence number and a non-zero count
    f = read_mkp(out)
    data = out.read_bytes()
    hdr_len = len(data) - sum(1 + len(p) for p in _split(data, f))
    ps = _split(data, f)
    lossy = tmp_path / "lossy.mkp"
    lossy.write_bytes(data[:hdr_len] + b"".join(bytes([len(p)]) + p for k, p in enumerate(ps) if k != 2))
    assert _cli(["decompress", str(lossy), "-o", str(tmp_path / "l.csv"), "--times-from", str(src)]) == 0
    e = capsys.readouterr().err
    assert "lost packet sequence number 2" in e and "1 packets lost" in e and "left out" in e
    # its points CSV marks the gap, and the CSV decode path refuses to bridge it
    assert _cli(["decompress", str(lossy), "-o", str(tmp_path / "lp.csv")]) == 0
    assert _cli(["decompress", str(tmp_path / "lp.csv"), "-o", str(tmp_path / "b.csv"), "--rate", "50"]) == 2
    assert "follows a lost packet" in capsys.readouterr().err
    assert _cli(["decompress", str(tmp_path / "pts.csv"), "-o", str(tmp_path / "b.csv"), "--rate", "50"]) == 0
    # options that do not apply
    assert _cli(["compress", str(src), "--threshold", "0.01", "-o", str(tmp_path / "x.mkp")]) == 2
    assert _cli(["compress", str(src), "--max-angle", "1", "--packet-bits", "6", "-o",
                     str(tmp_path / "x.mkp")]) == 2
    assert _cli(["compress", str(src), "--max-angle", "1", "--packet-bits", "12", "-o",
                     str(tmp_path / "x.csv")]) == 2
    assert "--max-angle" in capsys.readouterr().err


def _cli(args: list[str]) -> int:
    try:
        cli.main(args)
    except SystemExit as e:
        return int(e.code or 0)
    return 0


def _split(data: bytes, f) -> list[bytes]:
    """The packet records at the end of a file, walked back from the known packet count."""
    from mocapkit.pla.packet_layout import header_bytes

    pos = len(header_bytes(f.header))
    out = []
    while pos < len(data):
        n = data[pos]
        out.append(data[pos + 1:pos + 1 + n])
        pos += 1 + n
    return out


def test_info_reports_settings_points_and_losses(excerpt, two_sensors, tmp_path):
    from mocapkit.jobs.info import info_job

    per, packets, who = two_sensors
    whole = tmp_path / "whole.mkp"
    whole.write_bytes(_file(packets, 11, 1.0, names=tuple(per), rates=(50.0, 50.0)))
    rec = info_job(whole)
    assert rec["kind"] == "packets" and rec["bits"] == 11 and rec["max_angle_deg"] == 1.0
    assert rec["lost_packets"] == 0 and rec["warnings"] == []
    for name, p in per.items():  # the points each stream sent, and its samples (last tick + 1)
        s = rec["sensors"][name]
        assert s["packets"] == len(p.packets) and s["points"] == len(p.ticks) and s["samples"] == len(excerpt[name])
    j = len(packets) // 3
    lossy = tmp_path / "lossy.mkp"
    lossy.write_bytes(_file(packets[:j] + packets[j + 1:], 11, 1.0, names=tuple(per), rates=(50.0, 50.0)))
    rec = info_job(lossy)
    sensor, seq = who[j]
    assert rec["lost_packets"] == 1 and rec["sensors"][sensor]["lost_sequence_numbers"] == 1
    assert any(f"sequence number {seq}" in w for w in rec["warnings"])


@pytest.mark.parametrize("cut", [1, 3, 7])
def test_a_log_cut_short_keeps_the_packets_before_the_cut(excerpt, cut):
    """A receiver's log whose last record was cut (power lost) decodes up to the cut and reports the rest."""
    s = next(iter(excerpt.values()))
    pk = packetise(s.values, 2.0, bits=10)
    data = _file(pk.packets, 10, 2.0)
    whole = read_mkp("mem", data=data)
    got = read_mkp("mem", data=data[:-cut])
    (d,) = got.damaged
    assert d.index == len(pk.packets) - 1 and "cut short" in d.problem
    a, b = next(iter(whole.streams.values())), next(iter(got.streams.values()))
    n = len(b.ticks)
    assert 0 < n < len(a.ticks) and np.array_equal(a.ticks[:n], b.ticks) and np.array_equal(a.values[:n], b.values)
    assert not b.ended and any("end of the stream is missing" in w for w in got.losses())
    extra = read_mkp("mem", data=data + b"\x05\x00")  # a record of 5 bytes with 1 present after the end
    assert len(extra.damaged) == 1 and np.array_equal(next(iter(extra.streams.values())).ticks, a.ticks)


def test_decoded_points_keep_w_positive_at_the_start_and_no_sign_jumps(tmp_path):
    """Smallest-three makes the dropped (largest) component positive: a stream where x dominates with a
    negative sign, and where the largest component changes, decodes with sign jumps unless presented."""
    from scipy.spatial.transform import Rotation

    ang = np.linspace(2.7, 0.5, 400)  # from 155 to 29 degrees about -x: x dominates (negative), then w
    rv = np.column_stack([-ang, 0.2 * np.sin(3 * ang), 0.1 * np.cos(ang)])
    q = Rotation.from_rotvec(rv).as_quat()[:, [3, 0, 1, 2]]
    q[q[:, 0] < 0] *= -1          # the sensor's own convention: w >= 0
    pk = packetise(q, 1.0, bits=11)
    raw_q = dequantise(pk.codes, 11)
    assert raw_q[0, 0] < 0 and (np.einsum("ij,ij->i", raw_q[1:], raw_q[:-1]) < 0).any()  # the case exists
    path = tmp_path / "x.mkp"
    path.write_bytes(_file(pk.packets, 11, 1.0))
    decompress_packets_job(path, tmp_path / "pts.csv")
    rows = np.loadtxt(tmp_path / "pts.csv", delimiter=",", skiprows=1)
    got = rows[:, 1:5]
    assert got[0, 0] >= 0 and np.all(np.einsum("ij,ij->i", got[1:], got[:-1]) >= 0)
    assert np.max(angle(got, raw_q)) < 1e-9  # the same rotations (CSV text)


def test_decompress_of_several_sensors_into_an_existing_folder(excerpt, two_sensors, tmp_path):
    """Decoding again into the folder of a previous decode works (it was refused as 'a folder')."""
    per, packets, who = two_sensors
    path = tmp_path / "two.mkp"
    path.write_bytes(_file(packets, 11, 1.0, names=tuple(per), rates=(50.0, 50.0)))
    out = tmp_path / "pts"
    assert _cli(["decompress", str(path), "-o", str(out)]) == 0
    first = {p.name: p.read_text() for p in out.iterdir()}
    assert _cli(["decompress", str(path), "-o", str(out)]) == 0
    assert {p.name: p.read_text() for p in out.iterdir()} == first and len(first) == 2
