/* integrity_lag.c -- the per-camera time-offset monitor (integrity_lag.h). */
#include "firmware/nav/integrity/integrity_lag.h"

#include <math.h>
#include <string.h>

#include "firmware/nav/pose/motion.h"
#include "firmware/nav/pose/pose_internal.h"
#include "math/spd.h"

_Static_assert(MFNS_SPD_MAX_N >= 6, "6x6 information");
_Static_assert(MFNS_LAG_MIN_OBS >= 1, "a camera is tested on at least one beacon");

/* Per camera: the sums of one pass over the inliers. */
typedef struct {
    float jtf[MFNS_NUM_CAMERAS][6]; /* J^T f_c */
    float ftf[MFNS_NUM_CAMERAS];    /* f_c^T f_c */
    float fte[MFNS_NUM_CAMERAS];    /* f_c^T e */
    uint16_t obs[MFNS_NUM_CAMERAS]; /* inliers of c */
    float jte[6];                   /* J^T e */
    float h[6][6];                  /* J^T J */
} lag_sums_t;

static bool accumulate(const mfns_rig_t *rig, const mfns_pose_meas_t *m, int n, const mfns_pose_t *pose,
                       const mfns_pose_t *back, lag_sums_t *s)
{
    memset(s, 0, sizeof *s);
    for (int k = 0; k < n; k++) {
        float e[2], jac[2][6], eb[2];
        if (!m[k].active) {
            continue;
        }
        if (!mfns_pose_wresidual(rig, &m[k], pose, e, jac) || !mfns_pose_wresidual(rig, &m[k], back, eb, NULL)) {
            return false; /* behind the camera: no linearisation */
        }
        /* f = L^-1 (h(x) - h(x_back)) = e(x) - e(x_back): the measured point cancels */
        const float f[2] = {e[0] - eb[0], e[1] - eb[1]};
        const int c = m[k].cam;
        for (int i = 0; i < 6; i++) {
            s->jtf[c][i] += jac[0][i] * f[0] + jac[1][i] * f[1];
            s->jte[i] += jac[0][i] * e[0] + jac[1][i] * e[1];
            for (int j = 0; j < 6; j++) {
                s->h[i][j] += jac[0][i] * jac[0][j] + jac[1][i] * jac[1][j];
            }
        }
        s->ftf[c] += f[0] * f[0] + f[1] * f[1];
        s->fte[c] += f[0] * e[0] + f[1] * e[1];
        s->obs[c]++;
    }
    return true;
}

/* a^T P b with P from the factor */
static float quad(const mfns_chol_t *fac, const float a[6], const float b[6])
{
    float bb[MFNS_SPD_MAX_N] = {0.0f}, x[MFNS_SPD_MAX_N];
    for (int i = 0; i < 6; i++) {
        bb[i] = b[i];
    }
    mfns_chol_solve(fac, bb, x);
    float v = 0.0f;
    for (int i = 0; i < 6; i++) {
        v += a[i] * x[i];
    }
    return v;
}

static void ev_clear(mfns_lag_eval_t *ev)
{
    memset(ev, 0, sizeof *ev);
    ev->worst = -1;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        ev->sd_cycles[c] = INFINITY;
        ev->mdl_cycles[c] = INFINITY;
    }
}

/* The estimates, z and the verdict from num and den of the tested cameras;
 * tests: the tests per camera sharing P_fa (1, or 2 with z_fix). */
static void decide(const float num[MFNS_NUM_CAMERAS], const float den[MFNS_NUM_CAMERAS],
                   const float var[MFNS_NUM_CAMERAS], int tests, const mfns_integrity_settings_t *set,
                   mfns_lag_eval_t *ev)
{
    int tested = 0;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        tested += ev->tested[c] != 0U ? 1 : 0;
    }
    const float k_md = mfns_integrity_q_inv(set->p_md);
    ev->k = mfns_integrity_q_inv(set->p_fa / (2.0f * (float)tests * (float)(tested > 0 ? tested : 1)));
    ev->worst = -1;
    float worst = ev->k;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (!ev->tested[c] || !(den[c] > 0.0f) || !(var[c] > 0.0f)) {
            continue;
        }
        /* tau = num / den; var(num) = var (den for independent noise) */
        const float sd = sqrtf(var[c]) / den[c];
        ev->sd_cycles[c] = sd;
        ev->lag_cycles[c] = num[c] / den[c];
        ev->z[c] = num[c] / sqrtf(var[c]);
        ev->mdl_cycles[c] = (ev->k + k_md) * sd;
        const float zc = fmaxf(fabsf(ev->z[c]), fabsf(ev->z_fix[c]));
        if (zc > worst) {
            worst = zc;
            ev->worst = (int8_t)c;
        }
    }
}

