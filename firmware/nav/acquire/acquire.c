/* acquire.c -- see acquire.h: the API, the band schedule and the run loop.
 * The jobs of the search are in acquire_anchor.c, acquire_enum.c,
 * acquire_verify.c and acquire_complete.c (acquire_internal.h). */
#include "firmware/nav/acquire/acquire.h"
#include "math/core_inline.h"

#include <string.h>

#include "firmware/nav/acquire/acquire_internal.h"

/* The band schedule (mfns_acq_search): same-image anchors to this rank,
 * then cross anchors to this one, then the rest of both. */
#define SCHED_SAME_FIRST 8u
#define SCHED_CROSS_FIRST 4u

/* Cheap anchors first: a band of an anchor whose third blob is in the same
 * image costs N (w1^2 - w0^2) pair look-ups, one whose third is in another
 * camera N^2 (w1 - w0). In each rank range, the same-image anchors' triples
 * of the measured shape first (SHAPE_TOL: a fifth of the triples, nine
 * truths in ten), then their other triples, then the cross anchors' bands (a
 * same-image triple may be too ill-conditioned for its verification to find
 * the truth): to rank 8 (4 for cross anchors), then to the last rank
 * (measured on 1,000 module views without the shape pass: 829 right against
 * 824 with every same-image band first; docs/pose.md for the shape pass).
 * kind: 0 same image (the triples the shape pass left), 1 cross, 2 same
 * image, shape pass. */
#define KIND_SAME 0u
#define KIND_CROSS 1u
#define KIND_SHAPE 2u
static const struct {
    uint8_t kind, w_max;
} SCHED[] = {{KIND_SHAPE, SCHED_SAME_FIRST}, {KIND_SAME, SCHED_SAME_FIRST},   {KIND_CROSS, SCHED_CROSS_FIRST},
             {KIND_SHAPE, MFNS_BIDX_MAX_NBR}, {KIND_SAME, MFNS_BIDX_MAX_NBR}, {KIND_CROSS, MFNS_BIDX_MAX_NBR}};
#define SCHED_STEPS ((uint8_t)(sizeof SCHED / sizeof SCHED[0]))
_Static_assert(sizeof SCHED / sizeof SCHED[0] <= 255u, "cursor.stage is u8");
_Static_assert(KIND_SHAPE < sizeof(((mfns_acq_cursor_t *)0)->w_done), "cursor.w_done has one slot per kind");

/* The window after ranks [0, w0): doubling, capped at w_max. */
static uint8_t next_window(int w0, int w_max)
{
    const int w = w0 == 0 ? 1 : 2 * w0;
    return (uint8_t)(w < w_max ? w : w_max);
}

/* The bands, from the cursor: every step of the schedule, every window of
 * it, every anchor of its kind. */
static void run_bands(mfns_acq_t *q)
{
    mfns_acq_cursor_t *u = &q->cur;
    while (u->stage < SCHED_STEPS && !mfns_acq_stop(q)) {
        const int kind = SCHED[u->stage].kind;
        const bool cross = kind == (int)KIND_CROSS;
        const mfns_acq_band_mode_t mode = {kind == (int)KIND_SHAPE, cross ? 0 : (int)u->w_done[KIND_SHAPE]};
        const int w_max = SCHED[u->stage].w_max < q->idx->k_nbr ? SCHED[u->stage].w_max : q->idx->k_nbr;
        if (u->w == 0u) { /* the step starts after the windows its kind has done */
            u->w0 = u->w_done[kind];
            u->w = next_window(u->w0, w_max);
            u->anchor = 0u;
        }
        if ((int)u->w0 >= w_max) {
            u->w_done[kind] = u->w0;
            u->stage++;
            u->w = 0u;
            continue;
        }
        q->progress.band = u->w;
        while (u->anchor < q->na && !mfns_acq_stop(q)) {
            const mfns_acq_anchor_t *an = &q->anchor[u->anchor];
            if (an->k >= 0 && an->cross == cross) {
                mfns_acq_band(q, an, u->w0, u->w, mode);
            }
            if (!mfns_acq_stop(q)) {
                u->anchor++;
            }
        }
        if (!mfns_acq_stop(q)) { /* the window is done: the next one */
            u->w0 = u->w;
            u->w = next_window(u->w0, w_max);
            u->anchor = 0u;
        }
    }
}

