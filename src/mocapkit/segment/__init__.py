"""Segmentation of motion into actions.

``features`` (limb-bone/spine partition angles, Tables 2–3 of the ARMA seed paper), ``arma`` (the
seed paper's ARMA segmenter), ``baselines`` (PCA, K-means, MLP, ruptures and claspy adapters),
``metrics`` (RI, F1 with margin, Covering). Every segmenter has the ``fit(X).predict()`` /
``fit_predict(X)`` shape of ruptures and claspy and returns sorted 0-based cut frames.
"""

from mocapkit.segment.arma import ARMASegmenter
from mocapkit.segment.base import Segmenter
from mocapkit.segment.baselines import (
    BASELINES,
    ClaSPSegmenter,
    KernelCPDSegmenter,
    KMeansSegmenter,
    MLPSegmenter,
    PCASegmenter,
    PELTSegmenter,
)
from mocapkit.segment.features import LIMB_NAMES, LimbFeatures, motion_features, pose_features
from mocapkit.segment.metrics import F1Result, accuracy_ri, covering, f1_margin

__all__ = [
    "ARMASegmenter",
    "BASELINES",
    "ClaSPSegmenter",
    "F1Result",
    "KMeansSegmenter",
    "KernelCPDSegmenter",
    "LIMB_NAMES",
    "LimbFeatures",
    "MLPSegmenter",
    "PCASegmenter",
    "PELTSegmenter",
    "Segmenter",
    "accuracy_ri",
    "covering",
    "f1_margin",
    "motion_features",
    "pose_features",
]
