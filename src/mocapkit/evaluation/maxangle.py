"""How good is the online angle-bounded encoder? Compare it with the offline optimum and with the
paper's methods tuned to the same maximum angle.

The offline optimum (:mod:`mocapkit.pla.optimal`, also ``compress --method optimal``) is the fewest
segment points, drawn from the samples, such that every sample is within the bound of the SLERP
decode.
"""

from __future__ import annotations

from mocapkit.motion import Signal
from mocapkit.pla import compress_to, evaluate
from mocapkit.pla.optimal import optimal_max_angle


def compare(signals: dict[str, Signal], angles=(0.5, 1.0, 2.0, 5.0), max_segment_length: int = 200) -> list[dict]:
    """Points needed at each bound: optimum, anglesw (online), and each paper method tuned."""
    rows = []
    for deg in angles:
        tot = {"max_angle_deg": deg, "n_samples": sum(len(s) for s in signals.values())}
        worst: dict[str, float] = {}
        for sig in signals.values():
            runs = {"optimal": optimal_max_angle(sig, deg, max_segment_length)}
            for m in ("anglesw", "fastsw", "cplr", "swing"):
                runs[m] = compress_to(sig, m, max_angle=deg, max_segment_length=max_segment_length)
            for m, c in runs.items():
                tot[m] = tot.get(m, 0) + c.n_points
                worst[m] = max(worst.get(m, 0.0), evaluate(sig, c).max_deg)
        for m, w in worst.items():
            tot[f"{m}_max_deg"] = w
        rows.append(tot)
    return rows
