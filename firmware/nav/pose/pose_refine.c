/* pose_refine.c -- the maximum-likelihood refinement: Levenberg-Marquardt on
 * the pixel reprojection error whitened by each observation's covariance R_i
 * (mfns_pose_obs_cov: centroid + floor + survey), with a Huber loss (IRLS),
 * the rotation updated on the manifold (lens.h increment). Float throughout: the residuals are
 * differences of pixel values ~1e3 px whose float rounding (6e-5 px) is far
 * below the measurement noise, so double buys nothing here. */
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "math/core_inline.h"
#include "firmware/nav/pose/pose_internal.h"
#include "math/spd.h"
#include "math/units.h"

bool mfns_pose_residual(const mfns_rig_t *rig, const mfns_pose_meas_t *m, const mfns_pose_t *pose,
                        float r[2], float jac[2][6])
{
    float uv[2];
    if (mfns_cam_project(&rig->cam[m->cam], pose, m->p_w, uv, jac) != MFNS_PROJ_OK) {
        return false;
    }
    r[0] = uv[0] - m->u;
    r[1] = uv[1] - m->v;
    return isfinite(r[0]) && isfinite(r[1]);
}

bool mfns_pose_whitener(const float r_px2[3], float w[3])
{
    /* R = L L^T: l00 = sqrt(a), l10 = b / l00, l11 = sqrt(c - l10^2) */
    if (!(r_px2[0] > 0.0f) || !isfinite(r_px2[0]) || !isfinite(r_px2[1]) || !isfinite(r_px2[2])) {
        return false;
    }
    const float l00 = sqrtf(r_px2[0]);
    const float l10 = r_px2[1] / l00;
    const float d = r_px2[2] - l10 * l10;
    /* a pivot below 1e-6 of var v is a degenerate (rank-1) covariance */
    if (!(d > 1e-6f * r_px2[2])) {
        return false;
    }
    const float l11 = sqrtf(d);
    w[0] = 1.0f / l00;
    w[1] = -l10 / (l00 * l11);
    w[2] = 1.0f / l11;
    return true;
}

bool mfns_pose_obs_cov(const mfns_camera_t *cam, const mfns_pose_t *pose, mfns_v3_t p_w, const float cov_px2[3],
                       float sigma_mm, float sigma_px, float r_px2[3])
{
    const mfns_v3_t p_k = mfns_cam_world_to_camera(cam, pose, p_w);
    float uv[2], jk[2][3];
    if (mfns_cam_project_c(&cam->k, p_k, uv, jk) != MFNS_PROJ_OK) {
        return false;
    }
    /* The lens model (and so J_p) holds only over the image: a beacon
     * predicted far outside it, where the distortion polynomial explodes,
     * has no meaningful projected survey error (a wrong pose of the
     * acquisition would hide its misfit behind a huge R). */
    const float mg = MFNS_POSE_COV_MARGIN_PX;
    if (!(uv[0] >= -mg && uv[1] >= -mg && uv[0] <= (float)cam->k.width + mg && uv[1] <= (float)cam->k.height + mg)) {
        return false;
    }
    /* J_p = jk C_k_b^T C_w_b with both rotations orthonormal: J_p J_p^T = jk jk^T */
    const float s2 = sigma_mm * sigma_mm, f2 = sigma_px * sigma_px;
    r_px2[0] = cov_px2[0] + f2 + s2 * (jk[0][0] * jk[0][0] + jk[0][1] * jk[0][1] + jk[0][2] * jk[0][2]);
    r_px2[1] = cov_px2[1] + s2 * (jk[0][0] * jk[1][0] + jk[0][1] * jk[1][1] + jk[0][2] * jk[1][2]);
    r_px2[2] = cov_px2[2] + f2 + s2 * (jk[1][0] * jk[1][0] + jk[1][1] * jk[1][1] + jk[1][2] * jk[1][2]);
    float w[3];
    return mfns_pose_whitener(r_px2, w);
}

