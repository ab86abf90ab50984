/* integrity.c -- the solution-separation test and protection level of
 * integrity.h (the evaluation of one fix), the settings and the Gaussian
 * quantile. Exclusion and its memory are integrity_fde.c. */
#include "firmware/nav/integrity/integrity.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "firmware/nav/pose/pose_internal.h"
#include "math/spd.h"
#include "math/units.h"

_Static_assert(MFNS_INTEGRITY_AXES == 6 && MFNS_SPD_MAX_N >= 6, "6 output axes, 6x6 information");
_Static_assert(MFNS_INTEGRITY_MAX_HYP >= MFNS_MAX_OBS_PER_CAMERA * MFNS_NUM_CAMERAS + 3,
               "a hypothesis per observed beacon and per camera");

bool mfns_integrity_settings_valid(const mfns_integrity_settings_t *s)
{
    return s != NULL && s->alert_limit_pos_mm > 0.0f && isfinite(s->alert_limit_pos_mm) &&
           s->alert_limit_att_deg > 0.0f && isfinite(s->alert_limit_att_deg) && s->p_fa > 0.0f &&
           s->p_fa < 0.5f && s->p_md > 0.0f && s->p_md < 0.5f && s->require_camera_monitor <= 1U &&
           s->monitor_only <= 1U;
}

/* AS 241 PPND7 (Wichura 1988), 7-digit accuracy, for the lower tail p <= 0.5:
 * returns z <= 0 with Phi(z) = p. */
static float ppnd7_lower(float p)
{
    const float q = p - 0.5f;
    if (fabsf(q) <= 0.425f) {
        const float r = 0.180625f - q * q;
        return q * (((59.10937472f * r + 159.29113202f) * r + 50.434271938f) * r + 3.3871327179f) /
               (((67.1875636f * r + 78.757757664f) * r + 17.895169469f) * r + 1.0f);
    }
    float r = sqrtf(-logf(p));
    float v;
    if (r <= 5.0f) {
        r -= 1.6f;
        v = (((0.17023821103f * r + 1.3067284816f) * r + 2.75681539f) * r + 1.4234372777f) /
            ((0.1202113297f * r + 0.7370016425f) * r + 1.0f);
    } else {
        r -= 5.0f;
        v = (((0.017337203997f * r + 0.42868294337f) * r + 3.081226386f) * r + 6.657905115f) /
            ((0.012258202635f * r + 0.24197894225f) * r + 1.0f);
    }
    return -v;
}

float mfns_integrity_pl_axis(float s, float var_k, float k_ff)
{
    return fabsf(s) + k_ff * sqrtf(fmaxf(var_k, 0.0f));
}

float mfns_integrity_pl_axis_apriori(float t, float var_k, float k_md)
{
    return t + k_md * sqrtf(fmaxf(var_k, 0.0f));
}

float mfns_integrity_q_inv(float p)
{
    if (!(p > 0.0f && p <= 0.5f)) {
        return NAN;
    }
    return -ppnd7_lower(p);
}

/* G: the output axes (r_wb_w mm, phi_w rad) per increment (dtheta, dt), as
 * pose_cov.c maps its covariance: d r_wb_w = -C^T [r]x dtheta - C^T dt,
 * phi_w = -C^T dtheta. */
static void output_map(const mfns_pose_t *pose, float g[6][6])
{
    mfns_m3_t ct, a;
    mfns_m3_transpose_at(&pose->C_w_b, &ct);
    a = mfns_m3_skew(pose->r_bw_b);
    mfns_m3_mul_at(&ct, &a, &a);
    mfns_m3_scale_at(&a, -1.0f, &a);
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 3; c++) {
            g[r][c] = a.m[r][c];
            g[r][c + 3] = -ct.m[r][c];
            g[r + 3][c] = -ct.m[r][c];
            g[r + 3][c + 3] = 0.0f;
        }
    }
}

