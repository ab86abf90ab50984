/* pose_init.c -- generalized three-point pose (see pose_init.h). Lengths are
 * scaled by 1/max_range so depths lie in (0, 1] and the degree-8 polynomial
 * is evaluated with O(1) coefficients in float. */
#include "pose_init.h"

#include <math.h>
#include <stddef.h>

#include "rotation.h"

#define PD 9          /* coefficients of a polynomial of degree <= 8 */
#define GRID 48       /* bracketing samples over the depth range */
#define BISECT 26     /* halvings: 2^-26 of a grid cell is below float resolution */
#define POLISH 4      /* Newton steps on the distance equations */

typedef struct {
    float c[PD];
    int deg;
} poly_t;

static poly_t pconst(float a)
{
    poly_t p = {{0}, 0};
    p.c[0] = a;
    return p;
}

static poly_t plin(float a0, float a1)
{
    poly_t p = {{0}, 1};
    p.c[0] = a0;
    p.c[1] = a1;
    return p;
}

static poly_t pquad(float a0, float a1, float a2)
{
    poly_t p = {{0}, 2};
    p.c[0] = a0;
    p.c[1] = a1;
    p.c[2] = a2;
    return p;
}

static poly_t pmul(const poly_t *a, const poly_t *b)
{
    poly_t r = {{0}, 0};
    r.deg = a->deg + b->deg > PD - 1 ? PD - 1 : a->deg + b->deg;
    for (int i = 0; i <= a->deg; i++) {
        for (int j = 0; j <= b->deg && i + j < PD; j++) {
            r.c[i + j] += a->c[i] * b->c[j];
        }
    }
    return r;
}

/* a += s b */
static void pacc(poly_t *a, const poly_t *b, float s)
{
    for (int i = 0; i <= b->deg; i++) {
        a->c[i] += s * b->c[i];
    }
    if (b->deg > a->deg) {
        a->deg = b->deg;
    }
}

static float peval(const poly_t *p, float x)
{
    float v = p->c[p->deg];
    for (int i = p->deg - 1; i >= 0; i--) {
        v = v * x + p->c[i];
    }
    return v;
}

void mfns_pose_ray(const mfns_camera_t *cam, float x, float y, mfns_v3_t *origin, mfns_v3_t *dir)
{
    *origin = cam->r_bk_b;
    if (!mfns_v3_normalize(mfns_m3_mul_v3(cam->C_k_b, mfns_v3(x, y, 1.0f)), dir)) {
        *dir = mfns_v3(0.0f, 0.0f, 1.0f);
    }
}

typedef struct {
    mfns_v3_t e12, e13, e23; /* c_i - c_j, scaled */
    mfns_v3_t d[3];
    float dd12, dd13, dd23;  /* squared beacon distances, scaled */
} gp3p_t;

/* The three distance equations at depths l, and their Jacobian. */
static void dist_eqs(const gp3p_t *g, const float l[3], float f[3], float jac[3][3])
{
    const mfns_v3_t v12 = mfns_v3_add(g->e12, mfns_v3_sub(mfns_v3_scale(g->d[0], l[0]), mfns_v3_scale(g->d[1], l[1])));
    const mfns_v3_t v13 = mfns_v3_add(g->e13, mfns_v3_sub(mfns_v3_scale(g->d[0], l[0]), mfns_v3_scale(g->d[2], l[2])));
    const mfns_v3_t v23 = mfns_v3_add(g->e23, mfns_v3_sub(mfns_v3_scale(g->d[1], l[1]), mfns_v3_scale(g->d[2], l[2])));
    f[0] = mfns_v3_dot(v12, v12) - g->dd12;
    f[1] = mfns_v3_dot(v13, v13) - g->dd13;
    f[2] = mfns_v3_dot(v23, v23) - g->dd23;
    if (jac != NULL) {
        jac[0][0] = 2.0f * mfns_v3_dot(v12, g->d[0]);
        jac[0][1] = -2.0f * mfns_v3_dot(v12, g->d[1]);
        jac[0][2] = 0.0f;
        jac[1][0] = 2.0f * mfns_v3_dot(v13, g->d[0]);
        jac[1][1] = 0.0f;
        jac[1][2] = -2.0f * mfns_v3_dot(v13, g->d[2]);
        jac[2][0] = 0.0f;
        jac[2][1] = 2.0f * mfns_v3_dot(v23, g->d[1]);
        jac[2][2] = -2.0f * mfns_v3_dot(v23, g->d[2]);
    }
}

