/* pose_refine.c -- the maximum-likelihood refinement: Levenberg-Marquardt on
 * the pixel reprojection error with a Huber loss (IRLS), the rotation updated
 * on the manifold (camera.h increment). Float throughout: the residuals are
 * differences of pixel values ~1e3 px whose float rounding (6e-5 px) is far
 * below the measurement noise, so double buys nothing here. */
#include <math.h>
#include <stddef.h>

#include "pose_internal.h"
#include "spd.h"

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

void mfns_pose_info_matrix(const mfns_rig_t *rig, const mfns_pose_meas_t *m, int n,
                           const mfns_pose_t *pose, float h[6][6])
{
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            h[i][j] = 0.0f;
        }
    }
    for (int k = 0; k < n; k++) {
        float r[2], jac[2][6];
        if (!m[k].active || !mfns_pose_residual(rig, &m[k], pose, r, jac)) {
            continue;
        }
        for (int i = 0; i < 6; i++) {
            for (int j = 0; j <= i; j++) {
                h[i][j] += jac[0][i] * jac[0][j] + jac[1][i] * jac[1][j];
            }
        }
    }
    for (int i = 0; i < 6; i++) {
        for (int j = i + 1; j < 6; j++) {
            h[i][j] = h[j][i];
        }
    }
}

/* A point behind a camera costs this much (in squared sigma units): LM then
 * rejects steps that turn a beacon away rather than silently dropping it. */
#define BEHIND_COST 1e8f

/* Robust cost and, when h/g are not NULL, the IRLS normal equations. */
static float linearize(const mfns_rig_t *rig, const mfns_pose_meas_t *m, int n, const mfns_pose_t *pose,
                       float sigma, float huber_k, float h[6][6], float g[6])
{
    if (h != NULL) {
        for (int i = 0; i < 6; i++) {
            g[i] = 0.0f;
            for (int j = 0; j < 6; j++) {
                h[i][j] = 0.0f;
            }
        }
    }
    float cost = 0.0f;
    const float inv_s = 1.0f / sigma;
    for (int k = 0; k < n; k++) {
        if (!m[k].active) {
            continue;
        }
        float r[2], jac[2][6] = {{0.0f}};
        if (!mfns_pose_residual(rig, &m[k], pose, r, h != NULL ? jac : NULL)) {
            cost += BEHIND_COST;
            continue;
        }
        const float e = sqrtf(r[0] * r[0] + r[1] * r[1]) * inv_s;
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
        for (int i = 0; i < 6; i++) {
            for (int j = i + 1; j < 6; j++) {
                h[i][j] = h[j][i];
            }
        }
    }
    return cost;
}

mfns_pose_reason_t mfns_pose_lm(const mfns_rig_t *rig, const mfns_pose_meas_t *m, int n,
                                const mfns_pose_config_t *cfg, int max_iter, mfns_pose_t *pose,
                                int *iterations)
{
    const float sigma = cfg->sigma_px > 0.0f ? cfg->sigma_px : 1.0f;
    const float huber_k = cfg->s.huber_k > 0.0f ? cfg->s.huber_k : INFINITY;
    float h[6][6], g[6];
    float cost = linearize(rig, m, n, pose, sigma, huber_k, h, g);
    float lambda = 1e-4f;
    int it = 0;
    mfns_pose_reason_t result = MFNS_POSE_R_NOT_CONVERGED;
    for (; it < max_iter; it++) {
        /* Scaled gradient: |g_i| / sqrt(H_ii), in units of sigma: how much
         * the cost could still fall along each axis. */
        float gmax = 0.0f;
        for (int i = 0; i < 6; i++) {
            if (h[i][i] > 0.0f) {
                gmax = fmaxf(gmax, fabsf(g[i]) / sqrtf(h[i][i]) / sigma);
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
        mfns_chol_t f;
        if (mfns_chol_factor(a, 6, 0.0f, &f) != MFNS_SPD_OK) {
            result = MFNS_POSE_R_SINGULAR;
            break;
        }
        float d[6];
        mfns_chol_solve(&f, g, d);
        for (int i = 0; i < 6; i++) {
            d[i] = -d[i];
        }
        const float step_rot = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        const float step_tr = sqrtf(d[3] * d[3] + d[4] * d[4] + d[5] * d[5]) * 1e-3f;
        const bool tiny = step_rot < cfg->s.step_tol && step_tr < cfg->s.step_tol;
        const mfns_pose_t trial = mfns_pose_apply(pose, d);
        float ht[6][6], gt[6];
        const float cost_t = linearize(rig, m, n, &trial, sigma, huber_k, ht, gt);
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
