"""One block of a clip as bytes: key positions and grid integers, predicted and varint-coded, then an
entropy stage.

Layout of a block's payload before the entropy stage (every number a LEB128 varint; signed numbers
zigzag-mapped), for the ``T`` animated tracks of the clip in track-table order:

1. per track: ``2·level + (order − 1)`` and ``K``, the number of keys in the block. The track's grid
   step in this block is ``base_step · 2^(−level/2)`` (:func:`level_step`); ``order`` is the predictor.
2. per track: the ``K − 2`` interior key positions as gaps ``f_i − f_{i−1} − 1`` (the first key is the
   block's first frame and the last key its last frame).
3. per track, per component: the ``K`` grid integers as residuals: the first value itself, then
   ``q_i − pred_i`` with ``pred_i = q_{i−1}`` (order 1) or, from the second key on, the linear
   extrapolation in time ``q_{i−1} + ⌊(q_{i−1} − q_{i−2})·(f_i − f_{i−1})/(f_{i−1} − f_{i−2}) + ½⌋``
   (order 2).

The entropy stage, per block: stored (0), a zstd frame (1) or a raw LZMA2 stream (2, preset 6: 8 MiB
dictionary, lc 3, lp 0, pb 2) — zstd by default (fast to decode), LZMA2 or the smallest on request.
"""

from __future__ import annotations

import lzma
import math

import numba
import numpy as np

from mocapkit.errors import MocapFormatError
from mocapkit.rotvec import exp_into

CODEC_STORED, CODEC_ZSTD, CODEC_LZMA = 0, 1, 2
_LZMA_FILTERS = [{"id": lzma.FILTER_LZMA2, "preset": 6}]  # fixed: raw LZMA2 streams carry no filter properties
MAX_LEVEL = 120  # steps down to 2^-60 of the base step
SQRT_HALF = 0.7071067811865476
LIMIT = 2**52  # grid integers and residuals beyond are refused (exact in float64)


def level_step(base: float, level: int) -> float:
    """The grid step of a track at ``level`` (√2 finer per level); the encoder and the decoder both
    call this, so they agree to the last bit."""
    s = math.ldexp(base, -(level >> 1))
    return s * SQRT_HALF if level & 1 else s


@numba.njit(cache=True, nogil=True)
def _put(buf, pos, v):
    while v >= 128:
        buf[pos] = (v & 127) | 128
        v >>= 7
        pos += 1
    buf[pos] = v
    return pos + 1


@numba.njit(cache=True, nogil=True)
def _zig(v):
    return 2 * v if v >= 0 else -2 * v - 1


@numba.njit(cache=True, nogil=True)
def _pred(q, f, i, c, order):
    if i == 0:
        return 0
    if i == 1 or order == 1:
        return q[i - 1, c]
    d = q[i - 1, c] - q[i - 2, c]
    return q[i - 1, c] + math.floor(d * ((f[i] - f[i - 1]) / (f[i - 1] - f[i - 2])) + 0.5)


@numba.njit(cache=True)
def residual_cost(f, q, order):
    """Estimated bits of a track's residuals with a predictor order (Σ log2(1 + |r|))."""
    K, D = q.shape
    s = 0.0
    for c in range(D):
        for i in range(1, K):
            s += math.log2(1.0 + abs(q[i, c] - _pred(q, f, i, c, order)))
    return s


@numba.njit(cache=True)
def _pack(n, codes, Ks, f_flat, q_flat, dims):
    T = Ks.shape[0]
    total = 0
    for t in range(T):
        total += Ks[t] * (1 + dims[t])
    buf = np.empty(20 * (total + 2 * T) + 16, np.uint8)
    pos = 0
    for t in range(T):
        pos = _put(buf, pos, codes[t])
        pos = _put(buf, pos, Ks[t])
    fo = 0
    for t in range(T):
        K = Ks[t]
        for i in range(1, K - 1):
            pos = _put(buf, pos, f_flat[fo + i] - f_flat[fo + i - 1] - 1)
        fo += K
    fo = 0
    qo = 0
    for t in range(T):
        K, D = Ks[t], dims[t]
        f = f_flat[fo:fo + K]
        q = q_flat[qo:qo + K * D].reshape(K, D)
        order = (codes[t] & 1) + 1
        for c in range(D):
            for i in range(K):
                pos = _put(buf, pos, _zig(q[i, c] - _pred(q, f, i, c, order)))
        fo += K
        qo += K * D
    return buf[:pos].copy()


