"""Per-file options of a batch: a TOML manifest, a sidecar beside an input, the command's options.

A manifest (``mocapkit batch JOB ... --manifest FILE.toml``) maps globs or paths, relative to its own
folder, to reading options and bounds::

    [[files]]
    glob = "cmu/*.amc"          # or: path = "cmu/86_01.amc" (no pattern)
    rate = 120
    asf = "skeletons/86.asf"    # relative to the manifest's folder

A sidecar ``TAKE.mocapkit.toml`` beside ``TAKE.amc`` (beside the folder ``TAKE/`` of a sensor folder) holds
the same keys at its top level, paths relative to its own folder; it is found without being named and is
not an input itself (inputs of one folder with the same stem share it). Keys (:data:`KEYS`): ``rate``,
``asf``, ``unit_cm``, ``time_column``, ``quaternion_columns``, ``scalar_last``, ``time_unit``, ``strict``,
and the bounds ``max_angle`` (IMU data) and ``max_position_error`` (skeletons). A key the job does not take
is not used by it.

Precedence, key by key: the sidecar, then the manifest (the last matching entry), then the command's
option. Above all of them, what the file states itself: the frame time and skeleton of a BVH, MVNX or
``.mkc`` file, the clock of an IMU file with a time column or a stated sample rate. An option the file
makes needless is not used, and the row's record says so in a warning (never an error row, never an
override). The command's ``--unit-cm`` is used for a skeleton whose unit the file does not give (BVH); a
per-file ``unit_cm`` is used as given. Column options (``time_column``...) correct how a header is read,
whoever gives them: the command's apply to every IMU text file. An option that is not for the input's
kind (``--asf`` for IMU data) is not used; given per file, with a warning. In ``compress``, each kind takes
its own bound: IMU data ``max_angle``, skeletons ``max_position_error``, so one batch may carry both; a
per-file bound replaces the command's ``--threshold``/``--target-icr`` for that file.

Every manifest and sidecar is checked before any work: an unknown key, a wrong type, a value out of range,
an ``asf`` that is not a readable regular file, a glob that matches nothing is one
:class:`~mocapkit.errors.MocapFormatError` naming the file, its line and the key.
"""

from __future__ import annotations

import functools
import glob as globlib
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

from mocapkit.errors import MocapFormatError

SIDECAR_SUFFIX = ".mocapkit.toml"
#: a manifest or sidecar larger than this is refused (it is a list of options, not data)
MAX_BYTES = 16 * 2**20
TIME_UNITS = ("s", "ms", "us", "ns", "counter")
BOUND_KEYS = ("max_angle", "max_position_error")
CONTROL_KEYS = ("threshold", "target_icr", *BOUND_KEYS)
#: the value each option has when it is not given
DEFAULTS = {"rate": None, "asf": None, "unit_cm": None, "time_column": None, "quaternion_columns": None,
            "scalar_last": False, "time_unit": None, "strict": True, "max_angle": None, "max_position_error": None}
COLUMN_KEYS = ("time_column", "quaternion_columns", "scalar_last", "time_unit")
#: the command-line spelling of each key, for the warnings
FLAGS = {k: "--" + k.replace("_", "-") for k in DEFAULTS}


def _number(lo: float, hi: float, lo_open: bool = False, hi_open: bool = False):
    def check(v):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            return "a number"
        if not math.isfinite(v) or v < lo or v > hi or (lo_open and v == lo) or (hi_open and v == hi):
            return f"a finite number {'>' if lo_open else '>='} {lo:g} and {'<' if hi_open else '<='} {hi:g}"
        return None
    return check


def _text(v):
    return None if isinstance(v, str) and v.strip() else "a non-empty string"


def _flag(v):
    return None if isinstance(v, bool) else "true or false"


def _quaternion_columns(v):
    names = v.split(",") if isinstance(v, str) else v if isinstance(v, list) else None
    if names is None or len(names) != 4 or not all(isinstance(n, str) and n.strip() for n in names):
        return "four column names in w,x,y,z order ('W,X,Y,Z' or [\"W\", \"X\", \"Y\", \"Z\"])"
    return None


def _time_unit(v):
    return None if v in TIME_UNITS else f"one of {', '.join(TIME_UNITS)}"


#: key -> check(value) returning None or what the value must be (ranges as the command's options)
KEYS = {
    "rate": _number(1e-6, 1e6), "asf": _text, "unit_cm": _number(1e-6, 1e6), "time_column": _text,
    "quaternion_columns": _quaternion_columns, "scalar_last": _flag, "time_unit": _time_unit, "strict": _flag,
    "max_angle": _number(0.0, 180.0, lo_open=True, hi_open=True), "max_position_error": _number(1e-6, 1e9),
}