static void solve6(const mfns_chol_t *fac, const float b[6], float x[6])
{
    float bb[MFNS_SPD_MAX_N] = {0.0f}, xx[MFNS_SPD_MAX_N];
    for (int i = 0; i < 6; i++) {
        bb[i] = b[i];
    }
    mfns_chol_solve(fac, bb, xx);
    for (int i = 0; i < 6; i++) {
        x[i] = xx[i];
    }
}

/* The parts of var(f_c^T M e) that are static (the same in every fix of the
 * window, so they do not average down), with u = M f_c = f_c - J v (v = P0
 * J^T f_c) and y_i = L_i^-T u_i:
 *   - the beacons' survey errors: sum_i y_i^T S_i y_i, S_i the survey term of
 *     observation i's covariance (mfns_pose_obs_cov with no pixel noise);
 *     it is inside den (the weights carry it);
 *   - the calibration's (the table's Sigma_c, pose.h calib_cov): the error
 *     dc moves observation i by J_c,i dc, so f^T M e gets g^T dc with
 *     g = sum_i J_c,i^T y_i, variance g^T Sigma_c g; it is not in the
 *     weights, so it adds to den (0 without a table covariance).
 * A biased calibration (a mount error, a focal length) then widens the test
 * by what the calibration says it may be, instead of reading as a lag. */
static void static_var(const mfns_rig_t *rig, const mfns_pose_meas_t *m, int n, const mfns_pose_t *pose,
                       const mfns_pose_t *back, const mfns_calib_cov_t *calib, int c, const float v[6],
                       float *var_survey, float *var_calib)
{
    static const float zero[3] = {0.0f, 0.0f, 0.0f};
    const bool with_calib = calib != NULL && calib->present != 0U;
    float g[MFNS_CALIB_PARAMS] = {0.0f};
    float acc = 0.0f;
    for (int k = 0; k < n; k++) {
        float e[2], jac[2][6], eb[2];
        if (!m[k].active || !mfns_pose_wresidual(rig, &m[k], pose, e, jac) ||
            !mfns_pose_wresidual(rig, &m[k], back, eb, NULL)) {
            continue;
        }
        const bool mine = (int)m[k].cam == c;
        float u[2];
        for (int r = 0; r < 2; r++) {
            float jv = 0.0f;
            for (int i = 0; i < 6; i++) {
                jv += jac[r][i] * v[i];
            }
            u[r] = (mine ? e[r] - eb[r] : 0.0f) - jv;
        }
        /* y = L^-T u with L^-1 = [[w0, 0], [w1, w2]] */
        const float y0 = m[k].w[0] * u[0] + m[k].w[1] * u[1], y1 = m[k].w[2] * u[1];
        if (m[k].sigma_mm > 0.0f) {
            float sv[3] = {0.0f, 0.0f, 0.0f};
            (void)mfns_pose_obs_cov(&rig->cam[m[k].cam], pose, m[k].p_w, zero, m[k].sigma_mm, 0.0f, sv);
            acc += sv[0] * y0 * y0 + 2.0f * sv[1] * y0 * y1 + sv[2] * y1 * y1;
        }
        float jc[2][MFNS_CALIB_PARAMS_PER_CAMERA];
        if (with_calib && mfns_pose_calib_jacobian(&rig->cam[m[k].cam], pose, m[k].p_w, jc)) {
            const int c0 = (int)m[k].cam * MFNS_CALIB_PARAMS_PER_CAMERA;
            for (int j = 0; j < MFNS_CALIB_PARAMS_PER_CAMERA; j++) {
                g[c0 + j] += jc[0][j] * y0 + jc[1][j] * y1;
            }
        }
    }
    float gsg = 0.0f;
    for (int i = 0; with_calib && i < MFNS_CALIB_PARAMS; i++) {
        float row = 0.0f;
        for (int j = 0; j < MFNS_CALIB_PARAMS; j++) {
            row += calib->cov[i][j] * g[j];
        }
        gsg += g[i] * row;
    }
    *var_survey = acc;
    *var_calib = fmaxf(gsg, 0.0f); /* a PSD Sigma_c; rounding never makes it negative */
}

