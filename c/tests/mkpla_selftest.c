/*
 * C tests of mkpla and mkp that need no Python: run on the host (64- and 32-bit, both precisions, the
 * compiler's default flags) and on the Cortex-M4 under QEMU (c/mcu: selftest.elf). tests/test_native.py
 * and tests/test_mcu.py build and run it; it prints one line per failed check and a summary, and
 * returns non-zero on any failure.
 *
 * 1. Buffer size checks do not wrap around a 32-bit size_t (L = 858,993,460 needs 5 L = 2^32 + 4 reals).
 * 2. The checked API refuses NaN/Inf times and components, zero, subnormal- and overflowing-norm
 *    quaternions and out-of-order times with their codes, and a refused sample changes nothing: the
 *    points equal those of the same stream without the bad samples (push and push_many).
 * 3. mkp refuses NaN/Inf and zero quaternions; the packets equal those of the stream without them.
 * 4. float32: times are 32-bit ticks; a stream decides the same points whatever its first tick
 *    (0, 36 h of milliseconds, or just before the counter wraps), steps of 0 or more than
 *    MKPLA_MAX_SPAN ticks are refused, and a segment ends before it spans more than MKPLA_MAX_SPAN.
 */
#include <float.h>
#include <stdint.h>
#include <string.h>

#include "mkp.h"
#include "mkpla.h"

#ifdef SELFTEST_SEMIHOST
#include "semihost.h"
static void say(const char *s) { sh_puts(s); }
#else
#include <stdio.h>
static void say(const char *s) { fputs(s, stdout); }
#endif

static int checks, failures;

static void say_num(unsigned long v)
{
    char buf[24];
    int i = 23;
    buf[i] = 0;
    do {
        buf[--i] = (char)('0' + v % 10u);
        v /= 10u;
    } while (v);
    say(buf + i);
}

static void check_(int ok, const char *what, int line)
{
    checks++;
    if (ok)
        return;
    failures++;
    say("FAIL line ");
    say_num((unsigned long)line);
    say(": ");
    say(what);
    say("\n");
}
#define CHECK(cond, what) check_((cond) ? 1 : 0, what, __LINE__)

/* ---- a test signal: a quaternion random walk (no libm) --------------------------------------- */

#define N 400
static mkpla_real sig[N][4];
static uint32_t rng = 12345u;

static mkpla_real noise(void) /* about uniform in [-1, 1) */
{
    rng = rng * 1664525u + 1013904223u;
    return (mkpla_real)((int32_t)(rng >> 8) - (1 << 23)) / (mkpla_real)(1 << 23);
}

static void make_signal(void)
{
    mkpla_real q[4] = {1, 0, 0, 0};
    int i, d;
    for (i = 0; i < N; i++) {
        mkpla_real step = i % 97 < 40 ? (mkpla_real)0.0005 : (mkpla_real)0.02; /* still and moving stretches */
        for (d = 1; d < 4; d++)
            q[d] += step * noise();
        for (d = 0; d < 4; d++)
            sig[i][d] = q[d];
    }
}

#ifdef MKPLA_FLOAT32
static mkpla_time tick_of(int i, mkpla_time t0) { return t0 + (mkpla_time)(10 * i); } /* 10 ms apart */
#else
static mkpla_time tick_of(int i, mkpla_time t0) { return t0 + (mkpla_real)0.01 * (mkpla_real)i; }
#endif

/* ---- 1. buffer sizes ------------------------------------------------------------------------ */

static mkpla_real small_buf[32];

