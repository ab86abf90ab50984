/* pose.c -- the pose API of pose.h: input checks, the refinement driver
 * (robust solve, outlier gate, re-solve, covariance, status), tracking and
 * tracking. Acquisition is acquire.c, the solvers pose_refine.c /
 * pose_paper.c / pose_init.c. */
#include "firmware/nav/pose/pose.h"
#include "math/core_text.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "firmware/nav/pose/pose_internal.h"
#include "math/units.h"


void mfns_pose_config_default(mfns_pose_config_t *cfg)
{
    memset(cfg, 0, sizeof(*cfg));
    mfns_solver_settings_default(&cfg->s);
    cfg->sigma_px = 0.1f;
    cfg->mode = MFNS_POSE_MODE_ML;
}

const char *mfns_pose_status_str(mfns_pose_status_t s)
{
    switch (s) {
    case MFNS_POSE_OK:
        return MFNS_MSG("ok");
    case MFNS_POSE_DEGRADED:
        return MFNS_MSG("degraded");
    case MFNS_POSE_NO_FIX:
        return MFNS_MSG("no fix");
    }
    return MFNS_MSG("unknown pose status");
}

void mfns_pose_solution_clear(mfns_pose_solution_t *out, mfns_pose_reason_t reason)
{
    memset(out, 0, sizeof(*out));
    out->status = MFNS_POSE_NO_FIX;
    out->reason = reason;
    out->pose.C_w_b = mfns_m3_identity();
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < MFNS_MAX_OBS_PER_CAMERA; i++) {
            out->assoc.beacon[c][i] = MFNS_POSE_NO_BEACON;
        }
    }
}

/* Finite, and a covariance that is zero (unknown) or positive semi-definite. */
static bool finite_obs(const mfns_obs_t *o)
{
    const float *c = o->cov_px2;
    return isfinite(o->u) && isfinite(o->v) && isfinite(o->x) && isfinite(o->y) && isfinite(c[0]) &&
           isfinite(c[1]) && isfinite(c[2]) && c[0] >= 0.0f && c[2] >= 0.0f && c[1] * c[1] <= c[0] * c[2];
}

int mfns_pose_gather(const mfns_beacon_map_t *map, const mfns_obs_frame_t *frame,
                     const mfns_pose_assoc_t *assoc, mfns_pose_meas_t m[MFNS_POSE_MAX_MEAS])
{
    if (map->count > MFNS_MAX_BEACONS) {
        return -1;
    }
    int n = 0;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (frame->count[c] > MFNS_MAX_OBS_PER_CAMERA) {
            return -1;
        }
        for (int i = 0; i < frame->count[c]; i++) {
            const int16_t b = assoc->beacon[c][i];
            if (b == MFNS_POSE_NO_BEACON) {
                continue;
            }
            if (b < 0 || b >= (int)map->count || !finite_obs(&frame->obs[c][i])) {
                return -1;
            }
            mfns_pose_meas_set(map, frame, c, i, b, &m[n++]);
        }
    }
    return n;
}

/* Distinct beacons among the active measurements (a beacon seen twice adds
 * no independent constraint on its own position). */
static int distinct_active(const mfns_pose_meas_t *m, int n)
{
    int d = 0;
    for (int i = 0; i < n; i++) {
        if (!m[i].active) {
            continue;
        }
        bool seen = false;
        for (int j = 0; j < i; j++) {
            if (m[j].active && m[j].beacon == m[i].beacon) {
                seen = true;
                break;
            }
        }
        d += seen ? 0 : 1;
    }
    return d;
}

static bool valid_config(const mfns_pose_config_t *cfg)
{
    return cfg->s.max_iterations > 0 && cfg->sigma_px > 0.0f && isfinite(cfg->sigma_px) &&
           cfg->s.step_tol > 0.0f && (cfg->mode == MFNS_POSE_MODE_ML || cfg->mode == MFNS_POSE_MODE_PAPER);
}

