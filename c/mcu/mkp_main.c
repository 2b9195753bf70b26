/*
 * The radio packetiser (mkp) on a Cortex-M4 (QEMU mps2-an386): the second harness of tools/mcu_measure.py.
 *
 * Command line (semihosting): mkp_harness INPUT OUTPUT. INPUT holds quaternion signals and jobs; each job
 * runs one signal through mkp_init, one mkp_push per sample (tick = sample number), then mkp_flush until
 * it returns 0. OUTPUT receives every packet (the sample whose push sent it, its bytes) and, per sample,
 * the angle-bounded encoder's segment length n before the push.
 *
 * INPUT, little-endian 32-bit words:
 *   "MKPJ", version 1, n_signals, n_jobs
 *   n_signals x { n, float q[4 n] }
 *   n_jobs    x { signal, maxlen, bits, packet_bytes, sensor, float max_angle_rad }
 * OUTPUT:
 *   "MKPO", version 1, n_jobs, sizeof of mkp_packetiser, mkpla_anglesw
 *   n_jobs x { n_packets, n_bytes, n_packets x sent_at (n for the flush's), n_packets x length,
 *              the packets' bytes back to back (zero-padded to a word), n, n x segment length }
 */
#include <stdint.h>
#include <string.h>

#include "mkp.h"
#include "semihost.h"

#define MAGIC_IN 0x4a504b4du  /* "MKPJ" */
#define MAGIC_OUT 0x4f504b4du /* "MKPO" */
#define VERSION 1u
#define INPUT_WORDS (256u * 1024u)  /* 1 MB of input */
#define MAX_SAMPLES 32768u          /* longest signal */
#define MAX_PACKETS (MAX_SAMPLES + 3u)
#define PACKET_BYTES (512u * 1024u) /* packet bytes of one job */
#define OUT_WORDS (16u * 1024u)     /* 64 KB written at a time */
#define MAX_SEGMENT 8192u           /* largest maxlen a job may ask */

static uint32_t input[INPUT_WORDS] __attribute__((section(".noinit")));
static uint32_t out[OUT_WORDS] __attribute__((section(".noinit")));
static mkpla_real buffer[MKPLA_ANGLESW_BUFFER_LEN(MAX_SEGMENT)] __attribute__((section(".noinit")));
static uint8_t bytes[PACKET_BYTES] __attribute__((section(".noinit")));
static uint32_t sent_at[MAX_PACKETS] __attribute__((section(".noinit")));
static uint32_t length[MAX_PACKETS] __attribute__((section(".noinit")));
static uint32_t seglen[MAX_SAMPLES] __attribute__((section(".noinit")));
static uint8_t pkt[MKP_MAX_PACKET];
static mkp_packetiser st;
static uint32_t n_out;
static int out_fd = -1;

static int fail(const char *msg)
{
    sh_puts("mkp harness: ");
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

static float real(uint32_t w)
{
    float f;
    memcpy(&f, &w, 4);
    return f;
}

/* a packet of len bytes in pkt, sent by the push of sample i */
static int keep(uint32_t *np, uint32_t *nb, uint32_t i, int len)
{
    if (*np >= MAX_PACKETS || *nb + (uint32_t)len > PACKET_BYTES)
        return fail("more packet bytes than the harness keeps");
    memcpy(bytes + *nb, pkt, (size_t)len);
    sent_at[*np] = i;
    length[*np] = (uint32_t)len;
    *nb += (uint32_t)len;
    (*np)++;
    return 0;
}

/* one job: mkp_push per sample (the segment length before it noted), then mkp_flush until 0 */
static int run_job(const uint32_t *sig, const uint32_t *job)
{
    uint32_t i, w, n = sig[0], np = 0, nb = 0;
    const float *q = (const float *)(const void *)(sig + 1);
    int len, rc;
    if (n > MAX_SAMPLES)
        return fail("a signal longer than the harness takes");
    rc = mkp_init(&st, (uint8_t)job[4], real(job[5]), (int)job[2], (int)job[3], job[1], buffer,
                  sizeof buffer / sizeof buffer[0]);
    if (rc != MKPLA_OK)
        return fail("mkp_init refused a job");
    for (i = 0; i < n; i++) {
        seglen[i] = st.enc.n;
        len = mkp_push(&st, q + 4u * i, pkt);
        if (len < 0)
            return fail("mkp_push refused a sample");
        if (len > 0 && keep(&np, &nb, i, len) != 0)
            return 1;
    }
    while ((len = mkp_flush(&st, pkt)) > 0)
        if (keep(&np, &nb, n, len) != 0)
            return 1;
    if (len < 0)
        return fail("mkp_flush failed");
    rc = put(np) | put(nb);
    for (i = 0; i < np; i++)
        rc |= put(sent_at[i]);
    for (i = 0; i < np; i++)
        rc |= put(length[i]);
    for (i = 0; i < nb; i += 4) {
        w = 0;
        memcpy(&w, bytes + i, nb - i < 4u ? nb - i : 4u);
        rc |= put(w);
    }
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
        return fail("usage: mkp_harness INPUT OUTPUT");
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
        return fail("not a packet job file of this version");
    n_signals = input[2];
    n_jobs = input[3];
    if (n_signals > 64)
        return fail("more than 64 signals");
    pos = 4;
    for (i = 0; i < n_signals; i++) {
        if (pos >= (uint32_t)len / 4u || input[pos] > ((uint32_t)len / 4u - pos - 1u) / 4u)
            return fail("truncated signal");
        sigs[i] = input + pos;
        pos += 1u + 4u * input[pos];
    }
    if ((uint32_t)len / 4u - pos != 6u * n_jobs)
        return fail("job table size mismatch");

    out_fd = sh_open(argv[2], 1);
    if (out_fd < 0)
        return fail("cannot open the output");
    if (put(MAGIC_OUT) | put(VERSION) | put(n_jobs) | put(sizeof(mkp_packetiser)) | put(sizeof(mkpla_anglesw)))
        return fail("cannot write the output");
    for (i = 0; i < n_jobs; i++) {
        const uint32_t *job = input + pos + 6u * i;
        if (job[0] >= n_signals || job[1] > MAX_SEGMENT || job[4] > 255u)
            return fail("bad job");
        if (run_job(sigs[job[0]], job) != 0)
            return 1;
    }
    if (flush_out() != 0)
        return fail("cannot write the output");
    sh_close(out_fd);
    return 0;
}
