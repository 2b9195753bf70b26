"""Shared shape of the PLA methods: the result type, the batch entry point, the streaming encoder."""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from types import ModuleType
from typing import NamedTuple

import numpy as np

from mocapkit.errors import InvalidParameterError, InvalidSignalError
from mocapkit.motion import Signal
from mocapkit.pla import anglesw, cplr, fastsw, native, sw, swing
from mocapkit.quat import hemisphere_continuous

#: method name -> (module, keeps original samples as points, threshold meaning)
METHODS: dict[str, tuple[ModuleType, bool, str]] = {
    "fastsw": (fastsw, True, "max SSR per segment (Eq. 13)"),
    "sw": (sw, True, "max SSR per segment (Eq. 5)"),
    "cplr": (cplr, False, "max SSR per segment (regression through the anchor)"),
    "swing": (swing, False, "max absolute error ε per sample and dimension"),
    "anglesw": (anglesw, True, "max angle in degrees between each sample and the SLERP decode"),
}
POS_METHODS = frozenset(m for m, (_, pos, _) in METHODS.items() if pos)
#: SW and anglesw check every buffered sample per new sample: without a cap a still sensor (constant
#: input: one endless segment) would make their work per sample, and a stream's memory, grow without
#: bound. 1000 is the cap of the fastSW paper's experiments. The other methods do O(1) work per sample
#: and stay unbounded unless asked. Batch and streaming apply the same default, so they agree.
BOUNDED_BY_DEFAULT = {"sw": 1000, "anglesw": 1000}
#: largest accepted ``max_segment_length`` (the compiled kernels count in int64; a stream's buffer
#: grows only as far as the segments do)
MAX_SEGMENT_LENGTH_LIMIT = 10**9


#: smallest time step the kernels compute with: slopes (value difference / step) and squared time
#: offsets stay far from float64 overflow and underflow (a step of 1e-300 s made the CPLR and Swing
#: kernels divide by an underflowed zero); readers refuse steps far larger (below 1e-9 s)
MIN_TIME_STEP = 1e-100
#: a quaternion whose squared norm is subnormal or overflows cannot be normalised (the C encoders refuse it)
NORM_PROBLEM = "quaternion norm too small or too large to normalise (squared norm subnormal or overflowing)"


def _normalisable(n2):
    """Whether a squared norm is a normal, finite float (array or scalar)."""
    return (n2 >= sys.float_info.min) & (n2 <= sys.float_info.max)


def _check_steps(t: np.ndarray) -> None:
    if t.shape[0] > 1:
        dt = np.diff(t)
        k = int(np.argmin(dt))
        if not dt[k] >= MIN_TIME_STEP:
            raise InvalidSignalError(f"sample {k + 1}: time step {float(dt[k])!r} s after {float(t[k])!r} s is below "
                                     f"{MIN_TIME_STEP:g} s (slopes and squared times would overflow/underflow)")


def check_method(method: str) -> str:
    m = method.lower()
    if m not in METHODS:
        raise InvalidParameterError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    return m


def _check_params(method: str, threshold: float, max_segment_length: int | None, kind: str) -> int:
    if not (isinstance(threshold, (int, float)) and math.isfinite(threshold) and threshold >= 0):
        raise InvalidParameterError(f"threshold must be a finite number >= 0, got {threshold!r}")
    if max_segment_length is not None and not (
        isinstance(max_segment_length, (int, np.integer)) and not isinstance(max_segment_length, bool)
        and 1 <= max_segment_length <= MAX_SEGMENT_LENGTH_LIMIT
    ):
        raise InvalidParameterError(
            f"max segment length must be an integer in 1..{MAX_SEGMENT_LENGTH_LIMIT}, got {max_segment_length!r}")
    if method == "anglesw" and kind != "quaternion":
        raise InvalidParameterError("method 'anglesw' works on quaternion signals only")
    if max_segment_length is None and method in BOUNDED_BY_DEFAULT:
        return BOUNDED_BY_DEFAULT[method]
    return 0 if max_segment_length is None else int(max_segment_length)


