"""Radio bytes per second of ``.mkp`` packet streams against a raw float32 quaternion stream.

For every sensor of every shared IMU quaternion recording (../shared/data/imu) at --max-angle 0.5, 1, 2
and 5 degrees, the C packetiser (float64 build; the float32 sensor build gives the same sizes to within
a few points, tests/test_mkp.py) with the default bits and 20-byte packets (BLE 4 ATT payload):
points, packets, bytes (headers and CRCs included), bytes per second at the sensor's rate, and the
ratio to a raw stream of 16 bytes (four float32) per sample at the same rate, and to a raw 100 Hz
stream (1600 bytes/s). The worst decoded error of every sample (SLERP at every tick) is recorded
beside it. Also the bits sweep on the x-io walk that chose the default (δ(B) <= 15% of the bound)
for 20-, 64- and 244-byte packets.

    python benchmarks/radio_bench.py [--json docs/radio_bench.json]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "imu"
ANGLES = (0.5, 1.0, 2.0, 5.0)
#: the sensors' nominal rates (../shared/data/README.md); x-io's logs drop samples, so the time
#: stamps alone would understate its 50 Hz
RATES = {"xio-lower-body": 50.0, "xsens-dot": 60.0, "xsens-mtmanager": 100.0, "apdm": 128.0, "optitrack": 120.0}
PACKET_BYTES = 20


def recordings():
    from mocapkit.io import load_signals

    for sub, rate in RATES.items():
        paths = [DATA / sub] if sub == "xio-lower-body" else sorted(p for p in (DATA / sub).iterdir() if p.is_file())
        for p in paths:
            for name, sig in load_signals(p).items():
                if sig.kind == "quaternion":
                    yield sub, p.name, name, sig, rate


def measure(sig, deg, bits, packet_bytes):
    from mocapkit.jobs.packets import decode_at
    from mocapkit.jobs.readers import read_mkp
    from mocapkit.pla.packet_layout import Header, Sensor, mkp_bytes
    from mocapkit.pla.packets import packetise
    from mocapkit.quat import angular_distance

    pk = packetise(sig.values, deg, bits=bits, packet_bytes=packet_bytes)
    s = read_mkp("bench", data=mkp_bytes(Header(bits, packet_bytes, deg, 1000, (Sensor("s", 50.0, 0.0),)),
                                         pk.packets)).streams["s"]
    keep, dec = decode_at(s.ticks, s.values, s.gap_before, np.arange(len(sig), dtype=np.float64))
    assert keep.all()
    err = float(np.degrees(angular_distance(dec, sig.values)).max())
    return pk, sum(len(p) for p in pk.packets), err


def main() -> int:
    from mocapkit.pla.packet_layout import delta_bound
    from mocapkit.pla.packets import DEFAULT_FRACTION, default_bits

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    if not DATA.is_dir():
        print(f"no shared data at {DATA}", file=sys.stderr)
        return 1
    rows = []
    recs = list(recordings())
    for sub, file, name, sig, rate in recs:
        n = len(sig)
        for deg in ANGLES:
            bits = default_bits(deg)
            pk, nbytes, err = measure(sig, deg, bits, PACKET_BYTES)
            bps = nbytes / n * rate
            rows.append({"recording": sub, "file": file, "sensor": name, "rate_hz": rate, "samples": n,
                         "max_angle_deg": deg, "bits": bits, "points": len(pk.ticks),
                         "packets": len(pk.packets), "bytes": nbytes, "bytes_per_s": bps,
                         "raw_float32_bytes_per_s": 16 * rate, "ratio": nbytes / (16 * n),
                         "ratio_raw_100hz": bps / 1600.0, "max_error_deg": err})
            print(f"{sub:15s} {name[:24]:24s} {deg:4.1f}° B={bits:2d} {len(pk.ticks):5d} pts {len(pk.packets):5d} pk "
                  f"{nbytes:6d} B {bps:7.1f} B/s  ratio {nbytes / (16 * n):.4f}  max {err:.3f}°", file=sys.stderr)
    walk = {}
    for deg in ANGLES:
        sel = [r for r in rows if r["recording"] == "xio-lower-body" and r["max_angle_deg"] == deg]
        total = sum(r["bytes"] for r in sel)
        samples = sum(r["samples"] for r in sel)
        walk[str(deg)] = {"sensors": len(sel), "bytes": total, "bytes_per_s": sum(r["bytes_per_s"] for r in sel),
                          "raw_float32_bytes_per_s": 16 * 50.0 * len(sel), "ratio": total / (16 * samples),
                          "worst_sensor_ratio": max(r["ratio"] for r in sel)}
        print(f"x-io walk, 7 sensors, {deg}°: {walk[str(deg)]['bytes_per_s']:.0f} B/s of "
              f"{16 * 50 * len(sel):.0f} raw: ratio {walk[str(deg)]['ratio']:.4f} "
              f"(worst sensor {walk[str(deg)]['worst_sensor_ratio']:.4f})", file=sys.stderr)
    sweep = []
    walk_sigs = [r[3] for r in recs if r[0] == "xio-lower-body"]
    for pb in (20, 64, 244):
        for deg in ANGLES:
            for bits in range(7, 17):
                if math.radians(deg) - delta_bound(bits) - 1e-6 <= 0:
                    continue
                from mocapkit.pla.packets import packetise

                total = sum(sum(len(p) for p in packetise(s.values, deg, bits=bits, packet_bytes=pb).packets)
                            for s in walk_sigs)
                sweep.append({"packet_bytes": pb, "max_angle_deg": deg, "bits": bits, "bytes": total,
                              "delta_fraction": delta_bound(bits) / math.radians(deg)})
            best = min((s for s in sweep if s["packet_bytes"] == pb and s["max_angle_deg"] == deg),
                       key=lambda s: s["bytes"])
            print(f"sweep {pb:3d} B packets {deg}°: fewest bytes at B={best['bits']} "
                  f"(δ = {best['delta_fraction']:.3f} of the bound); default B={default_bits(deg)}", file=sys.stderr)
    out = {"packet_bytes": PACKET_BYTES, "default_fraction": DEFAULT_FRACTION, "rows": rows, "walk": walk,
           "bits_sweep_walk": sweep}
    if args.json:
        from mocapkit.io.atomic import atomic_write_text

        atomic_write_text(args.json, json.dumps(out, indent=1, allow_nan=False) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
