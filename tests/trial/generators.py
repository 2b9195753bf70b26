"""Files built from scratch: deep hierarchies, wide hierarchies, endless and huge claims."""

from __future__ import annotations

import math


def bvh_chain(n_joints: int, n_frames: int = 4, rate: float = 30.0, wide: bool = False) -> str:
    """A BVH whose ``n_joints`` joints form one chain (or, with ``wide``, a root with ``n_joints - 1``
    children); 3 rotation channels per joint, small smooth angles."""
    lines = ["HIERARCHY", "ROOT J0", "{", "\tOFFSET 0 0 0",
             "\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"]
    if wide:
        for i in range(1, n_joints):
            lines += [f"\tJOINT J{i}", "\t{", "\t\tOFFSET 0 1 0", "\t\tCHANNELS 3 Zrotation Xrotation Yrotation",
                      "\t\tEnd Site", "\t\t{", "\t\t\tOFFSET 0 1 0", "\t\t}", "\t}"]
        lines.append("}")
    else:
        for i in range(1, n_joints):
            lines += [f"JOINT J{i}", "{", "OFFSET 0 1 0", "CHANNELS 3 Zrotation Xrotation Yrotation"]
        lines += ["End Site", "{", "OFFSET 0 1 0", "}"]
        lines += ["}"] * n_joints
    lines += ["MOTION", f"Frames: {n_frames}", f"Frame Time: {1.0 / rate:.6f}"]
    for f in range(n_frames):
        a = 0.1 * math.sin(f / 3.0)
        row = [f"{f * 0.5:.3f}", "90.0", "0.0", "0.0", "0.0", "0.0"]
        row += [f"{a:.4f}", f"{-a:.4f}", "0.0"] * (n_joints - 1)
        lines.append(" ".join(row))
    return "\n".join(lines) + "\n"


def asf_chain(n_bones: int) -> str:
    """An ASF whose ``n_bones`` bones form one chain below the root (1-3 dofs each)."""
    lines = [":version 1.10", ":name chain", ":units", "  mass 1.0", "  length 1.0", "  angle deg",
             ":documentation", "  generated", ":root", "   order TX TY TZ RX RY RZ", "   axis XYZ",
             "   position 0 0 0", "   orientation 0 0 0", ":bonedata"]
    for i in range(1, n_bones + 1):
        lines += ["  begin", f"     id {i}", f"     name b{i}", "     direction 0 1 0", "     length 1",
                  "     axis 0 0 0 XYZ", "    dof rx ry rz", "    limits (-180.0 180.0)", "           (-180.0 180.0)",
                  "           (-180.0 180.0)", "  end"]
    lines.append(":hierarchy")
    lines.append("  begin")
    lines.append("    root b1")
    for i in range(1, n_bones):
        lines.append(f"    b{i} b{i + 1}")
    lines.append("  end")
    return "\n".join(lines) + "\n"


def amc_for_chain(n_bones: int, n_frames: int = 3) -> str:
    lines = [":FULLY-SPECIFIED", ":DEGREES"]
    for f in range(1, n_frames + 1):
        lines.append(str(f))
        lines.append(f"root 0 {f * 0.1:.2f} 0 0 0 0")
        for i in range(1, n_bones + 1):
            lines.append(f"b{i} {0.5 * math.sin(f + i):.4f} 0 0")
    return "\n".join(lines) + "\n"


def qtm_claim(n_markers: int = 1_000_000_000, rows: int = 20) -> str:
    """A Qualisys TSV whose header claims ``n_markers`` markers (the data hold 2)."""
    head = [f"NO_OF_FRAMES\t{rows}", "NO_OF_CAMERAS\t8", f"NO_OF_MARKERS\t{n_markers}",
            "FREQUENCY\t100", "NO_OF_ANALOG\t0", "ANALOG_FREQUENCY\t0", "DESCRIPTION\t--", "TIME_STAMP\t2020-01-01",
            "DATA_INCLUDED\t3D", "MARKER_NAMES\ta\tb", "TRAJECTORY_TYPES\tMeasured\tMeasured"]
    head.append("Frame\tTime\ta X\ta Y\ta Z\tb X\tb Y\tb Z")
    rows_txt = [f"{i + 1}\t{i / 100:.3f}\t1.0\t2.0\t3.0\t4.0\t5.0\t6.0" for i in range(rows)]
    return "\n".join(head + rows_txt) + "\n"


def imu_csv(n_rows: int, rate: float = 100.0) -> str:
    """A plain ``time,w,x,y,z`` file of unit quaternions turning slowly."""
    out = ["time,w,x,y,z"]
    for i in range(n_rows):
        a = 0.01 * i
        out.append(f"{i / rate:.6f},{math.cos(a):.6f},{math.sin(a):.6f},0,0")
    return "\n".join(out) + "\n"
