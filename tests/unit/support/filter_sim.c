/* filter_sim.c -- see filter_sim.h. Double throughout: the truth. */
#include "tests/unit/support/filter_sim.h"

#pragma GCC diagnostic ignored "-Wdouble-promotion"

#include <string.h>

static void mul33(const double a[3][3], const double b[3][3], double o[3][3])
{
    double t[3][3];
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            t[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    memcpy(o, t, sizeof t);
}

static void transpose33(const double a[3][3], double o[3][3])
{
    double t[3][3];
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            t[i][j] = a[j][i];
        }
    }
    memcpy(o, t, sizeof t);
}

/* C_w_b <- C_w_b exp(th)^T (C_b_w <- exp(th) C_b_w) */
static void turn(fs_truth_t *x, const double th[3])
{
    double e[3][3], et[3][3];
    pt_rot_exp(th, e);
    transpose33(e, et);
    mul33(x->C_w_b, et, x->C_w_b);
}

void fs_truth_advance(fs_truth_t *x, double dt, double q_lin, double q_ang, const double a_lin[3],
                      mfns_rng_t *rng)
{
    double th[3];
    for (int i = 0; i < 3; i++) {
        double n1 = 0.0, n2 = 0.0, m1 = 0.0, m2 = 0.0;
        if (rng != NULL) {
            /* Cholesky of q [[dt^3/3, dt^2/2], [dt^2/2, dt]] */
            const double z1 = mfns_rng_normal(rng), z2 = mfns_rng_normal(rng);
            const double z3 = mfns_rng_normal(rng), z4 = mfns_rng_normal(rng);
            const double l11 = sqrt(dt * dt * dt / 3.0), l21 = (dt * dt / 2.0) / l11;
            const double l22 = sqrt(dt - l21 * l21);
            n1 = sqrt(q_lin) * l11 * z1;
            n2 = sqrt(q_lin) * (l21 * z1 + l22 * z2);
            m1 = sqrt(q_ang) * l11 * z3;
            m2 = sqrt(q_ang) * (l21 * z3 + l22 * z4);
        }
        const double a = a_lin != NULL ? a_lin[i] : 0.0;
        x->r_wb_w[i] += x->v_w[i] * dt + 0.5 * a * dt * dt + n1;
        x->v_w[i] += a * dt + n2;
        th[i] = x->w_w[i] * dt + m1;
        x->w_w[i] += m2;
    }
    turn(x, th);
}

pt_dpose_t fs_truth_pose(const fs_truth_t *x)
{
    return pt_pose(x->C_w_b, x->r_wb_w);
}

int fs_observe(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const fs_truth_t *x, int cam, double sigma_px,
               mfns_rng_t *rng, int64_t t_us, mfns_filter_obs_t *obs, int16_t *beacon, int max)
{
    const pt_dpose_t p = fs_truth_pose(x);
    int n = 0;
    for (int b = 0; b < map->count && n < max; b++) {
        const double pw[3] = {map->beacon[b].p_w.x, map->beacon[b].p_w.y, map->beacon[b].p_w.z};
        double uv[2];
        if (!pt_project(&rig->cam[cam], &p, pw, uv)) {
            continue;
        }
        mfns_filter_obs_t *o = &obs[n];
        memset(o, 0, sizeof(*o));
        o->t_us = t_us;
        o->cam = (uint8_t)cam;
        o->u = (float)(uv[0] + sigma_px * mfns_rng_normal(rng));
        o->v = (float)(uv[1] + sigma_px * mfns_rng_normal(rng));
        o->p_w = map->beacon[b].p_w;
        o->sigma_mm = map->beacon[b].sigma_mm;
        beacon[n] = (int16_t)b;
        n++;
    }
    return n;
}