/* Run the search from its cursor until it ends or the call's budget does. */
static void run(mfns_acq_t *q)
{
    if (q->cur.phase == MFNS_ACQ_PHASE_BANDS) {
        run_bands(q);
        if (q->progress.budget_out && !q->to_complete && q->certified < 0) {
            return;
        }
        q->progress.finished = true;
        q->cur.phase = mfns_acq_completion_applies(q) ? MFNS_ACQ_PHASE_COMPLETE : MFNS_ACQ_PHASE_DONE;
        if (q->cur.phase == MFNS_ACQ_PHASE_COMPLETE && q->pause_before_completion) {
            q->paused = true; /* the caller decides whether this frame's completion runs */
            return;
        }
    }
    if (q->cur.phase == MFNS_ACQ_PHASE_COMPLETE) {
        mfns_acq_run_completion(q);
    }
    q->progress.certified = q->certified >= 0;
}

/* No search: progress, cursor and candidates cleared. */
static void clear_search(mfns_acq_t *q)
{
    memset(&q->progress, 0, sizeof q->progress);
    memset(&q->cur, 0, sizeof q->cur);
    q->ncand = 0;
    q->best = -1;
    q->certified = -1;
    q->skip = -1;
    q->exhaustive = false;
    q->to_complete = false;
    q->settled = false;
    q->paused = false;
}

void mfns_acq_search(mfns_acq_t *q)
{
    clear_search(q);
    mfns_acq_make_anchors(q);
    q->cur.phase = MFNS_ACQ_PHASE_BANDS;
    q->progress.calls = 1u;
    run(q);
    q->progress.units_total = q->progress.units;
}

static bool valid_inputs(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const mfns_beacon_index_t *idx,
                         const mfns_obs_frame_t *frame, const mfns_pose_config_t *cfg)
{
    if (rig == NULL || map == NULL || idx == NULL || frame == NULL || cfg == NULL || map->count > MFNS_MAX_BEACONS ||
        idx->count != map->count || idx->k_nbr == 0 || idx->k_nbr > MFNS_BIDX_MAX_NBR ||
        !(cfg->sigma_px > 0.0f) || cfg->s.max_iterations == 0 || !(cfg->s.track_gate_px > 0.0f)) {
        return false;
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (frame->count[c] > MFNS_MAX_OBS_PER_CAMERA) {
            return false;
        }
    }
    return true;
}

bool mfns_acq_prepare(mfns_acq_t *acq, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                      const mfns_beacon_index_t *idx, const mfns_obs_frame_t *frame, const mfns_pose_config_t *cfg,
                      uint32_t budget_units, bool analysis)
{
    clear_search(acq);
    if (!valid_inputs(rig, map, idx, frame, cfg)) {
        return false;
    }
    acq->rig = rig;
    acq->map = map;
    acq->idx = idx;
    acq->frame_copy = *frame; /* a resumed search reads it after the caller's frame has moved on */
    acq->frame = &acq->frame_copy;
    acq->cfg = cfg;
    acq->budget = budget_units;
    acq->analysis = analysis;
    acq->pause_before_completion = false;
    return mfns_acq_setup(acq);
}

