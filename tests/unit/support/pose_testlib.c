/* pose_testlib.c -- see pose_testlib.h. Double precision throughout: this is
 * the truth and the reference the float flight code is measured against. */
#include "tests/unit/support/pose_testlib.h"
#include "firmware/host/beacon_index_build.h"

/* Test code computes in double from the float model on purpose: promotion is intended. */
#pragma GCC diagnostic ignored "-Wdouble-promotion"

#include <string.h>

#define DEG (MFNS_PI / 180.0)

static mfns_m3_t euler_deg(double roll, double pitch, double yaw)
{
    return mfns_euler213_to_m3((mfns_euler_t){(float)(roll * DEG), (float)(pitch * DEG), (float)(yaw * DEG)});
}

mfns_rig_t pt_paper_rig(void)
{
    mfns_rig_t rig;
    memset(&rig, 0, sizeof(rig));
    rig.cam[0].k = (mfns_intrinsics_t){1599.26136f, 1599.93302f, 632.61591f, 522.17870f, 0.0f,
                                       {-0.13013f, 0.28701f, -0.00040f, -0.00004f, 0.0f}, 1280, 1024};
    rig.cam[1].k = (mfns_intrinsics_t){1605.35286f, 1603.54359f, 619.71227f, 505.99361f, 0.0f,
                                       {-0.11276f, 0.01776f, -0.00031f, 0.00057f, 0.0f}, 1280, 1024};
    rig.cam[2].k = (mfns_intrinsics_t){1611.21596f, 1610.79607f, 649.51210f, 531.29472f, 0.0f,
                                       {-0.10481f, 0.15881f, -0.00137f, 0.00184f, 0.0f}, 1280, 1024};
    rig.cam[0].C_k_b = euler_deg(-0.5788, -90.3523, 0.0395);
    rig.cam[1].C_k_b = euler_deg(90.1636, -0.5501, 0.1925);
    rig.cam[2].C_k_b = euler_deg(-0.1076, -0.7211, 1.1690);
    rig.cam[0].r_bk_b = mfns_v3(76.1319f, -36.8373f, 78.8949f);
    rig.cam[1].r_bk_b = mfns_v3(-32.5004f, 75.7149f, 76.9967f);
    rig.cam[2].r_bk_b = mfns_v3(34.1604f, 30.8251f, 119.7096f);
    return rig;
}

mfns_beacon_map_t pt_paper_map(void)
{
    static const float p[10][3] = {
        {487.4734f, -720.0265f, 240.8359f}, {-51.2618f, -737.6155f, 164.7393f}, {-366.1525f, -711.8317f, 131.2681f},
        {-458.8302f, -215.2964f, -69.2627f}, {-454.6380f, 410.3959f, -60.6549f}, {-117.4392f, 296.0537f, 83.0754f},
        {182.4478f, 279.1964f, 143.2510f}, {481.8346f, 252.9609f, 217.5775f}, {647.3834f, -127.6167f, 178.7407f},
        {-122.5798f, -44.9064f, 562.5394f}};
    mfns_beacon_map_t m;
    memset(&m, 0, sizeof(m));
    m.count = 10;
    for (int i = 0; i < 10; i++) {
        m.beacon[i].id = (uint16_t)i;
        m.beacon[i].p_w = mfns_v3(p[i][0], p[i][1], p[i][2]);
        m.beacon[i].sigma_mm = 0.3963f;
    }
    return m;
}

void pt_rot_exp(const double w[3], double r[3][3])
{
    const double th = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    double a = 1.0, b = 0.5;
    if (th > 1e-8) {
        a = sin(th) / th;
        b = (1.0 - cos(th)) / (th * th);
    }
    const double k[3][3] = {{0, -w[2], w[1]}, {w[2], 0, -w[0]}, {-w[1], w[0], 0}};
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            double k2 = 0;
            for (int l = 0; l < 3; l++) {
                k2 += k[i][l] * k[l][j];
            }
            r[i][j] = (i == j ? 1.0 : 0.0) + a * k[i][j] + b * k2;
        }
    }
}

