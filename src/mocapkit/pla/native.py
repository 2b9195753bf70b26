"""The C encoders of ``c/mkpla`` from Python (cffi): one streaming encoder of any method.

``precision="float64"`` runs the build that performs the Python kernels' operations in their order
(the same points bit for bit); ``"float32"`` runs the build a sensor runs (``MKPLA_FLOAT32``), fed
times relative to the first sample and values rounded to float32 exactly as a sensor would be.
Quaternion streams are made hemisphere-continuous inside C (as :func:`mocapkit.quat.hemisphere_continuous`).
"""

from __future__ import annotations

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
    -4: "zero-norm quaternion",
    -5: "push after flush",
}


def _module(precision: str):
    if precision == "float64":
        from mocapkit import _mkpla64 as mod
    elif precision == "float32":
        from mocapkit import _mkpla32 as mod
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

    Inputs are not validated here beyond what C checks (time order, zero quaternions): callers
    (:class:`mocapkit.pla.Encoder`) check finiteness and give the messages.
    """

    def __init__(self, method: str, threshold: float, dim: int, quaternion: bool, maxlen: int,
                 precision: str = "float64"):
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
        self._t0: float | None = None
        self._count = 0

    def _ptr(self, a: np.ndarray):
        return self._ffi.cast("mkpla_real *", self._ffi.from_buffer(a))

    def _time(self, t: float) -> float:
        """float64: the time itself; float32: the time since the first sample (a sensor's clock)."""
        if self.precision == "float64":
            return t
        if self._t0 is None:
            self._t0 = t
        return t - self._t0

    def push(self, t: float, x) -> tuple[int, float, tuple[float, ...]] | None:
        """One sample; the point it decided as ``(index, time, values)``, or ``None``."""
        xb = self._x
        for d in range(self.dim):
            xb[d] = x[d]
        rc = self._lib.mkpla_encoder_push(self._enc, self._time(t), xb, self._pt)
        self._count += 1
        if rc == 0:
            return None
        if rc < 0:
            raise InvalidSignalError(f"sample {self._count - 1}: {C_ERRORS.get(rc, rc)}")
        p = self._pt
        return int(p.index), float(p.t), tuple(p.v[d] for d in range(self.dim))

    def flush(self) -> tuple[int, float, tuple[float, ...]] | None:
        if self._lib.mkpla_encoder_flush(self._enc, self._pt) != 1:
            return None
        p = self._pt
        return int(p.index), float(p.t), tuple(p.v[d] for d in range(self.dim))

    def push_many(self, t: np.ndarray, X: np.ndarray, flush: bool = False) -> Points:
        """Many samples in one call (``t (n,)``, ``X (n, dim)``); the points they decided.

        For the float32 build the returned times are the float32 times the encoder saw (seconds
        since the first sample); take times from the indices where they matter.
        """
        n = int(t.shape[0])
        if n == 0 and not flush:
            return Points(np.empty(0, np.int64), np.empty(0), np.empty((0, self.dim)))
        if self.precision == "float32" and n:
            if self._t0 is None:
                self._t0 = float(t[0])
            tt = np.ascontiguousarray(t - self._t0, dtype=np.float32)
        else:
            tt = np.ascontiguousarray(t, dtype=self._dtype)
        xx = np.ascontiguousarray(X, dtype=self._dtype).reshape(n, self.dim)
        idx = np.empty(n + 1, dtype=np.uint32)
        ts = np.empty(n + 1, dtype=self._dtype)
        vals = np.empty((n + 1, self.dim), dtype=self._dtype)
        failed = self._ffi.new("size_t *")
        ffi = self._ffi
        m = self._lib.mkpla_encoder_push_many(
            self._enc, self._ptr(tt), self._ptr(xx), n, 1 if flush else 0,
            ffi.cast("uint32_t *", ffi.from_buffer(idx)), self._ptr(ts), self._ptr(vals), failed)
        if m < 0:
            raise InvalidSignalError(f"sample {self._count + int(failed[0])}: {C_ERRORS.get(m, m)}")
        self._count += n
        return Points(idx[:m].astype(np.int64), ts[:m].astype(np.float64), vals[:m].astype(np.float64))


def encode(t: np.ndarray, X: np.ndarray, method: str, threshold: float, maxlen: int, quaternion: bool,
           precision: str = "float64") -> Points:
    """A whole signal through a C encoder in one call (the kernel's threshold: radians for anglesw)."""
    enc = NativeEncoder(method, threshold, X.shape[1], quaternion, maxlen, precision)
    return enc.push_many(t, X, flush=True)