@numba.njit(cache=True, nogil=True)
def _get(buf, pos):
    v = 0
    shift = 0
    while True:
        if pos >= buf.shape[0] or shift > 56:
            return -1, -1
        b = buf[pos]
        v |= (b & 127) << shift
        pos += 1
        if b < 128:
            return v, pos
        shift += 7


@numba.njit(cache=True, nogil=True)
def _parse(buf, n, dims, steps_table):
    """A payload's keys: ``(error, K per track, key offsets, key frames, grid integers (flat, K·D a
    track), step per track)``; error 0, or 1 truncated/malformed, 2 bad count, 3 bad key position,
    4 bad level, 5 trailing bytes, 6 value out of range."""
    T = dims.shape[0]
    codes = np.empty(T, np.int64)
    Ks = np.zeros(T, np.int64)
    fo = np.zeros(T + 1, np.int64)
    qo = np.zeros(T + 1, np.int64)
    steps = np.empty(T)
    fs = np.empty(0, np.int64)
    qs = np.empty(0, np.int64)
    pos = 0
    for t in range(T):
        v, pos = _get(buf, pos)
        if v < 0:
            return 1, Ks, fo, fs, qo, qs, steps
        codes[t] = v
        v, pos = _get(buf, pos)
        if v < 0:
            return 1, Ks, fo, fs, qo, qs, steps
        if v < min(n, 2) or v > n:
            return 2, Ks, fo, fs, qo, qs, steps
        Ks[t] = v
        if (codes[t] >> 1) >= steps_table.shape[1]:
            return 4, Ks, fo, fs, qo, qs, steps
        steps[t] = steps_table[t, codes[t] >> 1]
        fo[t + 1] = fo[t] + Ks[t]
        qo[t + 1] = qo[t] + Ks[t] * dims[t]
    fs = np.empty(fo[T], np.int64)
    qs = np.empty(qo[T], np.int64)
    for t in range(T):
        K = Ks[t]
        f = fs[fo[t]:fo[t + 1]]
        f[0] = 0
        for i in range(1, K - 1):
            v, pos = _get(buf, pos)
            if v < 0:
                return 1, Ks, fo, fs, qo, qs, steps
            f[i] = f[i - 1] + 1 + v
            if f[i] >= n - 1:
                return 3, Ks, fo, fs, qo, qs, steps
        if K > 1:
            f[K - 1] = n - 1
    for t in range(T):
        K, D = Ks[t], dims[t]
        f = fs[fo[t]:fo[t + 1]]
        order = (codes[t] & 1) + 1
        q = qs[qo[t]:qo[t + 1]].reshape(K, D)
        ratio = np.empty(K)  # the extrapolation factor of _pred, once per key
        for i in range(2, K):
            ratio[i] = (f[i] - f[i - 1]) / (f[i - 1] - f[i - 2])
        for c in range(D):
            for i in range(K):
                v, pos = _get(buf, pos)
                if v < 0:
                    return 1, Ks, fo, fs, qo, qs, steps
                r = (v >> 1) if (v & 1) == 0 else -((v + 1) >> 1)
                if i == 0:
                    p = 0
                elif i == 1 or order == 1:
                    p = q[i - 1, c]
                elif ratio[i] == 1.0:  # equal gaps: _pred's value, in integers (|d| < 2^53 is exact)
                    p = 2 * q[i - 1, c] - q[i - 2, c]
                else:  # = _pred: the same operations
                    p = q[i - 1, c] + math.floor((q[i - 1, c] - q[i - 2, c]) * ratio[i] + 0.5)
                    if abs(p) > LIMIT:
                        return 6, Ks, fo, fs, qo, qs, steps
                if abs(r) > LIMIT:
                    return 6, Ks, fo, fs, qo, qs, steps
                q[i, c] = p + r
                if abs(q[i, c]) > LIMIT:
                    return 6, Ks, fo, fs, qo, qs, steps
    if pos != buf.shape[0]:
        return 5, Ks, fo, fs, qo, qs, steps
    return 0, Ks, fo, fs, qo, qs, steps


