"""What starting mocapkit imports (issue 25): ``import mocapkit``, ``mocapkit --version`` and ``--help`` load no
heavy library and no reader; ``mocapkit info`` of a BVH loads only the BVH reader. Each check runs in a fresh
interpreter and compares the set of modules it ends with (never a time). The lazy package names of PEP 562
are each the object of the module that defines it."""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

import mocapkit

SRC = Path(mocapkit.__file__).resolve().parent
DATA = Path(__file__).resolve().parent / "data"
BVH = DATA / "bvh" / "walk-meredith-60.bvh"

#: libraries a start must not load (distributed: dask's; PIL: Pillow)
HEAVY = ("scipy", "numba", "matplotlib", "duckdb", "pyarrow", "psycopg", "distributed", "dask", "ezc3d",
         "pygltflib", "zstandard", "PIL")
#: mocapkit's readers and algorithm/job internals a start must not load
INTERNALS = ("mocapkit.io.imu", "mocapkit.io.markers", "mocapkit.io.skeletal", "mocapkit.io.formats", "mocapkit.clip",
             "mocapkit.pla", "mocapkit.filters", "mocapkit.segment", "mocapkit.catalog", "mocapkit.batch",
             "mocapkit.view")
#: the packages whose names load on first use
LAZY_PACKAGES = ("mocapkit", "mocapkit.pla", "mocapkit.filters", "mocapkit.segment", "mocapkit.clip", "mocapkit.io",
                 "mocapkit.jobs", "mocapkit.catalog", "mocapkit.batch", "mocapkit.verify", "mocapkit.view")


def _run(code: str, tmp_path: Path) -> dict:
    """Run ``code`` in a fresh interpreter (this test's mocapkit first on its path); it leaves its results
    in the dict ``out``, returned with ``out["modules"]``: every module loaded at its end."""
    out = tmp_path / "out.json"
    script = (f"import json, sys\nsys.path.insert(0, {str(SRC.parent)!r})\nout = {{}}\n{code}\n"
              f"out['modules'] = sorted(sys.modules)\nopen({str(out)!r}, 'w').write(json.dumps(out))\n")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300,
                          check=False)
    assert done.returncode == 0, done.stderr
    return json.loads(out.read_text())


def _within(name: str, prefixes) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def _cli(args: list[str]) -> str:
    """Code running the command line in-process with ``args``, its exit code in ``out["code"]``."""
    return (f"from mocapkit import cli\ntry:\n    cli.main({args!r})\nexcept SystemExit as e:\n"
            f"    out['code'] = e.code\n")


def test_import_mocapkit_loads_no_heavy_library_and_no_reader(tmp_path):
    mods = _run("import mocapkit", tmp_path)["modules"]
    assert "mocapkit" in mods
    assert [m for m in mods if _within(m, HEAVY)] == []
    assert [m for m in mods if _within(m, INTERNALS)] == []
    assert "numpy" not in mods  # the model classes (numpy) load on first use too


@pytest.mark.parametrize("args", [["--version"], ["--help"]])
def test_version_and_help_load_no_heavy_library_and_no_reader(tmp_path, args):
    got = _run(_cli(args), tmp_path)
    assert got["code"] in (0, None)
    mods = got["modules"]
    assert "mocapkit.cli" in mods and "typer" in mods  # the command line did run
    assert [m for m in mods if _within(m, HEAVY)] == []
    assert [m for m in mods if _within(m, INTERNALS)] == []


def test_info_of_a_bvh_loads_only_what_it_reads(tmp_path):
    got = _run(_cli(["info", str(BVH), "--json"]), tmp_path)
    assert got["code"] in (0, None)
    mods = got["modules"]
    assert "mocapkit.io.skeletal.bvh" in mods  # the file was read
    assert [m for m in mods if _within(m, ("scipy", "numba", "matplotlib", "duckdb"))] == []


def test_the_generic_loader_still_reads_clips_and_opensim_orientations(tmp_path):
    """The ``.mkc`` reader the package root registers, and the OpenSim readers of ``io.imu.signals.READERS``,
    work in a fresh interpreter that imported nothing else first."""
    got = _run(f"import mocapkit\nm = mocapkit.load({str(DATA / 'clip' / 'walk-meredith-60.mkc')!r})\n"
               f"out['frames'] = m.n_frames\nout['type'] = type(m).__name__\n"
               f"s = mocapkit.load({str(DATA / 'opensim' / 'myComplexTasksTrial_orientations.sto')!r})\n"
               f"out['signals'] = sorted(s)\n"
               "from mocapkit.io import READERS\nout['readers'] = sorted(READERS)\n", tmp_path)
    assert got["type"] == "Motion" and got["frames"] == 60
    assert got["signals"] and {".sto", ".mot"} <= set(got["readers"])


