"""Three faults mypy found (issue 25): each once raised a TypeError far from its cause, or returned None
where an array was promised."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mocapkit.errors import InvalidParameterError
from mocapkit.evaluation.segmentation import MOCAP_TAKES, Take, features_for, run_mocap
from mocapkit.io.skeletal.labels import Reference
from mocapkit.segment import ClaSPSegmenter


def test_clasp_refuses_n_cuts_auto_when_built():
    # "auto" (a penalty read off a cost curve) is a mode of the ruptures methods only; ClaSP took it and
    # failed in fit() with "can only concatenate str (not "int") to str"
    with pytest.raises(InvalidParameterError, match=r"n_cuts='auto' is not a ClaSP mode"):
        ClaSPSegmenter(n_cuts="auto")
    assert ClaSPSegmenter().n_cuts is None
    assert ClaSPSegmenter(n_cuts=3).n_cuts == 3


def _take(partition: np.ndarray | None) -> Take:
    n = 10
    limbs = np.arange(4 * n, dtype=np.float64).reshape(n, 4)
    ref = Reference(n, np.array([5]), np.array([[5, 5]]), ("a", "b"))
    return Take("hand-made", limbs, limbs.copy(), ref, np.array(["a"] * 5 + ["b"] * 5, dtype=object), partition)


def test_features_for_auto_needs_the_partition_angles():
    with pytest.raises(InvalidParameterError, match=r"hand-made: method 'auto' needs the take's 8 partition angles"):
        features_for("auto", _take(None))
    part = np.ones((10, 8))
    assert features_for("auto", _take(part)) is part
    assert features_for("kmeans", _take(None)).shape == (10, 4)  # the limb angles need no partition


def test_run_mocap_takes_the_cmu_folder_as_a_string(shared_data: Path):
    cmu = shared_data / "cmu"
    from_str = run_mocap(str(cmu), methods=("every400",))
    from_path = run_mocap(cmu, methods=("every400",))
    assert [r["take"] for r in from_str] == list(MOCAP_TAKES)
    for a, b in zip(from_str, from_path, strict=True):
        assert {k: v for k, v in a.items() if k != "seconds"} == {k: v for k, v in b.items() if k != "seconds"}
        assert a["cuts"] == list(range(400, a["n_frames"], 400))  # every400 cuts every 400 frames
