"""The options of the ``compress`` jobs, one frozen dataclass per kind of work, and the one constructor
(:func:`compress_options`) that the ``compress`` command, ``mocapkit batch`` and its manifest rows and
sidecars (through :func:`mocapkit.jobs.compress_job`) all build them with."""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, Literal, TypeVar, overload

from mocapkit.errors import InvalidParameterError

METHODS = ("fastsw", "sw", "cplr", "swing", "anglesw", "optimal")
#: the kinds of compress work: IMU points, a skeleton (glTF, BVH or .mkc clip), ``.mkp`` radio packets
KINDS = ("imu", "skeletal", "packets")


@dataclass(frozen=True)
class ImuCompressOptions:
    """Orientation streams to segment points: the method, one control and how the IMU data are read."""

    method: str = "fastsw"
    threshold: float | None = None
    target_icr: float | None = None
    max_angle: float | None = None
    max_segment_length: int | None = None
    rate: float | None = None
    time_column: str | None = None
    quaternion_columns: str | None = None
    scalar_last: bool = False
    time_unit: str | None = None


@dataclass(frozen=True)
class SkeletonCompressOptions:
    """A skeleton to keyframes (glTF, BVH) or a ``.mkc`` clip: method, one control, how the file is read,
    the clip's metric and coding, the glTF rotation keys and a batch's output format."""

    method: str = "fastsw"
    threshold: float | None = None
    target_icr: float | None = None
    max_position_error: float | None = None
    max_segment_length: int | None = None
    rate: float | None = None
    asf: Path | None = None
    unit_cm: float | None = None
    strict: bool = True
    gltf_rotations: str = "short"
    error_metric: str = "joint+end"
    shell_distance: float = 3.0
    block_frames: int | None = None
    skeletal_format: str | None = None
    entropy: str = "zstd"


@dataclass(frozen=True)
class PacketCompressOptions:
    """IMU streams to ``.mkp`` radio packets: the angle bound, the packet layout and how the data are read
    (``packet_bits`` None: the fewest bits within 15% of the bound)."""

    max_angle: float
    packet_bits: int | None = None
    packet_bytes: int = 20
    max_segment_length: int | None = None
    rate: float | None = None
    time_column: str | None = None
    quaternion_columns: str | None = None
    scalar_last: bool = False
    time_unit: str | None = None
    precision: str = "float64"


CompressOptions = ImuCompressOptions | SkeletonCompressOptions | PacketCompressOptions
T = TypeVar("T", ImuCompressOptions, SkeletonCompressOptions, PacketCompressOptions)
_CLASSES = {"imu": ImuCompressOptions, "skeletal": SkeletonCompressOptions, "packets": PacketCompressOptions}
_POINTS = frozenset(f.name for c in (ImuCompressOptions, SkeletonCompressOptions) for f in fields(c)) \
    | {"packet_bits", "packet_bytes"}
#: the names :func:`compress_options` takes for each kind (some only to refuse them, as the command does)
TAKES = {"imu": _POINTS, "skeletal": _POINTS,
         "packets": frozenset(f.name for f in fields(PacketCompressOptions)) | {"method", "threshold", "target_icr"}}


def check_options(method: str = "fastsw", threshold=None, target_icr=None, max_angle=None,
                  max_position_error=None, skeletal_format=None, error_metric="joint+end",
                  per_file: bool = False) -> None:
    """The option checks that need no file: a known method and exactly one control; the batch's
    skeletal output format and what it can bound. ``per_file`` (a batch's own options, completed per
    file): ``max_angle`` and ``max_position_error`` may come together (each bounds its kind of input), or
    no control at all (the files' manifest or sidecars give them)."""
    from mocapkit.clip.metric import METRICS

    if skeletal_format not in (None, "glb", "mkc"):
        raise InvalidParameterError(f"--skeletal-format {skeletal_format!r}: mkc or glb")
    if error_metric not in METRICS:
        raise InvalidParameterError(f"--error-metric {error_metric!r}: one of {', '.join(METRICS)}")
    if error_metric == "shell" and skeletal_format == "glb":
        raise InvalidParameterError("--error-metric shell is bounded in .mkc clips: add --skeletal-format mkc")
    if method not in METHODS:
        raise InvalidParameterError(f"--method {method!r}: one of {', '.join(METHODS)}")
    given = sum(x is not None for x in (threshold, target_icr, max_angle, max_position_error))
    if per_file and (given == 0 or (given == 2 and max_angle is not None and max_position_error is not None)):
        return
    if given != 1:
        raise InvalidParameterError("give exactly one of --threshold, --target-icr, --max-angle (IMU data) or "
                                    "--max-position-error (skeletons)"
                                    + ("; --max-angle and --max-position-error may go together (each bounds its "
                                       "kind of input)" if per_file else ""))


