"""The ``.mkc`` clip: whole-skeleton compression within a guaranteed position error (joint or ACL's
shell metric), keyframes on quantisation grids, entropy-coded blocks with random access.

:func:`encode_clip` makes the bytes, :class:`Clip` decodes them (whole motion or one pose),
:func:`position_errors` measures both metrics. Nothing here opens a file: ``mocapkit.jobs.readers.read_mkc``
reads a ``.mkc`` file (:mod:`mocapkit.io.formats.mkc`) and decodes it.
"""

from mocapkit.clip.decoder import Clip
from mocapkit.clip.encoder import DEFAULT_BLOCK_FRAMES, EncodedClip, encode_clip
from mocapkit.clip.metric import DEFAULT_SHELL_CM, METRICS, position_errors

__all__ = ["DEFAULT_BLOCK_FRAMES", "DEFAULT_SHELL_CM", "METRICS", "Clip", "EncodedClip", "encode_clip", "position_errors"]
