/*
 * mkpla — streaming piecewise linear approximation of sensor signals, in C99 for microcontrollers.
 *
 * The C twin of mocapkit's Python encoders (src/mocapkit/pla/): fastSW, SW, CPLR, the Swing Filter
 * and the angle-bounded encoder anglesw. Each encoder takes one sample at a time and answers with
 * zero or one segment point, in O(1) work and memory per sample (fastSW, CPLR, Swing) or O(n) with
 * n the current segment length (SW, anglesw; bounded by a maximum segment length whose buffer the
 * caller provides). Nothing is allocated; the caller owns every state.
 *
 * Precision: the library is compiled once per precision from one source. By default mkpla_real is
 * double; define MKPLA_FLOAT32 (before including this header, and when compiling mkpla.c) for float.
 * The float64 build performs the same floating-point operations in the same order as the Python
 * kernels, so it decides the same segment points bit for bit (compile with -ffp-contract=off: a
 * fused multiply-add rounds differently). The float32 build uses its own sin/atan2 (mkpla.c) so a
 * desktop and a microcontroller decide alike; its anglesw bound keeps MKPLA_ANGLE_SLACK radians in
 * reserve for float32 rounding (see mkpla.c).
 *
 * Calling convention of every encoder (fastSW shown):
 *
 *     mkpla_fastsw st;
 *     mkpla_point p;
 *     mkpla_fastsw_init(&st, 4, threshold, 0);
 *     for each sample (t, x):  if (mkpla_fastsw_push(&st, t, x, &p)) send(p);
 *     if (mkpla_fastsw_flush(&st, &p)) send(p);
 *
 * The first sample is always a point (push returns 1). A later push returns 1 when the *previous*
 * sample's time became a segment point: p.index is that sample's index (0-based count of pushes).
 * Times must increase strictly; samples may be irregular and have gaps. The per-method push
 * functions do not check their input (they are the inner loop of a sensor); mkpla_encoder_push
 * does (time order, finiteness is the caller's).
 *
 * Point values: fastSW, SW and anglesw emit original samples (as passed to push; for anglesw the
 * sample normalised to unit length); CPLR and the Swing Filter emit extrapolated points.
 *
 * Thresholds: SSR per segment for fastSW, SW and CPLR (Eq. 5/13 of the fastSW paper), the maximum
 * absolute error per sample and dimension for the Swing Filter, radians for anglesw.
 */
#ifndef MKPLA_H
#define MKPLA_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#ifdef MKPLA_FLOAT32
typedef float mkpla_real;
#else
typedef double mkpla_real;
#endif

/* Largest dimension of a sample (4 for quaternions). States are sized by it: a sensor build keeps
 * the default, a host build may raise it. */
#ifndef MKPLA_MAX_DIM
#define MKPLA_MAX_DIM 4
#endif

/* Return codes of the init and the checked (mkpla_encoder_*) functions. */
#define MKPLA_OK 0
#define MKPLA_E_PARAM (-1)   /* bad dimension, method, threshold or maximum segment length */
#define MKPLA_E_BUFFER (-2)  /* the buffer is too small for the maximum segment length */
#define MKPLA_E_TIME (-3)    /* a time is not after the previous one */
#define MKPLA_E_ZERO (-4)    /* a zero quaternion (anglesw, quaternion encoders) */
#define MKPLA_E_DONE (-5)    /* push after flush */

/** A segment point: the sample index and time it lies at, and its values. */
typedef struct {
    uint32_t index;
    mkpla_real t;
    mkpla_real v[MKPLA_MAX_DIM];
} mkpla_point;

/* ---- fastSW: Algorithm 1 of the fastSW paper, O(1) per sample ------------------------------ */
typedef struct {
    int dim;
    uint32_t maxlen;  /* maximum segment length in sample intervals, 0 = unbounded */
    uint32_t count;   /* samples pushed */
    uint32_t n;       /* samples after the anchor in the current segment */
    mkpla_real th;
    mkpla_real ta, tp, t2m;  /* anchor time, previous time, mean t^2 (Eq. 12) */
    mkpla_real av[MKPLA_MAX_DIM], pv[MKPLA_MAX_DIM];   /* anchor, previous sample */
    mkpla_real tym[MKPLA_MAX_DIM], y2m[MKPLA_MAX_DIM]; /* mean t*y (Eq. 11), mean y^2 (Eq. 10) */
} mkpla_fastsw;

int mkpla_fastsw_init(mkpla_fastsw *s, int dim, mkpla_real threshold, uint32_t maxlen);
int mkpla_fastsw_push(mkpla_fastsw *s, mkpla_real t, const mkpla_real *x, mkpla_point *p);
int mkpla_fastsw_flush(mkpla_fastsw *s, mkpla_point *p);

/* ---- SW: sliding window with connected segments, Eq. 5, O(n) per sample --------------------- */
typedef struct {
    int dim;
    uint32_t maxlen;  /* >= 1: the buffer holds maxlen samples */
    uint32_t count, n;
    mkpla_real th;
    mkpla_real ta, tp;
    mkpla_real av[MKPLA_MAX_DIM], pv[MKPLA_MAX_DIM];
    mkpla_real *bt;   /* maxlen times */
    mkpla_real *bx;   /* maxlen x dim values */
} mkpla_sw;

