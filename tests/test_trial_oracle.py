"""The trial's own machinery: the oracle's classification, the mutators and the case generators do what
their documentation says (so a clean campaign means something)."""

from __future__ import annotations

import json
import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from trial import generators, mutators, oracle
from trial.runner import Run


def _run(rc=0, err="", out="", argv=("info", "/x/file.bvh"), signal=None, timed_out=False) -> Run:
    return Run(list(argv), rc, signal, out.encode(), err.encode(), 0.1, 10.0, timed_out)


@pytest.mark.parametrize("run, expected", [
    (_run(0, out="{}", argv=("info", "/x/file.bvh", "--json")), "ok"),
    (_run(2, "error: /x/file.bvh:3: OFFSET 1: 'nan' is not a number\n"), "error"),
    (_run(2, "warning: something\nerror: /x/file.bvh: bad\n"), "error"),
    (_run(2, "error: --unit-cm must be > 0, got 0\n"), "error"),
    (_run(2, "error: threshold must be >= 0\n"), "error_unnamed"),
    (_run(2, "error: a\nerror: b\n"), "bad_error"),
    (_run(2, "Usage: mocapkit info [OPTIONS]\n╭─ Error ─╮\n│ No such option │\n╰──╯\n"), "bad_error"),
    (_run(1, "Traceback (most recent call last):\n  File \"x\"\nZeroDivisionError: float division by zero\n"), "crash"),
    (_run(2, "Traceback (most recent call last):\nValueError: x\nerror: y\n"), "crash"),
    (_run(None, signal=11), "crash"),
    (_run(3, "error: odd exit\n"), "crash"),
    (_run(None, timed_out=True), "hang"),
    (_run(1, "Traceback (most recent call last):\nMemoryError\n"), "memory"),
])
def test_classify_run(run, expected):
    assert oracle.classify_run(run, ["file.bvh"])[0] == expected


def test_option_named_in_words_counts_as_named():
    r = _run(2, "error: time unit must be one of s, ms; got 'x'\n")
    assert oracle.classify_run(r, ["--time-unit"])[0] == "error"
    assert oracle.classify_run(r, ["--rate"])[0] == "error_unnamed"


def test_strict_json_refuses_nan_and_infinity():
    assert oracle.strict_json('{"a": 1.5}') == {"a": 1.5}
    for bad in ('{"a": NaN}', '{"a": Infinity}', '[-Infinity]'):
        with pytest.raises(ValueError):
            oracle.strict_json(bad)


def test_check_stdout_finds_nan_in_tables_and_json_and_stream_rows():
    assert oracle.check_stdout(_run(0, out='{"x": NaN}', argv=("info", "f", "--json")))
    assert oracle.check_stdout(_run(0, out="│ max │ nan │", argv=("compress", "f")))
    assert oracle.check_stdout(_run(0, out="│ nanometre │ 1.0 │", argv=("compress", "f"))) is None
    assert oracle.check_stdout(_run(0, out="time,w,x,y,z\n0,1,0,0,0\n1,inf,0,0,0\n", argv=("stream",)))
    assert oracle.check_stdout(_run(0, out="0,0,0,0,0\n", argv=("stream",)))
    assert oracle.check_stdout(_run(0, out="time,w,x,y,z\n0,1,0,0,0\n", argv=("stream",))) is None


def test_worst_outcome_order():
    assert oracle.worst("ok", "crash", "error") == "crash"
    assert oracle.worst("silent_wrong", "input_modified") == "input_modified"
    assert oracle.FAILING.isdisjoint({"ok", "error", "bad_error", "error_unnamed"})


TEXT = b"HEADER 3\nFrames: 2\n1.5 -0.124044 7\n2.5 3.25 8\n"


@given(seed=st.integers(0, 10**6), token=st.sampled_from(mutators.INVALID_TOKENS + mutators.EXTREME_TOKENS))
@settings(max_examples=200, deadline=None)
def test_replace_token_changes_exactly_one_number(seed, token):
    m = mutators.replace_token(TEXT, random.Random(seed), "bvh", token)
    old = m.detail["old"].encode()
    starts = [k for k in range(len(TEXT)) if TEXT.startswith(old, k)]
    assert any(TEXT[:k] + token.encode() + TEXT[k + len(old):] == m.data for k in starts)
    assert m.expect == ("refuse" if token in mutators.INVALID_TOKENS else "any")