@dataclass(frozen=True)
class Compressed:
    """Segment points of one signal.

    ``indices`` are the sample indices at whose times the points lie; ``values`` are the points.
    For fastSW, SW and anglesw the values are the original samples exactly as read (``q`` as given,
    even where the algorithm worked on ``-q`` for hemisphere continuity); for CPLR and the Swing
    Filter they are extrapolated points (not unit quaternions).
    """

    method: str
    threshold: float
    max_segment_length: int | None
    kind: str
    n_samples: int
    indices: np.ndarray
    times: np.ndarray
    values: np.ndarray

    @property
    def n_points(self) -> int:
        return int(self.indices.shape[0])

    @property
    def icr(self) -> float:
        """Inverse compression ratio, Eq. 1 of the fastSW paper: points / samples."""
        return self.n_points / self.n_samples

    @property
    def mean_segment_length(self) -> float:
        """Mean number of sample intervals per segment."""
        return (self.n_samples - 1) / max(self.n_points - 1, 1)


def prepared_values(signal: Signal) -> np.ndarray:
    """The values the algorithms see: quaternions made hemisphere-continuous, vectors as they are."""
    if signal.kind == "quaternion":
        return hemisphere_continuous(signal.values)
    return np.ascontiguousarray(signal.values)


def compress(
    signal: Signal,
    method: str = "fastsw",
    threshold: float = 0.0,
    max_segment_length: int | None = None,
    *,
    _prepared: np.ndarray | None = None,
) -> Compressed:
    """Compress one signal with a PLA method at a threshold on the method's own metric.

    Parameters
    ----------
    signal
        The signal (quaternion or vector).
    method
        ``fastsw``, ``sw``, ``cplr``, ``swing`` or ``anglesw`` (see :data:`METHODS`).
    threshold
        The method's own error bound: SSR per segment (fastSW, SW, CPLR), ε per sample and
        dimension (Swing Filter), degrees (anglesw).
    max_segment_length
        Maximum number of sample intervals between consecutive segment points (``None``: 1000 for
        SW and anglesw, see :data:`BOUNDED_BY_DEFAULT`; unbounded for the others).
    """
    method = check_method(method)
    maxlen = _check_params(method, threshold, max_segment_length, signal.kind)
    X = prepared_values(signal) if _prepared is None else _prepared
    t = signal.times
    _check_steps(t)
    th = float(threshold)
    if method == "fastsw":
        idx = fastsw.batch(t, X, th, maxlen)
    elif method == "sw":
        idx = sw.batch(t, X, th, maxlen)
    elif method == "anglesw":
        idx = anglesw.batch(t, X, math.radians(th), maxlen)
    elif method == "cplr":
        idx, vals = cplr.batch(t, X, th, maxlen)
    else:
        idx, vals = swing.batch(t, X, th, maxlen)
    if method in POS_METHODS:
        vals = signal.values[idx]
    return Compressed(
        method=method,
        threshold=th,
        max_segment_length=maxlen or None,  # the length applied (a method's default included)
        kind=signal.kind,
        n_samples=len(signal),
        indices=idx,
        times=t[idx],
        values=np.ascontiguousarray(vals),
    )


class Point(NamedTuple):
    """A segment point emitted by a streaming encoder."""

    index: int  # type: ignore[assignment]  # the field shadows tuple.index (public name of the point)
    time: float
    values: tuple[float, ...]


