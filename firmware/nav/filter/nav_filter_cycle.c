/* nav_filter_cycle.c -- the filter bank in the navigation cycle
 * (nav_filter_cycle.h). */
#include "firmware/nav/filter/nav_filter_cycle.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "math/rotation.h"
#include "math/units.h"

void mfns_navf_enable(mfns_navf_t *nf, uint32_t period_us)
{
    if (nf == NULL) {
        return;
    }
    memset(nf, 0, sizeof(*nf));
    nf->on = period_us > 0U;
    nf->period_us = period_us;
    nf->suspect_cam = -1;
}

void mfns_navf_set_frame_times(mfns_navf_t *nf, const int64_t t_us[MFNS_NUM_CAMERAS])
{
    if (nf == NULL || t_us == NULL) {
        return;
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        nf->cap_us[c] = t_us[c];
    }
    nf->have_cap = true;
}

/* What a reading of a doubted clock must resolve to clear it: the frame
 * period, the lag of a camera stale after a dropped frame (filter_bank.h). */
static float doubt_resolve_s(const mfns_navf_t *nf)
{
    return (float)nf->period_us * MFNS_S_PER_US_F;
}

void mfns_navf_suspect_frame(mfns_navf_t *nf, int cam)
{
    if (nf == NULL || !nf->on || cam < 0 || cam >= MFNS_NUM_CAMERAS) {
        return;
    }
    nf->suspect_cam = (int8_t)cam;
}

void mfns_navf_doubt_timing(mfns_navf_t *nf, int cam)
{
    if (nf == NULL || !nf->on || cam < 0 || cam >= MFNS_NUM_CAMERAS) {
        return;
    }
    nf->timing_doubt = (uint8_t)(nf->timing_doubt | (1U << (unsigned)cam));
    if (nf->running) {
        (void)mfns_bank_doubt_timing(&nf->bank, cam, doubt_resolve_s(nf)); /* valid: cannot fail */
    }
}

static bool usable(const mfns_pose_solution_t *s)
{
    return s->status == MFNS_POSE_OK || s->status == MFNS_POSE_DEGRADED;
}

/* A fix refused only for what the bank checks itself: its tests passed but
 * its protection level is beyond the alert limit (NO_FIX PL_EXCEEDS_AL), or
 * its cameras' timing could not be tested yet (NO_FIX LAG_UNTESTED: the first
 * two fixes after a gap; the bank's camera hypotheses carry each camera's
 * time offset). Its identification is certified (acquisition's certificate,
 * or tracking from one), its pose is a sound linearisation point, and the
 * bank's integrity does not rest on it (start). */
static bool startable_refused(const mfns_pose_solution_t *s, const mfns_integrity_result_t *integ)
{
    return s->status == MFNS_POSE_NO_FIX &&
           (s->reason == MFNS_POSE_R_PL_EXCEEDS_AL || s->reason == MFNS_POSE_R_LAG_UNTESTED) && integ->evaluated &&
           integ->tests_passed;
}

/* Start from the snapshot fix: its pose, and a prior that claims nothing of
 * it: per axis the larger of the fix's own sigma (its cov_ros less the datum
 * term) and the start's diffuse sigma (MFNS_BANK_START_SIGMA_MM / _RAD),
 * uncorrelated. Every filter of the bank starts from that prior, so the
 * bank's integrity rests on the observations it takes from here on (a fault
 * in the snapshot fix, which its own PL may not bound (a camera fault in a
 * DEGRADED CAMERA_UNMONITORED fix), leaves no trace in the PL once the
 * observations outweigh the prior); the snapshot gives the identification
 * and the linearisation point. */
