"""The files that a sensor folder holds beside the orientation data, and what they tell the reader.

- **Legacy x-io (x-IMU GUI) files** share a prefix: ``00000_Quaternion.csv``, ``00000_EulerAngles.csv``,
  ``00000_RotationMatrix.csv``, ``00000_CalInertialAndMag.csv``, ``00000_Registers.csv``... The
  quaternion file is the orientation; the Euler and matrix files are the same orientation in other forms
  (skipped). ``<prefix>_Registers.csv`` (``Packet Number,Address,Value,Float Value,Name``) holds the
  device's settings: register 55 (``QuatOutputRate``) is the rate of the quaternion, Euler and matrix
  messages, coded ``v`` -> ``floor(2^(v-1))`` Hz (0: off), as x-io's MATLAB library decodes it. That rate
  replaces ``--rate``; a different ``--rate`` is an error, and so are a register written twice with two
  values, a value of 0 (output off) or one beyond 15 (32 kHz).
- **NGIMU sessions** (NGIMU GUI / SD card file converter): ``Session.xml`` lists the devices
  (``<Devices><Device SerialNumber=... DeviceName=... DirectoryName=.../>``), one sub-folder each with
  ``quaternion.csv`` (and ``euler.csv``, ``matrix.csv``, ``sensors.csv``...). A listed device without its
  sub-folder is a warning naming it (the recording lost a device); a listed name is compared with the
  sub-folders' names, never used as a path.

:func:`folder_companions` lists these files for a folder, so that the command line can check them as
inputs (an output must never overwrite them).
"""

from __future__ import annotations

import csv
import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path

from mocapkit.errors import MocapFormatError

__all__ = [
    "DERIVED_ORIENTATION",
    "SESSION_XML",
    "drop_derived",
    "folder_companions",
    "legacy_xio_rate",
    "missing_devices",
    "ngimu_session_devices",
    "orientation_prefix",
    "registers_file",
    "session_file",
]

#: Register of the legacy x-IMU holding the quaternion / Euler / matrix output rate code.
QUAT_RATE_REGISTER = 55
#: Largest rate code read (2^14 = 16 kHz); beyond, the file is not an x-IMU register dump.
MAX_RATE_CODE = 15
SESSION_XML = "Session.xml"
#: Largest ``Session.xml`` / ``*_Registers.csv`` read (bytes): a larger one is no such file.
MAX_COMPANION_BYTES = 1 << 20

_PART_RE = re.compile(r"(?P<prefix>.*?)_?(?P<kind>quaternion|eulerangles|euler|rotationmatrix|matrix|registers)",
                      re.IGNORECASE)
#: Stems (after a shared prefix) holding the orientation in another form than the quaternion.
DERIVED_ORIENTATION = ("eulerangles", "euler", "rotationmatrix", "matrix")


def orientation_prefix(path: Path) -> tuple[str, str] | None:
    """``(prefix, kind)`` of an x-io file name (``00000_Quaternion.csv`` -> ``("00000", "quaternion")``,
    ``quaternion.csv`` -> ``("", "quaternion")``), else ``None``."""
    if path.suffix.lower() != ".csv":
        return None
    m = _PART_RE.fullmatch(path.stem)
    return (m.group("prefix"), m.group("kind").lower()) if m else None


def drop_derived(orientation_files: Sequence[Path]) -> tuple[list[Path], list[str]]:
    """``(kept, names skipped)``: the orientation files minus those holding the orientation of a
    quaternion file beside them in another form (``euler.csv``, ``00000_EulerAngles.csv``,
    ``matrix.csv``... of the same prefix)."""
    parts = {f: orientation_prefix(f) for f in orientation_files}
    with_quat = {p[0].lower() for p in parts.values() if p is not None and p[1] == "quaternion"}
    keep, skipped = [], []
    for f in orientation_files:
        p = parts[f]
        if p is not None and p[1] in DERIVED_ORIENTATION and p[0].lower() in with_quat:
            skipped.append(f.name)
        else:
            keep.append(f)
    return keep, skipped


def registers_file(quaternion_file: Path) -> Path | None:
    """``<prefix>_Registers.csv`` beside a legacy x-io ``<prefix>_Quaternion.csv``, when it exists."""
    part = orientation_prefix(quaternion_file)
    if part is None or part[1] != "quaternion" or not part[0]:
        return None
    try:
        for f in quaternion_file.parent.iterdir():
            if f.is_file() and orientation_prefix(f) == (part[0], "registers"):
                return f
    except OSError:
        return None
    return None


def _read_small(path: Path, what: str) -> str:
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_COMPANION_BYTES + 1)
    except OSError as exc:
        raise MocapFormatError(str(path), None, f"cannot read the {what}: {exc.strerror or exc}") from None
    if len(data) > MAX_COMPANION_BYTES:
        raise MocapFormatError(str(path), None, f"a {what} of more than {MAX_COMPANION_BYTES:,} bytes")
    if b"\0" in data:
        raise MocapFormatError(str(path), None, f"a {what} with NUL bytes")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise MocapFormatError(str(path), None, f"not UTF-8 text (byte {exc.start})") from None


