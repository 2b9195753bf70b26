"""The C radio packetiser (``c/mkpla/mkp.c``) from Python: one orientation stream into ``.mkp`` packets.

The packetiser quantises every sample by smallest-three at ``bits`` bits per component, runs the
angle-bounded encoder on the dequantised samples with the budget ``max_angle - delta(bits) - EPS``
and packs the decided points into packets of at most ``packet_bytes`` bytes (docs/mkp.md).
``precision="float32"`` runs the build a sensor runs.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from mocapkit.errors import InvalidParameterError, InvalidSignalError
from mocapkit.pla.native import C_ERRORS, _module
from mocapkit.pla.packet_layout import MAX_BITS, MAX_PACKET, MIN_BITS, MIN_PACKET, delta_bound

#: mkp.h MKP_EPS: radians kept besides delta(B) for float rounding
EPS = 1e-6
#: δ(B) as a fraction of the bound that the default B stays under (docs/mkp.md: the fewest radio bytes)
DEFAULT_FRACTION = 0.15
#: the default maximum segment length (as compress's anglesw, pla.base.BOUNDED_BY_DEFAULT)
DEFAULT_MAXLEN = 1000
#: samples per call into C
CHUNK = 1 << 14

#: the C library's return codes (mkpla.h, mkp.h), worded for the packetiser
_ERRORS = {**C_ERRORS, -1: "bad bits, packet size, bound or maximum segment length",
           -6: "the tick counter is full"}


def default_bits(max_angle_deg: float, fraction: float = DEFAULT_FRACTION) -> int:
    """The fewest bits per component whose quantisation bound is at most ``fraction`` of the bound."""
    th = math.radians(max_angle_deg)
    for b in range(MIN_BITS, MAX_BITS + 1):
        if delta_bound(b) <= fraction * th:
            return b
    return MAX_BITS


def check_packet_options(max_angle_deg: float, bits: int, packet_bytes: int) -> None:
    """Refuse, naming the option, what the C packetiser would refuse."""
    if not (isinstance(bits, (int, np.integer)) and MIN_BITS <= bits <= MAX_BITS):
        raise InvalidParameterError(f"--packet-bits {bits!r}: an integer in {MIN_BITS}..{MAX_BITS}")
    if not (isinstance(packet_bytes, (int, np.integer)) and MIN_PACKET <= packet_bytes <= MAX_PACKET):
        raise InvalidParameterError(f"--packet-bytes {packet_bytes!r}: an integer in {MIN_PACKET}..{MAX_PACKET}")
    if 11 + (2 + 3 * bits + 7) // 8 > packet_bytes:
        raise InvalidParameterError(f"--packet-bytes {packet_bytes}: too small for one point at {bits} bits")
    d = delta_bound(bits)
    if not (math.radians(max_angle_deg) - d - EPS > 0):
        raise InvalidParameterError(
            f"--packet-bits {bits}: the quantisation alone may turn a sample by {math.degrees(d):.4g} degrees, "
            f"which leaves nothing of --max-angle {max_angle_deg:g}; give more bits")


class Packets(NamedTuple):
    """What the packetiser sent: ``packets`` (bytes each), ``sent_at`` (the tick whose push sent each
    packet; the sample count for those of the flush), and the decided points' ``ticks`` and ``codes``."""

    packets: list[bytes]
    sent_at: np.ndarray
    ticks: np.ndarray
    codes: np.ndarray


def packetise(values: np.ndarray, max_angle_deg: float, *, bits: int, packet_bytes: int = 20,
              max_segment_length: int = DEFAULT_MAXLEN, sensor: int = 0, precision: str = "float64") -> Packets:
    """Run the C packetiser over one stream of quaternions ``(N, 4)`` (ticks 0..N-1), flush included."""
    check_packet_options(max_angle_deg, bits, packet_bytes)
    if not (isinstance(max_segment_length, (int, np.integer)) and 1 <= max_segment_length <= 1 << 20):
        raise InvalidParameterError(f"--max-segment-length {max_segment_length!r}: an integer in 1..{1 << 20}")
    if not 0 <= sensor <= 255:
        raise InvalidParameterError(f"sensor id {sensor}: 0..255")
    mod = _module(precision)
    ffi, lib = mod.ffi, mod.lib
    dtype = np.float64 if precision == "float64" else np.float32
    q = np.ascontiguousarray(values, dtype=dtype).reshape(-1, 4)
    n = q.shape[0]
    st = ffi.new("mkp_packetiser *")
    buf = np.zeros(5 * max_segment_length, dtype=dtype)
    real = ffi.cast("mkpla_real *", ffi.from_buffer(buf))
    rc = lib.mkp_init(st, sensor, math.radians(max_angle_deg), bits, packet_bytes, max_segment_length, real, buf.size)
    if rc != 0:
        raise InvalidParameterError(f"C packetiser: {_ERRORS.get(rc, rc)}")
    packets, sent, ticks, codes = [], [], [], []
    used = ffi.new("size_t *")
    npts = ffi.new("size_t *")
    failed = ffi.new("size_t *")
    for start in range(0, max(n, 1), CHUNK):
        chunk = q[start:start + CHUNK]
        k = chunk.shape[0]
        last = start + CHUNK >= n
        out = np.empty((k + 3) * (packet_bytes + 1), dtype=np.uint8)
        at = np.empty(k + 3, dtype=np.uint32)
        pt = np.empty(k + 2, dtype=np.uint32)
        pc = np.empty((k + 2) * 4, dtype=np.uint16)
        m = lib.mkp_push_many(st, ffi.cast("mkpla_real *", ffi.from_buffer(chunk)), k, 1 if last else 0,
                              ffi.cast("uint8_t *", ffi.from_buffer(out)), out.size, used,
                              ffi.cast("uint32_t *", ffi.from_buffer(at)), ffi.cast("uint32_t *", ffi.from_buffer(pt)),
                              ffi.cast("uint16_t *", ffi.from_buffer(pc)), npts, failed)
        if m < 0:
            raise InvalidSignalError(f"sample {start + int(failed[0])}: {_ERRORS.get(m, m)}")
        raw = out[:used[0]].tobytes()
        pos = 0
        for i in range(m):
            ln = raw[pos]
            packets.append(raw[pos + 1:pos + 1 + ln])
            pos += 1 + ln
            sent.append(start + int(at[i]))
        ticks.append(pt[:npts[0]].astype(np.int64))
        codes.append(pc[:4 * npts[0]].reshape(-1, 4).astype(np.int64))
    return Packets(packets, np.array(sent, dtype=np.int64), np.concatenate(ticks), np.concatenate(codes))
