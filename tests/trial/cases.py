"""Trial cases per category of issue 10, and their evaluation.

A :class:`Case` is built in a folder of its own (``case.dir``: ``in/`` holds the inputs, ``out/`` the
outputs) and run with :func:`evaluate`, which returns a JSON-able record with the outcome (see
:mod:`tests.trial.oracle`). Categories:

``mutation``     a seed mutated at random (tokens, truncation, lines, bytes, NUL/non-UTF-8, header counts);
``values``       a number of the data replaced by an invalid or extreme spelling;
``cut_number``   the file cut inside its last number;
``deep``         10,000-joint BVH chains and 2,000-bone ASF chains in every command, a 100k-joint BVH;
``huge``         header claims (``NO_OF_MARKERS 1000000000``...), ``/dev/zero`` and an endless pipe as input;
``paths``        outputs that are devices, FIFOs, symlinks, folders, the input itself or inside its folder;
``options``      extreme option values (0, -1, 1e308, nan, inf, 99999999999999999999, 1e-320...);
``usage``        usage mistakes (unknown option, missing argument, a word for a number);
``kill``         ``kill -9`` at a random moment of a command that writes: never a partial target;
``sql``          ``catalog query`` with hostile SQL (COPY, ATTACH, INSTALL, PRAGMA, DML, file readers, two
                 statements, huge literals, random bytes) on a copy of a small catalog: it stays byte-identical;
``manifest``     ``batch compress`` with a mutated TOML manifest or sidecar (garbage, wrong types, huge
                 numbers, unknown keys, escaping globs, an ``asf`` that is absolute, a FIFO, ``/dev/zero``).

The ``.mkp``, ``.mkc``, tick-column points CSV and ``verify`` seeds join ``mutation``, ``paths``, ``options``
and ``kill`` through their commands; a glTF whose buffer URI is hostile is a ``huge`` case, an OpenSense
``.sto`` whose column names are paths a ``paths`` case. Every case runs with its working folder inside the
case folder, and a file created anywhere in the case folder outside ``out/`` (or outside the output
folder the command was given) is ``written_outside``.
"""

from __future__ import annotations

import contextlib
import os
import random
import shutil
import stat
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

from . import generators, mutators, oracle, runner
from .seeds import AREA_OF_FORMAT, NAN_IS_GAP, Seed, expand, outputs_of

CATEGORIES = ["mutation", "values", "cut_number", "deep", "huge", "paths", "options", "usage", "kill", "sql",
              "manifest"]
#: formats whose every byte is covered by a CRC: a mutation is refused, reported, or changes nothing read
CRC_FORMATS = {"mkp", "mkc"}


@dataclass
class Case:
    id: str
    category: str
    area: str
    fmt: str
    dir: Path
    argv: list[str]
    stdin: Path | None = None
    inputs: list[Path] = field(default_factory=list)
    outputs: list[Path] = field(default_factory=list)
    expect: str = "any"  # mutators.Mutation.expect
    reference: dict | None = None  # digest of the unmutated input
    complete: Path | None = None  # the truncated file's line made whole (for expect == "truncated")
    digest_target: tuple | None = None  # (path, fmt, options) of the mutated file, for the digest
    detail: dict = field(default_factory=dict)
    timeout: float = runner.DEFAULT_TIMEOUT
    post: str | None = None  # a special check: "device", "fifo", "symlink", "kill"
    kill_after: float | None = None
    names: list[str] = field(default_factory=list)  # names an error line may mention
    confined: Path | None = None  # every file the command writes must be under this folder (default: out/)
    cwd: Path | None = None  # the command's working folder (default: ``dir/cwd``)

    def record(self) -> dict:
        cmd = " ".join(["mocapkit", *self.argv]) + (f" < {self.stdin}" if self.stdin else "")
        return {"id": self.id, "category": self.category, "area": self.area, "format": self.fmt, "command": cmd,
                "expect": self.expect, "detail": {k: v for k, v in self.detail.items() if k != "complete"}}


# --------------------------------------------------------------------------------------------------
# building
# --------------------------------------------------------------------------------------------------


def _prepare(base: Path, cid: str) -> tuple[Path, Path, Path]:
    d = base / cid
    if d.exists():
        shutil.rmtree(d)
    (d / "in").mkdir(parents=True)
    (d / "out").mkdir()
    return d, d / "in", d / "out"


def _digest_target(seed: Seed, mutated: Path, companion: Path | None) -> tuple:
    opts = {k: (str(companion) if v == "{asf}" else v) for k, v in seed.load_options.items()}
    if seed.fmt == "asf":
        return (str(companion), "amc", {"asf": str(mutated)})
    return (str(mutated), seed.fmt, opts)


def from_seed(seed: Seed, base: Path, cid: str, category: str, data: bytes, command: list[str],
              mutation: mutators.Mutation | None, references: dict) -> Case:
    d, din, dout = _prepare(base, cid)
    inp = din / seed.path.name
    if seed.folder:
        shutil.copytree(seed.path, inp)
    else:
        inp.write_bytes(data)
    companion = None
    if seed.companion is not None:
        companion = din / seed.companion.name
        shutil.copyfile(seed.companion, companion)
    argv, stdin = expand(command, inp=inp, out=dout, companion=companion)
    files = sorted(p for p in inp.rglob("*") if p.is_file()) if seed.folder else [inp]
    case = Case(cid, category, seed.area, seed.fmt, d, argv, stdin, inputs=files + ([companion] if companion else []),
                outputs=outputs_of(argv), names=[inp.name] + ([companion.name] if companion else []))
    if seed.folder:
        case.detail["input_folder"] = str(inp)
    if mutation is not None:
        case.expect = "any" if seed.binary and mutation.expect == "truncated" else mutation.expect
        if seed.fmt in CRC_FORMATS:
            case.expect = "refuse"
        case.detail = {"mutation": mutation.kind, "seed": seed.name,
                       **{k: v for k, v in mutation.detail.items() if k != "complete"}}
        case.reference = references.get(seed.name)
        case.digest_target = _digest_target(seed, inp, companion)
        if case.expect == "truncated":
            cdir = d / "complete"
            cdir.mkdir()
            comp = cdir / seed.path.name
            comp.write_bytes(mutation.detail["complete"])
            if companion is not None:
                shutil.copyfile(seed.companion, cdir / seed.companion.name)
            case.complete = comp
    return case


