/*
 * mkp — the radio packet format of mkpla: segment points of ONE orientation stream, quantised and
 * packed into small packets (a BLE 4 ATT payload of 20 bytes, or any size up to MKP_MAX_PACKET).
 *
 * The packetiser wraps the angle-bounded encoder (mkpla_anglesw). Each incoming quaternion is first
 * quantised by smallest-three at B bits per component and dequantised exactly as the decoder does;
 * THAT sample is what anglesw sees, with the threshold max_angle - mkp_delta(B) - MKP_EPS. Since
 * mkp_delta(B) bounds the rotation angle between a unit quaternion and its quantisation, every
 * original sample lies within max_angle of the SLERP decode of the transmitted points (triangle
 * inequality of the rotation angle). The format is specified in docs/mkp.md; in brief, a packet is
 *
 *     sensor id (1 byte) | sequence number (uint16 LE) | tick of the first point (LEB128) |
 *     count (1 byte: bit 7 = last packet of the stream, bits 0-6 = number of points) |
 *     bitstream, MSB first: point 0 = quaternion; point k >= 1 = tick delta (LEB128, 8-bit groups)
 *     then quaternion; quaternion = index of the dropped component (2 bits) + 3 codes of B bits;
 *     zero bits up to a byte | CRC-16/CCITT-FALSE of every byte before it (uint16 LE)
 *
 * A tick is the sample counter of the stream: the first sample pushed is tick 0.
 *
 *     mkp_packetiser st;                    static mkpla_real buf[MKPLA_ANGLESW_BUFFER_LEN(L)];
 *     uint8_t pkt[MKP_MAX_PACKET];
 *     mkp_init(&st, sensor_id, max_angle_rad, bits, 20, L, buf, MKPLA_ANGLESW_BUFFER_LEN(L));
 *     for each sample q:  if ((n = mkp_push(&st, q, pkt)) > 0) radio_send(pkt, n);
 *     while ((n = mkp_flush(&st, pkt)) > 0) radio_send(pkt, n);
 *
 * mkp_push returns at most one packet per sample. Nothing is allocated; no libm call but sqrt.
 */
#ifndef MKP_H
#define MKP_H

#include "mkpla.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Largest packet the state can build (bytes, CRC included); a sensor build may lower it. */
#ifndef MKP_MAX_PACKET
#define MKP_MAX_PACKET 255
#endif
#define MKP_MIN_BITS 6
#define MKP_MAX_BITS 16
#define MKP_MAX_POINTS 127  /* points per packet (7 bits of the count byte) */
#define MKP_LAST 0x80       /* count byte: the stream's last packet */
/* Margin (radians) kept besides mkp_delta(B): the float rounding of the quantisation and of the
 * float32 sensor's dequantisation against the float64 decoder (about 1e-7 rad). */
#define MKP_EPS ((mkpla_real)1e-6)

#define MKP_E_TICKS (-6)    /* the tick counter is full (2^32 - 1 ticks) */

typedef struct {
    mkpla_anglesw enc;
    mkpla_real max_angle, budget;   /* radians: the end-to-end bound, what anglesw gets */
    uint32_t count;                 /* samples pushed: the next tick */
    uint32_t max_count;
    uint16_t seq;                   /* sequence number of the pending packet */
    uint16_t max_bytes;
    uint8_t sensor, bits;
    uint8_t stage;                  /* 0: running, 1: final point added, 2: done */
    uint8_t full;                   /* the pending packet can take no further point */
    uint16_t prev_code[4];          /* codes of the last sample pushed */
    /* the pending packet */
    uint8_t npts, head;             /* points; header bytes (the count byte is buf[head - 1]) */
    uint32_t nbits;                 /* bits of the bitstream so far */
    uint32_t last_tick;             /* tick of its last point */
    uint8_t buf[MKP_MAX_PACKET];
    /* the point decided by the last push/flush call (new_point = 1), for callers that log points */
    uint8_t new_point;
    uint32_t point_tick;
    uint16_t point_code[4];
} mkp_packetiser;

/* The proven bound (radians) of the rotation angle between a unit quaternion and its smallest-three
 * quantisation at `bits` bits per component (docs/mkp.md); 0 for bits outside MKP_MIN_BITS..MAX. */
mkpla_real mkp_delta(int bits);
/* Smallest-three codes of q (any non-zero norm): code[0] = index of the dropped (largest-magnitude)
 * component, code[1..3] = the other components in order, made to the hemisphere where the dropped
 * one is positive, as integers 0..2^bits-1. MKPLA_E_NONFINITE for a NaN or infinite component,
 * MKPLA_E_ZERO for a zero quaternion (or one whose squared norm is subnormal or overflows). */
int mkp_quantise(const mkpla_real *q, int bits, uint16_t *code);
/* The unit quaternion the decoder reconstructs from the codes. */
void mkp_dequantise(const uint16_t *code, int bits, mkpla_real *q);
/* CRC-16/CCITT-FALSE (poly 0x1021, init 0xffff, no reflection, no final xor). */
uint16_t mkp_crc16(const uint8_t *data, size_t n);

/* max_angle_rad > mkp_delta(bits) + MKP_EPS; packet_bytes in 16..MKP_MAX_PACKET and large enough for
 * one point with a 5-byte tick; maxlen and buffer as for mkpla_anglesw_init. */
int mkp_init(mkp_packetiser *s, uint8_t sensor, mkpla_real max_angle_rad, int bits, int packet_bytes,
             uint32_t maxlen, mkpla_real *buffer, size_t buffer_len);
/* One sample (the next tick). Returns the length of a packet written to out (room for packet_bytes),
 * 0 when none is ready, or an MKPLA_E_* / MKP_E_* error (NaN or infinite component, zero quaternion,
 * push after flush, ticks); a refused sample changes nothing and takes no tick. */
int mkp_push(mkp_packetiser *s, const mkpla_real *q, uint8_t *out);
/* End of stream: call until it returns 0; each positive return is a packet in out. */
int mkp_flush(mkp_packetiser *s, uint8_t *out);

/* n samples (q: 4 per sample); each packet goes to out as [length byte][packet bytes] (room for
 * cap bytes), the tick at which it was sent to packet_at[] (n for the flush's packets; room for
 * n + 2 entries) and, when point_tick is not NULL, each decided point's tick and codes to
 * point_tick[] / point_code[] (4 per point; room for n + 1 points). flush_at_end: also flush.
 * Returns the number of packets; *used the bytes of out and *points the points written; an error
 * < 0 with *failed the offending sample (MKPLA_E_BUFFER: out is full). */
long mkp_push_many(mkp_packetiser *s, const mkpla_real *q, size_t n, int flush_at_end, uint8_t *out, size_t cap,
                   size_t *used, uint32_t *packet_at, uint32_t *point_tick, uint16_t *point_code, size_t *points,
                   size_t *failed);

#ifdef __cplusplus
}
#endif
#endif /* MKP_H */
