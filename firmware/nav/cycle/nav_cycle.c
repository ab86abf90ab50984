/* nav_cycle.c -- see nav_cycle.h. */
#include "firmware/nav/cycle/nav_cycle.h"
#include "math/core_text.h"

#include <math.h>
#include <string.h>

#include "firmware/nav/pose/motion.h"
#include "math/undistort.h"
#include "math/units.h"

#define NAV_MAGIC 0x4E415631u /* "NAV1" */

const char *mfns_nav_strerror(mfns_nav_status_t s)
{
    switch (s) {
    case MFNS_NAV_OK:
        return MFNS_MSG("ok");
    case MFNS_NAV_E_ARG:
        return MFNS_MSG("navigation cycle: null pointer or not initialised");
    case MFNS_NAV_E_TABLE:
        return MFNS_MSG("navigation cycle: calibration-table settings refused by the centroider");
    }
    return MFNS_MSG("navigation cycle: unknown status");
}

const char *mfns_nav_mode_str(mfns_nav_mode_t m)
{
    return m == MFNS_NAV_MODE_TRACK ? "track" : "acquire";
}

const char *mfns_nav_cam_state_str(mfns_nav_cam_state_t s)
{
    switch (s) {
    case MFNS_NAV_CAM_OK:
        return MFNS_MSG("ok");
    case MFNS_NAV_CAM_NO_FRAME:
        return MFNS_MSG("no frame");
    case MFNS_NAV_CAM_FRAME_ERROR:
        return MFNS_MSG("frame refused");
    case MFNS_NAV_CAM_TABLE_FULL:
        return MFNS_MSG("blob table full");
    }
    return MFNS_MSG("?");
}

/* The table's settings, noise model and uncertainty terms: what a bind takes from it
 * (mfns_nav_init, mfns_nav_rebind). */
static void take_settings(mfns_nav_t *nav, const mfns_caltable_t *table, mfns_pose_mode_t mode)
{
    nav->table = table;
    mfns_pose_config_default(&nav->pose_cfg);
    nav->pose_cfg.s = table->solver;
    nav->pose_cfg.sigma_px = table->pixel_sigma_px;
    nav->pose_cfg.calib_cov = &table->calib_cov; /* the table outlives the cycle */
    nav->pose_cfg.datum = &table->datum;
    nav->pose_cfg.mode = mode;
    nav->integ_set = table->integrity;
}

mfns_nav_status_t mfns_nav_init(mfns_nav_t *nav, const mfns_caltable_t *table, mfns_pose_mode_t mode)
{
    if (nav == NULL || table == NULL) {
        return MFNS_NAV_E_ARG;
    }
    memset(nav, 0, sizeof *nav);
    take_settings(nav, table, mode);
    nav->map = table->beacons;
    nav->mode = MFNS_NAV_MODE_ACQUIRE;
    mfns_acq_cycle_reset(&nav->acq);
    mfns_integrity_memory_reset(&nav->integ_mem);
    mfns_bmon_reset(&nav->bmon);
    mfns_ws_watch_init(&nav->wsw); /* the new table's box, as declared */
    mfns_spot_init(&nav->spots);
    nav->magic = NAV_MAGIC;
    return MFNS_NAV_OK;
}

/* Same rig and same beacons, value for value (ids and positions; sigmas may differ).
 * Member by member: a float's representation is not unique (+0 and -0), its value is;
 * a validated table holds no NaN. */
static bool same_v3(mfns_v3_t a, mfns_v3_t b)
{
    return a.x == b.x && a.y == b.y && a.z == b.z;
}

static bool same_camera(const mfns_camera_t *a, const mfns_camera_t *b)
{
    const mfns_intrinsics_t *ka = &a->k, *kb = &b->k;
    bool same = ka->fx == kb->fx && ka->fy == kb->fy && ka->cx == kb->cx && ka->cy == kb->cy &&
                ka->skew == kb->skew && ka->width == kb->width && ka->height == kb->height &&
                same_v3(a->r_bk_b, b->r_bk_b);
    for (int i = 0; i < 5 && same; i++) {
        same = ka->dist[i] == kb->dist[i];
    }
    for (int r = 0; r < 3 && same; r++) {
        for (int c = 0; c < 3 && same; c++) {
            same = a->C_k_b.m[r][c] == b->C_k_b.m[r][c];
        }
    }
    return same;
}

