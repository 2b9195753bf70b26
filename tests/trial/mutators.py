"""Mutations of a seed file's bytes, each with what a correct reader may do with the result.

Every mutator takes ``(data: bytes, rng: random.Random, fmt: str)`` and returns a :class:`Mutation` or
``None`` (not applicable). ``expect`` says what the oracle may accept on exit 0:

- ``"refuse"``: the mutation changed a number into something no format writes (``0_5``, ``inf``,
  ``1e308``...): a reader may refuse it, warn, or ignore the field (then the data read are unchanged);
  returning *different* data without a word is wrong-but-silent;
- ``"truncated"``: the file was cut inside its last line: the data read must equal those of the file
  cut at the end of that line (the line whole), unless the reader warns or refuses;
- ``"any"``: a legitimate value or a structural change; only crashes, hangs, invalid output count.
"""

from __future__ import annotations

import random
import re
from dataclasses import dataclass, field

from .seeds import GAP_SPELLINGS

NUMBER = re.compile(rb"(?<![\w.+-])[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?(?![\w.])")

#: tokens no motion file writes as a number: a correct reader refuses them (or ignores the field)
INVALID_TOKENS = ["nan", "NaN", "inf", "-inf", "Infinity", "1e308", "-1e308", "1e999", "0_5", "1_000",
                  "9" * 400, "-" + "9" * 400, "0x10", "1e", "--1", "1.2.3", ""]
#: legitimate but extreme numbers: reading them is fine, the output must still be finite and valid
EXTREME_TOKENS = ["1e-320", "0", "-0", "1e11", "-1e11", "0." + "1" * 400, "1e-300", "4.9e-324"]


@dataclass
class Mutation:
    kind: str
    data: bytes
    expect: str = "any"  # "refuse" | "truncated" | "any"
    detail: dict = field(default_factory=dict)


def _numbers(data: bytes) -> list[re.Match]:
    return list(NUMBER.finditer(data))