static bool start(mfns_navf_t *nf, const mfns_caltable_t *t, const mfns_pose_solution_t *sol)
{
    float d[6][6], cov[6][6];
    mfns_filter_datum_cov(&sol->pose, &t->datum, d); /* filter order: phi 0-2, r 3-5 */
    static const int to_filter[6] = {3, 4, 5, 0, 1, 2};
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            cov[i][j] = sol->cov_ros[i][j] - d[to_filter[i]][to_filter[j]];
        }
    }
    float var_ros[6], prior[6][6];
    for (int i = 0; i < 6; i++) {
        if (!(cov[i][i] > 0.0f) || !isfinite(cov[i][i])) {
            return false;
        }
        var_ros[i] = cov[i][i];
    }
    mfns_bank_diffuse_prior(var_ros, prior);
    int16_t excl_beacon[MFNS_BANK_MAX_EXCLUDED_BEACONS];
    uint8_t cam_excluded[MFNS_NUM_CAMERAS];
    memcpy(excl_beacon, nf->bank.excl_beacon, sizeof excl_beacon);
    memcpy(cam_excluded, nf->bank.cam_excluded, sizeof cam_excluded);
    nf->running = mfns_bank_init(&nf->bank, &sol->pose, (const float(*)[6])prior, mfns_v3(0.0f, 0.0f, 0.0f),
                                 MFNS_BANK_SIGMA_V0_MM_S, mfns_v3(0.0f, 0.0f, 0.0f), MFNS_BANK_SIGMA_W0_RAD_S,
                                 nf->t_us) == MFNS_FILTER_OK;
    if (nf->running && nf->carry_excl) {
        mfns_bank_keep_exclusions(&nf->bank, excl_beacon, cam_excluded);
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS && nf->running; c++) {
        if ((nf->timing_doubt & (1U << c)) != 0U) {
            (void)mfns_bank_doubt_timing(&nf->bank, c, doubt_resolve_s(nf)); /* valid: cannot fail */
        }
    }
    nf->carry_excl = false;
    return nf->running;
}

/* Camera c's frame time this cycle. */
static int64_t frame_time(const mfns_navf_t *nf, int c)
{
    return nf->have_cap ? nf->cap_us[c] : nf->t_us;
}

/* Camera c's observation i, taken as beacon b's at capture time tc: what the
 * filter takes (nav_filter.h mfns_filter_obs_t). */
static mfns_filter_obs_t filter_obs(const mfns_caltable_t *t, const mfns_obs_frame_t *obs, int c, int i, uint32_t b,
                                    int64_t tc)
{
    const mfns_obs_t *o = &obs->obs[c][i];
    mfns_filter_obs_t fo;
    fo.t_us = tc;
    fo.cam = (uint8_t)c;
    fo.u = o->u;
    fo.v = o->v;
    memcpy(fo.cov_px2, o->cov_px2, sizeof fo.cov_px2);
    fo.p_w = t->beacons.beacon[b].p_w;
    fo.sigma_mm = t->beacons.beacon[b].sigma_mm;
    return fo;
}

/* The filter's own association of camera c's frame at time tc: an
 * observation the solver left without a beacon gets the beacon whose
 * prediction from the full filter (propagated to tc) it matches within the
 * filter's gate (NIS <= mfns_filter_gate_nis), when exactly one beacon
 * does and no other observation of the frame takes the same beacon; the
 * candidates are first cut to the beacons predicted within the table's
 * tracking gate (pixels) of it. beacon[] holds the solver's association on
 * entry (-1: none) and gains the filter's. Returns the number added.
 * Why: with the bank running, the pose is known to a fraction of a pixel's
 * worth between frames, so a frame with one or two beacons (the paper's
 * turntable: 2.3 in view on average) still informs it, where the snapshot
 * needs three or more to associate anything. A wrong association (a
 * reflection or spurious spot inside the gate) is a fault of that beacon's
 * observation, covered by the beacon's hypothesis like any other.
 * Misses: an ambiguous frame (two beacons inside the gate of one spot) gives
 * nothing; a beacon whose spot left the gate is not associated (it is not
 * reported here: the snapshot's beacon watch reports it). Work: at most
 * map beacons projections and MFNS_MAX_OBS_PER_CAMERA x candidates tests. */
