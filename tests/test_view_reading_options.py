"""`view` reads IMU files with the options of `compress` (--rate, --time-column, --quaternion-columns,
--scalar-last, --time-unit) and pairs an original with the points CSV that `compress -o` writes (the kept
samples at their times): the decode drawn is the compression's, its largest error the one compress
reports."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mocapkit.errors import MocapFormatError
from mocapkit.view.arrays import decode_array
from mocapkit.view.scene import build_scene
from test_robust_cli import assert_one_line_error, cli_run

DATA = Path(__file__).resolve().parent / "data"
LEGACY = DATA / "formats" / "legacy_xio.csv"
PELVIS = DATA / "xio" / "pelvis" / "Quaternion.csv"


def test_rate_reads_an_imu_file_without_timestamps(tmp_path):
    with pytest.raises(MocapFormatError, match="--rate"):
        build_scene([LEGACY])
    scene = build_scene([LEGACY], rate=100.0)
    sensor = scene["panels"][0]["sensors"][0]
    packets = np.genfromtxt(LEGACY, delimiter=",", skip_header=1)[:, 0]
    np.testing.assert_allclose(decode_array(sensor["times"]), (packets - packets[0]) / 100.0, rtol=0, atol=1e-12)
    r = cli_run("view", LEGACY, "--rate", "100", "--export", tmp_path / "v.gif", "--frames", "0:2")
    assert r.code == 0, r.err


def test_column_options(tmp_path):
    p = tmp_path / "odd.csv"
    rows = np.genfromtxt(PELVIS, delimiter=",", skip_header=1)[:20]
    t_ms = (rows[:, 0] - rows[0, 0]) / 1000.0              # µs -> ms, under a name that says nothing
    lines = ["stamp,qa,qb,qc,qd"] + [",".join(repr(float(v)) for v in (t, *q))
                                     for t, q in zip(t_ms, rows[:, 1:5], strict=True)]
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(MocapFormatError):
        build_scene([p])
    cols = {"time_column": "stamp", "quaternion_columns": "qa,qb,qc,qd", "time_unit": "ms"}
    sensor = build_scene([p], columns=cols)["panels"][0]["sensors"][0]
    np.testing.assert_array_equal(decode_array(sensor["times"]), t_ms / 1e3)
    np.testing.assert_allclose(decode_array(sensor["original"]), rows[:, 1:5], rtol=0, atol=1e-6)  # float32 view
    r = cli_run("view", p, "--time-column", "stamp", "--quaternion-columns", "qa,qb,qc,qd", "--time-unit", "ms",
                "--export", tmp_path / "v.gif", "--frames", "0:2")
    assert r.code == 0, r.err
    assert_one_line_error(cli_run("view", p, "--export", tmp_path / "w.gif"), str(p))


@pytest.mark.parametrize("src, rate", [(LEGACY, 100.0), (PELVIS, None)])
def test_pairs_the_points_of_compress(tmp_path, src, rate):
    pts = tmp_path / "points.csv"
    extra = ["--rate", str(rate)] if rate else []
    r = cli_run("compress", src, "--threshold", "2e-3", "-o", pts, *extra)
    assert r.code == 0, r.err
    rec = json.loads(cli_run("compress", src, "--threshold", "2e-3", "--json", *extra).out)[0]
    scene = build_scene([src, pts], rate=rate)
    assert len(scene["panels"]) == 1 and scene["panels"][0]["name"] == f"{src.name} + points.csv"
    sensor = scene["panels"][0]["sensors"][0]
    assert sensor["max_error_deg"] == pytest.approx(rec["max_deg"], rel=1e-4, abs=1e-4)
    kept = np.genfromtxt(pts, delimiter=",", skip_header=1)
    np.testing.assert_array_equal(decode_array(sensor["keyframes"]), kept[:, 0])
    assert len(kept) == rec["n_points"]


def test_an_unrelated_time_wxyz_file_is_not_paired(tmp_path):
    other = tmp_path / "other.csv"
    rows = np.genfromtxt(PELVIS, delimiter=",", skip_header=1)[:30]
    t = (rows[:, 0] - rows[0, 0]) / 1e6 + 0.0001        # other times: another recording
    other.write_text("time,w,x,y,z\n" + "\n".join(",".join(repr(float(v)) for v in (ti, *q))
                                                  for ti, q in zip(t, rows[:, 1:5], strict=True)) + "\n")
    scene = build_scene([PELVIS, other])
    assert len(scene["panels"]) == 2
