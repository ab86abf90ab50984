/* acquire_cycle.c -- see acquire_cycle.h. */
#include "acquire_cycle.h"

#include <string.h>

#include "acquire_internal.h"

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
}

static bool usable(const mfns_pose_solution_t *s)
{
    return s->status == MFNS_POSE_OK || s->status == MFNS_POSE_DEGRADED;
}

/* The carried search's certified pose, of a frame age cycles old, checked on
 * this cycle's frame by tracking from it. */
static bool bridge(const mfns_pose_solution_t *carried, uint16_t age, const mfns_rig_t *rig,
                   const mfns_beacon_map_t *map, const mfns_obs_frame_t *frame, const mfns_pose_config_t *cfg,
                   mfns_pose_solution_t *out)
{
    if (age == 0u) {
        *out = *carried; /* certified on this very frame */
        return true;
    }
    mfns_pose_solution_t s;
    (void)mfns_pose_track(rig, map, frame, &carried->pose, cfg, &s); /* the status is in s */
    if (!usable(&s) || s.reason == MFNS_POSE_R_MINIMAL || s.beacons_used < MFNS_ACQ_MIN_BLOBS) {
        return false;
    }
    *out = s;
    return true;
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
    if (ac == NULL || rep == NULL || ac->fresh > 1u) {
        return out->status;
    }
    memset(rep, 0, sizeof *rep);
    if (ac->carrying) {
        ac->carry_age = (uint16_t)(ac->carry_age + 1u);
        if (ac->carry_age > MFNS_ACQ_CARRY_MAX_CYCLES) {
            mfns_acq_reset(&ac->search[1u - ac->fresh]);
            ac->carrying = false;
            rep->carry_dropped = true;
        }
    }
    /* 1. this cycle's frame */
    const uint32_t share = ac->carrying ? (uint32_t)(((uint64_t)budget_units * MFNS_ACQ_FRESH_SHARE_Q8) /
                                                     MFNS_ACQ_SHARE_ONE_Q8)
                                        : budget_units;
    mfns_acq_t *fresh = &ac->search[ac->fresh];
    /* while a search is carried, this frame's own 4-blob completion waits:
     * the carried one is further on (a still robot shows the same view) */
    (void)mfns_acq_start(fresh, rig, map, idx, frame, cfg, share, ac->carrying, out); /* the status is in out */
    rep->progress = fresh->progress;
    uint32_t used = fresh->progress.units;
    if (usable(out)) {
        if (ac->carrying) {
            mfns_acq_reset(&ac->search[1u - ac->fresh]); /* no longer needed */
            ac->carrying = false;
        }
        rep->source = MFNS_ACQ_SRC_FRESH;
        return out->status;
    }
    /* 2. an unfinished fresh search is carried when none is */
    if (!ac->carrying && mfns_acq_pending(fresh)) {
        ac->fresh = (uint8_t)(1u - ac->fresh);
        ac->carrying = true;
        ac->carry_age = 0u;
    }
    /* 3. the carried search goes on with the rest of the budget */
    if (ac->carrying && used < budget_units) {
        mfns_acq_t *carry = &ac->search[1u - ac->fresh];
        mfns_pose_solution_t cs;
        (void)mfns_acq_resume(carry, budget_units - used, &cs); /* the status is in cs */
        rep->carried_units = carry->progress.units;
        used += carry->progress.units;
        if (usable(&cs)) {
            mfns_pose_solution_t bridged;
            if (bridge(&cs, ac->carry_age, rig, map, frame, cfg, &bridged)) {
                *out = bridged;
                rep->source = MFNS_ACQ_SRC_CARRIED;
            } else {
                rep->bridge_refused = true;
            }
            mfns_acq_reset(carry);
            ac->carrying = false;
        } else if (!mfns_acq_pending(carry)) {
            mfns_acq_reset(carry); /* ended without a fix */
            ac->carrying = false;
            rep->carry_dropped = true;
        }
    }
    rep->carry_age = ac->carrying ? ac->carry_age : 0u;
    rep->progress.units = used;
    return out->status;
}
