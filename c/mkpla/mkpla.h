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
 * kernels, so it decides the same segment points bit for bit. The float32 build uses its own
 * sin/atan2 (mkpla.c) so a desktop and a microcontroller decide alike; its anglesw bound keeps
 * MKPLA_ANGLE_SLACK radians in reserve for float32 rounding (see mkpla.c). Both builds turn
 * floating-point contraction off in the source (a fused multiply-add rounds differently):
 * `#pragma STDC FP_CONTRACT OFF`, and for GCC, which ignores that pragma, `#pragma GCC optimize
 * ("fp-contract=off")`; so the compiler's default flags give the same bits. -ffast-math and
 * -ffinite-math-only are refused at build time (they drop the NaN checks and reorder sums).
 *
 * Time: mkpla_time is a double (seconds, or any unit) in the float64 build and an unsigned 32-bit
 * tick count in the float32 build (any clock: a sample counter, a millisecond or microsecond timer).
 * The float32 encoders only ever use the ticks since the current segment's anchor, as an exact
 * integer difference, so their decisions do not depend on how long the sensor has been running,
 * and the counter may wrap around 2^32. The decisions depend on time ratios only, so the tick's
 * length need not be told; point times are ticks. A segment ends before it spans more than
 * MKPLA_MAX_SPAN ticks; two samples must be 1..MKPLA_MAX_SPAN ticks apart.
 *
 * Calling convention of every encoder (fastSW shown):
 *
 *     mkpla_fastsw st;
 *     mkpla_point p;
 *     mkpla_fastsw_init(&st, 4, threshold, 0);
 *     for each sample (t, x):  if (mkpla_fastsw_push(&st, t, x, &p)) send(p);   (t: mkpla_time)
 *     if (mkpla_fastsw_flush(&st, &p)) send(p);
 *
 * The first sample is always a point (push returns 1). A later push returns 1 when the *previous*
 * sample's time became a segment point: p.index is that sample's index (0-based count of pushes).
 * Times must increase strictly; samples may be irregular and have gaps.
 *
 * The per-method push functions do not check their input (they are the inner loop of a sensor);
 * their preconditions, which the caller must meet: every time and component finite; each time after
 * the previous one (float32: 1..MKPLA_MAX_SPAN ticks after it); for anglesw, a quaternion whose
 * squared norm is a normal float (neither zero, subnormal nor overflowing). A sample that breaks
 * them may silently void the bound. mkpla_encoder_push checks all of it and refuses such a sample
 * with an MKPLA_E_* code, leaving the encoder as it was: the bound holds on every sample accepted.
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

#ifdef MKPLA_FLOAT32
typedef uint32_t mkpla_time;             /* ticks of the caller's clock, wrapping at 2^32 */
#define MKPLA_MAX_SPAN 0x7fffffffu       /* most ticks a segment (and a step) may span */
#else
typedef double mkpla_time;
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
#define MKPLA_E_TIME (-3)    /* a time is not after the previous one (float32: by 1..MKPLA_MAX_SPAN ticks) */
#define MKPLA_E_ZERO (-4)    /* a quaternion of zero, subnormal or overflowing squared norm */
#define MKPLA_E_DONE (-5)    /* push after flush */
/* -6 is MKP_E_TICKS (mkp.h) */
#define MKPLA_E_NONFINITE (-7) /* a NaN or infinite time or component */

/** A segment point: the sample index and time it lies at, and its values. */
typedef struct {
    uint32_t index;
    mkpla_time t;
    mkpla_real v[MKPLA_MAX_DIM];
} mkpla_point;

/* ---- fastSW: Algorithm 1 of the fastSW paper, O(1) per sample ------------------------------ */
typedef struct {
    int dim;
    uint32_t maxlen;  /* maximum segment length in sample intervals, 0 = unbounded */
    uint32_t count;   /* samples pushed */
    uint32_t n;       /* samples after the anchor in the current segment */
    mkpla_real th;
    mkpla_time ta, tp;       /* anchor time, previous time */
    mkpla_real t2m;          /* mean t^2 (Eq. 12) */
    mkpla_real av[MKPLA_MAX_DIM], pv[MKPLA_MAX_DIM];   /* anchor, previous sample */
    mkpla_real tym[MKPLA_MAX_DIM], y2m[MKPLA_MAX_DIM]; /* mean t*y (Eq. 11), mean y^2 (Eq. 10) */
} mkpla_fastsw;

int mkpla_fastsw_init(mkpla_fastsw *s, int dim, mkpla_real threshold, uint32_t maxlen);
int mkpla_fastsw_push(mkpla_fastsw *s, mkpla_time t, const mkpla_real *x, mkpla_point *p);
int mkpla_fastsw_flush(mkpla_fastsw *s, mkpla_point *p);

/* ---- SW: sliding window with connected segments, Eq. 5, O(n) per sample --------------------- */
typedef struct {
    int dim;
    uint32_t maxlen;  /* >= 1: the buffer holds maxlen samples */
    uint32_t count, n;
    mkpla_real th;
    mkpla_time ta, tp;
    mkpla_real av[MKPLA_MAX_DIM], pv[MKPLA_MAX_DIM];
    mkpla_real *bt;   /* maxlen times, relative to the anchor */
    mkpla_real *bx;   /* maxlen x dim values */
} mkpla_sw;

