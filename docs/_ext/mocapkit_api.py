"""``.. mocapkit-api:: PACKAGE`` — autodoc entries for every name in the package's ``__all__``, read at build
time, so the API pages follow ``__all__`` without being edited (classes with their documented members)."""

from __future__ import annotations

import importlib
import inspect
import sys

from docutils import nodes
from docutils.parsers.rst import Directive
from docutils.statemachine import StringList
from sphinx.util.nodes import nested_parse_with_titles

#: the packages whose ``__all__`` the API reference documents
PACKAGES = ("mocapkit", "mocapkit.pla", "mocapkit.filters", "mocapkit.segment", "mocapkit.clip", "mocapkit.io",
            "mocapkit.jobs")


def api_lines(package: str) -> list[str]:
    """The reST autodoc directives for ``package.__all__`` (getattr, so lazy ``__getattr__`` exports work)."""
    mod = importlib.import_module(package)
    lines = []
    for name in mod.__all__:
        obj = getattr(mod, name)
        if inspect.isclass(obj):
            lines += [f".. autoclass:: {package}.{name}", "   :members:", ""]
        elif callable(obj):
            lines += [f".. autofunction:: {package}.{name}", ""]
        else:
            lines += _data_lines(package, name, obj)
    return lines


def _data_lines(package: str, name: str, obj) -> list[str]:
    """A constant: its ``#:`` comment from the module that defines it (autodoc would show its type's docstring)."""
    from sphinx.pycode import ModuleAnalyzer

    lines = [f".. py:data:: {name}", f"   :module: {package}"]
    text = repr(obj)
    if len(text) <= 100 and "<" not in text:
        lines.append(f"   :value: {text}")
    lines.append("")
    for modname, mod in sorted(sys.modules.items()):
        if not modname.startswith("mocapkit") or getattr(mod, name, None) is not obj:
            continue
        try:
            doc = ModuleAnalyzer.for_module(modname).find_attr_docs().get(("", name))
        except Exception:  # a compiled or source-less module: no comment to read
            doc = None
        if doc:
            lines += ["   " + line if line else "" for line in doc] + [""]
            break
    return lines


class MocapkitApi(Directive):
    required_arguments = 1
    has_content = False

    def run(self):
        package = self.arguments[0]
        env = self.state.document.settings.env
        mod = importlib.import_module(package)
        env.note_dependency(mod.__file__)
        content = StringList(api_lines(package), source=f"<mocapkit-api {package}>")
        node = nodes.section()
        node.document = self.state.document
        nested_parse_with_titles(self.state, content, node)
        return node.children


def setup(app):
    app.add_directive("mocapkit-api", MocapkitApi)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
