"""Approximation quality: ICR (Eq. 1), angular deviation (Eq. 2), AAD (Eq. 3) and friends."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from mocapkit.motion import Signal
from mocapkit.pla.base import Compressed
from mocapkit.pla.decode import reconstruct
from mocapkit.quat import angular_distance


@dataclass(frozen=True)
class Metrics:
    """Quality of one compressed signal.

    For quaternion signals the deviations are rotation angles in degrees between every original
    sample and the SLERP reconstruction at its timestamp (Eq. 2); ``aad_deg`` is their mean (Eq. 3).
    ``point_mean_deg``/``point_max_deg`` measure the segment points themselves against the samples
    at the same times (Figure 4 right of the fastSW paper). For vector signals the deviations are
    Euclidean distances in the signal's units (the ``_deg`` names are then kept for the JSON shape
    but hold those distances; ``kind`` says which).
    """

    kind: str
    n_samples: int
    n_points: int
    icr: float
    mean_segment_length: float
    aad_deg: float
    max_deg: float
    std_deg: float
    point_mean_deg: float
    point_max_deg: float

    def as_dict(self) -> dict:
        return asdict(self)


def deviations(signal: Signal, comp: Compressed) -> np.ndarray:
    """Per-sample deviation of the decoded signal from the original (degrees for quaternions)."""
    rec = reconstruct(comp, signal.times)
    if signal.kind == "quaternion":
        return angular_distance(signal.values, rec, degrees=True)
    return np.linalg.norm(signal.values - rec, axis=1)


def point_deviations(signal: Signal, comp: Compressed) -> np.ndarray:
    """Deviation of each segment point from the original sample at the same time."""
    orig = signal.values[comp.indices]
    if signal.kind == "quaternion":
        return angular_distance(orig, comp.values, degrees=True)
    return np.linalg.norm(orig - comp.values, axis=1)


def evaluate(signal: Signal, comp: Compressed) -> Metrics:
    dev = deviations(signal, comp)
    pdev = point_deviations(signal, comp)
    return Metrics(
        kind=signal.kind,
        n_samples=len(signal),
        n_points=comp.n_points,
        icr=comp.icr,
        mean_segment_length=comp.mean_segment_length,
        aad_deg=float(dev.mean()),
        max_deg=float(dev.max()),
        std_deg=float(dev.std()),
        point_mean_deg=float(pdev.mean()),
        point_max_deg=float(pdev.max()),
    )
