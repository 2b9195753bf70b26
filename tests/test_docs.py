"""The documentation site (docs/, built by ``make docs``): the API pages cover every public name, every
relative link of the README and the pages points to a file (and heading) that exists, the pages' Python
examples run, the wearable guide's sensor program and receiver give a file within its bound, and the whole
site builds with warnings as errors (slow)."""

from __future__ import annotations

import doctest
import importlib
import io
import json
import os
import re
import shutil
import subprocess
import sys
import unicodedata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PACKAGES = ("mocapkit", "mocapkit.pla", "mocapkit.filters", "mocapkit.segment", "mocapkit.clip", "mocapkit.io",
            "mocapkit.jobs")
FENCE = re.compile(r"^\s*(```|~~~)")


def _pages() -> list[Path]:
    return [ROOT / "README.md", ROOT / "CONTRIBUTING.md",
            *sorted(p for p in DOCS.rglob("*.md") if "_build" not in p.parts)]


def _prose(text: str) -> list[tuple[int, str]]:
    """(line number, line) outside fenced code blocks, with inline code removed."""
    out, fenced = [], False
    for i, line in enumerate(text.splitlines(), 1):
        if FENCE.match(line):
            fenced = not fenced
            continue
        if not fenced:
            out.append((i, re.sub(r"`[^`]*`", "", line)))
    return out