static int own_associate(const mfns_navf_t *nf, const mfns_caltable_t *t, const mfns_obs_frame_t *obs,
                         float sigma_px, int c, int64_t tc, int count, int16_t beacon[])
{
    mfns_filter_t pred = nf->bank.full; /* ~1.2 KB: the bank's state stays as it is */
    if (tc < pred.t_us || mfns_filter_propagate(&pred, &t->motion, tc) != MFNS_FILTER_OK) {
        return 0;
    }
    const mfns_pose_t pose = mfns_filter_pose(&pred);
    const mfns_camera_t *cam = &t->rig.cam[c];
    const float gate_px2 = t->solver.track_gate_px * t->solver.track_gate_px;
    const float gate_nis = mfns_filter_gate_nis(&t->motion);
    int16_t cand[MFNS_MAX_OBS_PER_CAMERA];
    uint8_t n_cand[MFNS_MAX_OBS_PER_CAMERA];
    for (int i = 0; i < count; i++) {
        cand[i] = -1;
        n_cand[i] = 0U;
    }
    for (uint32_t b = 0; b < t->beacons.count && b < MFNS_MAX_BEACONS; b++) {
        bool taken = false; /* already the solver's in this frame */
        for (int i = 0; i < count && !taken; i++) {
            taken = beacon[i] == (int16_t)b;
        }
        float uv[2];
        if (taken || mfns_cam_project(cam, &pose, t->beacons.beacon[b].p_w, uv, NULL) != MFNS_PROJ_OK ||
            !mfns_cam_in_image(&cam->k, uv[0], uv[1])) {
            continue;
        }
        for (int i = 0; i < count; i++) {
            const mfns_obs_t *o = &obs->obs[c][i];
            const float du = o->u - uv[0], dv = o->v - uv[1];
            if (beacon[i] >= 0 || du * du + dv * dv > gate_px2) {
                continue;
            }
            const mfns_filter_obs_t fo = filter_obs(t, obs, c, i, b, tc);
            float nis = 0.0f;
            if (mfns_filter_test(&pred, &t->motion, &t->rig, sigma_px, &fo, &nis) == MFNS_FILTER_OK &&
                nis <= gate_nis) {
                cand[i] = (int16_t)b;
                n_cand[i] = (uint8_t)(n_cand[i] < 2U ? n_cand[i] + 1U : 2U);
            }
        }
    }
    int added = 0;
    for (int i = 0; i < count; i++) {
        bool unique = n_cand[i] == 1U;
        for (int j = 0; j < count && unique; j++) {
            unique = j == i || n_cand[j] == 0U || cand[j] != cand[i];
        }
        if (unique) {
            beacon[i] = cand[i];
            added++;
        }
    }
    return added;
}

static void feed(mfns_navf_t *nf, const mfns_caltable_t *t, const mfns_obs_frame_t *obs, float sigma_px,
                 const mfns_pose_solution_t *sol)
{
    /* the cameras in the order of their capture times (3: insertion sort) */
    int order[MFNS_NUM_CAMERAS];
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        int j = c;
        while (j > 0 && frame_time(nf, order[j - 1]) > frame_time(nf, c)) {
            order[j] = order[j - 1];
            j--;
        }
        order[j] = c;
    }
    for (int oi = 0; oi < MFNS_NUM_CAMERAS && nf->running; oi++) {
        const int c = order[oi];
        const int64_t tc = frame_time(nf, c);
        mfns_filter_obs_t fo[MFNS_MAX_OBS_PER_CAMERA];
        int16_t beacon[MFNS_MAX_OBS_PER_CAMERA];
        int n = 0;
        const int count = obs->count[c] <= MFNS_MAX_OBS_PER_CAMERA ? obs->count[c] : MFNS_MAX_OBS_PER_CAMERA;
        int16_t assoc[MFNS_MAX_OBS_PER_CAMERA];
        for (int i = 0; i < count; i++) {
            const int16_t b = sol->assoc.beacon[c][i];
            assoc[i] = b >= 0 && b < (int16_t)t->beacons.count ? b : -1;
        }
        nf->own_assoc += (uint32_t)own_associate(nf, t, obs, sigma_px, c, tc, count, assoc);
        for (int i = 0; i < count; i++) {
            const int16_t b = assoc[i];
            if (b < 0) {
                continue;
            }
            fo[n] = filter_obs(t, obs, c, i, (uint32_t)b, tc);
            beacon[n] = b;
            n++;
        }
        if (n > 0 && tc < nf->bank.full.t_us) {
            nf->stale_frames++; /* before the bank's state: it cannot go back */
            continue;
        }
        const mfns_filter_status_t st = mfns_bank_observe_frame(&nf->bank, &t->motion, &t->rig, sigma_px, n, beacon, fo);
        if (st == MFNS_FILTER_E_TIME || st == MFNS_FILTER_E_ARG) {
            nf->running = false;
        }
    }
}