/* reals a SW or anglesw buffer needs for a maximum segment length L and a dimension D (for constant
 * sizes; the init functions check L against SIZE_MAX without multiplying, so a length whose buffer
 * size does not fit a size_t is refused rather than wrapped around) */
#define MKPLA_SW_BUFFER_LEN(L, D) ((size_t)(L) * (size_t)((D) + 1))
#define MKPLA_ANGLESW_BUFFER_LEN(L) ((size_t)(L) * 5u)

int mkpla_sw_init(mkpla_sw *s, int dim, mkpla_real threshold, uint32_t maxlen, mkpla_real *buffer,
                  size_t buffer_len);
int mkpla_sw_push(mkpla_sw *s, mkpla_time t, const mkpla_real *x, mkpla_point *p);
int mkpla_sw_flush(mkpla_sw *s, mkpla_point *p);

/* ---- CPLR: connected regression lines through the anchor, O(1) per sample -------------------- */
typedef struct {
    int dim;
    uint32_t maxlen, count, n;
    mkpla_real th;
    mkpla_time ta, tp;
    mkpla_real t2m;
    mkpla_real av[MKPLA_MAX_DIM], tym[MKPLA_MAX_DIM], y2m[MKPLA_MAX_DIM];
} mkpla_cplr;

int mkpla_cplr_init(mkpla_cplr *s, int dim, mkpla_real threshold, uint32_t maxlen);
int mkpla_cplr_push(mkpla_cplr *s, mkpla_time t, const mkpla_real *x, mkpla_point *p);
int mkpla_cplr_flush(mkpla_cplr *s, mkpla_point *p);

/* ---- Swing Filter: per-sample L-infinity bound, O(1) per sample ------------------------------ */
typedef struct {
    int dim;
    uint32_t maxlen, count, n;
    mkpla_real eps;
    mkpla_time ta, tp;
    mkpla_real t2m;
    mkpla_real av[MKPLA_MAX_DIM], tym[MKPLA_MAX_DIM], up[MKPLA_MAX_DIM], lo[MKPLA_MAX_DIM];
} mkpla_swing;

int mkpla_swing_init(mkpla_swing *s, int dim, mkpla_real eps, uint32_t maxlen);
int mkpla_swing_push(mkpla_swing *s, mkpla_time t, const mkpla_real *x, mkpla_point *p);
int mkpla_swing_flush(mkpla_swing *s, mkpla_point *p);

/* ---- anglesw: every sample within an angle of the SLERP decode, O(n) per sample -------------- */
typedef struct {
    uint32_t maxlen, count, n;
    int32_t failed;   /* the buffered sample that failed last (checked first), -1: none */
    mkpla_real th;    /* radians, less MKPLA_ANGLE_SLACK in the float32 build */
    mkpla_time ta, tp;
    mkpla_real qa[4], qp[4];  /* normalised anchor and previous sample */
    mkpla_real *bt;   /* maxlen times, relative to the anchor */
    mkpla_real *bq;   /* maxlen x 4 normalised samples */
} mkpla_anglesw;

int mkpla_anglesw_init(mkpla_anglesw *s, mkpla_real max_angle_rad, uint32_t maxlen, mkpla_real *buffer,
                       size_t buffer_len);
int mkpla_anglesw_push(mkpla_anglesw *s, mkpla_time t, const mkpla_real *q, mkpla_point *p);
int mkpla_anglesw_flush(mkpla_anglesw *s, mkpla_point *p);

/* ---- One encoder of any method, with checked input ----------------------------------------- */
enum { MKPLA_FASTSW = 0, MKPLA_SW = 1, MKPLA_CPLR = 2, MKPLA_SWING = 3, MKPLA_ANGLESW = 4 };

typedef struct {
    int method, dim;
    int quaternion;   /* 1: samples are quaternions, made hemisphere-continuous before encoding */
    int done;
    uint32_t count;
    mkpla_real sign;                  /* sign applied to the last sample (+1 or -1) */
    mkpla_time last_t;
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
/* 1: a point in *p (values as passed for fastSW/SW/anglesw), 0: none, < 0: an MKPLA_E_* error for a
 * sample refused (the encoder unchanged: push the next one): MKPLA_E_NONFINITE, MKPLA_E_TIME,
 * MKPLA_E_ZERO (quaternion streams), MKPLA_E_DONE */
int mkpla_encoder_push(mkpla_encoder *e, mkpla_time t, const mkpla_real *x, mkpla_point *p);
int mkpla_encoder_flush(mkpla_encoder *e, mkpla_point *p);
/* n samples (t[i], x[i*dim .. i*dim+dim-1]); the points go to index[], ts[] and values[] (room for n
 * + 1 points, values dim per point). Returns the number of points, or an MKPLA_E_* error for a
 * refused sample: the batch stops there, *failed is its position, and the points of the samples
 * before it are in the arrays all the same, *made of them (the encoder as after those samples: the
 * next batch may start after the refused one). flush_at_end: also flush after the last sample.
 * failed and made may be NULL. */
long mkpla_encoder_push_many(mkpla_encoder *e, const mkpla_time *t, const mkpla_real *x, size_t n,
                             int flush_at_end, uint32_t *index, mkpla_time *ts, mkpla_real *values,
                             size_t *failed, size_t *made);

#ifdef __cplusplus
}
#endif
#endif /* MKPLA_H */
