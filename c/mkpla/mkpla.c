/*
 * mkpla — streaming PLA encoders (see mkpla.h). Every kernel mirrors its Python twin in
 * src/mocapkit/pla/ operation for operation, so the float64 build decides identically.
 */
/* No contraction of a*b + c into a fused multiply-add: it rounds once instead of twice, so the
 * decisions would depend on the compiler's flags and the target's FPU. Standard C says it with the
 * STDC pragma, which GCC ignores (with a warning): GCC gets its own. */
#if defined(__clang__) || !defined(__GNUC__)
#pragma STDC FP_CONTRACT OFF
#else
#pragma GCC optimize("fp-contract=off")
#endif
#if defined(__FAST_MATH__) || (defined(__FINITE_MATH_ONLY__) && __FINITE_MATH_ONLY__)
#error "mkpla: do not compile with -ffast-math or -ffinite-math-only (they drop the NaN checks and reorder sums)"
#endif

#include "mkpla.h"

#include <float.h>

#ifdef MKPLA_FLOAT32
#define R(x) x##f
#define MK_REAL_MIN FLT_MIN
#define MK_REAL_MAX FLT_MAX
/* ticks from a to b as a real: an exact integer difference, whatever the counter's value */
#define DT(b, a) ((mkpla_real)(uint32_t)((b) - (a)))
/* the segment anchored at s->ta may take a sample at t (its span stays countable) */
#define SPAN_OK(s, t) ((uint32_t)((t) - (s)->ta) <= MKPLA_MAX_SPAN)
#else
#define R(x) x
#define MK_REAL_MIN DBL_MIN
#define MK_REAL_MAX DBL_MAX
#define DT(b, a) ((b) - (a))
#define SPAN_OK(s, t) 1
#endif

/* ---- maths ----------------------------------------------------------------------------------
 * float64: the C library's sqrt, sin and atan2 (as the Python kernels use).
 * float32: sqrtf is correctly rounded everywhere (IEEE 754); sin and atan2 are computed here from
 * + - * / only, so a desktop and a Cortex-M4 get the same bits. The arguments are non-negative and
 * at most pi (angles on S^3), which keeps both short. Accuracy about 1e-7 relative, far inside the
 * anglesw slack below. */
#ifdef MKPLA_FLOAT32
#include <math.h>
#define MK_SQRT(x) sqrtf(x)
#define MK_PI 3.14159265358979f
#define MK_PI_2 1.57079632679490f
#define MK_PI_4 0.785398163397448f

static float mk_sin(float x) /* 0 <= x <= pi */
{
    float x2;
    if (x > MK_PI_2)
        x = MK_PI - x;
    x2 = x * x;
    /* Taylor series to x^13: truncation below 7e-10 on [0, pi/2] */
    return x * (1.0f - x2 / 6.0f * (1.0f - x2 / 20.0f * (1.0f - x2 / 42.0f * (1.0f - x2 / 72.0f
                * (1.0f - x2 / 110.0f * (1.0f - x2 / 156.0f))))));
}

static float mk_atan_small(float z) /* |z| <= tan(pi/8) */
{
    float z2 = z * z;
    /* Taylor series to z^17: truncation below 2e-8 for |z| <= 0.4143 */
    return z * (1.0f - z2 * (1.0f / 3.0f - z2 * (1.0f / 5.0f - z2 * (1.0f / 7.0f - z2 * (1.0f / 9.0f
                - z2 * (1.0f / 11.0f - z2 * (1.0f / 13.0f - z2 * (1.0f / 15.0f - z2 / 17.0f))))))));
}

static float mk_atan2(float y, float x) /* y >= 0, x >= 0, not both 0 */
{
    float z, a;
    int swap = y > x;
    z = swap ? x / y : y / x; /* 0 <= z <= 1 */
    if (z > 0.414213562f)
        a = MK_PI_4 + mk_atan_small((z - 1.0f) / (z + 1.0f));
    else
        a = mk_atan_small(z);
    return swap ? MK_PI_2 - a : a;
}
#define MK_SIN(x) mk_sin(x)
#define MK_ATAN2(y, x) mk_atan2(y, x)
/* anglesw's reserve for float32 rounding: inputs rounded to float (about 1e-7 rad), the SLERP and
 * the angle evaluated in float (a few 1e-7 rad) and sin/atan2 above; 1e-5 rad (0.00057 degrees) is
 * ten times the sum. The tests check the bound on the decoded output of every shared recording. */