@dataclass
class Entry:
    """One table of options: ``values`` (checked, paths absolute), ``where`` each came from (``FILE:LINE``,
    for the warnings) and, for a manifest entry, the ``abspath``s and ``realpath``s its glob or path
    matches."""

    values: dict
    where: dict
    matches: set[str] = field(default_factory=set)


def _read_toml(path: Path) -> tuple[dict, str]:
    import tomllib

    src = os.fspath(path)
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_BYTES + 1)
    except OSError as e:
        raise MocapFormatError(src, None, f"cannot read the options file: {e.strerror or e}") from None
    if len(data) > MAX_BYTES:
        raise MocapFormatError(src, None, f"larger than {MAX_BYTES // 2**20} MiB: not an options file")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise MocapFormatError(src, data[:e.start].count(b"\n") + 1, "not UTF-8 text (TOML is UTF-8)") from None
    try:
        return tomllib.loads(text), text
    except tomllib.TOMLDecodeError as e:
        msg = str(e)
        m = re.search(r"\s*\(at line (\d+), column \d+\)$", msg)
        line = int(m.group(1)) if m else None
        msg = msg[:m.start()] if m else re.sub(r"\s*\(at end of document\)$", " at the end", msg)
        raise MocapFormatError(src, line, f"not valid TOML: {msg}") from None
    except RecursionError:  # tomllib parses nested arrays and inline tables recursively
        raise MocapFormatError(src, None, "not valid TOML: arrays or inline tables nested too deeply") from None


def _key_line(text: str, table: int | None, key: str) -> int | None:
    """The line of ``key = ...`` in the ``table``-th ``[[files]]`` table (None: before any table)."""
    lines = text.split("\n")
    start, stop = 0, len(lines)
    if table is not None:
        heads = [i for i, ln in enumerate(lines) if re.match(r"\s*\[\[\s*files\s*\]\]", ln)]
        if table >= len(heads):
            return None
        start = heads[table]
        stop = next((i for i in range(start + 1, len(lines)) if re.match(r"\s*\[", lines[i])), len(lines))
    pat = re.compile(r"\s*(?:" + re.escape(key) + r"|\"" + re.escape(key) + r"\")\s*=")
    for i in range(start, stop):
        if pat.match(lines[i]):
            return i + 1
    return start + 1 if table is not None else None


def _check_values(raw: dict, src: str, text: str, table: int | None, folder: Path,
                  allowed: tuple) -> tuple[dict, dict]:
    """The checked options of one table (``asf`` made absolute against ``folder``) and where each is."""
    out, where = {}, {}
    what = "" if table is None else f"files[{table + 1}]: "
    for key, v in raw.items():
        line = _key_line(text, table, key)
        if key in allowed:
            continue
        if key not in KEYS:
            known = ", ".join([*allowed, *KEYS])
            raise MocapFormatError(src, line, f"{what}unknown key {key!r} (known: {known})")
        need = KEYS[key](v)
        if need is not None:
            raise MocapFormatError(src, line, f"{what}{key} = {v!r}: must be {need}")
        if key == "quaternion_columns" and isinstance(v, list):
            v = ",".join(n.strip() for n in v)
        if key == "asf":
            p = Path(os.path.abspath(folder / v))
            if not p.is_file():
                raise MocapFormatError(src, line, f"{what}asf = {v!r}: {p} is not a regular file")
            if not os.access(p, os.R_OK):
                raise MocapFormatError(src, line, f"{what}asf = {v!r}: {p} is not readable")
            v = str(p)
        out[key] = float(v) if key in ("rate", "unit_cm", "max_angle", "max_position_error") else v
        where[key] = f"{src}:{line}" if line is not None else src
    return out, where


def _paths(p: str) -> tuple[str, str]:
    return os.path.abspath(p), os.path.realpath(p)


@dataclass
class Manifest:
    """A checked manifest: ``path`` and its ``entries`` in file order."""

    path: Path
    entries: list[Entry]

    def matching(self, path: str | os.PathLike[str]) -> list[Entry]:
        a, r = _paths(os.fspath(path))
        return [e for e in self.entries if a in e.matches or r in e.matches]


