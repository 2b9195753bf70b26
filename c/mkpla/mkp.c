/*
 * mkp — radio packets of segment points (see mkp.h and docs/mkp.md).
 */
/* no fused multiply-add (see mkpla.c): the codes must not depend on the compiler's flags */
#if defined(__clang__) || !defined(__GNUC__)
#pragma STDC FP_CONTRACT OFF
#else
#pragma GCC optimize("fp-contract=off")
#endif
#if defined(__FAST_MATH__) || (defined(__FINITE_MATH_ONLY__) && __FINITE_MATH_ONLY__)
#error "mkp: do not compile with -ffast-math or -ffinite-math-only (they drop the NaN checks)"
#endif

#include "mkp.h"

#include <float.h>
#include <math.h>
#include <string.h>

#ifdef MKPLA_FLOAT32
#define MKP_SQRT(x) sqrtf(x)
#define MKP_REAL_MIN FLT_MIN
#define MKP_REAL_MAX FLT_MAX
#else
#define MKP_SQRT(x) sqrt(x)
#define MKP_REAL_MIN DBL_MIN
#define MKP_REAL_MAX DBL_MAX
#endif
/* ticks are counted in 32 bits (anglesw takes them as mkpla_time: exact in both builds) */
#define MKP_TICK_LIMIT 0xffffffffu

/* ---- quantisation -------------------------------------------------------------------------------
 * The kept components of a unit quaternion whose largest-magnitude component m is made positive lie
 * in [-1/sqrt2, 1/sqrt2] (a^2 + m^2 <= 1 and |a| <= m). With M = 2^B - 1, code c stands for
 * (2c - M) * h, h = 1 / (sqrt2 * M): M + 1 levels spanning the interval, rounding error <= h. */

static mkpla_real half_step(int bits)
{
    return (mkpla_real)1 / (MKP_SQRT((mkpla_real)2) * (mkpla_real)((1u << bits) - 1u));
}

mkpla_real mkp_delta(int bits)
{
    mkpla_real h, m2, e;
    if (bits < MKP_MIN_BITS || bits > MKP_MAX_BITS)
        return 0;
    h = half_step(bits);
    /* the kept part a (3 components) errs by |a - a'| <= sqrt3 h; both lie in |x| <= sqrt3/2 + sqrt3 h,
     * where the dropped component sqrt(1 - |x|^2) >= sqrt(1/4 - 3h - 3h^2) = mmin; the map
     * x -> (sqrt(1 - |x|^2), x) is 1/mmin-Lipschitz there, so |q - q'| <= e = sqrt3 h / mmin */
    m2 = (mkpla_real)0.25 - 3 * h - 3 * h * h;
    e = MKP_SQRT((mkpla_real)3) * h / MKP_SQRT(m2);
    /* rotation angle = 4 asin(|q - q'| / 2) <= 4 tan(asin(e / 2)) = 2e / sqrt(1 - e^2 / 4) */
    return 2 * e / MKP_SQRT(1 - e * e / 4);
}

int mkp_quantise(const mkpla_real *q, int bits, uint16_t *code)
{
    mkpla_real n2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
    mkpla_real nrm, big = 0, sg, k, mm;
    int d, i = 0, j = 1;
    uint32_t M = (1u << bits) - 1u;
    for (d = 0; d < 4; d++)
        if (!(q[d] - q[d] == 0)) /* NaN or infinite */
            return MKPLA_E_NONFINITE;
    if (!(n2 >= MKP_REAL_MIN && n2 <= MKP_REAL_MAX)) /* zero, subnormal or overflowing squared norm */
        return MKPLA_E_ZERO;
    nrm = MKP_SQRT(n2);
    for (d = 0; d < 4; d++) {
        mkpla_real a = q[d] < 0 ? -q[d] : q[d];
        if (a > big) {
            big = a;
            i = d;
        }
    }
    sg = q[i] < 0 ? -1 : 1;
    k = MKP_SQRT((mkpla_real)2) * (mkpla_real)M;
    mm = (mkpla_real)M;
    code[0] = (uint16_t)i;
    for (d = 0; d < 4; d++) {
        mkpla_real x, c;
        if (d == i)
            continue;
        x = sg * q[d] / nrm;
        c = (x * k + mm) * (mkpla_real)0.5 + (mkpla_real)0.5;
        if (c < 0)
            c = 0;
        c = (mkpla_real)(int32_t)c; /* rounds toward zero: floor for c >= 0 (no libm call on a Cortex-M4) */
        if (c > (mkpla_real)M)
            c = (mkpla_real)M;
        code[j++] = (uint16_t)c;
    }
    return MKPLA_OK;
}

void mkp_dequantise(const uint16_t *code, int bits, mkpla_real *q)
{
    mkpla_real h = half_step(bits), a[3], s;
    int32_t M = (int32_t)((1u << bits) - 1u);
    int d, j = 0, i = code[0] & 3;
    for (d = 0; d < 3; d++)
        a[d] = (mkpla_real)(2 * (int32_t)code[d + 1] - M) * h;
    s = a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
    for (d = 0; d < 4; d++)
        q[d] = d == i ? MKP_SQRT(s < 1 ? 1 - s : 0) : a[j++];
}

