/* pose_paper.c -- paper mode: the Newton iteration of the paper on Eq. 3's
 * algebraic form, kept as the comparison baseline. Eq. 3 multiplies the
 * projection out: for camera coordinates p_c = C_b^k (C_w^b P + r_bw^b - r_bk^b)
 * and undistorted normalized (x, y), x*Zc - Xc = 0 and y*Zc - Yc = 0. Those
 * residuals (mm) weight each beacon by its depth and are not the
 * maximum-likelihood error; the iteration is undamped Gauss-Newton with no
 * robust loss, as in the paper (its rotation update uses the same manifold
 * increment as ours so that only the error model differs). */
#include <math.h>
#include <stddef.h>

#include "firmware/nav/pose/pose_internal.h"
#include "math/spd.h"

static bool algebraic(const mfns_rig_t *rig, const mfns_pose_meas_t *m, const mfns_pose_t *pose,
                      float r[2], float jac[2][6])
{
    const mfns_camera_t *cam = &rig->cam[m->cam];
    const mfns_v3_t q = mfns_m3_mul_v3_at(&pose->C_w_b, m->p_w);
    const mfns_v3_t p_b = mfns_v3_add(q, pose->r_bw_b);
    const mfns_v3_t p_c = mfns_m3_tmul_v3_at(&cam->C_k_b, mfns_v3_sub(p_b, cam->r_bk_b));
    r[0] = m->x * p_c.z - p_c.x;
    r[1] = m->y * p_c.z - p_c.y;
    if (jac != NULL) {
        /* d r / d p_c = [[-1, 0, x], [0, -1, y]], chained to the increment */
        const float dc[2][3] = {{-1.0f, 0.0f, m->x}, {0.0f, -1.0f, m->y}};
        mfns_cam_chain_pose_jac(cam, q, dc, jac);
    }
    return isfinite(r[0]) && isfinite(r[1]);
}

mfns_pose_reason_t mfns_pose_paper_newton(const mfns_rig_t *rig, const mfns_pose_meas_t *m, int n,
                                          const mfns_pose_config_t *cfg, int max_iter,
                                          mfns_pose_t *pose, int *iterations)
{
    int it = 0;
    mfns_pose_reason_t result = MFNS_POSE_R_NOT_CONVERGED;
    for (; it < max_iter; it++) {
        float a[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N] = {{0}};
        float g[6] = {0};
        for (int k = 0; k < n; k++) {
            float r[2], jac[2][6];
            if (!m[k].active) {
                continue;
            }
            if (!algebraic(rig, &m[k], pose, r, jac)) {
                *iterations += it;
                return MFNS_POSE_R_NOT_CONVERGED;
            }
            for (int i = 0; i < 6; i++) {
                g[i] += jac[0][i] * r[0] + jac[1][i] * r[1];
                for (int j = 0; j <= i; j++) {
                    a[i][j] += jac[0][i] * jac[0][j] + jac[1][i] * jac[1][j];
                }
            }
        }
        float d[6], step_rot, step_tr;
        if (!mfns_pose_newton_step(a, g, cfg->s.min_rcond, d, &step_rot, &step_tr)) {
            result = MFNS_POSE_R_SINGULAR;
            break;
        }
        *pose = mfns_pose_apply(pose, d);
        if (!isfinite(step_rot) || !isfinite(step_tr)) {
            break;
        }
        if (step_rot < cfg->s.step_tol && step_tr < cfg->s.step_tol) {
            it++;
            result = MFNS_POSE_R_NONE;
            break;
        }
    }
    *iterations += it;
    return result;
}