/* diag(G M G^T) */
static void project_diag(const float g[6][6], const float m[6][6], float d[6])
{
    for (int r = 0; r < 6; r++) {
        float v = 0.0f;
        for (int i = 0; i < 6; i++) {
            float gi = 0.0f;
            for (int j = 0; j < 6; j++) {
                gi += m[i][j] * g[r][j];
            }
            v += g[r][i] * gi;
        }
        d[r] = v;
    }
}

/* y = G x */
static void map_vec(const float g[6][6], const float x[6], float y[6])
{
    for (int r = 0; r < 6; r++) {
        float v = 0.0f;
        for (int i = 0; i < 6; i++) {
            v += g[r][i] * x[i];
        }
        y[r] = v;
    }
}

/* The calibration term D Sigma_c D^T added to out (6x6), over the cameras
 * whose columns of D are not zero. */
static void add_calib(const float d[6][MFNS_CALIB_PARAMS], const mfns_calib_cov_t *calib, float out[6][6])
{
    bool used[MFNS_NUM_CAMERAS];
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        used[c] = false;
        for (int j = c * MFNS_CALIB_PARAMS_PER_CAMERA; j < (c + 1) * MFNS_CALIB_PARAMS_PER_CAMERA; j++) {
            for (int i = 0; i < 6; i++) {
                used[c] = used[c] || d[i][j] != 0.0f;
            }
        }
    }
    float t[6][MFNS_CALIB_PARAMS]; /* D Sigma_c */
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < MFNS_CALIB_PARAMS; j++) {
            float v = 0.0f;
            for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
                for (int q = c * MFNS_CALIB_PARAMS_PER_CAMERA; used[c] && q < (c + 1) * MFNS_CALIB_PARAMS_PER_CAMERA;
                     q++) {
                    v += d[i][q] * calib->cov[q][j];
                }
            }
            t[i][j] = v;
        }
    }
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            float v = 0.0f;
            for (int q = 0; q < MFNS_CALIB_PARAMS; q++) {
                v += t[i][q] * d[j][q];
            }
            out[i][j] += v;
        }
    }
}

/* A = P B (6 x 45) */
static void mul_pb(const float p[6][6], const float b[6][MFNS_CALIB_PARAMS], float a[6][MFNS_CALIB_PARAMS])
{
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < MFNS_CALIB_PARAMS; j++) {
            float v = 0.0f;
            for (int q = 0; q < 6; q++) {
                v += p[i][q] * b[q][j];
            }
            a[i][j] = v;
        }
    }
}

static bool in_hyp(const mfns_pose_meas_t *m, const mfns_integrity_hyp_t *h)
{
    return (h->kind == MFNS_INTEGRITY_HYP_BEACON && m->beacon == h->id) ||
           (h->kind == MFNS_INTEGRITY_HYP_CAMERA && (int)m->cam == h->id);
}

static bool same_hyp(const mfns_integrity_hyp_t *a, const mfns_integrity_hyp_t *b)
{
    return a->kind == b->kind && a->id == b->id;
}

/* The work of one evaluation (kept together so the stack use is visible). */
typedef struct {
    mfns_pose_meas_t m[MFNS_POSE_MAX_MEAS];
    uint8_t inlier[MFNS_POSE_MAX_MEAS];
    int n;
    float g[6][6];                        /* output map */
    float p0[6][6];                       /* P0 (pixel noise only) */
    float dx0[6];
    float a0[6][MFNS_CALIB_PARAMS];       /* A_0 = P0 B0 */
    bool calib;
} integ_work_t;

/* I = J^T J, B = J^T J_c and grad = J^T e over the inliers outside hyp
 * (hyp NULL: all). False when an inlier is behind its camera. */