class Encoder:
    """Streaming PLA encoder: ``push(t, x)`` returns the points it has decided, ``flush()`` the last.

    Work per sample and memory are O(1) for fastSW, CPLR and the Swing Filter; SW and anglesw buffer
    the samples of the current segment and check them all per new sample, so both are bounded by
    ``max_segment_length`` (default 1000 for them, :data:`BOUNDED_BY_DEFAULT`: a constant input
    cannot slow a stream down). The encoder runs in C (``c/mkpla``, float64 build, through
    :mod:`mocapkit.pla.native`) for samples of up to 16 values; wider ones run the compiled
    ``start``/``step``/``flush`` kernels. Either way the points equal those of :func:`compress` on
    the same samples, bit for bit (tested). :meth:`push_many` takes many samples per call: the fast
    way to feed it.

    Parameters are those of :func:`compress`, plus ``dim`` and ``kind`` of the incoming samples and
    ``engine``: ``"auto"`` (C where it applies), ``"c"`` (C or an error) or ``"numba"`` (the kernels).
    """

    def __init__(
        self,
        method: str,
        threshold: float,
        dim: int = 4,
        kind: str = "quaternion",
        max_segment_length: int | None = None,
        engine: str = "auto",
    ):
        self.method = check_method(method)
        if engine not in ("auto", "c", "numba"):
            raise InvalidParameterError(f"engine must be 'auto', 'c' or 'numba', got {engine!r}")
        if kind == "quaternion" and dim != 4:
            raise InvalidParameterError("a quaternion stream has dim 4")
        self.kind = kind
        self.dim = int(dim)
        self._maxlen = _check_params(self.method, threshold, max_segment_length, kind)
        self.threshold = float(threshold)
        self._th = math.radians(self.threshold) if self.method == "anglesw" else self.threshold
        mod = METHODS[self.method][0]
        self._mod = mod
        self._pos = self.method in POS_METHODS
        self._buffered = self.method in ("sw", "anglesw")
        cap = min(self._maxlen + 1, 256) if self._maxlen else 256  # grows with the segment (_grow)
        if self.method == "sw":
            self._state = list(sw.new_state(self.dim, cap))
        elif self.method == "anglesw":
            self._state = list(anglesw.new_state(cap))
        else:
            self._state = list(mod.new_state(self.dim))
        self._x = np.empty(self.dim)
        self._n = 0
        self._last_t = -math.inf
        self._first_t = math.nan
        self._last_raw: tuple[float, ...] | None = None
        self._sign = 1.0
        self._flushed = False
        self._native = None
        can_c = native.available() and native.supports(self.method, self.dim, self._maxlen)
        if engine == "c" and not can_c:
            raise InvalidParameterError(f"the C encoder is not available for {self.method} on {self.dim}-D samples "
                                        f"(compiled bindings present: {native.available()})")
        if can_c and engine != "numba":
            self._native = native.NativeEncoder(self.method, self._th, self.dim, kind == "quaternion", self._maxlen)

    def _grow(self) -> None:
        bt, bx = self._state[-2], self._state[-1]
        cap = bt.shape[0] * 2
        nbt = np.empty(cap)
        nbx = np.empty((cap, bx.shape[1]))
        nbt[: bt.shape[0]] = bt
        nbx[: bx.shape[0]] = bx
        self._state[-2], self._state[-1] = nbt, nbx

    def push(self, t: float, x) -> list[Point]:
        """Add one sample; return the segment points decided by it (0 or 1 points)."""
        if self._flushed:
            raise InvalidSignalError("push() after flush(): start a new Encoder")
        t = float(t)
        raw = tuple(float(v) for v in x)
        if len(raw) != self.dim:
            raise InvalidSignalError(f"sample {self._n}: expected {self.dim} values, got {len(raw)}")
        if not math.isfinite(t) or not all(math.isfinite(v) for v in raw):
            raise InvalidSignalError(f"sample {self._n}: NaN or infinite value")
        if self._n and not math.isfinite((t - self._first_t) ** 2):
            raise InvalidSignalError(f"sample {self._n}: time {t!r} is too far from the first sample to compute with")
        if self._n and t > self._last_t and t - self._last_t < MIN_TIME_STEP:
            raise InvalidSignalError(f"sample {self._n}: time step {t - self._last_t!r} s after {self._last_t!r} s is "
                                     f"below {MIN_TIME_STEP:g} s (slopes and squared times would overflow/underflow)")
        if t <= self._last_t:
            what = "duplicate" if t == self._last_t else "earlier"
            raise InvalidSignalError(
                f"sample {self._n}: time {t!r} is not after the previous time {self._last_t!r} ({what})"
            )
        if self.kind == "quaternion" and raw[0] == 0.0 and raw[1] == 0.0 and raw[2] == 0.0 and raw[3] == 0.0:
            raise InvalidSignalError(f"sample {self._n}: zero-norm quaternion")
        if self.kind == "quaternion" and not _normalisable(sum(v * v for v in raw)):
            raise InvalidSignalError(f"sample {self._n}: {NORM_PROBLEM}")
        if self._native is not None:
            if self._n == 0:
                self._first_t = t
            self._n += 1
            self._last_t = t
            r = self._native.push(t, raw)
            return [] if r is None else [Point(*r)]
        if self.kind == "quaternion":
            if self._last_raw is not None:
                p = self._last_raw
                dot = raw[0] * p[0] + raw[1] * p[1] + raw[2] * p[2] + raw[3] * p[3]
                self._sign = -1.0 if self._sign * dot < 0.0 else 1.0  # as quat.hemisphere_continuous
            s = self._sign
            self._x[:] = (s * raw[0], s * raw[1], s * raw[2], s * raw[3])
        else:
            self._x[:] = raw
        st = self._state
        i = self._n
        prev_raw, prev_t = self._last_raw, self._last_t
        self._last_raw = raw
        self._last_t = t
        self._n += 1
        if i == 0:
            self._first_t = t
            self._mod.start(*st, t, self._x)
            return [Point(0, t, raw)]
        if self._buffered and int(st[0][2]) + 1 >= st[-2].shape[0]:
            self._grow()
            st = self._state
        if not self._mod.step(*st, t, self._x, self._th, self._maxlen):
            return []
        assert prev_raw is not None  # i > 0: a sample came before
        return [Point(i - 1, prev_t, prev_raw if self._pos else tuple(st[1].tolist()))]

    def push_many(self, t, X) -> native.Points:
        """Add many samples (``t (n,)``, ``X (n, dim)``) in one call; the points they decided, as arrays.

        The same checks and the same points as ``n`` calls of :meth:`push`, for a fraction of the
        cost (one call into C per batch, the checks vectorised).
        """
        if self._flushed:
            raise InvalidSignalError("push_many() after flush(): start a new Encoder")
        t = np.asarray(t, dtype=np.float64).reshape(-1)
        X = np.asarray(X, dtype=np.float64)
        if X.ndim != 2 or X.shape != (t.shape[0], self.dim):
            raise InvalidSignalError(f"sample {self._n}: expected times (n,) and values (n, {self.dim}), "
                                     f"got {t.shape} and {X.shape}")
        n = t.shape[0]
        if n == 0:
            return native.Points(np.empty(0, np.int64), np.empty(0), np.empty((0, self.dim)))
        self._check_many(t, X)
        if self._native is None:  # the compiled kernels, one sample at a time
            pts = [p for i in range(n) for p in self.push(t[i], X[i])]
            return native.Points(
                np.array([p.index for p in pts], dtype=np.int64),
                np.array([p.time for p in pts]),
                np.array([p.values for p in pts]).reshape(-1, self.dim),
            )
        if self._n == 0:
            self._first_t = float(t[0])
        out = self._native.push_many(t, X)
        self._n += n
        self._last_t = float(t[-1])
        return out

    def _check_many(self, t: np.ndarray, X: np.ndarray) -> None:
        """The checks of :meth:`push` on a batch; the message names the first bad sample.

        A batch with a bad sample is refused whole: none of its samples is encoded.
        """
        first = float(t[0]) if self._n == 0 else self._first_t
        prev = np.concatenate([[self._last_t], t[:-1]])
        with np.errstate(over="ignore", invalid="ignore"):
            dt = t - prev
            far = ~np.isfinite((t - first) ** 2)
        checks = [  # in the order push() checks one sample
            (~(np.isfinite(t) & np.isfinite(X).all(axis=1)), lambda k: "NaN or infinite value"),
            (far, lambda k: f"time {float(t[k])!r} is too far from the first sample to compute with"),
            ((dt > 0) & (dt < MIN_TIME_STEP), lambda k: (
                f"time step {float(dt[k])!r} s after {float(prev[k])!r} s is below {MIN_TIME_STEP:g} s "
                "(slopes and squared times would overflow/underflow)")),
            (dt <= 0, lambda k: (f"time {float(t[k])!r} is not after the previous time {float(prev[k])!r} "
                                 f"({'duplicate' if t[k] == prev[k] else 'earlier'})")),
        ]
        if self.kind == "quaternion":
            checks.append((~(X != 0.0).any(axis=1), lambda k: "zero-norm quaternion"))
            with np.errstate(over="ignore", under="ignore", invalid="ignore"):
                n2 = np.sum(X * X, axis=1)
            checks.append(((X != 0.0).any(axis=1) & ~_normalisable(n2), lambda k: NORM_PROBLEM))
        bad = [(int(np.argmax(m)), c) for c, (m, _) in enumerate(checks) if m.any()]
        if bad:
            k, c = min(bad)
            raise InvalidSignalError(f"sample {self._n + k}: {checks[c][1](k)}")

    def flush(self) -> list[Point]:
        """End of stream: return the final segment point (if any)."""
        if self._flushed:
            return []
        self._flushed = True
        if self._native is not None:
            r = self._native.flush() if self._n else None
            return [] if r is None else [Point(*r)]
        if self._n == 0 or not self._mod.flush(*self._state):
            return []
        assert self._last_raw is not None  # self._n > 0
        vals = self._last_raw if self._pos else tuple(self._state[1].tolist())
        return [Point(self._n - 1, self._last_t, vals)]