#define MKPLA_ANGLE_SLACK 1e-5f
#else
#include <math.h>
#define MK_SQRT(x) sqrt(x)
#define MK_SIN(x) sin(x)
#define MK_ATAN2(y, x) atan2(y, x)
#define MKPLA_ANGLE_SLACK 0.0
#endif

static int bad_real(mkpla_real v) { return !(v >= 0); } /* NaN or negative */

static int finite_real(mkpla_real v) { return v - v == 0; } /* neither NaN nor infinite */

static void emit(mkpla_point *p, uint32_t index, mkpla_time t, const mkpla_real *v, int dim)
{
    int d;
    p->index = index;
    p->t = t;
    for (d = 0; d < dim; d++)
        p->v[d] = v[d];
}

static int check_dim(int dim) { return dim >= 1 && dim <= MKPLA_MAX_DIM; }

/* ======================================= fastSW ============================================= */

int mkpla_fastsw_init(mkpla_fastsw *s, int dim, mkpla_real threshold, uint32_t maxlen)
{
    if (!check_dim(dim) || bad_real(threshold))
        return MKPLA_E_PARAM;
    s->dim = dim;
    s->th = threshold;
    s->maxlen = maxlen;
    s->count = 0;
    s->n = 0;
    return MKPLA_OK;
}

/* Algorithm 1, PROCESS_SAMPLE, for a dimension D the compiler may know (inlined twice below) */
static inline int fastsw_step(mkpla_fastsw *s, mkpla_time t, const mkpla_real *restrict x, mkpla_point *p,
                              const int D)
{
    int d;
    uint32_t n = s->n + 1;                       /* line 2 */
    mkpla_real nr = (mkpla_real)n;
    mkpla_real tn = DT(t, s->ta);                /* line 4 */
    mkpla_real t2 = s->t2m;
    mkpla_real ssr = 0;                          /* line 3 */
    for (d = 0; d < D; d++) {                    /* lines 5-8: Eq. 13 with the means of n - 1 samples */
        mkpla_real y = x[d] - s->av[d];
        mkpla_real beta = y / tn;                /* Eq. 4 */
        ssr += (s->y2m[d] - 2 * beta * s->tym[d] + beta * beta * t2) * (nr - 1);
    }
    if (ssr <= s->th && (s->maxlen == 0 || n <= s->maxlen) && SPAN_OK(s, t)) { /* line 9 */
        mkpla_real rn = 1 / nr;
        s->t2m = t2 + (tn * tn - t2) * rn;       /* line 10, Eq. 12 */
        for (d = 0; d < D; d++) {
            mkpla_real y = x[d] - s->av[d];
            s->tym[d] = s->tym[d] + (tn * y - s->tym[d]) * rn; /* line 12, Eq. 11 */
            s->y2m[d] = s->y2m[d] + (y * y - s->y2m[d]) * rn;  /* line 13, Eq. 10 */
            s->pv[d] = x[d];                                   /* line 14 */
        }
        s->tp = t;
        s->n = n;
        s->count++;
        return 0;                                /* line 15 */
    }
    /* lines 16-25: s_{n-1} becomes the new segment point, s_n starts the new segment */
    emit(p, s->count - 1, s->tp, s->pv, D);
    s->ta = s->tp;
    tn = DT(t, s->ta);                           /* line 19 */
    s->t2m = tn * tn;                            /* line 20 */
    for (d = 0; d < D; d++) {
        mkpla_real y;
        s->av[d] = s->pv[d];
        y = x[d] - s->av[d];                     /* line 22 */
        s->tym[d] = tn * y;                      /* line 23 */
        s->y2m[d] = y * y;                       /* line 24 */
        s->pv[d] = x[d];
    }
    s->tp = t;
    s->n = 1;                                    /* line 18 */
    s->count++;
    return 1;
}

