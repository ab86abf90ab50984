/* blob_ring.h -- the last cycles' blob lists (corrected observations), kept so
 * that an identification certified on an older frame can be carried forward
 * frame by frame to the current one (acquire_cycle.h, "catch-up").
 *
 * A bounded ring of MFNS_BLOB_RING_LEN frames, each stored with the number of
 * the cycle it came from (its sequence number). Caller-owned storage (about
 * 2.7 KB a frame, 92 KB in all): no heap, no statics. A cycle that stores no
 * frame (mfns_blob_ring_skip) still takes a number, so a frame that was never
 * stored, or has been overwritten, is never mistaken for another: lookups are
 * by sequence number and return NULL for a frame the ring does not hold.
 *
 * Sequence numbers are uint32 and wrap after 2^32 cycles (7.3 years at
 * 18.6 Hz); all comparisons are unsigned differences, exact across the wrap.
 */
#ifndef MFNS_BLOB_RING_H
#define MFNS_BLOB_RING_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/pose/pose.h"

/* Frames the ring holds: the carried search's own frame is kept by the search
 * (mfns_acq_t.frame_copy); the ring holds every later frame up to the current
 * one, at most MFNS_ACQ_CARRY_MAX_CYCLES of them (acquire_cycle.h asserts it). */
#define MFNS_BLOB_RING_LEN 34u
_Static_assert(MFNS_BLOB_RING_LEN >= 2u && MFNS_BLOB_RING_LEN <= UINT16_MAX, "ring slots are u16");

typedef struct {
    mfns_obs_frame_t frame[MFNS_BLOB_RING_LEN];
    uint32_t seq[MFNS_BLOB_RING_LEN]; /* sequence number of the frame in the slot */
    bool held[MFNS_BLOB_RING_LEN];    /* the slot holds a frame */
    uint32_t next;                    /* sequence number of the next cycle */
} mfns_blob_ring_t;

/* Empty the ring; numbering starts at 0. */
void mfns_blob_ring_reset(mfns_blob_ring_t *r);

/* Store this cycle's frame (copied); returns its sequence number. A NULL
 * frame is stored as a skip. */
uint32_t mfns_blob_ring_push(mfns_blob_ring_t *r, const mfns_obs_frame_t *frame);

/* A cycle without a frame: takes a sequence number, stores nothing (and
 * forgets whatever the slot held). Returns that number. */
uint32_t mfns_blob_ring_skip(mfns_blob_ring_t *r);

/* The frame of cycle seq, or NULL when the ring does not hold it (skipped,
 * overwritten, not yet pushed, r NULL). */
const mfns_obs_frame_t *mfns_blob_ring_get(const mfns_blob_ring_t *r, uint32_t seq);

/* Sequence number of the newest cycle (pushed or skipped); meaningless on an
 * empty ring (check mfns_blob_ring_get). */
uint32_t mfns_blob_ring_newest(const mfns_blob_ring_t *r);

#endif /* MFNS_BLOB_RING_H */
