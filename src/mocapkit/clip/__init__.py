"""The ``.mkc`` clip: whole-skeleton compression within a guaranteed position error (joint or ACL's
shell metric), keyframes on quantisation grids, entropy-coded blocks with random access.

:func:`encode_clip` makes the bytes, :class:`Clip` decodes them (whole motion or one pose),
:func:`position_errors` measures both metrics. Nothing here opens a file: ``mocapkit.jobs.readers.read_mkc``
reads a ``.mkc`` file (:mod:`mocapkit.io.formats.mkc`) and decodes it.
"""

import importlib as _importlib

TYPE_CHECKING = False
if TYPE_CHECKING:  # what __getattr__ loads on first use, for type checkers and tests/import_graph.py
    from mocapkit.clip.decoder import Clip
    from mocapkit.clip.encoder import DEFAULT_BLOCK_FRAMES, EncodedClip, encode_clip
    from mocapkit.clip.metric import DEFAULT_SHELL_CM, METRICS, position_errors

#: module -> the names it gives the package on first use
_LAZY = {
    "mocapkit.clip.decoder": ("Clip",),
    "mocapkit.clip.encoder": ("DEFAULT_BLOCK_FRAMES", "EncodedClip", "encode_clip"),
    "mocapkit.clip.metric": ("DEFAULT_SHELL_CM", "METRICS", "position_errors"),
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


__all__ = ["DEFAULT_BLOCK_FRAMES", "DEFAULT_SHELL_CM", "METRICS", "Clip", "EncodedClip", "encode_clip",
           "position_errors"]