def load_manifest(path: str | os.PathLike[str]) -> Manifest:
    """Read and check a manifest (see the module docstring); raises :class:`MocapFormatError`."""
    path = Path(os.path.abspath(path))
    src = os.fspath(path)
    if not path.is_file():
        raise MocapFormatError(src, None, "no such manifest file" if not path.exists() else "not a regular file")
    data, text = _read_toml(path)
    for key in data:
        if key != "files":
            raise MocapFormatError(src, _key_line(text, None, key),
                                   f"unknown top-level key {key!r}: a manifest holds [[files]] tables")
    files = data.get("files", [])
    if not isinstance(files, list) or not all(isinstance(t, dict) for t in files):
        raise MocapFormatError(src, _key_line(text, None, "files"), "files must be [[files]] tables")
    entries = []
    for i, t in enumerate(files):
        line = _key_line(text, i, "glob") if "glob" in t else _key_line(text, i, "path")
        given = [k for k in ("glob", "path") if k in t]
        if len(given) != 1:
            raise MocapFormatError(src, line, f"files[{i + 1}]: give exactly one of glob = \"PATTERN\" or "
                                              "path = \"FILE\" (relative to the manifest's folder)")
        pattern = t[given[0]]
        if not isinstance(pattern, str) or not pattern.strip():
            raise MocapFormatError(src, _key_line(text, i, given[0]), f"files[{i + 1}]: {given[0]} must be a "
                                                                       "non-empty string")
        values, where = _check_values(t, src, text, i, path.parent, ("glob", "path"))
        full = os.path.join(path.parent, pattern)
        found = globlib.glob(full, recursive=True) if given[0] == "glob" else \
            ([full] if os.path.lexists(full) else [])
        if not found:
            raise MocapFormatError(src, _key_line(text, i, given[0]),
                                   f"files[{i + 1}]: {given[0]} = {pattern!r} matches no file in {path.parent}")
        matches = {x for f in found for x in _paths(f)}
        entries.append(Entry(values, where, matches))
    return Manifest(path, entries)


def sidecar_path(path: str | os.PathLike[str]) -> Path:
    """The sidecar of an input: ``TAKE.mocapkit.toml`` beside ``TAKE.ext`` (or beside the folder ``TAKE``)."""
    p = Path(path)
    return p.with_name((p.name if p.is_dir() else p.stem) + SIDECAR_SUFFIX)


def read_sidecar(path: str | os.PathLike[str]) -> Entry:
    """Read and check one sidecar file (see the module docstring)."""
    path = Path(os.path.abspath(path))
    src = os.fspath(path)
    data, text = _read_toml(path)
    for key, v in data.items():
        if isinstance(v, dict) or (isinstance(v, list) and v and isinstance(v[0], dict)):
            raise MocapFormatError(src, _key_line(text, None, key) or _line_of_table(text, key),
                                   f"[{key}]: a sidecar holds keys only (rate = 120, asf = \"86.asf\"...), no tables")
    return Entry(*_check_values(data, src, text, None, path.parent, ()))


def _line_of_table(text: str, name: str) -> int | None:
    for i, ln in enumerate(text.split("\n")):
        if re.match(r"\s*\[+\s*" + re.escape(name) + r"\s*\]", ln):
            return i + 1
    return None


# --------------------------------------------------------------------------------------------------
# resolving one input's options
# --------------------------------------------------------------------------------------------------

@dataclass
class FileOptions:
    """One input's options (``options``, passed to the job), the ``notes`` its record gets as warnings
    (options the file made needless, or given for another kind) and the option ``files`` it read
    (sidecar, ASF: inputs that no output may overwrite)."""

    options: dict
    notes: list[str] = field(default_factory=list)
    files: list[str] = field(default_factory=list)


@functools.cache
def _job_keys(job: str) -> frozenset[str]:
    import inspect

    from mocapkit.jobs import JOBS

    return frozenset(inspect.signature(JOBS[job]).parameters)


def _states(key: str, path: Path, kind: str, options: dict) -> str | None:
    """What in the file makes option ``key`` needless ("its Frame Time"...), or None when it needs it."""
    suffix = path.suffix.lower()
    own = {".bvh": ("its Frame Time", "its own skeleton (HIERARCHY)", None),
           ".mvnx": ("its frameRate", "its own skeleton", "its unit (metres)"),
           ".mkc": ("its frame times", "its own skeleton", "its header's unit"),
           ".amc": (None, None, "its skeleton's unit (the ASF's :units length)")}
    if kind == "skeletal":
        i = {"rate": 0, "asf": 1, "unit_cm": 2}.get(key)
        return None if i is None or suffix not in own else own[suffix][i]
    if kind == "imu" and key == "rate":
        if not path.is_dir() and suffix not in (".csv", ".txt"):
            return "its time column"
        from mocapkit.io.imu.columns import ColumnOptions
        from mocapkit.io.imu.signals import stated_clock

        try:
            cols = ColumnOptions(**{k: options[k] for k in COLUMN_KEYS if options.get(k)})
        except Exception:  # noqa: BLE001 - a bad column option: the job reports it
            return None
        return stated_clock(path, cols)
    return None