/* Roots of lambda^2 + b lambda + c; returns how many (0 or 2). */
static int quad_roots(float b, float c, float r[2])
{
    const float disc = 0.25f * b * b - c;
    if (!(disc >= 0.0f)) {
        return 0;
    }
    const float s = sqrtf(disc);
    r[0] = -0.5f * b - s;
    r[1] = -0.5f * b + s;
    return 2;
}

static float fnorm(const float f[3]) { return fmaxf(fabsf(f[0]), fmaxf(fabsf(f[1]), fabsf(f[2]))); }

static void polish(const gp3p_t *g, float l[3])
{
    for (int it = 0; it < POLISH; it++) {
        float f[3], j[3][3];
        dist_eqs(g, l, f, j);
        const float det = j[0][0] * (j[1][1] * j[2][2] - j[1][2] * j[2][1]) -
                          j[0][1] * (j[1][0] * j[2][2] - j[1][2] * j[2][0]) +
                          j[0][2] * (j[1][0] * j[2][1] - j[1][1] * j[2][0]);
        if (!(fabsf(det) > 1e-12f)) {
            return;
        }
        /* Cramer's rule for J dl = -f */
        float dl[3];
        for (int k = 0; k < 3; k++) {
            float m[3][3];
            for (int r = 0; r < 3; r++) {
                for (int c = 0; c < 3; c++) {
                    m[r][c] = (c == k) ? -f[r] : j[r][c];
                }
            }
            dl[k] = (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                     m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])) /
                    det;
        }
        l[0] += dl[0];
        l[1] += dl[1];
        l[2] += dl[2];
    }
}

/* Depths (l1, l2) at a root l3: from the elimination when it is well
 * conditioned, otherwise by trying the quadratics' roots. */
static void back_substitute(const gp3p_t *g, const poly_t *pa, const poly_t *pb, float l3, float l[3])
{
    const float k12 = mfns_v3_dot(g->d[0], g->d[1]), k13 = mfns_v3_dot(g->d[0], g->d[2]);
    const float a = peval(pa, l3), b = peval(pb, l3);
    l[2] = l3;
    float best = INFINITY;
    if (fabsf(a) > 1e-6f) {
        const float l2 = -b / a;
        /* lambda1 from the difference of eq12 and eq13 (both monic in lambda1) */
        const float pr = (2.0f * mfns_v3_dot(g->d[0], g->e12) - 2.0f * k12 * l2) -
                         (2.0f * mfns_v3_dot(g->d[0], g->e13) - 2.0f * k13 * l3);
        const float qs = (l2 * l2 - 2.0f * mfns_v3_dot(g->d[1], g->e12) * l2 + mfns_v3_dot(g->e12, g->e12) - g->dd12) -
                         (l3 * l3 - 2.0f * mfns_v3_dot(g->d[2], g->e13) * l3 + mfns_v3_dot(g->e13, g->e13) - g->dd13);
        if (fabsf(pr) > 1e-6f) {
            l[0] = -qs / pr;
            l[1] = l2;
            float f[3];
            dist_eqs(g, l, f, NULL);
            best = fnorm(f);
        }
    }
    if (best < 1e-3f) {
        return;
    }
    /* fallback: eq23 gives lambda2, eq12 lambda1, keep the pair that fits eq13 */
    const float k23 = mfns_v3_dot(g->d[1], g->d[2]);
    float r2[2];
    const int n2 = quad_roots(2.0f * mfns_v3_dot(g->d[1], g->e23) - 2.0f * k23 * l3,
                              l3 * l3 - 2.0f * mfns_v3_dot(g->d[2], g->e23) * l3 + mfns_v3_dot(g->e23, g->e23) - g->dd23,
                              r2);
    for (int i = 0; i < n2; i++) {
        float r1[2];
        const int n1 = quad_roots(2.0f * mfns_v3_dot(g->d[0], g->e12) - 2.0f * k12 * r2[i],
                                  r2[i] * r2[i] - 2.0f * mfns_v3_dot(g->d[1], g->e12) * r2[i] +
                                      mfns_v3_dot(g->e12, g->e12) - g->dd12,
                                  r1);
        for (int j = 0; j < n1; j++) {
            const float t[3] = {r1[j], r2[i], l3};
            float f[3];
            dist_eqs(g, t, f, NULL);
            if (fnorm(f) < best) {
                best = fnorm(f);
                l[0] = t[0];
                l[1] = t[1];
            }
        }
    }
}

