"""The adversarial trial of issue 10: thousands of mutated files, odd paths, extreme options, kills.

Usage (``make fuzz`` runs it with 5,000 cases)::

    .venv/bin/python tools/trial.py --cases 5000 --out trial-report [--jobs 2] [--seed 1]
        [--categories mutation,values,...] [--mode fork|subprocess]

Prints a table of category × outcome counts and the failing cases grouped by owner area, writes
``OUT/report.json`` (every case) and ``OUT/report.md``, keeps the input files of every failing case in
``OUT/cases/<id>/`` (passing cases are deleted), and exits 1 when any case crashed, hung, blew up its
memory, gave a wrong-but-silent result, modified its input, wrote outside its output folder or replaced a
device, pipe or symlink (``exceeded``, a ``verify`` bound exceeded, and ``partial``, a batch with error rows,
are counted, not failures).
Parts: ``tests/trial`` (seeds, mutators, generators, runner, oracle, cases).
"""

from __future__ import annotations

import argparse
import collections
import json
import random
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.trial import cases as C  # noqa: E402
from tests.trial import oracle, runner  # noqa: E402
from tests.trial import seeds as S  # noqa: E402

WEIGHTS = {"mutation": 40, "values": 15, "cut_number": 8, "deep": 0.6, "huge": 5, "paths": 12, "options": 10,
           "usage": 3, "kill": 4, "sql": 5, "manifest": 3}


def plan(n: int, categories: list[str], seed: int) -> list[str]:
    """The category of each of the ``n`` cases (deterministic for a seed)."""
    rng = random.Random(f"plan-{seed}")
    w = [WEIGHTS[c] for c in categories]
    return rng.choices(categories, weights=w, k=n)


def _seed_list(work: Path, mode: str) -> list[S.Seed]:
    return S.build_seeds(work, lambda argv, timeout=120: runner.run_cli(argv, timeout=timeout, mode=mode))


def _check_seeds(seeds: list[S.Seed], work: Path, mode: str) -> list[dict]:
    """Run every command on every unmutated seed; drop those that fail (they are reported)."""
    problems = []
    for s in seeds:
        keep = []
        for cmd in s.commands:
            d = work / "seedcheck" / s.name
            shutil.rmtree(d, ignore_errors=True)
            (d / "out").mkdir(parents=True)
            argv, stdin = S.expand(cmd, inp=s.path, out=d / "out", companion=s.companion)
            r = runner.run_cli(argv, stdin=stdin, timeout=120, mode=mode)
            if r.returncode == 0 or (r.returncode == 1 and cmd[0] == "verify"):  # 1: a bound exceeded
                keep.append(cmd)
            else:
                problems.append({"seed": s.name, "command": " ".join(["mocapkit", *argv]),
                                 "returncode": r.returncode, "first_stderr_line": r.first_error_line()})
        s.commands = keep or s.commands
    return problems


def warm(seeds: list[S.Seed], work: Path) -> None:
    """Compile the numba code of every command once in this process (see runner.warm_up)."""
    seen, argvs, stdins = set(), [], []
    d = work / "warm"
    d.mkdir(parents=True, exist_ok=True)
    for s in seeds:
        if s.fmt in seen:
            continue
        seen.add(s.fmt)
        for cmd in s.commands:
            argv, stdin = S.expand(cmd, inp=s.path, out=d, companion=s.companion)
            argvs.append(argv)
            stdins.append(stdin)
    runner.warm_up(argvs, stdins)


