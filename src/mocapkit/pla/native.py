"""The C encoders of ``c/mkpla`` from Python (cffi): one streaming encoder of any method.

``precision="float64"`` runs the build that performs the Python kernels' operations in their order
(the same points bit for bit); ``"float32"`` runs the build a sensor runs (``MKPLA_FLOAT32``), fed
values rounded to float32 and times as a sensor's 32-bit tick counter (:func:`sensor_ticks`: ``tick``
seconds per tick, counted from ``epoch``, wrapping at 2^32), exactly as a sensor would be.
Quaternion streams are made hemisphere-continuous inside C (as :func:`mocapkit.quat.hemisphere_continuous`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from mocapkit.errors import InvalidParameterError, InvalidSignalError

#: method name -> the C library's method code (mkpla.h)
METHOD_CODES = {"fastsw": 0, "sw": 1, "cplr": 2, "swing": 3, "anglesw": 4}
#: widest sample of the binding (c/mkpla_cffi.py MAX_DIM)
MAX_DIM = 16
#: largest maximum segment length whose buffer (SW, anglesw) is allocated up front for C
MAX_BUFFERED = 1 << 20

C_ERRORS = {
    -1: "bad dimension, method, threshold or maximum segment length",
    -2: "buffer too small for the maximum segment length",
    -3: "time is not after the previous time",
    -4: "zero-norm quaternion (or one whose squared norm is subnormal or overflows)",
    -5: "push after flush",
    -7: "NaN or infinite value",
}

#: the float32 build's default tick: a microsecond timer
DEFAULT_TICK = 1e-6


def sensor_ticks(t: np.ndarray, epoch: float, tick: float = DEFAULT_TICK) -> np.ndarray:
    """Times in seconds as the float32 build takes them: ``round((t - epoch) / tick)`` modulo 2^32 (uint32).

    The encoder uses only tick differences within a segment, so the epoch and the counter's wrapping
    do not change its decisions.
    """
    k = np.rint((np.asarray(t, dtype=np.float64) - epoch) / tick)
    return (k.astype(np.int64) & 0xFFFFFFFF).astype(np.uint32)


def _module(precision: str):
    if precision == "float64":
        import mocapkit._mkpla64 as mod
    elif precision == "float32":
        import mocapkit._mkpla32 as mod
    else:
        raise InvalidParameterError(f"precision must be 'float64' or 'float32', got {precision!r}")
    return mod


def available() -> bool:
    """Whether the compiled bindings are importable (they are built by ``pip install``)."""
    try:
        _module("float64")
        _module("float32")
    except ImportError:
        return False
    return True


def supports(method: str, dim: int, maxlen: int) -> bool:
    """Whether :class:`NativeEncoder` takes this configuration (else the numba kernels do)."""
    buffered = method in ("sw", "anglesw")
    return method in METHOD_CODES and 1 <= dim <= MAX_DIM and (not buffered or 1 <= maxlen <= MAX_BUFFERED)


class Points(NamedTuple):
    """Segment points as arrays: sample indices, times (as pushed) and values."""

    indices: np.ndarray
    times: np.ndarray
    values: np.ndarray


class NativeEncoder:
    """A C encoder. ``threshold`` is the kernel's (radians for anglesw); ``maxlen`` 0 = unbounded.

    C refuses a NaN or infinite time or value, a time not after the previous one and a zero
    quaternion (:class:`~mocapkit.errors.InvalidSignalError`; the encoder stays as it was, so the next
    sample may follow); :class:`mocapkit.pla.Encoder` checks more and gives fuller messages.
    float32: times become ticks (:func:`sensor_ticks`) of ``tick`` seconds from ``epoch`` (default:
    the first sample), and the points' times are those ticks.
    """

    def __init__(self, method: str, threshold: float, dim: int, quaternion: bool, maxlen: int,
                 precision: str = "float64", tick: float = DEFAULT_TICK, epoch: float | None = None):
        if not supports(method, dim, maxlen):
            raise InvalidParameterError(f"the C encoders take methods {', '.join(METHOD_CODES)} up to dimension "
                                        f"{MAX_DIM} (SW/anglesw with a maximum segment length 1..{MAX_BUFFERED})")
        mod = _module(precision)
        self._ffi, self._lib = mod.ffi, mod.lib
        self.precision = precision
        self._dtype = np.float64 if precision == "float64" else np.float32
        self.dim = dim
        self._enc = self._ffi.new("mkpla_encoder *")
        if method == "sw":
            n_buf = maxlen * (dim + 1)
        elif method == "anglesw":
            n_buf = maxlen * 5
        else:
            n_buf = 0
        self._buffer = np.zeros(max(n_buf, 1), dtype=self._dtype)  # kept alive with the encoder
        rc = self._lib.mkpla_encoder_init(self._enc, METHOD_CODES[method], dim, 1 if quaternion else 0,
                                          float(threshold), maxlen, self._ptr(self._buffer), n_buf)
        if rc != 0:
            raise InvalidParameterError(f"C encoder: {C_ERRORS.get(rc, rc)}")
        self._pt = self._ffi.new("mkpla_point *")
        self._x = self._ffi.new("mkpla_real[]", dim)
        self._tick = float(tick)
        if not (self._tick > 0 and math.isfinite(self._tick)):
            raise InvalidParameterError(f"tick must be a positive number of seconds, got {tick!r}")
        self._t0: float | None = epoch
        self._count = 0

    def _ptr(self, a: np.ndarray):
        return self._ffi.cast("mkpla_real *", self._ffi.from_buffer(a))

    def _time(self, t: float) -> float | int:
        """float64: the time itself; float32: its tick (a sensor's clock)."""
        if self.precision == "float64":
            return t
        if self._t0 is None:
            self._t0 = t
        return int(sensor_ticks(np.array([t]), self._t0, self._tick)[0])

    def push(self, t: float, x) -> tuple[int, float, tuple[float, ...]] | None:
        """One sample; the point it decided as ``(index, time, values)``, or ``None``."""
        xb = self._x
        for d in range(self.dim):
            xb[d] = x[d]
        if self.precision == "float32" and not math.isfinite(t):
            rc = -7   # a tick cannot be NaN: refused here as C refuses a NaN time
        else:
            rc = self._lib.mkpla_encoder_push(self._enc, self._time(t), xb, self._pt)
        if rc < 0:   # refused: the encoder is as it was, the next sample takes this one's place
            raise InvalidSignalError(f"sample {self._count}: {C_ERRORS.get(rc, rc)}")
        self._count += 1
        if rc == 0:
            return None
        p = self._pt
        return int(p.index), float(p.t), tuple(p.v[d] for d in range(self.dim))

    def flush(self) -> tuple[int, float, tuple[float, ...]] | None:
        if self._lib.mkpla_encoder_flush(self._enc, self._pt) != 1:
            return None
        p = self._pt
        return int(p.index), float(p.t), tuple(p.v[d] for d in range(self.dim))

    def push_many(self, t: np.ndarray, X: np.ndarray, flush: bool = False) -> Points:
        """Many samples in one call (``t (n,)``, ``X (n, dim)``); the points they decided.

        For the float32 build the returned times are the ticks the encoder saw (:func:`sensor_ticks`);
        take times from the indices where they matter. A sample C refuses stops the batch with an
        :class:`~mocapkit.errors.InvalidSignalError` whose ``points`` are those of the samples before
        it (which the encoder took); the encoder goes on after the refused sample.
        """
        n = int(t.shape[0])
        if n == 0 and not flush:
            return Points(np.empty(0, np.int64), np.empty(0), np.empty((0, self.dim)))
        tdtype = np.float64 if self.precision == "float64" else np.uint32
        if self.precision == "float32" and n:
            bad = ~np.isfinite(t)
            if bad.any():
                raise InvalidSignalError(f"sample {self._count + int(np.argmax(bad))}: {C_ERRORS[-7]}")
            if self._t0 is None:
                self._t0 = float(t[0])
            tt = sensor_ticks(t, self._t0, self._tick)
        else:
            tt = np.ascontiguousarray(t, dtype=np.float64)
        xx = np.ascontiguousarray(X, dtype=self._dtype).reshape(n, self.dim)
        idx = np.empty(n + 1, dtype=np.uint32)
        ts = np.empty(n + 1, dtype=tdtype)
        vals = np.empty((n + 1, self.dim), dtype=self._dtype)
        ffi = self._ffi
        failed, made = ffi.new("size_t *"), ffi.new("size_t *")
        tptr = ffi.cast("mkpla_time *", ffi.from_buffer(tt))
        rc = self._lib.mkpla_encoder_push_many(
            self._enc, tptr, self._ptr(xx), n, 1 if flush else 0,
            ffi.cast("uint32_t *", ffi.from_buffer(idx)), ffi.cast("mkpla_time *", ffi.from_buffer(ts)),
            self._ptr(vals), failed, made)
        m = int(made[0])
        pts = Points(idx[:m].astype(np.int64), ts[:m].astype(np.float64), vals[:m].astype(np.float64))
        if rc < 0:
            k = int(failed[0])
            err = InvalidSignalError(f"sample {self._count + k}: {C_ERRORS.get(rc, rc)}")
            err.points = pts
            self._count += k
            raise err
        self._count += n
        return pts


def encode(t: np.ndarray, X: np.ndarray, method: str, threshold: float, maxlen: int, quaternion: bool,
           precision: str = "float64", tick: float = DEFAULT_TICK, epoch: float | None = None) -> Points:
    """A whole signal through a C encoder in one call (the kernel's threshold: radians for anglesw)."""
    enc = NativeEncoder(method, threshold, X.shape[1], quaternion, maxlen, precision, tick, epoch)
    return enc.push_many(t, X, flush=True)