static bool same_system(const mfns_caltable_t *a, const mfns_caltable_t *b)
{
    if (a->beacons.count != b->beacons.count) {
        return false;
    }
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        if (!same_camera(&a->rig.cam[k], &b->rig.cam[k])) {
            return false;
        }
    }
    for (uint32_t i = 0; i < a->beacons.count && i < MFNS_MAX_BEACONS; i++) {
        const mfns_beacon_t *x = &a->beacons.beacon[i], *y = &b->beacons.beacon[i];
        if (x->id != y->id || !same_v3(x->p_w, y->p_w)) {
            return false;
        }
    }
    return true;
}

mfns_nav_status_t mfns_nav_rebind(mfns_nav_t *nav, const mfns_caltable_t *table, bool *kept)
{
    if (nav == NULL || table == NULL || kept == NULL || nav->magic != NAV_MAGIC || nav->table == NULL) {
        return MFNS_NAV_E_ARG;
    }
    *kept = same_system(nav->table, table);
    if (!*kept) {
        return MFNS_NAV_OK;
    }
    take_settings(nav, table, nav->pose_cfg.mode);
    nav->map = table->beacons;
    for (uint32_t b = 0; b < nav->map.count && b < MFNS_MAX_BEACONS; b++) {
        if (nav->bmon.flagged[b] != 0U) {
            nav->map.beacon[b].sigma_mm *= nav->bmon.sigma_scale[b]; /* down-weighted, as before */
        }
    }
    return MFNS_NAV_OK;
}

mfns_nav_status_t mfns_nav_set_prior(mfns_nav_t *nav, const mfns_pose_t *pose)
{
    if (nav == NULL || pose == NULL || nav->magic != NAV_MAGIC || !mfns_m3_is_rotation_at(&pose->C_w_b, 1e-4f) ||
        !(mfns_v3_norm(pose->r_bw_b) < 1e7f)) { /* also false for NaN */
        return MFNS_NAV_E_ARG;
    }
    nav->prior = *pose;
    nav->prior_is_fix = false;
    nav->have_prior = true;
    nav->have_prev = false;
    nav->coast = 0;
    nav->mode = MFNS_NAV_MODE_TRACK;
    return MFNS_NAV_OK;
}

mfns_nav_status_t mfns_nav_enable_filter(mfns_nav_t *nav, uint32_t period_us)
{
    if (nav == NULL || nav->magic != NAV_MAGIC) {
        return MFNS_NAV_E_ARG;
    }
    mfns_navf_enable(&nav->filt, period_us);
    return MFNS_NAV_OK;
}

mfns_nav_status_t mfns_nav_doubt_timing(mfns_nav_t *nav, int cam)
{
    if (nav == NULL || cam < 0 || cam >= MFNS_NUM_CAMERAS) {
        return MFNS_NAV_E_ARG;
    }
    mfns_navf_doubt_timing(&nav->filt, cam);
    return MFNS_NAV_OK;
}

mfns_nav_status_t mfns_nav_set_frame_times(mfns_nav_t *nav, const int64_t t_us[MFNS_NUM_CAMERAS])
{
    if (nav == NULL || nav->magic != NAV_MAGIC || t_us == NULL) {
        return MFNS_NAV_E_ARG;
    }
    mfns_navf_set_frame_times(&nav->filt, t_us);
    return MFNS_NAV_OK;
}

mfns_nav_status_t mfns_nav_set_frame_response(mfns_nav_t *nav, const float response[MFNS_NUM_CAMERAS])
{
    if (nav == NULL || nav->magic != NAV_MAGIC || response == NULL) {
        return MFNS_NAV_E_ARG;
    }
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        if (!isfinite(response[k]) || response[k] < 0.0f) {
            return MFNS_NAV_E_ARG;
        }
    }
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        nav->frame_response[k] = response[k];
    }
    return MFNS_NAV_OK;
}

