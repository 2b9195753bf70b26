"""Imports point down the layers of docs/architecture.md, over every import of every module (function
bodies included): cli -> jobs/batch/catalog/verify/view -> evaluation/plot -> pla/clip/filters/segment ->
model; io imports only the model and itself, and no algorithm imports io; inside io the shared helpers
import no family, and no family imports another or the dispatcher; no two packages import each other."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

import mocapkit
from import_graph import (
    LAYERS,
    import_graph,
    io_violations,
    layer_of,
    layer_violations,
    names_from_root,
    package_cycles,
)

SRC = Path(mocapkit.__file__).parent


def test_every_module_is_in_a_layer_and_imports_point_down():
    graph = import_graph(parents=True)
    assert len(graph) > 150 and all(layer_of(m) for m in graph)
    assert {layer_of(m) for m in graph} == set(LAYERS)
    assert layer_violations(graph, names_from_root()) == []


def test_no_algorithm_imports_io_and_io_imports_no_layer_above_the_model():
    graph = import_graph(parents=True)
    algorithms = [m for m in graph if layer_of(m) == "algorithms"]
    io = [m for m in graph if layer_of(m) == "io"]
    assert len(algorithms) > 50 and len(io) > 30
    for m in algorithms:
        assert not [x for x in graph[m] if layer_of(x) == "io"], m
    for m in io:
        assert {layer_of(x) for x in graph[m] - {"mocapkit"}} <= {"io", "model"}, (m, sorted(graph[m]))


def test_io_keeps_its_own_order():
    assert io_violations(import_graph()) == []


def test_no_two_packages_import_each_other():
    assert package_cycles(import_graph()) == []


@pytest.fixture
def planted(tmp_path):
    """A copy of the package's sources with the wrong imports planted in it (the sources are untouched)."""
    root = tmp_path / "mocapkit"
    shutil.copytree(SRC, root, ignore=shutil.ignore_patterns("*.so", "__pycache__", "*.nb[ic]", "data", "static"))

    def plant(module: str, line: str) -> None:
        f = root.joinpath(*module.split(".")[1:]).with_suffix(".py")
        if not f.exists():
            f = f.with_suffix("") / "__init__.py"
        f.write_text(f.read_text() + f"\n\ndef _planted():\n    {line}\n")

    return root, plant


def test_the_checks_find_planted_wrong_imports(planted):
    """The checks could pass vacuously if they missed imports: each wrong import planted lazily (inside a
    function) in a copy of the sources is found, and only those."""
    root, plant = planted
    plant("mocapkit.pla.packets", "from mocapkit.io.formats.mkp import read_mkp_bytes")  # algorithm -> io
    plant("mocapkit.clip.decoder", "from mocapkit import load")  # algorithm -> io through the root
    plant("mocapkit.io.formats.mkc", "from mocapkit.clip.decoder import Clip")  # io -> algorithm
    plant("mocapkit.io.text.numbers", "import mocapkit.jobs.readers")  # io -> jobs
    plant("mocapkit.motion", "from mocapkit.io.text import numbers")  # model -> io
    plant("mocapkit.segment.metrics", "from mocapkit.evaluation import sweep")  # algorithm -> evaluation
    plant("mocapkit.io.text.input", "from mocapkit.io.skeletal.bvh import read_bvh")  # io base -> family
    plant("mocapkit.io.skeletal.amc", "from mocapkit.io.markers import c3d")  # family -> family
    graph = import_graph(root, parents=True)
    found = layer_violations(graph, names_from_root(root))
    assert sorted(found) == sorted([
        "mocapkit.pla.packets (algorithms) imports mocapkit.io (io)",
        "mocapkit.pla.packets (algorithms) imports mocapkit.io.formats (io)",
        "mocapkit.pla.packets (algorithms) imports mocapkit.io.formats.mkp (io)",
        "mocapkit.clip.decoder (algorithms) imports ['load'] from the package root",
        "mocapkit.io.formats.mkc (io) imports mocapkit.clip (algorithms)",
        "mocapkit.io.formats.mkc (io) imports mocapkit.clip.decoder (algorithms)",
        "mocapkit.io.text.numbers (io) imports mocapkit.jobs (jobs)",
        "mocapkit.io.text.numbers (io) imports mocapkit.jobs.readers (jobs)",
        "mocapkit.motion (model) imports mocapkit.io (io)",
        "mocapkit.motion (model) imports mocapkit.io.text (io)",
        "mocapkit.motion (model) imports mocapkit.io.text.numbers (io)",
        "mocapkit.segment.metrics (algorithms) imports mocapkit.evaluation (evaluation)",
        "mocapkit.segment.metrics (algorithms) imports mocapkit.evaluation.sweep (evaluation)",
    ]), found
    io_found = io_violations(import_graph(root))
    assert sorted(io_found) == [
        "mocapkit.io.skeletal.amc (mocapkit.io.skeletal) imports mocapkit.io.markers (another io family)",
        "mocapkit.io.skeletal.amc (mocapkit.io.skeletal) imports mocapkit.io.markers.c3d (another io family)",
        "mocapkit.io.text.input (io base) imports mocapkit.io.skeletal.bvh",
    ], io_found
    assert package_cycles(import_graph(root))  # io.text <-> jobs, io.formats <-> clip...


def test_a_module_in_no_layer_is_refused(planted):
    root, _ = planted
    (root / "newpackage").mkdir()
    (root / "newpackage" / "__init__.py").write_text("")
    assert "mocapkit.newpackage: in no layer of docs/architecture.md" in layer_violations(
        import_graph(root, parents=True), names_from_root(root))
