/* acquire_cycle.c -- see acquire_cycle.h. */
#include "firmware/nav/acquire/acquire_cycle.h"
#include "math/core_inline.h"

#include <string.h>

#include "firmware/nav/acquire/acquire_internal.h"
#include "firmware/nav/pose/motion.h"

void mfns_acq_cycle_reset(mfns_acq_cycle_t *ac)
{
    if (ac == NULL) {
        return;
    }
    mfns_acq_reset(&ac->search[0]);
    mfns_acq_reset(&ac->search[1]);
    ac->fresh = 0u;
    ac->carrying = false;
    ac->carry_age = 0u;
    ac->carry_seq = 0u;
    memset(&ac->cu, 0, sizeof ac->cu);
    mfns_blob_ring_reset(&ac->ring);
}

MFNS_OUT_OF_LINE
void mfns_acq_cycle_skip(mfns_acq_cycle_t *ac)
{
    if (ac != NULL) {
        (void)mfns_blob_ring_skip(&ac->ring);
    }
}

static bool usable(const mfns_pose_solution_t *s)
{
    return s->status == MFNS_POSE_OK || s->status == MFNS_POSE_DEGRADED;
}

/* A step verified on its frame: a usable tracked pose of at least
 * MFNS_ACQ_MIN_BLOBS beacons (never a three-beacon one). */
static bool verified(const mfns_pose_solution_t *s)
{
    return usable(s) && s->reason != MFNS_POSE_R_MINIMAL && s->beacons_used >= MFNS_ACQ_MIN_BLOBS;
}

typedef enum {
    CU_GOING = 0, /* goes on next cycle (the budget stopped it, or the current frame did not verify) */
    CU_DONE,      /* verified on the current frame: out is the fix */
    CU_REFUSED,   /* a step could not be bridged: no fix */
} cu_state_t;

/* Start a catch-up from the carried search's certified solution (of the frame
 * numbered seq). */
static void catchup_start(mfns_acq_catchup_t *cu, const mfns_pose_solution_t *carried, uint32_t seq)
{
    memset(cu, 0, sizeof *cu);
    cu->active = true;
    cu->seq = seq;
    cu->from_seq = seq;
    cu->pose = carried->pose;
}

/* Step the catch-up through the ring toward its newest frame, one tracking
 * step per frame, while the budget lasts (*used grows by each step's units).
 * Bounded by the ring's length per call. */
static cu_state_t catchup_run(mfns_acq_cycle_t *ac, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                              const mfns_pose_config_t *cfg, uint32_t budget, uint32_t *used, uint16_t *steps,
                              mfns_pose_solution_t *out)
{
    mfns_acq_catchup_t *cu = &ac->cu;
    const uint32_t now = mfns_blob_ring_newest(&ac->ring);
    for (uint32_t n = 0u; n < MFNS_BLOB_RING_LEN && cu->seq != now; n++) {
        if (budget < *used + MFNS_ACQ_CATCHUP_STEP_UNITS) {
            return CU_GOING;
        }
        *used += MFNS_ACQ_CATCHUP_STEP_UNITS;
        const uint32_t next = cu->seq + 1u;
        const mfns_obs_frame_t *f = mfns_blob_ring_get(&ac->ring, next);
        mfns_pose_t pred;
        mfns_motion_predict_cv(&cu->pose, &cu->prev, cu->have_prev, &pred);
        mfns_pose_solution_t s;
        mfns_pose_solution_clear(&s, MFNS_POSE_R_TOO_FEW);
        if (f != NULL) {
            (void)mfns_pose_track(rig, map, f, &pred, cfg, &s); /* the status is in s */
        } else if (now - next >= MFNS_BLOB_RING_LEN) {
            return CU_REFUSED; /* overwritten: the ring no longer holds the frames in between */
        } /* else a cycle without a frame (mfns_acq_cycle_skip): coasted over */
        cu->seq = next;
        cu->steps++;
        (*steps)++;
        /* A verified frame carries the identification on; so does a
         * three-beacon pose inside the gate, as it carries the navigator's
         * track, but it verifies nothing. Only a pose verified on the current
         * frame is the fix; the current frame unverified, the catch-up waits
         * for the next one (never a fix from an unverified frame). */
        const bool ok = verified(&s);
        if (ok || (s.status == MFNS_POSE_NO_FIX && s.reason == MFNS_POSE_R_MINIMAL)) {
            cu->have_prev = cu->coast == 0u; /* a motion only between two verified frames */
            cu->coast = 0u;
            mfns_motion_advance(&cu->pose, &cu->prev, &s.pose);
            if (ok && next == now) {
                *out = s;
                return CU_DONE;
            }
            continue;
        }
        /* any other frame is coasted over, at most MFNS_ACQ_CATCHUP_MAX_COAST
         * in a row */
        cu->coast++;
        if (cu->coast > MFNS_ACQ_CATCHUP_MAX_COAST) {
            return CU_REFUSED;
        }
        mfns_motion_advance(&cu->pose, &cu->prev, &pred); /* the coast keeps the motion (have_prev stays) */
    }
    return CU_GOING;
}

/* Go on with a catch-up (or start one): the fix when it reaches the current
 * frame verified. */