@numba.njit(cache=True, nogil=True)
def _unpack(buf, n, dims, steps_table, out):
    """Decode a payload into ``out`` (n, ΣD): ``y = y_a + (y_b − y_a)·(t − a)/(b − a)`` between keys;
    returns :func:`_parse`'s error code."""
    err, Ks, fo, fs, qo, qs, steps = _parse(buf, n, dims, steps_table)
    if err:
        return err
    col = 0
    ya = np.empty(8)
    dy = np.empty(8)
    for t in range(dims.shape[0]):
        K, D = Ks[t], dims[t]
        f = fs[fo[t]:fo[t + 1]]
        q = qs[qo[t]:qo[t + 1]].reshape(K, D)
        step = steps[t]
        for s in range(K - 1):
            a, b = f[s], f[s + 1]
            for c in range(D):
                ya[c] = q[s, c] * step
                dy[c] = q[s + 1, c] * step - ya[c]
                out[a, col + c] = ya[c]
            for tt in range(a + 1, b):
                w = (tt - a) / (b - a)
                for c in range(D):
                    out[tt, col + c] = ya[c] + dy[c] * w
        for c in range(D):
            out[f[K - 1], col + c] = q[K - 1, c] * step
        col += D
    return 0


@numba.njit(cache=True, nogil=True)
def _unpack_pose(buf, n, dims, steps_table, joints, is_rot, rest_rot, rest_trans, rot, trans):
    """Decode a payload straight into poses (``rot`` (n, J, 4), ``trans`` (n, J, 3)): the rest pose, then
    every animated track's values — the same numbers as :func:`_unpack` — as translations or, through
    :func:`~mocapkit.rotvec.exp_into`, rotations. Returns :func:`_parse`'s error code."""
    err, Ks, fo, fs, qo, qs, steps = _parse(buf, n, dims, steps_table)
    if err:
        return err
    J = rest_rot.shape[0]
    for f in range(n):
        for j in range(J):
            for a in range(4):
                rot[f, j, a] = rest_rot[j, a]
            for a in range(3):
                trans[f, j, a] = rest_trans[j, a]
    y = np.empty(3)
    for t in range(dims.shape[0]):
        K = Ks[t]
        f = fs[fo[t]:fo[t + 1]]
        q = qs[qo[t]:qo[t + 1]].reshape(K, 3)
        step = steps[t]
        j = joints[t]
        for s in range(K):  # frames f[s] .. f[s+1] − 1, and the last key's frame
            a = f[s]
            b = f[s + 1] if s + 1 < K else a + 1
            for tt in range(a, b):
                for c in range(3):
                    ya = q[s, c] * step
                    if tt == a:
                        y[c] = ya
                    else:  # the same operations as _unpack
                        y[c] = ya + (q[s + 1, c] * step - ya) * ((tt - a) / (b - a))
                if is_rot[t]:
                    exp_into(y[0], y[1], y[2], rot[tt, j])
                else:
                    trans[tt, j, 0] = y[0]
                    trans[tt, j, 1] = y[1]
                    trans[tt, j, 2] = y[2]
    return 0


_ERRORS = {1: "the block's data end early or hold a malformed number", 2: "a track's key count is impossible",
           3: "a key lies outside its block", 4: "a track's grid level is out of range",
           5: "the block has bytes after its last number", 6: "a grid value is out of range"}


def pack_block(n: int, tracks: list[tuple[int, int, np.ndarray, np.ndarray]]) -> bytes:
    """``tracks``: per animated track ``(level, order, frames (K,), grid integers (K, D))`` -> payload."""
    codes = np.array([2 * lv + (order - 1) for lv, order, _, _ in tracks], dtype=np.int64)
    Ks = np.array([len(f) for _, _, f, _ in tracks], dtype=np.int64)
    dims = np.array([q.shape[1] for _, _, _, q in tracks], dtype=np.int64)
    f_flat = np.concatenate([f for _, _, f, _ in tracks]).astype(np.int64) if tracks else np.zeros(0, np.int64)
    q_flat = np.concatenate([q.ravel() for _, _, _, q in tracks]).astype(np.int64) if tracks else np.zeros(0, np.int64)
    return _pack(n, codes, Ks, f_flat, q_flat, dims).tobytes()


