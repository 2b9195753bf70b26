"""Segmentation of motion into actions.

``features`` (limb-bone/spine partition angles, Tables 2–3 of the ARMA seed paper), ``arma`` (the
seed paper's ARMA segmenter), ``autok`` (the number of segments chosen without labels; ``AutoSegmenter``
is ``segment --method auto``), the baselines one module each -- ``pca`` (Barbič et al. 2004), ``kmeans``,
``mlp`` (the seed paper's BP-net), ``kernelcpd`` and ``pelt`` (ruptures adapters, with the shared
penalty of ``cpdpenalty``), ``clasp`` (claspy adapter) -- gathered by name in ``registry.BASELINES``,
``metrics`` (the paper's RI as its authors compute it, frame agreement, F1 with margin, Covering),
``similarity`` (DTW and the correlation of aligned sequences, Eq. 5–9), ``diagnostics`` (ACF, PACF,
Ljung–Box, the differencing study), ``naming`` and ``cluster_metrics`` (actions named across takes,
purity, NMI, frame accuracy) and ``synthetic`` (signals with known changes). Every segmenter has the
``fit(X).predict()`` / ``fit_predict(X)`` shape of ruptures and claspy and returns sorted 0-based cut
frames.
"""

import importlib as _importlib

TYPE_CHECKING = False
if TYPE_CHECKING:  # what __getattr__ loads on first use, for type checkers and tests/import_graph.py
    from mocapkit.segment.arma import ARMASegmenter
    from mocapkit.segment.autok import AutoSegmenter, choose_k, cost_curve
    from mocapkit.segment.base import Segmenter
    from mocapkit.segment.clasp import ClaSPSegmenter
    from mocapkit.segment.cluster_metrics import frame_accuracy, nmi, purity
    from mocapkit.segment.features import (
        LIMB_NAMES,
        LimbFeatures,
        motion_features,
        pose_features,
    )
    from mocapkit.segment.kernelcpd import KernelCPDSegmenter
    from mocapkit.segment.kmeans import KMeansSegmenter
    from mocapkit.segment.metrics import (
        F1Result,
        covering,
        f1_margin,
        frame_agreement,
        ri_paper,
    )
    from mocapkit.segment.mlp import MLPSegmenter
    from mocapkit.segment.naming import Naming, name_actions, name_segments
    from mocapkit.segment.pca import PCASegmenter
    from mocapkit.segment.pelt import PELTSegmenter
    from mocapkit.segment.registry import BASELINES
    from mocapkit.segment.similarity import (
        DTWResult,
        LabelledSegment,
        PairSimilarity,
        dtw,
        sequence_similarity,
        similarity_table,
    )

#: module -> the names it gives the package on first use
_LAZY = {
    "mocapkit.segment.arma": ("ARMASegmenter",),
    "mocapkit.segment.base": ("Segmenter",),
    "mocapkit.segment.clasp": ("ClaSPSegmenter",),
    "mocapkit.segment.features": ("LIMB_NAMES", "LimbFeatures", "motion_features", "pose_features"),
    "mocapkit.segment.kernelcpd": ("KernelCPDSegmenter",),
    "mocapkit.segment.kmeans": ("KMeansSegmenter",),
    "mocapkit.segment.autok": ("AutoSegmenter", "choose_k", "cost_curve"),
    "mocapkit.segment.cluster_metrics": ("frame_accuracy", "nmi", "purity"),
    "mocapkit.segment.naming": ("Naming", "name_actions", "name_segments"),
    "mocapkit.segment.metrics": ("F1Result", "covering", "f1_margin", "frame_agreement", "ri_paper"),
    "mocapkit.segment.mlp": ("MLPSegmenter",),
    "mocapkit.segment.pca": ("PCASegmenter",),
    "mocapkit.segment.pelt": ("PELTSegmenter",),
    "mocapkit.segment.registry": ("BASELINES",),
    "mocapkit.segment.similarity": ("DTWResult", "LabelledSegment", "PairSimilarity", "dtw", "sequence_similarity",
                                    "similarity_table"),
}
_WHERE = {name: module for module, names in _LAZY.items() for name in names}


def __getattr__(name: str):
    """A name of ``__all__``, imported from its module on first use (PEP 562) and then kept."""
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(_importlib.import_module(_WHERE[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


__all__ = [
    "ARMASegmenter",
    "AutoSegmenter",
    "Naming",
    "frame_accuracy",
    "name_actions",
    "name_segments",
    "nmi",
    "purity",
    "choose_k",
    "cost_curve",
    "ri_paper",
    "BASELINES",
    "ClaSPSegmenter",
    "DTWResult",
    "F1Result",
    "KMeansSegmenter",
    "KernelCPDSegmenter",
    "LIMB_NAMES",
    "LabelledSegment",
    "LimbFeatures",
    "MLPSegmenter",
    "PCASegmenter",
    "PELTSegmenter",
    "PairSimilarity",
    "Segmenter",
    "frame_agreement",
    "covering",
    "dtw",
    "f1_margin",
    "motion_features",
    "pose_features",
    "sequence_similarity",
    "similarity_table",
]