static void test_sizes(void)
{
    mkpla_sw sw;
    mkpla_anglesw asw;
    mkpla_encoder enc;
    mkp_packetiser pk;
    const uint32_t wrap5 = 858993460u;  /* 5 * L = 2^32 + 4 */
    const uint32_t wrap4 = 1073741824u; /* 4 * L = 2^32 */
    CHECK(mkpla_anglesw_init(&asw, (mkpla_real)0.01, wrap5, small_buf, 4) == MKPLA_E_BUFFER,
          "anglesw: L = 858993460 with a 4-real buffer refused");
    CHECK(mkpla_sw_init(&sw, 4, (mkpla_real)0.01, wrap5, small_buf, 4) == MKPLA_E_BUFFER,
          "SW: L = 858993460, D = 4 with a 4-real buffer refused");
    CHECK(mkpla_sw_init(&sw, 3, (mkpla_real)0.01, wrap4, small_buf, 0) == MKPLA_E_BUFFER,
          "SW: L = 2^30, D = 3 with an empty buffer refused");
    CHECK(mkpla_encoder_init(&enc, MKPLA_ANGLESW, 4, 1, (mkpla_real)0.01, wrap5, small_buf, 4) == MKPLA_E_BUFFER,
          "encoder anglesw: L = 858993460 with a 4-real buffer refused");
    CHECK(mkpla_encoder_init(&enc, MKPLA_SW, 4, 1, (mkpla_real)0.01, wrap5, small_buf, 4) == MKPLA_E_BUFFER,
          "encoder SW: L = 858993460 with a 4-real buffer refused");
    CHECK(mkp_init(&pk, 0, (mkpla_real)0.1, 12, 20, wrap5, small_buf, 4) == MKPLA_E_BUFFER,
          "mkp: L = 858993460 with a 4-real buffer refused");
#if SIZE_MAX / 5u < 858993460u /* a 32-bit size_t: no buffer can be large enough */
    CHECK(mkpla_anglesw_init(&asw, (mkpla_real)0.01, wrap5, small_buf, SIZE_MAX) == MKPLA_E_BUFFER,
          "anglesw: 5 L beyond SIZE_MAX refused whatever buffer_len says");
    CHECK(mkpla_sw_init(&sw, 3, (mkpla_real)0.01, wrap4, small_buf, SIZE_MAX) == MKPLA_E_BUFFER,
          "SW: 4 L beyond SIZE_MAX refused whatever buffer_len says");
#endif
    /* the exact limits */
    CHECK(mkpla_anglesw_init(&asw, (mkpla_real)0.01, 3, small_buf, 15) == MKPLA_OK, "anglesw: 15 reals for L = 3");
    CHECK(mkpla_anglesw_init(&asw, (mkpla_real)0.01, 3, small_buf, 14) == MKPLA_E_BUFFER, "anglesw: 14 reals for L = 3");
    CHECK(mkpla_sw_init(&sw, 2, (mkpla_real)0.01, 4, small_buf, 12) == MKPLA_OK, "SW: 12 reals for L = 4, D = 2");
    CHECK(mkpla_sw_init(&sw, 2, (mkpla_real)0.01, 4, small_buf, 11) == MKPLA_E_BUFFER, "SW: 11 reals for L = 4, D = 2");
}

/* ---- 2. the checked API refuses bad samples and changes nothing ------------------------------ */

#define MAX_L 64
static mkpla_real buf_a[MKPLA_SW_BUFFER_LEN(MAX_L, 4)], buf_b[MKPLA_SW_BUFFER_LEN(MAX_L, 4)];
static mkpla_point pts_a[N + 1], pts_b[N + 1];
static uint32_t idx_a[N + 1], idx_b[N + 1];
static mkpla_time ts_a[N + 1], ts_b[N + 1];
static mkpla_real val_a[4 * (N + 1)], val_b[4 * (N + 1)];

static int same_points(const mkpla_point *a, const mkpla_point *b, int n)
{
    int i;
    for (i = 0; i < n; i++)
        if (a[i].index != b[i].index || a[i].t != b[i].t || memcmp(a[i].v, b[i].v, sizeof a[i].v) != 0)
            return 0;
    return 1;
}

static mkpla_real tiny(void) /* a component whose square underflows below the smallest normal */
{
#ifdef MKPLA_FLOAT32
    return 1e-20f;
#else
    return 1e-160;
#endif
}

static mkpla_real huge(void) /* a component whose square overflows */
{
#ifdef MKPLA_FLOAT32
    return 1e20f;
#else
    return 1e160;
#endif
}