def replace_token(data: bytes, rng: random.Random, fmt: str, token: str | None = None,
                  where: str = "any") -> Mutation | None:
    """One number replaced by ``token`` (an invalid or extreme spelling)."""
    nums = _numbers(data)
    if not nums:
        return None
    if where == "tail":  # the data block, where values are read
        nums = nums[len(nums) // 2:]
    m = rng.choice(nums)
    if token is None:
        token = rng.choice(INVALID_TOKENS + EXTREME_TOKENS)
    invalid = token in INVALID_TOKENS and token not in GAP_SPELLINGS.get(fmt, set())
    if token == "" and fmt in ("imu", "points"):  # a trailing empty cell may be a legitimate short row
        invalid = False
    new = data[:m.start()] + token.encode() + data[m.end():]
    line = data.count(b"\n", 0, m.start()) + 1
    return Mutation("token", new, "refuse" if invalid else "any",
                    {"line": line, "old": m.group().decode(), "new": token[:50]})


def truncate(data: bytes, rng: random.Random, fmt: str, at: int | None = None) -> Mutation:
    """The file cut at a random byte (or at ``at``)."""
    if at is None:
        at = rng.randrange(1, max(2, len(data)))
    new = data[:at]
    end = data.find(b"\n", at)
    complete = data if end < 0 else data[:end + 1]
    line = data.count(b"\n", 0, at) + 1
    mid_line = at > 0 and data[at - 1:at] != b"\n"
    return Mutation("truncate", new, "truncated" if mid_line else "any",
                    {"at": at, "line": line, "complete": complete})


def truncate_in_last_number(data: bytes, rng: random.Random, fmt: str) -> Mutation | None:
    """The file cut inside the last number of the file (``-0.124044`` -> ``-0.12``)."""
    nums = [m for m in _numbers(data) if len(m.group()) >= 3]
    if not nums:
        return None
    m = nums[-1]
    at = rng.randrange(m.start() + 1, m.end())
    return truncate(data, rng, fmt, at)


def lines_edit(data: bytes, rng: random.Random, fmt: str) -> Mutation | None:
    """A line duplicated, deleted or swapped with the next one."""
    lines = data.split(b"\n")
    if len(lines) < 3:
        return None
    i = rng.randrange(len(lines) - 1)
    op = rng.choice(["dup", "del", "swap"])
    if op == "dup":
        lines.insert(i, lines[i])
    elif op == "del":
        del lines[i]
    else:
        lines[i], lines[i + 1] = lines[i + 1], lines[i]
    return Mutation("lines", b"\n".join(lines), "any", {"op": op, "line": i + 1})


def byte_flips(data: bytes, rng: random.Random, fmt: str) -> Mutation:
    """1-8 random bytes replaced by random values (NUL, non-UTF-8, anything)."""
    b = bytearray(data)
    n = rng.randint(1, 8)
    pos = []
    for _ in range(n):
        i = rng.randrange(len(b))
        b[i] = rng.choice([0, 0xFF, 0xC3, 0x80, rng.randrange(256)])
        pos.append(i)
    return Mutation("bytes", bytes(b), "any", {"positions": pos[:8]})


def insert_bytes(data: bytes, rng: random.Random, fmt: str) -> Mutation:
    """NUL bytes, a lone UTF-8 lead byte, Latin-1 or a BOM in the middle of a line."""
    chunk = rng.choice([b"\x00", b"\x00" * 64, b"\xff\xfe", b"\xc3", b"\xe9", b"\xef\xbb\xbf", b"\r", b"\t\t"])
    i = rng.randrange(len(data) + 1)
    return Mutation("insert", data[:i] + chunk + data[i:], "any", {"at": i, "chunk": chunk.hex()})


#: header fields that state a count or a size, per format
_INFLATE = [
    (rb"(NO_OF_MARKERS\s+)\d+", b"1000000000"), (rb"(NO_OF_FRAMES\s+)\d+", b"1000000000"),
    (rb"(NO_OF_ANALOG\s+)\d+", b"1000000000"), (rb"(Frames:\s*)\d+", b"1000000000"),
    (rb"(Frames:\s*)\d+", b"1e9"), (rb"(Frame Time:\s*)[\d.eE+-]+", b"1e-320"),
    (rb"(Frame Time:\s*)[\d.eE+-]+", b"0"), (rb"(NumFrames\s*)\d+", b"1000000000"),
    (rb"(NumMarkers\s*)\d+", b"1000000000"), (rb"(nRows\s*=\s*)\d+", b"1000000000"),
    (rb"(nColumns\s*=\s*)\d+", b"1000000000"), (rb"(datarows\s+)\d+", b"1000000000"),
    (rb"(datacolumns\s+)\d+", b"1000000000"), (rb"(FREQUENCY\s+)[\d.]+", b"1e-320"),
    (rb"(DataRate\s+)[\d.]+", b"0"), (rb"(Sample Rate:,\s*)[\d.]+", b"1e308"),
    (rb"(segmentCount=\")\d+", b"1000000000"), (rb"(frameRate=\")\d+", b"0"),
]


def inflate_header(data: bytes, rng: random.Random, fmt: str) -> Mutation | None:
    """A header count or rate set to an absurd value (``NO_OF_MARKERS 1000000000``, ``Frames: 1e9``)."""
    options = [(pat, val) for pat, val in _INFLATE if re.search(pat, data)]
    if not options:
        return None
    pat, val = rng.choice(options)
    new = re.sub(pat, lambda m: m.group(1) + val, data, count=1)
    return Mutation("inflate", new, "any", {"field": pat.decode()[:30], "value": val.decode()})


def inflate_c3d(data: bytes, rng: random.Random, fmt: str) -> Mutation | None:
    """C3D header words (point count, first/last frame, analog count) set to large values."""
    if len(data) < 512:
        return None
    b = bytearray(data)
    word = rng.choice([1, 2, 3, 4, 5, 8, 9])  # 16-bit words of the header (1-based)
    value = rng.choice([0, 1, 0x7FFF, 0xFFFF, 0x8000])
    i = 2 * (word - 1)
    b[i:i + 2] = value.to_bytes(2, "little")
    return Mutation("inflate", bytes(b), "any", {"header_word": word, "value": value})


TEXT_MUTATORS = {
    "token": replace_token, "truncate": truncate, "truncate_number": truncate_in_last_number,
    "lines": lines_edit, "bytes": byte_flips, "insert": insert_bytes, "inflate": inflate_header,
}
BINARY_MUTATORS = {"truncate": truncate, "bytes": byte_flips, "insert": insert_bytes, "inflate": inflate_c3d}


def mutate(data: bytes, rng: random.Random, fmt: str, binary: bool, kind: str | None = None) -> Mutation | None:
    table = BINARY_MUTATORS if binary else TEXT_MUTATORS
    kind = kind or rng.choice(sorted(table))
    if kind not in table:
        return None
    return table[kind](data, rng, fmt)
