"""Limb-bone partition angles: the body representation of the ARMA segmentation paper.

World joint positions come from forward kinematics (Eq. 1–3 of the ARMA seed paper: BVH/AMC Euler
angles → rotation matrices → positions; :func:`mocapkit.skeleton.forward_kinematics` does this for
any channel order). Each of the 8 limb bones of Table 2 (thigh, shin, upper arm, forearm per side)
is compared with the central bone root → spine by the angle of Eq. 4,

    θ = arccos(θ_A · θ_B / (|θ_A| |θ_B|)) ∈ [0°, 180°],

and the two bones of a limb are averaged into the 4 limb angles of Table 3 (right leg, left leg,
right arm, left arm; the table's second "right arm" row is the left arm).

Joint roles are found by name with maps for CMU ASF/AMC, Perception Neuron / Axis Neuron BVH and
the common ``Hips/RightUpLeg/...`` BVH naming and Xsens MVNX segments; any role can be overridden by the user.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mocapkit.errors import InvalidParameterError, InvalidSignalError

#: The joint roles a limb-angle computation needs. A bone runs from one role's joint to the next.
ROLES = (
    "root", "spine",
    "r_hip", "r_knee", "r_ankle", "l_hip", "l_knee", "l_ankle",
    "r_shoulder", "r_elbow", "r_wrist", "l_shoulder", "l_elbow", "l_wrist",
)

#: Candidate joint names per role, tried in order (case-insensitive). A joint's position is where
#: its bone starts (BVH and our ASF reading alike), so the knee is the start of the shin bone, etc.
#: ``spine`` is the top of the spine (base of the neck): CMU ``lowerneck``, Perception Neuron
#: ``Neck``; skeletons with a single ``Spine`` bone under the head use ``Head``.
JOINT_CANDIDATES: dict[str, tuple[str, ...]] = {
    "root": ("root", "Hips", "hip", "pelvis", "Hip"),
    "spine": ("lowerneck", "Neck", "neck", "Neck1", "Head", "head"),
    "r_hip": ("rfemur", "RightUpLeg", "RightHip", "RThigh", "rThigh", "RightUpperLeg"),
    "r_knee": ("rtibia", "RightLeg", "RightKnee", "RShin", "rShin", "RightLowerLeg"),
    "r_ankle": ("rfoot", "RightFoot", "RightAnkle", "RFoot", "rFoot"),
    "l_hip": ("lfemur", "LeftUpLeg", "LeftHip", "LThigh", "lThigh", "LeftUpperLeg"),
    "l_knee": ("ltibia", "LeftLeg", "LeftKnee", "LShin", "lShin", "LeftLowerLeg"),
    "l_ankle": ("lfoot", "LeftFoot", "LeftAnkle", "LFoot", "lFoot"),
    "r_shoulder": ("rhumerus", "RightArm", "RightUpperArm", "RightShoulder", "RUpArm", "rShldr"),
    "r_elbow": ("rradius", "RightForeArm", "RightElbow", "RLowArm", "rForeArm"),
    "r_wrist": ("rwrist", "RightHand", "RightWrist", "RHand", "rHand"),
    "l_shoulder": ("lhumerus", "LeftArm", "LeftUpperArm", "LeftShoulder", "LUpArm", "lShldr"),
    "l_elbow": ("lradius", "LeftForeArm", "LeftElbow", "LLowArm", "lForeArm"),
    "l_wrist": ("lwrist", "LeftHand", "LeftWrist", "LHand", "lHand"),
}
# Perception Neuron names its shoulder girdle "RightShoulder" and the upper arm "RightArm": the
# upper-arm start is "RightArm", so that name is tried first above; "RightShoulder" only serves
# skeletons without an "...Arm" joint. Xsens MVNX segments (Pelvis, Neck, RightUpperLeg,
# RightLowerLeg, RightFoot, RightShoulder = clavicle, RightUpperArm, RightForeArm, RightHand) are
# placed at their proximal joint, so "RightUpperArm" (the glenohumeral joint) precedes
# "RightShoulder" and the spine top is "Neck" (jT1C7).

#: The 8 bones of Table 2 as (start role, end role), in the paper's order θ1..θ8.
PARTITION_BONES = (
    ("r_hip", "r_knee"),          # θ1 RHI → RK
    ("r_knee", "r_ankle"),        # θ2 RK → RA
    ("l_hip", "l_knee"),          # θ3 LHI → LK
    ("l_knee", "l_ankle"),        # θ4 LK → LA
    ("r_shoulder", "r_elbow"),    # θ5 RUA → RDA
    ("r_elbow", "r_wrist"),       # θ6 RDA → RH
    ("l_shoulder", "l_elbow"),    # θ7 LUA → LDA
    ("l_elbow", "l_wrist"),       # θ8 LDA → LH
)
PARTITION_NAMES = tuple(f"theta{i}" for i in range(1, 9))
#: Table 3: θa right leg = mean(θ1, θ2), θb left leg = mean(θ3, θ4), θc right arm, θd left arm.
LIMB_NAMES = ("right_leg", "left_leg", "right_arm", "left_arm")
LIMB_PARTS = ((0, 1), (2, 3), (4, 5), (6, 7))


def resolve_joint_map(names, overrides: dict[str, str] | None = None) -> dict[str, str]:
    """Role → joint name for a skeleton with joint ``names``.

    Each role takes the first of :data:`JOINT_CANDIDATES` present (case-insensitive, ignoring a
    ``namespace:`` prefix such as Mixamo's ``mixamorig:``); ``overrides``
    (role → exact joint name) wins. Raises :class:`InvalidParameterError` naming every role that
    could not be found, the names tried and the skeleton's joints.
    """
    names = tuple(names)
    lower = {n.lower(): n for n in names}
    for n in names:  # a rig namespace ("mixamorig:Hips", "Subject:RightUpLeg") matches the bare name too
        bare = n.rpartition(":")[2].lower()
        if bare and bare not in lower:
            lower[bare] = n
    overrides = dict(overrides or {})
    unknown = set(overrides) - set(ROLES)
    if unknown:
        raise InvalidParameterError(f"unknown joint role(s) {sorted(unknown)}; roles are {', '.join(ROLES)}")
    out: dict[str, str] = {}
    missing = []
    for role in ROLES:
        if role in overrides:
            name = overrides[role]
            if name not in names:
                raise InvalidParameterError(
                    f"joint map: role {role!r} → {name!r}, but the skeleton has no joint {name!r}"
                )
            out[role] = name
            continue
        for cand in JOINT_CANDIDATES[role]:
            if cand.lower() in lower:
                out[role] = lower[cand.lower()]
                break
        else:
            missing.append(role)
    if missing:
        tried = "; ".join(f"{r}: {', '.join(JOINT_CANDIDATES[r])}" for r in missing)
        raise InvalidParameterError(
            f"cannot find the joint for role(s) {', '.join(missing)} (tried {tried}); the skeleton has "
            f"{', '.join(names[:40])}{f' and {len(names) - 40} more joints' if len(names) > 40 else ''}. "
            "Give them as ROLE=JOINT (e.g. --joint spine=Spine3)"
        )
    return out


def bone_angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle in degrees between vectors ``a`` and ``b`` (``(..., 3)``), Eq. 4.

    Computed as ``atan2(|a × b|, a · b)``, which equals ``arccos(a·b / (|a||b|))`` and stays accurate
    near 0° and 180°. A zero-length vector raises :class:`InvalidSignalError`.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    na = np.linalg.norm(a, axis=-1)
    nb = np.linalg.norm(b, axis=-1)
    if (na == 0).any() or (nb == 0).any():
        raise InvalidSignalError("a bone vector has zero length (two mapped joints coincide)")
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    dot = np.einsum("...i,...i->...", a, b)
    return np.degrees(np.arctan2(cross, dot))


def partition_angles(positions: np.ndarray, index: dict[str, int]) -> np.ndarray:
    """The 8 limb-bone partition angles of Table 2, ``(N, 8)`` degrees.

    ``positions`` is ``(N, J, 3)`` world joint positions, ``index`` maps each role to its joint column.
    """
    P = np.asarray(positions, dtype=np.float64)
    central = P[:, index["spine"]] - P[:, index["root"]]
    out = np.empty((P.shape[0], 8))
    for k, (s, e) in enumerate(PARTITION_BONES):
        out[:, k] = bone_angles(P[:, index[e]] - P[:, index[s]], central)
    return out


def limb_angles(partition: np.ndarray) -> np.ndarray:
    """The 4 limb angles of Table 3 (mean of each limb's two partition angles), ``(N, 4)``."""
    P = np.asarray(partition, dtype=np.float64)
    return np.stack([(P[:, i] + P[:, j]) / 2 for i, j in LIMB_PARTS], axis=1)


@dataclass(frozen=True)
class LimbFeatures:
    """Limb features of one take: ``partition`` ``(N, 8)`` and ``limbs`` ``(N, 4)`` in degrees."""

    partition: np.ndarray
    limbs: np.ndarray
    rate_hz: float
    joint_map: dict

    @property
    def n_frames(self) -> int:
        return int(self.limbs.shape[0])


def motion_features(motion, joint_map: dict[str, str] | None = None) -> LimbFeatures:
    """Limb-bone partition angles and limb angles of a :class:`~mocapkit.skeleton.Motion`."""
    from mocapkit.skeleton import forward_kinematics

    sk = motion.skeleton
    roles = resolve_joint_map(sk.names, joint_map)
    index = {r: sk.index(n) for r, n in roles.items()}
    P = forward_kinematics(motion)[0]
    part = partition_angles(P, index)
    return LimbFeatures(partition=part, limbs=limb_angles(part), rate_hz=float(motion.rate), joint_map=roles)


def pose_features(motion) -> np.ndarray:
    """Root-relative world positions of every non-root joint, ``(N, 3(J-1))``, in file units.

    The pose description given to the PCA baseline (Barbič et al. 2004 work on the whole pose).
    Joints that coincide with the root in every frame (zero offsets) are dropped.
    """
    from mocapkit.skeleton import forward_kinematics

    P = forward_kinematics(motion)[0]
    roots = np.flatnonzero(np.asarray(motion.skeleton.parents) < 0)
    rel = P - P[:, roots[:1]]
    keep = [j for j in range(P.shape[1]) if j not in set(roots.tolist()) and np.abs(rel[:, j]).max() > 0]
    return rel[:, keep].reshape(P.shape[0], -1)