mfns_pose_status_t mfns_pose_refine_meas(const mfns_rig_t *rig, mfns_pose_meas_t *m, int n,
                                         const mfns_pose_t *init, const mfns_pose_config_t *cfg,
                                         mfns_pose_solution_t *out)
{
    /* the caller has set out->assoc; keep it across the clear */
    const mfns_pose_assoc_t assoc = out->assoc;
    const uint16_t hyp = out->hypotheses;
    mfns_pose_solution_clear(out, MFNS_POSE_R_NONE);
    out->assoc = assoc;
    out->hypotheses = hyp;
    if (distinct_active(m, n) < 3) {
        out->reason = MFNS_POSE_R_TOO_FEW;
        return out->status;
    }
    mfns_pose_t pose = *init;
    int iters = 0;
    const int cap = cfg->s.max_iterations;
    mfns_pose_reason_t r;
    int outliers = 0;
    bool weighed = false; /* m[].w evaluated at pose */
    if (cfg->mode == MFNS_POSE_MODE_PAPER) {
        r = mfns_pose_paper_newton(rig, m, n, cfg, cap, &pose, &iters);
    } else {
        /* weights at the start pose, held fixed through one LM run (a fixed
         * cost), re-evaluated at its solution for the gate and the re-solve */
        mfns_pose_weigh(rig, m, n, &pose, cfg);
        r = mfns_pose_lm(rig, m, n, cfg, cap, &pose, &iters);
        if (r == MFNS_POSE_R_NONE) {
            mfns_pose_weigh(rig, m, n, &pose, cfg);
            weighed = true;
        }
        if (r == MFNS_POSE_R_NONE && cfg->s.outlier_gate_sigma > 0.0f) {
            /* the whitened residual |L^-1 r| in sigmas of its own covariance */
            const float gate = cfg->s.outlier_gate_sigma;
            for (int k = 0; k < n; k++) {
                float res[2];
                if (m[k].active &&
                    (!mfns_pose_wresidual(rig, &m[k], &pose, res, NULL) ||
                     sqrtf(res[0] * res[0] + res[1] * res[1]) > gate)) {
                    m[k].active = 0;
                    outliers++;
                }
            }
            if (outliers > 0) {
                if (distinct_active(m, n) < 3) {
                    r = MFNS_POSE_R_TOO_FEW;
                } else if (iters < cap) {
                    r = mfns_pose_lm(rig, m, n, cfg, cap - iters, &pose, &iters);
                    weighed = false;
                } else {
                    r = MFNS_POSE_R_NOT_CONVERGED;
                }
            }
        }
    }
    /* the covariance and the residual check use R at the final pose (paper
     * mode fits unweighted, and reports the same covariance) */
    if (!weighed) {
        mfns_pose_weigh(rig, m, n, &pose, cfg);
    }
    out->pose = pose; /* for diagnostics even when NO_FIX */
    out->iterations = (uint16_t)iters;
    out->outliers = (uint16_t)outliers;
    bool cam_used[MFNS_NUM_CAMERAS] = {false, false, false};
    float ss = 0.0f, sw = 0.0f;
    int used = 0;
    for (int k = 0; k < n; k++) {
        float res[2];
        if (!m[k].active) {
            continue;
        }
        if (!mfns_pose_residual(rig, &m[k], &pose, res, NULL)) {
            r = (r == MFNS_POSE_R_NONE) ? MFNS_POSE_R_NOT_CONVERGED : r;
            continue;
        }
        out->inlier[m[k].cam][m[k].idx] = 1;
        cam_used[m[k].cam] = true;
        ss += res[0] * res[0] + res[1] * res[1];
        const float e0 = m[k].w[0] * res[0], e1 = m[k].w[1] * res[0] + m[k].w[2] * res[1];
        sw += e0 * e0 + e1 * e1;
        used++;
    }
    out->beacons_used = (uint16_t)used;
    out->residual_rms_px = used > 0 ? sqrtf(ss / (float)(2 * used)) : 0.0f;
    out->residual_rms_sigma = used > 0 ? sqrtf(sw / (float)(2 * used)) : 0.0f;
    out->r_wb_w = mfns_pose_position_w(&pose);
    mfns_euler_t e;
    (void)mfns_m3_to_euler213_at(&pose.C_w_b, &e);
    out->euler_deg.roll = e.roll * MFNS_DEG_PER_RAD_F;
    out->euler_deg.pitch = e.pitch * MFNS_DEG_PER_RAD_F;
    out->euler_deg.yaw = e.yaw * MFNS_DEG_PER_RAD_F;
    mfns_m3_t c_b_w;
    mfns_m3_transpose_at(&pose.C_w_b, &c_b_w);
    mfns_m3_to_quat(c_b_w, out->q_b_w);
    if (r != MFNS_POSE_R_NONE) {
        out->reason = r;
        return out->status;
    }
    float h[6][6], b[6][MFNS_CALIB_PARAMS];
    const bool calib = cfg->calib_cov != NULL && cfg->calib_cov->present != 0U;
    mfns_pose_info_matrix(rig, m, n, &pose, h, calib ? b : NULL);
    r = mfns_pose_covariance(h, calib ? b : NULL, cfg->calib_cov, cfg->datum, cfg->s.min_rcond, out);
    if (r != MFNS_POSE_R_NONE) {
        out->reason = r;
        return out->status;
    }
    if (!(out->residual_rms_sigma <= cfg->s.max_residual_rms_sigma)) {
        out->reason = MFNS_POSE_R_RESIDUAL_HIGH;
        return out->status;
    }
    out->cameras_used = (uint16_t)((cam_used[0] ? 1 : 0) + (cam_used[1] ? 1 : 0) + (cam_used[2] ? 1 : 0));
    if (distinct_active(m, n) == 3) {
        /* no redundancy: nothing can check a fault, so never usable; the pose
         * and covariance stay filled for tracking and diagnostics */
        out->status = MFNS_POSE_NO_FIX;
        out->reason = MFNS_POSE_R_MINIMAL;
    } else if (outliers > 0) {
        out->status = MFNS_POSE_DEGRADED;
        out->reason = MFNS_POSE_R_OUTLIERS;
    } else if (out->cameras_used < MFNS_NUM_CAMERAS) {
        out->status = MFNS_POSE_DEGRADED;
        out->reason = MFNS_POSE_R_CAMERA_UNUSED;
    } else {
        out->status = MFNS_POSE_OK;
        out->reason = MFNS_POSE_R_NONE;
    }
    return out->status;
}