/* The motion bound against the snapshot (nav_filter_cycle.h): the largest
 * normalised separation of the cycle's snapshot fix from the full filter's
 * output over the six pose axes (1 = the threshold), or 0 when the snapshot
 * fix cannot be the reference (not usable, or its cameras not bounded). The
 * attitude as the filter's (C_b_w(snapshot) = exp([a]x) C_b_w(filter), world
 * axes), both covariances in pose.h's cov_ros order (position first); the
 * map datum term is in both and cancels. */
static float snapshot_separation(const mfns_bank_output_t *o, const mfns_pose_solution_t *snap,
                                 const mfns_integrity_result_t *integ, const mfns_integrity_settings_t *is)
{
    if (!usable(snap) || snap->reason == MFNS_POSE_R_CAMERA_UNMONITORED || integ->camera_unmonitored) {
        return 0.0f;
    }
    mfns_m3_t c_b_w, d;
    mfns_m3_transpose_at(&snap->pose.C_w_b, &c_b_w);
    mfns_m3_mul_at(&c_b_w, &o->pose.C_w_b, &d);
    const mfns_v3_t a = mfns_rot_log(d);
    const mfns_v3_t r_f = mfns_pose_position_w(&o->pose);
    const float sep[6] = {snap->r_wb_w.x - r_f.x, snap->r_wb_w.y - r_f.y, snap->r_wb_w.z - r_f.z, a.x, a.y, a.z};
    const float k = mfns_integrity_q_inv(is->p_fa / (2.0f * 6.0f));
    float worst = 0.0f;
    for (int j = 0; j < 6; j++) {
        const float ps = snap->cov_ros[j][j];
        const float var = fmaxf(ps - o->cov_ros[j][j], MFNS_NAVF_MOTION_FLOOR * ps);
        if (!(var > 0.0f) || !isfinite(sep[j])) {
            return 0.0f; /* no covariance to test against (never for a usable fix) */
        }
        worst = fmaxf(worst, fabsf(sep[j]) / (k * sqrtf(var)));
    }
    return worst;
}

/* The filter's verdict into the cycle's solution and integrity result. */
static void apply(const mfns_bank_output_t *o, mfns_pose_solution_t *sol, mfns_integrity_result_t *integ)
{
    sol->status = o->status;
    sol->reason = o->reason;
    sol->pose = o->pose;
    sol->r_wb_w = mfns_pose_position_w(&o->pose);
    mfns_euler_t e;
    (void)mfns_m3_to_euler213_at(&o->pose.C_w_b, &e);
    sol->euler_deg.roll = e.roll * MFNS_DEG_PER_RAD_F;
    sol->euler_deg.pitch = e.pitch * MFNS_DEG_PER_RAD_F;
    sol->euler_deg.yaw = e.yaw * MFNS_DEG_PER_RAD_F;
    mfns_m3_t c_b_w;
    mfns_m3_transpose_at(&o->pose.C_w_b, &c_b_w);
    mfns_m3_to_quat(c_b_w, sol->q_b_w);
    memcpy(sol->cov_ros, o->cov_ros, sizeof sol->cov_ros);
    for (int i = 0; i < 3; i++) {
        sol->sigma_pos_mm[i] = sqrtf(fmaxf(o->cov_ros[i][i], 0.0f));
        /* about the world axes, not the Euler angles' (close near level) */
        sol->sigma_euler_deg[i] = sqrtf(fmaxf(o->cov_ros[3 + i][3 + i], 0.0f)) * MFNS_DEG_PER_RAD_F;
    }
    integ->evaluated = true;
    integ->tests_passed = true;
    integ->pl_pos_mm = o->pl_pos_mm;
    integ->pl_att_deg = o->pl_att_deg;
    integ->max_norm_sep = o->max_norm_sep;
    integ->hypotheses = o->hypotheses;
    integ->unmonitorable = o->unmonitorable;
    integ->camera_unmonitored = false;
}

/* With the filter on, a usable pose bounds every camera fault too (issue
 * 42): a snapshot fix whose PL covers the beacon faults only (DEGRADED
 * CAMERA_UNMONITORED: no redundancy against a camera, left to the camera
 * health checks, which a knocked mount passes) is refused when it stands in
 * for the filter: NO_FIX UNMONITORED, the pose kept for tracking and
 * diagnostics. The bank still starts from such a fix (its camera
 * hypotheses then cover what follows; a fault already in it is the start's
 * known miss, filter_bank.h). Measured on the grown campaign's knocked
 * camera x (seed 2): 6 such fixes beyond 5 sigma before this. */
