/* tlm_txq.c -- drop-oldest frame queue (see tlm_txq.h). */
#include "firmware/tlm/tlm_txq.h"

#include <string.h>

_Static_assert(TLM_MAX_WIRE <= TLM_TXQ_MAX_WIRE, "every telemetry frame fits the queue's longest");

#define SLOT(i) ((i) & (TLM_TXQ_FRAMES - 1u))
#define POS(i) ((i) % TLM_TXQ_BYTES)

void tlm_txq_init(tlm_txq_t *q)
{
    if (q != NULL) {
        memset(q, 0, sizeof *q);
    }
}

/* Drop the oldest frame that has not started. Returns false if none. */
static int drop_oldest(tlm_txq_t *q)
{
    if (q->frames == 0u) {
        return 0;
    }
    uint32_t len; /* bytes dropped: the head frame's, or the second frame's */
    if (!q->head_started) {
        len = q->frame_len[SLOT(q->head_frame)];
    } else {
        if (q->frames < 2u) {
            return 0;
        }
        /* Remove the second frame: slide the head frame's unsent rest (rem
         * bytes) forward over it so it ends where the second frame ended,
         * and give the rest the second frame's slot. Bounded by
         * TLM_MAX_WIRE byte moves. */
        const uint32_t rem = q->frame_len[SLOT(q->head_frame)];
        len = q->frame_len[SLOT(q->head_frame + 1u)];
        for (uint32_t k = rem; k > 0u; k--) {
            q->data[POS(q->head + len + k - 1u)] = q->data[POS(q->head + k - 1u)];
        }
        q->frame_len[SLOT(q->head_frame + 1u)] = (uint16_t)rem;
    }
    q->head = POS(q->head + len);
    q->used -= len;
    q->head_frame++;
    q->frames--;
    q->dropped++;
    q->dropped_bytes += len;
    return 1;
}

int tlm_txq_push(tlm_txq_t *q, const uint8_t *frame, size_t len)
{
    if (q == NULL || frame == NULL) {
        return TLM_ERR_NULL;
    }
    if (len == 0u || len > TLM_TXQ_MAX_WIRE) {
        return TLM_ERR_ARG;
    }
    /* Bounded: each pass removes one queued frame. */
    while (q->used + len > TLM_TXQ_BYTES || q->frames >= TLM_TXQ_FRAMES) {
        if (!drop_oldest(q)) {
            q->dropped++;
            q->dropped_bytes += (uint32_t)len;
            return TLM_ERR_BUFFER;
        }
    }
    const uint32_t tail = POS(q->head + q->used);
    const size_t first = (len < TLM_TXQ_BYTES - tail) ? len : TLM_TXQ_BYTES - tail;
    memcpy(q->data + tail, frame, first);
    memcpy(q->data, frame + first, len - first);
    q->frame_len[SLOT(q->head_frame + q->frames)] = (uint16_t)len;
    q->frames++;
    q->used += (uint32_t)len;
    q->pushed++;
    return TLM_OK;
}

size_t tlm_txq_peek(const tlm_txq_t *q, const uint8_t **data)
{
    if (q == NULL || data == NULL || q->used == 0u) {
        return 0;
    }
    *data = q->data + q->head;
    const uint32_t to_wrap = TLM_TXQ_BYTES - q->head;
    return (q->used < to_wrap) ? q->used : to_wrap;
}

void tlm_txq_consume(tlm_txq_t *q, size_t n)
{
    if (q == NULL) {
        return;
    }
    if (n > q->used) {
        n = q->used;
    }
    /* Bounded by the frames queued: each pass retires one frame or stops. */
    while (n > 0u && q->frames > 0u) {
        uint16_t *fl = &q->frame_len[SLOT(q->head_frame)];
        const size_t take = (n < *fl) ? n : *fl;
        *fl = (uint16_t)(*fl - take);
        q->head = POS(q->head + (uint32_t)take);
        q->used -= (uint32_t)take;
        n -= take;
        if (*fl == 0u) {
            q->head_frame++;
            q->frames--;
            q->sent++;
            q->head_started = 0;
        } else {
            q->head_started = 1;
        }
    }
}

void tlm_txq_discard_partial(tlm_txq_t *q)
{
    if (q == NULL || !q->head_started || q->frames == 0u) {
        return;
    }
    const uint32_t rem = q->frame_len[SLOT(q->head_frame)];
    q->head = POS(q->head + rem);
    q->used -= rem;
    q->head_frame++;
    q->frames--;
    q->head_started = 0;
    q->dropped++;
    q->dropped_bytes += rem;
}

size_t tlm_txq_bytes(const tlm_txq_t *q)
{
    return q != NULL ? q->used : 0u;
}

size_t tlm_txq_frames(const tlm_txq_t *q)
{
    return q != NULL ? q->frames : 0u;
}