def test_empty_token_is_a_gap_where_the_format_has_empty_cells():
    rng = random.Random(0)
    assert mutators.replace_token(TEXT, rng, "trc", "").expect == "any"
    assert mutators.replace_token(TEXT, rng, "bvh", "").expect == "refuse"
    assert mutators.replace_token(TEXT, rng, "qtm", "nan").expect == "any"


@given(at=st.integers(1, len(TEXT) - 1))
def test_truncate_reference_is_the_cut_line_made_whole(at):
    m = mutators.truncate(TEXT, random.Random(0), "bvh", at)
    assert m.data == TEXT[:at]
    complete = m.detail["complete"]
    assert complete.startswith(m.data) and (complete == TEXT or complete.endswith(b"\n"))
    assert complete.count(b"\n") == m.data.count(b"\n") + (0 if complete == TEXT and not TEXT.endswith(b"\n") else 1)
    assert m.expect == ("any" if TEXT[at - 1:at] == b"\n" else "truncated")


def test_truncate_in_last_number_cuts_inside_it():
    start = TEXT.rindex(b"3.25")  # the last number of 3 characters or more
    for seed in range(50):
        m = mutators.truncate_in_last_number(TEXT, random.Random(seed), "bvh")
        assert TEXT.startswith(m.data) and start + 1 <= len(m.data) <= start + 3
        assert m.expect == "truncated"
    m = mutators.truncate_in_last_number(b"1 -0.124044", random.Random(1), "bvh")
    assert b"1 -0.124044".startswith(m.data) and 3 <= len(m.data) < 11


def test_inflate_header_sets_an_absurd_count():
    m = mutators.inflate_header(b"NO_OF_FRAMES\t10\nNO_OF_MARKERS\t2\n", random.Random(3), "qtm")
    assert b"1000000000" in m.data


def test_generated_chain_bvh_has_the_joints_and_balanced_braces():
    text = generators.bvh_chain(50)
    assert text.count("JOINT ") == 49 and text.count("{") == text.count("}")
    rows = text.split("Frame Time:")[1].strip().splitlines()[1:]
    assert len(rows) == 4 and all(len(r.split()) == 6 + 3 * 49 for r in rows)
    wide = generators.bvh_chain(20, wide=True)
    assert wide.count("JOINT ") == 19 and wide.count("{") == wide.count("}")


def test_generated_asf_chain_names_every_bone_in_the_hierarchy():
    text = generators.asf_chain(30)
    assert text.count("begin") == 31 and "b29 b30" in text and "root b1" in text
    amc = generators.amc_for_chain(30, n_frames=2)
    assert amc.count("b30 ") == 2


def test_qtm_claim_states_the_marker_count():
    text = generators.qtm_claim(123)
    assert "NO_OF_MARKERS\t123" in text and json.dumps(text)


@pytest.mark.parametrize("argv", [
    ["info", "BVH", "--json"],
    ["compress", "IMU", "-t", "abc"],
    ["info", "BVH", "--rate", "-1"],
])
def test_fork_mode_runs_like_the_console_script(tests_data, argv):
    """The trial forks a warm process instead of starting ``.venv/bin/mocapkit``: same exit, same output."""
    import shutil as _shutil

    from trial import runner, server

    if not runner.MOCAPKIT.exists() or _shutil.which("true") is None:
        pytest.skip("no console script in .venv")
    argv = [str(tests_data / "bvh" / "walk-meredith-60.bvh") if a == "BVH" else
            str(tests_data / "xio" / "pelvis" / "Quaternion.csv") if a == "IMU" else a for a in argv]
    real = runner.run_cli(argv, mode="subprocess", timeout=120)
    forked = server.shared_client().run(argv, timeout=120)
    assert (real.returncode, real.stdout) == (forked.returncode, forked.stdout)
    assert real.err_text.strip().splitlines()[-1:] == forked.err_text.strip().splitlines()[-1:]