def seed_references(seeds: list[Seed], base: Path) -> dict:
    """Digest of every unmutated seed (through the same loader the differential check uses)."""
    refs = {}
    for s in seeds:
        target = _digest_target(s, s.path, s.companion)
        refs[s.name] = runner.call_in_child(oracle.digest, *target, timeout=120)
    return refs


MUTATION_KINDS_TEXT = ["token", "truncate", "lines", "bytes", "insert", "inflate"]


def gen_mutation(seeds, base, i, rng, refs, category="mutation") -> Case | None:
    seeds = [s for s in seeds if not s.folder]
    if category in ("values", "cut_number"):  # number spellings: text formats only
        seeds = [s for s in seeds if not s.binary]
    seed = rng.choice(seeds)
    data = seed.path.read_bytes()
    if category == "values":
        token = rng.choice(mutators.INVALID_TOKENS + mutators.EXTREME_TOKENS)
        mut = mutators.replace_token(data, rng, seed.fmt, token, where="tail")
    elif category == "cut_number":
        mut = mutators.truncate_in_last_number(data, rng, seed.fmt)
    else:
        kinds = list(mutators.BINARY_MUTATORS if seed.binary else MUTATION_KINDS_TEXT)
        mut = mutators.mutate(data, rng, seed.fmt, seed.binary, rng.choice(kinds))
    if mut is None:
        return None
    cmd = rng.choice(seed.commands)
    return from_seed(seed, base, f"{category}-{i:05d}", category, mut.data, cmd, mut, refs)


def gen_deep(base, i, rng) -> Case:
    d, din, dout = _prepare(base, f"deep-{i:05d}")
    kind = rng.choice(["bvh_chain", "bvh_chain", "bvh_wide", "asf_chain"])
    if kind == "asf_chain":
        n = rng.choice([1000, 2000])
        asf = din / "chain.asf"
        amc = din / "chain.amc"
        asf.write_text(generators.asf_chain(n))
        amc.write_text(generators.amc_for_chain(n))
        cmd = rng.choice([["info", amc, "--asf", asf, "--json"], ["convert", amc, dout / "o.bvh", "--asf", asf],
                          ["compress", amc, "--asf", asf, "--json", "--stats-only", "-t", "0.01"]])
        argv = [str(a) for a in cmd]
        return Case(d.name, "deep", "skeletal readers", "asf", d, argv, inputs=[asf, amc],
                    outputs=outputs_of(argv), names=["chain.asf", "chain.amc"], timeout=60,
                    detail={"bones": n})
    n = rng.choice([1000, 10_000]) if kind == "bvh_chain" else 100_000
    bvh = din / f"{kind}.bvh"
    bvh.write_text(generators.bvh_chain(n, wide=kind == "bvh_wide"))
    cmds = [["info", bvh, "--json"], ["convert", bvh, dout / "o.bvh"],
            ["compress", bvh, "--json", "--stats-only", "-t", "0.01"],
            ["compress", bvh, "-o", dout / "c.glb", "-t", "0.01"], ["segment", bvh, "-m", "pca", "--json"]]
    cmd = cmds[0] if kind == "bvh_wide" else rng.choice(cmds)
    argv = [str(a) for a in cmd]
    return Case(d.name, "deep", "skeletal readers", "bvh", d, argv, inputs=[bvh], outputs=outputs_of(argv),
                names=[bvh.name], timeout=60, detail={"joints": n, "shape": kind})


def gen_huge(seeds, base, i, rng) -> Case:
    d, din, dout = _prepare(base, f"huge-{i:05d}")
    kinds = ["qtm_claim", "bvh_frames", "dev_zero", "endless_pipe", "inflate"]
    if any(s.fmt == "gltf" for s in seeds):
        kinds.append("gltf_uri")
    kind = rng.choice(kinds)
    if kind == "gltf_uri":
        return gen_gltf_uri(seeds, d, din, dout, rng)
    if kind == "qtm_claim":
        f = din / "claim.tsv"
        f.write_text(generators.qtm_claim())
        argv = [str(a) for a in rng.choice([["info", f, "--json"], ["convert", f, dout / "o.csv"],
                                             ["filter", f, "--auto", "--json"]])]
        return Case(d.name, "huge", "marker readers", "qtm", d, argv, inputs=[f], outputs=outputs_of(argv),
                    names=[f.name], timeout=60, detail={"claim": "NO_OF_MARKERS 1000000000"})
    if kind == "bvh_frames":
        f = din / "frames.bvh"
        f.write_text(generators.bvh_chain(5).replace("Frames: 4", rng.choice(["Frames: 1000000000",
                                                                                "Frames: 1e9"])))
        argv = [str(a) for a in rng.choice([["info", f, "--json", "--no-strict"], ["info", f, "--json"],
                                             ["convert", f, dout / "o.bvh", "--no-strict"]])]
        return Case(d.name, "huge", "skeletal readers", "bvh", d, argv, inputs=[f], outputs=outputs_of(argv),
                    names=[f.name], timeout=60)
    if kind in ("dev_zero", "endless_pipe"):
        cmd = rng.choice([["info", "{in}"], ["info", "{in}", "--json"], ["compress", "{in}", "-t", "0.001"],
                          ["filter", "{in}", "--auto", "--json"], ["decompress", "{in}", "-o", "{out}/d.csv"],
                          ["stream", "-t", "0.001", "<stdin>"], ["convert", "{in}", "{out}/o.csv"]])
        if kind == "dev_zero":
            src = Path("/dev/zero")
        else:
            src = din / "endless.csv"
            os.mkfifo(src)
        argv, stdin = expand(cmd, inp=src, out=dout, companion=None)
        return Case(d.name, "huge", "IMU readers" if "stream" in cmd or "compress" in cmd else "CLI", "imu", d, argv,
                    stdin, outputs=outputs_of(argv), names=[src.name, "stdin"], timeout=60,
                    post="endless" if kind == "endless_pipe" else None, detail={"input": kind})
    seed = rng.choice([s for s in seeds if not s.binary and not s.folder])
    mut = mutators.inflate_header(seed.path.read_bytes(), rng, seed.fmt)
    if mut is None:
        mut = mutators.byte_flips(seed.path.read_bytes(), rng, seed.fmt)
    case = from_seed(seed, base, f"huge-{i:05d}", "huge", mut.data, rng.choice(seed.commands), mut, {})
    case.timeout = 60
    return case