static bool catchup(mfns_acq_cycle_t *ac, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                    const mfns_pose_config_t *cfg, uint32_t budget, uint32_t *used, mfns_pose_solution_t *out,
                    mfns_acq_cycle_report_t *rep)
{
    const cu_state_t st = catchup_run(ac, rig, map, cfg, budget, used, &rep->catchup_steps, out);
    if (st == CU_GOING) {
        rep->catchup_pending = true;
        return false;
    }
    ac->cu.active = false;
    if (st == CU_DONE) {
        rep->source = MFNS_ACQ_SRC_CARRIED;
        const uint32_t age = ac->cu.seq - ac->cu.from_seq;
        rep->carry_age = (uint16_t)(age > UINT16_MAX ? UINT16_MAX : age);
        return true;
    }
    rep->bridge_refused = true;
    return false;
}

mfns_pose_status_t mfns_acq_cycle_run(mfns_acq_cycle_t *ac, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                      const mfns_beacon_index_t *idx, const mfns_obs_frame_t *frame,
                                      const mfns_pose_config_t *cfg, uint32_t budget_units,
                                      mfns_pose_solution_t *out, mfns_acq_cycle_report_t *rep)
{
    if (out == NULL) {
        return MFNS_POSE_NO_FIX;
    }
    mfns_pose_solution_clear(out, MFNS_POSE_R_BAD_ARG);
    if (ac == NULL || rep == NULL || ac->fresh > 1u || frame == NULL) {
        return out->status;
    }
    memset(rep, 0, sizeof *rep);
    const uint32_t now = mfns_blob_ring_push(&ac->ring, frame);
    if (ac->carrying) {
        const uint32_t age = now - ac->carry_seq;
        ac->carry_age = (uint16_t)(age > UINT16_MAX ? UINT16_MAX : age);
        if (ac->carry_age > MFNS_ACQ_CARRY_MAX_CYCLES) {
            mfns_acq_reset(&ac->search[1u - ac->fresh]);
            ac->carrying = false;
            rep->carry_dropped = true;
        }
    }
    uint32_t used = 0u;
    /* 0. a catch-up under way comes first: it is a fix but for a few steps */
    if (ac->cu.active && catchup(ac, rig, map, cfg, budget_units, &used, out, rep)) {
        if (ac->carrying) {
            mfns_acq_reset(&ac->search[1u - ac->fresh]); /* a later search is moot now */
            ac->carrying = false;
        }
        rep->progress.units = used;
        return out->status;
    }
    const uint32_t left = budget_units - used;
    /* 1. this cycle's frame */
    const uint32_t share = ac->carrying ? (uint32_t)(((uint64_t)left * MFNS_ACQ_FRESH_SHARE_Q8) /
                                                     MFNS_ACQ_SHARE_ONE_Q8)
                                        : left;
    mfns_acq_t *fresh = &ac->search[ac->fresh];
    /* while a search is carried, this frame's own 4-blob completion waits:
     * the carried one is further on (a still robot shows the same view).
     * Into out: the fix, or NO_FIX with the fresh search's reason unless a
     * carried one bridges */
    (void)mfns_acq_start(fresh, rig, map, idx, frame, cfg, share, ac->carrying, out); /* the status is in out */
    rep->progress = fresh->progress;
    used += fresh->progress.units;
    if (usable(out)) {
        if (ac->carrying) {
            mfns_acq_reset(&ac->search[1u - ac->fresh]); /* no longer needed */
            ac->carrying = false;
        }
        ac->cu.active = false;
        rep->source = MFNS_ACQ_SRC_FRESH;
        rep->catchup_pending = false;
        rep->progress.units = used;
        return out->status;
    }
    /* 2. an unfinished fresh search is carried when none is */
    if (!ac->carrying && mfns_acq_pending(fresh)) {
        ac->fresh = (uint8_t)(1u - ac->fresh);
        ac->carrying = true;
        ac->carry_age = 0u;
        ac->carry_seq = now;
    }
    /* 3. the carried search goes on with the rest of the budget */
    if (ac->carrying && used < budget_units) {
        mfns_acq_t *carry = &ac->search[1u - ac->fresh];
        mfns_pose_solution_t cs;
        /* keep what a catch-up from the carried frame to this one costs, when
         * the budget allows, so that a certification is a fix in this cycle */
        const uint32_t reserve = (uint32_t)ac->carry_age * MFNS_ACQ_CATCHUP_STEP_UNITS;
        const uint32_t rest = budget_units - used;
        (void)mfns_acq_resume(carry, reserve < rest / 2u ? rest - reserve : rest, &cs); /* the status is in cs */
        rep->carried_units = carry->progress.units;
        used += carry->progress.units;
        if (usable(&cs)) {
            mfns_acq_reset(carry);
            ac->carrying = false;
            if (ac->carry_seq == now) {
                *out = cs; /* certified on this very frame */
                rep->source = MFNS_ACQ_SRC_CARRIED;
            } else {
                catchup_start(&ac->cu, &cs, ac->carry_seq); /* replaces an older catch-up */
                rep->catchup_pending = false;
                (void)catchup(ac, rig, map, cfg, budget_units, &used, out, rep);
            }
        } else if (!mfns_acq_pending(carry)) {
            mfns_acq_reset(carry); /* ended without a fix */
            ac->carrying = false;
            rep->carry_dropped = true;
        }
    }
    if (rep->source != MFNS_ACQ_SRC_CARRIED) {
        rep->carry_age = ac->carrying ? ac->carry_age : 0u;
    }
    rep->progress.units = used;
    return out->status;
}