void mfns_nav_lose_track(mfns_nav_t *nav)
{
    if (nav != NULL) {
        nav->have_prior = false;
        nav->have_prev = false;
        nav->coast = 0;
        nav->mode = MFNS_NAV_MODE_ACQUIRE;
    }
}

/* Windows around the beacons the prior predicts in camera k's image. Returns
 * the number of windows, 0 when none can be made (whole frame then). */
static uint16_t track_windows(mfns_nav_t *nav, int k, const mfns_frame_t *frame)
{
    const mfns_caltable_t *t = nav->table;
    const mfns_camera_t *cam = &t->rig.cam[k];
    uint16_t n = 0;
    for (uint16_t b = 0; b < nav->map.count && b < MFNS_MAX_BEACONS; b++) {
        float uv[2];
        if (mfns_cam_project(cam, &nav->predicted, nav->map.beacon[b].p_w, uv, NULL) == MFNS_PROJ_OK &&
            mfns_cam_in_image(&cam->k, uv[0], uv[1])) {
            nav->pred_uv[n][0] = uv[0];
            nav->pred_uv[n][1] = uv[1];
            n++;
        }
    }
    uint16_t n_rois = 0;
    if (n == 0 ||
        mfns_centroid_make_rois((const float(*)[2])nav->pred_uv, n, t->centroid.roi_half_size_px, frame->width,
                                frame->height, nav->rois, MFNS_CENTROID_MAX_ROIS, &n_rois) != MFNS_CENTROID_OK) {
        return 0;
    }
    return n_rois;
}

/* Brightest accepted blobs of nav->cres, distortion-corrected, into camera
 * k's observations. */
static void blobs_to_obs(mfns_nav_t *nav, int k, mfns_nav_cam_diag_t *d)
{
    const mfns_centroid_result_t *r = &nav->cres;
    bool taken[MFNS_MAX_BLOBS_PER_CAMERA] = {false};
    uint16_t n_obs = 0;
    /* Selection of the brightest: at most MAX_OBS passes over MAX_BLOBS blobs. */
    for (uint16_t pass = 0; pass < MFNS_MAX_OBS_PER_CAMERA; pass++) {
        int best = -1;
        for (uint16_t i = 0; i < r->n_accepted && i < MFNS_MAX_BLOBS_PER_CAMERA; i++) {
            if (!taken[i] && (best < 0 || r->blob[i].flux_dn > r->blob[best].flux_dn)) {
                best = (int)i;
            }
        }
        if (best < 0) {
            break;
        }
        taken[best] = true;
        const mfns_blob_t *b = &r->blob[best];
        float x, y;
        if (mfns_undistort_grid(&nav->table->grid[k], &nav->table->rig.cam[k].k, b->u_q8, b->v_q8, &x, &y) !=
            MFNS_UNDIST_OK) {
            d->undistort_failures++;
            continue;
        }
        mfns_obs_t *o = &nav->obs.obs[k][n_obs];
        o->u = mfns_px_q8_to_float(b->u_q8);
        o->v = mfns_px_q8_to_float(b->v_q8);
        o->x = x;
        o->y = y;
        o->cov_px2[0] = b->cov_px2[0];
        o->cov_px2[1] = b->cov_px2[1];
        o->cov_px2[2] = b->cov_px2[2];
        n_obs++;
    }
    nav->obs.count[k] = n_obs;
    d->observations = n_obs;
}