#: hostile buffer URIs of a .gltf (``{bin}``: a file holding the real buffer, ``{fifo}``: a FIFO nobody writes)
GLTF_URIS = ["/dev/zero", "{fifo}", "../x.bin", "{bin_abs}", "file:///dev/zero", "/dev/zero#", ".", "",
             "/proc/self/mem", "http://127.0.0.1:9/x.bin", "x.bin?", "%2e%2e/x.bin", "data:,", "data:;base64,@@@@",
             "{long_data}", "{bin_huge_length}", "{bin_negative_length}", "{bin_huge_offset}"]


def gen_gltf_uri(seeds, d: Path, din: Path, dout: Path, rng) -> Case:
    """A glTF clip whose buffer URI points at a device, a FIFO, a parent folder, an absolute path, or claims
    a huge or wrong ``byteLength``: a clean error or the clip, never a hang or a memory blow-up."""
    import base64
    import json

    seed = next(s for s in seeds if s.fmt == "gltf")
    doc = json.loads(seed.path.read_text())
    buf = doc["buffers"][0]
    head, _, b64 = buf["uri"].partition(",")
    raw = base64.b64decode(b64)
    (din / "clip.bin").write_bytes(raw)
    (d / "x.bin").write_bytes(raw)  # ../x.bin from in/
    fifo = din / "buffer.fifo"
    os.mkfifo(fifo)
    kind = rng.choice(GLTF_URIS)
    uri = kind.replace("{fifo}", str(fifo)).replace("{bin_abs}", str(din / "clip.bin"))
    if kind == "{long_data}":
        uri = head + "," + base64.b64encode(raw + b"\0" * rng.choice([1, 4096, 10**6])).decode()
    elif kind.startswith("{bin_"):
        uri = "clip.bin"
        if kind == "{bin_huge_length}":
            buf["byteLength"] = rng.choice([10**15, 2**63 - 1, 2**64, 10**30])
        elif kind == "{bin_negative_length}":
            buf["byteLength"] = rng.choice([-1, 0, 1.5, "1000"])
        else:
            doc["bufferViews"][0]["byteOffset"] = rng.choice([10**15, 2**63, -8])
    buf["uri"] = uri
    f = din / "clip.gltf"
    f.write_text(json.dumps(doc))
    orig = din / seed.companion.name
    shutil.copyfile(seed.companion, orig)
    cmd = rng.choice([["decompress", f, "-o", dout / "d.bvh"], ["info", f, "--json"],
                      ["verify", orig, f, "--max-position-error", "1", "--json"]])
    argv = [str(a) for a in cmd]
    return Case(d.name, "huge", "skeletal readers", "gltf", d, argv, inputs=[f, din / "clip.bin", orig],
                outputs=outputs_of(argv), names=[f.name], timeout=60, detail={"uri": kind})


#: OpenSense column (sensor) names that are paths: none may put a file outside the output folder
STO_NAMES = ["../victim", "../../victim", "{abs}/abs", "..", ".", "", " ", "a/b", "victim/../../../v2", "~",
             "$HOME", "..\\victim", "/", "//", "./", "pelvis_imu", "x" * 300, "con", "nul.txt", ".hidden", "-o"]


def gen_sto_names(seeds, base, i, rng) -> Case:
    """``compress X.sto -o FOLDER`` where the .sto's column names are paths."""
    seed = next(s for s in seeds if s.fmt == "sto")
    lines = seed.path.read_text().split("\n")
    k = next(n for n, ln in enumerate(lines) if ln.startswith("time\t"))
    cols = lines[k].split("\t")
    case = from_seed(seed, base, f"paths-{i:05d}", "paths", b"", ["compress", "{in}", "-t", "0.001", "-o",
                                                                   "{out}/sensors"], None, {})
    names = [rng.choice(STO_NAMES).replace("{abs}", str(case.dir)) for _ in range(rng.randint(1, 3))]
    for j, name in zip(rng.sample(range(1, len(cols)), len(names)), names, strict=True):
        cols[j] = name
    lines[k] = "\t".join(cols)
    case.inputs[0].write_text("\n".join(lines))
    case.area = "IMU readers"
    case.confined = case.outputs[0]
    case.detail = {"path_kind": "sensor_names", "names": names, "seed": seed.name}
    return case


def gen_paths(seeds, base, i, rng) -> Case:
    """An odd output path for a command that writes one file (or sensor names that are paths)."""
    if any(s.fmt == "sto" for s in seeds) and rng.random() < 0.15:
        return gen_sto_names(seeds, base, i, rng)
    writers = [(s, c) for s in seeds for c in s.commands if "-o" in c or c[0] == "convert"]
    seed, cmd = rng.choice(writers)
    if seed.folder:
        kind = rng.choice(["same_as_input", "inside_input_folder", "sensor_subfolder", "missing_folder"])
    else:
        kind = rng.choice(["device", "fifo", "symlink", "dangling_symlink", "same_as_input", "symlink_to_input",
                           "hardlink_to_input", "dot_path_to_input", "folder", "missing_folder",
                           "inside_input_folder"])
    case = from_seed(seed, base, f"paths-{i:05d}", "paths", b"" if seed.folder else seed.path.read_bytes(), cmd,
                     None, {})
    case.area = "atomic.py"
    target = case.outputs[0] if case.outputs else None
    if target is None:
        return case
    inp = Path(case.detail["input_folder"]) if seed.folder else case.inputs[0]
    new: Path | str = target
    if kind == "device":
        try:
            os.mknod(target, stat.S_IFCHR | 0o666, os.makedev(1, 3))  # a private /dev/null
            case.post = "device"
        except (PermissionError, OSError):
            kind = "fifo"
    if kind == "fifo":
        os.mkfifo(target)
        case.post = "fifo"
    elif kind == "symlink":
        real = case.dir / "real" / target.name
        real.parent.mkdir()
        real.write_bytes(b"")
        target.symlink_to(real)
        case.post = "symlink"
        case.detail["link_target"] = str(real)
    elif kind == "dangling_symlink":
        real = case.dir / "real" / target.name
        real.parent.mkdir()
        target.symlink_to(real)
        case.post = "symlink"
        case.detail["link_target"] = str(real)
    elif kind == "same_as_input":
        new = inp
    elif kind == "symlink_to_input":
        target.symlink_to(inp)
    elif kind == "hardlink_to_input":
        os.link(inp, target)
    elif kind == "dot_path_to_input":
        new = f"{inp.parent}/./{inp.name}"
    elif kind == "folder":
        target.mkdir()
    elif kind == "missing_folder":
        new = target.parent / "missing" / target.name
    elif kind == "inside_input_folder":
        new = inp / "points" if seed.folder else inp.parent / f"result{target.suffix}"
    elif kind == "sensor_subfolder":
        new = inp / "pelvis"
    if new != target:
        case.argv = [str(new) if a == str(target) else a for a in case.argv]
        case.outputs = [Path(new)]
    case.detail = {"path_kind": kind, "seed": seed.name, **case.detail}
    return case


