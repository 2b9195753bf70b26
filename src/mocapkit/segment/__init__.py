"""Segmentation of motion into actions.

``features`` (limb-bone/spine partition angles, Tables 2–3 of the ARMA seed paper), ``arma`` (the
seed paper's ARMA segmenter), the baselines one module each -- ``pca`` (Barbič et al. 2004), ``kmeans``,
``mlp`` (the seed paper's BP-net), ``kernelcpd`` and ``pelt`` (ruptures adapters, with the shared
penalty of ``cpdpenalty``), ``clasp`` (claspy adapter) -- gathered by name in ``registry.BASELINES``,
and ``metrics`` (RI, F1 with margin, Covering). Every segmenter has the ``fit(X).predict()`` /
``fit_predict(X)`` shape of ruptures and claspy and returns sorted 0-based cut frames.
"""

from mocapkit.segment.arma import ARMASegmenter
from mocapkit.segment.base import Segmenter
from mocapkit.segment.clasp import ClaSPSegmenter
from mocapkit.segment.features import LIMB_NAMES, LimbFeatures, motion_features, pose_features
from mocapkit.segment.kernelcpd import KernelCPDSegmenter
from mocapkit.segment.kmeans import KMeansSegmenter
from mocapkit.segment.metrics import F1Result, accuracy_ri, covering, f1_margin
from mocapkit.segment.mlp import MLPSegmenter
from mocapkit.segment.pca import PCASegmenter
from mocapkit.segment.pelt import PELTSegmenter
from mocapkit.segment.registry import BASELINES

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