/* Centroid camera k's frame (windows when tracking) into observations. */
static mfns_nav_status_t measure_camera(mfns_nav_t *nav, int k, const mfns_frame_t *frame, bool track,
                                        bool watch, mfns_nav_cam_diag_t *d)
{
    memset(d, 0, sizeof *d);
    nav->obs.count[k] = 0;
    nav->obs.dark[k] = 1U;
    if (frame == NULL) {
        d->state = MFNS_NAV_CAM_NO_FRAME;
        return MFNS_NAV_OK;
    }
    const uint16_t n_rois = track ? track_windows(nav, k, frame) : 0;
    const mfns_roi_t *rois = n_rois > 0 ? nav->rois : NULL;
    mfns_centroid_bg_t bg;
    mfns_centroid_status_t st = mfns_centroid_background(frame, rois, n_rois, &nav->work, &bg);
    if (st == MFNS_CENTROID_OK) {
        st = mfns_centroid_detect(frame, &nav->table->centroid, &bg, rois, n_rois, &nav->work, &nav->cres);
    }
    d->centroid_status = (int16_t)st;
    d->rois = n_rois;
    nav->obs.dark[k] = (uint8_t)(st == MFNS_CENTROID_OK || st == MFNS_CENTROID_TABLE_FULL ? 0U : 1U);
    if (st == MFNS_CENTROID_ERR_SETTINGS) {
        return MFNS_NAV_E_TABLE;
    }
    if (st != MFNS_CENTROID_OK && st != MFNS_CENTROID_TABLE_FULL) {
        d->state = MFNS_NAV_CAM_FRAME_ERROR;
        return MFNS_NAV_OK;
    }
    d->state = st == MFNS_CENTROID_TABLE_FULL ? MFNS_NAV_CAM_TABLE_FULL : MFNS_NAV_CAM_OK;
    d->blobs = nav->cres.n_blobs;
    d->accepted = nav->cres.n_accepted;
    d->background_dn = nav->cres.bg.background_dn;
    d->noise_dn = nav->cres.bg.noise_dn;
    blobs_to_obs(nav, k, d);
    if (watch && mfns_spot_observe(&nav->spots, k, &nav->cres, nav->frame_response[k]) != MFNS_SPOT_OK) {
        /* unreachable: k in range, the centroider's result, the response checked when set */
        d->state = MFNS_NAV_CAM_FRAME_ERROR;
    }
    return MFNS_NAV_OK;
}

/* Centroid every camera (windows when tracking) into nav->obs. watch: the
 * frames' first measurement this cycle, which the response watch sees (a
 * frame measured again on the whole image is the same frame). */
static mfns_nav_status_t measure(mfns_nav_t *nav, const mfns_frame_t *const frames[MFNS_NUM_CAMERAS], bool track,
                                 bool watch, mfns_nav_output_t *out)
{
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        const mfns_nav_status_t st = measure_camera(nav, k, frames[k], track, watch, &out->cam[k]);
        if (st != MFNS_NAV_OK) {
            return st;
        }
    }
    if (watch) {
        mfns_spot_evaluate(&nav->spots, &out->spots);
        for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
            nav->frame_response[k] = 0.0f; /* consumed: the next cycle's are set again or unknown */
        }
    }
    return MFNS_NAV_OK;
}

static void count_identified(const mfns_nav_t *nav, mfns_nav_output_t *out)
{
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        uint16_t ident = 0;
        for (uint16_t i = 0; i < nav->obs.count[k] && i < MFNS_MAX_OBS_PER_CAMERA; i++) {
            if (out->sol.assoc.beacon[k][i] != MFNS_POSE_NO_BEACON && out->sol.inlier[k][i] != 0U) {
                ident++;
            }
        }
        out->cam[k].identified = ident;
    }
}

/* A pose from exactly three beacons has no redundancy: nothing in the frame
 * can catch a wrong identification. It is usable only while tracking and
 * when it agrees with the prediction within their combined uncertainty: the
 * solution's covariance plus the prediction's, taken as the last cycle's
 * motion (the constant-velocity model's error is at most about one cycle of
 * motion) and a floor of MINIMAL_PRED_FLOOR_MM / _RAD. chi-square with 3
 * degrees of freedom at 1e-4 on position, and on attitude. */
#define MINIMAL_PRED_FLOOR_MM 2.0f
#define MINIMAL_PRED_FLOOR_RAD 0.002f
#define MINIMAL_CHI2_3 21.1f

