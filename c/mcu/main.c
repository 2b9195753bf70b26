/*
 * mkpla on a Cortex-M4 (QEMU mps2-an386): the measurement harness of tools/mcu_measure.py.
 *
 * Command line (semihosting): harness INPUT OUTPUT. INPUT holds quaternion signals and jobs; each job
 * runs one signal through one encoder of the checked API (mkpla_encoder_*, hemisphere flip included),
 * one mkpla_encoder_push per sample, then a flush. OUTPUT receives every point and, per sample, the
 * segment length n before its push (for the instruction counts per call against n).
 *
 * INPUT, little-endian 32-bit words:
 *   "MKJB", version 2, n_signals, n_jobs
 *   n_signals x { n, uint32 t[n], float q[4 n] }            times as ticks (mkpla_time)
 *   n_jobs    x { signal, method, maxlen, float threshold }  method: MKPLA_FASTSW .. MKPLA_ANGLESW
 * OUTPUT:
 *   "MKPT", version 2, n_jobs, sizeof of mkpla_fastsw, _sw, _cplr, _swing, _anglesw, _encoder
 *   n_jobs x { n_points, n_points x { index, tick, float v[4] }, n, n x segment length }
 */
#include <stdint.h>
#include <string.h>

#include "mkpla.h"
#include "semihost.h"

#define MAGIC_IN 0x424a4b4du  /* "MKJB" */
#define MAGIC_OUT 0x54504b4du /* "MKPT" */
#define VERSION 2u
#define INPUT_WORDS (256u * 1024u)  /* 1 MB of input */
#define MAX_SAMPLES 32768u          /* longest signal */
#define OUT_WORDS (16u * 1024u)     /* 64 KB written at a time */
#define MAX_SEGMENT 8192u           /* largest maxlen a job may ask of SW / anglesw */

static uint32_t input[INPUT_WORDS] __attribute__((section(".noinit")));
static uint32_t out[OUT_WORDS] __attribute__((section(".noinit")));
static mkpla_real buffer[MKPLA_SW_BUFFER_LEN(MAX_SEGMENT, 4)] __attribute__((section(".noinit")));
static mkpla_point points[MAX_SAMPLES + 1] __attribute__((section(".noinit")));
static uint32_t seglen[MAX_SAMPLES] __attribute__((section(".noinit")));
static mkpla_encoder enc;
static uint32_t n_out;
static int out_fd = -1;

static int fail(const char *msg)
{
    sh_puts("mcu harness: ");
    sh_puts(msg);
    sh_puts("\n");
    return 1;
}

static int flush_out(void)
{
    int rc = n_out ? sh_write(out_fd, out, n_out * 4u) : 0;
    n_out = 0;
    return rc;
}

static int put(uint32_t w)
{
    if (n_out == OUT_WORDS && flush_out() != 0)
        return -1;
    out[n_out++] = w;
    return 0;
}

static uint32_t bits(float f)
{
    uint32_t w;
    memcpy(&w, &f, 4);
    return w;
}

static float real(uint32_t w)
{
    float f;
    memcpy(&f, &w, 4);
    return f;
}

static int put_point(const mkpla_point *p)
{
    int d, rc = put(p->index) | put(p->t);
    for (d = 0; d < 4; d++)
        rc |= put(bits(p->v[d]));
    return rc;
}

/* segment length of the encoder's current segment (samples after its anchor) */
static uint32_t segment_length(const mkpla_encoder *e)
{
    switch (e->method) {
    case MKPLA_FASTSW: return e->u.fastsw.n;
    case MKPLA_SW: return e->u.sw.n;
    case MKPLA_CPLR: return e->u.cplr.n;
    case MKPLA_SWING: return e->u.swing.n;
    default: return e->u.anglesw.n;
    }
}

