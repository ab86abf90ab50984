/* plan_fix.h -- the flight's verdict on one view, for the layout planner
 * (host only: `mfns plan` calls it through the shared library, binding.py).
 *
 * A layout is planned for what flies: the share of workspace poses whose fix
 * the flight code would use. For one pose and the frame the rig sees from it
 * (mfns_certify_frame: the flight camera model, noise-free) with its true
 * association, this runs the flight's own snapshot chain -- the solver
 * (mfns_pose_refine from the true pose, the association given: what a
 * tracked or certified acquisition hands the solver) and then integrity
 * (mfns_integrity_fde with a fresh memory: the test, the exclusion and the
 * protection level against the alert limits) -- and reports its verdict and
 * PLs. Nothing here decides anything itself: the status, reason, PLs and
 * sigmas are the core's.
 *
 * What it leaves out, and the planner says so: the acquisition (whether the
 * view is identified in one call is the map analysis's question,
 * acquire_certify.h), measurement noise (the frame is exact, so no test fails
 * and no exclusion happens: the PL is the geometry's, which is what a layout
 * controls), memory across cycles (a beacon held out by an earlier
 * exclusion), and the camera health checks.
 */
#ifndef MFNS_PLAN_FIX_H
#define MFNS_PLAN_FIX_H

#include <stdint.h>

#include "firmware/nav/integrity/integrity.h"
#include "firmware/nav/pose/pose.h"

typedef struct {
    int32_t status;             /* mfns_pose_status_t after integrity (FIX, DEGRADED, NO_FIX) */
    int32_t reason;             /* mfns_pose_reason_t */
    float pl_pos_mm;            /* protection levels of the fix (INFINITY: unmonitorable) */
    float pl_att_deg;
    float sigma_pos_mm[3];      /* the fix's 1-sigma per world axis */
    float sigma_euler_deg[3];   /* roll, pitch, yaw */
    uint16_t beacons_used;      /* inlier observations */
    uint16_t cameras_used;
    uint16_t unmonitorable;     /* hypotheses with no subset left to check them */
    uint8_t usable;             /* 1: the flight would output this fix as usable */
    uint8_t camera_unmonitored; /* usable with camera faults left to the health checks */
} mfns_plan_fix_t;

/* Solve and judge the view (frame, assoc) of the pose truth. set NULL: the
 * flight's defaults (mfns_integrity_settings_default). Returns 0, or -1 on a
 * NULL argument or invalid settings (out zeroed, status NO_FIX). */
int mfns_plan_fix(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const mfns_obs_frame_t *frame,
                  const mfns_pose_assoc_t *assoc, const mfns_pose_t *truth, const mfns_pose_config_t *cfg,
                  const mfns_integrity_settings_t *set, mfns_plan_fix_t *out);

#endif /* MFNS_PLAN_FIX_H */
