"""Sphinx configuration of mocapkit's documentation (``make docs``: warnings are errors).

The Markdown pages are MyST; the API pages document the objects themselves (autodoc: every name of the
packages' ``__all__``, read at build time by ``_ext/mocapkit_api.py``); the command reference is read from
the typer app (``_ext/mocapkit_cli.py``). Nothing is fetched from the network (no intersphinx).
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))
if (HERE.parent / "src" / "mocapkit").is_dir():           # the sources of this tree before an installed copy
    sys.path.insert(0, str(HERE.parent / "src"))

import mocapkit  # noqa: E402

project = "mocapkit"
author = "mocapkit authors"
copyright = "mocapkit authors"
release = mocapkit.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "myst_parser",
    "mocapkit_api",
    "mocapkit_cli",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
# data files and helpers beside the pages are not pages
exclude_patterns = ["_build", "_ext", "**/*.json", "**/*.txt", "**/*.csv", "Thumbs.db", ".DS_Store"]

myst_heading_anchors = 4                                    # [text](page.md#a-heading) as on GitHub
myst_enable_extensions = ["colon_fence"]

autodoc_member_order = "bysource"
autodoc_typehints = "signature"
autodoc_preserve_defaults = True
autodoc_default_options = {}
napoleon_google_docstring = True
napoleon_numpy_docstring = True

nitpicky = False
smartquotes = False                                       # "--json" stays two hyphens, as typed
highlight_language = "text"                                # unlabelled blocks are commands and tables
html_theme = "furo"
html_title = f"mocapkit {release}"
html_static_path: list[str] = []