def _slug(title: str) -> str:
    """A heading's anchor as GitHub (and MyST's myst_heading_anchors) make it, written here independently:
    markup and punctuation dropped, lower case, spaces to hyphens."""
    title = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", title).replace("`", "")
    out = []
    for ch in title.strip().lower():
        if ch in " -":
            out.append("-")
        elif ch == "_" or unicodedata.category(ch)[0] in "LN":
            out.append(ch)
    return "".join(out)


def _anchors(page: Path) -> set[str]:
    seen: dict[str, int] = {}
    out = set()
    fenced = False
    for line in page.read_text(encoding="utf-8").splitlines():
        if FENCE.match(line):
            fenced = not fenced
        elif not fenced and re.match(r"#{1,6} ", line):
            s = _slug(line.lstrip("#"))
            n = seen.get(s, 0)
            seen[s] = n + 1
            out.add(s if n == 0 else f"{s}-{n}")
    return out


# --- (a) the API pages -------------------------------------------------------------------------------

def test_every_package_has_an_api_page_that_documents_its_all():
    pages = {p.stem: p.read_text(encoding="utf-8") for p in (DOCS / "api").glob("*.rst")}
    for package in PACKAGES:
        hits = [name for name, text in pages.items() if re.search(rf"^\.\. mocapkit-api:: {re.escape(package)}$",
                                                                    text, flags=re.M)]
        assert len(hits) == 1, f"{package}: {len(hits)} API pages with `.. mocapkit-api:: {package}`"
    index = (DOCS / "index.md").read_text(encoding="utf-8")
    for stem in pages:
        assert f"api/{stem}\n" in index, f"docs/api/{stem}.rst is not in the toctree of docs/index.md"


@pytest.mark.filterwarnings("ignore::PendingDeprecationWarning", "ignore::DeprecationWarning")
def test_api_pages_document_every_name_of_all(tmp_path):
    """Sphinx builds the seven API pages alone and its Python domain then holds every name of every
    ``__all__`` as a documented object (not a name in the page's text: the object autodoc found)."""
    pytest.importorskip("sphinx")
    pytest.importorskip("myst_parser")
    from sphinx.application import Sphinx

    src = tmp_path / "src"
    shutil.copytree(DOCS / "api", src / "api")
    (src / "index.rst").write_text("API\n===\n\n.. toctree::\n\n" +
                                   "".join(f"   api/{p.stem}\n" for p in sorted((DOCS / "api").glob("*.rst"))))
    warnings = io.StringIO()
    app = Sphinx(str(src), str(DOCS), str(tmp_path / "out"), str(tmp_path / "doctrees"), "dummy",
                 status=None, warning=warnings, freshenv=True)
    app.build()
    documented = set(app.env.get_domain("py").objects)
    missing = [f"{package}.{name}" for package in PACKAGES for name in importlib.import_module(package).__all__
               if f"{package}.{name}" not in documented]
    assert not missing, f"not in the API pages: {missing}"
    assert warnings.getvalue() == "", warnings.getvalue()


# --- (b) links -----------------------------------------------------------------------------------------

def test_relative_links_point_to_existing_files_and_headings():
    bad = []
    for page in _pages():
        if not page.exists():
            bad.append(f"{page.relative_to(ROOT)}: missing")
            continue
        for lineno, line in _prose(page.read_text(encoding="utf-8")):
            for target in re.findall(r"\]\(([^)\s]+)\)", line):
                if re.match(r"[a-z]+:", target):
                    continue
                path, _, anchor = target.partition("#")
                dest = (page.parent / path).resolve() if path else page
                where = f"{page.relative_to(ROOT)}:{lineno}: {target}"
                if not dest.exists():
                    bad.append(f"{where}: no such file")
                elif anchor and dest.suffix == ".md" and anchor not in _anchors(dest):
                    bad.append(f"{where}: no heading with that anchor")
    assert not bad, "\n".join(bad)


def test_readme_stays_short_and_links_the_guides():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 250
    for page in ("guide-wearable.md", "guide-animation.md", "guide-research.md", "cli.md", "benchmarks.md"):
        assert f"(docs/{page})" in text, page
    figures = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text)
    assert len(figures) == 1 and (ROOT / figures[0]).is_file()


# --- examples of the pages ----------------------------------------------------------------------------

@pytest.mark.parametrize("page", ["python.md", "guide-animation.md", "skeletons.md"])
def test_python_examples_of_the_pages_run(page):
    """The ```python blocks written as doctests run as written, from the repository root."""
    text = (DOCS / page).read_text(encoding="utf-8")
    blocks = [b for b in re.findall(r"```python\n(.*?)```", text, flags=re.S) if b.lstrip().startswith(">>>")]
    assert blocks, f"docs/{page} has no doctest block"
    test = doctest.DocTestParser().get_doctest("\n".join(blocks), {}, page, str(DOCS / page), 0)
    runner = doctest.DocTestRunner(optionflags=doctest.NORMALIZE_WHITESPACE)
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        runner.run(test)
    finally:
        os.chdir(cwd)
    res = runner.summarize(verbose=False)
    assert res.attempted >= 3 and res.failed == 0, f"{res.failed} of {res.attempted} examples of docs/{page} failed"


@pytest.mark.skipif(shutil.which("gcc") is None, reason="no gcc to compile the wearable guide's sensor program")
def test_wearable_guide_sensor_to_file_within_the_bound(tmp_path):
    """The guide's C program (the sensor) and Python receiver, as written: the .mkp they make decodes within
    the guide's 2° by ``mocapkit verify`` (its own SLERP and angle, a second implementation)."""
    text = (DOCS / "guide-wearable.md").read_text(encoding="utf-8")
    (tmp_path / "sensor.c").write_text(re.search(r"```c\n(.*?)```", text, flags=re.S).group(1))
    receiver = [b for b in re.findall(r"```python\n(.*?)```", text, flags=re.S) if "mkp_bytes" in b]
    assert len(receiver) == 1
    (tmp_path / "receiver.py").write_text(receiver[0])
    src = ROOT / "c" / "mkpla"
    subprocess.run(["gcc", "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-O2", "-DMKPLA_FLOAT32",
                    f"-I{src}", "sensor.c", str(src / "mkp.c"), str(src / "mkpla.c"), "-lm", "-o", "sensor"],
                   cwd=tmp_path, check=True)
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "data").symlink_to(ROOT / "tests" / "data")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    subprocess.run([sys.executable, "receiver.py"], cwd=tmp_path, env=env, check=True, capture_output=True)
    res = subprocess.run([sys.executable, "-m", "mocapkit.cli", "verify", "tests/data/xio", "body.mkp",
                          "--max-angle", "2", "--json"], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    rec = json.loads(res.stdout)
    assert rec["format"] == "mkp" and rec["within_bound"] and rec["max_error"] <= 2.0
    assert rec["compared_samples"] == 600 and rec["samples_not_decoded"] == 0


# --- (c) the whole site ------------------------------------------------------------------------------

@pytest.mark.slow
def test_site_builds_without_a_warning(tmp_path):
    """``make docs``'s command into tmp_path: exit 0 with -W; the command page holds every command."""
    pytest.importorskip("sphinx")
    pytest.importorskip("furo")
    pytest.importorskip("myst_parser")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    res = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", str(DOCS),
                          str(tmp_path / "html")], capture_output=True, text=True, env=env, cwd=ROOT)
    assert res.returncode == 0, res.stdout + res.stderr
    assert res.stderr.strip() == "", res.stderr
    html = (tmp_path / "html" / "cli.html").read_text(encoding="utf-8")
    sys.path.insert(0, str(DOCS / "_ext"))
    try:
        from mocapkit_cli import command_records
    finally:
        sys.path.remove(str(DOCS / "_ext"))
    paths = [path for path, _, _ in command_records()]
    assert {"mocapkit compress", "mocapkit segment", "mocapkit batch verify", "mocapkit catalog query"} <= set(paths)
    for path in paths:
        assert f'id="cli-{path.replace(" ", "-")}"' in html, path
    for page in ("index", "guide-wearable", "guide-animation", "guide-research", "benchmarks", "mkc", "mkp",
                 "records", "api/jobs"):
        assert (tmp_path / "html" / f"{page}.html").is_file(), page