int mkpla_fastsw_push(mkpla_fastsw *s, mkpla_time t, const mkpla_real *x, mkpla_point *p)
{
    int d;
    if (s->count == 0) { /* the very first sample is the initial segment point */
        s->ta = t;
        s->tp = t;
        s->t2m = 0;
        s->n = 0;
        for (d = 0; d < s->dim; d++) {
            s->av[d] = x[d];
            s->pv[d] = x[d];
            s->tym[d] = 0;
            s->y2m[d] = 0;
        }
        s->count = 1;
        emit(p, 0, t, x, s->dim);
        return 1;
    }
    if (s->dim == 4)
        return fastsw_step(s, t, x, p, 4);
    return fastsw_step(s, t, x, p, s->dim);
}

int mkpla_fastsw_flush(mkpla_fastsw *s, mkpla_point *p)
{
    if (s->n == 0)
        return 0;
    s->ta = s->tp;
    for (int d = 0; d < s->dim; d++)
        s->av[d] = s->pv[d];
    s->n = 0;
    emit(p, s->count - 1, s->tp, s->pv, s->dim);
    return 1;
}

/* ========================================= SW =============================================== */

int mkpla_sw_init(mkpla_sw *s, int dim, mkpla_real threshold, uint32_t maxlen, mkpla_real *buffer,
                  size_t buffer_len)
{
    if (!check_dim(dim) || bad_real(threshold) || maxlen == 0)
        return MKPLA_E_PARAM;
    /* buffer_len >= maxlen (dim + 1), without a product that could wrap around (32-bit size_t) */
    if (buffer == NULL || buffer_len / (size_t)(dim + 1) < (size_t)maxlen)
        return MKPLA_E_BUFFER;
    s->dim = dim;
    s->th = threshold;
    s->maxlen = maxlen;
    s->count = 0;
    s->n = 0;
    s->bt = buffer;
    s->bx = buffer + maxlen;
    return MKPLA_OK;
}

static inline int sw_step(mkpla_sw *s, mkpla_time t, const mkpla_real *x, mkpla_point *p, const int D)
{
    int d;
    uint32_t j, n = s->n + 1;
    mkpla_real tn = DT(t, s->ta);
    if (n <= s->maxlen && SPAN_OK(s, t)) {
        mkpla_real ssr = 0;
        for (d = 0; d < D; d++) {
            mkpla_real beta = (x[d] - s->av[d]) / tn;   /* slope, Eq. 4 */
            for (j = 0; j + 1 < n; j++) {                /* Eq. 5 over s_1..s_{n-1} */
                mkpla_real r = s->bx[(size_t)j * D + d] - beta * s->bt[j]; /* relative to the anchor */
                ssr += r * r;
            }
        }
        if (ssr <= s->th) {
            s->bt[n - 1] = tn;
            for (d = 0; d < D; d++) {
                s->bx[(size_t)(n - 1) * D + d] = x[d] - s->av[d];
                s->pv[d] = x[d];
            }
            s->tp = t;
            s->n = n;
            s->count++;
            return 0;
        }
    }
    emit(p, s->count - 1, s->tp, s->pv, D);
    s->ta = s->tp;
    for (d = 0; d < D; d++) {
        s->av[d] = s->pv[d];
        s->pv[d] = x[d];
        s->bx[d] = x[d] - s->av[d];
    }
    s->bt[0] = DT(t, s->ta);
    s->tp = t;
    s->n = 1;
    s->count++;
    return 1;
}

int mkpla_sw_push(mkpla_sw *s, mkpla_time t, const mkpla_real *x, mkpla_point *p)
{
    int d;
    if (s->count == 0) {
        s->ta = t;
        s->tp = t;
        s->n = 0;
        for (d = 0; d < s->dim; d++) {
            s->av[d] = x[d];
            s->pv[d] = x[d];
        }
        s->count = 1;
        emit(p, 0, t, x, s->dim);
        return 1;
    }
    if (s->dim == 4)
        return sw_step(s, t, x, p, 4);
    return sw_step(s, t, x, p, s->dim);
}

int mkpla_sw_flush(mkpla_sw *s, mkpla_point *p)
{
    if (s->n == 0)
        return 0;
    s->ta = s->tp;
    for (int d = 0; d < s->dim; d++)
        s->av[d] = s->pv[d];
    s->n = 0;
    emit(p, s->count - 1, s->tp, s->pv, s->dim);
    return 1;
}

/* ======================================== CPLR ============================================== */

int mkpla_cplr_init(mkpla_cplr *s, int dim, mkpla_real threshold, uint32_t maxlen)
{
    if (!check_dim(dim) || bad_real(threshold))
        return MKPLA_E_PARAM;
    s->dim = dim;
    s->th = threshold;
    s->maxlen = maxlen;
    s->count = 0;
    s->n = 0;
    return MKPLA_OK;
}

