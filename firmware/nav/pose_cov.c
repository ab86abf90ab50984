/* pose_cov.c -- the pose covariance sigma^2 (J^T J)^-1 of the ML solve (the
 * Cramer-Rao bound for Gaussian pixel noise of 1-sigma sigma_px), mapped to
 * the output quantities: r_wb_w (mm) and the 2-1-3 Euler angles (deg). */
#include <math.h>
#include <stddef.h>

#include "pose_internal.h"
#include "spd.h"

#define RAD2DEG 57.29577951308232f

mfns_pose_reason_t mfns_pose_covariance(const float h[6][6], float sigma_px, float min_rcond,
                                        mfns_pose_solution_t *out)
{
    float a[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N];
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            a[i][j] = h[i][j];
            out->cov[i][j] = 0.0f;
            out->cov_ros[i][j] = 0.0f;
        }
    }
    for (int i = 0; i < 3; i++) {
        out->sigma_pos_mm[i] = 0.0f;
        out->sigma_euler_deg[i] = 0.0f;
    }
    mfns_chol_t f;
    if (mfns_chol_factor(a, 6, min_rcond, &f) != MFNS_SPD_OK) {
        return MFNS_POSE_R_SINGULAR;
    }
    float inv[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N];
    mfns_chol_inverse(&f, inv);
    const float s2 = sigma_px * sigma_px;
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            out->cov[i][j] = s2 * inv[i][j];
        }
    }
    /* Output Jacobian rows (3 position, 3 Euler) w.r.t. the increment.
     * Position: r_wb_w = -C^T r, so d r_wb_w = -C^T skew(r) dtheta - C^T dt.
     * Euler: central differences of the angles of exp(h e_i) C (h = 1e-3 rad:
     * truncation ~1e-7, rounding ~6e-5 relative, ample for a 1-sigma). */
    const mfns_m3_t ct = mfns_m3_transpose(out->pose.C_w_b);
    const mfns_m3_t a_rot = mfns_m3_scale(mfns_m3_mul(ct, mfns_m3_skew(out->pose.r_bw_b)), -1.0f);
    float jo[6][6];
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 3; c++) {
            jo[r][c] = a_rot.m[r][c];
            jo[r][c + 3] = -ct.m[r][c];
        }
    }
    const float hstep = 1e-3f;
    for (int c = 0; c < 3; c++) {
        float dv[3] = {0.0f, 0.0f, 0.0f};
        dv[c] = hstep;
        mfns_euler_t ep, em;
        (void)mfns_m3_to_euler213(mfns_m3_mul(mfns_rot_exp(mfns_v3(dv[0], dv[1], dv[2])), out->pose.C_w_b), &ep);
        (void)mfns_m3_to_euler213(mfns_m3_mul(mfns_rot_exp(mfns_v3(-dv[0], -dv[1], -dv[2])), out->pose.C_w_b),
                                  &em);
        const float de[3] = {ep.roll - em.roll, ep.pitch - em.pitch, ep.yaw - em.yaw};
        for (int r = 0; r < 3; r++) {
            float v = de[r];
            /* angles wrap at +-pi */
            if (v > 3.14159265f) {
                v -= 6.28318531f;
            } else if (v < -3.14159265f) {
                v += 6.28318531f;
            }
            jo[3 + r][c] = v / (2.0f * hstep);
            jo[3 + r][c + 3] = 0.0f;
        }
    }
    /* ROS order: the position rows of jo, then the rotation about the world
     * axes. The increment rotates C_w_b on the left, C_w_b' = exp(dtheta) C_w_b,
     * so C_b_w' = C_b_w exp(-dtheta) = exp(-C_b_w dtheta) C_b_w: phi_w =
     * -C^T dtheta (pose.h: both errors are estimate minus truth). */
    float jr[6][6];
    for (int r = 0; r < 6; r++) {
        for (int c = 0; c < 6; c++) {
            jr[r][c] = r < 3 ? jo[r][c] : (c < 3 ? -ct.m[r - 3][c] : 0.0f);
        }
    }
    for (int p = 0; p < 6; p++) {
        for (int q = 0; q < 6; q++) {
            float v = 0.0f;
            for (int i = 0; i < 6; i++) {
                for (int j = 0; j < 6; j++) {
                    v += jr[p][i] * out->cov[i][j] * jr[q][j];
                }
            }
            out->cov_ros[p][q] = v;
        }
    }
    for (int p = 0; p < 6; p++) { /* exactly symmetric */
        for (int q = p + 1; q < 6; q++) {
            const float m = 0.5f * (out->cov_ros[p][q] + out->cov_ros[q][p]);
            out->cov_ros[p][q] = m;
            out->cov_ros[q][p] = m;
        }
    }
    for (int r = 0; r < 6; r++) {
        float var = 0.0f;
        for (int i = 0; i < 6; i++) {
            for (int j = 0; j < 6; j++) {
                var += jo[r][i] * out->cov[i][j] * jo[r][j];
            }
        }
        const float sd = sqrtf(fmaxf(var, 0.0f));
        if (r < 3) {
            out->sigma_pos_mm[r] = sd;
        } else {
            out->sigma_euler_deg[r - 3] = sd * RAD2DEG;
        }
    }
    return MFNS_POSE_R_NONE;
}
