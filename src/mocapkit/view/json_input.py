"""The JSON files the viewer draws on top of a recording (``segment --json``, ``filter --json``), read
strictly: RFC 8259 numbers only (no ``NaN``/``Infinity``), every number a finite double, every integer
within ±2^53 (exact in a double). A number outside is an error naming the file and the field."""

from __future__ import annotations

import json
import math
from pathlib import Path

from mocapkit.errors import MocapFormatError

__all__ = ["MAX_JSON_INT", "read_json"]

#: Largest integer magnitude accepted: beyond, a double no longer holds every integer.
MAX_JSON_INT = 2 ** 53


def _reject_constant(name: str):
    raise ValueError(f"{name} is not a JSON number")


def _bad_number(doc, where: str = "") -> tuple[str, str] | None:
    """``(field, problem)`` of the first number out of range in ``doc``, else ``None``."""
    stack = [(where, doc)]
    while stack:
        at, v = stack.pop()
        if isinstance(v, bool) or v is None or isinstance(v, str):
            continue
        if isinstance(v, int):
            if abs(v) > MAX_JSON_INT:
                return at or "(top)", f"an integer of {len(str(abs(v)))} digits, beyond ±2^53"
        elif isinstance(v, float):
            if not math.isfinite(v):
                return at or "(top)", "a number too large for a double (beyond ±1.8e308)"
        elif isinstance(v, dict):
            stack.extend((f"{at}.{k}" if at else str(k), x) for k, x in reversed(list(v.items())))
        elif isinstance(v, list):
            stack.extend((f"{at}[{i}]", x) for i, x in reversed(list(enumerate(v))))
    return None


def read_json(path: Path, what: str):
    """The parsed JSON of ``path`` (a ``what`` such as ``"segments JSON"``), its numbers checked."""
    from mocapkit.io.text.input import decode_text, read_input

    text, _ = decode_text(read_input(path, what))
    try:
        doc = json.loads(text, parse_constant=_reject_constant)
    except json.JSONDecodeError as e:
        raise MocapFormatError(str(path), e.lineno, f"not JSON ({e.msg})") from None
    except RecursionError:
        raise MocapFormatError(str(path), None, "not JSON (nested too deeply)") from None
    except ValueError as e:  # NaN/Infinity, or an integer of more than 4300 digits
        raise MocapFormatError(str(path), None, f"not JSON ({e})") from None
    bad = _bad_number(doc)
    if bad is not None:
        raise MocapFormatError(str(path), None, f"field {bad[0]}: {bad[1]}")
    return doc