static bool minimal_agrees(const mfns_nav_t *nav, const mfns_pose_solution_t *s)
{
    float step_mm = 0.0f, step_rad = 0.0f;
    if (nav->have_prev) {
        step_mm = mfns_v3_norm(mfns_v3_sub(mfns_pose_position_w(&nav->prior), mfns_pose_position_w(&nav->prev)));
        step_rad = mfns_rot_angle_between_at(&nav->prior.C_w_b, &nav->prev.C_w_b);
    }
    const float pp = fmaxf(step_mm, MINIMAL_PRED_FLOOR_MM), pr = fmaxf(step_rad, MINIMAL_PRED_FLOOR_RAD);
    const mfns_v3_t dp = mfns_v3_sub(s->r_wb_w, mfns_pose_position_w(&nav->predicted));
    const float d[3] = {dp.x, dp.y, dp.z};
    float chi_p = 0.0f;
    for (int i = 0; i < 3; i++) {
        chi_p += d[i] * d[i] / (s->sigma_pos_mm[i] * s->sigma_pos_mm[i] + pp * pp);
    }
    /* attitude: the rotation angle against the largest angular sigma */
    float sr = 0.0f;
    for (int i = 0; i < 3; i++) {
        sr = fmaxf(sr, s->sigma_euler_deg[i] * MFNS_RAD_PER_DEG_F);
    }
    const float da = mfns_rot_angle_between_at(&s->pose.C_w_b, &nav->predicted.C_w_b);
    const float chi_r = da * da / (sr * sr + pr * pr);
    return chi_p <= MINIMAL_CHI2_3 && chi_r <= MINIMAL_CHI2_3;
}

/* Acquisition on the whole frames already measured into nav->obs, within
 * the table's work budget: this frame's search and the one carried from an
 * earlier frame (acquire_cycle.h). */
static void acquire(mfns_nav_t *nav, mfns_nav_output_t *out)
{
    const mfns_caltable_t *t = nav->table;
    mfns_acq_cycle_report_t rep;
    (void)mfns_acq_cycle_run(&nav->acq, &t->rig, &nav->map, &t->index, &nav->obs, &nav->pose_cfg,
                             t->index.budget_units, &out->sol, &rep); /* the status is also in out->sol.status */
    out->acq = rep.progress;
    out->acq_carry_age = rep.carry_age;
    out->acq_source = rep.source;
    out->acquired = true;
}

static bool has_fix(const mfns_pose_solution_t *s)
{
    return s->status == MFNS_POSE_OK || s->status == MFNS_POSE_DEGRADED;
}

/* A pose that may carry the track on though it is not usable: a solve
 * refused only for want of redundancy or for its protection level, never
 * one with a detected fault. A three-beacon (MINIMAL) pose only from
 * tracking, where it has agreed with the prediction (minimal_agrees). */
static bool carries_track(const mfns_pose_solution_t *s, bool tracked)
{
    return has_fix(s) || (s->status == MFNS_POSE_NO_FIX &&
                          ((s->reason == MFNS_POSE_R_MINIMAL && tracked) || s->reason == MFNS_POSE_R_UNMONITORED ||
                           s->reason == MFNS_POSE_R_PL_EXCEEDS_AL || s->reason == MFNS_POSE_R_LAG_UNTESTED ||
                           s->reason == MFNS_POSE_R_CAMERAS_CONTRADICT));
}

/* A table in monitor-only mode (a bench, never flight; nav_settings.h): a pose
 * refused only for want of redundancy or for its protection level is marked
 * DEGRADED with that reason (the PL it has, or none, goes out with it); one
 * with a detected fault (FAULT_DETECTED), or a three-beacon pose that
 * disagreed with the prediction (MINIMAL_UNCONFIRMED), stays refused. */
static void monitor_only(const mfns_nav_t *nav, mfns_nav_output_t *out)
{
    mfns_pose_solution_t *s = &out->sol;
    if (nav->integ_set.monitor_only != 0U && s->status == MFNS_POSE_NO_FIX &&
        (s->reason == MFNS_POSE_R_MINIMAL || s->reason == MFNS_POSE_R_UNMONITORED ||
         s->reason == MFNS_POSE_R_PL_EXCEEDS_AL || s->reason == MFNS_POSE_R_LAG_UNTESTED)) {
        s->status = MFNS_POSE_DEGRADED;
    }
}