static void mul33(const double a[3][3], const double b[3][3], double o[3][3])
{
    double t[3][3];
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            t[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    memcpy(o, t, sizeof(t));
}

pt_dpose_t pt_pose(const double c[3][3], const double r_wb_w[3])
{
    pt_dpose_t p;
    memcpy(p.C, c, sizeof(p.C));
    for (int i = 0; i < 3; i++) {
        p.r[i] = -(c[i][0] * r_wb_w[0] + c[i][1] * r_wb_w[1] + c[i][2] * r_wb_w[2]);
    }
    return p;
}

void pt_random_rotation(mfns_rng_t *rng, double max_angle, const double c0[3][3], double out[3][3])
{
    double ax[3], n2;
    do {
        for (int i = 0; i < 3; i++) {
            ax[i] = mfns_rng_range(rng, -1, 1);
        }
        n2 = ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2];
    } while (n2 > 1.0 || n2 < 1e-6);
    const double ang = mfns_rng_range(rng, 0, max_angle) / sqrt(n2);
    const double w[3] = {ax[0] * ang, ax[1] * ang, ax[2] * ang};
    double r[3][3];
    pt_rot_exp(w, r);
    mul33(r, c0, out);
}

mfns_pose_t pt_to_float(const pt_dpose_t *p)
{
    mfns_pose_t f;
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            f.C_w_b.m[i][j] = (float)p->C[i][j];
        }
    }
    f.r_bw_b = mfns_v3((float)p->r[0], (float)p->r[1], (float)p->r[2]);
    return f;
}

pt_dpose_t pt_from_float(const mfns_pose_t *p)
{
    pt_dpose_t d;
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            d.C[i][j] = p->C_w_b.m[i][j];
        }
    }
    d.r[0] = p->r_bw_b.x;
    d.r[1] = p->r_bw_b.y;
    d.r[2] = p->r_bw_b.z;
    return d;
}

void pt_position_w(const pt_dpose_t *p, double r_wb_w[3])
{
    for (int i = 0; i < 3; i++) {
        r_wb_w[i] = -(p->C[0][i] * p->r[0] + p->C[1][i] * p->r[1] + p->C[2][i] * p->r[2]);
    }
}

static void distort(const mfns_intrinsics_t *k, double x, double y, double *xd, double *yd)
{
    const double k1 = k->dist[0], k2 = k->dist[1], p1 = k->dist[2], p2 = k->dist[3], k3 = k->dist[4];
    const double r2 = x * x + y * y;
    const double rad = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    *xd = x * rad + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
    *yd = y * rad + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
}

static bool project_raw(const mfns_camera_t *cam, const pt_dpose_t *pose, const double p_w[3], double uv[2])
{
    double pb[3], pc[3];
    for (int i = 0; i < 3; i++) {
        pb[i] = pose->C[i][0] * p_w[0] + pose->C[i][1] * p_w[1] + pose->C[i][2] * p_w[2] + pose->r[i];
    }
    const double d[3] = {pb[0] - cam->r_bk_b.x, pb[1] - cam->r_bk_b.y, pb[2] - cam->r_bk_b.z};
    for (int i = 0; i < 3; i++) {
        pc[i] = cam->C_k_b.m[0][i] * d[0] + cam->C_k_b.m[1][i] * d[1] + cam->C_k_b.m[2][i] * d[2];
    }
    if (!(pc[2] >= 1.0)) {
        return false;
    }
    double xd, yd;
    distort(&cam->k, pc[0] / pc[2], pc[1] / pc[2], &xd, &yd);
    uv[0] = cam->k.fx * xd + cam->k.skew * yd + cam->k.cx;
    uv[1] = cam->k.fy * yd + cam->k.cy;
    return true;
}

bool pt_project(const mfns_camera_t *cam, const pt_dpose_t *pose, const double p_w[3], double uv[2])
{
    if (!project_raw(cam, pose, p_w, uv)) {
        return false;
    }
    /* also require the undistorted direction to be within the lens's useful field
     * (the polynomial folds back far outside the image) */
    return uv[0] >= -0.5 && uv[1] >= -0.5 && uv[0] < cam->k.width - 0.5 && uv[1] < cam->k.height - 0.5;
}