static bool information(const mfns_rig_t *rig, integ_work_t *w, const mfns_pose_t *pose,
                        const mfns_integrity_hyp_t *hyp, float h[6][6], float b[6][MFNS_CALIB_PARAMS],
                        float grad[6])
{
    for (int k = 0; k < w->n; k++) {
        w->m[k].active = (uint8_t)(w->inlier[k] != 0U && (hyp == NULL || !in_hyp(&w->m[k], hyp)) ? 1U : 0U);
    }
    mfns_pose_info_matrix(rig, w->m, w->n, pose, h, w->calib ? b : NULL);
    for (int i = 0; i < 6; i++) {
        grad[i] = 0.0f;
    }
    for (int k = 0; k < w->n; k++) {
        float e[2], jac[2][6];
        if (!w->m[k].active) {
            continue;
        }
        if (!mfns_pose_wresidual(rig, &w->m[k], pose, e, jac)) {
            return false;
        }
        for (int i = 0; i < 6; i++) {
            grad[i] += jac[0][i] * e[0] + jac[1][i] * e[1];
        }
    }
    return true;
}

/* P = I^-1 and dx = -P grad; false when I is singular or below min_rcond. */
static bool solve(const float h[6][6], const float grad[6], float min_rcond, float p[6][6], float dx[6])
{
    float a[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N], inv[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N];
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            a[i][j] = h[i][j];
        }
    }
    mfns_chol_t f;
    if (mfns_chol_factor(a, 6, min_rcond, &f) != MFNS_SPD_OK) {
        return false;
    }
    mfns_chol_inverse(&f, inv);
    for (int i = 0; i < 6; i++) {
        float v = 0.0f;
        for (int j = 0; j < 6; j++) {
            p[i][j] = inv[i][j];
            v += inv[i][j] * grad[j];
        }
        dx[i] = -v;
    }
    return true;
}

/* Form the hypotheses: each distinct inlier beacon, then each camera with
 * an inlier. Returns the count. */
static int hypotheses(const integ_work_t *w, mfns_integrity_hyp_t hyp[MFNS_INTEGRITY_MAX_HYP])
{
    int nh = 0;
    bool cam[MFNS_NUM_CAMERAS] = {false};
    for (int k = 0; k < w->n; k++) {
        if (!w->inlier[k]) {
            continue;
        }
        cam[w->m[k].cam] = true;
        bool seen = false;
        for (int j = 0; j < k; j++) {
            seen = seen || (w->inlier[j] && w->m[j].beacon == w->m[k].beacon);
        }
        if (!seen && nh < MFNS_INTEGRITY_MAX_HYP) {
            hyp[nh].kind = MFNS_INTEGRITY_HYP_BEACON;
            hyp[nh].id = w->m[k].beacon;
            nh++;
        }
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (cam[c] && nh < MFNS_INTEGRITY_MAX_HYP) {
            hyp[nh].kind = MFNS_INTEGRITY_HYP_CAMERA;
            hyp[nh].id = (int16_t)c;
            nh++;
        }
    }
    return nh;
}

static void ev_clear(mfns_integrity_eval_t *ev)
{
    memset(ev, 0, sizeof *ev);
    ev->pl_pos_mm = INFINITY;
    ev->pl_att_deg = INFINITY;
    ev->pl_beacon_pos_mm = INFINITY;
    ev->pl_beacon_att_deg = INFINITY;
    ev->worst.id = -1;
    ev->unmonitored.id = -1;
}

/* The largest of the three axes of a protection level (position or attitude). */
static float max3(const float v[3])
{
    return fmaxf(v[0], fmaxf(v[1], v[2]));
}

/* The per-axis bounds of one hypothesis: the observed separation's into pl
 * (integrity.h mfns_integrity_pl_axis), and, when pl_apriori is not NULL,
 * the a-priori T + K_md sigma into it (the beacon-only PL that gates a
 * DEGRADED CAMERA_UNMONITORED fix, integrity.h); its normalised separation
 * returned. var_ss, var_k: the projected diagonals. */
