/* nav_filter.c -- the navigation filter of nav_filter.h: constant-velocity
 * propagation with an overbounding white-acceleration process noise and the
 * sequential update from beacon image positions. */
#include "firmware/nav/filter/nav_filter.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "math/core_text.h"
#include "firmware/nav/integrity/integrity.h"
#include "firmware/nav/pose/pose.h"
#include "firmware/nav/pose/pose_internal.h"
#include "math/rotation.h"
#include "math/spd.h"

#define N MFNS_FILTER_N
#define US_PER_S 1e6f
/* a rotation whose orthonormality drifted beyond this is refused (init) */
#define ROT_TOL 1e-3f
#define ORTHO_TOL 1e-6f

_Static_assert(MFNS_FILTER_BASE_N == 12, "pose 6 + velocity 6");
_Static_assert(MFNS_FILTER_N == MFNS_FILTER_BASE_N, "the body's states only: no camera fault parameters");
_Static_assert(MFNS_FILTER_AUG_ROT == MFNS_FILTER_N && MFNS_FILTER_AUG_DT == MFNS_FILTER_AUG_ROT + 3 &&
                   MFNS_FILTER_AUG_DT < MFNS_FILTER_JAC_N,
               "the fault parameters' Jacobian columns after the body's: pointing 3, timing 1");
_Static_assert(MFNS_FILTER_MAX_AUG <= MFNS_SPD_MAX_N, "the fault parameters' normal equations fit spd.h");
_Static_assert(MFNS_FILTER_INV_MAX_OBS <= MFNS_MAX_OBS_PER_CAMERA, "a frame's observations");
_Static_assert(MFNS_NUM_CAMERAS < MFNS_FILTER_NO_AUG, "camera index fits aug_cam");
_Static_assert(MFNS_FILTER_POS + 3 == MFNS_FILTER_VEL && MFNS_FILTER_ATT + 3 == MFNS_FILTER_POS,
               "pose block first, attitude then position");

/* mfns_filter_settings_default: nav_defaults_gen.c (the table's definition). */

static bool pos_finite(float x)
{
    return isfinite(x) && x > 0.0f;
}

bool mfns_filter_settings_valid(const mfns_filter_settings_t *s)
{
    return s != NULL && pos_finite(s->accel_bound_mm_s2) && pos_finite(s->alpha_bound_rad_s2) &&
           pos_finite(s->bound_time_s) && pos_finite(s->max_coast_s) && s->max_coast_s <= s->bound_time_s &&
           s->gate_p > 0.0f && s->gate_p < 0.5f && s->gate_reject_run > 0U && pos_finite(s->aug_rot_rad) &&
           pos_finite(s->aug_dt_s);
}

float mfns_filter_gate_nis(const mfns_filter_settings_t *s)
{
    return -2.0f * logf(s->gate_p);
}

const char *mfns_filter_strerror(mfns_filter_status_t s)
{
    switch (s) {
    case MFNS_FILTER_OK:
        return MFNS_MSG("ok");
    case MFNS_FILTER_GATED:
        return MFNS_MSG("observation inconsistent with the motion-bounded prediction: not applied");
    case MFNS_FILTER_E_ARG:
        return MFNS_MSG("bad argument: null, not initialised, bad settings or non-finite input");
    case MFNS_FILTER_E_TIME:
        return MFNS_MSG("time before the filter's state, or a coast longer than max_coast_s");
    case MFNS_FILTER_E_GEOM:
        return MFNS_MSG("beacon behind the camera or innovation covariance not positive definite");
    }
    return MFNS_MSG("unknown filter status");
}

static bool v3_finite(mfns_v3_t a)
{
    return isfinite(a.x) && isfinite(a.y) && isfinite(a.z);
}

static void symmetrise(mfns_filter_t *f)
{
    for (int i = 0; i < N; i++) {
        if (!(f->P[i][i] >= 0.0f)) {
            f->P[i][i] = 0.0f;
            f->clamp_events++;
        }
        for (int j = i + 1; j < N; j++) {
            const float m = 0.5f * (f->P[i][j] + f->P[j][i]);
            f->P[i][j] = m;
            f->P[j][i] = m;
        }
    }
}

mfns_filter_status_t mfns_filter_init(mfns_filter_t *f, const mfns_pose_t *pose, const float cov_ros[6][6],
                                      mfns_v3_t v_w, float sigma_v_mm_s, mfns_v3_t w_w, float sigma_w_rad_s,
                                      int64_t t_us)
{
    if (f == NULL) {
        return MFNS_FILTER_E_ARG;
    }
    memset(f, 0, sizeof(*f));
    if (pose == NULL || cov_ros == NULL || !mfns_m3_is_rotation_at(&pose->C_w_b, ROT_TOL) ||
        !v3_finite(pose->r_bw_b) || !v3_finite(v_w) || !v3_finite(w_w) || !pos_finite(sigma_v_mm_s) ||
        !pos_finite(sigma_w_rad_s)) {
        return MFNS_FILTER_E_ARG;
    }
    /* cov_ros (position 0-2, attitude 3-5) -> the filter's (attitude 0-2, position 3-5) */
    static const int from_ros[6] = {3, 4, 5, 0, 1, 2};
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            const float c = cov_ros[from_ros[i]][from_ros[j]];
            if (!isfinite(c)) {
                return MFNS_FILTER_E_ARG;
            }
            f->P[i][j] = c;
        }
    }
    for (int i = 0; i < 3; i++) {
        f->P[MFNS_FILTER_VEL + i][MFNS_FILTER_VEL + i] = sigma_v_mm_s * sigma_v_mm_s;
        f->P[MFNS_FILTER_OMEGA + i][MFNS_FILTER_OMEGA + i] = sigma_w_rad_s * sigma_w_rad_s;
    }
    if (!mfns_m3_reorthonormalize_at(&pose->C_w_b, MFNS_FILTER_ORTHO_ITERS, ORTHO_TOL, &f->C_w_b)) {
        return MFNS_FILTER_E_ARG;
    }
    f->r_wb_w = mfns_pose_position_w(pose);
    f->v_w = v_w;
    f->w_w = w_w;
    f->t_us = t_us;
    f->t_meas_us = t_us;
    f->aug_cam = MFNS_FILTER_NO_AUG;
    symmetrise(f);
    f->initialised = 1;
    return MFNS_FILTER_OK;
}

/* The partner of error-state row i under F = I + dt E: attitude <- angular
 * rate, position <- velocity; -1 for the velocity rows. */