/* The outcome of the search so far into out. */
static mfns_pose_status_t result(const mfns_acq_t *acq, mfns_pose_solution_t *out)
{
    const uint32_t hyp = acq->progress.hypotheses;
    if (acq->certified >= 0) {
        *out = acq->cand[acq->certified].sol;
    } else {
        mfns_pose_reason_t reason = acq->progress.rivals > 0 ? MFNS_POSE_R_AMBIGUOUS : MFNS_POSE_R_NOT_IDENTIFIED;
        if (acq->progress.rivals > 0 && mfns_acq_leave_one_out(acq)) {
            /* two identifications of at least four of the five blobs: which
             * blob is the reflection cannot be told from this frame */
            reason = MFNS_POSE_R_SPURIOUS_AMBIGUOUS;
        }
        for (int i = 0; i < acq->ncand && acq->best >= 0 && acq->progress.rivals == 0; i++) {
            if (i != acq->best && acq->cand[i].inliers == acq->cand[acq->best].inliers &&
                acq->cand[i].missing == acq->cand[acq->best].missing) {
                reason = MFNS_POSE_R_AMBIGUOUS;
            }
        }
        mfns_pose_solution_clear(out, reason);
    }
    out->hypotheses = (uint16_t)(hyp > 0xFFFFu ? 0xFFFFu : hyp);
    return out->status;
}

mfns_pose_status_t mfns_acquire(mfns_acq_t *acq, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                const mfns_beacon_index_t *idx, const mfns_obs_frame_t *frame,
                                const mfns_pose_config_t *cfg, uint32_t budget_units, mfns_pose_solution_t *out)
{
    return mfns_acq_start(acq, rig, map, idx, frame, cfg, budget_units, false, out);
}

MFNS_OUT_OF_LINE
mfns_pose_status_t mfns_acq_start(mfns_acq_t *acq, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                  const mfns_beacon_index_t *idx, const mfns_obs_frame_t *frame,
                                  const mfns_pose_config_t *cfg, uint32_t budget_units, bool pause_before_completion,
                                  mfns_pose_solution_t *out)
{
    if (out == NULL) {
        return MFNS_POSE_NO_FIX;
    }
    mfns_pose_solution_clear(out, MFNS_POSE_R_BAD_ARG);
    if (acq == NULL || !mfns_acq_prepare(acq, rig, map, idx, frame, cfg, budget_units, false)) {
        return out->status;
    }
    acq->pause_before_completion = pause_before_completion;
    if (acq->nb < 3 || map->count < 3) {
        out->reason = MFNS_POSE_R_TOO_FEW;
        return out->status;
    }
    if (acq->nb < (int)MFNS_ACQ_MIN_BLOBS) {
        /* no fix from three blobs can be certified: do not search */
        out->reason = MFNS_POSE_R_BELOW_CERTIFICATE;
        return out->status;
    }
    mfns_acq_search(acq);
    return result(acq, out);
}

bool mfns_acq_pending(const mfns_acq_t *acq)
{
    return acq != NULL && (acq->progress.budget_out || acq->paused) && acq->certified < 0 &&
           (acq->cur.phase == MFNS_ACQ_PHASE_BANDS || acq->cur.phase == MFNS_ACQ_PHASE_COMPLETE);
}

mfns_pose_status_t mfns_acq_resume(mfns_acq_t *acq, uint32_t budget_units, mfns_pose_solution_t *out)
{
    if (out == NULL) {
        return MFNS_POSE_NO_FIX;
    }
    mfns_pose_solution_clear(out, MFNS_POSE_R_BAD_ARG);
    if (!mfns_acq_pending(acq)) {
        return out->status;
    }
    acq->progress.units = 0u;
    acq->progress.budget_out = false;
    acq->progress.calls = (uint16_t)(acq->progress.calls < 0xFFFFu ? acq->progress.calls + 1u : 0xFFFFu);
    acq->budget = budget_units;
    acq->pause_before_completion = false; /* resumed: the completion runs */
    run(acq);
    acq->progress.units_total += acq->progress.units;
    return result(acq, out);
}

void mfns_acq_reset(mfns_acq_t *acq)
{
    if (acq != NULL) {
        clear_search(acq);
    }
}