/* rotation log (axis-angle) of a double rotation */
static void rot_log(const double r[3][3], double w[3])
{
    const double c = fmax(-1.0, fmin(1.0, 0.5 * (r[0][0] + r[1][1] + r[2][2] - 1.0)));
    const double th = acos(c);
    const double k = th < 1e-9 ? 0.5 : th / (2.0 * sin(th));
    w[0] = k * (r[2][1] - r[1][2]);
    w[1] = k * (r[0][2] - r[2][0]);
    w[2] = k * (r[1][0] - r[0][1]);
}

void fs_pose_error(const mfns_filter_t *f, const fs_truth_t *x, double e[6])
{
    /* truth = exp(phi) est: exp(phi) = C_b_w(true) C_b_w(est)^T = C_w_b(true)^T C_w_b(est) */
    double est[3][3], ct[3][3], d[3][3];
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            est[i][j] = f->C_w_b.m[i][j];
        }
    }
    transpose33(x->C_w_b, ct);
    mul33(ct, est, d);
    rot_log(d, e);
    e[3] = x->r_wb_w[0] - f->r_wb_w.x;
    e[4] = x->r_wb_w[1] - f->r_wb_w.y;
    e[5] = x->r_wb_w[2] - f->r_wb_w.z;
}

double fs_nees(const mfns_filter_t *f, const fs_truth_t *x)
{
    double e[6], a[6][6], l[6][6];
    fs_pose_error(f, x, e);
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            a[i][j] = f->P[i][j];
            l[i][j] = 0.0;
        }
    }
    for (int j = 0; j < 6; j++) {
        double s = a[j][j];
        for (int k = 0; k < j; k++) {
            s -= l[j][k] * l[j][k];
        }
        if (!(s > 0.0)) {
            return INFINITY;
        }
        l[j][j] = sqrt(s);
        for (int i = j + 1; i < 6; i++) {
            double t = a[i][j];
            for (int k = 0; k < j; k++) {
                t -= l[i][k] * l[j][k];
            }
            l[i][j] = t / l[j][j];
        }
    }
    double y[6] = {0, 0, 0, 0, 0, 0}, nees = 0.0;
    for (int i = 0; i < 6; i++) {
        double t = e[i];
        for (int k = 0; k < i; k++) {
            t -= l[i][k] * y[k];
        }
        y[i] = t / l[i][i];
        nees += y[i] * y[i];
    }
    return nees;
}

void fs_init_filter(mfns_filter_t *f, const fs_truth_t *x, double sig_att_rad, double sig_pos_mm, double sigma_v,
                    double sigma_w, int64_t t_us, mfns_rng_t *rng)
{
    fs_truth_t est = *x;
    double phi[3];
    for (int i = 0; i < 3; i++) {
        phi[i] = -sig_att_rad * mfns_rng_normal(rng); /* est = exp(-phi) truth */
        est.r_wb_w[i] -= sig_pos_mm * mfns_rng_normal(rng);
        est.v_w[i] -= sigma_v * mfns_rng_normal(rng);
        est.w_w[i] -= sigma_w * mfns_rng_normal(rng);
    }
    turn(&est, phi);
    const pt_dpose_t dp = fs_truth_pose(&est);
    const mfns_pose_t pose = pt_to_float(&dp);
    float cov[6][6];
    memset(cov, 0, sizeof cov);
    for (int i = 0; i < 3; i++) {
        cov[i][i] = (float)(sig_pos_mm * sig_pos_mm);
        cov[3 + i][3 + i] = (float)(sig_att_rad * sig_att_rad);
    }
    const mfns_filter_status_t st =
        mfns_filter_init(f, &pose, (const float(*)[6])cov, mfns_v3((float)est.v_w[0], (float)est.v_w[1], (float)est.v_w[2]),
                         (float)sigma_v, mfns_v3((float)est.w_w[0], (float)est.w_w[1], (float)est.w_w[2]),
                         (float)sigma_w, t_us);
    assert_int_equal(st, MFNS_FILTER_OK);
}