def _for_kind(key: str, path: Path, kind: str) -> bool:
    """Whether option ``key`` is one for an input of this kind."""
    if key in ("asf", "unit_cm", "max_position_error"):
        return kind == "skeletal"
    if key == "rate":
        return kind in ("skeletal", "imu")
    if key in COLUMN_KEYS:
        return kind == "imu" and (path.is_dir() or path.suffix.lower() in (".csv", ".txt"))
    if key == "max_angle":
        return kind == "imu"
    return True


#: the kinds of input each option is for (a per-file option given to another kind is reported)
_KIND_FOR = {"rate": "skeletons and IMU data", "asf": "AMC takes", "unit_cm": "skeletons",
             "time_column": "IMU text files", "quaternion_columns": "IMU text files", "scalar_last": "IMU text files",
             "time_unit": "IMU text files", "max_angle": "IMU data", "max_position_error": "skeletons"}
_KIND_WORD = {"imu": "IMU data", "skeletal": "a skeleton", "markers": "a marker file", "table": "an OpenSim table"}


def _shown(key: str, v, where: str | None) -> str:
    """An option as the user wrote it: ``--rate 128`` (the command's), ``rate = 120 (FILE:LINE)``."""
    if where is None:
        return f"{FLAGS[key]} {v:g}" if isinstance(v, float) else f"{FLAGS[key]} {v}"
    shown = f"{v:g}" if isinstance(v, float) else "true" if v is True else "false" if v is False else \
        '"' + str(v) + '"'
    return f"{key} = {shown} ({where})"


def resolve(job: str, path: str | os.PathLike[str], options: dict, manifest: Manifest | None = None,
            sidecars: dict | None = None) -> FileOptions:
    """The options ``job`` runs with on ``path``: the command's ``options`` with the manifest's and the
    sidecar's values laid over them and what the file states itself taken out (module docstring).
    ``sidecars`` caches read sidecars by path. Raises :class:`MocapFormatError` for a bad sidecar."""
    from mocapkit.io.loaders import kind_of

    path = Path(path)
    takes = _job_keys(job)
    given: dict[str, tuple[object, str]] = {}
    files: list[str] = []
    for entry in manifest.matching(path) if manifest is not None else ():
        given.update({k: (v, entry.where[k]) for k, v in entry.values.items()})
    side = sidecar_path(path)
    if side.is_file():
        cache = sidecars if sidecars is not None else {}
        key = os.fspath(side)
        if key not in cache:
            cache[key] = read_sidecar(side)
        given.update({k: (v, cache[key].where[k]) for k, v in cache[key].values.items()})
        files.append(key)
    try:
        kind = kind_of(path)
    except Exception:  # noqa: BLE001 - unreadable or unknown: the job reports it
        kind = "unknown"
    out, notes = dict(options), []
    source: dict[str, str | None] = {k: None for k in options}  # None: the command's option
    for k in DEFAULTS:
        if k in out and out[k] != DEFAULTS[k] and not _for_kind(k, path, kind) \
                and not (k in BOUND_KEYS and job == "compress"):
            out[k] = DEFAULTS[k]  # the command's option for another kind of input
    for k, (v, where) in given.items():
        if k not in takes:
            continue
        if not _for_kind(k, path, kind):
            notes.append(f"{_shown(k, v, where)} not used: it is for {_KIND_FOR[k]}; this is "
                         f"{_KIND_WORD.get(kind, 'another kind of input')}")
            continue
        out[k], source[k] = v, where
        if k in BOUND_KEYS:
            for c in CONTROL_KEYS:
                if c != k and out.get(c) is not None:
                    out[c] = None  # this file's bound replaces the command's control
    if job == "compress":  # each kind its own bound (the other is left only to be reported as skipped)
        mine = "max_angle" if kind == "imu" else "max_position_error" if kind == "skeletal" else None
        if mine is not None and out.get(mine) is not None:
            for c in BOUND_KEYS:
                if c != mine:
                    out[c] = None
    for k in ("rate", "asf", "unit_cm"):
        v = out.get(k)
        if v is None or (k == "unit_cm" and source.get(k) is not None):
            continue
        said = _states(k, path, kind, out)
        if said is not None:
            notes.append(f"{_shown(k, v, source.get(k))} not used: the file gives {said}")
            out[k] = None
    if out.get("asf") is not None:
        files.append(os.fspath(out["asf"]))
    elif kind == "skeletal" and path.suffix.lower() == ".amc" and "asf" in takes:
        from mocapkit.io.skeletal.amc import companion_asf

        found = companion_asf(path)
        if found is not None:
            files.append(os.fspath(found))
    return FileOptions(out, notes, files)