#: option values that must give a result or a clean error
BAD_VALUES = ["0", "-1", "-3", "1e308", "-1e308", "nan", "inf", "-inf", "99999999999999999999", "1e-320", "abc",
              "", "0.0", "1e999", "4.9e-324", "2147483648", "-2147483649"]


def gen_options(seeds, base, i, rng) -> Case:
    by_fmt = {s.fmt: s for s in seeds}
    choices = [
        ("imu", ["compress", "{in}", "-o", "{out}/p.csv"], ["--threshold", "--max-angle", "--target-icr",
                                                          "--max-segment-length", "--rate"]),
        ("imu", ["compress", "{in}", "--json", "-t", "0.001"], ["--max-segment-length", "--rate"]),
        ("imu", ["stream", "<stdin>"], ["--threshold", "--max-angle", "--max-segment-length", "--rate"]),
        ("bvh", ["compress", "{in}", "-o", "{out}/c.glb"], ["--threshold", "--max-position-error", "--unit-cm",
                                                          "--target-icr", "--max-angle", "--max-segment-length"]),
        ("bvh", ["compress", "{in}", "--json", "--stats-only", "--max-position-error", "1"], ["--unit-cm"]),
        ("bvh", ["convert", "{in}", "{out}/o.bvh"], ["--precision"]),
        ("amc", ["convert", "{in}", "{out}/o.bvh", "--asf", "{asf}"], ["--precision"]),
        ("bvh", ["segment", "{in}", "--json"], ["--downsample"]),
        ("qtm", ["filter", "{in}", "--json"], ["--penalty", "--order"]),
        ("qtm", ["filter", "{in}", "--auto", "-o", "{out}/f.csv"], ["--order"]),
        ("points", ["decompress", "{in}", "-o", "{out}/d.csv"], ["--rate"]),
        ("glb", ["decompress", "{in}", "-o", "{out}/d.bvh"], ["--rate"]),
        ("imu", ["compress", "{in}", "-o", "{out}/x.mkp"], ["--max-angle", "--max-segment-length", "--rate"]),
        ("mkp", ["decompress", "{in}", "-o", "{out}/d.csv"], ["--rate"]),
        ("mkp", ["decompress", "{in}", "-o", "{out}/d.csv", "--times-from", "{orig}"], ["--rate"]),
        ("mkp", ["verify", "{orig}", "{in}", "--json"], ["--max-angle", "--rate"]),
        ("points", ["verify", "{orig}", "{in}", "--json"], ["--max-angle", "--max-position-error"]),
        ("mkc", ["verify", "{orig}", "{in}", "--json"], ["--max-position-error", "--shell-distance", "--unit-cm",
                                                         "--max-angle"]),
        ("mkc", ["verify", "{orig}", "{in}", "--json", "--error-metric", "shell"], ["--max-position-error",
                                                                                    "--shell-distance"]),
        ("glb", ["verify", "{orig}", "{in}", "--json"], ["--max-position-error", "--unit-cm"]),
        ("bvh", ["compress", "{in}", "-o", "{out}/c.mkc"], ["--max-position-error", "--unit-cm"]),
    ]
    fmt, cmd, opts = rng.choice([c for c in choices if c[0] in by_fmt])
    seed = by_fmt[fmt]
    if fmt == "imu":
        seed = next(s for s in seeds if s.name == "imu-pelvis-Quaternion.csv")
    if fmt == "bvh":
        seed = next(s for s in seeds if s.name == "walk-meredith-60")
    opt = rng.choice(opts)
    value = rng.choice(BAD_VALUES)
    full = list(cmd)
    if opt == "--threshold" and "--max-angle" not in full:
        pass
    full += [opt, value]
    if cmd[0] in ("compress", "stream") and not any(o in full for o in ("--threshold", "-t", "--max-angle",
                                                                          "--target-icr", "--max-position-error")):
        full += ["--max-position-error", "1"] if any(a.endswith(".mkc") for a in full) else ["-t", "0.001"]
    case = from_seed(seed, base, f"options-{i:05d}", "options", seed.path.read_bytes(), full, None, {})
    case.area = "CLI"
    case.names.append(opt)
    case.detail = {"option": opt, "value": value}
    return case


USAGE = [
    ["info"], ["compress"], ["info", "{in}", "--no-such-option"], ["compress", "{in}", "-t"],
    ["compress", "{in}", "-t", "abc"], ["compress", "{in}", "--method", "nope", "-t", "1"],
    ["filter", "{in}", "--solver", "nope", "--auto"], ["decompress", "{in}"], ["convert", "{in}"],
    ["info", "{in}", "extra-argument"], ["segment", "{in}", "-m", "nope"], ["nosuchcommand"],
    ["info", "{in}", "--rate", "fast"], ["stream", "--max-segment-length", "1.5", "<stdin>"],
    ["info", "{in}/does-not-exist"], ["info", ""], ["convert", "{in}", "{out}/o.xyz"],
    ["info", "{out}"], ["compress", "{in}", "--time-unit", "fortnights", "-t", "1"],
    ["compress", "{in}", "--quaternion-columns", "a,b", "-t", "1"],
    ["compress", "{in}", "--time-column", "nope", "-t", "1"],
    ["verify"], ["verify", "{in}"], ["verify", "{in}", "{in}", "--max-angle", "x"], ["verify", "{in}", "{out}"],
    ["verify", "{in}", "{in}/missing.mkp"], ["verify", "{in}", "{in}", "--error-metric", "nope"],
    ["catalog", "query", "SELECT 1"], ["catalog", "query", "--db", "{out}/none.duckdb", "SELECT 1"],
    ["catalog", "query", "--db", "{in}", "SELECT 1"], ["catalog", "query", "--db", "{out}/c.duckdb", "SELECT 1",
                                                        "--format", "xml"],
    ["batch", "compress", "{in}"], ["batch", "compress", "{in}", "--out", "{out}/b", "--manifest",
                                    "{out}/none.toml", "-t", "1"],
    ["batch", "compress", "{in}", "--out", "{out}/b", "--manifest", "{in}", "-t", "1"],
    ["decompress", "{in}", "-o", "{out}/x.mkp"], ["compress", "{in}", "-o", "{out}/x.mkp"],
    ["compress", "{in}", "-o", "{out}/x.mkc", "-t", "1"], ["compress", "{in}", "--max-angle", "2", "-o",
                                                              "{out}/x.mkc"],
]