def worker(args) -> None:
    """Run the cases ``i`` with ``i % jobs == shard``; write ``OUT/shard-<k>.json``."""
    out = Path(args.out)
    work = out / "work"
    meta = json.loads((work / "seeds.json").read_text())
    seeds = [S.Seed(m["name"], m["fmt"], Path(m["path"]), m["commands"],
                    Path(m["companion"]) if m["companion"] else None, m["load_options"], m["binary"], m["folder"])
             for m in meta["seeds"]]
    refs = meta["references"]
    cats = meta["plan"]
    if args.mode == "fork":
        warm(seeds, work / f"warm-{args.shard}")
    base = out / "cases"
    base.mkdir(exist_ok=True)
    records = []
    for i, cat in enumerate(cats):
        if i % args.jobs != args.shard:
            continue
        rng = random.Random(f"{args.seed}-{i}")
        try:
            case = None
            for _ in range(5):
                case = C.generate(cat, seeds, base, i, rng, refs)
                if case is not None:
                    break
            if case is None:
                continue
            rec = C.evaluate(case, mode=args.mode)
        except Exception as e:  # a bug of the trial itself: reported, never hidden
            import traceback

            rec = {"id": f"{cat}-{i:05d}", "category": cat, "area": "trial", "format": "", "command": "",
                   "outcome": "trial_error", "message": f"{type(e).__name__}: {e}",
                   "first_stderr_line": traceback.format_exc()[-400:], "detail": {}}
            case = None
        rec["area"] = C.area_of(rec) if rec.get("outcome") != "trial_error" else "trial"
        records.append(rec)
        if case is not None and rec["outcome"] not in oracle.FAILING:
            shutil.rmtree(case.dir, ignore_errors=True)
        if len(records) % 100 == 0:
            print(f"shard {args.shard}: {len(records)} cases", file=sys.stderr, flush=True)
    (out / f"shard-{args.shard}.json").write_text(json.dumps(records))


def table(records: list[dict]) -> str:
    outcomes = [o for o in oracle.ORDER + ["trial_error"] if any(r["outcome"] == o for r in records)]
    cats = [c for c in C.CATEGORIES if any(r["category"] == c for r in records)]
    count = collections.Counter((r["category"], r["outcome"]) for r in records)
    w = max(len(c) for c in cats + ["category", "total"]) + 2
    head = "category".ljust(w) + "".join(o.rjust(max(len(o), 5) + 2) for o in outcomes) + "total".rjust(8)
    lines = [head, "-" * len(head)]
    for c in cats + ["total"]:
        row = c.ljust(w)
        for o in outcomes:
            n = sum(v for (cc, oo), v in count.items() if oo == o and (c == "total" or cc == c))
            row += str(n).rjust(max(len(o), 5) + 2)
        row += str(sum(v for (cc, _), v in count.items() if c == "total" or cc == c)).rjust(8)
        lines.append(row)
    return "\n".join(lines)


