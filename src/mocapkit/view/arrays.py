"""Numeric arrays inside the scene's JSON: ``{"dtype", "shape", "b64"}`` = the little-endian bytes of a
C-ordered array, base64-encoded (what ``static/viewer.js`` turns into a typed array without parsing numbers)."""

from __future__ import annotations

import base64

import numpy as np

from mocapkit.errors import MocapFormatError

DTYPES = {"float32": "<f4", "float64": "<f8"}


def encode_array(a, dtype: str = "float32") -> dict:
    """``a`` as the scene's array object (``dtype`` ``"float32"`` or ``"float64"``; NaN kept)."""
    arr = np.ascontiguousarray(np.asarray(a, dtype=DTYPES[dtype]))
    return {"dtype": dtype, "shape": list(arr.shape), "b64": base64.b64encode(arr.tobytes()).decode("ascii")}


def decode_array(obj: dict, where: str = "scene") -> np.ndarray:
    """The array an :func:`encode_array` object holds (float64 or float32, its shape)."""
    try:
        dt = np.dtype(DTYPES[obj["dtype"]])
        shape = tuple(int(s) for s in obj["shape"])
        raw = base64.b64decode(obj["b64"], validate=True)
    except (KeyError, TypeError, ValueError) as e:
        raise MocapFormatError(where, None, f"not an array object ({e})") from None
    if len(raw) != dt.itemsize * int(np.prod(shape, dtype=np.int64)):
        raise MocapFormatError(where, None, f"{len(raw)} bytes do not hold a {obj['dtype']} array of shape {shape}")
    return np.frombuffer(raw, dtype=dt).reshape(shape)