def gen_usage(seeds, base, i, rng) -> Case:
    seed = next((s for s in seeds if s.name == "imu-pelvis-Quaternion.csv"), seeds[0])
    cmd = rng.choice(USAGE)
    case = from_seed(seed, base, f"usage-{i:05d}", "usage", seed.path.read_bytes(), cmd, None, {})
    case.area = "CLI"
    case.names += [a for a in cmd if a.startswith("-")] + [Path(a).name for a in case.argv[1:2]]
    return case


def gen_kill(seeds, base, i, rng) -> Case:
    writers = [(s, c) for s in seeds for c in s.commands if ("-o" in c or c[0] == "convert") and s.fmt != "asf"
               and not s.folder]
    seed, cmd = rng.choice(writers)
    case = from_seed(seed, base, f"kill-{i:05d}", "kill", seed.path.read_bytes(), cmd, None, {})
    case.area = "atomic.py"
    case.post = "kill"
    case.kill_after = rng.uniform(0.02, 2.0)
    case.detail = {"seed": seed.name, "kill_after_s": round(case.kill_after, 3)}
    return case


#: hostile SQL for ``catalog query`` (``{cwd}``: the command's working folder, ``{in}``: the inputs' folder,
#: ``{db}``: the catalog itself)
HOSTILE_SQL = [
    "COPY recordings TO '{cwd}/x.csv'", "COPY (SELECT 1) TO 'x.parquet' (FORMAT parquet)",
    "COPY recordings FROM '{in}/victim.csv'", "ATTACH '{cwd}/y.duckdb' AS y", "ATTACH ':memory:' AS m",
    "DETACH memory", "INSTALL httpfs", "LOAD httpfs", "FORCE INSTALL json", "PRAGMA enable_profiling",
    "PRAGMA threads=1", "CREATE TABLE t(a INT)", "CREATE TEMP TABLE t AS SELECT 1", "CREATE VIEW v AS SELECT 1",
    "CREATE MACRO m(a) AS a", "CREATE SEQUENCE s", "INSERT INTO recordings SELECT * FROM recordings",
    "DELETE FROM recordings", "UPDATE recordings SET path = 'x'", "DROP TABLE recordings",
    "ALTER TABLE recordings ADD COLUMN z INT",
    "SET threads=1", "SET enable_external_access=true", "RESET ALL", "SET memory_limit='1TB'",
    "SELECT * FROM read_csv('{in}/victim.csv')", "SELECT * FROM read_text('/etc/hostname')",
    "SELECT * FROM read_blob('{db}')", "SELECT * FROM glob('/*')", "SELECT * FROM read_parquet('{db}')",
    "SELECT 1; SELECT 2", "SELECT 1; DROP TABLE recordings", "SELECT 1;;", ";", "", " ", "\n\t",
    "-- only a comment", "/* */ DELETE FROM recordings", "EXPLAIN ANALYZE DELETE FROM recordings",
    "EXPLAIN COPY recordings TO '{cwd}/e.csv'", "WITH x AS (SELECT 1) DELETE FROM recordings",
    "WITH x AS (SELECT 1) SELECT * FROM x", "CHECKPOINT", "FORCE CHECKPOINT", "VACUUM", "ANALYZE",
    "EXPORT DATABASE '{cwd}/exp'", "IMPORT DATABASE '{cwd}'", "USE memory", "BEGIN TRANSACTION", "COMMIT",
    "CALL pragma_version()", "CALL dbgen(sf=0.01)", "SELECT * FROM duckdb_settings()", "SELECT nextval('s')",
    "SELECT setseed(0.5)", "SHOW TABLES", "DESCRIBE recordings", "SUMMARIZE recordings", "SELECT * FROM recordings",
    "VALUES (1, 'a'), (2, 'b')", "SELECT 'NaN'::DOUBLE, 'inf'::DOUBLE, -0.0", "SELECT 1/0", "SELECT 1e308 * 10",
    "SELECT range FROM range(200000)", "SELECT repeat('x', 100000000)", "SELECT * FROM recordings, range(2000)",
    "SELECT '{big}'", "SELECT {digits}", "SELECT \"" + "a" * 300 + "\" FROM recordings",
    "SELECT * FROM recordings WHERE path = '\x00'", "select/**/*/**/from/**/recordings", "SeLeCt 1",
    "PIVOT recordings ON format", "SELECT current_setting('threads')", "SELECT getenv('HOME')",
    "SELECT * FROM sniff_csv('{in}/victim.csv')", "FROM recordings", "FROM '{in}/victim.csv'",
]


def gen_sql(seeds, base, i, rng) -> Case:
    """``catalog query --db CATALOG SQL`` with hostile SQL (or random bytes): ok or one clean error; the
    catalog byte-identical, nothing written anywhere (the working folder is inside the case folder)."""
    d, din, dout = _prepare(base, f"sql-{i:05d}")
    cat = din / "catalog.duckdb"
    shutil.copyfile(seeds[0].path.parent / "catalog.duckdb", cat)
    (din / "victim.csv").write_text("a,b\n1,2\n")
    cwd = d / "cwd"
    cwd.mkdir()
    kind = rng.choice(["sql"] * 8 + ["bytes", "db"])
    if kind == "bytes":
        sql = bytes(rng.randrange(1, 256) for _ in range(rng.randint(1, 300))).decode("latin-1")
    else:
        sql = rng.choice(HOSTILE_SQL)
        sql = sql.replace("{big}", "x" * rng.choice([10**4, 10**6])).replace("{digits}", "9" * rng.choice([50, 10**5]))
    sql = sql.replace("{cwd}", str(cwd)).replace("{in}", str(din)).replace("{db}", str(cat))
    db = str(cat)
    if kind == "db":  # the catalog is something else
        other = rng.choice(["missing", "text", "fifo", "/dev/zero", "folder"])
        if other == "missing":
            db = str(din / "none.duckdb")
        elif other == "text":
            db = str(din / "victim.csv")
        elif other == "fifo":
            db = str(din / "db.fifo")
            os.mkfifo(db)
        elif other == "folder":
            db = str(din)
        else:
            db = other
        sql = "SELECT * FROM recordings"
    argv = ["catalog", "query", "--db", db, sql, *rng.choice([[], ["--format", "csv"], ["--format", "json"]])]
    case = Case(d.name, "sql", "catalog", "catalog", d, argv, inputs=[cat, din / "victim.csv"], names=["catalog.duckdb",
                Path(db).name, "--db", "sql"], timeout=60, detail={"sql": sql[:200], "db": Path(db).name})
    case.cwd = cwd
    return case