static void camera_bound_or_refused(mfns_pose_solution_t *sol, const mfns_integrity_result_t *integ)
{
    /* The snapshot's flag, not only its reason: a fix that held something out
     * is DEGRADED EXCLUDED whatever its PL covers (integrity_fde.c
     * mark_usable), and a knocked camera x once passed that way (grown
     * campaign seed 5, 0.6 deg: the time-offset monitor blamed camera y, the
     * rest, camera x and one beacon of z, were EXCLUDED with a beacon-only
     * PL, 1.92 x beyond it). */
    const bool cameras_unbounded = integ->camera_unmonitored || sol->reason == MFNS_POSE_R_CAMERA_UNMONITORED;
    if (sol->status == MFNS_POSE_DEGRADED && cameras_unbounded) {
        sol->status = MFNS_POSE_NO_FIX;
        sol->reason = MFNS_POSE_R_UNMONITORED;
    }
}

/* The bank's exclusion and re-admission of this cycle into the integrity
 * result, whose fields the flight program reports as events (BEACON_EXCLUDED,
 * CAMERA_EXCLUDED, *_READMITTED against their subject): the bank's verdict
 * names its subject whether or not the cycle's pose is usable. A snapshot
 * exclusion of the same cycle is replaced (the filter's is the one flown on
 * while it runs). */
static void report(const mfns_bank_output_t *o, mfns_integrity_result_t *integ)
{
    if (o->detected_kind == (uint8_t)MFNS_BANK_HYP_BEACON && o->detected_id >= 0) {
        integ->excluded_beacon = o->detected_id;
        integ->new_beacon_exclusion = true;
        integ->detect_norm_sep = o->max_norm_sep;
    } else if (o->detected_kind == (uint8_t)MFNS_BANK_HYP_CAMERA && o->detected_id >= 0 &&
               o->detected_id < MFNS_NUM_CAMERAS) {
        integ->excluded_camera = (int8_t)o->detected_id;
        integ->new_camera_exclusion = true;
        integ->detect_norm_sep = o->max_norm_sep;
    }
    if (o->readmitted_beacon >= 0) {
        integ->readmitted_beacon = o->readmitted_beacon;
    }
    if (o->readmitted_camera >= 0) {
        integ->readmitted_camera = o->readmitted_camera;
    }
}

/* Feed this cycle's frames and evaluate the bank at t_eval: the bank's
 * verdict (exclusion, re-admission) into integ; an exclusion or a restart
 * request stops it (nav_filter_cycle.h). */
static void run_bank(mfns_navf_t *nf, const mfns_caltable_t *t, const mfns_integrity_settings_t *is,
                     const mfns_obs_frame_t *obs, float sigma_px, const mfns_pose_solution_t *sol,
                     mfns_integrity_result_t *integ, mfns_navf_report_t *rep)
{
    feed(nf, t, obs, sigma_px, sol);
    if (!nf->running) {
        rep->ran = false;
        return;
    }
    /* the snapshot saw this cycle's frame of the camera lagging: the bank
     * refuses the fix and does not count the cycle towards re-admission */
    const bool told = nf->suspect_cam < 0 || mfns_bank_suspect_frame(&nf->bank, nf->suspect_cam) == MFNS_FILTER_OK;
    rep->ran = told && mfns_bank_evaluate(&nf->bank, &t->motion, is, &t->datum, nf->t_us, &rep->out) == MFNS_FILTER_OK;
    if (rep->ran) {
        nf->timing_doubt = rep->out.timing_doubt_mask; /* a doubt the bank's readings cleared */
    }
    nf->running = rep->ran && !rep->out.restart;
    if (nf->running && rep->out.detected_kind == (uint8_t)MFNS_BANK_HYP_NONE) {
        /* the motion bound against the snapshot (nav_filter_cycle.h) */
        const float ns = snapshot_separation(&rep->out, sol, integ, is);
        nf->snap_sep_run = ns > 1.0f ? (uint8_t)(nf->snap_sep_run + 1U) : 0U;
        rep->motion_sep = fmaxf(rep->motion_sep, ns);
        if (nf->snap_sep_run >= MFNS_NAVF_MOTION_RUN) {
            rep->motion_by_snapshot = !nf->motion_latched;
            rep->out.restart = true;
            rep->out.usable = false;
            rep->out.status = MFNS_POSE_NO_FIX;
            rep->out.reason = MFNS_POSE_R_MOTION_EXCEEDED;
            nf->running = false;
        }
    }
    if (rep->ran && rep->out.restart && rep->out.reason == MFNS_POSE_R_MOTION_EXCEEDED) {
        rep->motion_exceeded = rep->motion_exceeded || !nf->motion_latched;
        nf->motion_latched = true;
        nf->snap_sep_run = 0;
    }
    if (rep->ran) {
        report(&rep->out, integ);
    }
    if (nf->running && rep->out.detected_kind != (uint8_t)MFNS_BANK_HYP_NONE) {
        nf->running = false; /* restart from a certified snapshot (nav_filter_cycle.h) */
        nf->carry_excl = true;
    }
}