/* Rotation taking the triad of three world points onto that of the body points. */
static bool triad(const mfns_v3_t p[3], const mfns_v3_t x[3], mfns_pose_t *pose)
{
    mfns_v3_t e1, e3, f1, f3;
    if (!mfns_v3_normalize(mfns_v3_sub(x[1], x[0]), &e1) ||
        !mfns_v3_normalize(mfns_v3_cross(e1, mfns_v3_sub(x[2], x[0])), &e3) ||
        !mfns_v3_normalize(mfns_v3_sub(p[1], p[0]), &f1) ||
        !mfns_v3_normalize(mfns_v3_cross(f1, mfns_v3_sub(p[2], p[0])), &f3)) {
        return false;
    }
    const mfns_v3_t e2 = mfns_v3_cross(e3, e1), f2 = mfns_v3_cross(f3, f1);
    const float ev[3][3] = {{e1.x, e1.y, e1.z}, {e2.x, e2.y, e2.z}, {e3.x, e3.y, e3.z}};
    const float fv[3][3] = {{f1.x, f1.y, f1.z}, {f2.x, f2.y, f2.z}, {f3.x, f3.y, f3.z}};
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 3; c++) {
            pose->C_w_b.m[r][c] = fv[0][r] * ev[0][c] + fv[1][r] * ev[1][c] + fv[2][r] * ev[2][c];
        }
    }
    const mfns_v3_t pm = mfns_v3_scale(mfns_v3_add(mfns_v3_add(p[0], p[1]), p[2]), 1.0f / 3.0f);
    const mfns_v3_t xm = mfns_v3_scale(mfns_v3_add(mfns_v3_add(x[0], x[1]), x[2]), 1.0f / 3.0f);
    pose->r_bw_b = mfns_v3_sub(pm, mfns_m3_mul_v3(pose->C_w_b, xm));
    return true;
}