static int partner(int i)
{
    if (i < MFNS_FILTER_POS) {
        return i + MFNS_FILTER_OMEGA;
    }
    if (i < MFNS_FILTER_VEL) {
        return i - MFNS_FILTER_POS + MFNS_FILTER_VEL;
    }
    return -1;
}

/* Nominal state and covariance moved on by dt (s). */
static void propagate_dt(mfns_filter_t *f, const mfns_filter_settings_t *s, float dt)
{
    if (dt <= 0.0f) {
        return;
    }
    /* nominal: r += v dt; C_b_w <- exp(w dt) C_b_w, i.e. C_w_b <- C_w_b exp(w dt)^T */
    f->r_wb_w = mfns_v3_add(f->r_wb_w, mfns_v3_scale(f->v_w, dt));
    const mfns_m3_t e = mfns_rot_exp(mfns_v3_scale(f->w_w, dt));
    mfns_m3_t et, c;
    mfns_m3_transpose_at(&e, &et);
    mfns_m3_mul_at(&f->C_w_b, &et, &c);
    if (!mfns_m3_reorthonormalize_at(&c, MFNS_FILTER_ORTHO_ITERS, ORTHO_TOL, &f->C_w_b)) {
        f->C_w_b = c; /* a product of rotations: cannot fail on finite input */
    }
    /* P <- F P F^T: rows, then columns */
    for (int i = 0; i < MFNS_FILTER_VEL; i++) {
        const int p = partner(i);
        for (int j = 0; j < N; j++) {
            f->P[i][j] += dt * f->P[p][j];
        }
    }
    for (int j = 0; j < MFNS_FILTER_VEL; j++) {
        const int p = partner(j);
        for (int i = 0; i < N; i++) {
            f->P[i][j] += dt * f->P[i][p];
        }
    }
    /* + Q: q [[dt^3/3, dt^2/2], [dt^2/2, dt]] per axis */
    const float q_lin = s->accel_bound_mm_s2 * s->accel_bound_mm_s2 * s->bound_time_s;
    const float q_ang = s->alpha_bound_rad_s2 * s->alpha_bound_rad_s2 * s->bound_time_s;
    const float d2 = dt * dt, d3 = d2 * dt;
    for (int i = 0; i < MFNS_FILTER_VEL; i++) {
        const int p = partner(i);
        const float q = i < MFNS_FILTER_POS ? q_ang : q_lin;
        f->P[i][i] += q * d3 / 3.0f;
        f->P[i][p] += q * d2 / 2.0f;
        f->P[p][i] += q * d2 / 2.0f;
        f->P[p][p] += q * dt;
    }
    symmetrise(f);
}

static mfns_filter_status_t step_dt(const mfns_filter_t *f, const mfns_filter_settings_t *s, int64_t t_us,
                                    float *dt)
{
    if (t_us < f->t_us) {
        return MFNS_FILTER_E_TIME;
    }
    const int64_t d = t_us - f->t_us;
    if ((float)(t_us - f->t_meas_us) > s->max_coast_s * US_PER_S) {
        return MFNS_FILTER_E_TIME; /* coasted too long since the last measurement */
    }
    *dt = (float)d / US_PER_S;
    return MFNS_FILTER_OK;
}

mfns_filter_status_t mfns_filter_propagate(mfns_filter_t *f, const mfns_filter_settings_t *s, int64_t t_us)
{
    if (f == NULL || f->initialised == 0U || !mfns_filter_settings_valid(s)) {
        return MFNS_FILTER_E_ARG;
    }
    float dt = 0.0f;
    const mfns_filter_status_t st = step_dt(f, s, t_us, &dt);
    if (st != MFNS_FILTER_OK) {
        return st;
    }
    propagate_dt(f, s, dt);
    f->t_us = t_us;
    return MFNS_FILTER_OK;
}

mfns_pose_t mfns_filter_pose(const mfns_filter_t *f)
{
    return mfns_pose_from_position_at(&f->C_w_b, f->r_wb_w);
}

bool mfns_filter_obs_jacobian(const mfns_camera_t *cam, const mfns_pose_t *pose, mfns_v3_t p_w, float uv[2],
                              float h[2][6])
{
    float ji[2][6];
    if (mfns_cam_project(cam, pose, p_w, uv, ji) != MFNS_PROJ_OK) {
        return false;
    }
    /* d inc / d phi = [-C ; [r_bw_b]x C], d inc / d dr = [0 ; -C] (C = C_w_b) */
    const mfns_m3_t *c = &pose->C_w_b;
    const mfns_m3_t sr = mfns_m3_skew(pose->r_bw_b);
    mfns_m3_t src;
    mfns_m3_mul_at(&sr, c, &src);
    for (int a = 0; a < 2; a++) {
        for (int j = 0; j < 3; j++) {
            float hp = 0.0f, hr = 0.0f;
            for (int q = 0; q < 3; q++) {
                hp += -ji[a][q] * c->m[q][j] + ji[a][3 + q] * src.m[q][j];
                hr += -ji[a][3 + q] * c->m[q][j];
            }
            h[a][j] = hp;
            h[a][3 + j] = hr;
        }
    }
    return true;
}

static bool obs_valid(const mfns_filter_obs_t *o)
{
    const float *c = o->cov_px2;
    return o->cam < MFNS_NUM_CAMERAS && isfinite(o->u) && isfinite(o->v) && v3_finite(o->p_w) &&
           isfinite(o->sigma_mm) && o->sigma_mm >= 0.0f && isfinite(c[0]) && isfinite(c[1]) && isfinite(c[2]) &&
           c[0] >= 0.0f && c[2] >= 0.0f && c[1] * c[1] <= c[0] * c[2];
}

/* The columns of an observation's Jacobian on the states that can be
 * non-zero: the pose (attitude, position). Velocity and rate enter only
 * through the propagation. */
#define NH 6
_Static_assert(NH <= N, "the pose columns are states");
_Static_assert(MFNS_FILTER_INV_COLS == 1 + NH, "residual + the pose block");

/* One observation as the state f predicts it: the residual y = z - h(x),
 * its Jacobian and its noise. */
typedef struct {
    float y[2];
    float h[2][MFNS_FILTER_JAC_N]; /* the observation's Jacobian (Joseph update; fault columns last) */
    float r[3];                    /* its noise R: [0] 00, [1] 01, [2] 11 */
} obs_model_t;

/* The innovation: the model above, its covariance S and P H^T at f. */
typedef struct {
    obs_model_t m;
    float s[3]; /* S: [0] 00, [1] 01, [2] 11 */
    float pht[N][2];
    float nis;
} innov_t;

/* camera obs->cam as f predicts it: its mount through the pointing bias
 * when it is f's augmented camera */