mfns_integrity_status_t mfns_integrity_lag(const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                           const mfns_obs_frame_t *frame, const mfns_pose_solution_t *sol,
                                           const mfns_pose_config_t *cfg, const mfns_integrity_settings_t *set,
                                           const mfns_pose_t *back, mfns_lag_eval_t *ev)
{
    if (ev == NULL) {
        return MFNS_INTEGRITY_E_ARG;
    }
    ev_clear(ev);
    if (rig == NULL || map == NULL || frame == NULL || sol == NULL || cfg == NULL || back == NULL ||
        !mfns_integrity_settings_valid(set) || (sol->status != MFNS_POSE_OK && sol->status != MFNS_POSE_DEGRADED)) {
        return MFNS_INTEGRITY_E_ARG;
    }
    mfns_pose_meas_t m[MFNS_POSE_MAX_MEAS];
    const int n = mfns_pose_gather(map, frame, &sol->assoc, m);
    if (n < 0) {
        return MFNS_INTEGRITY_E_ARG;
    }
    for (int k = 0; k < n; k++) {
        m[k].active = sol->inlier[m[k].cam][m[k].idx];
    }
    mfns_pose_weigh(rig, m, n, &sol->pose, cfg); /* the weights of the fix's covariance */
    lag_sums_t s;
    if (!accumulate(rig, m, n, &sol->pose, back, &s)) {
        return MFNS_INTEGRITY_E_GEOM;
    }
    float a[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N] = {{0.0f}};
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            a[i][j] = s.h[i][j];
        }
    }
    mfns_chol_t fac;
    if (mfns_chol_factor(a, 6, cfg->s.min_rcond, &fac) != MFNS_SPD_OK) {
        return MFNS_INTEGRITY_E_GEOM;
    }
    float num[MFNS_NUM_CAMERAS] = {0.0f}, den[MFNS_NUM_CAMERAS] = {0.0f}, var[MFNS_NUM_CAMERAS] = {0.0f};
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (s.obs[c] < MFNS_LAG_MIN_OBS) {
            continue;
        }
        /* f^T M e and f^T M f, M = I - J P0 J^T (exact also at a robust fix, where J^T e != 0) */
        num[c] = s.fte[c] - quad(&fac, s.jtf[c], s.jte);
        den[c] = s.ftf[c] - quad(&fac, s.jtf[c], s.jtf[c]);
        /* den is the information on tau_c; a lag absorbed by the pose (or no
         * motion) leaves nothing to test: a floor of 1e-4 of f^T f against
         * rounding, and an absolute one of 1e-12 */
        if (!(den[c] > 1e-4f * s.ftf[c]) || !(den[c] > 1e-12f)) {
            continue;
        }
        ev->tested[c] = 1U;
        ev->num[c] = num[c];
        ev->den[c] = den[c];
        /* the pose's shift under a lag of one cycle, in its sigmas:
         * |P0 J^T f|_I0 = sqrt(f^T J P0 J^T f) = sqrt(f^T f - f^T M f) */
        ev->shift_sigma[c] = sqrtf(fmaxf(s.ftf[c] - den[c], 0.0f));
        float v[6];
        solve6(&fac, s.jtf[c], v);
        static_var(rig, m, n, &sol->pose, back, cfg->calib_cov, c, v, &ev->var_survey[c], &ev->var_calib[c]);
        var[c] = den[c] + ev->var_calib[c];
    }
    decide(num, den, var, 1, set, ev);
    return MFNS_INTEGRITY_OK;
}

static void clear_windows(mfns_integrity_memory_t *mem)
{
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < MFNS_INTEGRITY_LAG_WINDOW; i++) {
            mem->lag_num[c][i] = 0.0f;
            mem->lag_den[c][i] = 0.0f;
            mem->lag_vs[c][i] = 0.0f;
            mem->lag_vc[c][i] = 0.0f;
        }
    }
}

static bool is_fix(const mfns_pose_solution_t *sol)
{
    return sol != NULL && (sol->status == MFNS_POSE_OK || sol->status == MFNS_POSE_DEGRADED);
}