/* move the anchor to the segment's regression line at t_prev */
static inline void cplr_end(mkpla_cplr *s, const int D)
{
    mkpla_real tp = DT(s->tp, s->ta);
    for (int d = 0; d < D; d++)
        s->av[d] = s->av[d] + s->tym[d] / s->t2m * tp;
    s->ta = s->tp;
}

/* s_n as the only sample of a new segment anchored at (ta, av) */
static inline void cplr_restart(mkpla_cplr *s, mkpla_time t, const mkpla_real *x, const int D)
{
    mkpla_real tn = DT(t, s->ta);
    s->t2m = tn * tn;
    for (int d = 0; d < D; d++) {
        mkpla_real y = x[d] - s->av[d];
        s->tym[d] = tn * y;
        s->y2m[d] = y * y;
    }
    s->tp = t;
    s->n = 1;
}

static inline int cplr_step(mkpla_cplr *s, mkpla_time t, const mkpla_real *restrict x, mkpla_point *p,
                            const int D)
{
    int d;
    uint32_t n = s->n + 1;
    mkpla_real nr = (mkpla_real)n;
    mkpla_real tn = DT(t, s->ta);
    mkpla_real rn = 1 / nr;
    mkpla_real t2 = s->t2m + (tn * tn - s->t2m) * rn;
    int ok = (s->maxlen == 0 || n <= s->maxlen) && SPAN_OK(s, t);
    if (ok && n > 1) {
        mkpla_real ssr = 0;
        for (d = 0; d < D; d++) {
            mkpla_real y = x[d] - s->av[d];
            mkpla_real ty = s->tym[d] + (tn * y - s->tym[d]) * rn;
            mkpla_real y2 = s->y2m[d] + (y * y - s->y2m[d]) * rn;
            ssr += (y2 - ty * ty / t2) * nr;
        }
        ok = ssr <= s->th;
    }
    if (ok) {
        s->t2m = t2;
        for (d = 0; d < D; d++) {
            mkpla_real y = x[d] - s->av[d];
            s->tym[d] = s->tym[d] + (tn * y - s->tym[d]) * rn;
            s->y2m[d] = s->y2m[d] + (y * y - s->y2m[d]) * rn;
        }
        s->tp = t;
        s->n = n;
        s->count++;
        return 0;
    }
    cplr_end(s, D);
    emit(p, s->count - 1, s->ta, s->av, D);
    cplr_restart(s, t, x, D);
    s->count++;
    return 1;
}

int mkpla_cplr_push(mkpla_cplr *s, mkpla_time t, const mkpla_real *x, mkpla_point *p)
{
    int d;
    if (s->count == 0) {
        s->ta = t;
        s->tp = t;
        s->t2m = 0;
        s->n = 0;
        for (d = 0; d < s->dim; d++) {
            s->av[d] = x[d];
            s->tym[d] = 0;
            s->y2m[d] = 0;
        }
        s->count = 1;
        emit(p, 0, t, x, s->dim);
        return 1;
    }
    if (s->dim == 4)
        return cplr_step(s, t, x, p, 4);
    return cplr_step(s, t, x, p, s->dim);
}

int mkpla_cplr_flush(mkpla_cplr *s, mkpla_point *p)
{
    if (s->n == 0)
        return 0;
    cplr_end(s, s->dim);
    s->n = 0;
    emit(p, s->count - 1, s->ta, s->av, s->dim);
    return 1;
}

/* ==================================== Swing Filter ========================================== */

int mkpla_swing_init(mkpla_swing *s, int dim, mkpla_real eps, uint32_t maxlen)
{
    if (!check_dim(dim) || bad_real(eps))
        return MKPLA_E_PARAM;
    s->dim = dim;
    s->eps = eps;
    s->maxlen = maxlen;
    s->count = 0;
    s->n = 0;
    return MKPLA_OK;
}

