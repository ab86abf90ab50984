/* pose_cov.c -- the pose covariance of the ML solve: (J^T R^-1 J)^-1 with
 * each observation's covariance R_i (the Cramer-Rao bound for Gaussian pixel
 * noise), plus the first-order effect of the calibration's uncertainty
 * A Sigma_c A^T, A = (J^T R^-1 J)^-1 J^T R^-1 J_c, plus the map datum's rigid
 * motion G Sigma_d G^T (mfns_pose_add_datum_term), mapped to the output
 * quantities: r_wb_w (mm), the 2-1-3 Euler angles (deg) and the ROS-order
 * covariance. */
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "firmware/nav/pose/pose_internal.h"
#include "math/spd.h"
#include "math/units.h"


/* d(u, v) / d(calibration parameters of the observing camera) (nav_settings.h
 * order) at pose, with the errors' conventions of mfns_calib_cov_t: a mount
 * error theta turns camera coordinates p_k = C_k_b^T d (d = p_b - r_bk_b)
 * into C_k_b^T exp(-[theta]x) d = p_k + C_k_b^T [d]x theta, an offset error r
 * moves them by -C_k_b^T r. False when the beacon is behind the camera. */
bool mfns_pose_calib_jacobian(const mfns_camera_t *cam, const mfns_pose_t *pose, mfns_v3_t p_w,
                              float jc[2][MFNS_CALIB_PARAMS_PER_CAMERA])
{
    const mfns_v3_t p_b = mfns_v3_add(mfns_m3_mul_v3_at(&pose->C_w_b, p_w), pose->r_bw_b);
    const mfns_v3_t d = mfns_v3_sub(p_b, cam->r_bk_b);
    const mfns_v3_t p_k = mfns_m3_tmul_v3_at(&cam->C_k_b, d);
    float uv[2], jk[2][3];
    if (mfns_cam_project_c(&cam->k, p_k, uv, jk) != MFNS_PROJ_OK) {
        return false;
    }
    const mfns_intrinsics_t *k = &cam->k;
    const float x = p_k.x / p_k.z, y = p_k.y / p_k.z;
    float xd, yd;
    mfns_cam_distort(k, x, y, &xd, &yd, NULL);
    const float r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
    /* d(xd, yd) / d(k1, k2, p1, p2, k3) */
    const float dx[5] = {x * r2, x * r4, 2.0f * x * y, r2 + 2.0f * x * x, x * r6};
    const float dy[5] = {y * r2, y * r4, r2 + 2.0f * y * y, 2.0f * x * y, y * r6};
    jc[0][MFNS_CALIB_FX] = xd;
    jc[1][MFNS_CALIB_FX] = 0.0f;
    jc[0][MFNS_CALIB_FY] = 0.0f;
    jc[1][MFNS_CALIB_FY] = yd;
    jc[0][MFNS_CALIB_CX] = 1.0f;
    jc[1][MFNS_CALIB_CX] = 0.0f;
    jc[0][MFNS_CALIB_CY] = 0.0f;
    jc[1][MFNS_CALIB_CY] = 1.0f;
    for (int i = 0; i < 5; i++) {
        jc[0][MFNS_CALIB_K1 + i] = k->fx * dx[i] + k->skew * dy[i];
        jc[1][MFNS_CALIB_K1 + i] = k->fy * dy[i];
    }
    const mfns_m3_t sd = mfns_m3_skew(d);
    for (int a = 0; a < 2; a++) {
        /* row a of M = d(u, v) / d p_b = jk C_k_b^T, i.e. C_k_b jk_a; then M [d]x */
        const mfns_v3_t mm = mfns_m3_mul_v3_at(&cam->C_k_b, mfns_v3(jk[a][0], jk[a][1], jk[a][2]));
        const mfns_v3_t th = mfns_m3_tmul_v3_at(&sd, mm);
        jc[a][MFNS_CALIB_THETA_X] = th.x;
        jc[a][MFNS_CALIB_THETA_Y] = th.y;
        jc[a][MFNS_CALIB_THETA_Z] = th.z;
        jc[a][MFNS_CALIB_R_X] = -mm.x;
        jc[a][MFNS_CALIB_R_Y] = -mm.y;
        jc[a][MFNS_CALIB_R_Z] = -mm.z;
    }
    return true;
}

