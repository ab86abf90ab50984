/* acquire_cycle.h -- lost-in-space acquisition over navigation cycles: every
 * cycle searches its own frame afresh, and a search its budget stopped goes
 * on in the following cycles on the frame it started from (acquire.h,
 * "Resumable"), so that a view whose search needs more than one cycle's
 * budget (a 4-blob view's exhaustive completion, an ill-conditioned anchor)
 * is still identified while no cycle overruns its budget.
 *
 * Each cycle, within budget_units in all:
 *   1. the fresh search of this cycle's frame, with the whole budget when no
 *      search is carried, else with MFNS_ACQ_FRESH_SHARE_Q8 of it (an easy
 *      view is certified in a few hundred units: docs/pose.md) and stopping
 *      where a 4-blob completion would start (the carried search of a still
 *      robot is the same view, further on);
 *   2. a fresh search that its budget stopped becomes the carried search
 *      when none is carried (the oldest unfinished search is kept: a search
 *      replaced every cycle would never end);
 *   3. the carried search goes on with what the budget has left. It is
 *      dropped when it ends without a fix, or after
 *      MFNS_ACQ_CARRY_MAX_CYCLES cycles.
 * A carried search certifies an identification of an older frame. Its pose is
 * never output as such: the cycle's own frame is tracked from it
 * (mfns_pose_track, the tracking gate around the beacons it predicts), and
 * only a pose of at least MFNS_ACQ_MIN_BLOBS beacons that tracking verifies
 * on this frame is the fix ("bridged"). When the robot has moved too far for
 * the gate, the bridge fails: no fix, and the search starts again. This is
 * the trust tracking already gives a prediction coasted over as many cycles.
 *
 * All state is the caller's (two searches, 23,096 B); no heap; every
 * loop bounded by the budget.
 */
#ifndef MFNS_ACQUIRE_CYCLE_H
#define MFNS_ACQUIRE_CYCLE_H

#include <stdbool.h>
#include <stdint.h>

#include "acquire.h"

/* Cycles a search may be carried: 1.7 s at 18.6 Hz, long enough for the
 * exhaustive completion of nearly every 4-blob view of the 60-beacon module
 * (docs/pose.md); an older frame is a poor prior for the bridge (which then
 * refuses: no fix). */
#define MFNS_ACQ_CARRY_MAX_CYCLES 32u
/* The fresh search's share of the budget while a search is carried, in
 * 1/256ths (half). */
#define MFNS_ACQ_FRESH_SHARE_Q8 128u
#define MFNS_ACQ_SHARE_ONE_Q8 256u
_Static_assert(MFNS_ACQ_FRESH_SHARE_Q8 <= MFNS_ACQ_SHARE_ONE_Q8, "the fresh search's share is at most the budget");
_Static_assert(MFNS_ACQ_CARRY_MAX_CYCLES <= UINT16_MAX, "carry_age is u16");

typedef enum {
    MFNS_ACQ_SRC_NONE = 0,  /* no fix this cycle */
    MFNS_ACQ_SRC_FRESH,     /* certified on this cycle's frame */
    MFNS_ACQ_SRC_CARRIED,   /* certified on an older frame, bridged to this one */
} mfns_acq_source_t;

typedef struct {
    mfns_acq_t search[2];
    uint8_t fresh;       /* slot of the next fresh search; the other holds the carried one */
    bool carrying;       /* a search is carried */
    uint16_t carry_age;  /* cycles since the carried search's frame */
} mfns_acq_cycle_t;

/* What one cycle did (telemetry: the housekeeping's acquisition figures). */
typedef struct {
    mfns_acq_progress_t progress; /* the fresh search's, with units the cycle's total */
    uint32_t carried_units;       /* of which the carried search spent */
    uint16_t carry_age;           /* age of the carried search's frame (0: none carried) */
    uint8_t source;               /* mfns_acq_source_t */
    bool carry_dropped;           /* a carried search ended without a fix or grew too old */
    bool bridge_refused;          /* a carried search certified, but this frame did not confirm it */
} mfns_acq_cycle_report_t;

/* Start with nothing carried. */
void mfns_acq_cycle_reset(mfns_acq_cycle_t *ac);

/* One cycle of acquisition on frame (see top of file). out is OK/DEGRADED
 * only for a certified identification verified on frame; otherwise NO_FIX
 * with the fresh search's reason. rig, map, idx and cfg must be those of the
 * earlier cycles while a search is carried (reset on a table change). */
mfns_pose_status_t mfns_acq_cycle_run(mfns_acq_cycle_t *ac, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                      const mfns_beacon_index_t *idx, const mfns_obs_frame_t *frame,
                                      const mfns_pose_config_t *cfg, uint32_t budget_units,
                                      mfns_pose_solution_t *out, mfns_acq_cycle_report_t *rep);

#endif /* MFNS_ACQUIRE_CYCLE_H */
