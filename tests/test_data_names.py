"""Names read from a file's contents (sensor names) never become paths: the per-sensor CSVs of
`compress`/`decompress -o FOLDER` stay directly inside FOLDER, whatever a `.sto` column or a `.mkp`
header calls a sensor."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mocapkit import cli
from mocapkit.errors import MocapFormatError
from mocapkit.io.filenames import file_names, safe_stem

DATA = Path(__file__).parent / "data"
STO = DATA / "opensim" / "myComplexTasksTrial_orientations.sto"


def _cli(args: list[str]) -> int:
    try:
        cli.main([str(a) for a in args])
    except SystemExit as e:
        return int(e.code or 0)
    return 0


def _sto_with_names(tmp_path: Path, names: list[str], rows: int = 60) -> Path:
    """The shared OpenSense excerpt with its first sensors renamed."""
    lines = STO.read_text().splitlines()
    h = next(i for i, ln in enumerate(lines) if ln.startswith("time\t"))
    cols = lines[h].split("\t")
    for i, n in enumerate(names):
        cols[1 + i] = n
    out = tmp_path / "in" / "renamed.sto"
    out.parent.mkdir()
    out.write_text("\n".join([*lines[:h], "\t".join(cols), *lines[h + 1:h + 1 + rows]]) + "\n")
    return out


def _files_under(root: Path) -> set[Path]:
    return {Path(dp) / f for dp, _, fs in os.walk(root) for f in fs}


HOSTILE = ["../victim", "../../escape", "/abs/path", "..", "a/../../b", ".hidden", "CON", "sub\\dir"]


@pytest.mark.parametrize("how", ["csv", "mkp"])
def test_sensor_names_from_the_file_stay_inside_the_output_folder(tmp_path, capsys, how):
    names = ["../victim", "/tmp/abs_victim", "a/../../b", "pelvis_imu"]
    src = _sto_with_names(tmp_path, names)
    out = tmp_path / "out" / "res"
    out.parent.mkdir()
    before = _files_under(tmp_path)
    if how == "csv":
        assert _cli(["compress", src, "--max-angle", "2", "-o", out]) == 0
    else:
        mkp = tmp_path / "out" / "x.mkp"
        assert _cli(["compress", src, "--max-angle", "2", "-o", mkp]) == 0
        before.add(mkp)
        assert _cli(["decompress", mkp, "-o", out]) == 0
    err = capsys.readouterr().err
    new = _files_under(tmp_path) - before
    assert new and all(p.parent == out for p in new), sorted(map(str, new))
    assert not Path("/tmp/abs_victim.csv").exists()
    assert len(new) == 7  # one file per sensor, none lost to a collision
    assert "'../victim' is written as _victim.csv" in err


def test_a_name_that_leaves_nothing_is_refused_before_any_output(tmp_path, capsys):
    src = _sto_with_names(tmp_path, [".."])
    out = tmp_path / "res"
    assert _cli(["compress", src, "--max-angle", "2", "-o", out]) == 2
    assert "cannot be made a file name" in capsys.readouterr().err
    assert not out.exists()


def test_a_sensor_file_that_is_a_link_to_the_input_is_refused(tmp_path, capsys):
    src = _sto_with_names(tmp_path, ["pelvis"])
    out = tmp_path / "res"
    out.mkdir()
    (out / "pelvis.csv").symlink_to(src)
    data = src.read_bytes()
    assert _cli(["compress", src, "--max-angle", "2", "-o", out]) == 2
    assert "is the input file" in capsys.readouterr().err
    assert src.read_bytes() == data


def test_json_record_lists_the_written_files(tmp_path, capsys):
    src = _sto_with_names(tmp_path, ["../x"])
    out = tmp_path / "res"
    assert _cli(["compress", src, "--max-angle", "2", "-o", out, "--json"]) == 0
    cap = capsys.readouterr()
    rec = json.loads(cap.out)
    assert {s["name"] for s in rec} >= {"../x"}
    assert (out / "_x.csv").is_file()


@settings(max_examples=300, deadline=None)
@given(st.lists(st.text(min_size=1, max_size=40), min_size=1, max_size=6, unique=True))
def test_file_names_are_plain_distinct_names_or_a_refusal(names):
    try:
        got, warnings = file_names(names, ".csv", "x.sto")
    except MocapFormatError as e:
        assert "file name" in str(e)
        return
    files = list(got.values())
    assert len({f.casefold() for f in files}) == len(files)
    for name, f in got.items():
        assert "/" not in f and "\\" not in f and "\0" not in f
        assert not f.startswith(".") and f.endswith(".csv")
        assert os.path.basename(f) == f and os.path.normpath(f) == f
        assert (f == name + ".csv") or any(repr(name) in w for w in warnings)


@pytest.mark.parametrize("name", HOSTILE)
def test_hostile_names(name):
    try:
        s = safe_stem(name, "x")
    except MocapFormatError:
        assert name.strip("./\\ ") == ""
        return
    assert s and "/" not in s and "\\" not in s and not s.startswith(".") and s.casefold() != "con"