void mfns_navf_step(mfns_navf_t *nf, const mfns_caltable_t *t, const mfns_integrity_settings_t *is,
                    const mfns_obs_frame_t *obs, float sigma_px, mfns_pose_solution_t *sol,
                    mfns_integrity_result_t *integ, mfns_navf_report_t *rep)
{
    if (rep == NULL) {
        return;
    }
    memset(rep, 0, sizeof(*rep));
    if (nf == NULL || !nf->on || t == NULL || is == NULL || obs == NULL || sol == NULL || integ == NULL) {
        return;
    }
    /* the cycle's time: the latest frame's capture (or one period on) */
    int64_t t0 = INT64_MAX, t1 = INT64_MIN;
    for (int c = 0; c < MFNS_NUM_CAMERAS && nf->have_cap; c++) {
        if (obs->count[c] > 0U && obs->dark[c] == 0U) {
            t0 = nf->cap_us[c] < t0 ? nf->cap_us[c] : t0;
            t1 = nf->cap_us[c] > t1 ? nf->cap_us[c] : t1;
        }
    }
    if (nf->have_cap && t1 == INT64_MIN) {
        nf->have_cap = false; /* no camera saw anything: the period's clock */
    }
    nf->t_us = nf->have_cap ? (t1 > nf->t_us || !nf->running ? t1 : nf->t_us) : nf->t_us + (int64_t)nf->period_us;
    if (nf->running) {
        run_bank(nf, t, is, obs, sigma_px, sol, integ, rep);
    }
    if (!nf->running) {
        /* (re)start from this cycle's fix, at the earliest of its frames,
         * then take those frames: the start's prior claims nothing of them
         * (start), so they are not counted twice */
        const int64_t t_eval = nf->have_cap ? t1 : nf->t_us;
        nf->t_us = nf->have_cap ? t0 : t_eval;
        rep->started = (usable(sol) || startable_refused(sol, integ)) && start(nf, t, sol);
        if (rep->started) {
            /* this cycle's exclusion, if the bank that stopped made one,
             * stays the cycle's (its subject is held out of the new bank) */
            const uint8_t kind = rep->ran ? rep->out.detected_kind : (uint8_t)MFNS_BANK_HYP_NONE;
            const int16_t id = rep->out.detected_id;
            const uint8_t by_gate = rep->out.by_gate;
            nf->t_us = t_eval;
            run_bank(nf, t, is, obs, sigma_px, sol, integ, rep);
            if (kind != (uint8_t)MFNS_BANK_HYP_NONE && rep->out.detected_kind == (uint8_t)MFNS_BANK_HYP_NONE) {
                rep->out.detected_kind = kind;
                rep->out.detected_id = id;
                rep->out.by_gate = by_gate;
            }
        }
    }
    nf->have_cap = false;
    rep->t_us = rep->ran ? nf->t_us : 0;
    nf->suspect_cam = -1; /* consumed by this cycle's evaluations (run_bank) */
    if (nf->running && rep->ran && rep->out.usable) {
        apply(&rep->out, sol, integ);
        rep->used = true;
        nf->motion_latched = false;
        return;
    }
    camera_bound_or_refused(sol, integ); /* the snapshot's verdict stands this cycle, if it bounds cameras */
}