static bool valid_pose(const mfns_pose_t *p)
{
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            if (!isfinite(p->C_w_b.m[i][j])) {
                return false;
            }
        }
    }
    return isfinite(p->r_bw_b.x) && isfinite(p->r_bw_b.y) && isfinite(p->r_bw_b.z) &&
           mfns_m3_is_rotation_at(&p->C_w_b, 1e-3f);
}

mfns_pose_status_t mfns_pose_refine(const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                    const mfns_obs_frame_t *frame, const mfns_pose_assoc_t *assoc,
                                    const mfns_pose_t *init, const mfns_pose_config_t *cfg,
                                    mfns_pose_solution_t *out)
{
    if (out == NULL) {
        return MFNS_POSE_NO_FIX;
    }
    mfns_pose_solution_clear(out, MFNS_POSE_R_BAD_ARG);
    if (rig == NULL || map == NULL || frame == NULL || assoc == NULL || init == NULL || cfg == NULL ||
        !valid_config(cfg) || !valid_pose(init)) {
        return out->status;
    }
    mfns_pose_meas_t m[MFNS_POSE_MAX_MEAS];
    const int n = mfns_pose_gather(map, frame, assoc, m);
    if (n < 0) {
        return out->status;
    }
    out->assoc = *assoc;
    return mfns_pose_refine_meas(rig, m, n, init, cfg, out);
}