MFNS_OUT_OF_LINE
void mfns_pose_meas_set(const mfns_beacon_map_t *map, const mfns_obs_frame_t *frame, int c, int i, int b,
                        mfns_pose_meas_t *m)
{
    const mfns_obs_t *o = &frame->obs[c][i];
    m->cam = (uint8_t)c;
    m->idx = (uint8_t)i;
    m->beacon = (int16_t)b;
    m->u = o->u;
    m->v = o->v;
    m->x = o->x;
    m->y = o->y;
    m->p_w = map->beacon[b].p_w;
    m->cov_px2[0] = o->cov_px2[0];
    m->cov_px2[1] = o->cov_px2[1];
    m->cov_px2[2] = o->cov_px2[2];
    m->sigma_mm = map->beacon[b].sigma_mm;
    m->w[0] = 1.0f;
    m->w[1] = 0.0f;
    m->w[2] = 1.0f;
    m->active = 1;
}

void mfns_pose_weigh(const mfns_rig_t *rig, mfns_pose_meas_t *m, int n, const mfns_pose_t *pose,
                     const mfns_pose_config_t *cfg)
{
    const float s = cfg->sigma_px > 0.0f ? cfg->sigma_px : 1.0f;
    for (int k = 0; k < n; k++) {
        float r[3];
        if (!m[k].active || !mfns_pose_obs_cov(&rig->cam[m[k].cam], pose, m[k].p_w, m[k].cov_px2, m[k].sigma_mm,
                                               cfg->sigma_px, r) ||
            !mfns_pose_whitener(r, m[k].w)) {
            /* behind the camera (its residual costs BEHIND_COST anyway) */
            m[k].w[0] = 1.0f / s;
            m[k].w[1] = 0.0f;
            m[k].w[2] = 1.0f / s;
        }
    }
}

bool mfns_pose_wresidual(const mfns_rig_t *rig, const mfns_pose_meas_t *m, const mfns_pose_t *pose,
                         float e[2], float jac[2][6])
{
    float r[2];
    if (!mfns_pose_residual(rig, m, pose, r, jac)) {
        return false;
    }
    e[0] = m->w[0] * r[0];
    e[1] = m->w[1] * r[0] + m->w[2] * r[1];
    if (jac != NULL) {
        for (int i = 0; i < 6; i++) {
            const float j0 = jac[0][i], j1 = jac[1][i];
            jac[0][i] = m->w[0] * j0;
            jac[1][i] = m->w[1] * j0 + m->w[2] * j1;
        }
    }
    return true;
}

/* A point behind a camera costs this much (in squared sigma units): LM then
 * rejects steps that turn a beacon away rather than silently dropping it. */
#define BEHIND_COST 1e8f

/* Robust cost and, when h/g are not NULL, the IRLS normal equations, on the
 * whitened residuals (unit sigma). */
static float linearize(const mfns_rig_t *rig, const mfns_pose_meas_t *m, int n, const mfns_pose_t *pose,
                       float huber_k, float h[6][6], float g[6])
{
    if (h != NULL) {
        memset(h, 0, sizeof(float[6][6])); /* all-zero bytes are 0.0f */
        memset(g, 0, sizeof(float[6]));
    }
    float cost = 0.0f;
    for (int k = 0; k < n; k++) {
        if (!m[k].active) {
            continue;
        }
        float r[2], jac[2][6] = {{0.0f}};
        if (!mfns_pose_wresidual(rig, &m[k], pose, r, h != NULL ? jac : NULL)) {
            cost += BEHIND_COST;
            continue;
        }
        const float e = sqrtf(r[0] * r[0] + r[1] * r[1]);
        float w = 1.0f;
        if (e <= huber_k) {
            cost += e * e;
        } else {
            cost += 2.0f * huber_k * e - huber_k * huber_k;
            w = huber_k / e;
        }
        if (h != NULL) {
            for (int i = 0; i < 6; i++) {
                g[i] += w * (jac[0][i] * r[0] + jac[1][i] * r[1]);
                for (int j = 0; j <= i; j++) {
                    h[i][j] += w * (jac[0][i] * jac[0][j] + jac[1][i] * jac[1][j]);
                }
            }
        }
    }
    if (h != NULL) {
        mfns_pose_mirror_lower(h);
    }
    return cost;
}