void mfns_pose_info_matrix(const mfns_rig_t *rig, const mfns_pose_meas_t *m, int n,
                           const mfns_pose_t *pose, float h[6][6], float b[6][MFNS_CALIB_PARAMS])
{
    memset(h, 0, sizeof(float[6][6])); /* all-zero bytes are 0.0f */
    if (b != NULL) {
        memset(b, 0, sizeof(float[6][MFNS_CALIB_PARAMS]));
    }
    for (int k = 0; k < n; k++) {
        float r[2], jac[2][6];
        if (!m[k].active || !mfns_pose_wresidual(rig, &m[k], pose, r, jac)) {
            continue;
        }
        for (int i = 0; i < 6; i++) {
            for (int j = 0; j <= i; j++) {
                h[i][j] += jac[0][i] * jac[0][j] + jac[1][i] * jac[1][j];
            }
        }
        float jc[2][MFNS_CALIB_PARAMS_PER_CAMERA];
        if (b == NULL || !mfns_pose_calib_jacobian(&rig->cam[m[k].cam], pose, m[k].p_w, jc)) {
            continue;
        }
        const int c0 = (int)m[k].cam * MFNS_CALIB_PARAMS_PER_CAMERA;
        for (int j = 0; j < MFNS_CALIB_PARAMS_PER_CAMERA; j++) {
            /* whitened: L^-1 J_c */
            const float w0 = m[k].w[0] * jc[0][j], w1 = m[k].w[1] * jc[0][j] + m[k].w[2] * jc[1][j];
            for (int i = 0; i < 6; i++) {
                b[i][c0 + j] += jac[0][i] * w0 + jac[1][i] * w1;
            }
        }
    }
    mfns_pose_mirror_lower(h);
}

/* cov += A Sigma_c A^T with A = cov B (6 x 45), over the cameras B touches
 * (the others' columns are zero): at most 6 * 45^2 + 6^2 * 45 multiply-adds. */
static void add_calibration_term(const float b[6][MFNS_CALIB_PARAMS], const mfns_calib_cov_t *calib,
                                 float cov[6][6])
{
    bool cam_used[MFNS_NUM_CAMERAS];
    float a[6][MFNS_CALIB_PARAMS];
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        cam_used[c] = false;
        for (int j = c * MFNS_CALIB_PARAMS_PER_CAMERA; j < (c + 1) * MFNS_CALIB_PARAMS_PER_CAMERA; j++) {
            for (int i = 0; i < 6; i++) {
                float v = 0.0f;
                for (int q = 0; q < 6; q++) {
                    v += cov[i][q] * b[q][j];
                }
                a[i][j] = v;
                cam_used[c] = cam_used[c] || v != 0.0f;
            }
        }
    }
    float t[6][MFNS_CALIB_PARAMS]; /* A Sigma_c */
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < MFNS_CALIB_PARAMS; j++) {
            float v = 0.0f;
            for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
                for (int q = c * MFNS_CALIB_PARAMS_PER_CAMERA;
                     cam_used[c] && q < (c + 1) * MFNS_CALIB_PARAMS_PER_CAMERA; q++) {
                    v += a[i][q] * calib->cov[q][j];
                }
            }
            t[i][j] = v;
        }
    }
    float add[6][6];
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j <= i; j++) {
            float v = 0.0f;
            for (int q = 0; q < MFNS_CALIB_PARAMS; q++) {
                v += t[i][q] * a[j][q];
            }
            add[i][j] = v;
        }
    }
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j <= i; j++) {
            /* symmetric by construction; a PSD Sigma_c makes the sum grow */
            cov[i][j] += add[i][j];
            cov[j][i] = cov[i][j];
        }
    }
}

void mfns_pose_add_datum_term(const mfns_pose_t *pose, const mfns_map_datum_t *datum, float cov[6][6])
{
    if (datum == NULL || datum->present == 0U) {
        return;
    }
    /* G (increment rows dtheta, dt_inc; datum columns dt, dth) */
    const mfns_m3_t *c = &pose->C_w_b;
    const mfns_m3_t sc = mfns_m3_skew(datum->c_w);
    mfns_m3_t csc; /* C_w_b [c_w]x */
    mfns_m3_mul_at(c, &sc, &csc);
    float g[6][MFNS_MAP_DATUM_PARAMS];
    for (int r = 0; r < 3; r++) {
        for (int q = 0; q < 3; q++) {
            g[r][q] = 0.0f;
            g[r][q + 3] = -c->m[r][q];
            g[r + 3][q] = -c->m[r][q];
            g[r + 3][q + 3] = -csc.m[r][q];
        }
    }
    float t[6][MFNS_MAP_DATUM_PARAMS]; /* G Sigma_d */
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < MFNS_MAP_DATUM_PARAMS; j++) {
            float v = 0.0f;
            for (int q = 0; q < MFNS_MAP_DATUM_PARAMS; q++) {
                v += g[i][q] * datum->cov[q][j];
            }
            t[i][j] = v;
        }
    }
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j <= i; j++) {
            float v = 0.0f;
            for (int q = 0; q < MFNS_MAP_DATUM_PARAMS; q++) {
                v += t[i][q] * g[j][q];
            }
            cov[i][j] += v;
            if (j != i) {
                cov[j][i] += v;
            }
        }
    }
}

