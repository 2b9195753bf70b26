"""Baseline smoothers: zero-phase Butterworth (Winter's residual cut-off), GCV smoothing spline.

These are the standard filters of biomechanics that the piecewise-polynomial filters of
:mod:`mocapkit.filters` are compared against (issue 5, item 4; the seed report's Fig. 1 shows the
overshoot of a forward-backward Butterworth filter at a step, measured by :func:`step_overshoot`).

* :func:`corrected_cutoff` -- the per-pass design cut-off that puts the −3 dB point of a cascade of
  ``passes`` identical Butterworth passes at the requested frequency (Winter's "double-pass
  correction", applied to the bilinear-warped frequency);
* :func:`butterworth_filtfilt` -- zero-phase (forward-backward) Butterworth low-pass through
  :func:`scipy.signal.sosfiltfilt`;
* :func:`winter_residual_cutoff` -- Winter's residual analysis for choosing the cut-off;
* :func:`smoothing_spline` -- cubic smoothing spline through
  :func:`scipy.interpolate.make_smoothing_spline` (GCV when no ``lam`` is given);
* :func:`step_overshoot` -- overshoot at a step, as a fraction of the step height.

Missing samples are refused (:class:`~mocapkit.errors.InvalidSignalError` naming the first NaN):
these filters have no notion of a gap, and silently bridging one would hide it. The caller splits
the signal at its gaps and filters each finite segment.

References
----------
D. A. Winter, *Biomechanics and Motor Control of Human Movement*, 4th ed., Hoboken, NJ: Wiley, 2009,
chapter 3 (digital filtering of kinematic data: the Butterworth low-pass filter, the correction of
the cut-off for multiple passes, and the residual analysis for choosing the cut-off).
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np
from scipy import signal
from scipy.interpolate import make_smoothing_spline

from mocapkit.errors import InvalidParameterError, InvalidSignalError

__all__ = [
    "corrected_cutoff",
    "butterworth_filtfilt",
    "winter_residual_cutoff",
    "smoothing_spline",
    "step_overshoot",
]


# --------------------------------------------------------------------------------------------------
# validation helpers
# --------------------------------------------------------------------------------------------------


def _positive_float(value: Any, name: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{name} must be a number, got {value!r}") from None
    if not np.isfinite(v) or v <= 0.0:
        raise InvalidParameterError(f"{name} must be finite and > 0, got {value!r}")
    return v


def _positive_int(value: Any, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise InvalidParameterError(f"{name} must be an integer >= 1, got {value!r}")
    return int(value)


def _signal_2d(y: Any, name: str = "y") -> tuple[np.ndarray, bool]:
    """``y`` as float (N, D) (and whether it was 1-D); refuses NaN/inf, naming the first one."""
    arr = np.asarray(y, dtype=float)
    if arr.ndim not in (1, 2):
        raise InvalidSignalError(f"{name} must have shape (N,) or (N, D), got shape {arr.shape}")
    was_1d = arr.ndim == 1
    arr2 = arr[:, None] if was_1d else arr
    if arr2.shape[0] == 0 or arr2.shape[1] == 0:
        raise InvalidSignalError(f"{name} is empty (shape {arr.shape})")
    bad = ~np.isfinite(arr2)
    if bad.any():
        row, col = (int(i) for i in np.argwhere(bad)[0])
        what = "NaN" if np.isnan(arr2[row, col]) else "an infinite value"
        where = f"sample {row}" if was_1d else f"sample {row}, column {col}"
        raise InvalidSignalError(
            f"{name} contains {what} at {where} (first one); these filters do not bridge gaps: "
            "split the signal at its gaps and filter each finite segment"
        )
    return arr2, was_1d


def _sos_padlen(sos: np.ndarray) -> int:
    """The default ``padlen`` of :func:`scipy.signal.sosfiltfilt` for ``sos``."""
    n_zeros = min(int((sos[:, 2] == 0).sum()), int((sos[:, 5] == 0).sum()))
    return 3 * (2 * len(sos) + 1 - n_zeros)


# --------------------------------------------------------------------------------------------------
# cut-off correction and the zero-phase filter
# --------------------------------------------------------------------------------------------------


def corrected_cutoff(fc: float, fs: float, order: int = 2, passes: int = 2) -> float:
    r"""Per-pass design cut-off giving a cascade of ``passes`` passes its −3 dB point at ``fc``.

    Filtering forward and backward with the same Butterworth filter multiplies its magnitude
    response by itself, so a filter designed for ``fc`` ends up at −6 dB there and the effective
    cut-off drops. Winter (2009, ch. 3) corrects the cut-off of each pass; this function does so
    on the *pre-warped analog prototype frequency*, which is exact for the bilinear-transform design
    of :func:`scipy.signal.butter` at any ``fc / fs`` (correcting ``fc`` itself is only the low
    frequency approximation).

    Parameters
    ----------
    fc : float
        Wanted −3 dB frequency of the whole cascade, in Hz; ``0 < fc < fs / 2``.
    fs : float
        Sampling frequency in Hz.
    order : int, default 2
        Order ``n`` of the Butterworth filter of each pass.
    passes : int, default 2
        Number ``p`` of passes of that filter (2 for forward-backward filtering; 1 means no
        correction).

    Returns
    -------
    float
        The cut-off ``f_d`` (Hz) to design each pass with (``scipy.signal.butter(order, f_d,
        fs=fs)``); ``f_d >= fc``.

    Raises
    ------
    InvalidParameterError
        If ``fc`` or ``fs`` is not positive and finite, ``order`` or ``passes`` is not an integer
        >= 1, ``fc >= fs / 2``, or the corrected cut-off is not below ``fs / 2`` in floating point.

    Notes
    -----
    A digital Butterworth low-pass of order :math:`n` designed by the bilinear transform with
    pre-warping at :math:`f_d` has

    .. math:: |H(f)|^2 = \frac{1}{1 + (\Omega(f) / \Omega_d)^{2n}}, \qquad
              \Omega(f) = \tan(\pi f / f_s), \quad \Omega_d = \Omega(f_d).

    A cascade of :math:`p` passes (the backward pass has the same magnitude as the forward one)
    has magnitude :math:`|H(f)|^p`. Asking for :math:`|H(f_c)|^p = 1/\sqrt{2}` gives
    :math:`(\Omega_c/\Omega_d)^{2n} = 2^{1/p} - 1`, hence

    .. math:: \Omega_d = C\,\Omega_c, \qquad C = (2^{1/p} - 1)^{-1/(2n)}, \qquad
              f_d = \frac{f_s}{\pi} \arctan\!\bigl(C \tan(\pi f_c / f_s)\bigr).

    :math:`C \ge 1` *multiplies* the warped frequency (for :math:`n = 2, p = 2`, :math:`C = 1.2465`;
    Winter writes the same factor as :math:`0.802 = 1/C` and divides by it). Since
    :math:`\arctan < \pi/2`, :math:`f_d < f_s/2` for every :math:`f_c < f_s/2`.
    """
    fc = _positive_float(fc, "fc")
    fs = _positive_float(fs, "fs")
    order = _positive_int(order, "order")
    passes = _positive_int(passes, "passes")
    nyquist = fs / 2.0
    if fc >= nyquist:
        raise InvalidParameterError(
            f"cut-off fc = {fc:g} Hz must be below the Nyquist frequency fs/2 = {nyquist:g} Hz"
        )
    c = (2.0 ** (1.0 / passes) - 1.0) ** (-1.0 / (2.0 * order))
    fd = fs / np.pi * float(np.arctan(c * np.tan(np.pi * fc / fs)))
    if not fd / nyquist < 1.0:
        raise InvalidParameterError(
            f"cut-off fc = {fc:g} Hz corrected for {passes} passes of order {order} is "
            f"{fd:.12g} Hz, not below the Nyquist frequency fs/2 = {nyquist:g} Hz; lower fc"
        )
    return fd


def butterworth_filtfilt(
    y: Any, fs: float, fc: float, order: int = 2, correct: bool = True
) -> np.ndarray:
    """Zero-phase Butterworth low-pass: one forward and one backward pass (``sosfiltfilt``).

    Parameters
    ----------
    y : array_like, shape (N,) or (N, D)
        Uniformly sampled signal; a 2-D array is filtered along axis 0 (each column independently).
        Must be finite: NaN is refused (see Raises).
    fs : float
        Sampling frequency in Hz.
    fc : float
        Cut-off frequency in Hz.
    order : int, default 2
        Order of the Butterworth filter of *each* pass (the forward-backward cascade has twice the
        roll-off; Winter's "fourth-order zero-lag" filter is ``order=2``).
    correct : bool, default True
        If True, ``fc`` is the −3 dB frequency of the whole forward-backward cascade and each pass
        is designed at :func:`corrected_cutoff` ``(fc, fs, order, passes=2)``. If False each pass
        is designed at ``fc`` (the cascade is then at −6 dB at ``fc``).

    Returns
    -------
    numpy.ndarray
        Filtered signal, same shape as ``y``, float.

    Raises
    ------
    InvalidParameterError
        Bad ``fs``, ``fc`` (including ``fc >= fs / 2``) or ``order``.
    InvalidSignalError
        ``y`` has the wrong shape, contains NaN or inf (the message names the first such sample;
        this function does not bridge gaps, the caller splits the signal at them), or is not longer
        than the padding of ``sosfiltfilt`` (``3 * (2 * n_sections + 1 - ...)`` samples).

    Notes
    -----
    The ends are handled by ``sosfiltfilt``'s default odd extension of the signal.
    """
    fs = _positive_float(fs, "fs")
    fc = _positive_float(fc, "fc")
    order = _positive_int(order, "order")
    arr, was_1d = _signal_2d(y)
    if correct:
        fd = corrected_cutoff(fc, fs, order=order, passes=2)
    else:
        if fc >= fs / 2.0:
            raise InvalidParameterError(
                f"cut-off fc = {fc:g} Hz must be below the Nyquist frequency fs/2 = {fs / 2:g} Hz"
            )
        fd = fc
    sos = signal.butter(order, fd, btype="low", fs=fs, output="sos")
    padlen = _sos_padlen(sos)
    if arr.shape[0] <= padlen:
        raise InvalidSignalError(
            f"y has {arr.shape[0]} samples; forward-backward filtering of order {order} "
            f"needs more than {padlen}"
        )
    out = signal.sosfiltfilt(sos, arr, axis=0)
    return out[:, 0] if was_1d else out


# --------------------------------------------------------------------------------------------------
# Winter's residual analysis
# --------------------------------------------------------------------------------------------------


def _default_grid(fs: float) -> np.ndarray:
    f_max = min(0.4 * fs, 30.0)
    if f_max < 0.5 + 5 * 0.25:
        raise InvalidParameterError(
            f"fs = {fs:g} Hz is too low for the default cut-off grid (0.5 Hz to min(0.4·fs, 30 Hz) "
            "in 0.25 Hz steps); pass fc_grid explicitly"
        )
    return np.arange(0.5, f_max + 1e-9, 0.25)


def winter_residual_cutoff(
    y: Any,
    fs: float,
    fc_grid: Any = None,
    order: int = 2,
    *,
    fit_range: tuple[float, float] | None = None,
) -> tuple[float | np.ndarray, dict[str, Any]]:
    r"""Cut-off frequency by Winter's residual analysis.

    For every cut-off :math:`f` of a grid the signal is filtered with :func:`butterworth_filtfilt`
    (``correct=True``, so :math:`f` is the −3 dB point of the zero-phase filter) and the residual

    .. math:: R(f) = \sqrt{\frac{1}{N}\sum_{i=1}^{N} (y_i - \hat y_{f,i})^2}

    is computed. Above the signal's bandwidth the residual is made of noise only and, for white
    noise, falls nearly linearly with :math:`f` (towards 0 at :math:`f_s/2`). Following Winter
    (2009, ch. 3), a straight line :math:`R \approx a + b f` is fitted to that noise-dominated part;
    its intercept :math:`a` at :math:`f = 0` estimates the RMS of the noise. The chosen cut-off is
    where the residual curve comes down to that level, :math:`R(f) = a`: there the signal distortion
    let through by a lower cut-off would equal the noise let through by a higher one.

    Parameters
    ----------
    y : array_like, shape (N,) or (N, D)
        Uniformly sampled, finite signal (NaN is refused as in :func:`butterworth_filtfilt`).
    fs : float
        Sampling frequency in Hz.
    fc_grid : array_like, optional
        Strictly increasing cut-offs (Hz) to evaluate, all in ``(0, fs/2)``, at least 6 of them.
        Default: 0.5 Hz to ``min(0.4 * fs, 30)`` Hz in steps of 0.25 Hz.
    order : int, default 2
        Butterworth order per pass (Winter's fourth-order zero-lag filter is ``order=2``).
    fit_range : (float, float), optional
        Frequency interval (Hz, inclusive) of the grid points the straight line is fitted to.
        Default (the fit-range rule): the upper third of the grid,
        ``f >= f_min + 2/3 · (f_max − f_min)``. The rule assumes the signal has (almost) no power
        in that band; when it does, pass ``fit_range`` (``info["fit_max_dev"]`` shows how far the
        residual curve departs from the line in the fitted band). At least 3 grid points must fall
        in the range.

    Returns
    -------
    fc_opt : float or numpy.ndarray
        The cut-off where :math:`R` first comes down to :math:`a` (scanning the grid upwards),
        linearly interpolated between the two bracketing grid points. For ``y`` of shape (N, D) the
        analysis is done per column and ``fc_opt`` has shape (D,). If :math:`R` is already
        :math:`\le a` at the first grid point the first grid point is returned, and if it never
        gets down to :math:`a` the last one; ``info["bracketed"]`` is False then.
    info : dict
        ``"fc_grid"`` (G,), ``"residuals"`` (G,) or (G, D), ``"intercept"`` :math:`a` (the noise
        RMS estimate), ``"slope"`` :math:`b` (per Hz), ``"fit_range"`` (lo, hi) in Hz actually
        spanned by the fitted grid points, ``"fit_mask"`` (G,) bool, ``"fit_max_dev"`` (largest
        absolute deviation of :math:`R` from the line within the fit range), ``"bracketed"``
        (bool). Per-column entries are scalars for 1-D ``y`` and arrays of shape (D,) otherwise.

    Raises
    ------
    InvalidParameterError
        Bad ``fs``, ``order``, ``fc_grid`` or ``fit_range``.
    InvalidSignalError
        Bad ``y`` (shape, NaN/inf, too short to filter).
    """
    fs = _positive_float(fs, "fs")
    order = _positive_int(order, "order")
    arr, was_1d = _signal_2d(y)

    if fc_grid is None:
        grid = _default_grid(fs)
    else:
        grid = np.asarray(fc_grid, dtype=float)
        if grid.ndim != 1 or grid.size < 6:
            raise InvalidParameterError(
                f"fc_grid must be 1-D with at least 6 cut-offs, got shape {grid.shape}"
            )
        if not np.all(np.isfinite(grid)) or np.any(np.diff(grid) <= 0):
            raise InvalidParameterError("fc_grid must be finite and strictly increasing")
        if grid[0] <= 0 or grid[-1] >= fs / 2:
            raise InvalidParameterError(
                f"fc_grid must lie in (0, fs/2) = (0, {fs / 2:g}) Hz, "
                f"got [{grid[0]:g}, {grid[-1]:g}]"
            )

    if fit_range is None:
        lo = grid[0] + (2.0 / 3.0) * (grid[-1] - grid[0])
        hi = grid[-1]
    else:
        try:
            lo, hi = (float(v) for v in fit_range)
        except (TypeError, ValueError):
            raise InvalidParameterError(
                f"fit_range must be a pair (lo, hi) of frequencies, got {fit_range!r}"
            ) from None
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise InvalidParameterError(f"fit_range must satisfy lo < hi, got {fit_range!r}")
    # a small tolerance so that a bound given as a grid value includes that grid point
    tol = 1e-9 * max(1.0, abs(grid[-1]))
    mask = (grid >= lo - tol) & (grid <= hi + tol)
    if mask.sum() < 3:
        raise InvalidParameterError(
            f"fit range [{lo:g}, {hi:g}] Hz holds {int(mask.sum())} grid cut-offs; "
            "at least 3 needed"
        )

    n_cols = arr.shape[1]
    residuals = np.empty((grid.size, n_cols))
    for k, f in enumerate(grid):
        filtered = butterworth_filtfilt(arr, fs, f, order=order, correct=True)
        residuals[k] = np.sqrt(np.mean((arr - filtered) ** 2, axis=0))

    fg = grid[mask]
    fc_opt = np.empty(n_cols)
    intercept = np.empty(n_cols)
    slope = np.empty(n_cols)
    max_dev = np.empty(n_cols)
    bracketed = np.empty(n_cols, dtype=bool)
    for j in range(n_cols):
        r = residuals[:, j]
        b, a = np.polyfit(fg, r[mask], 1)
        intercept[j], slope[j] = a, b
        max_dev[j] = float(np.max(np.abs(r[mask] - (a + b * fg))))
        below = np.nonzero(r <= a)[0]
        if below.size == 0:
            fc_opt[j], bracketed[j] = grid[-1], False
        elif below[0] == 0:
            fc_opt[j], bracketed[j] = grid[0], False
        else:
            i = below[0]
            r0, r1 = r[i - 1], r[i]
            frac = (r0 - a) / (r0 - r1)
            fc_opt[j] = grid[i - 1] + frac * (grid[i] - grid[i - 1])
            bracketed[j] = True

    def per_col(v: np.ndarray) -> Any:
        return v[0].item() if was_1d else v

    info: dict[str, Any] = {
        "fc_grid": grid,
        "residuals": residuals[:, 0] if was_1d else residuals,
        "intercept": per_col(intercept),
        "slope": per_col(slope),
        "fit_range": (float(fg[0]), float(fg[-1])),
        "fit_mask": mask,
        "fit_max_dev": per_col(max_dev),
        "bracketed": per_col(bracketed),
    }
    return per_col(fc_opt), info


# --------------------------------------------------------------------------------------------------
# smoothing spline
# --------------------------------------------------------------------------------------------------

_GCV_LOCK = threading.Lock()
_GCV_SEEN = threading.local()


def _gcv_spline(t: np.ndarray, y: np.ndarray) -> tuple[Any, float]:
    """``make_smoothing_spline(t, y, lam=None)`` and the GCV ``lam`` it used.

    SciPy does not return the GCV parameter, so its internal
    ``scipy.interpolate._bsplines._compute_optimal_gcv_parameter`` is wrapped for the duration of
    the call by a transparent wrapper that records the value (thread-locally) and returns it
    unchanged; the spline is SciPy's own. If that private function no longer exists, ``lam`` is NaN.
    """
    from scipy.interpolate import _bsplines

    with _GCV_LOCK:
        original = getattr(_bsplines, "_compute_optimal_gcv_parameter", None)
        if original is None:
            return make_smoothing_spline(t, y, lam=None), float("nan")

        def recording(*args: Any, **kwargs: Any) -> Any:
            lam = original(*args, **kwargs)
            _GCV_SEEN.lam = lam
            return lam

        _GCV_SEEN.lam = None
        _bsplines._compute_optimal_gcv_parameter = recording
        try:
            spl = make_smoothing_spline(t, y, lam=None)
        finally:
            if _bsplines._compute_optimal_gcv_parameter is recording:
                _bsplines._compute_optimal_gcv_parameter = original
        lam = _GCV_SEEN.lam
    return spl, (float("nan") if lam is None else float(np.asarray(lam).item()))


def smoothing_spline(t: Any, y: Any, lam: float | None = None) -> tuple[np.ndarray, Any]:
    r"""Cubic smoothing spline at the samples (``scipy.interpolate.make_smoothing_spline``).

    Minimises :math:`\sum_i (y_i - s(t_i))^2 + \lambda \int s''(u)^2\,du` over cubic splines
    :math:`s`; with ``lam=None`` :math:`\lambda` is chosen by generalised cross-validation (GCV).

    Parameters
    ----------
    t : array_like, shape (N,)
        Sample times in seconds (real timestamps; irregular sampling allowed), strictly
        increasing and finite, ``N >= 5``.
    y : array_like, shape (N,) or (N, D)
        Finite samples (NaN is refused, naming the first one). A 2-D array is smoothed column by
        column, each column with its own :math:`\lambda` (its own GCV choice when ``lam`` is None).
    lam : float, optional
        Smoothing parameter :math:`\lambda \ge 0` (in s³ when ``t`` is in seconds: it scales with
        the cube of the time unit), used for every column. None: GCV.

    Returns
    -------
    y_smooth : numpy.ndarray
        The spline at ``t``, same shape as ``y``.
    lam_used : float or numpy.ndarray
        The :math:`\lambda` used: float for 1-D ``y``, shape (D,) otherwise. With GCV it is the
        value SciPy chose (NaN if the installed SciPy does not expose it, see ``_gcv_spline``).

    Raises
    ------
    InvalidSignalError
        Bad ``t`` (not 1-D, not strictly increasing, not finite, fewer than 5 samples, length
        different from ``y``) or bad ``y`` (shape, NaN/inf).
    InvalidParameterError
        ``lam`` negative or not finite.
    """
    tt = np.asarray(t, dtype=float)
    if tt.ndim != 1:
        raise InvalidSignalError(f"t must be 1-D, got shape {tt.shape}")
    if not np.all(np.isfinite(tt)):
        raise InvalidSignalError(
            f"t contains a non-finite value at sample {int(np.argmin(np.isfinite(tt)))}"
        )
    if tt.size < 5:
        raise InvalidSignalError(f"a smoothing spline needs at least 5 samples, got {tt.size}")
    steps = np.diff(tt)
    if np.any(steps <= 0):
        i = int(np.argmax(steps <= 0))
        raise InvalidSignalError(
            f"t must be strictly increasing: t[{i + 1}] = {tt[i + 1]!r} <= t[{i}] = {tt[i]!r}"
        )
    arr, was_1d = _signal_2d(y)
    if arr.shape[0] != tt.size:
        raise InvalidSignalError(f"t has {tt.size} samples but y has {arr.shape[0]}")
    if lam is not None:
        try:
            lam_f = float(lam)
        except (TypeError, ValueError):
            raise InvalidParameterError(f"lam must be a number or None, got {lam!r}") from None
        if not np.isfinite(lam_f) or lam_f < 0:
            raise InvalidParameterError(f"lam must be finite and >= 0, got {lam!r}")

    out = np.empty_like(arr)
    lams = np.empty(arr.shape[1])
    for j in range(arr.shape[1]):
        if lam is None:
            spl, lams[j] = _gcv_spline(tt, arr[:, j])
        else:
            spl, lams[j] = make_smoothing_spline(tt, arr[:, j], lam=lam_f), lam_f
        out[:, j] = spl(tt)
    if was_1d:
        return out[:, 0], float(lams[0])
    return out, lams


# --------------------------------------------------------------------------------------------------
# overshoot at a step
# --------------------------------------------------------------------------------------------------


def step_overshoot(y_filtered: Any, y_clean_step: Any) -> float:
    """Overshoot of a smoothed step: the largest excursion beyond the step's levels / step height.

    With ``lo = min(y_clean_step)`` and ``hi = max(y_clean_step)`` (the two levels of a clean step,
    rising or falling), the overshoot is

    ``max(0, max(y_filtered) − hi, lo − min(y_filtered)) / (hi − lo)``,

    i.e. both the overshoot past the upper level and the undershoot (pre-shoot) past the lower level
    count, whichever is larger. 0 means the smoothed signal stays within the step's range (a
    monotone step response); 0.05 means it rings 5 % of the step height beyond a level.

    Parameters
    ----------
    y_filtered : array_like, shape (N,)
        The smoothed signal (finite).
    y_clean_step : array_like, shape (N,)
        The clean step it was made from (finite, not constant). Any clean signal is accepted; its
        range defines the levels.

    Returns
    -------
    float
        The overshoot as a fraction of the step height (>= 0).

    Raises
    ------
    InvalidSignalError
        Shapes differ or are not 1-D, non-finite values, or a constant ``y_clean_step``.
    """
    yf = np.asarray(y_filtered, dtype=float)
    yc = np.asarray(y_clean_step, dtype=float)
    if yf.ndim != 1 or yc.shape != yf.shape:
        raise InvalidSignalError(
            "y_filtered and y_clean_step must be 1-D of the same length, "
            f"got {yf.shape} and {yc.shape}"
        )
    _signal_2d(yf, "y_filtered")
    _signal_2d(yc, "y_clean_step")
    lo, hi = float(yc.min()), float(yc.max())
    height = hi - lo
    if not height > 0:
        raise InvalidSignalError("y_clean_step is constant: there is no step height to refer to")
    excursion = max(0.0, float(yf.max()) - hi, lo - float(yf.min()))
    return excursion / height