static void test_refusals(int method, mkpla_real th, uint32_t maxlen)
{
    mkpla_encoder a, b;
    mkpla_point p;
    int i, k, na = 0, nb = 0, rc;
    volatile mkpla_real zero = 0;
    mkpla_real nan = zero / zero, inf = 1 / zero;
    mkpla_real bad[6][4];
    int code[6] = {MKPLA_E_NONFINITE, MKPLA_E_NONFINITE, MKPLA_E_NONFINITE, MKPLA_E_ZERO, MKPLA_E_ZERO, MKPLA_E_ZERO};
    size_t failed = 0, made = 0;
    long m;
    for (k = 0; k < 6; k++)
        for (i = 0; i < 4; i++)
            bad[k][i] = (mkpla_real)0.5;
    bad[0][2] = nan;
    bad[1][0] = inf;
    bad[2][3] = -inf;
    for (i = 0; i < 4; i++) {
        bad[3][i] = 0;
        bad[4][i] = tiny();
        bad[5][i] = huge();
    }
    CHECK(mkpla_encoder_init(&a, method, 4, 1, th, maxlen, buf_a, sizeof buf_a / sizeof buf_a[0]) == MKPLA_OK, "init");
    CHECK(mkpla_encoder_init(&b, method, 4, 1, th, maxlen, buf_b, sizeof buf_b / sizeof buf_b[0]) == MKPLA_OK, "init");
    for (i = 0; i < N; i++) {
        mkpla_time t = tick_of(i, 0);
        na += mkpla_encoder_push(&a, t, sig[i], &pts_a[na]);
        if (i > 0 && i % 23 == 0) { /* bad samples before sample i: each refused with its code */
            for (k = 0; k < 6; k++) {
                rc = mkpla_encoder_push(&b, t, bad[(i / 23 + k) % 6], &p);
                CHECK(rc == code[(i / 23 + k) % 6], "a bad sample is refused with its code");
            }
            rc = mkpla_encoder_push(&b, tick_of(i - 1, 0), sig[i], &p);
            CHECK(rc == MKPLA_E_TIME, "a repeated time is refused");
            if (i > 1) {
                rc = mkpla_encoder_push(&b, tick_of(i - 2, 0), sig[i], &p);
                CHECK(rc == MKPLA_E_TIME, "an earlier time is refused");
            }
#ifndef MKPLA_FLOAT32
            rc = mkpla_encoder_push(&b, nan, sig[i], &p);
            CHECK(rc == MKPLA_E_NONFINITE, "a NaN time is refused");
            rc = mkpla_encoder_push(&b, inf, sig[i], &p);
            CHECK(rc == MKPLA_E_NONFINITE, "an infinite time is refused");
#endif
        }
        nb += mkpla_encoder_push(&b, t, sig[i], &pts_b[nb]);
    }
    na += mkpla_encoder_flush(&a, &pts_a[na]);
    nb += mkpla_encoder_flush(&b, &pts_b[nb]);
    CHECK(na > 2 && na == nb && same_points(pts_a, pts_b, na), "the points ignore the refused samples (push)");

    /* push_many: the batch stops at the bad sample (failed = its position), the rest follows */
    {
        static mkpla_time tt[N + 1];
        static mkpla_real xx[4 * (N + 1)];
        long total = 0;
        int at = N / 2;
        for (i = 0, k = 0; i < N; i++, k++) {
            if (i == at) { /* a NaN sample before sample `at` */
                tt[k] = tick_of(i, 0);
                memcpy(xx + 4 * k, bad[0], sizeof bad[0]);
                k++;
            }
            tt[k] = tick_of(i, 0);
            memcpy(xx + 4 * k, sig[i], sizeof sig[i]);
        }
        mkpla_encoder_init(&a, method, 4, 1, th, maxlen, buf_a, sizeof buf_a / sizeof buf_a[0]);
        mkpla_encoder_init(&b, method, 4, 1, th, maxlen, buf_b, sizeof buf_b / sizeof buf_b[0]);
        m = mkpla_encoder_push_many(&b, tt, xx, (size_t)N + 1, 0, idx_b, ts_b, val_b, &failed, &made);
        CHECK(m == MKPLA_E_NONFINITE && failed == (size_t)at && made > 0, "push_many stops at the NaN sample, naming it");
        total = (long)made; /* the points of the samples before it are kept */
        m = mkpla_encoder_push_many(&b, tt + at + 1, xx + 4 * (at + 1), (size_t)N - (size_t)at, 1, idx_b + total,
                                    ts_b + total, val_b + 4 * total, &failed, &made);
        CHECK(m > 0 && (size_t)m == made, "push_many goes on after the refused sample");
        total += m > 0 ? m : 0;
        for (i = 0; i < N; i++) { /* the clean stream */
            tt[i] = tick_of(i, 0);
            memcpy(xx + 4 * i, sig[i], sizeof sig[i]);
        }
        m = mkpla_encoder_push_many(&a, tt, xx, (size_t)N, 1, idx_a, ts_a, val_a, &failed, NULL);
        CHECK(m == total && memcmp(idx_a, idx_b, (size_t)m * sizeof idx_a[0]) == 0
              && memcmp(ts_a, ts_b, (size_t)m * sizeof ts_a[0]) == 0
              && memcmp(val_a, val_b, (size_t)m * 4 * sizeof val_a[0]) == 0,
              "the points ignore the refused sample (push_many)");
    }
}

