"""The local viewer: the scene every file is read into (``scene``), the 127.0.0.1 server (``server``) and
the matplotlib export (``export``). Schema and routes: docs/viewer.md."""

import importlib as _importlib

TYPE_CHECKING = False
if TYPE_CHECKING:  # what __getattr__ loads on first use, for type checkers and tests/import_graph.py
    from mocapkit.view.arrays import decode_array, encode_array
    from mocapkit.view.scene import build_scene
    from mocapkit.view.server import ViewServer

#: module -> the names it gives the package on first use
_LAZY = {
    "mocapkit.view.arrays": ("decode_array", "encode_array"),
    "mocapkit.view.scene": ("build_scene",),
    "mocapkit.view.server": ("ViewServer",),
}
_WHERE = {name: module for module, names in _LAZY.items() for name in names}


def __getattr__(name: str):
    """A name of ``__all__``, imported from its module on first use (PEP 562) and then kept."""
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(_importlib.import_module(_WHERE[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


__all__ = ["ViewServer", "build_scene", "decode_array", "encode_array"]