/* The windows' sums into num, den (after this fix's entries). */
static void window(mfns_integrity_memory_t *mem, const mfns_lag_eval_t *ev, float num[MFNS_NUM_CAMERAS],
                   float den[MFNS_NUM_CAMERAS], float var[MFNS_NUM_CAMERAS])
{
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        const uint8_t pos = (uint8_t)(mem->lag_pos[c] % MFNS_INTEGRITY_LAG_WINDOW);
        for (int i = 0; i < MFNS_INTEGRITY_LAG_WINDOW && !ev->tested[c]; i++) {
            mem->lag_num[c][i] = 0.0f; /* an outage or no motion: a fresh window */
            mem->lag_den[c][i] = 0.0f;
            mem->lag_vs[c][i] = 0.0f;
            mem->lag_vc[c][i] = 0.0f;
        }
        if (ev->tested[c]) {
            mem->lag_num[c][pos] = ev->num[c];
            mem->lag_den[c][pos] = ev->den[c];
            mem->lag_vs[c][pos] = fminf(fmaxf(ev->var_survey[c], 0.0f), ev->den[c]);
            mem->lag_vc[c][pos] = ev->var_calib[c];
            mem->lag_pos[c] = (uint8_t)((pos + 1U) % MFNS_INTEGRITY_LAG_WINDOW);
        }
        num[c] = 0.0f;
        den[c] = 0.0f;
        float sd_s = 0.0f, sd_c = 0.0f, var_px = 0.0f;
        for (int i = 0; i < MFNS_INTEGRITY_LAG_WINDOW; i++) {
            num[c] += mem->lag_num[c][i];
            den[c] += mem->lag_den[c][i];
            /* pixel noise independent from fix to fix; survey and calibration
             * errors the same in every fix (fully correlated: the sum of the
             * sds, an upper bound whatever the fixes' geometry), independent
             * of each other */
            var_px += mem->lag_den[c][i] - mem->lag_vs[c][i];
            sd_s += sqrtf(mem->lag_vs[c][i]);
            sd_c += sqrtf(mem->lag_vc[c][i]);
        }
        var[c] = var_px + sd_s * sd_s + sd_c * sd_c;
    }
}

/* Another camera than c gave an image and is not held for its lag: a
 * reference to verify c against, and a fix to go on with without it. When
 * every camera went dark at once there is none: they come back unverified
 * (else a still robot would never fix again). */
static bool reference_for(const mfns_integrity_memory_t *mem, const mfns_obs_frame_t *frame, int c)
{
    if (mem->dark_run[c] < MFNS_INTEGRITY_LAG_OUTAGE) {
        return false; /* a single dropped frame is no outage */
    }
    for (int o = 0; o < MFNS_NUM_CAMERAS; o++) {
        if (o != c && frame->dark[o] == 0U && mem->cam_lag[o] == 0U) {
            return true;
        }
    }
    return false;
}

/* Camera c comes back after a gap in which it gave images but none of its
 * spots was an inlier while the fix predicted beacons in them (the camera
 * watch's miss run, integrity_cameras.h: stale frames two periods and more
 * old fall outside the association gate, then a single spot falls inside
 * it), and another camera that is not held for its lag has an inlier in sol
 * to verify it against. Like an outage without images, its lag is verified
 * before it is used again. */
static bool back_after_gap(const mfns_integrity_memory_t *mem, const mfns_pose_solution_t *sol,
                           const mfns_obs_frame_t *frame, int c)
{
    if (mem->camwatch.miss_run[c] < MFNS_INTEGRITY_LAG_OUTAGE || !mfns_camera_has_inlier(sol, frame, c)) {
        return false;
    }
    for (int o = 0; o < MFNS_NUM_CAMERAS; o++) {
        if (o != c && mem->cam_lag[o] == 0U && mfns_camera_has_inlier(sol, frame, o)) {
            return true;
        }
    }
    return false;
}

/* Holds and releases after this fix's verdict; returns the camera of a new
 * lag episode or -1. */