static void test_vector_refusals(void)
{
    mkpla_encoder a;
    mkpla_point p;
    volatile mkpla_real zero = 0;
    mkpla_real x[3] = {0, 0, 0};
    CHECK(mkpla_encoder_init(&a, MKPLA_FASTSW, 3, 0, (mkpla_real)0.1, 0, NULL, 0) == MKPLA_OK, "init");
    CHECK(mkpla_encoder_push(&a, tick_of(0, 0), x, &p) == 1, "a zero vector is a sample");
    x[1] = 1 / zero;
    CHECK(mkpla_encoder_push(&a, tick_of(1, 0), x, &p) == MKPLA_E_NONFINITE, "an infinite component is refused");
    x[1] = zero / zero;
    CHECK(mkpla_encoder_push(&a, tick_of(1, 0), x, &p) == MKPLA_E_NONFINITE, "a NaN component is refused");
    x[1] = 0;
    CHECK(mkpla_encoder_push(&a, tick_of(1, 0), x, &p) == 0, "the next good sample is taken");
}

/* ---- 3. mkp ---------------------------------------------------------------------------------- */

static uint8_t pkt_a[64 * 1024], pkt_b[64 * 1024];

static size_t packets(mkp_packetiser *s, uint8_t *out, int with_bad)
{
    volatile mkpla_real zero = 0;
    mkpla_real bad[3][4] = {{1, 0, 0, 0}, {0, 0, 0, 0}, {1, 0, 0, 0}};
    uint8_t pkt[MKP_MAX_PACKET];
    size_t used = 0;
    int i, k, len;
    bad[0][1] = 1 / zero;
    bad[2][3] = zero / zero;
    for (i = 0; i < N; i++) {
        if (with_bad && i % 31 == 5)
            for (k = 0; k < 3; k++)
                CHECK(mkp_push(s, bad[k], pkt) == (k == 1 ? MKPLA_E_ZERO : MKPLA_E_NONFINITE),
                      "mkp refuses a NaN, infinite or zero quaternion");
        len = mkp_push(s, sig[i], pkt);
        if (len > 0 && used + (size_t)len <= sizeof pkt_a) {
            memcpy(out + used, pkt, (size_t)len);
            used += (size_t)len;
        }
    }
    while ((len = mkp_flush(s, pkt)) > 0)
        if (used + (size_t)len <= sizeof pkt_a) {
            memcpy(out + used, pkt, (size_t)len);
            used += (size_t)len;
        }
    return used;
}

static void test_mkp(void)
{
    mkp_packetiser a, b;
    uint16_t code[4];
    volatile mkpla_real zero = 0;
    mkpla_real q[4] = {1, 0, 0, 0};
    size_t na, nb;
    q[2] = 1 / zero;
    CHECK(mkp_quantise(q, 12, code) == MKPLA_E_NONFINITE, "mkp_quantise: +Inf refused");
    q[2] = -1 / zero;
    CHECK(mkp_quantise(q, 12, code) == MKPLA_E_NONFINITE, "mkp_quantise: -Inf refused");
    q[2] = zero / zero;
    CHECK(mkp_quantise(q, 12, code) == MKPLA_E_NONFINITE, "mkp_quantise: NaN refused");
    q[0] = q[1] = q[2] = q[3] = 0;
    CHECK(mkp_quantise(q, 12, code) == MKPLA_E_ZERO, "mkp_quantise: zero refused");
    q[0] = huge();
    CHECK(mkp_quantise(q, 12, code) == MKPLA_E_ZERO, "mkp_quantise: an overflowing norm refused");
    q[0] = (mkpla_real)0.5;
    CHECK(mkp_quantise(q, 12, code) == MKPLA_OK, "mkp_quantise: a short quaternion is fine");
    CHECK(mkp_init(&a, 1, (mkpla_real)0.02, 12, 20, MAX_L, buf_a, sizeof buf_a / sizeof buf_a[0]) == MKPLA_OK, "mkp init");
    CHECK(mkp_init(&b, 1, (mkpla_real)0.02, 12, 20, MAX_L, buf_b, sizeof buf_b / sizeof buf_b[0]) == MKPLA_OK, "mkp init");
    na = packets(&a, pkt_a, 0);
    nb = packets(&b, pkt_b, 1);
    CHECK(na > 40 && na == nb && memcmp(pkt_a, pkt_b, na) == 0, "mkp: the packets ignore the refused samples");
}

/* ---- 4. float32: ticks ---------------------------------------------------------------------- */

