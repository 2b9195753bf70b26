"""Ground-truth action segmentations of motion-capture takes.

A segmentation of ``n`` frames is stored as sorted 0-based *cuts*: cut ``c`` (``0 < c < n``) means
a new segment starts at frame ``c``. :class:`Reference` bundles the cuts with the annotators'
tolerance interval of each cut, one label per segment, the frame rate and where it came from.

Two file formats are read:

* :func:`read_haca_labels` — the CMU subject-86 format (a header line, then ``label a b c`` lines
  giving the 1-based end frame ``b`` of each segment and the annotators' uncertainty ``a..c``);
* :func:`read_frame_labels` — the mocap6 format (one integer action id per block of 12 frames).

:func:`read_reference` tells the two apart and checks the file against the take (call it before any
long computation). :func:`labels_from_frames` builds a :class:`Reference` from a per-frame label
array (synthetic data, tests).

Integers are plain ASCII decimals of at most 15 digits (no ``1_0``, no other scripts' digits, nothing
that would overflow ``int64``); a pipe or device is read in bounded chunks and a NUL byte is refused
(:mod:`mocapkit.io.text.input`); text is UTF-8, else Latin-1.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path

import numpy as np

from mocapkit.errors import InvalidParameterError, InvalidSignalError, MocapFormatError

__all__ = [
    "MOCAP6_ACTIONS",
    "Reference",
    "labels_from_frames",
    "read_frame_labels",
    "read_haca_labels",
    "read_reference",
]

#: Action names of the mocap6 label files (CMU subjects 13 and 14), by action id.
MOCAP6_ACTIONS: Mapping[int, str] = {
    1: "JumpJack",
    2: "Jog",
    3: "Squat",
    4: "KneeRaise",
    5: "ArmCircle",
    6: "Twist",
    7: "SideReach",
    8: "Box",
    9: "UpDown",
    10: "ToeTouchOneHand",
    11: "SideBend",
    12: "ToeTouchTwoHands",
}

_LINE_SPLIT_RE = re.compile(r"\r\n|\r|\n")
_INT_RE = re.compile(r"[+-]?[0-9]{1,15}")


@dataclass(frozen=True, eq=False)
class Reference:
    """A ground-truth segmentation of one take.

    Parameters
    ----------
    n_frames
        Number of frames of the take (``>= 1``).
    cuts
        Sorted, distinct 0-based cut frames, each in ``(0, n_frames)``; stored as a read-only
        ``int64`` array of shape ``(k,)``.
    intervals
        ``(k, 2)`` read-only ``int64`` array: for each cut the inclusive 0-based range ``[lo, hi]``
        of positions the annotators consider correct (``lo <= cut <= hi``). Equal to
        ``[cut, cut]`` when the source gives no tolerance.
    labels
        One label per segment: ``k + 1`` strings.
    rate_hz
        Frame rate of the take, in Hz (``> 0``).
    source
        Where the segmentation came from (a file path or a short description).
    warnings
        What the reader accepted but the caller should show (e.g. one label block more or less than
        the take needs); readers never print.

    Raises
    ------
    InvalidParameterError
        If the fields are inconsistent (cuts unsorted or out of range, wrong shapes, wrong number of
        labels, a cut outside its interval, a non-positive rate).
    """

    n_frames: int
    cuts: np.ndarray
    intervals: np.ndarray
    labels: tuple[str, ...]
    rate_hz: float = 120.0
    source: str = ""
    warnings: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        n = self.n_frames
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise InvalidParameterError(f"n_frames must be a positive integer, got {n!r}")
        n = int(n)
        cuts = np.array(self.cuts, dtype=np.int64).reshape(-1)
        if cuts.size and (cuts[0] <= 0 or cuts[-1] >= n or np.any(np.diff(cuts) <= 0)):
            raise InvalidParameterError(
                f"cuts must be strictly increasing and inside (0, {n}), got {cuts.tolist()}"
            )
        intervals = np.array(self.intervals, dtype=np.int64)
        if intervals.size == 0:
            intervals = intervals.reshape(0, 2)
        if intervals.shape != (cuts.size, 2):
            raise InvalidParameterError(
                f"intervals must have shape ({cuts.size}, 2), got {intervals.shape}"
            )
        outside = (intervals[:, 0] > cuts) | (intervals[:, 1] < cuts)
        if outside.any():
            i = int(np.flatnonzero(outside)[0])
            raise InvalidParameterError(
                f"cut {int(cuts[i])} lies outside its interval {intervals[i].tolist()}"
            )
        labels = tuple(str(s) for s in self.labels)
        if len(labels) != cuts.size + 1:
            raise InvalidParameterError(
                f"{cuts.size} cuts make {cuts.size + 1} segments but {len(labels)} labels were given"
            )
        rate = float(self.rate_hz)
        if not math.isfinite(rate) or rate <= 0:
            raise InvalidParameterError(f"rate_hz must be positive and finite, got {self.rate_hz!r}")
        cuts.flags.writeable = False
        intervals.flags.writeable = False
        object.__setattr__(self, "n_frames", n)
        object.__setattr__(self, "cuts", cuts)
        object.__setattr__(self, "intervals", intervals)
        object.__setattr__(self, "labels", labels)
        object.__setattr__(self, "rate_hz", rate)
        object.__setattr__(self, "source", str(self.source))
        object.__setattr__(self, "warnings", tuple(str(w) for w in self.warnings))

    @property
    def n_segments(self) -> int:
        """Number of segments (``len(cuts) + 1``)."""
        return int(self.cuts.size) + 1

    def frame_labels(self) -> np.ndarray:
        """Segment index of every frame.

        Returns
        -------
        numpy.ndarray
            ``int64`` array of length ``n_frames``; frame ``f`` gets the index ``0..k`` of the
            segment containing it (``labels[index]`` is its label).
        """
        return np.searchsorted(self.cuts, np.arange(self.n_frames), side="right").astype(np.int64)


# --------------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------------


def _read_lines(path: str | Path) -> tuple[str, list[str]]:
    """The file's name and its lines (CRLF, LF or CR ends; a UTF-8 byte-order mark is dropped)."""
    from mocapkit.io.text.input import decode_text, read_input

    src = str(Path(path))
    text, _ = decode_text(read_input(path, "label file"))
    return src, _LINE_SPLIT_RE.split(text)