def findings(records: list[dict], outcomes=None, per_group: int = 12) -> str:
    """The failing cases grouped by owner area, then by (outcome, first message)."""
    outcomes = outcomes or (oracle.FAILING | {"bad_error", "error_unnamed", "trial_error"})
    by_area: dict[str, list[dict]] = collections.defaultdict(list)
    for r in records:
        if r["outcome"] in outcomes:
            by_area[r["area"]].append(r)
    out = []
    for area in sorted(by_area, key=lambda a: -len(by_area[a])):
        rs = by_area[area]
        out.append(f"\n### {area}: {len(rs)} cases")
        groups: dict[tuple, list[dict]] = collections.defaultdict(list)
        for r in rs:
            key = (r["outcome"], _normalise(r.get("message") or r.get("first_stderr_line") or ""))
            groups[key].append(r)
        for (outcome, msg), g in sorted(groups.items(), key=lambda kv: (oracle.ORDER.index(kv[0][0])
                                                                        if kv[0][0] in oracle.ORDER else 99,
                                                                        -len(kv[1]))):
            out.append(f"- **{outcome}** ×{len(g)} ({', '.join(sorted({x['category'] for x in g}))}; "
                       f"{', '.join(sorted({x['format'] for x in g}))}): {msg[:200]}")
            for x in g[:max(1, per_group // 6)]:
                det = {k: v for k, v in x.get("detail", {}).items() if k in ("mutation", "old", "new", "line",
                                                                             "path_kind", "option", "value",
                                                                             "field", "joints", "bones", "input")}
                out.append(f"  - `{x['command']}` {json.dumps(det) if det else ''}")
                out.append(f"    first stderr line: `{(x.get('first_stderr_line') or '')[:200]}`")
    return "\n".join(out)


def _normalise(msg: str) -> str:
    import re

    msg = re.sub(r"/\S*/cases/[^/\s]+/", "CASE/", msg)
    msg = re.sub(r"\d+(\.\d+)?(e[+-]?\d+)?", "N", msg)
    return msg[:160]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", type=int, default=5000)
    ap.add_argument("--out", required=True, help="report folder (created)")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--mode", choices=["fork", "subprocess"], default="fork")
    ap.add_argument("--categories", default=",".join(C.CATEGORIES))
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--shard", type=int, default=0, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        worker(args)
        return 0
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    shutil.rmtree(out / "cases", ignore_errors=True)
    work = out / "work"
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir()
    t0 = time.monotonic()
    cats = [c for c in args.categories.split(",") if c]
    seeds = _seed_list(work, args.mode)
    if args.mode == "fork":
        warm(seeds, work / "warm-main")
    seed_problems = _check_seeds(seeds, work, args.mode)
    refs = C.seed_references(seeds, work)
    print(f"setup (seeds made, checked, digested): {time.monotonic() - t0:.0f} s", file=sys.stderr, flush=True)
    meta = {"seeds": [{"name": s.name, "fmt": s.fmt, "path": str(s.path), "commands": s.commands,
                       "companion": str(s.companion) if s.companion else None, "load_options": s.load_options,
                       "binary": s.binary, "folder": s.folder} for s in seeds],
            "references": refs, "plan": plan(args.cases, cats, args.seed)}
    (work / "seeds.json").write_text(json.dumps(meta))
    print(f"{len(seeds)} seeds ({len(seed_problems)} seed commands failing on valid files); "
          f"{args.cases} cases on {args.jobs} job(s)", file=sys.stderr, flush=True)
    procs = [subprocess.Popen([sys.executable, __file__, "--worker", "--shard", str(k), "--jobs", str(args.jobs),
                               "--out", str(out), "--seed", str(args.seed), "--mode", args.mode])
             for k in range(args.jobs)]
    for p in procs:
        p.wait()
    records = []
    for k in range(args.jobs):
        f = out / f"shard-{k}.json"
        if f.exists():
            records += json.loads(f.read_text())
            f.unlink()
        else:
            print(f"shard {k} wrote no report", file=sys.stderr)
    records.sort(key=lambda r: r["id"])
    elapsed = time.monotonic() - t0
    tab = table(records) if records else "(no cases)"
    found = findings(records)
    failing = sum(r["outcome"] in oracle.FAILING for r in records)
    report = {"cases": len(records), "seconds": round(elapsed, 1), "seed": args.seed, "mode": args.mode,
              "failing": failing, "seed_problems": seed_problems,
              "counts": collections.Counter(r["outcome"] for r in records), "records": records}
    (out / "report.json").write_text(json.dumps(report, indent=1))
    md = [f"# Trial: {len(records)} cases in {elapsed / 60:.1f} min (seed {args.seed}, mode {args.mode})", "",
          "```", tab, "```", ""]
    if seed_problems:
        md += ["## Commands failing on the unmutated seeds", ""]
        md += [f"- `{p['command']}` → exit {p['returncode']}: `{p['first_stderr_line']}`" for p in seed_problems]
    md += ["", "## Findings by owner area", found]
    (out / "report.md").write_text("\n".join(md) + "\n")
    shutil.rmtree(work / "seedcheck", ignore_errors=True)
    print(tab)
    print(found)
    print(f"\n{len(records)} cases, {failing} failing, {elapsed / 60:.1f} min; report: {out}/report.md")
    return 1 if failing or any(r["outcome"] == "trial_error" for r in records) else 0


if __name__ == "__main__":
    sys.exit(main())
