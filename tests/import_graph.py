"""Every ``import`` of every mocapkit module (function bodies, ``if`` and ``TYPE_CHECKING`` blocks too), read
from the sources with :mod:`ast`, and the layers of docs/architecture.md they must point down."""

from __future__ import annotations

import ast
import functools
from pathlib import Path

#: the layers, top first; a module belongs to the first layer one of whose prefixes it is or starts with
LAYERS = {
    "face": ("mocapkit", "mocapkit.__main__", "mocapkit.cli"),  # also every mocapkit.cli_* module
    "jobs": ("mocapkit.jobs", "mocapkit.batch", "mocapkit.catalog", "mocapkit.verify", "mocapkit.view"),
    "evaluation": ("mocapkit.evaluation", "mocapkit.plot"),
    "algorithms": ("mocapkit.pla", "mocapkit.clip", "mocapkit.filters", "mocapkit.segment"),
    "model": ("mocapkit.motion", "mocapkit.skeleton", "mocapkit.markers", "mocapkit.quat", "mocapkit.rotvec",
              "mocapkit.errors"),
    "io": ("mocapkit.io",),
}
#: the layers a module of each layer may import (its own included): the face reaches everything, the
#: algorithms only the model, io only the model and io, the model only itself
MAY_IMPORT = {
    "face": set(LAYERS),
    "jobs": {"jobs", "evaluation", "algorithms", "model", "io"},
    "evaluation": {"evaluation", "algorithms", "model", "io"},
    "algorithms": {"algorithms", "model"},
    "model": {"model"},
    "io": {"io", "model"},
}
#: io's own order: the shared helpers at its bottom import no family, no family imports the dispatcher
IO_BASE = ("mocapkit.io.text", "mocapkit.io.atomic", "mocapkit.io.filenames")
IO_FAMILIES = ("mocapkit.io.imu", "mocapkit.io.markers", "mocapkit.io.skeletal", "mocapkit.io.formats")
IO_TOP = ("mocapkit.io", "mocapkit.io.loaders")  # the package's face and the dispatcher by file type


def within(name: str, prefix: str) -> bool:
    return name == prefix or name.startswith(prefix + ".")


def layer_of(name: str) -> str | None:
    if name.startswith("mocapkit.cli_"):
        return "face"
    for layer, prefixes in LAYERS.items():
        # the root package is only itself: mocapkit.io is not in the face layer
        if any(name == p if p == "mocapkit" else within(name, p) for p in prefixes):
            return layer
    return None


def mocapkit_imports(tree, module: str, known: set[str]) -> set[str]:
    """The ``known`` modules that a parsed source file imports anywhere (function bodies, ``if`` blocks,
    ``TYPE_CHECKING`` blocks too): ``import a.b``, ``from a import b`` (``a.b`` when it is a module,
    else ``a``), relative imports resolved against ``module``."""
    package = module.rsplit(".", 1)[0]
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                parts = parts[: len(parts) - (node.level - 1)]
                base = ".".join(parts + ([base] if base else []))
            names = [base] + [f"{base}.{a.name}" for a in node.names]
        else:
            continue
        found.update(n for n in names if n in known)
    return found