def _parse_int(src: str, ln: int, token: str, what: str) -> int:
    if not _INT_RE.fullmatch(token):
        shown = token if len(token) <= 40 else token[:37] + "..."
        raise MocapFormatError(src, ln, f"{what} must be an integer (at most 15 digits), got {shown!r}")
    return int(token)


def _check_rate(rate_hz: float) -> float:
    try:
        rate = float(rate_hz)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"rate_hz must be a number, got {rate_hz!r}") from None
    if not math.isfinite(rate) or rate <= 0:
        raise InvalidParameterError(f"rate_hz must be positive and finite, got {rate_hz!r}")
    return rate


def _check_positive_int(value: object, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise InvalidParameterError(f"{name} must be a positive integer, got {value!r}")
    return int(value)


# --------------------------------------------------------------------------------------------------
# CMU subject 86 (HACA) format
# --------------------------------------------------------------------------------------------------


def _is_haca_row(tokens: list[str]) -> bool:
    """``label a b c`` with integers ``a <= b <= c``."""
    if len(tokens) != 4 or not all(_INT_RE.fullmatch(t) for t in tokens[1:]):
        return False
    a, b, c = (int(t) for t in tokens[1:])
    return a <= b <= c


def read_haca_labels(
    path: str | Path, n_frames: int | None = None, rate_hz: float = 120.0
) -> Reference:
    """Read a CMU subject-86 segmentation file (e.g. ``86_01.labels.txt``).

    Format: blank lines are ignored; the first non-blank line is a header (e.g. ``86 01``) and is
    not interpreted, unless it is itself a segment line (4 tokens, integers ``a <= b <= c``): the
    header is optional. Every following line is ``label a b c`` with integers ``a <= b <= c``. The
    segment named ``label`` *ends* at the 1-based frame ``b`` (inclusive), and ``a..c`` is the
    annotators' uncertainty about that end. The ``b`` are strictly increasing; the last line ends
    the take, so its ``b`` is the number of frames and is not a cut (its ``a`` and ``c`` are not
    used).

    Mapping to 0-based cuts: a segment ending at the 1-based frame ``e`` ends at the 0-based frame
    ``e - 1``, so the next segment starts at the 0-based frame ``e``. Hence a line ``label a b c``
    (not the last) gives the cut ``b`` and its tolerance interval ``[a, c]`` (both 0-based start
    positions of the next segment).

    Parameters
    ----------
    path
        The file.
    n_frames
        Expected number of frames of the take (e.g. from its AMC file); ``None`` accepts the last
        ``b`` of the file.
    rate_hz
        Frame rate of the take, in Hz.

    Returns
    -------
    Reference
        ``n_frames`` = the last ``b``; ``labels`` = the ``label`` of every line, in order.

    Raises
    ------
    MocapFormatError
        With the file and the 1-based line: a line without exactly 4 tokens, a non-integer
        ``a``/``b``/``c``, ``a > b`` or ``b > c``, ``a < 1``, ``b`` not strictly increasing, an
        interval reaching the end of the take (``c >= `` the number of frames, for a cut), or a last
        ``b`` different from ``n_frames``. With line ``None``: no segment line at all.
    InvalidParameterError
        If ``n_frames`` or ``rate_hz`` is out of its domain.
    """
    rate = _check_rate(rate_hz)
    if n_frames is not None:
        n_frames = _check_positive_int(n_frames, "n_frames")
    src, lines = _read_lines(path)

    header_seen = False
    labels: list[str] = []
    rows: list[tuple[int, int, int, int]] = []  # (line number, a, b, c)
    for ln, raw in enumerate(lines, start=1):
        tokens = raw.split()
        if not tokens:
            continue
        if not header_seen:
            header_seen = True
            if not _is_haca_row(tokens):  # a header such as "86 01"; a first line "walk 40 50 60" is data
                continue
        if len(tokens) != 4:
            raise MocapFormatError(
                src, ln, f"expected 4 tokens 'label a b c', got {len(tokens)}: {raw.strip()[:60]!r}"
            )
        a = _parse_int(src, ln, tokens[1], "a")
        b = _parse_int(src, ln, tokens[2], "b")
        c = _parse_int(src, ln, tokens[3], "c")
        if a < 1:
            raise MocapFormatError(src, ln, f"frames are 1-based, got a = {a}")
        if not a <= b <= c:
            raise MocapFormatError(src, ln, f"need a <= b <= c, got a = {a}, b = {b}, c = {c}")
        if rows and b <= rows[-1][2]:
            raise MocapFormatError(
                src, ln, f"segment ends must increase: b = {b} after b = {rows[-1][2]}"
            )
        labels.append(tokens[0])
        rows.append((ln, a, b, c))

    if not rows:
        raise MocapFormatError(src, None, "no segment lines after the header")
    last_ln, _, total, _ = rows[-1]
    if n_frames is not None and total != n_frames:
        raise MocapFormatError(
            src, last_ln, f"the last segment ends at frame {total} but the take has {n_frames} frames"
        )
    for ln, _, _b, c in rows[:-1]:
        if c >= total:
            raise MocapFormatError(
                src, ln, f"interval end c = {c} reaches the end of the take ({total} frames)"
            )
    cut_rows = np.array([r[1:] for r in rows[:-1]], dtype=np.int64).reshape(-1, 3)
    return Reference(
        n_frames=total,
        cuts=cut_rows[:, 1],
        intervals=cut_rows[:, [0, 2]],
        labels=tuple(labels),
        rate_hz=rate,
        source=src,
    )


# --------------------------------------------------------------------------------------------------
# mocap6 format (one label per block of frames)
# --------------------------------------------------------------------------------------------------


def read_frame_labels(
    path: str | Path,
    n_frames: int,
    frames_per_label: int = 12,
    rate_hz: float = 120.0,
    action_names: Mapping[int, str] | None = MOCAP6_ACTIONS,
) -> Reference:
    """Read a mocap6 block-label file (e.g. ``13_29.labels.txt``).

    Format: whitespace-separated integer action ids over any number of lines. Label ``k``
    (0-based) covers the 1-based frames ``frames_per_label*k + 1 .. frames_per_label*(k+1)``, i.e.
    the 0-based frames ``frames_per_label*k .. frames_per_label*(k+1) - 1``; the last label may
    cover a partial block. The file should hold exactly ``ceil(n_frames / frames_per_label)``
    labels; one label more (the last is ignored) or one less (the last label is extended over the
    remaining frames) is accepted with a message in :attr:`Reference.warnings` — exporters round
    the frame count up or down.

    A cut is placed at the 0-based frame ``frames_per_label*k`` wherever label ``k`` differs from
    label ``k - 1``. The files give no annotator tolerance, so every interval is ``[cut, cut]``;
    note however that the labels only resolve boundaries to a block (12 frames = 0.1 s at
    120 Hz), so a margin of at least ``frames_per_label`` is sensible when scoring against them.

    Parameters
    ----------
    path
        The file.
    n_frames
        Number of frames of the take (from its AMC file).
    frames_per_label
        Frames covered by one label.
    rate_hz
        Frame rate of the take, in Hz.
    action_names
        Names of the action ids used as segment labels; ids missing from it (or every id, when
        ``None``) are labelled by their decimal string.

    Returns
    -------
    Reference

    Raises
    ------
    MocapFormatError
        A non-integer token (with the file and 1-based line), or a label count that differs from
        ``ceil(n_frames / frames_per_label)`` by more than one (with the file, line ``None``, the
        expected and the found counts).
    InvalidParameterError
        If ``n_frames``, ``frames_per_label`` or ``rate_hz`` is out of its domain.
    """
    n = _check_positive_int(n_frames, "n_frames")
    block = _check_positive_int(frames_per_label, "frames_per_label")
    rate = _check_rate(rate_hz)
    src, lines = _read_lines(path)

    ids: list[int] = []
    for ln, raw in enumerate(lines, start=1):
        ids.extend(_parse_int(src, ln, tok, "a label") for tok in raw.split())
    expected = -(-n // block)
    warn: list[str] = []
    if len(ids) == expected + 1:
        warn.append(f"{src}: {len(ids)} labels for {n} frames (expected ceil({n} / {block}) = {expected}): "
                    f"the last label is ignored")
        ids = ids[:expected]
    elif len(ids) == expected - 1 and ids:
        warn.append(f"{src}: {len(ids)} labels for {n} frames (expected ceil({n} / {block}) = {expected}): "
                    f"the last label also covers the last {n - block * len(ids)} frames")
    elif len(ids) != expected:
        raise MocapFormatError(
            src,
            None,
            f"expected {expected} labels (ceil({n} frames / {block})), found {len(ids)}",
        )
    blocks = np.asarray(ids, dtype=np.int64)
    starts = np.flatnonzero(blocks[1:] != blocks[:-1]) + 1
    cuts = starts * block
    names = action_names if action_names is not None else {}
    labels = tuple(names.get(int(v), str(int(v))) for v in blocks[np.r_[0, starts]])
    return Reference(
        n_frames=n,
        cuts=cuts,
        intervals=np.stack([cuts, cuts], axis=1),
        labels=labels,
        rate_hz=rate,
        source=src,
        warnings=tuple(warn),
    )


def read_reference(path: str | Path, n_frames: int, rate_hz: float = 120.0) -> Reference:
    """A label file of either format, checked against the take (``n_frames`` at ``rate_hz``).

    HACA (:func:`read_haca_labels`) when a line after the first holds a token that is not an
    integer (the label names), or when every segment line is ``label a b c`` with increasing ``b``
    and the last ``b`` is ``n_frames`` (integer labels); otherwise per-frame block labels (:func:`read_frame_labels`) at
    10 Hz, i.e. ``round(rate_hz / 10)`` frames per label (12 at 120 Hz, as in mocap6).
    """
    rate = _check_rate(rate_hz)
    src, lines = _read_lines(path)
    rows = [ln.split() for ln in lines if ln.strip()]
    haca = any(not _INT_RE.fullmatch(tok) for ln in rows[1:] for tok in ln)
    if not haca:  # integer labels: HACA when every segment line is "label a b c" ending the take at its last b
        seg = rows[1:] if rows and not _is_haca_row(rows[0]) else rows
        ends = [int(r[2]) for r in seg if _is_haca_row(r)]
        haca = (len(seg) > 0 and len(ends) == len(seg) and all(x < y for x, y in pairwise(ends))
                and ends[-1] == n_frames)
    if haca:
        return read_haca_labels(path, n_frames=n_frames, rate_hz=rate)
    return read_frame_labels(path, n_frames=n_frames, frames_per_label=max(1, int(round(rate / 10.0))), rate_hz=rate)


def labels_from_frames(
    per_frame_labels: Sequence[object] | np.ndarray,
    rate_hz: float = 120.0,
    source: str = "<per-frame labels>",
) -> Reference:
    """Build a :class:`Reference` from one label per frame.

    A cut is placed at every frame whose label differs from the previous frame's; every interval
    is ``[cut, cut]``; a segment's label is ``str`` of its frames' label (so the same label may
    occur in several, non-adjacent segments).

    Parameters
    ----------
    per_frame_labels
        1-D sequence of labels (integers, strings...), one per frame; at least one frame.
    rate_hz
        Frame rate, in Hz.
    source
        Description stored in :attr:`Reference.source`.

    Returns
    -------
    Reference

    Raises
    ------
    InvalidSignalError
        If the labels are not a non-empty 1-D sequence.
    InvalidParameterError
        If ``rate_hz`` is out of its domain.
    """
    rate = _check_rate(rate_hz)
    a = np.asarray(per_frame_labels)
    if a.ndim != 1 or a.size == 0:
        raise InvalidSignalError(
            f"expected a non-empty 1-D array of per-frame labels, got shape {a.shape}"
        )
    cuts = (np.flatnonzero(a[1:] != a[:-1]) + 1).astype(np.int64)
    labels = tuple(str(a[i].item() if hasattr(a[i], "item") else a[i]) for i in np.r_[0, cuts])
    return Reference(
        n_frames=int(a.size),
        cuts=cuts,
        intervals=np.stack([cuts, cuts], axis=1),
        labels=labels,
        rate_hz=rate,
        source=source,
    )
