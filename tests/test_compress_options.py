"""The options of the compress jobs: the command, ``batch compress`` and a batch manifest build equal
options objects for the same values; the invalid combinations are refused with the messages the command
has always printed; each options class is a frozen, typed dataclass."""

from __future__ import annotations

import dataclasses
import typing
from pathlib import Path

import pytest
from typer.testing import CliRunner

import mocapkit.jobs.compress as compress_module
from mocapkit import jobs
from mocapkit.batch.file_options import load_manifest, resolve
from mocapkit.cli import app
from mocapkit.errors import InvalidParameterError
from mocapkit.jobs import (
    ImuCompressOptions,
    PacketCompressOptions,
    SkeletonCompressOptions,
    batch_output,
    compress_job,
    compress_options,
)
from mocapkit.jobs.compress import options_for

CLASSES = (ImuCompressOptions, SkeletonCompressOptions, PacketCompressOptions)


@pytest.fixture
def imu(tests_data) -> Path:
    return (tests_data / "imu" / "xsens-dot" / "LFemur_excerpt.csv").resolve()


@pytest.fixture
def bvh(tests_data) -> Path:
    return (tests_data / "bvh" / "walk-meredith-60.bvh").resolve()


def _cli_options(monkeypatch, argv: list[str]):
    """The options object the ``compress`` command hands to its job (the job itself replaced)."""
    seen = []

    def job(path, options, **run):
        seen.append(options)
        return {"job": "compress", "kind": "imu", "method": "x", "mode": "x", "target": 1.0, "signals": [],
                "warnings": [], "skipped_files": [], "outputs": []}

    monkeypatch.setattr(compress_module, "compress_imu", job)
    monkeypatch.setattr(compress_module, "compress_skeleton", job)
    monkeypatch.setattr(jobs, "compress_packets", job)
    res = CliRunner().invoke(app, ["compress", *map(str, argv)])
    assert res.exception is None or isinstance(res.exception, SystemExit), res.output
    assert len(seen) == 1, res.output
    return seen[0]


def _batch_options(monkeypatch, argv: list[str]) -> dict:
    """The options dict ``batch compress`` hands to the engine (the engine replaced)."""
    from mocapkit import cli_batch

    seen = []
    monkeypatch.setattr(cli_batch, "_run", lambda job, inputs, options, *a: seen.append(options))
    res = CliRunner().invoke(app, ["batch", "compress", *map(str, argv)])
    assert res.exception is None, res.output
    return seen[0]


def _per_file(path: Path, options: dict, tmp_path: Path, manifest=None):
    """What a batch worker builds for ``path``: its resolved options (manifest, sidecar) through the job's
    constructor, with the output the batch gives it."""
    opts = resolve("compress", path, options, manifest).options
    out = batch_output("compress", path, opts, tmp_path / "out" / path.stem, make=False)
    return options_for(path, out, **opts)


def test_imu_options_are_equal_from_the_command_the_batch_and_a_manifest(monkeypatch, imu, tmp_path):
    given = ["--method", "anglesw", "--max-segment-length", "50", "--time-unit", "s"]
    cli = _cli_options(monkeypatch, [imu, "--max-angle", "2", *given, "--json"])
    assert cli == ImuCompressOptions(method="anglesw", max_angle=2.0, max_segment_length=50, time_unit="s")
    batch = _batch_options(monkeypatch, [imu, "--out", tmp_path / "b", "--max-angle", "2", *given])
    assert _per_file(imu, batch, tmp_path) == cli
    (tmp_path / "m.toml").write_text(f'[[files]]\npath = "{imu}"\nmax_angle = 2\n')
    manifest = load_manifest(tmp_path / "m.toml")
    batch = _batch_options(monkeypatch, [imu, "--out", tmp_path / "b", "--manifest", tmp_path / "m.toml", *given])
    assert _per_file(imu, batch, tmp_path, manifest) == cli