static int update_holds(mfns_integrity_memory_t *mem, const mfns_pose_solution_t *sol,
                        const mfns_obs_frame_t *frame, const mfns_integrity_settings_t *set,
                        const mfns_lag_eval_t *ev)
{
    int fresh = -1;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (c == ev->worst) {
            mem->lag_verify[c] = MFNS_INTEGRITY_LAG_WINDOW; /* the lag must leave the window, then pass */
            fresh = mfns_integrity_hold_lagging(mem, c, 1U, set->hold_cycles) == 1U ? fresh : c;
        } else if (mem->cam_lag[c] == 0U && ((frame->dark[c] != 0U && reference_for(mem, frame, c)) ||
                                             back_after_gap(mem, sol, frame, c))) {
            /* an outage (no image: dead, held out by the frame-health
             * checks), or a gap without inliers in its images: verify its
             * lag before it is used again */
            mem->lag_verify[c] = MFNS_INTEGRITY_LAG_VERIFY;
            (void)mfns_integrity_hold_lagging(mem, c, 2U, set->hold_cycles);
        } else if (!mfns_camera_has_inlier(sol, frame, c)) {
            if (mem->cam_lag[c] != 0U) {
                mem->cam_hold[c] = set->hold_cycles; /* nothing to test it on: it stays out */
            }
        } else if (mem->cam_lag[c] != 0U) {
            /* a pass counts only when the window could have seen a lag of
             * one period (its minimum detectable lag <= 1 cycle), or when
             * the lag it could miss moves the fix by less than a sigma */
            const bool power = ev->mdl_cycles[c] <= MFNS_LAG_CERT_CYCLES ||
                               ev->mdl_cycles[c] * ev->shift_sigma[c] <= MFNS_LAG_HARMLESS_SIGMA;
            if (ev->tested[c] && fabsf(ev->z[c]) <= ev->k && fabsf(ev->z_fix[c]) <= ev->k && power &&
                mem->lag_verify[c] > 0U) {
                mem->lag_verify[c]--;
            }
            if (mem->lag_verify[c] == 0U) {
                mem->cam_lag[c] = 0U; /* verified: used again */
                mem->cam_held[c] = 0U;
                mem->cam_hold[c] = 0U;
            } else {
                mem->cam_hold[c] = set->hold_cycles;
            }
        }
    }
    return fresh;
}

int mfns_integrity_lag_monitor(mfns_integrity_memory_t *mem, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                               const mfns_obs_frame_t *frame, const mfns_pose_solution_t *sol,
                               const mfns_pose_config_t *cfg, const mfns_integrity_settings_t *set,
                               mfns_lag_eval_t *ev)
{
    if (ev == NULL) {
        return -1;
    }
    ev_clear(ev);
    if (mem == NULL) {
        return -1;
    }
    if (frame == NULL || set == NULL) {
        return -1;
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        mem->dark_run[c] = (uint8_t)(frame->dark[c] == 0U ? 0U
                                     : (mem->dark_run[c] < UINT8_MAX ? mem->dark_run[c] + 1U : UINT8_MAX));
    }
    if (!is_fix(sol)) {
        mem->lag_fixes = 0U; /* the motion restarts */
        mem->lag_tested_motion = 0U;
        clear_windows(mem);
        for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
            if (frame->dark[c] != 0U && mem->cam_lag[c] == 0U && reference_for(mem, frame, c)) { /* an outage */
                mem->lag_verify[c] = MFNS_INTEGRITY_LAG_VERIFY;
                (void)mfns_integrity_hold_lagging(mem, c, 2U, set->hold_cycles);
            }
        }
        return -1;
    }
    const bool motion = mem->lag_fixes >= 2U;
    mem->lag_tested_motion = (uint8_t)(motion ? 1U : 0U);
    const mfns_pose_t back = motion ? mfns_motion_step_back(&sol->pose, &mem->lag_last, &mem->lag_prev) : sol->pose;
    mem->lag_prev = mem->lag_last;
    mem->lag_last = sol->pose;
    mem->lag_fixes = (uint8_t)(mem->lag_fixes < 2U ? mem->lag_fixes + 1U : 2U);
    if (!motion || mfns_integrity_lag(rig, map, frame, sol, cfg, set, &back, ev) != MFNS_INTEGRITY_OK) {
        ev_clear(ev);
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        /* the onset: this fix alone, its variance den plus the calibration's */
        ev->z_fix[c] = ev->tested[c] ? ev->num[c] / sqrtf(ev->den[c] + ev->var_calib[c]) : 0.0f;
    }
    float num[MFNS_NUM_CAMERAS], den[MFNS_NUM_CAMERAS], var[MFNS_NUM_CAMERAS];
    window(mem, ev, num, den, var);
    decide(num, den, var, 2, set, ev);
    return update_holds(mem, sol, frame, set, ev);
}

bool mfns_integrity_lag_motion_known(const mfns_integrity_memory_t *mem)
{
    return mem != NULL && mem->lag_tested_motion != 0U;
}

int mfns_integrity_lag_cameras(const mfns_pose_solution_t *sol, const mfns_obs_frame_t *frame)
{
    if (sol == NULL || frame == NULL) {
        return 0;
    }
    int n = 0;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        n += mfns_camera_has_inlier(sol, frame, c) ? 1 : 0;
    }
    return n;
}