static mfns_camera_t cam_of(const mfns_filter_t *f, const mfns_rig_t *rig, int cam)
{
    mfns_camera_t c = rig->cam[cam];
    if (f->aug_cam == (uint8_t)cam) {
        const mfns_m3_t e = mfns_rot_exp(f->aug_rot);
        mfns_m3_mul_at(&e, &rig->cam[cam].C_k_b, &c.C_k_b);
    }
    return c;
}

bool mfns_filter_obs_jacobian_full(const mfns_filter_t *f, const mfns_rig_t *rig, const mfns_filter_obs_t *o,
                                   float uv[2], float h[2][MFNS_FILTER_JAC_N])
{
    const mfns_camera_t cam = cam_of(f, rig, o->cam);
    const mfns_pose_t pose = mfns_filter_pose(f);
    float hp[2][6];
    if (!mfns_filter_obs_jacobian(&cam, &pose, o->p_w, uv, hp)) {
        return false;
    }
    memset(h, 0, sizeof(float[2][MFNS_FILTER_JAC_N]));
    for (int a = 0; a < 2; a++) {
        for (int q = 0; q < 6; q++) {
            h[a][q] = hp[a][q];
        }
    }
    if (f->aug_cam != o->cam) {
        return true;
    }
    /* pointing: d p_k / d b = C'^T [d]x, d = p_b - r_bk_b */
    const mfns_v3_t p_b = mfns_v3_add(mfns_m3_mul_v3_at(&pose.C_w_b, o->p_w), pose.r_bw_b);
    const mfns_v3_t d = mfns_v3_sub(p_b, cam.r_bk_b);
    const mfns_v3_t p_k = mfns_m3_tmul_v3_at(&cam.C_k_b, d);
    float uv2[2], jc[2][3];
    if (mfns_cam_project_c(&cam.k, p_k, uv2, jc) != MFNS_PROJ_OK) {
        return false;
    }
    const mfns_m3_t sd = mfns_m3_skew(d);
    mfns_m3_t ct, a3;
    mfns_m3_transpose_at(&cam.C_k_b, &ct);
    mfns_m3_mul_at(&ct, &sd, &a3);
    /* The velocity the offset's column is taken at: the prediction at the
     * frame's first observation, held for the frame. Each observation is an
     * update of its own, and the state's velocity moves with them (position
     * and velocity are correlated after a coast); re-linearised at the
     * updated velocity, a late frame's first beacons took the velocity down
     * (a lag read as a deceleration: 80 -> 26 mm/s in the hypothesis filter,
     * test_filter_bank's dominant camera late after a dropped frame) and the
     * shrunken column left the offset at 0.5 ms of the true 54 ms, the
     * camera's hypothesis filter as far off as the full one (3.4 x its PL).
     * Held, the frame is linearised once, as a batch would be. */
    const float w[3] = {f->aug_w_w.x, f->aug_w_w.y, f->aug_w_w.z};
    const float v[3] = {f->aug_v_w.x, f->aug_v_w.y, f->aug_v_w.z};
    for (int a = 0; a < 2; a++) {
        for (int j = 0; j < 3; j++) {
            float x = 0.0f;
            for (int q = 0; q < 3; q++) {
                x += jc[a][q] * a3.m[q][j];
            }
            h[a][MFNS_FILTER_AUG_ROT + j] = x;
        }
        /* timing: the image velocity of the beacon. The offset's lever on the
         * velocity states (-tau H) is left out on purpose: tau is nearly
         * free at every frame (restarted), and a linearisation at a
         * poorly known tau would feed the velocity information that the
         * frame does not hold (measured: P_k below P_0 on yaw) */
        float zdot = 0.0f;
        for (int j = 0; j < 3; j++) {
            zdot += hp[a][j] * w[j] + hp[a][3 + j] * v[j];
        }
        h[a][MFNS_FILTER_AUG_DT] = -zdot;
        uv[a] -= f->aug_dt_s * zdot;
    }
    return true;
}

mfns_filter_status_t mfns_filter_augment(mfns_filter_t *f, int cam)
{
    if (f == NULL || f->initialised == 0U || cam < 0 || cam >= MFNS_NUM_CAMERAS) {
        return MFNS_FILTER_E_ARG;
    }
    mfns_filter_strip_aug(f);
    f->aug_cam = (uint8_t)cam;
    return MFNS_FILTER_OK;
}

void mfns_filter_strip_aug(mfns_filter_t *f)
{
    if (f == NULL) {
        return;
    }
    f->aug_cam = MFNS_FILTER_NO_AUG;
    f->aug_rot = mfns_v3(0.0f, 0.0f, 0.0f);
    f->aug_dt_s = 0.0f;
}

static mfns_filter_status_t observe_model(const mfns_filter_t *f, const mfns_rig_t *rig, float sigma_px,
                                          const mfns_filter_obs_t *o, obs_model_t *om)
{
    const mfns_camera_t cam = cam_of(f, rig, o->cam);
    const mfns_pose_t pose = mfns_filter_pose(f);
    float uv[2];
    if (!mfns_filter_obs_jacobian_full(f, rig, o, uv, om->h)) {
        return MFNS_FILTER_E_GEOM;
    }
    if (!mfns_pose_obs_cov(&cam, &pose, o->p_w, o->cov_px2, o->sigma_mm, sigma_px, om->r)) {
        /* pose.c's fallback: the floor alone */
        om->r[0] = sigma_px * sigma_px;
        om->r[1] = 0.0f;
        om->r[2] = om->r[0];
    }
    om->y[0] = o->u - uv[0];
    om->y[1] = o->v - uv[1];
    return MFNS_FILTER_OK;
}

static mfns_filter_status_t innovation(const mfns_filter_t *f, const mfns_rig_t *rig, float sigma_px,
                                       const mfns_filter_obs_t *o, innov_t *in)
{
    const mfns_filter_status_t st = observe_model(f, rig, sigma_px, o, &in->m);
    if (st != MFNS_FILTER_OK) {
        return st;
    }
    const obs_model_t *om = &in->m;
    for (int i = 0; i < N; i++) {
        for (int a = 0; a < 2; a++) {
            float v = 0.0f;
            for (int q = 0; q < NH; q++) {
                v += f->P[i][q] * om->h[a][q];
            }
            in->pht[i][a] = v;
        }
    }
    float hph[2][2];
    for (int a = 0; a < 2; a++) {
        for (int b = 0; b < 2; b++) {
            float v = 0.0f;
            for (int q = 0; q < NH; q++) {
                v += om->h[a][q] * in->pht[q][b];
            }
            hph[a][b] = v;
        }
    }
    in->s[0] = hph[0][0] + om->r[0];
    in->s[1] = 0.5f * (hph[0][1] + hph[1][0]) + om->r[1];
    in->s[2] = hph[1][1] + om->r[2];
    const float det = in->s[0] * in->s[2] - in->s[1] * in->s[1];
    if (!(in->s[0] > 0.0f && det > 0.0f) || !isfinite(det)) {
        return MFNS_FILTER_E_GEOM;
    }
    in->nis = (in->s[2] * om->y[0] * om->y[0] - 2.0f * in->s[1] * om->y[0] * om->y[1] +
               in->s[0] * om->y[1] * om->y[1]) /
              det;
    return MFNS_FILTER_OK;
}

