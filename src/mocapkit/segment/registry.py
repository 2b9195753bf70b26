"""The baseline segmenters that the ARMA segmenter (:mod:`mocapkit.segment.arma`) is compared against,
by name: :data:`BASELINES`.

Every class follows :class:`~mocapkit.segment.base.Segmenter`: ``fit(X)`` then ``predict()`` (or
``fit_predict(X)``) returns the cut frames, a sorted ``int64`` array of 0-based frames ``c`` with
``0 < c < n`` (a new segment starts at frame ``c``). ``X`` is a ``(n,)`` or ``(n, d)`` float array,
e.g. limb angles in degrees at 120 Hz, root-relative joint positions, or a univariate benchmark
series. Lengths and widths are given in frames; the defaults are chosen for motion capture at
120 Hz, where an action lasts several seconds (one second is 120 frames).

* ``"pca"``: :class:`~mocapkit.segment.pca.PCASegmenter`, Barbič et al. (2004);
* ``"kmeans"``: :class:`~mocapkit.segment.kmeans.KMeansSegmenter`;
* ``"mlp"``: :class:`~mocapkit.segment.mlp.MLPSegmenter`, the seed paper's supervised BP-net;
* ``"kernelcpd"``: :class:`~mocapkit.segment.kernelcpd.KernelCPDSegmenter` (ruptures);
* ``"pelt"``: :class:`~mocapkit.segment.pelt.PELTSegmenter` (ruptures);
* ``"clasp"``: :class:`~mocapkit.segment.clasp.ClaSPSegmenter` (claspy).

The number of cuts is never an input, except through the explicit ``n_cuts`` parameter of the
change-point adapters (KernelCPD, PELT, ClaSP), which exists only for a separately reported "known
number of segments" mode; its default ``None`` means "unknown". The optional packages ruptures and
claspy (extra ``mocapkit[segment]``) and scikit-learn are imported only when a segmenter is fitted;
without ruptures or claspy an :class:`~mocapkit.errors.InvalidParameterError` explains how to install
them.
"""

from __future__ import annotations

from collections.abc import Callable

from mocapkit.segment.base import Segmenter
from mocapkit.segment.clasp import ClaSPSegmenter
from mocapkit.segment.kernelcpd import KernelCPDSegmenter
from mocapkit.segment.kmeans import KMeansSegmenter
from mocapkit.segment.mlp import MLPSegmenter
from mocapkit.segment.pca import PCASegmenter
from mocapkit.segment.pelt import PELTSegmenter

__all__ = ["BASELINES"]

BASELINES: dict[str, Callable[..., Segmenter]] = {  # the classes; each takes its own options
    "pca": PCASegmenter,
    "kmeans": KMeansSegmenter,
    "mlp": MLPSegmenter,
    "kernelcpd": KernelCPDSegmenter,
    "pelt": PELTSegmenter,
    "clasp": ClaSPSegmenter,
}
"""Name -> class of every baseline segmenter."""