/* The time-offset monitor (integrity_lag.h) on the solver's fix: a camera
 * whose frames lag is held out for FDE. */
static void lag_monitor(mfns_nav_t *nav, mfns_nav_output_t *out)
{
    const mfns_caltable_t *t = nav->table;
    out->lag_new_camera = (int8_t)mfns_integrity_lag_monitor(&nav->integ_mem, &t->rig, &nav->map, &nav->obs,
                                                             &out->sol, &nav->pose_cfg, &nav->integ_set, &out->lag);
}

/* The camera whose frame of this cycle is suspect: the time-offset
 * monitor's new lag episode, else a camera it holds as lagging (cam_lag 1;
 * not one held only to verify it after an outage, 2), else the camera whose
 * spots jumped this cycle or the last (spot_watch.h: the attributed one,
 * else the first in the mask; the cycle after too, because the filter took
 * the jumped frame and its tests need the next one to see the fault: on the
 * grown campaign a mount turned 1 deg about the optical axis left the fix
 * after its onset 4.2 sigma off, NEES 41.6), else -1. */
static int suspect_camera(const mfns_nav_t *nav, const mfns_nav_output_t *out)
{
    if (out->lag_new_camera >= 0) {
        return out->lag_new_camera;
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (nav->integ_mem.cam_lag[c] == 1U) {
            return c;
        }
    }
    if (out->spots.jump_camera >= 0) {
        return out->spots.jump_camera;
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if ((out->spots.recent_mask & (1U << (unsigned)c)) != 0U) {
            return c;
        }
    }
    return -1;
}

/* A fix whose cameras could not be tested for a lag (no motion known yet:
 * the first two fixes after a gap) is not usable; it carries the track.
 * Only a fix on two or more cameras: on one, a lag is a stamp error the
 * monitor never sees, motion or not (integrity_lag.h), so holding it would
 * cost fixes and catch nothing. */
static void lag_untested(const mfns_nav_t *nav, mfns_nav_output_t *out)
{
    if (has_fix(&out->sol) && !mfns_integrity_lag_motion_known(&nav->integ_mem) &&
        mfns_integrity_lag_cameras(&out->sol, &nav->obs) >= 2) {
        out->sol.status = MFNS_POSE_NO_FIX;
        out->sol.reason = MFNS_POSE_R_LAG_UNTESTED;
    }
}

/* A fix from one camera that another camera's image contradicts
 * (integrity_cameras.h mfns_camera_watch_contradicting) is not usable: one
 * of the two cameras is wrong and nothing says which. The pose carries the
 * track (the camera watch goes on counting the disagreement and reports it).
 * A beacon counts when its tracking window would lie inside the image. A
 * camera held only to verify its lag (integrity_lag.h, cam_lag 2) whose
 * spots are in the solver's fix does not contradict. */
static void one_camera_contradicted(const mfns_nav_t *nav, const uint8_t solver_inlier[MFNS_NUM_CAMERAS],
                                    mfns_nav_output_t *out)
{
    const mfns_caltable_t *t = nav->table;
    uint8_t verifying[MFNS_NUM_CAMERAS]; /* held only to verify its lag, its spots in the solver's fix */
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        verifying[c] = (uint8_t)(solver_inlier[c] != 0U && nav->integ_mem.cam_lag[c] == 2U ? 1U : 0U);
    }
    if (has_fix(&out->sol) &&
        mfns_camera_watch_contradicting(&t->rig, &nav->map, &nav->obs, &out->sol,
                                        (float)t->centroid.roi_half_size_px, verifying) >= 0) {
        out->sol.status = MFNS_POSE_NO_FIX;
        out->sol.reason = MFNS_POSE_R_CAMERAS_CONTRADICT;
    }
}

