"""The data model: small frozen dataclasses shared by every layer."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from mocapkit.errors import InvalidSignalError

Kind = Literal["quaternion", "vector"]

MAX_ABS = 1e12
"""Largest magnitude a reader accepts for any coordinate, angle, quaternion component or time (squares and
sums of up to 1e6 such values stay far below float64's 1.8e308): the limit of the text readers'
number grammar (:mod:`mocapkit.io.text.numbers`) and of the ``.mkp`` header's times."""


@dataclass(frozen=True)
class Signal:
    """A sampled signal.

    Attributes
    ----------
    times
        ``(N,)`` float64 seconds, strictly increasing (irregular sampling allowed).
    values
        ``(N, D)`` float64, exactly as read (quaternions are *not* normalised here).
    kind
        ``"quaternion"`` (scalar-first ``w, x, y, z``; D must be 4) or ``"vector"``.
    name
        A label (sensor or joint name).
    source
        Where it came from (a path), for messages.
    """

    times: NDArray[np.float64]
    values: NDArray[np.float64]
    kind: Kind = "quaternion"
    name: str = ""
    source: str = ""
    meta: dict[str, Any] = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        t = np.ascontiguousarray(self.times, dtype=np.float64)
        v = np.ascontiguousarray(self.values, dtype=np.float64)
        if v.ndim == 1:
            v = v[:, None]
        where = f"signal {self.name!r}" if self.name else "signal"
        if t.ndim != 1:
            raise InvalidSignalError(f"{where}: times must be 1-D, got shape {t.shape}")
        if v.ndim != 2 or v.shape[0] != t.shape[0]:
            raise InvalidSignalError(
                f"{where}: values must be (N, D) with N = len(times) = {t.shape[0]}, got {v.shape}"
            )
        if t.shape[0] == 0:
            raise InvalidSignalError(f"{where}: no samples")
        if self.kind not in ("quaternion", "vector"):
            raise InvalidSignalError(f"{where}: kind must be 'quaternion' or 'vector', got {self.kind!r}")
        if self.kind == "quaternion" and v.shape[1] != 4:
            raise InvalidSignalError(f"{where}: a quaternion signal needs 4 columns, got {v.shape[1]}")
        if not np.all(np.isfinite(t)):
            i = int(np.flatnonzero(~np.isfinite(t))[0])
            raise InvalidSignalError(f"{where}: time of sample {i} is not finite")
        if not np.all(np.isfinite(v)):
            i = int(np.flatnonzero(~np.all(np.isfinite(v), axis=1))[0])
            raise InvalidSignalError(f"{where}: sample {i} has a NaN or infinite value")
        if not np.isfinite((t[-1] - t[0]) ** 2):
            raise InvalidSignalError(f"{where}: the time span {t[-1] - t[0]!r} s is too large to compute with")
        span = float(t[-1] - t[0])
        if t.shape[0] > 1 and span > 0 and (t.shape[0] - 1) / 1e300 > span:  # the mean rate would overflow
            raise InvalidSignalError(f"{where}: the time span {span!r} s is too small (the rate overflows)")
        bad = np.flatnonzero(np.diff(t) <= 0)
        if bad.size:
            i = int(bad[0])
            raise InvalidSignalError(
                f"{where}: times must be strictly increasing; sample {i + 1} (t={t[i + 1]!r}) "
                f"is not after sample {i} (t={t[i]!r})"
            )
        if self.kind == "quaternion":
            norms = np.einsum("ij,ij->i", v, v)
            zero = np.flatnonzero(norms == 0.0)
            if zero.size:
                raise InvalidSignalError(f"{where}: sample {int(zero[0])} is a zero-norm quaternion")
        t.setflags(write=False)
        v.setflags(write=False)
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "values", v)

    def __len__(self) -> int:
        return int(self.times.shape[0])

    @property
    def dim(self) -> int:
        return int(self.values.shape[1])

    @property
    def duration(self) -> float:
        return float(self.times[-1] - self.times[0])

    @property
    def mean_rate(self) -> float:
        """Mean sample rate in Hz (``nan`` for a single sample)."""
        if len(self) < 2:
            return float("nan")
        return (len(self) - 1) / self.duration