def legacy_xio_rate(registers: Path) -> tuple[float, str]:
    """``(rate in Hz, how it was found)`` from a legacy x-io ``*_Registers.csv`` (register 55)."""
    src = str(registers)
    rows = list(csv.reader(_read_small(registers, "register file").splitlines()))
    if not rows or [c.strip().lower() for c in rows[0][:3]] != ["packet number", "address", "value"]:
        raise MocapFormatError(src, 1, "not an x-IMU register file (expected the header "
                               "'Packet Number,Address,Value,Float Value,Name')")
    found: list[tuple[int, int]] = []
    for k, row in enumerate(rows[1:], start=2):
        if not any(c.strip() for c in row):
            continue
        if len(row) < 3:
            raise MocapFormatError(src, k, f"expected Packet Number, Address and Value, found {len(row)} cells")
        try:
            addr, value = int(row[1].strip()), int(row[2].strip())
        except ValueError:
            raise MocapFormatError(src, k, f"address {row[1].strip()[:20]!r} and value {row[2].strip()[:20]!r} "
                                   "must be whole numbers") from None
        if addr == QUAT_RATE_REGISTER:
            found.append((k, value))
    if not found:
        raise MocapFormatError(src, None, f"no register {QUAT_RATE_REGISTER} (QuatOutputRate): the quaternion "
                               "rate is not stated; pass it with --rate HZ")
    values = {v for _, v in found}
    if len(values) > 1:
        lines = ", ".join(f"{v} on line {k}" for k, v in found)
        raise MocapFormatError(src, found[-1][0], f"register {QUAT_RATE_REGISTER} (QuatOutputRate) has "
                               f"conflicting values ({lines})")
    line, code = found[0]
    if code == 0:
        raise MocapFormatError(src, line, f"register {QUAT_RATE_REGISTER} (QuatOutputRate) is 0: the quaternion "
                               "output was off when the registers were saved; pass the rate with --rate HZ")
    if not 1 <= code <= MAX_RATE_CODE:
        raise MocapFormatError(src, line, f"register {QUAT_RATE_REGISTER} (QuatOutputRate) is {code}: expected a "
                               f"rate code from 1 (1 Hz) to {MAX_RATE_CODE} ({2 ** (MAX_RATE_CODE - 1)} Hz)")
    rate = float(math.floor(2.0 ** (code - 1)))
    return rate, f"{registers.name} line {line}: register {QUAT_RATE_REGISTER} (QuatOutputRate) = {code}: {rate:g} Hz"


def session_file(folder: Path) -> Path | None:
    """``Session.xml`` of an NGIMU session folder (any case), when it exists."""
    try:
        for f in folder.iterdir():
            if f.name.lower() == SESSION_XML.lower() and f.is_file():
                return f
    except OSError:
        return None
    return None


def ngimu_session_devices(session: Path) -> list[str]:
    """The device folder names listed by an NGIMU ``Session.xml`` (``DirectoryName``, else
    ``"<DeviceName> - <SerialNumber>"``), in the file's order."""
    src = str(session)
    text = _read_small(session, "session file")
    if "<!DOCTYPE" in text or "<!ENTITY" in text:
        raise MocapFormatError(src, None, "a session file with a DOCTYPE or entities is not read")
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise MocapFormatError(src, exc.position[0], f"not XML ({exc.msg if hasattr(exc, 'msg') else exc})") from None
    if root.tag != "Session":
        raise MocapFormatError(src, None, f"root element <{root.tag}>: expected <Session> (an NGIMU session file)")
    names: list[str] = []
    for dev in root.iter("Device"):
        name = dev.get("DirectoryName")
        if not name:
            dn, sn = dev.get("DeviceName"), dev.get("SerialNumber")
            if not (dn and sn):
                raise MocapFormatError(src, None, "a <Device> without DirectoryName (or DeviceName and SerialNumber)")
            name = f"{dn} - {sn}"
        names.append(name.strip())
    return names


def missing_devices(session: Path, present: Sequence[str]) -> str | None:
    """A warning naming the devices that ``Session.xml`` lists but that have no sub-folder, else ``None``."""
    listed = ngimu_session_devices(session)
    have = set(present)
    missing = [n for n in listed if n not in have]
    if not missing:
        return None
    return (f"{session.name} lists {len(listed)} devices; {len(missing)} missing (no sub-folder): "
            + ", ".join(repr(n) for n in missing))


def folder_companions(folder: Path) -> list[Path]:
    """The files a sensor folder is read with besides its data: ``Session.xml`` and every
    ``*_Registers.csv`` (at the top and in the sensor sub-folders)."""
    out: list[Path] = []
    s = session_file(folder)
    if s is not None:
        out.append(s)
    try:
        places = [folder] + sorted((d for d in folder.iterdir() if d.is_dir() and not d.name.startswith(".")),
                                   key=lambda d: d.name)
        for place in places:
            for f in sorted(place.iterdir(), key=lambda f: f.name):
                part = orientation_prefix(f)
                if part is not None and part[1] == "registers" and part[0] and f.is_file():
                    out.append(f)
    except OSError:
        pass
    return out
