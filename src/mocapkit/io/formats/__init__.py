"""Our own output files: glTF export and read-back, and the ``.mkc``/``.mkp`` files' bytes (their coding is
:mod:`mocapkit.clip` and :mod:`mocapkit.pla.packet_layout`)."""
