/* blob_ring.c -- see blob_ring.h. */
#include "firmware/nav/acquire/blob_ring.h"
#include "math/core_inline.h"

#include <string.h>

void mfns_blob_ring_reset(mfns_blob_ring_t *r)
{
    if (r == NULL) {
        return;
    }
    for (uint32_t i = 0u; i < MFNS_BLOB_RING_LEN; i++) {
        r->held[i] = false;
        r->seq[i] = 0u;
    }
    r->next = 0u;
}

MFNS_OUT_OF_LINE
static uint32_t take(mfns_blob_ring_t *r, const mfns_obs_frame_t *frame)
{
    const uint32_t s = r->next;
    const uint32_t slot = s % MFNS_BLOB_RING_LEN;
    r->seq[slot] = s;
    r->held[slot] = frame != NULL;
    if (frame != NULL) {
        memcpy(&r->frame[slot], frame, sizeof *frame);
    }
    r->next = s + 1u;
    return s;
}

uint32_t mfns_blob_ring_push(mfns_blob_ring_t *r, const mfns_obs_frame_t *frame)
{
    return r == NULL ? 0u : take(r, frame);
}

uint32_t mfns_blob_ring_skip(mfns_blob_ring_t *r)
{
    return r == NULL ? 0u : take(r, NULL);
}

const mfns_obs_frame_t *mfns_blob_ring_get(const mfns_blob_ring_t *r, uint32_t seq)
{
    if (r == NULL) {
        return NULL;
    }
    const uint32_t back = r->next - seq; /* 1: the newest; unsigned, exact across the wrap */
    if (back == 0u || back > MFNS_BLOB_RING_LEN) {
        return NULL;
    }
    const uint32_t slot = seq % MFNS_BLOB_RING_LEN;
    return r->held[slot] && r->seq[slot] == seq ? &r->frame[slot] : NULL;
}

uint32_t mfns_blob_ring_newest(const mfns_blob_ring_t *r)
{
    return r == NULL ? 0u : r->next - 1u;
}
