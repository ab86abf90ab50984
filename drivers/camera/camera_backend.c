/* camera_backend.c -- the bookkeeping every backend shares
 * (camera_backend.h): the handle's failure message, the monotonic clock and
 * the frame sequence numbers. */
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE 1
#endif
#include "drivers/camera/camera_backend.h"

#include <stdarg.h>
#include <stdio.h>
#include <time.h>

mfns_cam_err_t mfns_cam_fail(mfns_cam_t *h, mfns_cam_err_t e, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    /* ap is initialised by va_start just above; the analyzer loses it across
     * camera_v4l2_ident.c's call paths (a false positive, clang-tidy 14). */
    /* NOLINTNEXTLINE(clang-analyzer-valist.Uninitialized) */
    (void)vsnprintf(h->msg, sizeof h->msg, fmt, ap);
    va_end(ap);
    return e;
}

int64_t mfns_cam_now_ns(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_MONOTONIC, &ts) != 0) {
        return 0; /* cannot fail for CLOCK_MONOTONIC on Linux */
    }
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

void mfns_cam_seq_reset(mfns_cam_t *h)
{
    h->have_seq = false;
    h->missing = 0;
}

/* Frames between the baseline and seq; a step backwards (counter reset or a
 * reordered frame) rebases without counting. */
static uint32_t seq_gap(mfns_cam_t *h, uint32_t seq)
{
    uint32_t gap = 0;
    if (h->have_seq) {
        const uint32_t d = seq - h->last_seq - 1u; /* modulo 2^32: wraps are fine */
        gap = d < 0x80000000u ? d : 0u;
    }
    h->have_seq = true;
    h->last_seq = seq;
    return gap;
}

uint32_t mfns_cam_seq_delivered(mfns_cam_t *h, uint32_t seq)
{
    const uint32_t gap = seq_gap(h, seq);
    h->stats.dropped += gap;
    h->stats.frames++;
    const uint32_t missing = h->missing + gap;
    h->missing = 0;
    return missing;
}

void mfns_cam_seq_errored(mfns_cam_t *h, uint32_t seq)
{
    const uint32_t gap = seq_gap(h, seq);
    h->stats.dropped += gap;
    h->stats.error_frames++;
    h->missing += gap + 1u;
}