def test_readme_quick_start_commands_run(tmp_path):
    """The README's quick start as written (but ``view``, which serves until stopped), in a scratch folder
    that sees ``tests/data``: every command exits 0."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = re.search(r"## Quick start\n.*?```\n(.*?)```", text, flags=re.S).group(1)
    commands = [line.split("  #")[0].split() for line in block.splitlines() if line.startswith("mocapkit ")]
    assert len(commands) >= 5 and commands[-1][1] == "view"
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "data").symlink_to(ROOT / "tests" / "data")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    for argv in commands[:-1]:
        res = subprocess.run([sys.executable, "-m", "mocapkit.cli", *argv[1:]], cwd=tmp_path, env=env,
                             capture_output=True, text=True)
        assert res.returncode == 0, f"{' '.join(argv)}: {res.stderr}"
    assert (tmp_path / "walk.mkc").is_file() and (tmp_path / "points" / "pelvis.csv").is_file()


def _guide_commands(page: str) -> list[str]:
    """The ``mocapkit`` command lines of a guide's unlabelled code blocks, continuations joined, comments cut."""
    text = (DOCS / page).read_text(encoding="utf-8")
    out = []
    for block in re.findall(r"```\n(.*?)```", text, flags=re.S):
        for line in block.replace("\\\n", " ").splitlines():
            line = re.split(r"\s{2,}#", line)[0].strip()
            if line.startswith("mocapkit "):
                out.append(" ".join(line.split()))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("page", ["guide-wearable.md", "guide-animation.md", "guide-research.md"])
def test_guide_commands_run(tmp_path, page):
    """Every command of a guide, in order, in a scratch folder that sees ``tests/data``, exits 0 — but the
    ones that serve until stopped (``view`` without ``--export``), the hour-long experiments
    (``segment-bench``, ``filter-eval``) and those on ``../shared/data`` when it is absent."""
    commands = _guide_commands(page)
    assert len(commands) >= 5
    work = tmp_path / "work"                     # its ../shared/data is the repository's, when there is one
    (work / "tests").mkdir(parents=True)
    (work / "tests" / "data").symlink_to(ROOT / "tests" / "data")
    shared = ROOT.parent / "shared" / "data"
    if shared.is_dir():
        (tmp_path / "shared").mkdir()
        (tmp_path / "shared" / "data").symlink_to(shared)
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    (bin_dir / "mocapkit").write_text(f'#!/bin/sh\nexec "{sys.executable}" -m mocapkit.cli "$@"\n')
    (bin_dir / "mocapkit").chmod(0o755)
    env = {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ['PATH']}",
           "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    ran = 0
    for cmd in commands:
        words = cmd.split()
        if (words[1] == "view" and "--export" not in words) or words[1] in ("segment-bench", "filter-eval") \
                or ("../shared/data" in cmd and not shared.is_dir()):
            continue
        res = subprocess.run(["bash", "-c", cmd], cwd=work, env=env, capture_output=True, text=True,
                             timeout=600)
        assert res.returncode == 0, f"{page}: {cmd}: {res.stderr[-2000:]}"
        ran += 1
    assert ran >= 5