/* s_n as the first sample of a segment anchored at (ta, av): the initial slope bounds */
static inline void swing_restart(mkpla_swing *s, mkpla_time t, const mkpla_real *x, const int D)
{
    mkpla_real tn = DT(t, s->ta);
    s->t2m = tn * tn;
    for (int d = 0; d < D; d++) {
        mkpla_real y = x[d] - s->av[d];
        s->tym[d] = tn * y;
        s->up[d] = (y + s->eps) / tn;
        s->lo[d] = (y - s->eps) / tn;
    }
    s->tp = t;
    s->n = 1;
}

/* move the anchor to t_prev along the least-squares slope clamped into [lo, up] */
static inline void swing_end(mkpla_swing *s, const int D)
{
    mkpla_real tp = DT(s->tp, s->ta);
    for (int d = 0; d < D; d++) {
        mkpla_real sl = s->tym[d] / s->t2m;
        if (sl > s->up[d])
            sl = s->up[d];
        if (sl < s->lo[d])
            sl = s->lo[d];
        s->av[d] = s->av[d] + sl * tp;
    }
    s->ta = s->tp;
}

static inline int swing_step(mkpla_swing *s, mkpla_time t, const mkpla_real *x, mkpla_point *p, const int D)
{
    int d, ok;
    uint32_t n = s->n + 1;
    mkpla_real tn;
    if (n == 1) {
        swing_restart(s, t, x, D);
        s->count++;
        return 0;
    }
    tn = DT(t, s->ta);
    ok = (s->maxlen == 0 || n <= s->maxlen) && SPAN_OK(s, t);
    if (ok) {
        for (d = 0; d < D; d++) {
            mkpla_real y = x[d] - s->av[d];
            if ((y + s->eps) / tn < s->lo[d] || (y - s->eps) / tn > s->up[d]) {
                ok = 0;
                break;
            }
        }
    }
    if (ok) {
        mkpla_real rn = 1 / (mkpla_real)n;
        s->t2m = s->t2m + (tn * tn - s->t2m) * rn;
        for (d = 0; d < D; d++) {
            mkpla_real y = x[d] - s->av[d];
            mkpla_real hi = (y + s->eps) / tn;
            mkpla_real lw = (y - s->eps) / tn;
            if (hi < s->up[d])
                s->up[d] = hi;
            if (lw > s->lo[d])
                s->lo[d] = lw;
            s->tym[d] = s->tym[d] + (tn * y - s->tym[d]) * rn;
        }
        s->tp = t;
        s->n = n;
        s->count++;
        return 0;
    }
    swing_end(s, D);
    emit(p, s->count - 1, s->ta, s->av, D);
    swing_restart(s, t, x, D);
    s->count++;
    return 1;
}

int mkpla_swing_push(mkpla_swing *s, mkpla_time t, const mkpla_real *x, mkpla_point *p)
{
    int d;
    if (s->count == 0) {
        s->ta = t;
        s->tp = t;
        s->t2m = 0;
        s->n = 0;
        for (d = 0; d < s->dim; d++)
            s->av[d] = x[d];
        s->count = 1;
        emit(p, 0, t, x, s->dim);
        return 1;
    }
    if (s->dim == 4)
        return swing_step(s, t, x, p, 4);
    return swing_step(s, t, x, p, s->dim);
}

int mkpla_swing_flush(mkpla_swing *s, mkpla_point *p)
{
    if (s->n == 0)
        return 0;
    swing_end(s, s->dim);
    s->n = 0;
    emit(p, s->count - 1, s->ta, s->av, s->dim);
    return 1;
}

/* ======================================= anglesw ============================================ */

int mkpla_anglesw_init(mkpla_anglesw *s, mkpla_real max_angle_rad, uint32_t maxlen, mkpla_real *buffer,
                       size_t buffer_len)
{
    if (bad_real(max_angle_rad) || maxlen == 0 || maxlen > 0x7fffffffu)
        return MKPLA_E_PARAM;
    if (buffer == NULL || buffer_len / 5u < (size_t)maxlen) /* buffer_len >= 5 maxlen, without wrapping */
        return MKPLA_E_BUFFER;
    s->th = max_angle_rad > MKPLA_ANGLE_SLACK ? max_angle_rad - MKPLA_ANGLE_SLACK : 0;
    s->maxlen = maxlen;
    s->count = 0;
    s->n = 0;
    s->failed = -1;
    s->bt = buffer;
    s->bq = buffer + maxlen;
    return MKPLA_OK;
}