#ifdef MKPLA_FLOAT32
static int run_at(int method, mkpla_real th, uint32_t maxlen, mkpla_time t0, mkpla_point *pts)
{
    mkpla_encoder e;
    int i, n = 0, rc;
    mkpla_encoder_init(&e, method, 4, 1, th, maxlen, buf_a, sizeof buf_a / sizeof buf_a[0]);
    for (i = 0; i < N; i++) {
        rc = mkpla_encoder_push(&e, tick_of(i, t0), sig[i], &pts[n]);
        if (rc < 0)
            return rc;
        n += rc;
    }
    return n + mkpla_encoder_flush(&e, &pts[n]);
}

static void test_ticks(void)
{
    static const mkpla_time starts[2] = {129600000u /* 36 h in ms */, 0xffffffffu - 1500u /* wraps */};
    static const struct { int method; float th; uint32_t maxlen; } runs[] = {
        {MKPLA_FASTSW, 1e-4f, 0}, {MKPLA_SW, 1e-4f, MAX_L}, {MKPLA_CPLR, 1e-4f, 0}, {MKPLA_SWING, 0.01f, 0},
        {MKPLA_ANGLESW, 0.01f, MAX_L}};
    mkpla_encoder e;
    mkpla_point p;
    mkpla_real still[4] = {1, 0, 0, 0};
    unsigned r, k;
    int i, n0, n1, same;
    for (r = 0; r < sizeof runs / sizeof runs[0]; r++) {
        n0 = run_at(runs[r].method, runs[r].th, runs[r].maxlen, 0, pts_a);
        CHECK(n0 > 2, "points at tick 0");
        for (k = 0; k < 2; k++) {
            n1 = run_at(runs[r].method, runs[r].th, runs[r].maxlen, starts[k], pts_b);
            same = n1 == n0;
            for (i = 0; same && i < n0; i++)
                same = pts_a[i].index == pts_b[i].index && (mkpla_time)(pts_b[i].t - starts[k]) == pts_a[i].t
                       && memcmp(pts_a[i].v, pts_b[i].v, sizeof pts_a[i].v) == 0;
            CHECK(same, "the same points whatever the first tick (36 h, a wrapping counter)");
        }
    }
    /* steps: 0 and more than MKPLA_MAX_SPAN refused, MKPLA_MAX_SPAN taken */
    mkpla_encoder_init(&e, MKPLA_FASTSW, 4, 1, 0, 0, NULL, 0);
    CHECK(mkpla_encoder_push(&e, 5u, still, &p) == 1, "first sample");
    CHECK(mkpla_encoder_push(&e, 5u, still, &p) == MKPLA_E_TIME, "a step of 0 ticks is refused");
    CHECK(mkpla_encoder_push(&e, 5u + MKPLA_MAX_SPAN + 1u, still, &p) == MKPLA_E_TIME,
          "a step of 2^31 ticks (an earlier time, modulo 2^32) is refused");
    CHECK(mkpla_encoder_push(&e, 5u + 0x40000000u, still, &p) == 0, "a step of 2^30 ticks is taken");
    CHECK(mkpla_encoder_push(&e, 5u + MKPLA_MAX_SPAN, still, &p) == 0, "a segment of MKPLA_MAX_SPAN ticks");
    /* a still sensor at threshold 0 would go on: the segment ends before it spans too many ticks */
    CHECK(mkpla_encoder_push(&e, 5u + 0xbfffffffu, still, &p) == 1 && p.index == 2 && p.t == 5u + MKPLA_MAX_SPAN,
          "the segment ends before spanning more than MKPLA_MAX_SPAN ticks");
}
#endif

int main(void)
{
    make_signal();
    test_sizes();
    test_refusals(MKPLA_FASTSW, (mkpla_real)1e-4, 0);
    test_refusals(MKPLA_SW, (mkpla_real)1e-4, MAX_L);
    test_refusals(MKPLA_CPLR, (mkpla_real)1e-4, 0);
    test_refusals(MKPLA_SWING, (mkpla_real)0.01, 50);
    test_refusals(MKPLA_ANGLESW, (mkpla_real)0.01, MAX_L);
    test_vector_refusals();
    test_mkp();
#ifdef MKPLA_FLOAT32
    test_ticks();
#endif
    say("mkpla selftest: ");
    say_num((unsigned long)checks);
    say(" checks, ");
    say_num((unsigned long)failures);
    say(" failed (size_t of ");
    say_num((unsigned long)(sizeof(size_t) * 8u));
    say(" bits)\n");
    return failures != 0;
}