uint16_t mkp_crc16(const uint8_t *data, size_t n)
{
    uint32_t crc = 0xffffu;
    size_t i;
    int b;
    for (i = 0; i < n; i++) {
        crc ^= (uint32_t)data[i] << 8;
        for (b = 0; b < 8; b++)
            crc = crc & 0x8000u ? ((crc << 1) ^ 0x1021u) & 0xffffu : (crc << 1) & 0xffffu;
    }
    return (uint16_t)crc;
}

/* ---- packets ----------------------------------------------------------------------------------- */

static int varint_len(uint32_t v)
{
    int n = 1;
    while (v >= 0x80u) {
        v >>= 7;
        n++;
    }
    return n;
}

static int point_bits(const mkp_packetiser *s) { return 2 + 3 * s->bits; }

/* append the low n bits of v (n <= 16) to the pending packet's bitstream, MSB first */
static void put_bits(mkp_packetiser *s, uint32_t v, int n)
{
    while (n > 0) {
        uint32_t pos = s->nbits & 7u;
        int take = 8 - (int)pos < n ? 8 - (int)pos : n;
        uint32_t chunk = (v >> (n - take)) & ((1u << take) - 1u);
        s->buf[s->head + (s->nbits >> 3)] |= (uint8_t)(chunk << (8 - (int)pos - take));
        s->nbits += (uint32_t)take;
        n -= take;
    }
}

static void put_point(mkp_packetiser *s, const uint16_t *code)
{
    put_bits(s, code[0], 2);
    put_bits(s, code[1], s->bits);
    put_bits(s, code[2], s->bits);
    put_bits(s, code[3], s->bits);
}

/* bytes of the pending packet with `bits` more bits in its bitstream, CRC included */
static uint32_t size_with(const mkp_packetiser *s, uint32_t bits)
{
    return (uint32_t)s->head + (s->nbits + bits + 7u) / 8u + 2u;
}

static void start_packet(mkp_packetiser *s, uint32_t tick, const uint16_t *code)
{
    uint32_t v = tick;
    int h = 3;
    s->buf[0] = s->sensor;
    s->buf[1] = (uint8_t)(s->seq & 0xffu);
    s->buf[2] = (uint8_t)(s->seq >> 8);
    while (v >= 0x80u) {
        s->buf[h++] = (uint8_t)(0x80u | (v & 0x7fu));
        v >>= 7;
    }
    s->buf[h++] = (uint8_t)v;
    s->buf[h++] = 0; /* count, set when the packet is closed */
    s->head = (uint8_t)h;
    memset(s->buf + h, 0, (size_t)(s->max_bytes - h));
    s->nbits = 0;
    s->npts = 0;
    s->full = 0;
    if (code != NULL) {
        put_point(s, code);
        s->npts = 1;
        s->last_tick = tick;
    }
}

/* close the pending packet into out; its length */
static int close_packet(mkp_packetiser *s, uint8_t *out, int last)
{
    uint32_t n = (uint32_t)s->head + (s->nbits + 7u) / 8u;
    uint16_t crc;
    s->buf[s->head - 1] = (uint8_t)(s->npts | (last ? MKP_LAST : 0));
    crc = mkp_crc16(s->buf, n);
    memcpy(out, s->buf, n);
    out[n] = (uint8_t)(crc & 0xffu);
    out[n + 1] = (uint8_t)(crc >> 8);
    s->seq = (uint16_t)(s->seq + 1u);
    s->npts = 0;
    s->full = 0;
    return (int)(n + 2);
}

/* the pending packet takes no point of the smallest kind (1-byte delta) any more */
static void mark_full(mkp_packetiser *s)
{
    s->full = s->npts >= MKP_MAX_POINTS || size_with(s, 8u + (uint32_t)point_bits(s)) > s->max_bytes;
}

/* a decided point; a packet it closed goes to out (its length), else 0 */
static int add_point(mkp_packetiser *s, uint32_t tick, const uint16_t *code, uint8_t *out)
{
    int len = 0;
    uint32_t delta, v;
    s->new_point = 1;
    s->point_tick = tick;
    memcpy(s->point_code, code, sizeof s->point_code);
    if (s->npts == 0) {
        start_packet(s, tick, code);
        mark_full(s);
        return 0;
    }
    delta = tick - s->last_tick;
    if (size_with(s, 8u * (uint32_t)varint_len(delta) + (uint32_t)point_bits(s)) > s->max_bytes) {
        len = close_packet(s, out, 0);
        start_packet(s, tick, code);
        mark_full(s);
        return len;
    }
    for (v = delta; v >= 0x80u; v >>= 7)
        put_bits(s, 0x80u | (v & 0x7fu), 8);
    put_bits(s, v, 8);
    put_point(s, code);
    s->npts++;
    s->last_tick = tick;
    mark_full(s);
    return 0;
}

