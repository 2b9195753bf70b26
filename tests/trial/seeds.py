"""Seed files of every reader format and the commands the trial runs on each.

A seed is a valid file (a ``tests/data`` excerpt, or a file made from one by ``mocapkit`` itself: a C3D
from the Qualisys TSV, a glb/glTF clip from a BVH, a points CSV from an x-io quaternion file). Each seed
has a list of commands; ``{in}`` is the (mutated) input, ``{asf}`` the ASF of an AMC seed, ``{amc}`` the
AMC of an ASF seed, ``{out}`` the case's output folder. A command whose argv contains ``<stdin>`` reads
the input from standard input.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass, field
from pathlib import Path

DATA = Path(__file__).resolve().parents[1] / "data"

#: owner areas of issue 10, used to group the findings
AREA_OF_FORMAT = {
    "bvh": "skeletal readers", "asf": "skeletal readers", "amc": "skeletal readers", "glb": "skeletal readers",
    "gltf": "skeletal readers",
    "qtm": "marker readers", "c3d": "marker readers", "trc": "marker readers", "mot": "marker readers",
    "sto": "marker readers", "vicon": "marker readers", "mvnx": "marker readers",
    "imu": "IMU readers", "points": "IMU readers",
    "mkp": "packets", "mkpoints": "packets", "mkc": "clip", "verify": "verify", "catalog": "catalog",
    "batch": "batch",
}

#: formats where a missing sample is a convention of the format (an empty cell, NaN in a marker CSV):
#: replacing a number with such a spelling may legitimately read as a gap
GAP_SPELLINGS = {
    "qtm": {"", "nan", "NaN", "NULL"},
    "trc": {""},
    "vicon": {""},
    "c3d": set(),
}

#: formats where a sample's values are not checked for finiteness after reading (marker positions hold
#: NaN for gaps)
NAN_IS_GAP = {"qtm", "c3d", "trc", "vicon"}


@dataclass
class Seed:
    name: str
    fmt: str
    path: Path  # the seed file in the work folder
    commands: list[list[str]]
    companion: Path | None = None  # the ASF of an AMC, the AMC of an ASF, the original of a compressed file
    load_options: dict = field(default_factory=dict)  # options of mocapkit.load for the digest
    binary: bool = False
    folder: bool = False  # a sensor folder (odd paths and kills only; not mutated)

    @property
    def area(self) -> str:
        return AREA_OF_FORMAT[self.fmt]


def _skeletal(extra: list[str]) -> list[list[str]]:
    return [
        ["info", "{in}", "--json", *extra],
        ["convert", "{in}", "{out}/o.bvh", *extra],
        ["compress", "{in}", "--json", "--stats-only", "-t", "0.01", *extra],
        ["compress", "{in}", "-o", "{out}/c.glb", "--max-position-error", "1", "--unit-cm", "1", *extra],
    ]


def _markers() -> list[list[str]]:
    return [
        ["info", "{in}", "--json"],
        ["convert", "{in}", "{out}/o.csv"],
        ["convert", "{in}", "{out}/o.c3d"],
        ["convert", "{in}", "{out}/o.trc"],
        ["filter", "{in}", "--auto", "--json"],
    ]


def _imu(rate: list[str]) -> list[list[str]]:
    return [
        ["info", "{in}", "--json", *rate],
        ["compress", "{in}", "-t", "0.001", "-o", "{out}/p.csv", *rate],
        ["compress", "{in}", "--max-angle", "2", "--json", *rate],
        ["compress", "{in}", "--max-angle", "2", "-o", "{out}/x.mkp", *rate],
        ["stream", "-t", "0.001", *rate, "<stdin>"],
    ]


#: IMU excerpts without timestamps need a rate
_NEEDS_RATE = {"legacy_xio.csv", "xsens_wrap.txt", "SensorLog_motion.csv", "legacy_QuaternionData.csv"}


def imu_files() -> list[Path]:
    files = sorted((DATA / "imu").glob("*/*")) + sorted((DATA / "formats").glob("*"))
    files += [DATA / "xio" / "pelvis" / "Quaternion.csv"]
    return [f for f in files if f.is_file()]


def build_seeds(work: Path, run_cli=None) -> list[Seed]:
    """Copy the excerpts into ``work/seeds`` and make the generated seeds (needs ``run_cli``, see
    :func:`tests.trial.runner.run_cli`, for the C3D, glb/glTF and points files)."""
    sd = work / "seeds"
    sd.mkdir(parents=True, exist_ok=True)

    def copy(rel: str, name: str | None = None) -> Path:
        dst = sd / (name or Path(rel).name)
        shutil.copyfile(DATA / rel, dst)
        return dst

    seeds: list[Seed] = []
    for rel in ("bvh/walk-meredith-60.bvh", "bvh/perception-neuron-freya-12.bvh"):
        p = copy(rel)
        seeds.append(Seed(p.stem, "bvh", p, _skeletal([]) + [["segment", "{in}", "-m", "pca", "--json"]]
                          + [["compress", "{in}", "--max-position-error", "1", "-o", "{out}/c.mkc"]]
                          * (p.stem == "walk-meredith-60")))
    asf = copy("cmu/86.asf")
    amc = copy("cmu/86_01_first60.amc")
    amc_cmds = [["info", "{in}", "--asf", "{asf}", "--json"], ["convert", "{in}", "{out}/o.bvh", "--asf", "{asf}"],
                ["compress", "{in}", "--asf", "{asf}", "--json", "--stats-only", "-t", "0.01"]]
    seeds.append(Seed("86_01_first60", "amc", amc, amc_cmds, companion=asf, load_options={"asf": "{asf}"}))
    asf_cmds = [["info", "{amc}", "--asf", "{in}", "--json"], ["convert", "{amc}", "{out}/o.bvh", "--asf", "{in}"]]
    seeds.append(Seed("86.asf", "asf", asf, asf_cmds, companion=amc))
    mv = copy("mvnx/86_01_xsens_60hz.mvnx")
    seeds.append(Seed(mv.stem, "mvnx", mv, _skeletal([])[:3]))
    tsv = copy("markers/juggling-qualisys-300hz-first120.tsv")
    seeds.append(Seed(tsv.stem, "qtm", tsv, _markers()))
    for rel in ("opensim/walk_free_01-first20.trc", "opensim/std_walking2_markers-frames36-51.trc"):
        p = copy(rel)
        seeds.append(Seed(p.stem, "trc", p, _markers()))
    vic = copy("markers/vicon-nexus-walking2-excerpt.csv")
    seeds.append(Seed(vic.stem, "vicon", vic, _markers()))
    mot = copy("opensim/subject01_walk1_ik-first20.mot")
    seeds.append(Seed(mot.stem, "mot", mot, [["info", "{in}", "--json"], ["convert", "{in}", "{out}/o.csv"],
                                             ["convert", "{in}", "{out}/o.mot"]]))
    sto = copy("opensim/myComplexTasksTrial_orientations.sto")
    seeds.append(Seed(sto.stem, "sto", sto, [["info", "{in}", "--json"], ["convert", "{in}", "{out}/o.sto"],
                                             ["compress", "{in}", "-t", "0.001", "--json"]]))
    for f in imu_files():
        dst = sd / f"imu-{f.parent.name}-{f.name}"
        shutil.copyfile(f, dst)
        rate = ["--rate", "100"] if f.name in _NEEDS_RATE else []
        seeds.append(Seed(dst.name, "imu", dst, _imu(rate), load_options={"rate": 100.0} if rate else {}))
    folder = sd / "xio-folder"
    if not folder.exists():
        shutil.copytree(DATA / "xio", folder)
    seeds.append(Seed("xio-folder", "imu", folder, [["compress", "{in}", "-t", "0.001", "-o", "{out}/points"],
                                                    ["info", "{in}", "--json"],
                                                    ["compress", "{in}", "--json", "-t", "0.001"]], folder=True))
    if run_cli is not None:
        seeds += _generated(sd, tsv, run_cli)
    return seeds


def make_catalog(sd: Path, run_cli) -> Path | None:
    """``sd/catalog.duckdb``: a small catalog (``catalog import`` of three tests/data files) for the
    ``sql`` category."""
    cat = sd / "catalog.duckdb"
    if cat.exists():
        cat.unlink()
    files = [DATA / "bvh" / "walk-meredith-60.bvh", DATA / "xio" / "pelvis" / "Quaternion.csv",
             DATA / "markers" / "juggling-qualisys-300hz-first120.tsv"]
    r = run_cli(["catalog", "import", *files, "--db", cat], timeout=120)
    return cat if r.returncode == 0 and cat.is_file() else None


def _verify(bound: list[str]) -> list[str]:
    return ["verify", "{orig}", "{in}", *bound, "--json"]


def _generated(sd: Path, tsv: Path, run_cli) -> list[Seed]:
    out: list[Seed] = []
    c3d = sd / "juggling.c3d"
    r = run_cli(["convert", tsv, c3d], timeout=120)
    if r.returncode == 0 and c3d.is_file():
        out.append(Seed(c3d.stem, "c3d", c3d, _markers(), binary=True))
    bvh = sd / "walk-meredith-60.bvh"
    for suffix in (".glb", ".gltf"):
        clip = sd / f"walk-clip{suffix}"
        r = run_cli(["compress", bvh, "-o", clip, "-t", "0.01"], timeout=120)
        if r.returncode == 0 and clip.is_file():
            out.append(Seed(clip.name, suffix[1:], clip, [["decompress", "{in}", "-o", "{out}/d.bvh"],
                                                          _verify(["--max-position-error", "1"])],
                            companion=bvh, binary=suffix == ".glb"))
    src = sd / "imu-pelvis-Quaternion.csv"
    pts = sd / "points.csv"
    r = run_cli(["compress", src, "-t", "0.001", "-o", pts], timeout=120)
    if r.returncode == 0 and pts.is_file():
        out.append(Seed(pts.name, "points", pts, [["decompress", "{in}", "-o", "{out}/d.csv", "--rate", "50"],
                                                  ["decompress", "{in}", "-o", "{out}/d2.csv", "--times-from",
                                                   "{orig}"], _verify(["--max-angle", "3"]), _verify([])],
                        companion=src))
        # the original mutated, the compressed file kept
        out.append(Seed("verify-original-imu", "imu", src, [["verify", "{in}", "{orig}", "--max-angle", "2",
                                                               "--json"]], companion=pts))
    mkp = sd / "walk-imu.mkp"
    r = run_cli(["compress", src, "--max-angle", "2", "-o", mkp], timeout=120)
    if r.returncode == 0 and mkp.is_file():
        out.append(Seed(mkp.name, "mkp", mkp, [["decompress", "{in}", "-o", "{out}/pts.csv"],
                                               ["decompress", "{in}", "-o", "{out}/d.csv", "--times-from", "{orig}"],
                                               ["decompress", "{in}", "-o", "{out}/d.csv", "--rate", "50"],
                                               ["info", "{in}", "--json"], _verify(["--max-angle", "2"])],
                        companion=src, binary=True))
        ticks = sd / "mkp-points.csv"
        r = run_cli(["decompress", mkp, "-o", ticks], timeout=120)
        if r.returncode == 0 and ticks.is_file():
            out.append(Seed(ticks.name, "mkpoints", ticks,
                            [["decompress", "{in}", "-o", "{out}/d.csv", "--times-from", "{orig}"],
                             _verify(["--max-angle", "2"])], companion=src))
    make_catalog(sd, run_cli)
    mkc = sd / "walk.mkc"
    r = run_cli(["compress", bvh, "--max-position-error", "1", "-o", mkc], timeout=300)
    if r.returncode == 0 and mkc.is_file():
        out.append(Seed(mkc.name, "mkc", mkc, [["decompress", "{in}", "-o", "{out}/d.bvh"], ["info", "{in}", "--json"],
                                               _verify(["--max-position-error", "1"])], companion=bvh, binary=True))
        out.append(Seed("verify-original-bvh", "bvh", bvh, [["verify", "{in}", "{orig}", "--max-position-error", "1",
                                                               "--json"]], companion=mkc))
    return out


def expand(argv: list[str], *, inp: Path, out: Path, companion: Path | None) -> tuple[list[str], Path | None]:
    """Fill a command template; returns ``(argv, stdin)``."""
    res, stdin = [], None
    for a in argv:
        if a == "<stdin>":
            stdin = inp
            continue
        a = a.replace("{in}", str(inp)).replace("{out}", str(out))
        if companion is not None:
            a = a.replace("{asf}", str(companion)).replace("{amc}", str(companion)).replace("{orig}", str(companion))
        res.append(a)
    return res, stdin


def outputs_of(argv: list[str]) -> list[Path]:
    """The files a command writes (``-o X``, the second argument of ``convert``)."""
    outs = []
    for i, a in enumerate(argv):
        if a in ("-o", "--output") and i + 1 < len(argv):
            outs.append(Path(argv[i + 1]))
    if argv and argv[0] == "convert" and len(argv) >= 3:
        outs.append(Path(argv[2]))
    return outs
