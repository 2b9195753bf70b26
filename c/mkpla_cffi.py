"""cffi builders of the two Python bindings of the C library in ``c/mkpla``: float64 and float32.

Run by setuptools at ``pip install`` (``setup.py``: ``cffi_modules``); the modules land in the package
as ``mocapkit._mkpla64`` and ``mocapkit._mkpla32``. Both compile the same ``mkpla.c``; the float32
one with ``MKPLA_FLOAT32``. No fused multiply-add, so the float64 build rounds as the Python kernels
do: the sources turn contraction off themselves; ``-ffp-contract=off`` says it once more. Times are
``double`` in the float64 build and ``uint32_t`` ticks in the float32 one (``mkpla_time``).
"""

from __future__ import annotations

from pathlib import Path

from cffi import FFI

#: relative to the project root (setuptools refuses absolute paths; the build runs from the root)
LIB = Path("c") / "mkpla"
#: the widest sample the binding encodes in C (wider signals use the numba kernels)
MAX_DIM = 16

CDEF = """
typedef REAL mkpla_real;
typedef TIME mkpla_time;
typedef struct { uint32_t index; mkpla_time t; mkpla_real v[%d]; } mkpla_point;
typedef struct { ...; } mkpla_encoder;
int mkpla_encoder_init(mkpla_encoder *e, int method, int dim, int quaternion, mkpla_real threshold,
                       uint32_t maxlen, mkpla_real *buffer, size_t buffer_len);
int mkpla_encoder_push(mkpla_encoder *e, mkpla_time t, const mkpla_real *x, mkpla_point *p);
int mkpla_encoder_flush(mkpla_encoder *e, mkpla_point *p);
long mkpla_encoder_push_many(mkpla_encoder *e, const mkpla_time *t, const mkpla_real *x, size_t n,
                             int flush_at_end, uint32_t *index, mkpla_time *ts, mkpla_real *values,
                             size_t *failed, size_t *made);
typedef struct { ...; } mkp_packetiser;
mkpla_real mkp_delta(int bits);
int mkp_quantise(const mkpla_real *q, int bits, uint16_t *code);
void mkp_dequantise(const uint16_t *code, int bits, mkpla_real *q);
uint16_t mkp_crc16(const uint8_t *data, size_t n);
int mkp_init(mkp_packetiser *s, uint8_t sensor, mkpla_real max_angle_rad, int bits, int packet_bytes,
             uint32_t maxlen, mkpla_real *buffer, size_t buffer_len);
long mkp_push_many(mkp_packetiser *s, const mkpla_real *q, size_t n, int flush_at_end, uint8_t *out, size_t cap,
                   size_t *used, uint32_t *packet_at, uint32_t *point_tick, uint16_t *point_code, size_t *points,
                   size_t *failed);
""" % MAX_DIM


def _builder(name: str, real: str, time: str, defines: list[tuple[str, str | None]]) -> FFI:
    ffi = FFI()
    ffi.cdef(CDEF.replace("REAL", real).replace("TIME", time))
    ffi.set_source(
        f"mocapkit.{name}",
        '#include "mkpla.h"\n#include "mkp.h"',
        sources=[(LIB / "mkpla.c").as_posix(), (LIB / "mkp.c").as_posix()],
        include_dirs=[LIB.as_posix()],
        define_macros=[("MKPLA_MAX_DIM", str(MAX_DIM)), *defines],
        extra_compile_args=["-std=c99", "-O2", "-ffp-contract=off"],
        libraries=["m"],
    )
    return ffi


ffi64 = _builder("_mkpla64", "double", "double", [])
ffi32 = _builder("_mkpla32", "float", "uint32_t", [("MKPLA_FLOAT32", "1")])
