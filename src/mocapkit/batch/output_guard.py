"""No output of a batch may be written onto one of its inputs.

Each job checks its output against its own input (:func:`mocapkit.io.atomic.check_output`); a batch also
has to keep every other input safe, and the files it read beside them (manifest, sidecars, ASF skeletons,
labels): an output in OUT that is already a symlink or hard link onto one of them, or lies in a folder
that is (a link to) an input folder, is refused. :class:`OutputGuard` holds the identities (device, inode)
of all of them once, so each output costs a few ``stat`` calls whatever the number of inputs.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Iterable


def _stat(p: str) -> os.stat_result | None:
    try:
        return os.stat(p)
    except (OSError, ValueError):
        return None


class OutputGuard:
    """The batch's inputs and the files read with them, by identity."""

    def __init__(self, inputs: Iterable[str | os.PathLike[str]]):
        self.files: dict[tuple[int, int], str] = {}
        self.folders: dict[tuple[int, int], str] = {}
        for p in inputs:
            st = _stat(os.fspath(p))
            if st is not None:
                (self.folders if stat.S_ISDIR(st.st_mode) else self.files)[(st.st_dev, st.st_ino)] = os.fspath(p)

    def problem(self, output: str | os.PathLike[str]) -> str | None:
        """Why ``output`` (a file, or a folder of files) must not be written, or None."""
        out = os.fspath(output)
        st = _stat(out)
        if st is not None:
            hit = self.files.get((st.st_dev, st.st_ino))
            if hit is not None:
                return f"{out}: is (a link to) {hit}, an input of this batch; remove it from the output folder"
            if stat.S_ISDIR(st.st_mode):
                try:
                    names = os.listdir(out)
                except OSError:
                    names = []
                for n in names:
                    est = _stat(os.path.join(out, n))
                    hit = None if est is None else self.files.get((est.st_dev, est.st_ino))
                    if hit is not None:
                        return (f"{os.path.join(out, n)}: is (a link to) {hit}, an input of this batch; "
                                "remove it from the output folder")
        anc = os.path.realpath(out)
        while True:
            ast = _stat(anc)
            hit = None if ast is None else self.folders.get((ast.st_dev, ast.st_ino))
            if hit is not None:
                return f"{out}: lies in {hit}, an input folder of this batch (through a link in the output folder)"
            parent = os.path.dirname(anc)
            if parent == anc:
                return None
            anc = parent