mfns_filter_status_t mfns_filter_test(const mfns_filter_t *f, const mfns_filter_settings_t *s,
                                      const mfns_rig_t *rig, float sigma_px, const mfns_filter_obs_t *obs,
                                      float *nis)
{
    if (f == NULL || f->initialised == 0U || rig == NULL || obs == NULL || nis == NULL ||
        !mfns_filter_settings_valid(s) || !obs_valid(obs) || !pos_finite(sigma_px)) {
        return MFNS_FILTER_E_ARG;
    }
    float dt = 0.0f;
    mfns_filter_status_t st = step_dt(f, s, obs->t_us, &dt);
    if (st != MFNS_FILTER_OK) {
        return st;
    }
    mfns_filter_t g = *f; /* ~1.2 KB on the stack: the state itself is untouched */
    propagate_dt(&g, s, dt);
    innov_t in;
    st = innovation(&g, rig, sigma_px, obs, &in);
    if (st == MFNS_FILTER_OK) {
        *nis = in.nis;
    }
    return st;
}

/* x (+) dx: rotation on the manifold, the rest added. */
static void inject(mfns_filter_t *f, const float dx[N])
{
    const mfns_m3_t e = mfns_rot_exp(mfns_v3(dx[0], dx[1], dx[2]));
    mfns_m3_t et, c;
    mfns_m3_transpose_at(&e, &et);
    mfns_m3_mul_at(&f->C_w_b, &et, &c); /* C_b_w <- exp(phi) C_b_w */
    if (!mfns_m3_reorthonormalize_at(&c, MFNS_FILTER_ORTHO_ITERS, ORTHO_TOL, &f->C_w_b)) {
        f->C_w_b = c;
    }
    f->r_wb_w = mfns_v3_add(f->r_wb_w, mfns_v3(dx[3], dx[4], dx[5]));
    f->v_w = mfns_v3_add(f->v_w, mfns_v3(dx[6], dx[7], dx[8]));
    f->w_w = mfns_v3_add(f->w_w, mfns_v3(dx[9], dx[10], dx[11]));
}

static mfns_filter_status_t update(mfns_filter_t *f, const mfns_filter_settings_t *s, const mfns_rig_t *rig,
                                   float sigma_px, const mfns_filter_obs_t *obs, bool gate,
                                   mfns_filter_update_info_t *info);

mfns_filter_status_t mfns_filter_update(mfns_filter_t *f, const mfns_filter_settings_t *s, const mfns_rig_t *rig,
                                        float sigma_px, const mfns_filter_obs_t *obs,
                                        mfns_filter_update_info_t *info)
{
    return update(f, s, rig, sigma_px, obs, true, info);
}

mfns_filter_status_t mfns_filter_update_ungated(mfns_filter_t *f, const mfns_filter_settings_t *s,
                                                const mfns_rig_t *rig, float sigma_px, const mfns_filter_obs_t *obs,
                                                mfns_filter_update_info_t *info)
{
    return update(f, s, rig, sigma_px, obs, false, info);
}

static mfns_filter_status_t update(mfns_filter_t *f, const mfns_filter_settings_t *s, const mfns_rig_t *rig,
                                   float sigma_px, const mfns_filter_obs_t *obs, bool gate,
                                   mfns_filter_update_info_t *info)
{
    if (f == NULL || f->initialised == 0U || rig == NULL || obs == NULL || !mfns_filter_settings_valid(s) ||
        !obs_valid(obs) || !pos_finite(sigma_px)) {
        return MFNS_FILTER_E_ARG;
    }
    mfns_filter_status_t st = mfns_filter_propagate(f, s, obs->t_us);
    if (st != MFNS_FILTER_OK) {
        return st;
    }
    innov_t in;
    st = innovation(f, rig, sigma_px, obs, &in);
    if (st != MFNS_FILTER_OK) {
        return st;
    }
    if (info != NULL) {
        info->nis = in.nis;
        info->innov_px[0] = in.m.y[0];
        info->innov_px[1] = in.m.y[1];
    }
    if (gate && !(in.nis <= mfns_filter_gate_nis(s))) {
        f->cyc_nis += mfns_filter_gate_nis(s);
        f->cyc_dof = (uint16_t)(f->cyc_dof < UINT16_MAX - 2U ? f->cyc_dof + 2U : f->cyc_dof);
        f->gated++;
        if (f->reject_run < UINT16_MAX) {
            f->reject_run++;
        }
        f->reject_cams = (uint8_t)(f->reject_cams | (1U << obs->cam));
        /* two or more cameras in the run: one camera's fault (a knocked mount,
         * a late frame) fails only its own observations */
        if (f->reject_run >= s->gate_reject_run && (f->reject_cams & (f->reject_cams - 1U)) != 0U) {
            f->motion_exceeded = 1;
        }
        return MFNS_FILTER_GATED;
    }
    f->reject_run = 0;
    f->reject_cams = 0;
    f->cyc_nis += in.nis;
    f->cyc_dof = (uint16_t)(f->cyc_dof < UINT16_MAX - 2U ? f->cyc_dof + 2U : f->cyc_dof);
    /* K = P H^T S^-1; dx = K y; P -= K (P H^T)^T */
    const float det = in.s[0] * in.s[2] - in.s[1] * in.s[1];
    const float si[3] = {in.s[2] / det, -in.s[1] / det, in.s[0] / det};
    float k[N][2], dx[N];
    for (int i = 0; i < N; i++) {
        k[i][0] = in.pht[i][0] * si[0] + in.pht[i][1] * si[1];
        k[i][1] = in.pht[i][0] * si[1] + in.pht[i][1] * si[2];
        dx[i] = k[i][0] * in.m.y[0] + k[i][1] * in.m.y[1];
    }
    /* Joseph form, P <- (I - K H) P (I - K H)^T + K R K^T, in its rank-2
     * shape: A = P - K (P H^T)^T, then P <- A - (A H^T) K^T + K R K^T.
     * The short form P - K S K^T lost positive definiteness in float when
     * a camera's fault parameters were states with a 1 deg prior cut to
     * 1e-4 deg in one observation (H P H^T of a later observation came out
     * -0.02 px^2); kept for its margin on a diffuse start. */
    float aht[N][2];
    for (int i = 0; i < N; i++) {
        for (int j = 0; j < N; j++) {
            f->P[i][j] -= k[i][0] * in.pht[j][0] + k[i][1] * in.pht[j][1];
        }
    }
    for (int i = 0; i < N; i++) {
        for (int a = 0; a < 2; a++) {
            float v = 0.0f;
            for (int q = 0; q < NH; q++) {
                v += f->P[i][q] * in.m.h[a][q];
            }
            aht[i][a] = v;
        }
    }
    for (int i = 0; i < N; i++) {
        const float kr0 = k[i][0] * in.m.r[0] + k[i][1] * in.m.r[1];
        const float kr1 = k[i][0] * in.m.r[1] + k[i][1] * in.m.r[2];
        for (int j = 0; j < N; j++) {
            f->P[i][j] += -aht[i][0] * k[j][0] - aht[i][1] * k[j][1] + kr0 * k[j][0] + kr1 * k[j][1];
        }
    }
    symmetrise(f);
    inject(f, dx);
    f->t_meas_us = obs->t_us;
    f->updates++;
    return MFNS_FILTER_OK;
}