static inline void normalised(const mkpla_real *x, mkpla_real *q)
{
    mkpla_real nrm = MK_SQRT(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3]);
    for (int d = 0; d < 4; d++)
        q[d] = x[d] / nrm;
}

/* the arc from a to b, computed once per push */
typedef struct { mkpla_real sg, om, so; int same; } arc;

static void arc_of(const mkpla_real *a, const mkpla_real *b, arc *r)
{
    int k;
    mkpla_real c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
    mkpla_real sg = c < 0 ? -1 : 1;
    mkpla_real d2 = 0, s2 = 0;
    for (k = 0; k < 4; k++) {
        mkpla_real dk = a[k] - sg * b[k];
        mkpla_real sk = a[k] + sg * b[k];
        d2 += dk * dk;
        s2 += sk * sk;
    }
    r->sg = sg;
    r->same = d2 == 0;
    r->om = 0;
    r->so = 0;
    if (!r->same) {
        r->om = 2 * MK_ATAN2(MK_SQRT(d2), MK_SQRT(s2));
        r->so = MK_SIN(r->om);
    }
}

static void slerp_unit(const mkpla_real *a, const mkpla_real *b, const arc *r, mkpla_real f, mkpla_real *out)
{
    int k;
    mkpla_real w0, w1, nn = 0, sg = r->sg;
    if (r->same) {
        for (k = 0; k < 4; k++)
            out[k] = a[k];
        return;
    }
    if (r->so < R(1e-12)) {
        w0 = 1 - f;
        w1 = f;
    } else {
        w0 = MK_SIN((1 - f) * r->om) / r->so;
        w1 = MK_SIN(f * r->om) / r->so;
    }
    for (k = 0; k < 4; k++) {
        out[k] = w0 * a[k] + w1 * sg * b[k];
        nn += out[k] * out[k];
    }
    nn = MK_SQRT(nn);
    for (k = 0; k < 4; k++)
        out[k] /= nn;
}

/* rotation angle between two quaternions of any non-zero norm, Eq. 2 in its stable form
 * (quat._angle_between) */
static mkpla_real angle_between(const mkpla_real *a, const mkpla_real *b)
{
    mkpla_real na = MK_SQRT(a[0] * a[0] + a[1] * a[1] + a[2] * a[2] + a[3] * a[3]);
    mkpla_real nb = MK_SQRT(b[0] * b[0] + b[1] * b[1] + b[2] * b[2] + b[3] * b[3]);
    mkpla_real a0 = a[0] / na, a1 = a[1] / na, a2 = a[2] / na, a3 = a[3] / na;
    mkpla_real b0 = b[0] / nb, b1 = b[1] / nb, b2 = b[2] / nb, b3 = b[3] / nb;
    mkpla_real d0, d1, d2, d3, s0, s1, s2, s3;
    if (a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3 < 0) {
        b0 = -b0;
        b1 = -b1;
        b2 = -b2;
        b3 = -b3;
    }
    d0 = a0 - b0;
    d1 = a1 - b1;
    d2 = a2 - b2;
    d3 = a3 - b3;
    s0 = a0 + b0;
    s1 = a1 + b1;
    s2 = a2 + b2;
    s3 = a3 + b3;
    return 4 * MK_ATAN2(MK_SQRT(d0 * d0 + d1 * d1 + d2 * d2 + d3 * d3), MK_SQRT(s0 * s0 + s1 * s1 + s2 * s2 + s3 * s3));
}

/* angle between buffered sample j and the SLERP decode at its time, for a segment ending at (t, qn) */
static mkpla_real deviation(const mkpla_anglesw *s, uint32_t j, mkpla_real tn, const mkpla_real *qn, const arc *r)
{
    mkpla_real tmp[4];
    mkpla_real f = s->bt[j] / tn;
    slerp_unit(s->qa, qn, r, f, tmp);
    return angle_between(s->bq + 4 * (size_t)j, tmp);
}

/* a deviation beyond the bound; NaN counts as beyond, so nothing unforeseen can extend a segment */
#define BEYOND(dev, th) (!((dev) <= (th)))