_MANIFEST = """[[files]]
glob = "tree/cmu/*.amc"
asf = "tree/cmu/86.asf"
max_position_error = 1

[[files]]
glob = "tree/imu/*.csv"
max_angle = 2
"""

#: per-entry values of a manifest or sidecar: wrong types, huge numbers, unknown keys, escaping globs,
#: hostile ``asf`` paths (``{fifo}``, ``{abs}``: made per case)
MANIFEST_LINES = [
    'rate = "fast"', "rate = true", "rate = 1e308", "rate = 99999999999999999999999999", "rate = -1", "rate = nan",
    "rate = inf", "rate = 0", "rate = [1, 2]", "rate = {a = 1}", "max_angle = 180", "max_angle = 1e-320",
    "max_angle = -0.0", "max_position_error = 1e999", "max_position_error = 0", "unit_cm = 1e-300",
    "unit_cm = 1e300", "strict = 'yes'", "strict = 1", "scalar_last = 2", "time_unit = 'fortnights'",
    "time_column = ''", 'time_column = "\u0000"', "quaternion_columns = 5", "quaternion_columns = 'a,b'",
    'quaternion_columns = ["w", "x", "y", "z"]', "foo = 1", "max_segment_length = 1", "threshold = 1", "[x]",
    'glob = "../../*"', 'glob = "/*"', 'glob = "/**/*"', 'glob = "**/*"', 'glob = ""', 'glob = "../*"',
    'glob = "[["', 'glob = "tree/**/**/**/**/**/**/**/**"', 'path = "/etc/passwd"', 'path = "../../../etc"',
    'asf = "{abs}"', 'asf = "/dev/zero"', 'asf = "{fifo}"', 'asf = "../../../../etc/passwd"', 'asf = "tree"',
    'asf = "m.toml"', 'asf = ""', 'asf = "tree/cmu/missing.asf"', 'asf = "{link}"', "asf = 3",
    "rate = " + "[" * 3000 + "]" * 3000, 'rate = """' + "1" * 100000 + '"""', "glob = 'tree/*' glob = 'x'",
]


def gen_manifest(seeds, base, i, rng) -> Case:
    """``batch compress TREE --manifest M --out OUT``, the manifest or a sidecar mutated: a clean error
    before any work (exit 2, nothing in OUT) or a batch (exit 0, or 1 with error rows); never a crash or a
    hang."""
    d, din, dout = _prepare(base, f"manifest-{i:05d}")
    data = seeds[0].path.parent
    tree = din / "tree"
    (tree / "cmu").mkdir(parents=True)
    (tree / "imu").mkdir()
    for name, dst in (("86.asf", tree / "cmu" / "86.asf"), ("86_01_first60.amc", tree / "cmu" / "86_01_first60.amc"),
                      ("imu-pelvis-Quaternion.csv", tree / "imu" / "q.csv"),
                      ("walk-meredith-60.bvh", tree / "walk.bvh")):
        shutil.copyfile(data / name, dst)
    fifo = din / "asf.fifo"
    os.mkfifo(fifo)
    link = din / "zero.asf"
    link.symlink_to("/dev/zero")
    manifest = din / "m.toml"
    text = _MANIFEST
    where = rng.choice(["manifest", "manifest", "sidecar", "sidecar_alone"])
    how = rng.choice(["line", "line", "line", "bytes"])
    line = rng.choice(MANIFEST_LINES).replace("{fifo}", str(fifo)).replace("{abs}", str(tree / "cmu" / "86.asf"))
    line = line.replace("{link}", str(link))
    if where == "manifest":
        if how == "line":
            blocks = text.split("\n\n")
            k = rng.randrange(len(blocks))
            blocks[k] = blocks[k].rstrip("\n") + "\n" + line + "\n"
            text = "\n\n".join(blocks)
            detail = {"manifest_line": line[:120]}
        else:
            mut = mutators.mutate(text.encode(), rng, "toml", False)
            text = mut.data.decode("utf-8", "surrogateescape") if mut else text
            detail = {"manifest_mutation": mut.kind if mut else None}
        manifest.write_bytes(text.encode("utf-8", "surrogateescape"))
    else:
        manifest.write_text(text)
        side = rng.choice([tree / "walk.mocapkit.toml", tree / "cmu" / "86_01_first60.mocapkit.toml",
                           tree / "imu" / "q.mocapkit.toml"])
        side.write_text(line.replace("tree/cmu/86.asf", "86.asf") + "\n")
        detail = {"sidecar": side.name, "sidecar_line": line[:120]}
    argv = ["batch", "compress", str(tree), "--out", str(dout / "b"), "-j", "1", "-t", "0.001"]
    if where != "sidecar_alone":
        argv[3:3] = ["--manifest", str(manifest)]
    inputs = [p for p in din.rglob("*") if p.is_file() and not p.is_symlink()]
    case = Case(d.name, "manifest", "batch", "batch", d, argv, inputs=inputs, names=["m.toml", "mocapkit.toml",
                "--manifest"], timeout=120, detail={"where": where, **detail}, post="batch")
    case.confined = dout
    return case


def generate(category: str, seeds, base: Path, i: int, rng: random.Random, refs: dict) -> Case | None:
    if category in ("mutation", "values", "cut_number"):
        return gen_mutation(seeds, base, i, rng, refs, category)
    return {"deep": gen_deep, "huge": gen_huge, "paths": gen_paths, "options": gen_options, "usage": gen_usage,
            "kill": gen_kill, "sql": gen_sql, "manifest": gen_manifest}[category](
        *(() if category == "deep" else (seeds,)), base, i, rng)