def _modules(root: Path | None) -> dict[str, Path]:
    if root is None:
        import mocapkit

        root = Path(mocapkit.__file__).parent
    files = {}
    for f in sorted(root.rglob("*.py")):
        parts = ("mocapkit",) + f.relative_to(root).with_suffix("").parts
        files[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = f
    return files


@functools.lru_cache(maxsize=4)
def _scan(root: Path | None) -> tuple[dict[str, set[str]], dict[str, set[str]], dict[str, set[str]]]:
    """One parse of every module: its imports, with the parent packages they run, and the names it
    takes from the root package."""
    files = _modules(root)
    known = set(files)
    graph, with_parents, from_root = {}, {}, {}
    for name, f in files.items():
        tree = ast.parse(f.read_text())
        mod = name if f.name != "__init__.py" else name + ".__init__"
        found = mocapkit_imports(tree, mod, known)
        graph[name] = found - {name}
        parents = set(found)
        for m in found:
            parts = m.split(".")
            parents.update(p for p in (".".join(parts[:k]) for k in range(2, len(parts))) if p in known)
        with_parents[name] = parents - {name}
        from_root[name] = {a.name for node in ast.walk(tree)
                           if isinstance(node, ast.ImportFrom) and node.module == "mocapkit" and not node.level
                           for a in node.names}
    return graph, with_parents, from_root


def import_graph(root: Path | None = None, *, parents: bool = False) -> dict[str, set[str]]:
    """``{module: modules it imports anywhere}`` over every module of the mocapkit package (``root``: the
    package folder). ``parents``: an import of ``a.b.c`` also imports the packages ``a.b`` (their
    ``__init__`` runs), the root package ``mocapkit`` excepted (it runs before any of its modules)."""
    graph, with_parents, _ = _scan(root)
    return {k: set(v) for k, v in (with_parents if parents else graph).items()}


def reachable(graph: dict[str, set[str]], start: str) -> set[str]:
    seen, todo = set(), [start]
    while todo:
        for nxt in graph.get(todo.pop(), ()):
            if nxt not in seen:
                seen.add(nxt)
                todo.append(nxt)
    return seen


#: what any module may take from the root package (it runs before any of its modules anyway): the
#: version and the compiled extensions; ``import mocapkit`` alone (for ``mocapkit.__file__``) too
FROM_ROOT = {"__version__", "_mkpla32", "_mkpla64"}


def names_from_root(root: Path | None = None) -> dict[str, set[str]]:
    """``{module: names it imports by from mocapkit import ...}`` (anywhere in the module)."""
    return {k: set(v) for k, v in _scan(root)[2].items()}


def layer_violations(graph: dict[str, set[str]], from_root: dict[str, set[str]]) -> list[str]:
    """Every import that points up or sideways out of its layer, and every module in no layer."""
    out = []
    for name, imports in sorted(graph.items()):
        layer = layer_of(name)
        if layer is None:
            out.append(f"{name}: in no layer of docs/architecture.md")
            continue
        if layer != "face" and from_root.get(name, set()) - FROM_ROOT:
            out.append(f"{name} ({layer}) imports {sorted(from_root[name] - FROM_ROOT)} from the package root")
        for m in sorted(imports - {"mocapkit"}):
            if layer_of(m) not in MAY_IMPORT[layer]:
                out.append(f"{name} ({layer}) imports {m} ({layer_of(m)})")
    return out


def io_violations(graph: dict[str, set[str]]) -> list[str]:
    """Imports against io's own order: base helpers -> no family; a family -> no other family, neither the
    dispatcher nor the package's face; every io module in one of base, families, top."""
    out = []
    for name, imports in sorted(graph.items()):
        if layer_of(name) != "io":
            continue
        is_base = any(within(name, p) for p in IO_BASE)
        is_family = any(within(name, p) for p in IO_FAMILIES)
        if not (is_base or is_family or name in IO_TOP):
            out.append(f"{name}: in no part of io (base, family or top)")
        for m in sorted(imports):
            if is_base and not any(within(m, p) for p in IO_BASE) and layer_of(m) == "io":
                out.append(f"{name} (io base) imports {m}")
            if is_family and m in IO_TOP:
                out.append(f"{name} (io family) imports {m}")
            family = next((p for p in IO_FAMILIES if within(name, p)), None)
            other = next((p for p in IO_FAMILIES if within(m, p)), None)
            if family and other and other != family:
                out.append(f"{name} ({family}) imports {m} (another io family)")
    return out


def package_of(name: str) -> str:
    """The unit the no-cycle rule is about: a top-level module or package, an io sub-package or module."""
    parts = name.split(".")
    return ".".join(parts[:3]) if len(parts) >= 3 and parts[1] == "io" else ".".join(parts[:2])


def package_cycles(graph: dict[str, set[str]]) -> list[str]:
    """Pairs of packages that import each other, directly or through others (the root package aside)."""
    pg: dict[str, set[str]] = {}
    for a, bs in graph.items():
        for b in bs - {"mocapkit"}:
            if package_of(a) != package_of(b):
                pg.setdefault(package_of(a), set()).add(package_of(b))
    return [f"{a} -> {b} -> ... -> {a}" for a in sorted(pg) for b in sorted(pg[a]) if a in reachable(pg, b)]