/* ---- camera k's frame with its fault parameters eliminated -------------- */

/* One frame's whitened rows at the linearisation point f (its aug_rot,
 * aug_dt_s): per observation R_i = L L^T, each row divided through L, so
 * the rows have unit, independent noise. a[r][0] the residual z - h(x),
 * a[r][1 + q] the pose Jacobian (q < 6), fr[r] the fault parameters'
 * (pointing 3, timing 1). No velocity columns: a frame tau late shows the
 * pose of t - tau, whose velocity term -tau (H_r v + H_phi w) is the
 * eliminated timing column at the predicted velocity; the rest, tau times
 * the velocity's error, is left out (0.015 sigma at 54 ms of offset on a
 * turning robot, noise-free, measured). Put in at the fitted tau it made matters worse:
 * on a slow robot tau is barely determined and its fitted value, noise,
 * scaled columns that invented velocity information (false camera
 * exclusions in test_filter_bank's clean runs). False on a beacon behind the camera or a singular R. */
static bool inv_rows(const mfns_filter_t *f, const mfns_rig_t *rig, float sigma_px, int m,
                     const mfns_filter_obs_t obs[], float a[][MFNS_FILTER_INV_COLS],
                     float fr[][MFNS_FILTER_MAX_AUG])
{
    for (int i = 0; i < m; i++) {
        obs_model_t in; /* the model alone: the projection needs no P */
        if (observe_model(f, rig, sigma_px, &obs[i], &in) != MFNS_FILTER_OK) {
            return false;
        }
        const float l00 = sqrtf(in.r[0]);
        const float l10 = in.r[1] / l00;
        const float l11sq = in.r[2] - l10 * l10;
        if (!(l00 > 0.0f) || !(l11sq > 0.0f)) {
            return false;
        }
        const float l11 = sqrtf(l11sq);
        float *r0 = a[2 * i], *r1 = a[2 * i + 1];
        float *g0 = fr[2 * i], *g1 = fr[2 * i + 1];
        for (int q = 0; q < MFNS_FILTER_INV_COLS; q++) {
            const float v0 = q == 0 ? in.y[0] : in.h[0][q - 1];
            const float v1 = q == 0 ? in.y[1] : in.h[1][q - 1];
            r0[q] = v0 / l00;
            r1[q] = (v1 - l10 * r0[q]) / l11;
        }
        for (int q = 0; q < MFNS_FILTER_MAX_AUG; q++) {
            g0[q] = in.h[0][MFNS_FILTER_AUG_ROT + q] / l00;
            g1[q] = (in.h[1][MFNS_FILTER_AUG_ROT + q] - l10 * g0[q]) / l11;
        }
    }
    return true;
}

/* The fault parameters that fit the frame best at the predicted pose (the
 * linearisation point only; regularised by the settings' scales,
 * aug_rot_rad and aug_dt_s, which nothing but this point depends on). */
static bool inv_fit(mfns_filter_t *f, const mfns_filter_settings_t *s, int rows,
                    const float a[][MFNS_FILTER_INV_COLS], const float fr[][MFNS_FILTER_MAX_AUG],
                    bool pointing_free)
{
    float ntn[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N];
    float rhs[MFNS_SPD_MAX_N];
    memset(ntn, 0, sizeof ntn);
    memset(rhs, 0, sizeof rhs);
    for (int r = 0; r < rows; r++) {
        for (int p = 0; p < MFNS_FILTER_MAX_AUG; p++) {
            rhs[p] += fr[r][p] * a[r][0];
            for (int q = 0; q < MFNS_FILTER_MAX_AUG; q++) {
                ntn[p][q] += fr[r][p] * fr[r][q];
            }
        }
    }
    for (int p = 0; p < 3; p++) {
        ntn[p][p] += 1.0f / (s->aug_rot_rad * s->aug_rot_rad);
    }
    ntn[3][3] += 1.0f / (s->aug_dt_s * s->aug_dt_s);
    if (!pointing_free) {
        /* the pointing held at the mount: its rows and columns out */
        for (int p = 0; p < 3; p++) {
            for (int q = 0; q < MFNS_FILTER_MAX_AUG; q++) {
                ntn[p][q] = p == q ? 1.0f : 0.0f;
                ntn[q][p] = p == q ? 1.0f : 0.0f;
            }
            rhs[p] = 0.0f;
        }
    }
    mfns_chol_t ch;
    if (mfns_chol_factor(ntn, MFNS_FILTER_MAX_AUG, 0.0f, &ch) != MFNS_SPD_OK) {
        return false;
    }
    mfns_chol_solve(&ch, rhs, rhs);
    f->aug_rot = mfns_v3_add(f->aug_rot, mfns_v3(rhs[0], rhs[1], rhs[2]));
    f->aug_dt_s += rhs[3];
    return isfinite(f->aug_dt_s) && isfinite(f->aug_rot.x) && isfinite(f->aug_rot.y) && isfinite(f->aug_rot.z);
}

/* Householder: rotate the rows so that each fault column with an effect has
 * its weight in one row, that row dropped. The rows from the returned index
 * on are orthogonal to every eliminated column: what no value of those
 * parameters can change. A column left (remaining norm below
 * MFNS_FILTER_INV_COL_EPS per rad or s: a parameter whose largest value
 * moves the data by a negligible part of a sigma, e.g. the timing on a
 * robot at rest) keeps its rows. */
