/* plan_fix.c -- see plan_fix.h. */
#include "firmware/host/plan_fix.h"

#include <math.h>
#include <string.h>

#include "firmware/nav/settings/nav_settings.h"

int mfns_plan_fix(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const mfns_obs_frame_t *frame,
                  const mfns_pose_assoc_t *assoc, const mfns_pose_t *truth, const mfns_pose_config_t *cfg,
                  const mfns_integrity_settings_t *set, mfns_plan_fix_t *out)
{
    if (out == NULL) {
        return -1;
    }
    memset(out, 0, sizeof *out);
    out->status = (int32_t)MFNS_POSE_NO_FIX;
    if (rig == NULL || map == NULL || frame == NULL || assoc == NULL || truth == NULL || cfg == NULL) {
        return -1;
    }
    mfns_integrity_settings_t def;
    if (set == NULL) {
        mfns_integrity_settings_default(&def);
        set = &def;
    }
    if (!mfns_integrity_settings_valid(set)) {
        return -1;
    }
    mfns_pose_solution_t sol;
    (void)mfns_pose_refine(rig, map, frame, assoc, truth, cfg, &sol); /* the verdict is in sol */
    mfns_integrity_memory_t mem;
    mfns_integrity_memory_reset(&mem);
    mfns_integrity_result_t res;
    memset(&res, 0, sizeof res);
    const bool usable = mfns_integrity_fde(&mem, rig, map, frame, cfg, set, &sol, &res);
    out->status = (int32_t)sol.status;
    out->reason = (int32_t)sol.reason;
    out->pl_pos_mm = res.evaluated ? res.pl_pos_mm : INFINITY;
    out->pl_att_deg = res.evaluated ? res.pl_att_deg : INFINITY;
    for (int i = 0; i < 3; i++) {
        out->sigma_pos_mm[i] = sol.sigma_pos_mm[i];
        out->sigma_euler_deg[i] = sol.sigma_euler_deg[i];
    }
    out->beacons_used = sol.beacons_used;
    out->cameras_used = sol.cameras_used;
    out->unmonitorable = res.unmonitorable;
    out->usable = usable ? 1U : 0U;
    out->camera_unmonitored = res.camera_unmonitored ? 1U : 0U;
    return 0;
}