int mfns_gp3p(const mfns_v3_t c[3], const mfns_v3_t d[3], const mfns_v3_t x_w[3], float min_range_mm,
              float max_range_mm, mfns_pose_t out[MFNS_GP3P_MAX_SOLUTIONS])
{
    if (!(max_range_mm > 0.0f) || !(min_range_mm >= 0.0f) || !(min_range_mm < max_range_mm)) {
        return 0;
    }
    const float s = 1.0f / max_range_mm;
    gp3p_t g;
    for (int i = 0; i < 3; i++) {
        if (!mfns_v3_normalize(d[i], &g.d[i])) {
            return 0;
        }
    }
    g.e12 = mfns_v3_scale(mfns_v3_sub(c[0], c[1]), s);
    g.e13 = mfns_v3_scale(mfns_v3_sub(c[0], c[2]), s);
    g.e23 = mfns_v3_scale(mfns_v3_sub(c[1], c[2]), s);
    const mfns_v3_t x12 = mfns_v3_scale(mfns_v3_sub(x_w[0], x_w[1]), s);
    const mfns_v3_t x13 = mfns_v3_scale(mfns_v3_sub(x_w[0], x_w[2]), s);
    const mfns_v3_t x23 = mfns_v3_scale(mfns_v3_sub(x_w[1], x_w[2]), s);
    g.dd12 = mfns_v3_dot(x12, x12);
    g.dd13 = mfns_v3_dot(x13, x13);
    g.dd23 = mfns_v3_dot(x23, x23);
    if (!(g.dd12 > 1e-12f && g.dd13 > 1e-12f && g.dd23 > 1e-12f)) {
        return 0;
    }
    const float k12 = mfns_v3_dot(g.d[0], g.d[1]), k13 = mfns_v3_dot(g.d[0], g.d[2]),
                k23 = mfns_v3_dot(g.d[1], g.d[2]);
    /* eq12: l1^2 + P(l2) l1 + Q(l2); eq13: l1^2 + R(l3) l1 + S(l3); eq23: l2^2 + M(l3) l2 + N(l3) */
    const float p0 = 2.0f * mfns_v3_dot(g.d[0], g.e12), p1 = -2.0f * k12;
    const float q0 = mfns_v3_dot(g.e12, g.e12) - g.dd12, q1 = -2.0f * mfns_v3_dot(g.d[1], g.e12);
    const poly_t rp = plin(2.0f * mfns_v3_dot(g.d[0], g.e13), -2.0f * k13);
    const poly_t sp = pquad(mfns_v3_dot(g.e13, g.e13) - g.dd13, -2.0f * mfns_v3_dot(g.d[2], g.e13), 1.0f);
    const poly_t mp = plin(2.0f * mfns_v3_dot(g.d[1], g.e23), -2.0f * k23);
    const poly_t np = pquad(mfns_v3_dot(g.e23, g.e23) - g.dd23, -2.0f * mfns_v3_dot(g.d[2], g.e23), 1.0f);
    /* Bivariate polynomials: index = power of l2, entries polynomials in l3. */
    poly_t qs[3], pr[2], psqr[3];
    qs[0] = pconst(q0);
    pacc(&qs[0], &sp, -1.0f);
    qs[1] = pconst(q1);
    qs[2] = pconst(1.0f);
    pr[0] = pconst(p0);
    pacc(&pr[0], &rp, -1.0f);
    pr[1] = pconst(p1);
    /* P S - Q R */
    psqr[0] = pconst(0.0f);
    pacc(&psqr[0], &sp, p0);
    pacc(&psqr[0], &rp, -q0);
    psqr[1] = pconst(0.0f);
    pacc(&psqr[1], &sp, p1);
    pacc(&psqr[1], &rp, -q1);
    psqr[2] = pconst(0.0f);
    pacc(&psqr[2], &rp, -1.0f);
    /* G = (Q - S)^2 + (P - R)(P S - Q R): the resultant in l1, quartic in l2 */
    poly_t gq[5];
    for (int i = 0; i < 5; i++) {
        gq[i] = pconst(0.0f);
    }
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            const poly_t t = pmul(&qs[i], &qs[j]);
            pacc(&gq[i + j], &t, 1.0f);
        }
    }
    for (int i = 0; i < 2; i++) {
        for (int j = 0; j < 3; j++) {
            const poly_t t = pmul(&pr[i], &psqr[j]);
            pacc(&gq[i + j], &t, 1.0f);
        }
    }
    /* G mod (l2^2 + M l2 + N) = A l2 + B */
    for (int i = 4; i >= 2; i--) {
        const poly_t tm = pmul(&gq[i], &mp), tn = pmul(&gq[i], &np);
        pacc(&gq[i - 1], &tm, -1.0f);
        pacc(&gq[i - 2], &tn, -1.0f);
        gq[i] = pconst(0.0f);
    }
    const poly_t pa = gq[1], pb = gq[0];
    /* resultant in l2: A^2 N - A B M + B^2 */
    const poly_t aa = pmul(&pa, &pa), ab = pmul(&pa, &pb);
    poly_t f = pmul(&pb, &pb);
    const poly_t t1 = pmul(&aa, &np), t2 = pmul(&ab, &mp);
    pacc(&f, &t1, 1.0f);
    pacc(&f, &t2, -1.0f);

    const float lo = min_range_mm * s, hi = 1.0f;
    const float step = (hi - lo) / (float)GRID;
    int nsol = 0;
    float xa = lo, fa = peval(&f, xa);
    for (int k = 1; k <= GRID && nsol < MFNS_GP3P_MAX_SOLUTIONS; k++) {
        const float xb = lo + step * (float)k, fb = peval(&f, xb);
        if ((fa < 0.0f) != (fb < 0.0f) || fb == 0.0f) {
            float a = xa, b = xb, fla = fa;
            for (int it = 0; it < BISECT; it++) {
                const float mid = 0.5f * (a + b), fm = peval(&f, mid);
                if ((fm < 0.0f) == (fla < 0.0f)) {
                    a = mid;
                    fla = fm;
                } else {
                    b = mid;
                }
            }
            float l[3];
            back_substitute(&g, &pa, &pb, 0.5f * (a + b), l);
            polish(&g, l);
            float fe[3];
            dist_eqs(&g, l, fe, NULL);
            const float tol = 1e-4f * fmaxf(g.dd12, fmaxf(g.dd13, g.dd23));
            if (fnorm(fe) < tol && l[0] > 0.5f * lo && l[1] > 0.5f * lo && l[2] > 0.5f * lo && l[0] < 2.0f &&
                l[1] < 2.0f && l[2] < 2.0f) {
                mfns_v3_t pb3[3];
                for (int i = 0; i < 3; i++) {
                    pb3[i] = mfns_v3_add(c[i], mfns_v3_scale(g.d[i], l[i] * max_range_mm));
                }
                mfns_pose_t pose;
                bool dup = false;
                if (triad(pb3, x_w, &pose)) {
                    for (int q = 0; q < nsol; q++) {
                        if (mfns_v3_norm(mfns_v3_sub(out[q].r_bw_b, pose.r_bw_b)) < 1e-3f * max_range_mm &&
                            mfns_rot_angle_between(out[q].C_w_b, pose.C_w_b) < 1e-3f) {
                            dup = true;
                        }
                    }
                    if (!dup) {
                        out[nsol++] = pose;
                    }
                }
            }
        }
        xa = xb;
        fa = fb;
    }
    return nsol;
}