int mkpla_anglesw_push(mkpla_anglesw *s, mkpla_time t, const mkpla_real *q, mkpla_point *p)
{
    int d, ok;
    uint32_t j, n;
    mkpla_real qn[4];
    if (s->count == 0) {
        normalised(q, s->qa);
        normalised(q, s->qp);
        s->ta = t;
        s->tp = t;
        s->n = 0;
        s->failed = -1;
        s->count = 1;
        emit(p, 0, t, s->qa, 4);
        return 1;
    }
    n = s->n + 1;
    normalised(q, qn);
    ok = n <= s->maxlen && SPAN_OK(s, t);
    if (ok && n > 1) {
        int32_t first = s->failed;
        mkpla_real tn = DT(t, s->ta);
        arc r;
        arc_of(s->qa, qn, &r);
        if (first >= 0 && (uint32_t)first < n - 1 && BEYOND(deviation(s, (uint32_t)first, tn, qn, &r), s->th)) {
            ok = 0;
        } else {
            for (j = 0; j + 1 < n; j++) {
                if (BEYOND(deviation(s, j, tn, qn, &r), s->th)) {
                    ok = 0;
                    s->failed = (int32_t)j;
                    break;
                }
            }
        }
    }
    if (ok) {
        s->bt[n - 1] = DT(t, s->ta);
        for (d = 0; d < 4; d++) {
            s->bq[4 * (size_t)(n - 1) + d] = qn[d];
            s->qp[d] = qn[d];
        }
        s->tp = t;
        s->n = n;
        s->count++;
        return 0;
    }
    emit(p, s->count - 1, s->tp, s->qp, 4);
    s->ta = s->tp;
    for (d = 0; d < 4; d++) {
        s->qa[d] = s->qp[d];
        s->qp[d] = qn[d];
        s->bq[d] = qn[d];
    }
    s->bt[0] = DT(t, s->ta);
    s->tp = t;
    s->n = 1;
    s->failed = -1;
    s->count++;
    return 1;
}

int mkpla_anglesw_flush(mkpla_anglesw *s, mkpla_point *p)
{
    if (s->n == 0)
        return 0;
    s->ta = s->tp;
    for (int d = 0; d < 4; d++)
        s->qa[d] = s->qp[d];
    s->n = 0;
    emit(p, s->count - 1, s->tp, s->qp, 4);
    return 1;
}

/* ================================= one encoder, checked ===================================== */

int mkpla_encoder_init(mkpla_encoder *e, int method, int dim, int quaternion, mkpla_real threshold,
                       uint32_t maxlen, mkpla_real *buffer, size_t buffer_len)
{
    int rc;
    if (quaternion && dim != 4)
        return MKPLA_E_PARAM;
    e->method = method;
    e->dim = dim;
    e->quaternion = quaternion != 0;
    e->done = 0;
    e->count = 0;
    e->sign = 1;
    e->last_t = 0;
    switch (method) {
    case MKPLA_FASTSW: rc = mkpla_fastsw_init(&e->u.fastsw, dim, threshold, maxlen); break;
    case MKPLA_SW: rc = mkpla_sw_init(&e->u.sw, dim, threshold, maxlen, buffer, buffer_len); break;
    case MKPLA_CPLR: rc = mkpla_cplr_init(&e->u.cplr, dim, threshold, maxlen); break;
    case MKPLA_SWING: rc = mkpla_swing_init(&e->u.swing, dim, threshold, maxlen); break;
    case MKPLA_ANGLESW:
        rc = quaternion ? mkpla_anglesw_init(&e->u.anglesw, threshold, maxlen, buffer, buffer_len) : MKPLA_E_PARAM;
        break;
    default: rc = MKPLA_E_PARAM;
    }
    return rc;
}

/* Why the sample (t, x) cannot be encoded next (an MKPLA_E_* code), or MKPLA_OK. Reads only. */
static int refused(const mkpla_encoder *e, mkpla_time t, const mkpla_real *x)
{
    int d, ok = 1;
#ifdef MKPLA_FLOAT32
    uint32_t step = (uint32_t)(t - e->last_t);
#else
    ok = finite_real(t);
#endif
    for (d = 0; d < e->dim; d++)
        ok &= finite_real(x[d]);
    if (!ok)
        return MKPLA_E_NONFINITE;
#ifdef MKPLA_FLOAT32
    if (e->count > 0 && (step == 0 || step > MKPLA_MAX_SPAN))
        return MKPLA_E_TIME;
#else
    if (e->count > 0 && !(t > e->last_t))
        return MKPLA_E_TIME;
#endif
    if (e->quaternion) { /* normalisable: a normal, finite squared norm */
        mkpla_real n2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3];
        if (!(n2 >= MK_REAL_MIN && n2 <= MK_REAL_MAX))
            return MKPLA_E_ZERO;
    }
    return MKPLA_OK;
}

