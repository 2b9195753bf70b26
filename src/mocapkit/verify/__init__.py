"""Independent checks of what mocapkit writes: SLERP and the angle between orientations
(:mod:`~mocapkit.verify.quaternions`), forward kinematics with End Sites (:mod:`~mocapkit.verify.kinematics`)
and the comparisons of an original with its decode (:mod:`~mocapkit.verify.compare`).

None of this calls the encoders' or the model's kernels (``mocapkit.quat``, ``mocapkit.skeleton``'s forward
kinematics, ``mocapkit.clip.metric``): it is a second, small implementation, so that a defect in one is
seen by the other. Tests check both against scipy.
"""

import importlib as _importlib

TYPE_CHECKING = False
if TYPE_CHECKING:  # what __getattr__ loads on first use, for type checkers and tests/import_graph.py
    from mocapkit.verify.compare import (
        ImuComparison,
        SkeletalComparison,
        compare_imu,
        compare_skeletal,
    )
    from mocapkit.verify.kinematics import world_pose
    from mocapkit.verify.quaternions import angle_deg, slerp

#: module -> the names it gives the package on first use
_LAZY = {
    "mocapkit.verify.compare": ("ImuComparison", "SkeletalComparison", "compare_imu", "compare_skeletal"),
    "mocapkit.verify.kinematics": ("world_pose",),
    "mocapkit.verify.quaternions": ("angle_deg", "slerp"),
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


__all__ = ["ImuComparison", "SkeletalComparison", "angle_deg", "compare_imu", "compare_skeletal", "slerp",
           "world_pose"]