/* An acquisition while the robot was last tracked outside the table's
 * workspace (workspace_watch.h) is not certified: whatever it found, usable
 * or only carrying the track, is refused and carries nothing, so it cannot
 * clear the watch by being tracked. */
static void outside_workspace(const mfns_nav_t *nav, mfns_nav_output_t *out)
{
    if (out->acquired && mfns_ws_watch_refuses(&nav->wsw) && carries_track(&out->sol, false)) {
        mfns_pose_solution_clear(&out->sol, MFNS_POSE_R_OUTSIDE_WORKSPACE);
    }
}

static void held_cameras(const mfns_nav_t *nav, mfns_nav_output_t *out)
{
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        out->cam_held[c] = (uint8_t)(nav->integ_mem.cam_held[c] == 0U ? 0U : (nav->integ_mem.cam_lag[c] != 0U ? 1U + nav->integ_mem.cam_lag[c] : 1U));
    }
}

/* The bias monitor's finding acts on the live map once the cycle is done with it: a
 * beacon it reports (once: the monitor flags each beacon at most once per table) counts
 * with its sigma_mm scaled from the next cycle on, in every stage. */
static void downweight_biased(mfns_nav_t *nav, const mfns_bmon_report_t *r)
{
    if (r->beacon_chi2 > 0.0f && r->new_beacon >= 0 && (uint32_t)r->new_beacon < nav->map.count) {
        nav->map.beacon[r->new_beacon].sigma_mm *= nav->bmon.sigma_scale[r->new_beacon];
    }
}