void pt_undistort(const mfns_intrinsics_t *k, double u, double v, double *x, double *y)
{
    const double yd = (v - k->cy) / k->fy;
    const double xd = (u - k->cx - k->skew * yd) / k->fx;
    double cx = xd, cy = yd;
    for (int it = 0; it < 50; it++) {
        double fx, fy, ax, ay, bx, by;
        const double h = 1e-7;
        distort(k, cx, cy, &fx, &fy);
        fx -= xd;
        fy -= yd;
        if (fabs(fx) < 1e-16 && fabs(fy) < 1e-16) {
            break;
        }
        distort(k, cx + h, cy, &ax, &ay);
        distort(k, cx - h, cy, &bx, &by);
        const double j00 = (ax - bx) / (2 * h), j10 = (ay - by) / (2 * h);
        distort(k, cx, cy + h, &ax, &ay);
        distort(k, cx, cy - h, &bx, &by);
        const double j01 = (ax - bx) / (2 * h), j11 = (ay - by) / (2 * h);
        const double det = j00 * j11 - j01 * j10;
        cx -= (j11 * fx - j01 * fy) / det;
        cy -= (-j10 * fx + j00 * fy) / det;
    }
    *x = cx;
    *y = cy;
}

int pt_make_frame(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const pt_dpose_t *pose, double sigma,
                  mfns_rng_t *rng, mfns_obs_frame_t *frame, mfns_pose_assoc_t *truth)
{
    memset(frame, 0, sizeof(*frame));
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < MFNS_MAX_OBS_PER_CAMERA; i++) {
            truth->beacon[c][i] = MFNS_POSE_NO_BEACON;
        }
    }
    int n = 0;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int b = 0; b < map->count; b++) {
            const double pw[3] = {map->beacon[b].p_w.x, map->beacon[b].p_w.y, map->beacon[b].p_w.z};
            double uv[2];
            if (!pt_project(&rig->cam[c], pose, pw, uv) || frame->count[c] >= MFNS_MAX_OBS_PER_CAMERA) {
                continue;
            }
            if (sigma > 0) {
                uv[0] += sigma * mfns_rng_normal(rng);
                uv[1] += sigma * mfns_rng_normal(rng);
            }
            double x, y;
            pt_undistort(&rig->cam[c].k, uv[0], uv[1], &x, &y);
            mfns_obs_t *o = &frame->obs[c][frame->count[c]];
            o->u = (float)uv[0];
            o->v = (float)uv[1];
            o->x = (float)x;
            o->y = (float)y;
            truth->beacon[c][frame->count[c]] = (int16_t)b;
            frame->count[c]++;
            n++;
        }
    }
    return n;
}

void pt_add_spurious(const mfns_rig_t *rig, int cam, mfns_rng_t *rng, mfns_obs_frame_t *frame,
                     mfns_pose_assoc_t *truth)
{
    const int i = frame->count[cam];
    if (i >= MFNS_MAX_OBS_PER_CAMERA) {
        return;
    }
    const double u = mfns_rng_range(rng, 20, rig->cam[cam].k.width - 20);
    const double v = mfns_rng_range(rng, 20, rig->cam[cam].k.height - 20);
    double x, y;
    pt_undistort(&rig->cam[cam].k, u, v, &x, &y);
    frame->obs[cam][i] = (mfns_obs_t){(float)u, (float)v, (float)x, (float)y, {0.0f, 0.0f, 0.0f}};
    truth->beacon[cam][i] = MFNS_POSE_NO_BEACON;
    frame->count[cam]++;
}

static void apply(const pt_dpose_t *p, const double d[6], pt_dpose_t *o)
{
    double r[3][3];
    pt_rot_exp(d, r);
    mul33(r, p->C, o->C);
    for (int i = 0; i < 3; i++) {
        o->r[i] = p->r[i] + d[3 + i];
    }
}

static bool solve6(double a[6][6], double b[6], double x[6])
{
    for (int c = 0; c < 6; c++) {
        int piv = c;
        for (int r = c + 1; r < 6; r++) {
            if (fabs(a[r][c]) > fabs(a[piv][c])) {
                piv = r;
            }
        }
        if (fabs(a[piv][c]) < 1e-300) {
            return false;
        }
        for (int k = 0; k < 6; k++) {
            const double t = a[c][k];
            a[c][k] = a[piv][k];
            a[piv][k] = t;
        }
        const double tb = b[c];
        b[c] = b[piv];
        b[piv] = tb;
        for (int r = c + 1; r < 6; r++) {
            const double f = a[r][c] / a[c][c];
            for (int k = c; k < 6; k++) {
                a[r][k] -= f * a[c][k];
            }
            b[r] -= f * b[c];
        }
    }
    for (int r = 5; r >= 0; r--) {
        double s = b[r];
        for (int k = r + 1; k < 6; k++) {
            s -= a[r][k] * x[k];
        }
        x[r] = s / a[r][r];
    }
    return true;
}

