"""The local viewer: the scene every file is read into (``scene``), the 127.0.0.1 server (``server``) and
the matplotlib export (``export``). Schema and routes: docs/viewer.md."""

from mocapkit.view.arrays import decode_array, encode_array
from mocapkit.view.scene import build_scene
from mocapkit.view.server import ViewServer

__all__ = ["ViewServer", "build_scene", "decode_array", "encode_array"]