/* reals a SW or anglesw buffer needs for a maximum segment length L and a dimension D */
#define MKPLA_SW_BUFFER_LEN(L, D) ((size_t)(L) * (size_t)((D) + 1))
#define MKPLA_ANGLESW_BUFFER_LEN(L) ((size_t)(L) * 5u)

int mkpla_sw_init(mkpla_sw *s, int dim, mkpla_real threshold, uint32_t maxlen, mkpla_real *buffer,
                  size_t buffer_len);
int mkpla_sw_push(mkpla_sw *s, mkpla_real t, const mkpla_real *x, mkpla_point *p);
int mkpla_sw_flush(mkpla_sw *s, mkpla_point *p);

/* ---- CPLR: connected regression lines through the anchor, O(1) per sample -------------------- */
typedef struct {
    int dim;
    uint32_t maxlen, count, n;
    mkpla_real th;
    mkpla_real ta, tp, t2m;
    mkpla_real av[MKPLA_MAX_DIM], tym[MKPLA_MAX_DIM], y2m[MKPLA_MAX_DIM];
} mkpla_cplr;

int mkpla_cplr_init(mkpla_cplr *s, int dim, mkpla_real threshold, uint32_t maxlen);
int mkpla_cplr_push(mkpla_cplr *s, mkpla_real t, const mkpla_real *x, mkpla_point *p);
int mkpla_cplr_flush(mkpla_cplr *s, mkpla_point *p);

/* ---- Swing Filter: per-sample L-infinity bound, O(1) per sample ------------------------------ */
typedef struct {
    int dim;
    uint32_t maxlen, count, n;
    mkpla_real eps;
    mkpla_real ta, tp, t2m;
    mkpla_real av[MKPLA_MAX_DIM], tym[MKPLA_MAX_DIM], up[MKPLA_MAX_DIM], lo[MKPLA_MAX_DIM];
} mkpla_swing;

int mkpla_swing_init(mkpla_swing *s, int dim, mkpla_real eps, uint32_t maxlen);
int mkpla_swing_push(mkpla_swing *s, mkpla_real t, const mkpla_real *x, mkpla_point *p);
int mkpla_swing_flush(mkpla_swing *s, mkpla_point *p);

/* ---- anglesw: every sample within an angle of the SLERP decode, O(n) per sample -------------- */
typedef struct {
    uint32_t maxlen, count, n;
    int32_t failed;   /* the buffered sample that failed last (checked first), -1: none */
    mkpla_real th;    /* radians, less MKPLA_ANGLE_SLACK in the float32 build */
    mkpla_real ta, tp;
    mkpla_real qa[4], qp[4];  /* normalised anchor and previous sample */
    mkpla_real *bt;   /* maxlen times */
    mkpla_real *bq;   /* maxlen x 4 normalised samples */
} mkpla_anglesw;

int mkpla_anglesw_init(mkpla_anglesw *s, mkpla_real max_angle_rad, uint32_t maxlen, mkpla_real *buffer,
                       size_t buffer_len);
int mkpla_anglesw_push(mkpla_anglesw *s, mkpla_real t, const mkpla_real *q, mkpla_point *p);
int mkpla_anglesw_flush(mkpla_anglesw *s, mkpla_point *p);

/* ---- One encoder of any method, with checked input ----------------------------------------- */
enum { MKPLA_FASTSW = 0, MKPLA_SW = 1, MKPLA_CPLR = 2, MKPLA_SWING = 3, MKPLA_ANGLESW = 4 };

typedef struct {
    int method, dim;
    int quaternion;   /* 1: samples are quaternions, made hemisphere-continuous before encoding */
    int done;
    uint32_t count;
    mkpla_real sign;                  /* sign applied to the last sample (+1 or -1) */
    mkpla_real last_t;
    mkpla_real last[MKPLA_MAX_DIM];   /* the last sample as passed */
    union {
        mkpla_fastsw fastsw;
        mkpla_sw sw;
        mkpla_cplr cplr;
        mkpla_swing swing;
        mkpla_anglesw anglesw;
    } u;
} mkpla_encoder;

/* threshold in the method's unit (radians for anglesw); buffer only for SW and anglesw */
int mkpla_encoder_init(mkpla_encoder *e, int method, int dim, int quaternion, mkpla_real threshold,
                       uint32_t maxlen, mkpla_real *buffer, size_t buffer_len);
/* 1: a point in *p (values as passed for fastSW/SW/anglesw), 0: none, < 0: an MKPLA_E_* error */
int mkpla_encoder_push(mkpla_encoder *e, mkpla_real t, const mkpla_real *x, mkpla_point *p);
int mkpla_encoder_flush(mkpla_encoder *e, mkpla_point *p);
/* n samples (t[i], x[i*dim .. i*dim+dim-1]); the points go to index[], ts[] and values[] (room for n
 * + 1 points, values dim per point). Returns the number of points, or an MKPLA_E_* error with
 * *failed set to the offending sample. flush_at_end: also flush after the last sample. */
long mkpla_encoder_push_many(mkpla_encoder *e, const mkpla_real *t, const mkpla_real *x, size_t n,
                             int flush_at_end, uint32_t *index, mkpla_real *ts, mkpla_real *values,
                             size_t *failed);

#ifdef __cplusplus
}
#endif
#endif /* MKPLA_H */