int pt_ref_refine(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const mfns_obs_frame_t *frame,
                  const mfns_pose_assoc_t *assoc, pt_dpose_t *pose)
{
    for (int it = 0; it < 100; it++) {
        double h[6][6] = {{0}}, g[6] = {0};
        for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
            for (int i = 0; i < frame->count[c]; i++) {
                const int b = assoc->beacon[c][i];
                if (b < 0) {
                    continue;
                }
                const double pw[3] = {map->beacon[b].p_w.x, map->beacon[b].p_w.y, map->beacon[b].p_w.z};
                double uv[2];
                if (!project_raw(&rig->cam[c], pose, pw, uv)) {
                    return -1;
                }
                const double r[2] = {uv[0] - frame->obs[c][i].u, uv[1] - frame->obs[c][i].v};
                double j[2][6];
                for (int k = 0; k < 6; k++) {
                    const double hs = k < 3 ? 1e-7 : 1e-4;
                    double dp[6] = {0}, dm[6] = {0};
                    dp[k] = hs;
                    dm[k] = -hs;
                    pt_dpose_t pp, pm;
                    apply(pose, dp, &pp);
                    apply(pose, dm, &pm);
                    double up[2], um[2];
                    if (!project_raw(&rig->cam[c], &pp, pw, up) || !project_raw(&rig->cam[c], &pm, pw, um)) {
                        return -1;
                    }
                    j[0][k] = (up[0] - um[0]) / (2 * hs);
                    j[1][k] = (up[1] - um[1]) / (2 * hs);
                }
                for (int a = 0; a < 6; a++) {
                    g[a] -= j[0][a] * r[0] + j[1][a] * r[1];
                    for (int bb = 0; bb < 6; bb++) {
                        h[a][bb] += j[0][a] * j[0][bb] + j[1][a] * j[1][bb];
                    }
                }
            }
        }
        double d[6];
        if (!solve6(h, g, d)) {
            return -1;
        }
        pt_dpose_t np;
        apply(pose, d, &np);
        *pose = np;
        const double sr = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        const double st = sqrt(d[3] * d[3] + d[4] * d[4] + d[5] * d[5]);
        if (sr < 1e-11 && st < 1e-8) {
            return it + 1;
        }
    }
    return -1;
}

double pt_rot_err(const double a[3][3], const double b[3][3])
{
    /* angle of a^T b from its trace, stable for small angles via the skew part */
    double m[3][3];
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            m[i][j] = a[0][i] * b[0][j] + a[1][i] * b[1][j] + a[2][i] * b[2][j];
        }
    }
    const double s = 0.5 * sqrt((m[2][1] - m[1][2]) * (m[2][1] - m[1][2]) + (m[0][2] - m[2][0]) * (m[0][2] - m[2][0]) +
                                (m[1][0] - m[0][1]) * (m[1][0] - m[0][1]));
    const double c = 0.5 * (m[0][0] + m[1][1] + m[2][2] - 1.0);
    return atan2(s, c);
}

double pt_pos_err(const pt_dpose_t *a, const pt_dpose_t *b)
{
    double pa[3], pb[3];
    pt_position_w(a, pa);
    pt_position_w(b, pb);
    return sqrt((pa[0] - pb[0]) * (pa[0] - pb[0]) + (pa[1] - pb[1]) * (pa[1] - pb[1]) + (pa[2] - pb[2]) * (pa[2] - pb[2]));
}

mfns_beacon_map_t pt_dense_map(const mfns_rig_t *rig, const pt_dpose_t *pose, const int per_cam[3], double depth_lo,
                               double depth_hi, mfns_rng_t *rng)
{
    mfns_beacon_map_t m;
    memset(&m, 0, sizeof(m));
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        const mfns_camera_t *cam = &rig->cam[c];
        for (int k = 0; k < per_cam[c] && m.count < MFNS_MAX_BEACONS; k++) {
            /* a pixel inside the image, undistorted, at a random depth */
            const double u = mfns_rng_range(rng, 40, cam->k.width - 40), v = mfns_rng_range(rng, 40, cam->k.height - 40);
            double x, y;
            pt_undistort(&cam->k, u, v, &x, &y);
            const double z = mfns_rng_range(rng, depth_lo, depth_hi);
            const double pc[3] = {x * z, y * z, z};
            double pb[3], pw[3];
            for (int i = 0; i < 3; i++) {
                pb[i] = cam->C_k_b.m[i][0] * pc[0] + cam->C_k_b.m[i][1] * pc[1] + cam->C_k_b.m[i][2] * pc[2];
            }
            pb[0] += cam->r_bk_b.x - pose->r[0];
            pb[1] += cam->r_bk_b.y - pose->r[1];
            pb[2] += cam->r_bk_b.z - pose->r[2];
            for (int i = 0; i < 3; i++) {
                pw[i] = pose->C[0][i] * pb[0] + pose->C[1][i] * pb[1] + pose->C[2][i] * pb[2];
            }
            mfns_beacon_t *b = &m.beacon[m.count];
            b->id = m.count;
            b->p_w = mfns_v3((float)pw[0], (float)pw[1], (float)pw[2]);
            b->sigma_mm = 0.0f;
            m.count++;
        }
    }
    return m;
}