void mfns_pose_mirror_lower(float h[6][6])
{
    for (int i = 0; i < 6; i++) {
        for (int j = i + 1; j < 6; j++) {
            h[i][j] = h[j][i];
        }
    }
}

bool mfns_pose_newton_step(float a[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N], const float g[6], float min_rcond,
                           float d[6], float *step_rot_rad, float *step_tr_m)
{
    mfns_chol_t f;
    if (mfns_chol_factor(a, 6, min_rcond, &f) != MFNS_SPD_OK) {
        return false;
    }
    mfns_chol_solve(&f, g, d);
    for (int i = 0; i < 6; i++) {
        d[i] = -d[i];
    }
    *step_rot_rad = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    *step_tr_m = sqrtf(d[3] * d[3] + d[4] * d[4] + d[5] * d[5]) * MFNS_M_PER_MM_F;
    return true;
}

mfns_pose_reason_t mfns_pose_lm(const mfns_rig_t *rig, const mfns_pose_meas_t *m, int n,
                                const mfns_pose_config_t *cfg, int max_iter, mfns_pose_t *pose,
                                int *iterations)
{
    const float huber_k = cfg->s.huber_k > 0.0f ? cfg->s.huber_k : INFINITY;
    float h[6][6], g[6];
    float cost = linearize(rig, m, n, pose, huber_k, h, g);
    float lambda = 1e-4f;
    int it = 0;
    mfns_pose_reason_t result = MFNS_POSE_R_NOT_CONVERGED;
    for (; it < max_iter; it++) {
        /* Scaled gradient: |g_i| / sqrt(H_ii), in units of sigma (whitened):
         * how much the cost could still fall along each axis. */
        float gmax = 0.0f;
        for (int i = 0; i < 6; i++) {
            if (h[i][i] > 0.0f) {
                gmax = fmaxf(gmax, fabsf(g[i]) / sqrtf(h[i][i]));
            }
        }
        if (gmax < cfg->s.grad_tol) {
            result = MFNS_POSE_R_NONE;
            break;
        }
        float a[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N];
        for (int i = 0; i < 6; i++) {
            for (int j = 0; j < 6; j++) {
                a[i][j] = h[i][j];
            }
            a[i][i] = h[i][i] * (1.0f + lambda);
        }
        float d[6], step_rot, step_tr;
        if (!mfns_pose_newton_step(a, g, 0.0f, d, &step_rot, &step_tr)) {
            result = MFNS_POSE_R_SINGULAR;
            break;
        }
        const bool tiny = step_rot < cfg->s.step_tol && step_tr < cfg->s.step_tol;
        const mfns_pose_t trial = mfns_pose_apply(pose, d);
        float ht[6][6], gt[6];
        const float cost_t = linearize(rig, m, n, &trial, huber_k, ht, gt);
        if (cost_t <= cost) {
            *pose = trial;
            cost = cost_t;
            for (int i = 0; i < 6; i++) {
                g[i] = gt[i];
                for (int j = 0; j < 6; j++) {
                    h[i][j] = ht[i][j];
                }
            }
            lambda = fmaxf(lambda * 0.2f, 1e-7f);
            if (tiny) {
                it++;
                result = MFNS_POSE_R_NONE;
                break;
            }
        } else {
            if (tiny && lambda < 1.0f) {
                /* At the float noise floor: a step below tolerance that does
                 * not lower the cost means there is nothing left to gain. */
                it++;
                result = MFNS_POSE_R_NONE;
                break;
            }
            lambda *= 10.0f;
            if (lambda > 1e8f) {
                it++;
                break;
            }
        }
    }
    if (cost >= BEHIND_COST) {
        result = MFNS_POSE_R_NOT_CONVERGED;
    }
    *iterations += it;
    return result;
}
