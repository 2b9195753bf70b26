"""Write an Xsens MVNX (version 4 layout) file from a CMU ASF/AMC take mapped onto the 23 MVN segments.

Used to make ``tests/data/mvnx/86_01_xsens_60hz.mvnx`` (no MVNX recording is available to the
project) and, inside the tests, longer or "soft body" variants::

    python tests/make_mvnx.py tests/data/cmu/86.asf tests/data/cmu/86_01_first60.amc \
        tests/data/mvnx/86_01_xsens_60hz.mvnx --rate 120 --stride 2

Mapping (CMU world: X left, Y up, Z forward -> MVN global: X forward, Y left, Z up; lengths in
metres from the ASF unit): every MVN segment takes the local rotation of a CMU bone, conjugated by
that axis permutation, so the rest (identity) pose is CMU's T-pose:

Pelvis root · L5 lowerback · L3 upperback · T12 none (identity; L3 and T12 each carry half of the
upperback bone, so the chain ends where CMU's does) · T8 thorax · Neck lowerneck · Head upperneck∘head ·
Right/LeftShoulder r/lclavicle · …UpperArm …humerus · …ForeArm …radius · …Hand …wrist∘…hand ·
…UpperLeg …femur · …LowerLeg …tibia · …Foot …foot · …Toe …toes.

The connector points are the CMU bone vectors; segment orientations (global, scalar first) and
positions (global, of each segment origin) are composed here with scipy, independently of mocapkit's
forward kinematics, and written with six decimals as MVN does. Three calibration frames
(``identity``, ``tpose``, ``tpose-isb``) come first. ``soft_m`` > 0 adds a seeded random change of
up to that many metres to every joint's connector vector in every frame (a "soft body" file).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

# MVN global = PERM @ CMU world
PERM = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def _side(s: str, c: str):
    """Right/left limb rows: (segment, parent, joint, CMU bones composed, connector CMU bone vectors)."""
    S = "Right" if s == "r" else "Left"
    return [
        (f"{S}Shoulder", "T8", f"j{S}T4Shoulder", [f"{c}clavicle"], ["thorax"]),
        (f"{S}UpperArm", f"{S}Shoulder", f"j{S}Shoulder", [f"{c}humerus"], [f"{c}clavicle"]),
        (f"{S}ForeArm", f"{S}UpperArm", f"j{S}Elbow", [f"{c}radius"], [f"{c}humerus"]),
        (f"{S}Hand", f"{S}ForeArm", f"j{S}Wrist", [f"{c}wrist", f"{c}hand"], [f"{c}radius"]),
    ]


def _leg(s: str, c: str):
    S = "Right" if s == "r" else "Left"
    return [
        (f"{S}UpperLeg", "Pelvis", f"j{S}Hip", [f"{c}femur"], [f"{c}hipjoint"]),
        (f"{S}LowerLeg", f"{S}UpperLeg", f"j{S}Knee", [f"{c}tibia"], [f"{c}femur"]),
        (f"{S}Foot", f"{S}LowerLeg", f"j{S}Ankle", [f"{c}foot"], [f"{c}tibia"]),
        (f"{S}Toe", f"{S}Foot", f"j{S}BallFoot", [f"{c}toes"], [f"{c}foot"]),
    ]


#: (segment, parent, joint label, CMU bones whose local rotations compose it, CMU bone vectors
#: summed into the connector1 point in the parent; "upperback/2" = half that vector)
SEGMENTS = [
    ("Pelvis", None, None, ["root"], []),
    ("L5", "Pelvis", "jL5S1", ["lowerback"], []),
    ("L3", "L5", "jL4L3", ["upperback"], ["lowerback"]),
    ("T12", "L3", "jL1T12", [], ["upperback/2"]),
    ("T8", "T12", "jT9T8", ["thorax"], ["upperback/2"]),
    ("Neck", "T8", "jT1C7", ["lowerneck"], ["thorax"]),
    ("Head", "Neck", "jC1Head", ["upperneck", "head"], ["lowerneck", "upperneck"]),
    *_side("r", "r"), *_side("l", "l"), *_leg("r", "r"), *_leg("l", "l"),
]
#: extra named points (not joints) per segment, as CMU bone vectors or fixed MVN-frame metres
TIPS = {"Head": ("pTopOfHead", ["head"]), "RightHand": ("pRightTopOfHand", ["rhand"]),
        "LeftHand": ("pLeftTopOfHand", ["lhand"]), "RightToe": ("pRightToe", ["rtoes"]),
        "LeftToe": ("pLeftToe", ["ltoes"])}
HEELS = {"RightFoot": ("pRightHeelFoot", (-0.04, 0.0, -0.06)), "LeftFoot": ("pLeftHeelFoot", (-0.04, 0.0, -0.06))}
SENSORS = ("Pelvis", "T8", "Head", "RightShoulder", "RightUpperArm", "RightForeArm", "RightHand", "LeftShoulder",
           "LeftUpperArm", "LeftForeArm", "LeftHand", "RightUpperLeg", "RightLowerLeg", "RightFoot",
           "LeftUpperLeg", "LeftLowerLeg", "LeftFoot")


def _vec(asf: dict, names: list[str], scale: float) -> np.ndarray:
    v = np.zeros(3)
    for n in names:
        name, _, half = n.partition("/")
        b = asf["bones"][name]
        v += np.asarray(b["direction"]) * b["length"] / (2.0 if half else 1.0)
    return PERM @ v * scale


def build(asf_path, amc_path, stride: int = 1, first: int = 0, count: int | None = None, soft_m: float = 0.0,
          seed: int = 0) -> dict:
    """The MVN arrays of a CMU take: labels, parents, points, globals ``(N, 23, 4)`` (scalar first),
    positions ``(N, 23, 3)`` and the rest (identity-pose) positions."""
    from mocapkit.io.skeletal.amc import read_amc, read_asf
    from mocapkit.quat import to_scipy

    sk = read_asf(asf_path)
    m = read_amc(amc_path, sk)
    asf = sk.meta["asf"]
    scale = sk.meta["length_unit_cm"] / 100.0
    stop = m.n_frames if count is None else first + count * stride
    frames = np.arange(first, min(stop, m.n_frames), stride)
    N = frames.size
    P = Rotation.from_matrix(PERM)
    labels = [s[0] for s in SEGMENTS]
    parents = [labels.index(s[1]) if s[1] else -1 for s in SEGMENTS]
    points = {}
    for lab, par, jl, _, vecs in SEGMENTS:
        points.setdefault(lab, {})
        if par is None:
            points[lab]["pHipOrigin"] = np.zeros(3)
        else:
            points[lab][jl] = np.zeros(3)
            points[par][jl] = _vec(asf, vecs, scale)
    for lab, (pt, vecs) in TIPS.items():
        points[lab][pt] = _vec(asf, vecs, scale)
    for lab, (pt, v) in HEELS.items():
        points[lab][pt] = np.asarray(v)
    rng = np.random.default_rng(seed)
    G = [None] * len(SEGMENTS)
    X = np.zeros((N, len(SEGMENTS), 3))
    rest = np.zeros((len(SEGMENTS), 3))
    for k, (_lab, par, jl, bones, _) in enumerate(SEGMENTS):
        local = Rotation.identity(N)
        for b in bones:
            local = local * to_scipy(m.rotations[frames, sk.index(b)])
        local = P * local * P.inv()
        if par is None:
            G[k] = local
            X[:, k] = (PERM @ m.translations[frames, sk.index("root")].T).T * scale
            continue
        p = parents[k]
        c1 = np.broadcast_to(points[par][jl], (N, 3))
        if soft_m > 0:
            c1 = c1 + rng.uniform(-soft_m, soft_m, size=(N, 3))
        G[k] = G[p] * local
        X[:, k] = X[:, p] + G[p].apply(c1)
        rest[k] = rest[p] + points[par][jl]
    quats = np.stack([g.as_quat() for g in G], axis=1)  # scalar last
    quats = np.concatenate([quats[..., 3:], quats[..., :3]], axis=-1)
    quats *= np.where(quats[..., :1] < 0, -1.0, 1.0)
    lowest = min(rest[:, 2].min(), min(rest[labels.index(s), 2] + v[2] for s, (_, v) in HEELS.items()))
    rest[:, 2] -= lowest
    return {"labels": labels, "parents": parents, "points": points, "quats": quats, "positions": X,
            "rest": rest, "frames": frames, "rate": 120.0 / stride}


def _nums(a) -> str:
    return " ".join(f"{v:.6f}" for v in np.asarray(a).ravel())


def write(path, data: dict, rate: float | None = None, note: str = "") -> None:
    """Write ``data`` (from :func:`build`) in the MVNX 4 layout."""
    rate = data["rate"] if rate is None else rate
    labels, points = data["labels"], data["points"]
    S = len(labels)
    out = ['<?xml version="1.0" encoding="UTF-8"?>',
           '<mvnx xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xmlns="http://www.xsens.com/mvn/mvnx" '
           'xsi:schemaLocation="http://www.xsens.com/mvn/mvnx http://www.xsens.com/mvn/mvnx/schema.xsd" version="4">',
           '\t<mvn version="2019.0.0" build="layout only: written by mocapkit tests/make_mvnx.py"/>',
           f"\t<comment>{note}</comment>",
           f'\t<subject label="CMU subject 86" torsoColor="#ea6852" frameRate="{rate:g}" segmentCount="{S}" '
           'recDate="Mon Nov 20 10:00:00.000 2023" configuration="FullBody" userScenario="singleLevel">',
           "\t\t<comment></comment>", "\t\t<segments>"]
    for i, lab in enumerate(labels):
        out.append(f'\t\t\t<segment label="{lab}" id="{i + 1}">')
        out.append("\t\t\t\t<points>")
        for pt, v in points[lab].items():
            out += [f'\t\t\t\t\t<point label="{pt}">', f"\t\t\t\t\t\t<pos_b>{_nums(v)}</pos_b>", "\t\t\t\t\t</point>"]
        out += ["\t\t\t\t</points>", "\t\t\t</segment>"]
    out.append("\t\t</segments>")
    out.append("\t\t<sensors>")
    out += [f'\t\t\t<sensor label="{s}"/>' for s in SENSORS]
    out.append("\t\t</sensors>")
    out.append("\t\t<joints>")
    for _k, (lab, par, jl, _, _) in enumerate(SEGMENTS):
        if par is not None:
            out += [f'\t\t\t<joint label="{jl}">', f"\t\t\t\t<connector1>{par}/{jl}</connector1>",
                    f"\t\t\t\t<connector2>{lab}/{jl}</connector2>", "\t\t\t</joint>"]
    out.append("\t\t</joints>")
    out.append(f'\t\t<frames segmentCount="{S}" sensorCount="{len(SENSORS)}" jointCount="{S - 1}">')
    ident = np.tile([1.0, 0, 0, 0], S)
    isb = np.tile([1.0, 0, 0, 0], (S, 1))
    for lab in labels:
        if "Arm" in lab or "Hand" in lab:
            s = 1.0 if lab.startswith("Left") else -1.0
            isb[labels.index(lab)] = [np.sqrt(0.5), s * np.sqrt(0.5), 0, 0]
    for kind, q in (("identity", ident), ("tpose", ident), ("tpose-isb", isb)):
        out += [f'\t\t\t<frame time="0" tc="00:00:00:00" ms="0" type="{kind}">',
                f"\t\t\t\t<orientation>{_nums(q)}</orientation>",
                f"\t\t\t\t<position>{_nums(data['rest'])}</position>", "\t\t\t</frame>"]
    epoch = 1700474400000
    for n in range(data["quats"].shape[0]):
        ms = int(round(n * 1000.0 / rate))
        sec, ff = divmod(n, int(round(rate)))
        tc = f"10:00:{sec:02d}:{ff:02d}"
        pos = data["positions"][n]
        out += [f'\t\t\t<frame time="{ms}" index="{n}" tc="{tc}" ms="{epoch + ms}" type="normal">',
                f"\t\t\t\t<orientation>{_nums(data['quats'][n])}</orientation>",
                f"\t\t\t\t<position>{_nums(pos)}</position>",
                "\t\t\t\t<footContacts>0 0 0 0</footContacts>",
                f"\t\t\t\t<centerOfMass>{_nums(pos[0])}</centerOfMass>", "\t\t\t</frame>"]
    out += ["\t\t</frames>", "\t</subject>", '\t<securityCode code="0"/>', "</mvnx>"]
    Path(path).write_text("\n".join(out) + "\n", encoding="utf-8")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("asf")
    ap.add_argument("amc")
    ap.add_argument("out")
    ap.add_argument("--rate", type=float, default=120.0, help="frame rate of the AMC take (Hz)")
    ap.add_argument("--stride", type=int, default=1)
    ap.add_argument("--first", type=int, default=0)
    ap.add_argument("--count", type=int, default=None)
    ap.add_argument("--soft", type=float, default=0.0, help="soft-body jitter of the connectors (m)")
    a = ap.parse_args(argv)
    data = build(a.asf, a.amc, a.stride, a.first, a.count, a.soft)
    note = (f"Not an Xsens recording: CMU {Path(a.amc).name} frames {data['frames'][0] + 1}-{data['frames'][-1] + 1} "
            f"(every {a.stride}) "
            "mapped onto the 23 MVN segments by mocapkit tests/make_mvnx.py")
    write(a.out, data, rate=a.rate / a.stride, note=note)


if __name__ == "__main__":
    main()