pt_dpose_t pt_random_pose(mfns_rng_t *rng, double pos_range)
{
    static const double eye[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    double c[3][3];
    pt_random_rotation(rng, MFNS_PI, eye, c);
    const double r[3] = {mfns_rng_range(rng, -pos_range, pos_range), mfns_rng_range(rng, -pos_range, pos_range),
                         mfns_rng_range(rng, -pos_range, pos_range)};
    return pt_pose(c, r);
}

int pt_random_visible_pose(const mfns_rig_t *rig, const mfns_beacon_map_t *map, double pos_range, int min_visible,
                           int max_tries, mfns_rng_t *rng, pt_dpose_t *pose)
{
    for (int t = 0; t < max_tries; t++) {
        *pose = pt_random_pose(rng, pos_range);
        int n = 0;
        for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
            for (int b = 0; b < map->count; b++) {
                const double pw[3] = {map->beacon[b].p_w.x, map->beacon[b].p_w.y, map->beacon[b].p_w.z};
                double uv[2];
                n += pt_project(&rig->cam[k], pose, pw, uv) ? 1 : 0;
            }
        }
        if (n >= min_visible) {
            return n;
        }
    }
    return 0;
}

mfns_pose_config_t pt_config(double sigma)
{
    mfns_pose_config_t cfg;
    mfns_pose_config_default(&cfg);
    cfg.sigma_px = (float)sigma;
    return cfg;
}

bool pt_assoc_right(const mfns_pose_solution_t *sol, const mfns_obs_frame_t *frame, const mfns_pose_assoc_t *truth)
{
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < frame->count[c] && i < MFNS_MAX_OBS_PER_CAMERA; i++) {
            if (sol->inlier[c][i] && sol->assoc.beacon[c][i] != truth->beacon[c][i]) {
                return false;
            }
        }
    }
    return true;
}

mfns_beacon_map_t pt_twin_map(const mfns_rig_t *rig, const int per_cam[3], mfns_rng_t *rng, mfns_beacon_index_t *idx)
{
    const double eye[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    const double zero[3] = {0, 0, 0};
    const pt_dpose_t at0 = pt_pose(eye, zero);
    mfns_beacon_map_t twin = pt_dense_map(rig, &at0, per_cam, 900, 1400, rng);
    const uint16_t n = twin.count;
    assert_true(2 * n <= MFNS_MAX_BEACONS);
    for (uint16_t i = 0; i < n; i++) {
        twin.beacon[n + i] = twin.beacon[i];
        twin.beacon[n + i].id = (uint16_t)(n + i);
        twin.beacon[n + i].p_w.x += 1500.0f;
        twin.beacon[i].sigma_mm = twin.beacon[n + i].sigma_mm = 0.4f;
    }
    twin.count = (uint16_t)(2 * n);
    mfns_bidx_params_t par;
    mfns_bidx_params_default(&par);
    assert_int_equal(mfns_bidx_build(rig, &twin, NULL, mfns_v3(-50, -50, -50), mfns_v3(1550, 50, 50), &par, idx),
                     MFNS_BIDX_OK);
    return twin;
}

void pt_build_index(const mfns_rig_t *rig, const mfns_beacon_map_t *map, double range_mm, uint8_t cert,
                    mfns_beacon_index_t *idx)
{
    mfns_bidx_params_t par;
    mfns_bidx_params_default(&par);
    par.cert_inliers = cert;
    const float r = (float)range_mm;
    assert_int_equal(mfns_bidx_build(rig, map, NULL, mfns_v3(-r, -r, -r), mfns_v3(r, r, r), &par, idx), MFNS_BIDX_OK);
}
