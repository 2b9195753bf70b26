"""Shared fixtures (paths to the project's test data and to the real data in ../shared/data), the
hypothesis profiles, the markers given by what a test needs, and the check for leftover files."""

from __future__ import annotations

import contextlib
from pathlib import Path

import pytest

TESTS_DIR = Path(__file__).resolve().parent

# --------------------------------------------------------------------------------------------------
# hypothesis profiles, chosen by HYPOTHESIS_PROFILE (default "ci"): "ci" keeps every test's own example
# count (``@settings(max_examples=...)``, else hypothesis' 100) with no deadline (a loaded CI machine
# must not fail a test by its speed); "dev" (make check) runs at most DEV_MAX_EXAMPLES examples of
# any property test, its own count included, for a quick edit loop.
# --------------------------------------------------------------------------------------------------

DEV_MAX_EXAMPLES = 10

try:
    from hypothesis import settings as _hsettings
except ImportError:  # pragma: no cover - hypothesis is in the test extra
    _hsettings = None
else:
    _hsettings.register_profile("ci", deadline=None, print_blob=True)
    _hsettings.register_profile("dev", max_examples=DEV_MAX_EXAMPLES, deadline=None)


def _hypothesis_profile() -> str:
    import os

    return os.environ.get("HYPOTHESIS_PROFILE", "ci")


if _hsettings is not None:
    _hsettings.load_profile(_hypothesis_profile())


def _cap_examples(item) -> None:
    """In the dev profile, a property test's own ``max_examples`` is capped at DEV_MAX_EXAMPLES."""
    fn = getattr(item, "obj", None)
    own = getattr(fn, "_hypothesis_internal_use_settings", None)
    if own is not None and own.max_examples > DEV_MAX_EXAMPLES:
        fn._hypothesis_internal_use_settings = _hsettings(own, max_examples=DEV_MAX_EXAMPLES)


# --------------------------------------------------------------------------------------------------
# markers by what a test needs (registered in pyproject.toml; ``make check`` leaves these out):
# a fixture or module listed here marks every test that uses it. Files mark the rest themselves.
# --------------------------------------------------------------------------------------------------

#: fixture name -> marker
FIXTURE_MARKS = {"shared_data": "shared"}
#: files whose tests run the command line or a whole pipeline on many inputs (the trial, robustness,
#: CLI, batch and viewer-output files): marked "integration"; fnmatch patterns of the file stem
INTEGRATION_FILES = ("test_trial_*", "test_robust_*", "test_cli", "test_cli_behaviour", "test_batch*",
                     "test_view_export", "test_view_server", "test_segment_cli")
#: test module (file stem) -> markers of all its tests (the needs no fixture shows)
MODULE_MARKS = {
    "test_view_browser": ("browser", "slow"),
    "test_batch_dask": ("dask", "slow"),
    "test_mcu": ("mcu", "slow"),
    "test_gltf_short": ("node",),
    "test_catalog": ("pg",),
    "test_batch_options": ("pg",),
}


def _slow_tests() -> set[str]:
    """``file::function`` lines of tests/slow_tests.txt (tests measured at a second or more)."""
    path = TESTS_DIR / "slow_tests.txt"
    lines = path.read_text().splitlines() if path.is_file() else []
    return {ln.strip() for ln in lines if ln.strip() and not ln.startswith("#")}


def pytest_collection_modifyitems(config, items):
    import fnmatch

    dev = _hsettings is not None and _hypothesis_profile() == "dev"
    slow = _slow_tests()
    for item in items:
        stem = Path(str(item.fspath)).stem
        if f"{stem}.py::{getattr(item, 'originalname', item.name)}" in slow:
            item.add_marker("slow")
        if "clasp" in item.name.lower():  # claspy compiles its numba kernels on first use (~50 s)
            item.add_marker("slow")
        if any(fnmatch.fnmatch(stem, pat) for pat in INTEGRATION_FILES):
            item.add_marker("integration")
        for fx, mark in FIXTURE_MARKS.items():
            if fx in getattr(item, "fixturenames", ()):
                item.add_marker(mark)
        callspec = getattr(item, "callspec", None)
        if callspec is not None and "postgresql" in map(str, callspec.params.values()):
            item.add_marker("pg")
        for mark in MODULE_MARKS.get(stem, ()):
            item.add_marker(mark)
        if dev:
            _cap_examples(item)


# --------------------------------------------------------------------------------------------------
# No test leaves files outside its temporary folder (issue 10): the repository tree (new files; changed
# or removed files in tests/data) and the system temp folder (outside pytest's basetemp) are listed at
# the start of the session and compared at the end; leftovers fail the session with their list.
# MOCAPKIT_LEFTOVER_CHECK=0 turns the check off (e.g. while other people write into the same tree).
# --------------------------------------------------------------------------------------------------

_SKIP_DIRS = {".git", ".venv", "__pycache__", ".hypothesis", ".pytest_cache", "node_modules", "build"}


def _repo_files() -> dict[str, int]:
    import os

    root = TESTS_DIR.parent
    out = {}
    for d, dirs, files in os.walk(root):
        dirs[:] = [x for x in dirs if x not in _SKIP_DIRS and not x.endswith(".egg-info")]
        for f in files:
            if f.endswith((".pyc", ".nbi", ".nbc")):
                continue
            p = os.path.join(d, f)
            with contextlib.suppress(FileNotFoundError):
                out[p] = os.lstat(p).st_mtime_ns if p.startswith(str(TESTS_DIR / "data")) else 0
    return out


def _temp_entries() -> set[str]:
    import os
    import tempfile

    tmp = tempfile.gettempdir()
    # pymp-*: multiprocessing's own folder of a forkserver (batch tests), removed when the interpreter exits
    return {os.path.join(tmp, e) for e in os.listdir(tmp) if not e.startswith(("pytest-of-", "pymp-"))}


def pytest_sessionstart(session):
    import os

    if hasattr(session.config, "workerinput"):
        return  # an xdist worker: the controller checks the whole session
    if os.environ.get("MOCAPKIT_LEFTOVER_CHECK", "1") != "0":
        session.config._mocapkit_snapshot = (_repo_files(), _temp_entries())


def pytest_sessionfinish(session, exitstatus):
    snap = getattr(session.config, "_mocapkit_snapshot", None)
    if snap is None:
        return
    repo0, tmp0 = snap
    repo1, tmp1 = _repo_files(), _temp_entries()
    leftovers = sorted(set(repo1) - set(repo0)) + sorted(tmp1 - tmp0)
    changed = sorted(p for p in repo0 if repo0[p] and repo1.get(p) != repo0[p])
    if leftovers or changed:
        lines = [f"  left behind: {p}" for p in leftovers] + [f"  changed or removed: {p}" for p in changed]
        msg = "tests left files outside their temporary folders:\n" + "\n".join(lines[:50])
        rep = session.config.pluginmanager.get_plugin("terminalreporter")
        if rep is not None:
            rep.write_sep("=", "leftover files", red=True)
            rep.write_line(msg)
        else:
            print(msg)
        if session.exitstatus == 0:
            session.exitstatus = pytest.ExitCode.TESTS_FAILED


@pytest.fixture(scope="session")
def tests_data() -> Path:
    """``tests/data`` of this project."""
    return TESTS_DIR / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """``../shared/data`` next to the project root (read-only real recordings); skips when absent."""
    path = Path(__file__).resolve().parents[1].parent / "shared" / "data"
    if not path.is_dir():
        pytest.skip(f"../shared/data not present: {path} (real-data tests skipped)")
    return path