def _declared(package: str) -> dict[str, tuple[str, str]]:
    """``{name: (module, name there)}`` the package's ``__init__`` imports (at its top or in its
    ``TYPE_CHECKING`` block, read from the source: what type checkers see), aliases ``a = b`` included."""
    init = SRC.joinpath(*package.split(".")[1:], "__init__.py")
    found: dict[str, tuple[str, str]] = {}
    body = ast.parse(init.read_text()).body
    for node in body + [n for b in body if isinstance(b, ast.If) for n in b.body]:
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("mocapkit"):
            found.update({a.asname or a.name: (node.module, a.name) for a in node.names})
        elif isinstance(node, ast.Assign) and isinstance(node.value, ast.Name) and node.value.id in found:
            found.update({t.id: found[node.value.id] for t in node.targets if isinstance(t, ast.Name)})
    return found


def test_every_lazy_name_is_the_object_of_its_module(tmp_path):
    """In a fresh interpreter: ``dir(pkg)`` lists ``__all__`` before any name is used; each name of
    ``__all__`` resolves by ``getattr`` to the very object its defining module holds; unknown names
    raise AttributeError (so ``from pkg import submodule`` still imports the submodule)."""
    declared = {p: _declared(p) for p in LAZY_PACKAGES}
    assert all(declared.values())
    code = f"""
import importlib
declared = {declared!r}
problems = []
for package, names in declared.items():
    pkg = importlib.import_module(package)
    missing = set(pkg.__all__) - set(dir(pkg))
    if missing:
        problems.append(f"{{package}}: dir() lacks {{sorted(missing)}}")
    if hasattr(pkg, "no_such_name"):
        problems.append(f"{{package}}: an unknown name resolved")
    for name in pkg.__all__:
        value = getattr(pkg, name)
        if name in names:
            module, there = names[name]
            if value is not getattr(importlib.import_module(module), there):
                problems.append(f"{{package}}.{{name}} is not {{module}}.{{there}}")
        elif name not in vars(pkg):
            problems.append(f"{{package}}.{{name}} is not kept in the package")
out["problems"] = problems
import mocapkit.jobs as jobs
out["jobs"] = {{k: f"{{v.__module__}}.{{v.__name__}}" for k, v in jobs.JOBS.items()}}
import mocapkit.pla as pla
out["submodule"] = importlib.import_module("mocapkit.pla.base") is __import__("mocapkit.pla", fromlist=["base"]).base
from importlib import metadata
try:
    expected = metadata.version("mocapkit")
except metadata.PackageNotFoundError:
    expected = "0+unknown"
import mocapkit
out["version"] = [mocapkit.__version__, expected]
"""
    got = _run(code, tmp_path)
    assert got["problems"] == []
    assert got["jobs"] == {j: f"mocapkit.jobs.{j}.{j}_job" for j in ("info", "compress", "filter", "segment", "verify")}
    assert got["submodule"] is True
    assert got["version"][0] == got["version"][1]


def test_each_lazy_package_declares_every_name_it_loads():
    """The lazy maps name no module the package does not show to type checkers, and the reverse: every
    name a package's ``__getattr__`` loads comes from the module its ``TYPE_CHECKING`` import says."""
    import importlib

    for package in LAZY_PACKAGES:
        pkg = importlib.import_module(package)
        where = getattr(pkg, "_WHERE", None)
        if where is None:  # mocapkit.jobs: its map is by job
            continue
        declared = _declared(package)
        for name, module in where.items():
            module = module if isinstance(module, str) else module[0]
            assert declared.get(name, (None,))[0] == module, (package, name, module)


def test_no_numba_kernel_compiles_at_import(tmp_path):
    """Every compiled kernel waits for its first call: importing every algorithm package (and resolving its
    names) leaves each numba dispatcher of mocapkit without a compiled signature."""
    got = _run("""
import importlib, pkgutil
import mocapkit
for info in pkgutil.walk_packages(mocapkit.__path__, "mocapkit."):
    if info.name.startswith(("mocapkit.pla", "mocapkit.clip", "mocapkit.filters", "mocapkit.segment",
                             "mocapkit.quat", "mocapkit.rotvec")):
        importlib.import_module(info.name)
from numba.core.registry import CPUDispatcher
kernels = [(name, k, bool(v.signatures)) for name, mod in list(sys.modules.items()) if name.startswith("mocapkit")
           for k, v in vars(mod).items() if isinstance(v, CPUDispatcher)]
out["kernels"] = sorted({(n, k) for n, k, _ in kernels})
out["compiled"] = sorted({(n, k) for n, k, done in kernels if done})
""", tmp_path)
    assert len(got["kernels"]) > 40  # the walk did reach the kernels
    assert got["compiled"] == []