int mkpla_encoder_push(mkpla_encoder *e, mkpla_time t, const mkpla_real *x, mkpla_point *p)
{
    mkpla_real y[MKPLA_MAX_DIM];
    const mkpla_real *v = x;
    int d, rc;
    if (e->done)
        return MKPLA_E_DONE;
    rc = refused(e, t, x);
    if (rc != MKPLA_OK)
        return rc; /* nothing changed: the encoder takes the next sample as if this one never came */
    if (e->quaternion) {
        if (e->count > 0) { /* as quat.hemisphere_continuous: against the sample as passed */
            mkpla_real dot = x[0] * e->last[0] + x[1] * e->last[1] + x[2] * e->last[2] + x[3] * e->last[3];
            e->sign = e->sign * dot < 0 ? -1 : 1;
        }
        for (d = 0; d < 4; d++)
            y[d] = e->sign * x[d];
        v = y;
    }
    switch (e->method) {
    case MKPLA_FASTSW: rc = mkpla_fastsw_push(&e->u.fastsw, t, v, p); break;
    case MKPLA_SW: rc = mkpla_sw_push(&e->u.sw, t, v, p); break;
    case MKPLA_CPLR: rc = mkpla_cplr_push(&e->u.cplr, t, v, p); break;
    case MKPLA_SWING: rc = mkpla_swing_push(&e->u.swing, t, v, p); break;
    default: rc = mkpla_anglesw_push(&e->u.anglesw, t, v, p); break;
    }
    /* fastSW, SW and anglesw emit original samples: give them back as passed */
    if (rc == 1 && e->method != MKPLA_CPLR && e->method != MKPLA_SWING) {
        const mkpla_real *src = p->index == e->count ? x : e->last;
        for (d = 0; d < e->dim; d++)
            p->v[d] = src[d];
    }
    for (d = 0; d < e->dim; d++)
        e->last[d] = x[d];
    e->last_t = t;
    e->count++;
    return rc;
}

int mkpla_encoder_flush(mkpla_encoder *e, mkpla_point *p)
{
    int d, rc;
    if (e->done)
        return 0;
    e->done = 1;
    if (e->count == 0)
        return 0;
    switch (e->method) {
    case MKPLA_FASTSW: rc = mkpla_fastsw_flush(&e->u.fastsw, p); break;
    case MKPLA_SW: rc = mkpla_sw_flush(&e->u.sw, p); break;
    case MKPLA_CPLR: rc = mkpla_cplr_flush(&e->u.cplr, p); break;
    case MKPLA_SWING: rc = mkpla_swing_flush(&e->u.swing, p); break;
    default: rc = mkpla_anglesw_flush(&e->u.anglesw, p); break;
    }
    if (rc == 1 && e->method != MKPLA_CPLR && e->method != MKPLA_SWING)
        for (d = 0; d < e->dim; d++)
            p->v[d] = e->last[d];
    return rc;
}

long mkpla_encoder_push_many(mkpla_encoder *e, const mkpla_time *t, const mkpla_real *x, size_t n,
                             int flush_at_end, uint32_t *index, mkpla_time *ts, mkpla_real *values,
                             size_t *failed, size_t *made)
{
    size_t i;
    long m = 0;
    int d, rc;
    mkpla_point p;
    for (i = 0; i < n; i++) {
        rc = mkpla_encoder_push(e, t[i], x + i * (size_t)e->dim, &p);
        if (rc < 0) {
            if (failed)
                *failed = i;
            if (made)
                *made = (size_t)m;
            return rc;
        }
        if (rc) {
            index[m] = p.index;
            ts[m] = p.t;
            for (d = 0; d < e->dim; d++)
                values[(size_t)m * (size_t)e->dim + d] = p.v[d];
            m++;
        }
    }
    if (flush_at_end && mkpla_encoder_flush(e, &p)) {
        index[m] = p.index;
        ts[m] = p.t;
        for (d = 0; d < e->dim; d++)
            values[(size_t)m * (size_t)e->dim + d] = p.v[d];
        m++;
    }
    if (made)
        *made = (size_t)m;
    return m;
}
