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
 * A carried search certifies an identification of an older frame k. Its pose
 * is never output as such: it is carried forward frame by frame through the
 * blob lists of the cycles since (blob_ring.h, "catch-up"): from the pose
 * verified on frame j, the constant-velocity prediction for frame j + 1
 * (the motion between the last two verified frames) is tracked on j + 1
 * (mfns_pose_track, the tracking gate around the beacons it predicts). A step
 * is verified when tracking gives a usable pose of at least
 * MFNS_ACQ_MIN_BLOBS beacons; a frame that does not verify is coasted over
 * (the prediction moves on), at most MFNS_ACQ_CATCHUP_MAX_COAST in a row; a
 * three-beacon pose inside the gate carries it on without verifying it (as
 * it carries the navigator's track: only while the robot sees three of the
 * beacons it predicts, each frame within the gate). Only a pose
 * verified on the current frame is the fix (source CARRIED): a current frame
 * that does not verify counts as a coasted one and the catch-up goes on with
 * the next cycle's frame. A robot that moved beyond the gate between two
 * stored frames (then nothing verifies), more coasted frames in a row, or a
 * frame the ring no longer holds: no fix (bridge_refused), and the search
 * starts again.
 * Each step costs MFNS_ACQ_CATCHUP_STEP_UNITS of the cycle's budget; a
 * catch-up the budget stops goes on, first, in the next cycle (the ring keeps
 * the frames). This is the trust tracking gives a robot it follows frame by
 * frame; what it misses: a wrong identification that tracks consistently
 * through every frame (as tracking itself would), and motion beyond the
 * gate between two frames (then refused, never wrong).
 *
 * The caller gives every cycle's frame to mfns_acq_cycle_run, or says there
 * was none (mfns_acq_cycle_skip): the ring numbers cycles, so the age of a
 * carried frame is exact.
 *
 * All state is the caller's (two searches and the ring, about 117 KB); no
 * heap; every loop bounded by the budget or the ring's length.
 */
#ifndef MFNS_ACQUIRE_CYCLE_H
#define MFNS_ACQUIRE_CYCLE_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/acquire/acquire.h"
#include "firmware/nav/acquire/blob_ring.h"

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
_Static_assert(MFNS_BLOB_RING_LEN > MFNS_ACQ_CARRY_MAX_CYCLES,
               "the ring holds every frame after a carried search's, up to the current one");
/* Work units of one catch-up step: an association and a refinement, as a full
 * verification of the search (MFNS_ACQ_VERIFY_UNITS plus a unit per 8 of up
 * to 24 beacons: about 20-40 us on the benchmark host). */
#define MFNS_ACQ_CATCHUP_STEP_UNITS (MFNS_ACQ_VERIFY_UNITS + 3u)
/* Frames in a row a catch-up may coast over (too few beacons, a step that
 * does not verify): as tracking coasts, but shorter, since nothing but the
 * last verified pose and its motion carries the identification on. */
#define MFNS_ACQ_CATCHUP_MAX_COAST 3u
_Static_assert(MFNS_ACQ_CATCHUP_STEP_UNITS * MFNS_BLOB_RING_LEN < 15000u,
               "a whole catch-up fits one cycle's default budget");

typedef enum {
    MFNS_ACQ_SRC_NONE = 0,  /* no fix this cycle */
    MFNS_ACQ_SRC_FRESH,     /* certified on this cycle's frame */
    MFNS_ACQ_SRC_CARRIED,   /* certified on an older frame, bridged to this one */
} mfns_acq_source_t;

/* A catch-up under way: the identification carried forward through the ring. */
typedef struct {
    bool active;
    uint8_t coast;      /* frames coasted over in a row */
    bool have_prev;     /* prev is a verified pose one frame before pose */
    uint16_t steps;     /* frames stepped through so far */
    uint32_t seq;       /* ring number of the frame pose belongs to */
    uint32_t from_seq;  /* ring number of the certified frame */
    mfns_pose_t pose;   /* verified on frame seq (or coasted to it) */
    mfns_pose_t prev;   /* the pose of the frame before, for the motion */
} mfns_acq_catchup_t;

typedef struct {
    mfns_acq_t search[2];
    uint8_t fresh;       /* slot of the next fresh search; the other holds the carried one */
    bool carrying;       /* a search is carried */
    uint16_t carry_age;  /* cycles since the carried search's frame */
    uint32_t carry_seq;  /* ring number of the carried search's frame */
    mfns_acq_catchup_t cu;
    mfns_blob_ring_t ring; /* every cycle's frame (blob_ring.h) */
} mfns_acq_cycle_t;

/* What one cycle did (telemetry: the housekeeping's acquisition figures). */
typedef struct {
    mfns_acq_progress_t progress; /* the fresh search's, with units the cycle's total */
    uint32_t carried_units;       /* of which the carried search spent */
    uint16_t carry_age;           /* age of the carried search's frame (0: none carried); with a
                                   * fix from a carried search, the age of its certified frame */
    uint8_t source;               /* mfns_acq_source_t */
    bool carry_dropped;           /* a carried search ended without a fix or grew too old */
    bool bridge_refused;          /* a carried search certified, but this frame did not confirm it */
    uint16_t catchup_steps;       /* frames a catch-up stepped through this cycle */
    bool catchup_pending;         /* a catch-up goes on next cycle (budget) */
} mfns_acq_cycle_report_t;

/* Start with nothing carried and an empty ring. */
void mfns_acq_cycle_reset(mfns_acq_cycle_t *ac);

/* A cycle that did not run acquisition while a search may be carried (the
 * navigator coasted a track): its frame is missing from the ring, and the
 * carried frame is one cycle older. */
void mfns_acq_cycle_skip(mfns_acq_cycle_t *ac);

/* One cycle of acquisition on frame (see top of file). out is OK/DEGRADED
 * only for a certified identification verified on frame (fresh, or carried
 * and caught up to it); otherwise NO_FIX
 * with the fresh search's reason. rig, map, idx and cfg must be those of the
 * earlier cycles while a search is carried (reset on a table change). */
mfns_pose_status_t mfns_acq_cycle_run(mfns_acq_cycle_t *ac, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                      const mfns_beacon_index_t *idx, const mfns_obs_frame_t *frame,
                                      const mfns_pose_config_t *cfg, uint32_t budget_units,
                                      mfns_pose_solution_t *out, mfns_acq_cycle_report_t *rep);

#endif /* MFNS_ACQUIRE_CYCLE_H */