static int inv_project(int rows, float a[][MFNS_FILTER_INV_COLS], float fr[][MFNS_FILTER_MAX_AUG], int c_first)
{
    int top = 0;
    for (int c = c_first; c < MFNS_FILTER_MAX_AUG && top < rows; c++) {
        float nrm2 = 0.0f;
        for (int r = top; r < rows; r++) {
            nrm2 += fr[r][c] * fr[r][c];
        }
        const float nrm = sqrtf(nrm2);
        if (!(nrm > MFNS_FILTER_INV_COL_EPS)) {
            continue;
        }
        /* H = I - 2 v v^T / v^T v, v = x + alpha e_top (alpha = sign(x_top)
         * |x|, no cancellation), v^T v = 2 alpha (alpha + x_top); H x =
         * -alpha e_top. v's tail is the column itself below top, kept until
         * the column is done. */
        const float alpha = fr[top][c] >= 0.0f ? nrm : -nrm;
        const float v0 = fr[top][c] + alpha;
        const float two_over_vv = 1.0f / (alpha * v0);
        for (int q = c + 1; q < MFNS_FILTER_MAX_AUG + MFNS_FILTER_INV_COLS; q++) {
            float *col_top = q < MFNS_FILTER_MAX_AUG ? &fr[top][q] : &a[top][q - MFNS_FILTER_MAX_AUG];
            float d = v0 * *col_top;
            for (int r = top + 1; r < rows; r++) {
                d += fr[r][c] * (q < MFNS_FILTER_MAX_AUG ? fr[r][q] : a[r][q - MFNS_FILTER_MAX_AUG]);
            }
            const float t = d * two_over_vv;
            *col_top -= t * v0;
            for (int r = top + 1; r < rows; r++) {
                float *e = q < MFNS_FILTER_MAX_AUG ? &fr[r][q] : &a[r][q - MFNS_FILTER_MAX_AUG];
                *e -= t * fr[r][c];
            }
        }
        fr[top][c] = -alpha;
        for (int r = top + 1; r < rows; r++) {
            fr[r][c] = 0.0f;
        }
        top++;
    }
    return top;
}

static bool frame_valid(int n, const mfns_filter_obs_t obs[])
{
    if (n < 1 || n > MFNS_MAX_OBS_PER_CAMERA || obs == NULL) {
        return false;
    }
    for (int i = 0; i < n; i++) {
        if (!obs_valid(&obs[i]) || obs[i].cam != obs[0].cam || obs[i].t_us != obs[0].t_us) {
            return false;
        }
    }
    return true;
}

typedef struct {
    float tau_s, tau_sigma_s;
} tau_reading_t;

/* The time offset's fit from the rows at the final linearisation point,
 * before the projection: tau = the point + (f^T y) / (f^T f), its variance
 * 1 / (f^T f) from the frame's noise plus (u^T P u) / (f^T f)^2 from the
 * state's (u = H^T f: the pose error that the fit reads as an offset). The
 * timing-free update's test of a camera's clock (nav_filter.h). */
static void tau_fit(const mfns_filter_t *f, int rows, const float a[][MFNS_FILTER_INV_COLS],
                    const float fr[][MFNS_FILTER_MAX_AUG], tau_reading_t *info)
{
    float ff = 0.0f, fy = 0.0f, u[NH];
    memset(u, 0, sizeof u);
    for (int r = 0; r < rows; r++) {
        const float g = fr[r][MFNS_FILTER_AUG_DT - MFNS_FILTER_AUG_ROT];
        ff += g * g;
        fy += g * a[r][0];
        for (int q = 0; q < NH; q++) {
            u[q] += g * a[r][1 + q];
        }
    }
    if (!(ff > 0.0f)) {
        info->tau_s = f->aug_dt_s;
        info->tau_sigma_s = INFINITY; /* no image motion: no clock to read */
        return;
    }
    float upu = 0.0f;
    for (int i = 0; i < NH; i++) {
        for (int j = 0; j < NH; j++) {
            upu += u[i] * f->P[i][j] * u[j];
        }
    }
    info->tau_s = f->aug_dt_s + fy / ff;
    info->tau_sigma_s = sqrtf(1.0f / ff + fmaxf(upu, 0.0f) / (ff * ff));
}

/* The velocity's share of a frame whose offset is unknown (the timing-free
 * update, nav_filter.h mfns_filter_update_timing_free's tau_bound_s): the
 * frame shows x(t - tau) = x(t) - tau (w, v); the eliminated column takes
 * (w, v) at the prediction, so every row keeps -tau h z, z = (dw, dv) the
 * predicted angular and linear velocity errors seen through the row's own
 * pose columns (h: attitude then position). The rows move the state by
 * tau M z more than the filter's model says (M: N x 6, the rows' gain on
 * that term, tracked row by row). With Sz = cov(z) (the filter's own
 * predicted velocity block: the bank's full filter's exactly, whose
 * velocity gives the eliminated direction; a subset's, which took less
 * data, at least as large) the term's covariance at |tau| <= T is at most
 * T^2 M Sz M^T, added to P. Its cross-covariance with the state's nominal
 * error, tau (X M^T + M X^T) with X = cov(error, z), is left out: bounded
 * for both signs of tau (Cauchy-Schwarz) it added about three times P at
 * every frame of a camera a period stale (module seed 5: nothing usable
 * after the onset), and its sign follows tau's, which the doubt does not
 * know. */
typedef struct {
    float sz[NH][NH]; /* cov(z), pose-column order (angular rate, velocity) */
    float m[N][NH];   /* the rows' gain on the term */
} consider_t;

static void consider_start(const mfns_filter_t *f, consider_t *c)
{
    for (int q = 0; q < NH; q++) {
        const int iq = q < 3 ? MFNS_FILTER_OMEGA + q : MFNS_FILTER_VEL + (q - 3);
        for (int p = 0; p < NH; p++) {
            const int ip = p < 3 ? MFNS_FILTER_OMEGA + p : MFNS_FILTER_VEL + (p - 3);
            c->sz[q][p] = f->P[iq][ip];
        }
        for (int i = 0; i < N; i++) {
            c->m[i][q] = 0.0f;
        }
    }
}

/* one scalar row h (pose columns) applied with gain k: the row sees h z
 * less what the rows before it moved the pose by */
static void consider_row(consider_t *c, const float h[NH], const float k[N])
{
    float hm[NH];
    for (int p = 0; p < NH; p++) {
        float v = h[p];
        for (int q = 0; q < NH; q++) {
            v -= h[q] * c->m[q][p];
        }
        hm[p] = v;
    }
    for (int i = 0; i < N; i++) {
        for (int p = 0; p < NH; p++) {
            c->m[i][p] += k[i] * hm[p];
        }
    }
}