# --------------------------------------------------------------------------------------------------
# evaluation
# --------------------------------------------------------------------------------------------------


def _readback(path: Path, argv: list[str]) -> str | None:
    """A problem with a written output file, or ``None``."""
    res = runner.call_in_child(oracle.digest, str(path), oracle.output_format(path, argv), {}, timeout=120)
    if res.get("status") == "ok":
        if res["nonfinite"]:
            return f"{path.name} holds non-finite values in {res['nonfinite']}"
        return None
    if path.suffix.lower() == ".csv":  # a plain table (MOT -> CSV, filter on columns): numbers only
        return _plain_csv(path)
    return f"{path.name} does not read back: {res.get('message') or res.get('status')}"


def _plain_csv(path: Path) -> str | None:
    import math

    try:
        lines = path.read_text().splitlines()
    except (OSError, UnicodeDecodeError) as e:
        return f"{path.name} is not readable text: {e}"
    rows = [ln for ln in lines if ln and not ln.startswith("#")]
    for k, ln in enumerate(rows[1:], start=2):
        for c in ln.split(","):
            if c in ("", "nan", "NaN"):
                continue
            try:
                v = float(c)
            except ValueError:
                return f"{path.name}:{k}: {c[:40]!r} is not a number"
            if not math.isfinite(v):
                return f"{path.name}:{k}: {c!r} is not finite"
    return None