/* Tracking association: every blob goes to the nearest predicted beacon
 * within the gate, one-to-one, closest pairs first. */
int mfns_pose_associate(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const mfns_obs_frame_t *frame,
                           const mfns_pose_t *pred, float gate, mfns_pose_assoc_t *assoc)
{
    int total = 0;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < MFNS_MAX_OBS_PER_CAMERA; i++) {
            assoc->beacon[c][i] = MFNS_POSE_NO_BEACON;
        }
        float pu[MFNS_MAX_BEACONS], pv[MFNS_MAX_BEACONS];
        bool vis[MFNS_MAX_BEACONS];
        for (int b = 0; b < map->count; b++) {
            float uv[2];
            vis[b] = mfns_cam_project(&rig->cam[c], pred, map->beacon[b].p_w, uv, NULL) == MFNS_PROJ_OK;
            pu[b] = uv[0];
            pv[b] = uv[1];
        }
        const int nb = frame->count[c];
        bool blob_done[MFNS_MAX_OBS_PER_CAMERA] = {false};
        /* each round takes the globally closest remaining pair: at most nb rounds */
        for (int round = 0; round < nb; round++) {
            float best = gate * gate;
            int bi = -1, bb = -1;
            for (int i = 0; i < nb; i++) {
                if (blob_done[i]) {
                    continue;
                }
                for (int b = 0; b < map->count; b++) {
                    if (!vis[b]) {
                        continue;
                    }
                    const float du = pu[b] - frame->obs[c][i].u, dv = pv[b] - frame->obs[c][i].v;
                    const float d2 = du * du + dv * dv;
                    if (d2 <= best) {
                        best = d2;
                        bi = i;
                        bb = b;
                    }
                }
            }
            if (bi < 0) {
                break;
            }
            blob_done[bi] = true;
            vis[bb] = false;
            assoc->beacon[c][bi] = (int16_t)bb;
            total++;
        }
    }
    return total;
}

static bool valid_inputs(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const mfns_obs_frame_t *frame,
                         const mfns_pose_config_t *cfg)
{
    if (rig == NULL || map == NULL || frame == NULL || cfg == NULL || !valid_config(cfg) ||
        map->count > MFNS_MAX_BEACONS) {
        return false;
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (frame->count[c] > MFNS_MAX_OBS_PER_CAMERA) {
            return false;
        }
        for (int i = 0; i < frame->count[c]; i++) {
            if (!finite_obs(&frame->obs[c][i])) {
                return false;
            }
        }
    }
    return true;
}

mfns_pose_status_t mfns_pose_track(const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                   const mfns_obs_frame_t *frame, const mfns_pose_t *predicted,
                                   const mfns_pose_config_t *cfg, mfns_pose_solution_t *out)
{
    if (out == NULL) {
        return MFNS_POSE_NO_FIX;
    }
    mfns_pose_solution_clear(out, MFNS_POSE_R_BAD_ARG);
    if (!valid_inputs(rig, map, frame, cfg) || predicted == NULL || !valid_pose(predicted)) {
        return out->status;
    }
    mfns_pose_assoc_t assoc;
    if (mfns_pose_associate(rig, map, frame, predicted, cfg->s.track_gate_px, &assoc) < 3) {
        out->reason = MFNS_POSE_R_TRACK_LOST;
        return out->status;
    }
    mfns_pose_meas_t m[MFNS_POSE_MAX_MEAS];
    const int n = mfns_pose_gather(map, frame, &assoc, m);
    if (n < 0) {
        return out->status;
    }
    out->assoc = assoc;
    return mfns_pose_refine_meas(rig, m, n, predicted, cfg, out);
}