def steps_table(base_steps: np.ndarray) -> np.ndarray:
    """``(T, MAX_LEVEL + 1)`` every track's step at every level, the same operations as
    :func:`level_step` (``ldexp`` then one multiplication), vectorised."""
    lv = np.arange(MAX_LEVEL + 1)
    b = np.asarray(base_steps, dtype=np.float64).reshape(-1, 1)
    s = np.ldexp(b, -(lv >> 1))
    return np.where(lv & 1, s * SQRT_HALF, s)


def unpack_pose(payload: bytes, n: int, table: np.ndarray, joints: np.ndarray, is_rot: np.ndarray,
                rest_rot: np.ndarray, rest_trans: np.ndarray, rot: np.ndarray, trans: np.ndarray, where: str) -> None:
    """Payload (3 values a track) -> the block's poses written into ``rot`` (n, J, 4) / ``trans`` (n, J, 3)."""
    dims = np.full(joints.shape[0], 3, dtype=np.int64)
    code = _unpack_pose(np.frombuffer(payload, dtype=np.uint8), n, dims, table, joints, is_rot, rest_rot, rest_trans,
                        rot, trans)
    if code:
        raise MocapFormatError(where, None, _ERRORS[code])


def unpack_block(payload: bytes, n: int, dims: np.ndarray, table: np.ndarray, where: str) -> np.ndarray:
    """Payload -> ``(n, ΣD)`` decoded track values of the block; errors name ``where`` (file, block)."""
    out = np.empty((n, int(dims.sum())))
    code = _unpack(np.frombuffer(payload, dtype=np.uint8), n, dims.astype(np.int64), table, out)
    if code:
        raise MocapFormatError(where, None, _ERRORS[code])
    return out


ENTROPY = ("zstd", "lzma", "smallest")
ZSTD_LEVEL = 15  # on 86_01 the smallest of levels 9..22 and 4× faster than 19


def entropy_encode(payload: bytes, entropy: str = "zstd") -> bytes:
    """The payload through zstd (fast to decode), LZMA2 (a few % smaller, ~10× slower to decode) or
    the ``"smallest"`` of those and stored, prefixed by its codec byte. Stored when that is smaller."""
    import zstandard

    best = bytes([CODEC_STORED]) + payload
    if entropy in ("zstd", "smallest"):
        z = bytes([CODEC_ZSTD]) + zstandard.ZstdCompressor(level=ZSTD_LEVEL).compress(payload)
        if len(z) < len(best):
            best = z
    if entropy in ("lzma", "smallest"):
        x = bytes([CODEC_LZMA]) + lzma.compress(payload, format=lzma.FORMAT_RAW, filters=_LZMA_FILTERS)
        if len(x) < len(best):
            best = x
    return best


def entropy_decode(data: bytes, raw_length: int, where: str) -> bytes:
    """Undo :func:`entropy_encode`; the result must be exactly ``raw_length`` bytes."""
    if not data:
        raise MocapFormatError(where, None, "empty block")
    codec, body = data[0], data[1:]
    try:
        if codec == CODEC_STORED:
            out = bytes(body)
        elif codec == CODEC_ZSTD:
            import zstandard

            size = zstandard.frame_content_size(body)
            if size != raw_length:
                raise MocapFormatError(where, None, f"the zstd frame declares {size} bytes, not {raw_length}")
            out = zstandard.ZstdDecompressor().decompress(body)
        elif codec == CODEC_LZMA:
            d = lzma.LZMADecompressor(format=lzma.FORMAT_RAW, filters=_LZMA_FILTERS)
            out = d.decompress(body, max_length=raw_length + 1)
        else:
            raise MocapFormatError(where, None, f"unknown entropy codec {codec}")
    except (lzma.LZMAError, ValueError, EOFError) as e:
        raise MocapFormatError(where, None, f"the block does not decompress: {e}") from None
    except Exception as e:  # zstandard.ZstdError
        if type(e).__name__ == "ZstdError":
            raise MocapFormatError(where, None, f"the block does not decompress: {e}") from None
        raise
    if len(out) != raw_length:
        raise MocapFormatError(where, None, f"the block decompresses to {len(out)} bytes, not {raw_length}")
    return out