def test_skeleton_options_are_equal_from_the_command_the_batch_and_a_manifest(monkeypatch, bvh, tmp_path):
    given = ["--unit-cm", "2.54", "--gltf-rotations", "float", "--method", "cplr"]
    cli = _cli_options(monkeypatch, [bvh, "--max-position-error", "1", *given, "-o", tmp_path / "c.glb"])
    assert cli == SkeletonCompressOptions(method="cplr", max_position_error=1.0, unit_cm=2.54, gltf_rotations="float")
    as_batch = dataclasses.replace(cli, skeletal_format="glb")  # the batch names the format its outputs carry
    batch = _batch_options(monkeypatch, [bvh, "--out", tmp_path / "b", "--max-position-error", "1", *given])
    assert _per_file(bvh, batch, tmp_path) == as_batch
    sidecar = bvh.with_name(bvh.stem + ".mocapkit.toml")
    assert not sidecar.exists()
    (tmp_path / "m.toml").write_text(f'[[files]]\npath = "{bvh}"\nmax_position_error = 1\n')
    batch = _batch_options(monkeypatch, [bvh, "--out", tmp_path / "b", "--manifest", tmp_path / "m.toml", *given])
    assert _per_file(bvh, batch, tmp_path, load_manifest(tmp_path / "m.toml")) == as_batch


def test_an_asf_is_the_same_path_whoever_gives_it(tests_data):
    amc, asf = tests_data / "cmu" / "86_01_first60.amc", (tests_data / "cmu" / "86.asf").resolve()
    assert options_for(amc, max_position_error=1.0, asf=str(asf)) == options_for(amc, max_position_error=1.0, asf=asf)
    assert options_for(amc, max_position_error=1.0, asf=asf).asf == asf


def test_packet_options_from_the_command(monkeypatch, imu, tmp_path):
    out = tmp_path / "p.mkp"
    cli = _cli_options(monkeypatch, [imu, "--max-angle", "2", "--packet-bits", "10", "--rate", "60", "-o", out,
                                     "--json"])
    assert cli == PacketCompressOptions(max_angle=2.0, packet_bits=10, packet_bytes=20, rate=60.0)
    assert cli == compress_options("packets", out, max_angle=2.0, packet_bits=10, rate=60.0)


REFUSED = [
    ("imu", {"threshold": 1.0, "max_angle": 2.0}, None,
     "give exactly one of --threshold, --target-icr, --max-angle (IMU data) or --max-position-error (skeletons)"),
    ("skeletal", {}, None,
     "give exactly one of --threshold, --target-icr, --max-angle (IMU data) or --max-position-error (skeletons)"),
    ("imu", {"method": "nope", "threshold": 1.0}, None,
     "--method 'nope': one of fastsw, sw, cplr, swing, anglesw, optimal"),
    ("skeletal", {"max_position_error": 1.0, "skeletal_format": "zip"}, None, "--skeletal-format 'zip': mkc or glb"),
    ("skeletal", {"max_position_error": 1.0, "error_metric": "shell", "skeletal_format": "glb"}, None,
     "--error-metric shell is bounded in .mkc clips: add --skeletal-format mkc"),
    ("skeletal", {"max_angle": 2.0}, None,
     "for skeletal input use --max-position-error CM (or --threshold / --target-icr)"),
    ("skeletal", {"max_angle": 2.0}, "c.mkc", "c.mkc: a .mkc clip is bounded by --max-position-error CM only"),
    ("imu", {"max_angle": 2.0, "asf": "86.asf"}, None,
     "--max-position-error, --asf and --unit-cm apply to BVH/AMC input"),
    ("imu", {"max_angle": 2.0, "unit_cm": 1.0}, None,
     "--max-position-error, --asf and --unit-cm apply to BVH/AMC input"),
    ("imu", {"threshold": 1.0, "packet_bits": 8}, None,
     "--packet-bits and --packet-bytes apply to a packet stream (-o OUT.mkp)"),
    ("packets", {"threshold": 1.0, "max_angle": 2.0}, "p.mkp",
     "p.mkp: a .mkp packet stream is bounded by --max-angle DEG only"),
    ("packets", {}, "p.mkp", "p.mkp: a .mkp packet stream is bounded by --max-angle DEG only"),
    ("packets", {"max_angle": 2.0, "method": "cplr"}, "p.mkp",
     "p.mkp: a .mkp packet stream is made by the angle-bounded encoder (anglesw), not cplr"),
    ("packets", {"max_angle": float("inf")}, "p.mkp", "--max-angle inf: a positive number of degrees"),
    ("packets", {"max_angle": 2.0, "packet_bits": 3}, "p.mkp", "--packet-bits 3: an integer in 6..16"),
]


