"""`view --segments/--filter`: numbers out of a double's exact range in the JSON (1e400, 10**30, 10**400)
are a clean error (exit 2) naming the file and the field, never an internal error or a silent infinity."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mocapkit.errors import MocapFormatError
from mocapkit.view.scene import build_scene
from test_robust_cli import assert_one_line_error, cli_run

DATA = Path(__file__).resolve().parent / "data"
BVH = DATA / "bvh" / "walk-meredith-60.bvh"
TSV = DATA / "markers" / "juggling-qualisys-300hz-first120.tsv"


def _segments() -> str:
    rec = {"job": "segment", "file": BVH.name, "n_frames": 60, "rate_hz": 30.0,
           "cuts": [{"frame": 30, "time_s": 1.0}],
           "segments": [{"t0": 0.0, "t1": 1.0, "frame0": 0, "frame1": 30, "label": None, "action": None},
                        {"t0": 1.0, "t1": 2.0, "frame0": 30, "frame1": 60, "label": None, "action": None}]}
    return json.dumps(rec)


@pytest.mark.parametrize("old, new, field", [
    ('"frame": 30', '"frame": 1e400', "cuts[0].frame"),
    ('"frame": 30', '"frame": ' + str(10 ** 30), "cuts[0].frame"),
    ('"n_frames": 60', '"n_frames": ' + str(10 ** 400), "n_frames"),
    ('"frame0": 30', '"frame0": 1e400', "segments[1].frame0"),
    ('"t0": 1.0', '"t0": 1e400', "segments[1].t0"),
    ('"time_s": 1.0', '"time_s": -1e999', "cuts[0].time_s"),
])
def test_segments_json_huge_numbers(tmp_path, old, new, field):
    p = tmp_path / "seg.json"
    text = _segments()
    assert old in text
    p.write_text(text.replace(old, new, 1))
    with pytest.raises(MocapFormatError, match=field.replace("[", r"\[").replace("]", r"\]")):
        build_scene([BVH], segments=p)
    r = cli_run("view", BVH, "--segments", p, "--export", tmp_path / "v.gif", "--frames", "0:2")
    assert_one_line_error(r, str(p), field)


def test_segments_json_well_formed_still_reads(tmp_path):
    p = tmp_path / "seg.json"
    p.write_text(_segments())
    scene = build_scene([BVH], segments=p)
    assert [c["frame"] for c in scene["segments"]["cuts"]] == [30]


@pytest.mark.parametrize("coeff, field", [
    (str(10 ** 400), "signals[0].pieces[0].coeffs[0]"),
    (str(10 ** 30), "signals[0].pieces[0].coeffs[0]"),
    ("1e400", "signals[0].pieces[0].coeffs[0]"),
])
def test_filter_json_huge_numbers(tmp_path, coeff, field):
    p = tmp_path / "filt.json"
    p.write_text('{"signals": [{"name": "base_1", "components": ["base_1_x"], '
                 '"pieces": [{"t0": 0.0, "t1": 0.1, "coeffs": [' + coeff + ']}]}]}')
    with pytest.raises(MocapFormatError, match=r"signals\[0\]"):
        build_scene([TSV], filter_json=p)
    r = cli_run("view", TSV, "--filter", p, "--export", tmp_path / "v.gif", "--frames", "0:2")
    assert_one_line_error(r, str(p), field)
