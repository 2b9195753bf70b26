"""The ``.mkp`` radio packet stream as bytes: segment points of IMU orientation streams as they went over the radio.

The packets are made on the sensor by the C packetiser (``c/mkpla/mkp.c``); this module defines the
smallest-three quantisation's decoding and error bound, parses packets and makes and decodes the file's
bytes (:func:`mkp_bytes`, :func:`decode_mkp`). It opens no file: :mod:`mocapkit.io.formats.mkp` reads and
writes one, ``mocapkit.jobs.readers.read_mkp`` joins reading and decoding. The full specification is
``docs/mkp.md``. File layout (little-endian)::

    offset  size  field
    0       4     magic b"MKP\\0"
    4       1     format version (1)
    5       1     B, bits per quaternion component (6..16)
    6       1     largest packet the sender makes, bytes (16..255)
    7       1     S, number of sensors (1..255)
    8       8     end-to-end bound, degrees (float64)
    16      4     maximum segment length of the encoder, samples (uint32; informational)
    20      ...   S sensors: name length (1 byte, 1..255), UTF-8 name, rate Hz (float64, 1e-6..1e9),
                  time of tick 0 in seconds (float64, within ±1e12): tick k at the nominal t0 + k / rate
    ...     4     CRC-32 of every header byte before it
    ...     ...   packets as received: length L (1 byte, >= 1) then L bytes

A packet (all of it covered by its CRC-16)::

    sensor id (1 byte, index into the header's sensors) | sequence number (uint16, per sensor, wraps) |
    tick of the first point (LEB128) | count (bit 7: last packet of the stream; bits 0-6: points) |
    bitstream, MSB first: point 0 = quaternion; point k >= 1 = tick delta >= 1 (LEB128 in 8-bit
    groups) then quaternion; a quaternion = dropped component's index (2 bits) + 3 codes of B bits;
    zero bits to the byte | CRC-16/CCITT-FALSE of the bytes before it (uint16)

Reading is strict about the container: a bad header or a packet whose CRC matches but whose content
is impossible is a :class:`~mocapkit.errors.MocapFormatError` naming the file and the packet. A packet
whose CRC does not match (a radio error), or a last record cut short by the end of the file (a
receiver's log cut by a power loss), is *reported*, not raised: it is dropped, and the missing sequence numbers of its
sensor are listed, so the decoder can refuse to bridge the gap (:attr:`SensorPoints.gap_before`).
"""

from __future__ import annotations

import binascii
import math
import struct
import zlib
from dataclasses import dataclass, field
from typing import TypedDict

import numpy as np

from mocapkit.errors import MocapFormatError
from mocapkit.motion import MAX_ABS

MAGIC = b"MKP\x00"
VERSION = 1
MIN_BITS, MAX_BITS = 6, 16
MIN_PACKET, MAX_PACKET = 16, 255
LAST = 0x80
MAX_POINTS = 127
_FIXED = struct.Struct("<4sBBBBdI")
_SENSOR = struct.Struct("<dd")
TICK_LIMIT = 1 << 32
#: a sensor's rate in Hz, as the text readers accept it (``io.imu.columns.RATE_RANGE``)
RATE_RANGE = (1e-6, 1e9)
#: the encoder's maximum segment length, samples (``pla.packets.packetise`` accepts 1..2^20)
SEGMENT_LENGTH_RANGE = (1, 1 << 20)
#: smallest step between two points' times on a stream's clock (the text readers' ``MIN_STEP``)
MIN_STEP = 1e-9


# ---- smallest-three quantisation ---------------------------------------------------------------

def half_step(bits: int) -> float:
    """``h = 1 / (sqrt(2) (2^B - 1))``: code ``c`` stands for ``(2c - M) h``, ``M = 2^B - 1``."""
    return 1.0 / (math.sqrt(2.0) * ((1 << bits) - 1))