int mkp_init(mkp_packetiser *s, uint8_t sensor, mkpla_real max_angle_rad, int bits, int packet_bytes,
             uint32_t maxlen, mkpla_real *buffer, size_t buffer_len)
{
    mkpla_real budget;
    int rc;
    if (bits < MKP_MIN_BITS || bits > MKP_MAX_BITS || packet_bytes < 16 || packet_bytes > MKP_MAX_PACKET)
        return MKPLA_E_PARAM;
    /* one point with the longest tick: 1 + 2 + 5 + 1 header bytes, the quaternion, the CRC */
    if (11 + (2 + 3 * bits + 7) / 8 > packet_bytes)
        return MKPLA_E_PARAM;
    budget = max_angle_rad - mkp_delta(bits) - MKP_EPS;
    if (!(budget > 0))
        return MKPLA_E_PARAM;
    rc = mkpla_anglesw_init(&s->enc, budget, maxlen, buffer, buffer_len);
    if (rc != MKPLA_OK)
        return rc;
    s->max_angle = max_angle_rad;
    s->budget = budget;
    s->count = 0;
    s->max_count = MKP_TICK_LIMIT;
    s->seq = 0;
    s->max_bytes = (uint16_t)packet_bytes;
    s->sensor = sensor;
    s->bits = (uint8_t)bits;
    s->stage = 0;
    s->full = 0;
    s->npts = 0;
    s->head = 0;
    s->nbits = 0;
    s->last_tick = 0;
    s->new_point = 0;
    s->point_tick = 0;
    memset(s->prev_code, 0, sizeof s->prev_code);
    memset(s->point_code, 0, sizeof s->point_code);
    return MKPLA_OK;
}

int mkp_push(mkp_packetiser *s, const mkpla_real *q, uint8_t *out)
{
    uint16_t code[4];
    mkpla_real qd[4];
    mkpla_point p;
    int rc, len = 0;
    uint32_t tick = s->count;
    s->new_point = 0;
    if (s->stage != 0)
        return MKPLA_E_DONE;
    if (tick >= s->max_count)
        return MKP_E_TICKS;
    rc = mkp_quantise(q, s->bits, code);
    if (rc != MKPLA_OK)
        return rc; /* refused: nothing changed, the tick not counted */
    mkp_dequantise(code, s->bits, qd);
    if (s->full) /* a packet that was full after the previous point leaves now: one packet per call */
        len = close_packet(s, out, 0);
    rc = mkpla_anglesw_push(&s->enc, (mkpla_time)tick, qd, &p);
    s->count++;
    if (rc == 1) {
        /* the first sample, or the previous one */
        const uint16_t *pc = p.index == tick ? code : s->prev_code;
        int l2 = add_point(s, p.index, pc, out);
        if (l2 > 0)
            len = l2; /* cannot happen after a close above: the pending packet was empty then */
    }
    memcpy(s->prev_code, code, sizeof code);
    return len;
}

int mkp_flush(mkp_packetiser *s, uint8_t *out)
{
    mkpla_point p;
    s->new_point = 0;
    if (s->stage == 0) {
        if (s->full)
            return close_packet(s, out, 0); /* the stage stays: called again */
        s->stage = 1;
        if (s->count > 0 && mkpla_anglesw_flush(&s->enc, &p)) {
            int len = add_point(s, p.index, s->prev_code, out);
            if (len > 0)
                return len;
        }
    }
    if (s->stage == 1) {
        s->stage = 2;
        if (s->count == 0)
            return 0;
        if (s->npts == 0) /* the last point left in a full packet: an empty packet ends the stream */
            start_packet(s, s->count - 1u, NULL);
        return close_packet(s, out, 1);
    }
    return 0;
}

long mkp_push_many(mkp_packetiser *s, const mkpla_real *q, size_t n, int flush_at_end, uint8_t *out, size_t cap,
                   size_t *used, uint32_t *packet_at, uint32_t *point_tick, uint16_t *point_code, size_t *points,
                   size_t *failed)
{
    uint8_t pkt[MKP_MAX_PACKET];
    size_t i, u = 0, m = 0;
    long np = 0;
    int len, d;
    for (i = 0; i <= n; i++) {
        int flushing = i == n;
        if (flushing && !flush_at_end)
            break;
        for (;;) {
            len = flushing ? mkp_flush(s, pkt) : mkp_push(s, q + 4 * i, pkt);
            if (len < 0) {
                if (failed)
                    *failed = i;
                return len;
            }
            if (s->new_point && point_tick != NULL) {
                point_tick[m] = s->point_tick;
                for (d = 0; d < 4; d++)
                    point_code[4 * m + d] = s->point_code[d];
                m++;
            }
            if (len > 0) {
                if (u + 1u + (size_t)len > cap) {
                    if (failed)
                        *failed = i;
                    return MKPLA_E_BUFFER;
                }
                out[u] = (uint8_t)len;
                memcpy(out + u + 1, pkt, (size_t)len);
                u += 1u + (size_t)len;
                packet_at[np++] = (uint32_t)i;
            }
            if (!flushing || len == 0)
                break;
        }
    }
    if (used)
        *used = u;
    if (points)
        *points = m;
    return np;
}
