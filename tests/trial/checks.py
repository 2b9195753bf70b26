"""Assertions shared by ``tests/test_trial_*.py`` (each failure message shows the command and stderr)."""

from __future__ import annotations

from pathlib import Path

from . import oracle


def describe(run) -> str:
    return (f"mocapkit {' '.join(run.argv)}\n exit {run.returncode} signal {run.signal} timed_out {run.timed_out}"
            f" ({run.seconds:.1f} s, {run.maxrss_mb:.0f} MB)\n stderr: {run.err_text[-1500:]}\n"
            f" stdout: {run.out_text[:300]}")


def outcome(run, *names) -> str:
    names = [str(n) for n in names] + [Path(a).name for a in run.argv if "/" in a]
    return oracle.classify_run(run, names)[0]


def assert_no_failure(run, *names) -> str:
    """Not a crash, hang or memory blow-up; exit 0 with valid stdout, or one clean ``error:`` line."""
    got = outcome(run, *names)
    assert got in ("ok", "error"), f"{got}: {describe(run)}"
    if got == "ok":
        problem = oracle.check_stdout(run)
        assert problem is None, f"{problem}: {describe(run)}"
    return got


def assert_clean_error(run, *names) -> str:
    """Exit 2 with one ``error:`` line naming one of ``names`` (file names or options)."""
    got = outcome(run, *names)
    assert got == "error", f"expected one clean error line naming {names}, got {got}: {describe(run)}"
    return run.first_error_line()


def assert_ok(run) -> None:
    got = outcome(run)
    assert got == "ok", f"{got}: {describe(run)}"
    problem = oracle.check_stdout(run)
    assert problem is None, f"{problem}: {describe(run)}"


def assert_not_silent(trial, path: Path, fmt: str, reference: dict, options: dict | None = None,
                      complete: dict | None = None) -> dict:
    """The library read of a mutated file is an error, carries a warning, or equals the reference
    (the mutation hit a field the reader ignores) — never different data without a word; and a
    successful read holds only finite values (NaN only for marker gaps)."""
    rep = trial.digest(path, fmt, options)
    assert rep.get("status") in ("ok", "error"), f"{path.name}: the library failed: {rep}"
    if rep["status"] == "ok":
        assert not rep["nonfinite"], f"{path.name}: non-finite values read: {rep['nonfinite']}"
        if not rep["warnings"]:
            same = oracle.same_data(rep, reference) or (complete is not None and oracle.same_data(rep, complete))
            assert same, f"{path.name}: read as different data without a warning or an error"
    return rep