mfns_nav_status_t mfns_nav_cycle(mfns_nav_t *nav, const mfns_frame_t *const frames[MFNS_NUM_CAMERAS],
                                 mfns_nav_output_t *out)
{
    if (nav == NULL || frames == NULL || out == NULL || nav->magic != NAV_MAGIC || nav->table == NULL) {
        return MFNS_NAV_E_ARG;
    }
    memset(out, 0, sizeof *out);
    out->lag_new_camera = -1;
    out->beacons.missing = -1;
    out->beacons.rejected = -1;
    out->cameras.inconsistent = -1;
    out->spots.camera = -1;
    out->spots.jump_camera = -1;
    const mfns_nav_mode_t before = nav->mode;
    const bool track = nav->mode == MFNS_NAV_MODE_TRACK && nav->have_prior;
    if (track) {
        /* the last cycle's motion once more (the catch-up's model too) */
        mfns_motion_predict_cv(&nav->prior, &nav->prev, nav->have_prev, &nav->predicted);
    }
    out->mode = track ? MFNS_NAV_MODE_TRACK : MFNS_NAV_MODE_ACQUIRE;
    /* The one place of the policy: track from the prediction, else (or when
     * tracking gives no fix) acquire once, on whole frames. */
    mfns_nav_status_t st = measure(nav, frames, track, true, out);
    if (st == MFNS_NAV_OK && track) {
        const mfns_caltable_t *t = nav->table;
        (void)mfns_pose_track(&t->rig, &nav->map, &nav->obs, &nav->predicted, &nav->pose_cfg, &out->sol);
        /* a three-beacon pose is never usable (pose.c: NO_FIX MINIMAL); it
         * carries the track only when it agrees with the prediction */
        if (out->sol.status == MFNS_POSE_NO_FIX && out->sol.reason == MFNS_POSE_R_MINIMAL &&
            !minimal_agrees(nav, &out->sol)) {
            mfns_pose_solution_clear(&out->sol, MFNS_POSE_R_MINIMAL_UNCONFIRMED);
        }
        if (!has_fix(&out->sol) && out->sol.reason != MFNS_POSE_R_MINIMAL_UNCONFIRMED &&
            out->sol.reason != MFNS_POSE_R_MINIMAL) {
            out->reacquired = true;
            out->mode = MFNS_NAV_MODE_ACQUIRE;
            st = measure(nav, frames, false, false, out);
            if (st == MFNS_NAV_OK) {
                acquire(nav, out);
            }
        }
    } else if (st == MFNS_NAV_OK) {
        acquire(nav, out);
    }
    if (!out->acquired) {
        mfns_acq_cycle_skip(&nav->acq); /* the catch-up ring numbers every cycle (acquire_cycle.h) */
    }
    if (st == MFNS_NAV_OK) {
        const mfns_caltable_t *t = nav->table;
        outside_workspace(nav, out);
        lag_monitor(nav, out);
        /* a frame the snapshot finds lagging (a new lag, or a camera it
         * holds as lagging), or whose spots jumped: the filter's fix of this
         * cycle refused (nav_filter_cycle.h) */
        mfns_navf_suspect_frame(&nav->filt, suspect_camera(nav, out));
        uint8_t solver_inlier[MFNS_NUM_CAMERAS]; /* before FDE holds cameras out (integrity_cameras.h) */
        for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
            solver_inlier[c] =
                (uint8_t)(has_fix(&out->sol) && mfns_camera_has_inlier(&out->sol, &nav->obs, c) ? 1U : 0U);
        }
        (void)mfns_integrity_fde(&nav->integ_mem, &t->rig, &nav->map, &nav->obs, &nav->pose_cfg, &nav->integ_set,
                                 &out->sol, &out->integrity); /* the verdict is in out->sol.status */
        lag_untested(nav, out);
        one_camera_contradicted(nav, solver_inlier, out);
        monitor_only(nav, out);
        mfns_navf_step(&nav->filt, t, &nav->integ_set, &nav->obs, nav->pose_cfg.sigma_px, &out->sol,
                       &out->integrity, &out->filt); /* nothing when off (the default) */
        (void)mfns_bmon_update(&nav->bmon, &t->rig, &nav->map, &nav->obs, &out->sol, nav->pose_cfg.sigma_px,
                               nav->pose_cfg.s.track_gate_px, nav->integ_mem.beacon, MFNS_INTEGRITY_MAX_HELD_BEACONS,
                               &out->bmon); /* arguments checked above */
        count_identified(nav, out);
        held_cameras(nav, out);
        const bool carries = carries_track(&out->sol, !out->acquired); /* the cycle's verdict is final here */
        mfns_beacon_watch_update(&nav->integ_mem.watch, &t->rig, &nav->map, &nav->obs, &out->sol, carries,
                                 nav->integ_mem.beacon, MFNS_INTEGRITY_MAX_HELD_BEACONS, &out->beacons);
        mfns_camera_watch_update(&nav->integ_mem.camwatch, &t->rig, &nav->map, &nav->obs, &out->sol, carries,
                                 solver_inlier, &out->cameras);
        mfns_ws_watch_update(&nav->wsw, &t->index, &out->sol, carries, !out->acquired, &out->ws);
    }
    out->ws_state = nav->wsw.state;
    downweight_biased(nav, &out->bmon);
    if (st != MFNS_NAV_OK) {
        out->sol.status = MFNS_POSE_NO_FIX;
        mfns_nav_lose_track(nav);
        return st;
    }
    if (carries_track(&out->sol, !out->acquired)) {
        /* velocity only between two real fixes: never from a hint or a coast */
        nav->have_prev = nav->have_prior && nav->prior_is_fix;
        mfns_motion_advance(&nav->prior, &nav->prev, &out->sol.pose);
        nav->prior_is_fix = true;
        nav->have_prior = true;
        nav->coast = 0;
        nav->mode = MFNS_NAV_MODE_TRACK;
        if (!out->acquired) {
            mfns_acq_cycle_reset(&nav->acq); /* tracking holds: a carried search is moot */
        }
    } else if (track && nav->coast < MFNS_NAV_MAX_COAST) {
        /* Coast: move the prior on by the predicted motion, keep the motion. */
        nav->coast++;
        mfns_motion_advance(&nav->prior, &nav->prev, &nav->predicted);
        nav->prior_is_fix = false; /* have_prev stays: the coast keeps the motion */
        out->coasting = nav->coast;
    } else {
        nav->coast = 0;
        mfns_nav_lose_track(nav);
    }
    out->next_mode = nav->mode;
    out->mode_changed = nav->mode != before;
    return MFNS_NAV_OK;
}