@overload
def compress_options(kind: Literal["imu"], output: Path | None = None, **given: Any) -> ImuCompressOptions: ...
@overload
def compress_options(kind: Literal["skeletal"], output: Path | None = None,
                     **given: Any) -> SkeletonCompressOptions: ...
@overload
def compress_options(kind: Literal["packets"], output: Path | None = None, **given: Any) -> PacketCompressOptions: ...
@overload
def compress_options(kind: str, output: Path | None = None, **given: Any) -> CompressOptions: ...
def compress_options(kind: str, output: Path | None = None, **given: Any) -> CompressOptions:
    """The options of compress work ``kind`` (:data:`KINDS`) from the ``given`` values (the command's
    options in snake case; None: not given), checked as the command checks them, the bad option named.
    ``output`` only words the messages (a ``.mkc`` or ``.mkp`` output takes fewer controls). Options of
    another kind that change nothing are ignored, as the command always did; those that would be
    silently lost (``--asf`` for IMU data...) are refused."""
    if kind not in _CLASSES:
        raise InvalidParameterError(f"unknown compress kind {kind!r}: one of {', '.join(KINDS)}")
    unknown = sorted(set(given) - TAKES[kind])
    if unknown:
        raise TypeError(f"compress_options() got an unexpected keyword argument {unknown[0]!r}")
    if kind == "packets":
        return _packets(output, given)
    if given.get("packet_bits") is not None or given.get("packet_bytes") is not None:
        raise InvalidParameterError("--packet-bits and --packet-bytes apply to a packet stream (-o OUT.mkp)")
    check_options(**{k: given[k] for k in ("method", "threshold", "target_icr", "max_angle", "max_position_error",
                                           "skeletal_format", "error_metric") if k in given})
    if kind == "skeletal" and given.get("max_angle") is not None:
        if output is not None and Path(output).suffix.lower() == ".mkc":
            raise InvalidParameterError(f"{output}: a .mkc clip is bounded by --max-position-error CM only")
        raise InvalidParameterError("for skeletal input use --max-position-error CM (or --threshold / --target-icr)")
    if kind == "imu" and any(given.get(k) is not None for k in ("max_position_error", "asf", "unit_cm")):
        raise InvalidParameterError("--max-position-error, --asf and --unit-cm apply to BVH/AMC input")
    if given.get("asf") is not None:
        given["asf"] = Path(given["asf"])
    return _build(_CLASSES[kind], given)


def _packets(output, given: dict) -> PacketCompressOptions:
    """The checks of ``compress -o OUT.mkp``, in the order the command always made them."""
    from mocapkit.pla.packets import check_packet_options, default_bits

    max_angle = given.get("max_angle")
    if max_angle is None or given.get("threshold") is not None or given.get("target_icr") is not None:
        raise InvalidParameterError(f"{output}: a .mkp packet stream is bounded by --max-angle DEG only")
    method = given.get("method", "anglesw")
    if method not in ("anglesw", "fastsw"):  # fastsw: the command's default, not a choice
        raise InvalidParameterError(f"{output}: a .mkp packet stream is made by the angle-bounded encoder "
                                    f"(anglesw), not {method}")
    if not (math.isfinite(max_angle) and max_angle > 0):
        raise InvalidParameterError(f"--max-angle {max_angle!r}: a positive number of degrees")
    if given.get("packet_bytes") is None:
        given["packet_bytes"] = 20
    bits = given.get("packet_bits")
    check_packet_options(max_angle, default_bits(max_angle) if bits is None else bits, given["packet_bytes"])
    return _build(PacketCompressOptions, given)


def _build(cls: type[T], given: dict) -> T:
    return cls(**{f.name: given[f.name] for f in fields(cls) if f.name in given})


@contextlib.contextmanager
def naming_target_icr(target_icr):
    """An unreachable ``--target-icr`` is reported under the option's name."""
    from mocapkit.errors import UnreachableTargetError

    try:
        yield
    except UnreachableTargetError as e:
        raise InvalidParameterError(f"--target-icr {target_icr:g}: {e}") from None