def _start_endless_writer(fifo: Path) -> subprocess.Popen:
    """A separate process writing CSV-like rows into ``fifo`` until it is killed (no thread here: the
    trial forks)."""
    code = ("import sys\nb=b'1.0,2.0,3.0,4.0,5.0\\n'*4096\nw=sys.stdout.buffer\n"
            "try:\n while True: w.write(b)\nexcept OSError: pass\n")
    return subprocess.Popen(["/bin/sh", "-c", 'exec "$0" -c "$1" > "$2"', sys.executable, code, str(fifo)],
                            stdin=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def evaluate(case: Case, mode: str = "fork") -> dict:
    rec = case.record()
    before = {str(p): oracle.sha(p) for p in case.inputs}
    folder = case.detail.get("input_folder")
    listing = sorted(str(p) for p in Path(folder).rglob("*")) if folder else None
    helper = None
    drain = None
    if case.post == "fifo":  # a reader draining the FIFO while the command writes (a process: no threads here)
        sink = case.dir / "fifo-received"
        with open(sink, "wb") as received:  # the child holds its own descriptor
            drain = subprocess.Popen(["cat", str(case.outputs[0])], stdout=received, stdin=subprocess.DEVNULL)
    if case.post == "endless":
        helper = _start_endless_writer(case.stdin or Path(case.argv[1]))
    cwd = case.cwd or case.dir / "cwd"
    cwd.mkdir(exist_ok=True)
    entries = _entries(case.dir)
    try:
        run = runner.run_cli(case.argv, stdin=case.stdin, timeout=case.timeout, mode=mode,
                             kill_after=case.kill_after, cwd=cwd)
    finally:
        got = b""
        if drain is not None:
            # a writer that opens and closes: the reader sees EOF even if the command never opened it
            with contextlib.suppress(OSError):
                os.close(os.open(case.outputs[0], os.O_WRONLY | os.O_NONBLOCK))
            try:
                drain.wait(timeout=5)  # EOF once every writer closed
            except subprocess.TimeoutExpired:  # nobody opened the FIFO for writing
                drain.kill()
                drain.wait()
            got = (case.dir / "fifo-received").read_bytes()
        if helper is not None:
            helper.kill()
            helper.wait()
    names = case.names + [Path(a).name for a in case.argv if "/" in a] + (["<stdin>"] if case.stdin else [])
    outcome, detail = oracle.classify_run(run, names)
    if case.post == "kill" and run.extra.get("killed_at") is not None:
        outcome, detail = "ok", "killed"
    notes = []
    # inputs unchanged
    for p, h in before.items():
        if oracle.sha(p) != h:
            outcome, detail = "input_modified", f"{p} changed"
    if folder and sorted(str(p) for p in Path(folder).rglob("*")) != listing:
        outcome, detail = "input_modified", f"files were added to or removed from the input folder {folder}"
    outside = _written_outside(case, entries)
    if outside:
        outcome, detail = oracle.worst(outcome, "written_outside"), f"created outside the output folder: {outside}"
    if case.post == "batch" and run.returncode == 2:
        written = [str(p) for p in (case.confined or case.dir / "out").rglob("*") if p.is_file()]
        if written:
            outcome, detail = oracle.worst(outcome, "silent_wrong"), f"exit 2 after work was written: {written[:3]}"
    # devices, pipes and symlinks kept
    if case.post in ("device", "fifo", "symlink") and case.outputs:
        o = case.outputs[0]
        try:
            st = os.lstat(o)
        except FileNotFoundError:
            st = None
        if case.post == "device" and (st is None or not stat.S_ISCHR(st.st_mode)):
            outcome, detail = oracle.worst(outcome, "device_replaced"), f"{o} is no longer a character device"
        if case.post == "fifo":
            if st is None or not stat.S_ISFIFO(st.st_mode):
                outcome, detail = oracle.worst(outcome, "device_replaced"), f"{o} is no longer a FIFO"
            elif run.returncode == 0 and not got:
                outcome, detail = oracle.worst(outcome, "device_replaced"), "the FIFO's reader got nothing"
        if case.post == "symlink":
            if st is None or not stat.S_ISLNK(st.st_mode):
                outcome, detail = oracle.worst(outcome, "device_replaced"), f"{o} is no longer a symlink"
            elif run.returncode == 0:
                real = Path(case.detail["link_target"])
                if not real.is_file() or real.stat().st_size == 0:
                    outcome, detail = oracle.worst(outcome, "silent_wrong"), "the symlink's target was not written"
    # a successful run: stdout and written files valid
    if outcome == "ok" and case.post != "kill":
        problem = oracle.check_stdout(run)
        if problem is None and case.post not in ("device", "fifo"):
            for o in case.outputs:
                real = Path(os.path.realpath(o))
                if not real.exists():
                    problem = f"exit 0 but {o} was not written"
                    break
                if real.is_file():
                    problem = _readback(real, case.argv)
                    if problem:
                        break
        if problem:
            outcome, detail = "silent_wrong", problem
    # a mutated number read differently without a word
    if outcome == "ok" and case.expect in ("refuse", "truncated") and case.digest_target and case.reference:
        res = runner.call_in_child(oracle.digest, *case.digest_target, timeout=60)
        if res.get("status") == "ok" and not res["warnings"]:
            if res["nonfinite"] and case.fmt not in NAN_IS_GAP:
                outcome, detail = "silent_wrong", f"read without a warning, non-finite {res['nonfinite']}"
            elif not oracle.same_data(res, case.reference):
                ok = False
                if case.expect == "truncated" and case.complete is not None:
                    tgt = list(case.digest_target)
                    tgt[0] = str(case.complete) if tgt[1] != "amc" or case.fmt != "asf" else tgt[0]
                    if case.fmt == "asf":
                        tgt[2] = {"asf": str(case.complete)}
                    elif "asf" in tgt[2]:
                        tgt[2] = {**tgt[2], "asf": str(case.complete.parent / Path(tgt[2]["asf"]).name)}
                    ref2 = runner.call_in_child(oracle.digest, *tgt, timeout=60)
                    ok = oracle.same_data(res, ref2)
                if not ok:
                    what = case.detail.get("new", "") if case.expect == "refuse" else "a cut last line"
                    outcome, detail = "silent_wrong", (f"{what!r} at line {case.detail.get('line')} read as different "
                                                      f"data without a warning or error")
        elif res.get("status") in ("hang", "signal", "died", "exception"):
            notes.append(f"library load: {res.get('status')} {res.get('type', '')} {res.get('message', '')[:100]}")
    # a damaged .mkp told, a verify record checked against an independent decode
    if outcome == "ok" and case.fmt == "mkp" and case.digest_target and case.expect == "refuse":
        res = runner.call_in_child(oracle.digest, *case.digest_target, timeout=60)
        if res.get("status") == "ok" and res["warnings"] and not oracle.damage_reported(run):
            outcome, detail = "silent_wrong", f"the file lost packets ({res['warnings'][0][:120]}) but the command " \
                                              "did not say so"
    if outcome in ("ok", "exceeded") and case.argv[0] == "verify":
        problem = _verify_check(case, run)
        if problem:
            outcome, detail = "silent_wrong", problem
    if case.post == "kill":
        problem = _kill_check(case, run)
        if problem:
            outcome, detail = oracle.worst(outcome, "silent_wrong"), problem
    rec.update({"outcome": outcome, "message": detail, "first_stderr_line": run.first_error_line(),
                "returncode": run.returncode, "seconds": round(run.seconds, 3), "maxrss_mb": round(run.maxrss_mb, 1),
                "notes": notes})
    if outcome == "crash":
        rec["owner_file"] = _owner_file(run.err_text)
    return rec


def _entries(top: Path) -> set[str]:
    """Every path under ``top`` (files, folders, links; links not followed)."""
    out = set()
    for d, dirs, files in os.walk(top):
        out.update(os.path.join(d, x) for x in dirs + files)
    return out


def _written_outside(case: Case, before: set[str]) -> list[str]:
    """Paths that appeared in the case folder outside the output folder (``case.confined``, else ``out/``)
    and outside the command's own output paths."""
    allowed = [str(case.confined or case.dir / "out")] + [str(o) for o in case.outputs]
    if case.detail.get("link_target"):  # an output that is a symlink is written through it
        allowed.append(case.detail["link_target"])
    new = sorted(_entries(case.dir) - before)
    bad = [p for p in new if not any(p == a or p.startswith(a.rstrip("/") + "/") for a in allowed)
           and Path(p).name not in ("fifo-received",)]
    return bad[:5]


def _verify_check(case: Case, run) -> str | None:
    """A ``verify`` record against an independent SLERP decode of a points CSV (scipy), and its exit code
    against its ``within_bound``."""
    if "--json" not in case.argv:
        return None
    try:
        rec = oracle.strict_json(run.out_text)
    except ValueError:
        return None  # check_stdout reports it
    within = rec.get("within_bound")
    bound = None
    for opt in ("--max-angle", "--max-position-error"):
        if opt in case.argv:
            bound = float(case.argv[case.argv.index(opt) + 1])
    if (run.returncode == 0) != (within is not False):
        return f"verify exit {run.returncode} with within_bound={within!r}"
    if bound is not None and within is None:
        return "verify was given a bound but its record states no within_bound"
    original, compressed = case.argv[1], case.argv[2]
    if not compressed.lower().endswith(".csv") or "--max-position-error" in case.argv:
        return None
    ref = runner.call_in_child(oracle.verify_reference, original, compressed, {}, timeout=60)
    if ref.get("status") not in ("ok", "skip"):
        return None
    return oracle.verify_disagreement(rec, ref, bound)


def _owner_file(err: str) -> str | None:
    files = [ln.split('"')[1] for ln in err.splitlines() if ln.strip().startswith('File "') and "mocapkit" in ln]
    return files[-1].split("src/mocapkit/")[-1] if files else None


def _kill_check(case: Case, run) -> str | None:
    """After ``kill -9`` an output is absent (or what was there before) or complete."""
    for o in case.outputs:
        if not o.exists():
            continue
        if run.extra.get("killed_at") is None and run.returncode != 0:
            continue
        problem = _readback(o, case.argv)
        if problem:
            return f"after kill -9 at {case.kill_after:.2f} s: {problem}"
    return None


def area_of(rec: dict) -> str:
    """The owner area of a finding: the module in the traceback, else the case's area."""
    f = rec.get("owner_file") or ""
    if "io/atomic" in f:
        return "atomic.py"
    if any(k in f for k in ("io/markers/", "io/skeletal/mvnx", "markers.py")):
        return "marker readers"
    if any(k in f for k in ("io/skeletal/bvh", "io/skeletal/amc", "io/formats/gltf")):
        return "skeletal readers"
    if any(k in f for k in ("io/imu/", "io/text/numbers")):
        return "IMU readers"
    if f == "cli.py" and rec["category"] in ("options", "usage"):
        return "CLI"
    return rec["area"]


__all__ = ["CATEGORIES", "Case", "generate", "evaluate", "seed_references", "area_of", "AREA_OF_FORMAT"]