@pytest.mark.parametrize(("kind", "given", "output", "message"), REFUSED)
def test_invalid_combinations_are_refused_as_before(kind, given, output, message):
    with pytest.raises(InvalidParameterError) as e:
        compress_options(kind, None if output is None else Path(output), **given)
    assert str(e.value) == message


@pytest.mark.parametrize(("argv", "message"), [
    (["{bvh}", "--max-angle", "2", "-o", "{tmp}/c.mkc"],
     "{tmp}/c.mkc: a .mkc clip is bounded by --max-position-error CM only"),
    (["{bvh}", "--max-angle", "2", "--json"],
     "for skeletal input use --max-position-error CM (or --threshold / --target-icr)"),
    (["{imu}", "-t", "1", "--unit-cm", "1", "--json"],
     "--max-position-error, --asf and --unit-cm apply to BVH/AMC input"),
    (["{imu}", "-t", "1", "-o", "{tmp}/p.mkp"], "{tmp}/p.mkp: a .mkp packet stream is bounded by --max-angle DEG only"),
    (["{imu}", "-t", "1", "--packet-bits", "8", "--json"],
     "--packet-bits and --packet-bytes apply to a packet stream (-o OUT.mkp)"),
])
def test_the_command_refuses_them_with_the_same_message(argv, message, imu, bvh, tmp_path):
    fill = {"bvh": bvh, "imu": imu, "tmp": tmp_path}
    res = CliRunner().invoke(app, ["compress", *(a.format(**fill) for a in argv)])
    assert isinstance(res.exception, InvalidParameterError) and str(res.exception) == message.format(**fill)


def test_the_job_takes_the_options_it_always_took(imu):
    """The batch reads which options the job takes from its signature (the manifest's keys it uses)."""
    import inspect

    names = set(inspect.signature(compress_job).parameters)
    assert names == {"path", "method", "threshold", "target_icr", "max_angle", "max_segment_length", "rate",
                     "time_column", "quaternion_columns", "scalar_last", "time_unit", "asf", "max_position_error",
                     "unit_cm", "strict", "output", "points_stream", "discard_ok", "progress", "gltf_rotations",
                     "error_metric", "shell_distance", "block_frames", "skeletal_format", "entropy"}
    with pytest.raises(TypeError, match="unexpected keyword argument 'packet_bits'"):
        compress_job(imu, threshold=1.0, packet_bits=8)
    with pytest.raises(TypeError, match="unexpected keyword argument 'bogus'"):
        compress_options("imu", bogus=1)


@pytest.mark.parametrize("cls", CLASSES)
def test_each_options_class_is_frozen_and_typed(cls):
    assert dataclasses.is_dataclass(cls) and cls.__dataclass_params__.frozen
    hints = typing.get_type_hints(cls)
    assert [f.name for f in dataclasses.fields(cls)] == list(hints)
    options = cls(max_angle=2.0) if cls is PacketCompressOptions else cls()
    for f in dataclasses.fields(cls):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(options, f.name, getattr(options, f.name))
    assert options == dataclasses.replace(options) and hash(options) == hash(dataclasses.replace(options))


def test_the_packets_job_takes_the_options_it_always_took(imu, tmp_path):
    with pytest.raises(TypeError, match="unexpected keyword argument 'asf'"):
        compress_options("packets", tmp_path / "p.mkp", max_angle=2.0, asf="86.asf")
