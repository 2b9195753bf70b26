"""Helpers shared by the baseline segmenters: parameter checks, the lazy import of an optional package,
per-channel standardisation and frame decimation."""

from __future__ import annotations

import importlib
import math
from typing import Any

import numpy as np

from mocapkit.errors import InvalidParameterError

__all__ = ["float_param", "int_param", "optional_module", "optional_n_cuts", "standardise", "take_every"]


def int_param(value: Any, name: str, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise InvalidParameterError(f"{name} must be an integer, got {value!r}")
    if value < minimum:
        raise InvalidParameterError(f"{name} must be >= {minimum}, got {value!r}")
    return int(value)


def float_param(value: Any, name: str, *, positive: bool = True) -> float:
    if isinstance(value, bool):
        raise InvalidParameterError(f"{name} must be a number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v) or (positive and v <= 0.0) or (not positive and v < 0.0):
        bound = "> 0" if positive else ">= 0"
        raise InvalidParameterError(f"{name} must be finite and {bound}, got {value!r}")
    return v


def optional_n_cuts(value: Any) -> int | str | None:
    """``None`` (the a-priori penalty), ``"auto"`` (the penalty of the cost curve,
    :func:`mocapkit.segment.autok.curve_penalty`) or a known number of cuts."""
    if value is None or value == "auto":
        return value
    return int_param(value, "n_cuts", 0)


def optional_module(module: str, package: str, owner: str) -> Any:
    try:
        return importlib.import_module(module)
    except ImportError:
        raise InvalidParameterError(
            f"{owner} needs the optional {package!r} package: pip install 'mocapkit[segment]'"
        ) from None


def standardise(x: np.ndarray) -> np.ndarray:
    """Each channel centred and scaled to unit standard deviation; a constant channel (standard deviation at most
    1e-8 of its level) becomes 0."""
    mu = x.mean(axis=0)
    sd = x.std(axis=0)
    const = sd <= 1e-8 * np.maximum(1.0, np.abs(mu))  # rounding-level wiggle counts as constant
    sd = np.where(const, 1.0, sd)
    z = (x - mu) / sd
    z[:, const] = 0.0
    return z


def take_every(x: np.ndarray, k: int) -> np.ndarray:
    return x[::k] if k > 1 else x