/* one job: one mkpla_encoder_push per sample (the segment length before it noted), then the flush */
static int run_job(const uint32_t *sig, uint32_t method, uint32_t maxlen, float threshold)
{
    uint32_t i, n = sig[0], n_points = 0;
    const mkpla_time *t = sig + 1;
    const float *q = (const float *)(const void *)(t + n);
    int rc;
    if (n > MAX_SAMPLES)
        return fail("a signal longer than the harness takes");
    rc = mkpla_encoder_init(&enc, (int)method, 4, 1, threshold, maxlen, buffer, sizeof buffer / sizeof buffer[0]);
    if (rc != MKPLA_OK)
        return fail("mkpla_encoder_init refused a job");
    for (i = 0; i < n; i++) {
        seglen[i] = segment_length(&enc);
        rc = mkpla_encoder_push(&enc, t[i], q + 4u * i, &points[n_points]);
        if (rc < 0)
            return fail("mkpla_encoder_push refused a sample");
        n_points += (uint32_t)rc;
    }
    n_points += (uint32_t)mkpla_encoder_flush(&enc, &points[n_points]);
    rc = put(n_points);
    for (i = 0; i < n_points; i++)
        rc |= put_point(&points[i]);
    rc |= put(n);
    for (i = 0; i < n; i++)
        rc |= put(seglen[i]);
    return rc ? fail("cannot write the output") : 0;
}

int main(void)
{
    static char cmd[512];
    char *argv[4];
    int argc = 0, fd;
    char *c;
    long len;
    uint32_t i, n_signals, n_jobs, pos;
    const uint32_t *sigs[64];

    if (sh_cmdline(cmd, (int)sizeof cmd) != 0)
        return fail("no command line");
    for (c = cmd; *c && argc < 4;) {
        while (*c == ' ')
            *c++ = 0;
        if (!*c)
            break;
        argv[argc++] = c;
        while (*c && *c != ' ')
            c++;
    }
    if (argc != 3)
        return fail("usage: harness INPUT OUTPUT");
    fd = sh_open(argv[1], 0);
    if (fd < 0)
        return fail("cannot open the input");
    len = sh_flen(fd);
    if (len < 16 || len % 4 != 0 || (unsigned long)len > sizeof input)
        return fail("input size not a multiple of 4 or larger than 1 MB");
    if (sh_read(fd, input, (size_t)len) != 0)
        return fail("cannot read the input");
    sh_close(fd);
    if (input[0] != MAGIC_IN || input[1] != VERSION)
        return fail("not a job file of this version");
    n_signals = input[2];
    n_jobs = input[3];
    if (n_signals > 64)
        return fail("more than 64 signals");
    pos = 4;
    for (i = 0; i < n_signals; i++) {
        if (pos >= (uint32_t)len / 4u || input[pos] > ((uint32_t)len / 4u - pos - 1u) / 5u)
            return fail("truncated signal");
        sigs[i] = input + pos;
        pos += 1u + 5u * input[pos];
    }
    if ((uint32_t)len / 4u - pos != 4u * n_jobs)
        return fail("job table size mismatch");

    out_fd = sh_open(argv[2], 1);
    if (out_fd < 0)
        return fail("cannot open the output");
    if (put(MAGIC_OUT) | put(VERSION) | put(n_jobs) | put(sizeof(mkpla_fastsw)) | put(sizeof(mkpla_sw))
        | put(sizeof(mkpla_cplr)) | put(sizeof(mkpla_swing)) | put(sizeof(mkpla_anglesw))
        | put(sizeof(mkpla_encoder)))
        return fail("cannot write the output");
    for (i = 0; i < n_jobs; i++) {
        const uint32_t *job = input + pos + 4u * i;
        if (job[0] >= n_signals || job[1] > MKPLA_ANGLESW || job[2] > MAX_SEGMENT)
            return fail("bad job");
        if (run_job(sigs[job[0]], job[1], job[2], real(job[3])) != 0)
            return 1;
    }
    if (flush_out() != 0)
        return fail("cannot write the output");
    sh_close(out_fd);
    return 0;
}