/* x^T c y, the products summed row by row (the output covariance of two
 * output Jacobian rows x and y). */
static float quad_form(const float x[6], const float c[6][6], const float y[6])
{
    float v = 0.0f;
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            v += x[i] * c[i][j] * y[j];
        }
    }
    return v;
}

_Static_assert(MFNS_SPD_MAX_N == 6, "the pose's 6x6 matrices are the factorisation's");

mfns_pose_reason_t mfns_pose_covariance(const float h[6][6], const float b[6][MFNS_CALIB_PARAMS],
                                        const mfns_calib_cov_t *calib, const mfns_map_datum_t *datum,
                                        float min_rcond, mfns_pose_solution_t *out)
{
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            out->cov[i][j] = 0.0f;
            out->cov_ros[i][j] = 0.0f;
        }
    }
    for (int i = 0; i < 3; i++) {
        out->sigma_pos_mm[i] = 0.0f;
        out->sigma_euler_deg[i] = 0.0f;
    }
    mfns_chol_t f; /* h and the covariance are the factor's size: no copies */
    if (mfns_chol_factor(h, 6, min_rcond, &f) != MFNS_SPD_OK) {
        return MFNS_POSE_R_SINGULAR;
    }
    mfns_chol_inverse(&f, out->cov); /* whitened: R is in h */
    if (b != NULL && calib != NULL && calib->present != 0U) {
        add_calibration_term(b, calib, out->cov);
    }
    mfns_pose_add_datum_term(&out->pose, datum, out->cov);
    /* Output Jacobian rows (3 position, 3 Euler) w.r.t. the increment.
     * Position: r_wb_w = -C^T r, so d r_wb_w = -C^T skew(r) dtheta - C^T dt.
     * Euler: central differences of the angles of exp(h e_i) C (h = 1e-3 rad:
     * truncation ~1e-7, rounding ~6e-5 relative, ample for a 1-sigma). */
    mfns_m3_t ct, a_rot;
    mfns_m3_transpose_at(&out->pose.C_w_b, &ct);
    a_rot = mfns_m3_skew(out->pose.r_bw_b);
    mfns_m3_mul_at(&ct, &a_rot, &a_rot);
    mfns_m3_scale_at(&a_rot, -1.0f, &a_rot);
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
        mfns_m3_t cp = mfns_rot_exp(mfns_v3(dv[0], dv[1], dv[2]));
        mfns_m3_mul_at(&cp, &out->pose.C_w_b, &cp);
        (void)mfns_m3_to_euler213_at(&cp, &ep);
        cp = mfns_rot_exp(mfns_v3(-dv[0], -dv[1], -dv[2]));
        mfns_m3_mul_at(&cp, &out->pose.C_w_b, &cp);
        (void)mfns_m3_to_euler213_at(&cp, &em);
        const float de[3] = {ep.roll - em.roll, ep.pitch - em.pitch, ep.yaw - em.yaw};
        for (int r = 0; r < 3; r++) {
            float v = de[r];
            /* angles wrap at +-pi */
            if (v > MFNS_PI_F) {
                v -= MFNS_TWO_PI_F;
            } else if (v < -MFNS_PI_F) {
                v += MFNS_TWO_PI_F;
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
            out->cov_ros[p][q] = quad_form(jr[p], out->cov, jr[q]);
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
        const float var = quad_form(jo[r], out->cov, jo[r]);
        const float sd = sqrtf(fmaxf(var, 0.0f));
        if (r < 3) {
            out->sigma_pos_mm[r] = sd;
        } else {
            out->sigma_euler_deg[r - 3] = sd * MFNS_DEG_PER_RAD_F;
        }
    }
    return MFNS_POSE_R_NONE;
}