/* term = T^2 M Sz M^T */
static void consider_term(const consider_t *c, float tau_bound_s, float term[N][N])
{
    float ms[N][NH];
    for (int i = 0; i < N; i++) {
        for (int p = 0; p < NH; p++) {
            float v = 0.0f;
            for (int q = 0; q < NH; q++) {
                v += c->m[i][q] * c->sz[q][p];
            }
            ms[i][p] = tau_bound_s * tau_bound_s * v;
        }
    }
    for (int i = 0; i < N; i++) {
        for (int j = 0; j < N; j++) {
            float v = 0.0f;
            for (int p = 0; p < NH; p++) {
                v += ms[i][p] * c->m[j][p];
            }
            term[i][j] = v;
        }
    }
}

/* P <- P + add, symmetrised */
static void add_to_p(mfns_filter_t *f, const float add[N][N])
{
    for (int i = 0; i < N; i++) {
        for (int j = 0; j < N; j++) {
            f->P[i][j] += add[i][j];
        }
    }
    symmetrise(f);
}

bool mfns_filter_add_cov(mfns_filter_t *f, const float add[MFNS_FILTER_N][MFNS_FILTER_N])
{
    if (f == NULL || f->initialised == 0U || add == NULL) {
        return false;
    }
    for (int i = 0; i < N; i++) {
        if (!(add[i][i] >= 0.0f) || !isfinite(add[i][i])) {
            return false;
        }
    }
    add_to_p(f, add);
    return true;
}

static mfns_filter_status_t invariant(mfns_filter_t *f, const mfns_filter_settings_t *s, const mfns_rig_t *rig,
                                      float sigma_px, int n, const mfns_filter_obs_t obs[], bool pointing_free,
                                      const mfns_filter_t *ref, float tau_bound_s, mfns_filter_invariant_info_t *info)
{
    mfns_filter_status_t st = mfns_filter_propagate(f, s, obs[0].t_us);
    if (st != MFNS_FILTER_OK) {
        return st;
    }
    /* the frame's own fault parameters have no prior (they are no states:
     * observe_model() gives the body states' columns); the timing column is
     * taken at the velocity predicted for the frame */
    f->aug_v_w = ref != NULL ? ref->v_w : f->v_w;
    f->aug_w_w = ref != NULL ? ref->w_w : f->w_w;
    const int m = n < MFNS_FILTER_INV_MAX_OBS ? n : MFNS_FILTER_INV_MAX_OBS;
    const int rows = 2 * m;
    float a[2 * MFNS_FILTER_INV_MAX_OBS][MFNS_FILTER_INV_COLS];
    float fr[2 * MFNS_FILTER_INV_MAX_OBS][MFNS_FILTER_MAX_AUG];
    /* linearised where the frame puts the fault parameters (from the last
     * frame's: a persistent knock starts where it was), then projected */
    for (int it = 0; it < MFNS_FILTER_INV_FIT_ITERS; it++) {
        if (!inv_rows(f, rig, sigma_px, m, obs, a, fr) || !inv_fit(f, s, rows, a, fr, pointing_free)) {
            return MFNS_FILTER_E_GEOM;
        }
    }
    if (!inv_rows(f, rig, sigma_px, m, obs, a, fr)) {
        return MFNS_FILTER_E_GEOM;
    }
    tau_reading_t fit = {0.0f, 0.0f};
    if (info != NULL) {
        memset(info->added_cov, 0, sizeof info->added_cov);
    }
    if (!pointing_free) {
        tau_fit(f, rows, a, fr, &fit);
    }
    const int top = inv_project(rows, a, fr, pointing_free ? 0 : MFNS_FILTER_AUG_DT - MFNS_FILTER_AUG_ROT);
    /* the rows left, sequential scalar updates (unit noise) of the body
     * states about the one linearisation point: each row's residual less
     * what the rows before it moved */
    float dx[N];
    memset(dx, 0, sizeof dx);
    /* the rows' effect through an offset times the velocity's error (only
     * when the offset is bounded: consider_t above) */
    const bool consider = tau_bound_s > 0.0f;
    consider_t cons;
    if (consider) {
        consider_start(f, &cons);
    }
    float nis = 0.0f;
    for (int r = top; r < rows; r++) {
        const float *h = &a[r][1];
        float pht[N];
        float y = a[r][0], sden = 1.0f;
        for (int i = 0; i < N; i++) {
            float v = 0.0f;
            for (int q = 0; q < MFNS_FILTER_INV_COLS - 1; q++) {
                v += f->P[i][q] * h[q];
            }
            pht[i] = v;
        }
        for (int q = 0; q < MFNS_FILTER_INV_COLS - 1; q++) {
            y -= h[q] * dx[q];
            sden += h[q] * pht[q];
        }
        if (!(sden > 0.0f) || !isfinite(sden)) {
            return MFNS_FILTER_E_GEOM;
        }
        nis += y * y / sden;
        float k[N];
        for (int i = 0; i < N; i++) {
            k[i] = pht[i] / sden;
            dx[i] += k[i] * y;
        }
        if (consider) {
            consider_row(&cons, h, k);
        }
        /* Joseph, scalar: A = P - k pht^T, P <- A - (A h) k^T + k k^T */
        for (int i = 0; i < N; i++) {
            for (int j = 0; j < N; j++) {
                f->P[i][j] -= k[i] * pht[j];
            }
        }
        float ah[N];
        for (int i = 0; i < N; i++) {
            float v = 0.0f;
            for (int q = 0; q < MFNS_FILTER_INV_COLS - 1; q++) {
                v += f->P[i][q] * h[q];
            }
            ah[i] = v;
        }
        for (int i = 0; i < N; i++) {
            for (int j = 0; j < N; j++) {
                f->P[i][j] += (k[i] - ah[i]) * k[j];
            }
        }
        symmetrise(f);
    }
    const int used = rows - top;
    if (used > 0) {
        if (consider) {
            float term[N][N];
            consider_term(&cons, tau_bound_s, term);
            add_to_p(f, (const float(*)[N])term);
            if (info != NULL) {
                memcpy(info->added_cov, term, sizeof term);
            }
        }
        inject(f, dx);
        f->t_meas_us = obs[0].t_us;
        f->updates += (uint32_t)m;
        f->cyc_nis += nis;
        f->cyc_dof = (uint16_t)(f->cyc_dof < UINT16_MAX - (uint16_t)used ? f->cyc_dof + (uint16_t)used : f->cyc_dof);
    }
    if (info != NULL) {
        info->rows = (uint16_t)used;
        info->eliminated = (uint8_t)top;
        info->nis = nis;
        info->tau_s = fit.tau_s;
        info->tau_sigma_s = fit.tau_sigma_s;
    }
    return MFNS_FILTER_OK;
}