static float test_axes(const float s[6], const float var_ss[6], const float var_k[6], const float off[6], float k_fa,
                       float k_md, float k_ff, float pl[6], float *pl_apriori)
{
    float worst = 0.0f;
    for (int j = 0; j < 6; j++) {
        /* P_k - P0 is PSD in exact arithmetic; rounding can leave a tiny
         * negative: a floor of 1e-6 of var_k keeps T from collapsing to 0 */
        const float vss = fmaxf(var_ss[j], 1e-6f * fmaxf(var_k[j], 0.0f));
        const float t = k_fa * sqrtf(vss);
        const float ns = t > 0.0f ? fabsf(s[j]) / t : (s[j] == 0.0f ? 0.0f : INFINITY);
        worst = fmaxf(worst, ns);
        pl[j] = fmaxf(pl[j], mfns_integrity_pl_axis(s[j], var_k[j], k_ff) + off[j]);
        if (pl_apriori != NULL) {
            pl_apriori[j] = fmaxf(pl_apriori[j], mfns_integrity_pl_axis_apriori(t, var_k[j], k_md) + off[j]);
        }
    }
    return worst;
}

mfns_integrity_status_t mfns_integrity_evaluate(const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                                const mfns_obs_frame_t *frame, const mfns_pose_solution_t *sol,
                                                const mfns_pose_config_t *cfg,
                                                const mfns_integrity_settings_t *set,
                                                const mfns_integrity_hyp_t *probe, mfns_integrity_eval_t *ev)
{
    if (ev == NULL) {
        return MFNS_INTEGRITY_E_ARG;
    }
    ev_clear(ev);
    if (rig == NULL || map == NULL || frame == NULL || sol == NULL || cfg == NULL ||
        !mfns_integrity_settings_valid(set) ||
        (sol->status != MFNS_POSE_OK && sol->status != MFNS_POSE_DEGRADED)) {
        return MFNS_INTEGRITY_E_ARG;
    }
    integ_work_t w;
    w.n = mfns_pose_gather(map, frame, &sol->assoc, w.m);
    if (w.n < 0) {
        return MFNS_INTEGRITY_E_ARG;
    }
    for (int k = 0; k < w.n; k++) {
        w.inlier[k] = sol->inlier[w.m[k].cam][w.m[k].idx];
        w.m[k].active = w.inlier[k];
    }
    /* the solver's weights at the fix (the covariance's) */
    mfns_pose_weigh(rig, w.m, w.n, &sol->pose, cfg);
    w.calib = cfg->calib_cov != NULL && cfg->calib_cov->present != 0U;
    output_map(&sol->pose, w.g);

    float h[6][6], b[6][MFNS_CALIB_PARAMS], grad[6];
    if (!information(rig, &w, &sol->pose, NULL, h, b, grad) || !solve(h, grad, cfg->s.min_rcond, w.p0, w.dx0)) {
        return MFNS_INTEGRITY_E_GEOM;
    }
    float p0f[6][6];
    memcpy(p0f, w.p0, sizeof p0f);
    if (w.calib) {
        mul_pb(w.p0, b, w.a0);
        add_calib(w.a0, cfg->calib_cov, p0f);
    }
    /* The map datum moves the fix and every subset solution alike: it widens
     * the fault-free and the subset covariances, never a separation's. */
    float datum[6][6];
    memset(datum, 0, sizeof datum); /* all-zero bytes are 0.0f */
    mfns_pose_add_datum_term(&sol->pose, cfg->datum, datum);
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            p0f[i][j] += datum[i][j];
        }
    }

    mfns_integrity_hyp_t hyp[MFNS_INTEGRITY_MAX_HYP];
    const int nh = hypotheses(&w, hyp);
    ev->hypotheses = (uint16_t)nh;
    ev->k_fa = mfns_integrity_q_inv(set->p_fa / (2.0f * (float)MFNS_INTEGRITY_AXES * (float)(nh > 0 ? nh : 1)));
    ev->k_md = mfns_integrity_q_inv(set->p_md);
    const float k_ff = mfns_integrity_q_inv(0.5f * set->p_md);

    /* The robust (Huber) fix x0 differs from the least-squares one the
     * separations refer to by dx_0 (0 when no residual is beyond huber_k):
     * its size on each axis is added to every bound. */
    float pl[6], var0[6], off[6];
    project_diag(w.g, p0f, var0);
    map_vec(w.g, w.dx0, off);
    for (int j = 0; j < 6; j++) {
        off[j] = fabsf(off[j]);
        pl[j] = k_ff * sqrtf(fmaxf(var0[j], 0.0f)) + off[j];
    }
    float pl_b[6]; /* fault-free and beacon hypotheses only, a-priori (integrity.h) */
    for (int j = 0; j < 6; j++) {
        pl_b[j] = pl[j];
    }
    float worst = 0.0f;
    for (int q = 0; q < nh; q++) {
        const bool is_cam = hyp[q].kind == MFNS_INTEGRITY_HYP_CAMERA;
        float pk[6][6], dxk[6];
        if (!information(rig, &w, &sol->pose, &hyp[q], h, b, grad) ||
            !solve(h, grad, cfg->s.min_rcond, pk, dxk)) {
            if (ev->unmonitorable == 0U) {
                ev->unmonitored = hyp[q];
            }
            ev->unmonitorable++;
            ev->unmonitorable_cameras = (uint16_t)(ev->unmonitorable_cameras + (is_cam ? 1U : 0U));
            continue;
        }
        float pss[6][6], pkf[6][6];
        for (int i = 0; i < 6; i++) {
            for (int j = 0; j < 6; j++) {
                pss[i][j] = pk[i][j] - w.p0[i][j];
                pkf[i][j] = pk[i][j];
            }
        }
        if (w.calib) {
            float ak[6][MFNS_CALIB_PARAMS], dk[6][MFNS_CALIB_PARAMS];
            mul_pb(pk, b, ak);
            for (int i = 0; i < 6; i++) {
                for (int j = 0; j < MFNS_CALIB_PARAMS; j++) {
                    dk[i][j] = ak[i][j] - w.a0[i][j];
                }
            }
            add_calib(dk, cfg->calib_cov, pss);
            add_calib(ak, cfg->calib_cov, pkf);
        }
        for (int i = 0; i < 6; i++) {
            for (int j = 0; j < 6; j++) {
                pkf[i][j] += datum[i][j];
            }
        }
        float ddx[6], s[6];
        for (int i = 0; i < 6; i++) {
            ddx[i] = dxk[i] - w.dx0[i];
        }
        map_vec(w.g, ddx, s);
        float var_ss[6], var_k[6];
        project_diag(w.g, pss, var_ss);
        project_diag(w.g, pkf, var_k);
        const float ns = test_axes(s, var_ss, var_k, off, ev->k_fa, ev->k_md, k_ff, pl, is_cam ? NULL : pl_b);
        if (probe != NULL && same_hyp(probe, &hyp[q])) {
            ev->probe_norm_sep = ns;
        }
        if (ns > worst || ev->worst.kind == MFNS_INTEGRITY_HYP_NONE) {
            worst = ns;
            ev->worst = hyp[q];
        }
    }
    ev->max_norm_sep = worst;
    ev->tests_passed = worst <= 1.0f;
    ev->pl_pos_mm = max3(&pl[0]);
    ev->pl_att_deg = max3(&pl[3]) * MFNS_DEG_PER_RAD_F;
    ev->pl_beacon_pos_mm = max3(&pl_b[0]);
    ev->pl_beacon_att_deg = max3(&pl_b[3]) * MFNS_DEG_PER_RAD_F;
    if (ev->unmonitorable_cameras > 0U) {
        ev->pl_pos_mm = INFINITY; /* no bound on a camera fault */
        ev->pl_att_deg = INFINITY;
    }
    return MFNS_INTEGRITY_OK;
}
