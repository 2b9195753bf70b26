"""Start-up time of the command line and the package, side by side in one run on this machine.

Each case is a fresh process, timed from start to exit (wall clock): ``python -c pass`` (the interpreter
alone), ``python -c "import numpy"`` (the yardstick), ``mocapkit --version``, ``mocapkit --help``,
``mocapkit info <small BVH>`` and ``python -c "import mocapkit"``. The cases are interleaved (each repeat
runs every case once, in a rotated order) after one unmeasured warm-up run each, so a change in the
machine's load touches all of them alike; the median and the minimum of the repeats are reported, with the
ratio ``--version / import numpy`` (goal: at most 3) and the wall time of ``info`` (goal: at most 0.5 s).
The machine's load (``os.getloadavg``) before and after the run goes into the JSON.

    python benchmarks/startup.py [--repeats 15] [--json docs/startup_bench.json]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SMALL_BVH = ROOT / "tests" / "data" / "bvh" / "walk-meredith-60.bvh"
GOAL_VERSION_OVER_NUMPY = 3.0
GOAL_INFO_S = 0.5


def _mocapkit() -> list[str]:
    """The installed ``mocapkit`` command beside this interpreter, else ``python -m mocapkit``."""
    script = Path(sys.executable).parent / "mocapkit"
    found = str(script) if script.exists() else shutil.which("mocapkit")
    return [found] if found else [sys.executable, "-m", "mocapkit"]


def cases() -> dict[str, list[str]]:
    py, mk = sys.executable, _mocapkit()
    return {
        "python -c pass": [py, "-c", "pass"],
        "python -c 'import numpy'": [py, "-c", "import numpy"],
        "mocapkit --version": [*mk, "--version"],
        "mocapkit --help": [*mk, "--help"],
        f"mocapkit info {SMALL_BVH.name}": [*mk, "info", str(SMALL_BVH)],
        "python -c 'import mocapkit'": [py, "-c", "import mocapkit"],
    }


def wall(cmd: list[str], env: dict) -> float:
    """Seconds from start to exit of ``cmd`` (its output discarded); a failure stops the benchmark."""
    t0 = time.perf_counter()
    subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env, check=True)
    return time.perf_counter() - t0


def measure(repeats: int) -> dict[str, list[float]]:
    env = dict(os.environ, COLUMNS="100")
    todo = cases()
    names = list(todo)
    for cmd in todo.values():  # warm-up: bytecode and numba caches, the OS's file cache
        wall(cmd, env)
    times: dict[str, list[float]] = {n: [] for n in names}
    for r in range(repeats):
        for n in names[r % len(names):] + names[:r % len(names)]:
            times[n].append(wall(todo[n], env))
    return times


def summary(times: dict[str, list[float]]) -> dict:
    rows = {n: {"median_s": round(statistics.median(t), 4), "min_s": round(min(t), 4),
                "runs_s": [round(x, 4) for x in t]}
            for n, t in times.items()}
    names = list(times)
    numpy, version, info = rows[names[1]], rows[names[2]], rows[names[4]]
    ratios = {
        "version_over_import_numpy_median": round(version["median_s"] / numpy["median_s"], 3),
        "version_over_import_numpy_min": round(version["min_s"] / numpy["min_s"], 3),
        "goal_version_over_import_numpy": GOAL_VERSION_OVER_NUMPY,
        "info_wall_median_s": info["median_s"],
        "info_wall_min_s": info["min_s"],
        "goal_info_s": GOAL_INFO_S,
    }
    return {"cases": rows, "ratios": ratios}


def table(result: dict) -> str:
    lines = [f"{'case':<40} {'median s':>9} {'min s':>8}"]
    for n, r in result["cases"].items():
        lines.append(f"{n:<40} {r['median_s']:>9.3f} {r['min_s']:>8.3f}")
    q = result["ratios"]
    lines += ["",
              (f"--version / import numpy: {q['version_over_import_numpy_median']:.2f}x median, "
               f"{q['version_over_import_numpy_min']:.2f}x min (goal <= {GOAL_VERSION_OVER_NUMPY:g}x)"),
              (f"info wall: {q['info_wall_median_s']:.3f} s median, {q['info_wall_min_s']:.3f} s min "
               f"(goal <= {GOAL_INFO_S:g} s)")]
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=15, help="measured runs of each case (default 15)")
    ap.add_argument("--json", type=Path, help="write the figures here")
    args = ap.parse_args()
    load_before = os.getloadavg()
    uptime_before = subprocess.run(["uptime"], capture_output=True, text=True, check=False).stdout.strip()
    result = summary(measure(args.repeats))
    load_after = os.getloadavg()
    result["machine"] = {
        "python": platform.python_version(), "interpreter": sys.executable, "platform": platform.platform(),
        "cpus": os.cpu_count(),
        "load_average_1_5_15_before": [round(x, 2) for x in load_before],
        "load_average_1_5_15_after": [round(x, 2) for x in load_after],
        "uptime_before": uptime_before,
        "date_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }
    result["repeats"] = args.repeats
    mk = _mocapkit()
    result["command"] = "the mocapkit console script" if len(mk) == 1 else "python -m mocapkit"
    print(table(result))
    print(f"\nload average before {load_before[0]:.2f}, after {load_after[0]:.2f} "
          f"({os.cpu_count()} cpus, {args.repeats} runs each)")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()