def delta_bound(bits: int) -> float:
    """The proven bound, in radians, of the rotation angle between a unit quaternion and its
    smallest-three quantisation at ``bits`` bits per component (docs/mkp.md):
    ``e = sqrt(3) h / sqrt(1/4 - 3h - 3h^2)`` bounds ``|q - q'|``, and the angle
    ``4 asin(|q - q'| / 2) <= 2e / sqrt(1 - e^2/4)``. The C library's ``mkp_delta`` computes the same."""
    if not (isinstance(bits, (int, np.integer)) and MIN_BITS <= bits <= MAX_BITS):
        raise ValueError(f"bits must be an integer in {MIN_BITS}..{MAX_BITS}, got {bits!r}")
    h = half_step(int(bits))
    e = math.sqrt(3.0) * h / math.sqrt(0.25 - 3 * h - 3 * h * h)
    return 2 * e / math.sqrt(1 - e * e / 4)


def dequantise(codes: np.ndarray, bits: int) -> np.ndarray:
    """Unit quaternions ``(M, 4)`` from codes ``(M, 4)`` (dropped index, then the three kept codes),
    with the C library's operations in its order (``mkp_dequantise``): the float64 results are equal."""
    codes = np.asarray(codes, dtype=np.int64).reshape(-1, 4)
    h = half_step(bits)
    m = (1 << bits) - 1
    a = (2 * codes[:, 1:] - m).astype(np.float64) * h
    s = a[:, 0] * a[:, 0] + a[:, 1] * a[:, 1] + a[:, 2] * a[:, 2]
    big = np.sqrt(np.where(s < 1.0, 1.0 - s, 0.0))
    out = np.empty((codes.shape[0], 4))
    rows = np.arange(codes.shape[0])
    keep = np.array([[j for j in range(4) if j != i] for i in range(4)])[codes[:, 0] & 3]
    out[rows, codes[:, 0] & 3] = big
    for k in range(3):
        out[rows, keep[:, k]] = a[:, k]
    return out


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE (polynomial 0x1021, initial value 0xffff, no reflection, no final xor)."""
    return binascii.crc_hqx(data, 0xFFFF)


# ---- the file -----------------------------------------------------------------------------------

@dataclass(frozen=True)
class Sensor:
    """One stream of the file: its name, sample rate and ``t0``. The stream's clock is the tick (the index
    of the sample); ``t0 + k / rate`` (:meth:`nominal_times`) is tick ``k``'s time only for a recording
    sampled at exactly ``rate`` (docs/mkp.md, "Time")."""

    name: str
    rate: float
    t0: float

    def nominal_times(self, ticks: np.ndarray) -> np.ndarray:
        """``t0 + ticks / rate``: the times the file alone gives its (fractional) ticks."""
        return self.t0 + np.asarray(ticks, dtype=np.float64) / self.rate


@dataclass(frozen=True)
class Header:
    bits: int
    packet_bytes: int
    max_angle_deg: float
    max_segment_length: int
    sensors: tuple[Sensor, ...]


@dataclass
class SensorPoints:
    """The points of one sensor that arrived: ticks, codes, dequantised unit quaternions, and
    ``gap_before[k]`` = points were lost between point ``k - 1`` (or the stream's start) and point ``k``."""

    sensor: Sensor
    ticks: np.ndarray
    codes: np.ndarray
    values: np.ndarray
    gap_before: np.ndarray
    packets: int
    lost: list[int]
    ended: bool

    @property
    def samples(self) -> int | None:
        """Samples of the stream (last point's tick + 1) when its last packet arrived, else ``None``."""
        return int(self.ticks[-1]) + 1 if self.ended and len(self.ticks) else None


@dataclass(frozen=True)
class Damaged:
    """A packet dropped because its CRC does not match (or it is too short to hold one)."""

    index: int       # 0-based packet record of the file
    offset: int      # byte offset of its length byte
    length: int
    problem: str


@dataclass
class PacketFile:
    path: str
    header: Header
    streams: dict[str, SensorPoints]
    damaged: list[Damaged] = field(default_factory=list)

    def losses(self) -> list[str]:
        """One line per problem found: damaged packets, lost sequence numbers, missing stream ends."""
        lines = [f"{self.path}: packet {d.index} (byte {d.offset}, {d.length} bytes): {d.problem}; dropped"
                 for d in self.damaged]
        for name, s in self.streams.items():
            if s.lost:
                lines.append(f"{self.path}: {name}: lost packet sequence number{'s' * (len(s.lost) > 1)} "
                             f"{_ranges(s.lost)}")
            if not s.ended:
                last = "no packet arrived" if s.packets == 0 else "its last packet did not arrive"
                lines.append(f"{self.path}: {name}: the end of the stream is missing ({last})")
        return lines

    @property
    def lost_packets(self) -> int:
        """Sequence numbers known lost (each stream's missing end counts as one)."""
        return sum(len(s.lost) + (not s.ended) for s in self.streams.values())


def _ranges(seqs: list[int]) -> str:
    out, i = [], 0
    while i < len(seqs):
        j = i
        while j + 1 < len(seqs) and seqs[j + 1] == seqs[j] + 1:
            j += 1
        out.append(str(seqs[i]) if i == j else f"{seqs[i]}-{seqs[j]}")
        i = j + 1
    return ", ".join(out)


def header_problem(bits: int, packet_bytes: int, max_angle_deg: float, max_segment_length: int) -> str | None:
    """What is impossible in the file header's fixed fields (a field named, its value, the range), or ``None``."""
    if not MIN_BITS <= bits <= MAX_BITS:
        return f"{bits} bits per component, expected {MIN_BITS}..{MAX_BITS}"
    if not MIN_PACKET <= packet_bytes <= MAX_PACKET:
        return f"packets of {packet_bytes} bytes, expected {MIN_PACKET}..{MAX_PACKET}"
    if not (math.isfinite(max_angle_deg) and 0 < max_angle_deg < 180):
        return f"the bound {max_angle_deg!r} degrees is not a number of degrees in (0, 180)"
    if not math.radians(max_angle_deg) > delta_bound(bits):
        return (f"the bound {max_angle_deg!r} degrees is not above the quantisation bound "
                f"{math.degrees(delta_bound(bits)):.4g} degrees of {bits} bits (no sender makes it)")
    lo, hi = SEGMENT_LENGTH_RANGE
    if not lo <= max_segment_length <= hi:
        return f"maximum segment length {max_segment_length} samples, expected {lo}..{hi}"
    return None


def sensor_problem(name: str, rate: float, t0: float) -> str | None:
    """What is impossible in one sensor's header fields (rate, time of tick 0), or ``None``."""
    lo, hi = RATE_RANGE
    if not (math.isfinite(rate) and lo <= rate <= hi):
        return f"sensor {name!r}: rate {rate!r} Hz, expected {lo:g}..{hi:g} Hz"
    if not (math.isfinite(t0) and abs(t0) <= MAX_ABS):
        return f"sensor {name!r}: time of tick 0 {t0!r} s, expected a finite time within ±{MAX_ABS:g} s"
    return None


def clock_problem(sensor: Sensor, ticks: np.ndarray) -> str | None:
    """Whether the points' times on the sensor's nominal clock are what the text readers accept (within
    ±``MAX_ABS`` s, ``MIN_STEP`` apart): otherwise a points CSV written from them could not be read back."""
    if len(ticks) == 0:
        return None
    t = sensor.nominal_times(ticks)
    if not abs(float(t[-1])) <= MAX_ABS:
        return (f"sensor {sensor.name!r}: tick {int(ticks[-1])} at rate {sensor.rate!r} Hz from {sensor.t0!r} s "
                f"is at {float(t[-1])!r} s, beyond ±{MAX_ABS:g} s")
    step = np.diff(t)
    if len(step) and not step.min() >= MIN_STEP:
        k = int(np.argmin(step)) + 1
        return (f"sensor {sensor.name!r}: at rate {sensor.rate!r} Hz from {sensor.t0!r} s, tick {int(ticks[k])} is "
                f"{float(step[k - 1])!r} s after tick {int(ticks[k - 1])}, below {MIN_STEP:g} s (the clock cannot "
                "tell them apart)")
    return None


def header_bytes(header: Header) -> bytes:
    """The file header (CRC included)."""
    problem = header_problem(header.bits, header.packet_bytes, header.max_angle_deg, header.max_segment_length)
    if problem is None and not 1 <= len(header.sensors) <= 255:
        problem = "a packet file holds 1..255 sensors"
    for s in header.sensors:
        problem = problem or sensor_problem(s.name, s.rate, s.t0)
    if problem:
        raise ValueError(f"header: {problem}")
    out = bytearray(_FIXED.pack(MAGIC, VERSION, header.bits, header.packet_bytes, len(header.sensors),
                                float(header.max_angle_deg), int(header.max_segment_length)))
    for s in header.sensors:
        name = s.name.encode("utf-8")
        if not 1 <= len(name) <= 255:
            raise ValueError(f"sensor name {s.name!r}: 1..255 bytes of UTF-8")
        out += bytes([len(name)]) + name + _SENSOR.pack(float(s.rate), float(s.t0))
    out += struct.pack("<I", zlib.crc32(out))
    return bytes(out)


def mkp_bytes(header: Header, packets: list[bytes]) -> bytes:
    """The file's bytes: the header, then every packet as ``[length][bytes]`` in the order received."""
    out = bytearray(header_bytes(header))
    for p in packets:
        if not 1 <= len(p) <= MAX_PACKET:
            raise ValueError(f"a packet has 1..{MAX_PACKET} bytes, got {len(p)}")
        out += bytes([len(p)]) + p
    return bytes(out)


def _parse_header(data: bytes, where: str) -> tuple[Header, int]:
    if len(data) < _FIXED.size + 4:
        raise MocapFormatError(where, None, f"not a mocapkit packet file: {len(data)} bytes, shorter than its header")
    magic, version, bits, pbytes, n, angle, maxlen = _FIXED.unpack_from(data)
    if magic != MAGIC:
        raise MocapFormatError(where, None, f"not a mocapkit packet file (magic {magic!r}, expected {MAGIC!r})")
    if version != VERSION:
        raise MocapFormatError(
            where, None, f"packet format version {version} is not supported (this mocapkit reads {VERSION})"
        )
    pos = _FIXED.size
    sensors = []
    for i in range(n):
        if pos >= len(data):
            raise MocapFormatError(where, None, f"truncated header: sensor {i} of {n} is missing")
        k = data[pos]
        end = pos + 1 + k + _SENSOR.size
        if end > len(data):
            raise MocapFormatError(where, None, f"truncated header: sensor {i} of {n} is cut short")
        try:
            name = data[pos + 1:pos + 1 + k].decode("utf-8")
        except UnicodeDecodeError:
            name = None
        rate, t0 = _SENSOR.unpack_from(data, pos + 1 + k)
        sensors.append((name, k, rate, t0))
        pos = end
    if pos + 4 > len(data):
        raise MocapFormatError(where, None, "truncated header: its CRC is missing")
    (crc,) = struct.unpack_from("<I", data, pos)
    if zlib.crc32(data[:pos]) != crc:
        raise MocapFormatError(where, None, "the header's CRC-32 does not match (corrupt file)")
    # the fields, once the CRC says they are what the writer wrote
    problem = header_problem(bits, pbytes, angle, maxlen)
    if problem:
        raise MocapFormatError(where, None, f"header: {problem}")
    if n == 0:
        raise MocapFormatError(where, None, "header: no sensor")
    names = set()
    out = []
    for i, (name, k, rate, t0) in enumerate(sensors):
        if name is None or k == 0:
            raise MocapFormatError(where, None, f"header: sensor {i}'s name is not 1..255 bytes of UTF-8")
        if name in names:
            raise MocapFormatError(where, None, f"header: sensor name {name!r} repeats")
        problem = sensor_problem(name, rate, t0)
        if problem:
            raise MocapFormatError(where, None, f"header: {problem}")
        names.add(name)
        out.append(Sensor(name, rate, t0))
    return Header(bits, pbytes, angle, maxlen, tuple(out)), pos + 4


@dataclass
class _Packet:
    sensor: int
    seq: int
    last: bool
    ticks: list[int]
    codes: list[tuple[int, int, int, int]]


def _varint_bytes(data: bytes, pos: int, end: int, what: str) -> tuple[int, int]:
    v, shift = 0, 0
    for k in range(5):
        if pos >= end:
            raise ValueError(f"{what} runs past the packet")
        b = data[pos]
        pos += 1
        v |= (b & 0x7F) << shift
        shift += 7
        if not b & 0x80:
            if k and b == 0:
                raise ValueError(f"{what} is not in its shortest form")
            if v >= TICK_LIMIT:
                raise ValueError(f"{what} {v} does not fit 32 bits")
            return v, pos
    raise ValueError(f"{what} is longer than 5 bytes")


def parse_packet(pkt: bytes, bits: int) -> _Packet:
    """One packet whose CRC matched; ``ValueError`` says what is impossible in it."""
    end = len(pkt) - 2
    if end < 5:
        raise ValueError(f"{len(pkt)} bytes cannot hold a packet")
    sensor = pkt[0]
    seq = pkt[1] | pkt[2] << 8
    first, pos = _varint_bytes(pkt, 3, end, "the first tick")
    if pos >= end:
        raise ValueError("the count byte is missing")
    count_byte = pkt[pos]
    pos += 1
    n, last = count_byte & 0x7F, bool(count_byte & LAST)
    if n == 0 and not last:
        raise ValueError("a packet without points that is not the last")
    stream = int.from_bytes(pkt[pos:end], "big")
    total = 8 * (end - pos)
    used = 0

    def take(k: int) -> int:
        nonlocal used
        if used + k > total:
            raise ValueError(f"the bitstream ends inside point {len(ticks)} of {n}")
        used += k
        return (stream >> (total - used)) & ((1 << k) - 1)

    ticks, codes = [], []
    tick = first
    for i in range(n):
        if i:
            v, shift = 0, 0
            for k in range(6):
                if k == 5:
                    raise ValueError(f"point {i}: its tick delta is longer than 5 bytes")
                b = take(8)
                v |= (b & 0x7F) << shift
                shift += 7
                if not b & 0x80:
                    if k and b == 0:
                        raise ValueError(f"point {i}: its tick delta is not in its shortest form")
                    break
            if v == 0:
                raise ValueError(f"point {i}: tick delta 0 (ticks must increase)")
            tick += v
            if tick >= TICK_LIMIT:
                raise ValueError(f"point {i}: tick {tick} does not fit 32 bits")
        ticks.append(tick)
        codes.append((take(2), take(bits), take(bits), take(bits)))
    pad = total - used
    if pad >= 8:
        raise ValueError(f"{pad // 8} bytes after the last point")
    if stream & ((1 << pad) - 1):
        raise ValueError("non-zero padding bits after the last point")
    return _Packet(sensor, seq, last, ticks, codes)


class _Stream(TypedDict):
    """What :func:`decode_mkp` gathers of one sensor while it reads the packets."""

    ticks: list[int]
    codes: list[tuple[int, int, int, int]]
    gap: list[bool]
    packets: int
    lost: list[int]
    ended: bool
    seq: int | None
    last_tick: int


def decode_mkp(data: bytes, where: str) -> PacketFile:
    """Decode a ``.mkp`` file's bytes: every sensor's points that arrived, the damaged and lost packets;
    ``where`` (the file's path, or any label) names the file in errors."""
    header, pos = _parse_header(data, where)
    bits = header.bits
    m = (1 << bits) - 1
    h2 = half_step(bits) ** 2
    acc: list[_Stream] = [{"ticks": [], "codes": [], "gap": [], "packets": 0, "lost": [], "ended": False, "seq": None,
            "last_tick": -1} for _ in header.sensors]
    damaged: list[Damaged] = []
    index = 0
    while pos < len(data):
        off = pos
        length = data[pos]
        pos += 1
        if pos + length > len(data):  # a receiver's log cut short (power lost): the packets before it stand
            damaged.append(Damaged(index, off, len(data) - pos, f"cut short: the file ends inside it ({length} bytes "
                                                               f"declared, {len(data) - pos} present)"))
            break
        pkt = data[pos:pos + length]
        pos += length
        here = f"packet {index} (byte {off})"
        if length < 7:
            damaged.append(Damaged(index, off, length, f"{length} bytes, too short for a packet"))
        elif crc16(pkt[:-2]) != (pkt[-2] | pkt[-1] << 8):
            damaged.append(Damaged(index, off, length, "CRC-16 does not match"))
        else:
            try:
                p = parse_packet(pkt, bits)
            except ValueError as e:
                raise MocapFormatError(where, None, f"{here}: {e}") from None
            if p.sensor >= len(header.sensors):
                raise MocapFormatError(where, None, f"{here}: sensor id {p.sensor}, the header lists "
                                                    f"{len(header.sensors)}")
            a = acc[p.sensor]
            name = header.sensors[p.sensor].name
            if a["ended"]:
                raise MocapFormatError(where, None, f"{here}: {name}: a packet after the stream's last one")
            if a["seq"] is None:
                missing = p.seq
                if p.seq == 0 and p.ticks and p.ticks[0] != 0:
                    raise MocapFormatError(
                        where, None, f"{here}: {name}: sequence 0 starts at tick {p.ticks[0]}, not 0"
                    )
            else:
                missing = (p.seq - a["seq"] - 1) & 0xFFFF
                if missing >= 0x8000:
                    raise MocapFormatError(where, None, f"{here}: {name}: sequence number {p.seq} repeats or goes "
                                                        f"back (after {a['seq']})")
            a["lost"].extend((p.seq - missing + k) & 0xFFFF for k in range(missing))
            if p.ticks and p.ticks[0] <= a["last_tick"]:
                raise MocapFormatError(where, None, f"{here}: {name}: tick {p.ticks[0]} is not after tick "
                                                    f"{a['last_tick']} of the previous packet")
            for k, (t, c) in enumerate(zip(p.ticks, p.codes, strict=False)):
                s = sum((2 * x - m) ** 2 for x in c[1:]) * h2
                if s > 1.0:
                    raise MocapFormatError(where, None, f"{here}: point {k}: its codes lie outside the unit sphere")
                a["ticks"].append(t)
                a["codes"].append(c)
                a["gap"].append(k == 0 and missing > 0)
                a["last_tick"] = t
            a["seq"] = p.seq
            a["packets"] += 1
            a["ended"] = p.last
        index += 1
    streams = {}
    for sensor, a in zip(header.sensors, acc, strict=True):
        problem = clock_problem(sensor, np.array(a["ticks"], dtype=np.int64))
        if problem:
            raise MocapFormatError(where, None, f"header: {problem}")
        codes = np.array(a["codes"], dtype=np.int64).reshape(-1, 4)
        streams[sensor.name] = SensorPoints(
            sensor, np.array(a["ticks"], dtype=np.int64), codes, dequantise(codes, bits),
            np.array(a["gap"], dtype=bool), a["packets"], a["lost"], a["ended"])
    return PacketFile(where, header, streams, damaged)