mfns_filter_status_t mfns_filter_update_invariant(mfns_filter_t *f, const mfns_filter_settings_t *s,
                                                  const mfns_rig_t *rig, float sigma_px, int n,
                                                  const mfns_filter_obs_t obs[], mfns_filter_invariant_info_t *info)
{
    if (f == NULL || f->initialised == 0U || rig == NULL || !mfns_filter_settings_valid(s) ||
        !frame_valid(n, obs) || !pos_finite(sigma_px) || f->aug_cam != obs[0].cam) {
        return MFNS_FILTER_E_ARG;
    }
    return invariant(f, s, rig, sigma_px, n, obs, true, NULL, 0.0f, info);
}

mfns_filter_status_t mfns_filter_update_timing_free(mfns_filter_t *f, const mfns_filter_settings_t *s,
                                                    const mfns_rig_t *rig, float sigma_px, int n,
                                                    const mfns_filter_obs_t obs[], const mfns_filter_t *ref,
                                                    float tau_bound_s, mfns_filter_invariant_info_t *info)
{
    if (f == NULL || f->initialised == 0U || rig == NULL || !mfns_filter_settings_valid(s) ||
        !frame_valid(n, obs) || !pos_finite(sigma_px) || (ref != NULL && ref->initialised == 0U) ||
        !(tau_bound_s >= 0.0f) || !(tau_bound_s <= MFNS_FILTER_CONSIDER_TAU_MAX_S)) {
        return MFNS_FILTER_E_ARG;
    }
    /* the frame's camera as the filter's fault camera for this frame only,
     * its pointing at the mount and the offset fitted from zero; the
     * filter's own camera hypothesis, if any, comes back untouched */
    const uint8_t cam0 = f->aug_cam;
    const mfns_v3_t rot0 = f->aug_rot, v0 = f->aug_v_w, w0 = f->aug_w_w;
    const float dt0 = f->aug_dt_s;
    f->aug_cam = obs[0].cam;
    f->aug_rot = mfns_v3(0.0f, 0.0f, 0.0f);
    f->aug_dt_s = 0.0f;
    const mfns_filter_status_t st = invariant(f, s, rig, sigma_px, n, obs, false, ref, tau_bound_s, info);
    f->aug_cam = cam0;
    f->aug_rot = rot0;
    f->aug_dt_s = dt0;
    f->aug_v_w = v0;
    f->aug_w_w = w0;
    return st;
}

void mfns_filter_datum_cov(const mfns_pose_t *pose, const mfns_map_datum_t *datum, float d[6][6])
{
    float inc[6][6];
    memset(inc, 0, sizeof inc);
    memset(d, 0, sizeof(float[6][6]));
    if (datum == NULL || datum->present == 0U) {
        return;
    }
    mfns_pose_add_datum_term(pose, datum, inc);
    /* increment -> filter pose error (phi_w, dr_w), sign aside (second moments):
     * phi = -C^T dtheta, dr = -C^T [r_bw_b]x dtheta - C^T dt */
    mfns_m3_t ct, a;
    mfns_m3_transpose_at(&pose->C_w_b, &ct);
    a = mfns_m3_skew(pose->r_bw_b);
    mfns_m3_mul_at(&ct, &a, &a);
    float g[6][6];
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 3; c++) {
            g[r][c] = -ct.m[r][c];
            g[r][c + 3] = 0.0f;
            g[r + 3][c] = -a.m[r][c];
            g[r + 3][c + 3] = -ct.m[r][c];
        }
    }
    float t[6][6];
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            float v = 0.0f;
            for (int q = 0; q < 6; q++) {
                v += g[i][q] * inc[q][j];
            }
            t[i][j] = v;
        }
    }
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            float v = 0.0f;
            for (int q = 0; q < 6; q++) {
                v += t[i][q] * g[j][q];
            }
            d[i][j] = v;
        }
    }
}

void mfns_filter_pose_cov_ros(const mfns_filter_t *f, const mfns_map_datum_t *datum, float cov_ros[6][6])
{
    const mfns_pose_t pose = mfns_filter_pose(f);
    float d[6][6];
    mfns_filter_datum_cov(&pose, datum, d);
    static const int to_filter[6] = {3, 4, 5, 0, 1, 2}; /* ros index -> filter index */
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            const int a = to_filter[i], b = to_filter[j];
            cov_ros[i][j] = f->P[a][b] + d[a][b];
        }
    }
}

float mfns_filter_chi2_quantile(float dof, float p)
{
    const float z = mfns_integrity_q_inv(p);
    const float a = 2.0f / (9.0f * dof);
    const float c = 1.0f - a + z * sqrtf(a);
    return dof * c * c * c;
}

void mfns_filter_reset_window(mfns_filter_t *f)
{
    f->cyc_nis = 0.0f;
    f->cyc_dof = 0;
    for (int i = 0; i < MFNS_FILTER_NIS_WINDOW; i++) {
        f->win_nis[i] = 0.0f;
        f->win_dof[i] = 0;
    }
    f->win_pos = 0;
    f->win_fill = 0;
}

bool mfns_filter_end_cycle(mfns_filter_t *f, const mfns_filter_settings_t *s)
{
    if (f == NULL || f->initialised == 0U || !mfns_filter_settings_valid(s)) {
        return false;
    }
    f->win_nis[f->win_pos] = f->cyc_nis;
    f->win_dof[f->win_pos] = f->cyc_dof;
    f->win_pos = (uint8_t)((f->win_pos + 1U) % MFNS_FILTER_NIS_WINDOW);
    f->win_fill = (uint8_t)(f->win_fill < MFNS_FILTER_NIS_WINDOW ? f->win_fill + 1U : f->win_fill);
    f->cyc_nis = 0.0f;
    f->cyc_dof = 0;
    if (f->win_fill < MFNS_FILTER_NIS_WINDOW) {
        return false;
    }
    float sum = 0.0f, dof = 0.0f;
    for (int i = 0; i < MFNS_FILTER_NIS_WINDOW; i++) {
        sum += f->win_nis[i];
        dof += (float)f->win_dof[i];
    }
    if (dof < 4.0f || !(sum > mfns_filter_chi2_quantile(dof, s->gate_p))) {
        return false;
    }
    f->motion_exceeded = 1;
    return true;
}
