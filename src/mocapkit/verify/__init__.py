"""Independent checks of what mocapkit writes: SLERP and the angle between orientations
(:mod:`~mocapkit.verify.quaternions`), forward kinematics with End Sites (:mod:`~mocapkit.verify.kinematics`)
and the comparisons of an original with its decode (:mod:`~mocapkit.verify.compare`).

None of this calls the encoders' or the model's kernels (``mocapkit.quat``, ``mocapkit.skeleton``'s forward
kinematics, ``mocapkit.clip.metric``): it is a second, small implementation, so that a defect in one is
seen by the other. Tests check both against scipy.
"""

from mocapkit.verify.compare import ImuComparison, SkeletalComparison, compare_imu, compare_skeletal
from mocapkit.verify.kinematics import world_pose
from mocapkit.verify.quaternions import angle_deg, slerp

__all__ = ["ImuComparison", "SkeletalComparison", "angle_deg", "compare_imu", "compare_skeletal", "slerp",
           "world_pose"]
