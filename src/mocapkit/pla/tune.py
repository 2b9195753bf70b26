"""Error control in the user's terms: a threshold, a target ICR, or a guaranteed maximum angle."""

from __future__ import annotations

import math

import numpy as np

from mocapkit.errors import BoundViolationError, InvalidParameterError, UnreachableTargetError
from mocapkit.motion import Signal
from mocapkit.pla.base import Compressed, check_method, compress, prepared_values
from mocapkit.pla.metrics import deviations

#: slack when checking a guaranteed angle: SLERP evaluated by two code paths differs by ~1e-13°
BOUND_TOL_DEG = 1e-9
_LOG_RANGE = {"anglesw": (-9.0, math.log10(360.0))}
_DEFAULT_LOG_RANGE = (-15.0, 6.0)
_ITER = 36  # 21 decades / 2**36: the threshold to ~1e-9 decades


def _search_range(method: str) -> tuple[float, float]:
    return _LOG_RANGE.get(method, _DEFAULT_LOG_RANGE)


def max_deviation_deg(signal: Signal, comp: Compressed) -> float:
    return float(deviations(signal, comp).max())


def threshold_for_icr(
    signal: Signal, method: str, target_icr: float, max_segment_length: int | None = None
) -> Compressed:
    """Smallest threshold (bisection in log space) whose ICR is at most ``target_icr``.

    ICR is not strictly monotone in the threshold, so this is the boundary found by bisection
    between a threshold known to give a larger ICR and one known to meet the target.
    """
    method = check_method(method)
    if not (0.0 < target_icr <= 1.0):
        raise InvalidParameterError(f"target ICR must be in (0, 1], got {target_icr!r}")
    X = prepared_values(signal)

    def run(th: float) -> Compressed:
        return compress(signal, method, th, max_segment_length, _prepared=X)

    best = run(0.0)
    if best.icr <= target_icr:
        return best
    lo, hi = _search_range(method)
    top = run(10.0**hi)
    if top.icr > target_icr:
        raise UnreachableTargetError(
            f"{signal.source or signal.name or 'signal'}: ICR {target_icr:g} is out of reach for {method}: the loosest "
            f"threshold gives {top.icr:.4g} ({top.n_points} points"
            + (f"; max segment length {max_segment_length})" if max_segment_length else ")")
        )
    best = top
    for _ in range(_ITER):
        mid = 0.5 * (lo + hi)
        c = run(10.0**mid)
        if c.icr <= target_icr:
            hi, best = mid, c
        else:
            lo = mid
    return best


def threshold_for_max_angle(
    signal: Signal, method: str, max_angle_deg: float, max_segment_length: int | None = None
) -> Compressed:
    """Compress so that every sample is within ``max_angle_deg`` of the SLERP decode.

    ``anglesw`` meets the bound by construction (online). The other methods have no angular
    threshold: their threshold is found by bisection in log space, checking the real maximum
    deviation of every candidate; the feasible candidate with the fewest points is returned.
    """
    method = check_method(method)
    if signal.kind != "quaternion":
        raise InvalidParameterError("a maximum angle applies to quaternion signals only")
    if not (math.isfinite(max_angle_deg) and max_angle_deg >= 0):
        raise InvalidParameterError(f"maximum angle must be a finite number >= 0, got {max_angle_deg!r}")
    if method == "anglesw":
        return compress(signal, method, max_angle_deg, max_segment_length)
    X = prepared_values(signal)
    bound = max_angle_deg + 1e-12  # candidates meet the bound itself (1e-12° absorbs rounding at 0°)

    def run(th: float) -> tuple[Compressed, bool]:
        c = compress(signal, method, th, max_segment_length, _prepared=X)
        return c, max_deviation_deg(signal, c) <= bound

    best, ok = run(0.0)
    if not ok:
        raise InvalidParameterError(
            f"{signal.source or signal.name or 'signal'}: {method} cannot keep every sample within {max_angle_deg:g}° "
            "even at threshold 0; use --method anglesw"
        )
    lo, hi = _search_range(method)
    c, ok = run(10.0**hi)
    if ok:
        return c
    c, ok = run(10.0**lo)
    if not ok:
        return best
    best = c
    for _ in range(_ITER):
        mid = 0.5 * (lo + hi)
        c, ok = run(10.0**mid)
        if ok:
            lo = mid
            if c.n_points <= best.n_points:
                best = c
        else:
            hi = mid
    return best


def verify_max_angle(signal: Signal, comp: Compressed, max_angle_deg: float) -> float:
    """Check the guarantee on the decoded output; return the maximum deviation (degrees)."""
    m = max_deviation_deg(signal, comp)
    if not m <= max_angle_deg + BOUND_TOL_DEG:
        raise BoundViolationError(
            f"{signal.source or signal.name or 'signal'}: maximum deviation {m:.6g}° exceeds the bound "
            f"{max_angle_deg:g}°"
        )
    return m


def compress_to(
    signal: Signal,
    method: str = "fastsw",
    *,
    threshold: float | None = None,
    target_icr: float | None = None,
    max_angle: float | None = None,
    max_segment_length: int | None = None,
) -> Compressed:
    """Compress with exactly one of: the method's own ``threshold``, a ``target_icr``, or a
    guaranteed ``max_angle`` in degrees (verified on the decoded output before returning)."""
    given = [x is not None for x in (threshold, target_icr, max_angle)]
    if sum(given) != 1:
        raise InvalidParameterError("give exactly one of threshold, target ICR, max angle")
    if method == "optimal":  # offline: the fewest sample points for a maximum angle
        if max_angle is None:
            raise InvalidParameterError("method 'optimal' takes --max-angle only")
        from mocapkit.pla.optimal import optimal_max_angle

        comp = optimal_max_angle(signal, float(max_angle), max_segment_length)
        verify_max_angle(signal, comp, float(max_angle))
        return comp
    if threshold is not None:
        return _finite(compress(signal, method, threshold, max_segment_length))
    if target_icr is not None:
        return _finite(threshold_for_icr(signal, method, target_icr, max_segment_length))
    assert max_angle is not None  # exactly one of the three is given (checked above)
    comp = threshold_for_max_angle(signal, method, float(max_angle), max_segment_length)
    verify_max_angle(signal, comp, float(max_angle))
    return comp


def _finite(comp: Compressed) -> Compressed:
    if not np.all(np.isfinite(comp.values)):
        raise BoundViolationError("a segment point is not finite (values or times out of floating-point range)")
    return comp


def segment_lengths(comp: Compressed) -> np.ndarray:
    return np.diff(comp.indices)
