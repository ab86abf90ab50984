/* pose_init.c -- generalized three-point pose (see pose_init.h). Lengths are
 * scaled by 1/max_range so depths lie in (0, 1].
 *
 * Double precision, by necessity: the elimination polynomial is built by
 * products that cancel heavily, and the true root often sits next to a
 * second one (a nearly double root); in float its values near the root are
 * rounding noise (measured: 2% of random configurations lost). Both flight
 * targets have double-precision FPUs (Cortex-M7 fpv5-d16, aarch64). Only this
 * solver uses double; its output pose is float. */
#include "firmware/nav/pose/pose_init.h"

#include <math.h>
#include <stddef.h>

#include "math/core_inline.h"
#include "firmware/nav/pose/pose_init_internal.h"
#include "math/rotation.h"

#define POLISH 4 /* Newton steps on the distance equations */

typedef struct {
    double x, y, z;
} dv3_t;

static dv3_t dv(mfns_v3_t a) { return (dv3_t){(double)a.x, (double)a.y, (double)a.z}; }
static dv3_t dsub(const dv3_t *a, const dv3_t *b) { return (dv3_t){a->x - b->x, a->y - b->y, a->z - b->z}; }
static dv3_t dadd(const dv3_t *a, const dv3_t *b) { return (dv3_t){a->x + b->x, a->y + b->y, a->z + b->z}; }
static dv3_t dscale(const dv3_t *a, double s) { return (dv3_t){a->x * s, a->y * s, a->z * s}; }
/* (a - b) s; out of line on a build for size (LTO would copy it into both
 * sites of the pair loop of mfns_gp3p: 64 B, docs/budgets.md) */
MFNS_OUT_OF_LINE
static dv3_t dsub_scaled(const dv3_t *a, const dv3_t *b, double s)
{
    const dv3_t d = dsub(a, b);
    return dscale(&d, s);
}
/* a . b, by address: a call by value (or an inlined copy)
 * loads both vectors first; -208 B on the Cortex-M7 (docs/budgets.md) */
static double ddot(const dv3_t *a, const dv3_t *b)
{
    return a->x * b->x + a->y * b->y + a->z * b->z;
}
static dv3_t dcross(dv3_t a, dv3_t b)
{
    return (dv3_t){a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
/* a / |a| into out (which may be a) */
static bool dnormalize(const dv3_t *a, dv3_t *out)
{
    const double n = sqrt(ddot(a, a));
    if (!(n > 1e-300)) {
        return false;
    }
    *out = dscale(a, 1.0 / n);
    return true;
}

void mfns_pose_ray(const mfns_camera_t *cam, float x, float y, mfns_v3_t *origin, mfns_v3_t *dir)
{
    *origin = cam->r_bk_b;
    if (!mfns_v3_normalize(mfns_m3_mul_v3_at(&cam->C_k_b, mfns_v3(x, y, 1.0f)), dir)) {
        *dir = mfns_v3(0.0f, 0.0f, 1.0f);
    }
}

/* The rays of the three distance equations, in order: 12, 13, 23. */
static const int PAIR[3][2] = {{0, 1}, {0, 2}, {1, 2}};

/* The distance equation of rays i < j, |e + l_i d_i - l_j d_j|^2 = dd with
 * e = c_i - c_j, and its products (computed once per solve: the elimination
 * and the back-substitution both need them). */
typedef struct {
    dv3_t e;   /* c_i - c_j, scaled */
    double dd; /* squared beacon distance, scaled */
    double k;  /* d_i . d_j */
    double die, dje, ee; /* d_i . e, d_j . e, e . e */
} pair_eq_t;

typedef struct {
    dv3_t d[3];
    pair_eq_t eq[3]; /* PAIR order */
} gp3p_t;

/* The equation as a monic quadratic in l_i at l_j:
 * l_i^2 + b l_i + c with b = 2 d_i.e - 2 k l_j, c = l_j^2 - 2 d_j.e l_j + e.e - dd. */
static void monic_at(const pair_eq_t *q, double lj, double *b, double *c)
{
    *b = 2.0 * q->die - 2.0 * q->k * lj;
    *c = lj * lj - 2.0 * q->dje * lj + q->ee - q->dd;
}

/* The three distance equations at depths l, and their Jacobian. */
static void dist_eqs(const gp3p_t *g, const double l[3], double f[3], double jac[3][3])
{
    for (int k = 0; k < 3; k++) {
        const int i = PAIR[k][0], j = PAIR[k][1];
        const dv3_t si = dscale(&g->d[i], l[i]), sj = dscale(&g->d[j], l[j]);
        const dv3_t t = dsub(&si, &sj);
        const dv3_t v = dadd(&g->eq[k].e, &t);
        f[k] = ddot(&v, &v) - g->eq[k].dd;
        if (jac != NULL) {
            jac[k][i] = 2.0 * ddot(&v, &g->d[i]);
            jac[k][j] = -2.0 * ddot(&v, &g->d[j]);
            jac[k][3 - i - j] = 0.0; /* the third ray's depth is not in it */
        }
    }
}

/* Roots of lambda^2 + b lambda + c; returns how many (0 or 2). */
static int quad_roots(double b, double c, double r[2])
{
    const double disc = 0.25 * b * b - c;
    if (!(disc >= 0.0)) {
        return 0;
    }
    const double s = sqrt(disc);
    r[0] = -0.5 * b - s;
    r[1] = -0.5 * b + s;
    return 2;
}


static double fnorm(const double f[3]) { return fmax(fabs(f[0]), fmax(fabs(f[1]), fabs(f[2]))); }

/* det m, expanded along the first row (the Jacobian's and Cramer's rule's) */
static double det3(const double m[3][3])
{
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

static void polish(const gp3p_t *g, double l[3])
{
    for (int it = 0; it < POLISH; it++) {
        double f[3], j[3][3];
        dist_eqs(g, l, f, j);
        if (fnorm(f) < 1e-15) {
            return;
        }
        const double det = det3(j);
        if (!(fabs(det) > 1e-12)) {
            return;
        }
        /* Cramer's rule for J dl = -f */
        double dl[3];
        for (int k = 0; k < 3; k++) {
            double m[3][3];
            for (int r = 0; r < 3; r++) {
                for (int c = 0; c < 3; c++) {
                    m[r][c] = (c == k) ? -f[r] : j[r][c];
                }
            }
            dl[k] = det3(m) / det;
        }
        l[0] += dl[0];
        l[1] += dl[1];
        l[2] += dl[2];
    }
}

/* Depths (l1, l2) at a root l3: from the elimination when it is well
 * conditioned, otherwise by trying the quadratics' roots. */
static void back_substitute(const gp3p_t *g, const mfns_poly_t *pa, const mfns_poly_t *pb, double l3, double l[3])
{
    const double a = mfns_poly_eval(pa, l3), b = mfns_poly_eval(pb, l3);
    l[2] = l3;
    double best = INFINITY;
    if (fabs(a) > 1e-6) {
        const double l2 = -b / a;
        /* lambda1 from the difference of eq12 and eq13 (both monic in lambda1) */
        double b12, c12, b13, c13;
        monic_at(&g->eq[0], l2, &b12, &c12);
        monic_at(&g->eq[1], l3, &b13, &c13);
        const double pr = b12 - b13, qs = c12 - c13;
        if (fabs(pr) > 1e-6) {
            l[0] = -qs / pr;
            l[1] = l2;
            double f[3];
            dist_eqs(g, l, f, NULL);
            best = fnorm(f);
        }
    }
    if (best < 1e-3) {
        return;
    }
    /* fallback: eq23 gives lambda2, eq12 lambda1, keep the pair that fits eq13 */
    double r2[2], b23, c23;
    monic_at(&g->eq[2], l3, &b23, &c23);
    const int n2 = quad_roots(b23, c23, r2);
    for (int i = 0; i < n2; i++) {
        double r1[2], b12, c12;
        monic_at(&g->eq[0], r2[i], &b12, &c12);
        const int n1 = quad_roots(b12, c12, r1);
        for (int j = 0; j < n1; j++) {
            const double t[3] = {r1[j], r2[i], l3};
            double f[3];
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
static bool triad(const dv3_t p[3], const dv3_t x[3], mfns_pose_t *pose)
{
    dv3_t e1 = dsub(&x[1], &x[0]), f1 = dsub(&p[1], &p[0]);
    if (!dnormalize(&e1, &e1) || !dnormalize(&f1, &f1)) {
        return false;
    }
    dv3_t e3 = dcross(e1, dsub(&x[2], &x[0])), f3 = dcross(f1, dsub(&p[2], &p[0]));
    if (!dnormalize(&e3, &e3) || !dnormalize(&f3, &f3)) {
        return false;
    }
    const dv3_t e2 = dcross(e3, e1), f2 = dcross(f3, f1);
    const double ev[3][3] = {{e1.x, e1.y, e1.z}, {e2.x, e2.y, e2.z}, {e3.x, e3.y, e3.z}};
    const double fv[3][3] = {{f1.x, f1.y, f1.z}, {f2.x, f2.y, f2.z}, {f3.x, f3.y, f3.z}};
    double rm[3][3];
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 3; c++) {
            rm[r][c] = fv[0][r] * ev[0][c] + fv[1][r] * ev[1][c] + fv[2][r] * ev[2][c];
            pose->C_w_b.m[r][c] = (float)rm[r][c];
        }
    }
    const dv3_t p01 = dadd(&p[0], &p[1]), x01 = dadd(&x[0], &x[1]);
    const dv3_t ps = dadd(&p01, &p[2]), xs = dadd(&x01, &x[2]);
    const dv3_t pm = dscale(&ps, 1.0 / 3.0), xm = dscale(&xs, 1.0 / 3.0);
    const dv3_t rx = {rm[0][0] * xm.x + rm[0][1] * xm.y + rm[0][2] * xm.z,
                      rm[1][0] * xm.x + rm[1][1] * xm.y + rm[1][2] * xm.z,
                      rm[2][0] * xm.x + rm[2][1] * xm.y + rm[2][2] * xm.z};
    const dv3_t t = dsub(&pm, &rx);
    pose->r_bw_b = mfns_v3((float)t.x, (float)t.y, (float)t.z);
    return true;
}

int mfns_gp3p(const mfns_v3_t c[3], const mfns_v3_t d[3], const mfns_v3_t x_w[3], float min_range_mm,
              float max_range_mm, mfns_pose_t out[MFNS_GP3P_MAX_SOLUTIONS])
{
    const mfns_v3_t *const pc[3] = {&c[0], &c[1], &c[2]}, *const pd[3] = {&d[0], &d[1], &d[2]};
    const mfns_v3_t *const px[3] = {&x_w[0], &x_w[1], &x_w[2]};
    return mfns_gp3p_at(pc, pd, px, min_range_mm, max_range_mm, out);
}

int mfns_gp3p_at(const mfns_v3_t *const c[3], const mfns_v3_t *const d[3], const mfns_v3_t *const x_w[3],
                 float min_range_mm, float max_range_mm, mfns_pose_t out[MFNS_GP3P_MAX_SOLUTIONS])
{
    if (!(max_range_mm > 0.0f) || !(min_range_mm >= 0.0f) || !(min_range_mm < max_range_mm)) {
        return 0;
    }
    const double s = 1.0 / (double)max_range_mm;
    gp3p_t g;
    dv3_t cd[3], xd[3];
    for (int i = 0; i < 3; i++) {
        g.d[i] = dv(*d[i]);
        if (!dnormalize(&g.d[i], &g.d[i])) {
            return 0;
        }
        cd[i] = dv(*c[i]);
        xd[i] = dv(*x_w[i]);
    }
    for (int k = 0; k < 3; k++) {
        const int i = PAIR[k][0], j = PAIR[k][1];
        pair_eq_t *q = &g.eq[k];
        q->e = dsub_scaled(&cd[i], &cd[j], s);
        const dv3_t x = dsub_scaled(&xd[i], &xd[j], s);
        q->dd = ddot(&x, &x);
        if (!(q->dd > 1e-12)) {
            return 0;
        }
        q->k = ddot(&g.d[i], &g.d[j]);
        q->die = ddot(&g.d[i], &q->e);
        q->dje = ddot(&g.d[j], &q->e);
        q->ee = ddot(&q->e, &q->e);
    }
    const pair_eq_t *q12 = &g.eq[0], *q13 = &g.eq[1], *q23 = &g.eq[2];
    /* eq12: l1^2 + P(l2) l1 + Q(l2); eq13: l1^2 + R(l3) l1 + S(l3); eq23: l2^2 + M(l3) l2 + N(l3) */
    const double p0 = 2.0 * q12->die, p1 = -2.0 * q12->k;
    const double q0 = q12->ee - q12->dd, q1 = -2.0 * q12->dje;
    /* R = r0 + r1 l3, S = s0 + s1 l3 + l3^2, M = m0 + m1 l3, N = n0 + n1 l3 + l3^2 */
    const double r[2] = {2.0 * q13->die, -2.0 * q13->k};
    const double sq[3] = {q13->ee - q13->dd, -2.0 * q13->dje, 1.0};
    const double m[2] = {2.0 * q23->die, -2.0 * q23->k};
    const double nq[3] = {q23->ee - q23->dd, -2.0 * q23->dje, 1.0};
    /* Bivariate polynomials in (l2, l3), as coefficients of powers of l2,
     * each a polynomial in l3 (fixed degrees, written out: this runs once
     * per identification hypothesis). Eq12 minus eq13 is linear in l1:
     *   Q - S = qs0 + q1 l2 + l2^2,  P - R = pr0 + p1 l2,
     *   P S - Q R = psqr0 + psqr1 l2 + psqr2 l2^2. */
    const double qs0[3] = {q0 - sq[0], -sq[1], -1.0};
    const double pr0[2] = {p0 - r[0], -r[1]};
    const double psqr0[3] = {p0 * sq[0] - q0 * r[0], p0 * sq[1] - q0 * r[1], p0};
    const double psqr1[3] = {p1 * sq[0] - q1 * r[0], p1 * sq[1] - q1 * r[1], p1};
    const double psqr2[2] = {-r[0], -r[1]};
    /* G = (Q - S)^2 + (P - R)(P S - Q R): the resultant in l1, quartic in l2
     * (gq[k] multiplies l2^k; gq4 = 1) */
    double gq0[5] = {0}, gq1[4] = {0}, gq2[3] = {0}, gq3[2] = {0};
    mfns_poly_macc(gq0, qs0, 2, qs0, 2, 1.0);
    mfns_poly_macc(gq0, pr0, 1, psqr0, 2, 1.0);
    for (int i = 0; i < 3; i++) {
        gq1[i] += 2.0 * q1 * qs0[i] + p1 * psqr0[i];
        gq2[i] += 2.0 * qs0[i] + p1 * psqr1[i];
    }
    mfns_poly_macc(gq1, pr0, 1, psqr1, 2, 1.0);
    gq2[0] += q1 * q1;
    mfns_poly_macc(gq2, pr0, 1, psqr2, 1, 1.0);
    gq3[0] = 2.0 * q1 + p1 * psqr2[0];
    gq3[1] = p1 * psqr2[1];
    /* G mod (l2^2 + M l2 + N) = A l2 + B */
    gq3[0] -= m[0];
    gq3[1] -= m[1];
    for (int i = 0; i < 3; i++) {
        gq2[i] -= nq[i];
    }
    mfns_poly_macc(gq2, gq3, 1, m, 1, -1.0);
    mfns_poly_macc(gq1, gq3, 1, nq, 2, -1.0);
    mfns_poly_macc(gq1, gq2, 2, m, 1, -1.0);
    mfns_poly_macc(gq0, gq2, 2, nq, 2, -1.0);
    mfns_poly_t pa = {{0}, 3}, pb = {{0}, 4};
    for (int i = 0; i < 4; i++) {
        pa.c[i] = gq1[i];
    }
    for (int i = 0; i < 5; i++) {
        pb.c[i] = gq0[i];
    }
    /* resultant in l2: A^2 N - A B M + B^2 (degree 8 in l3) */
    double aa[7] = {0}, ab[8] = {0};
    mfns_poly_t f = {{0}, 8};
    mfns_poly_macc(f.c, gq0, 4, gq0, 4, 1.0);
    mfns_poly_macc(aa, gq1, 3, gq1, 3, 1.0);
    mfns_poly_macc(ab, gq1, 3, gq0, 4, 1.0);
    mfns_poly_macc(f.c, aa, 6, nq, 2, 1.0);
    mfns_poly_macc(f.c, ab, 7, m, 1, -1.0);

    const double lo = (double)min_range_mm * s, hi = 1.0;
    double roots[MFNS_POLY_COEFS - 1];
    const int nroots = mfns_poly_real_roots(&f, lo, hi, roots);
    const double tol = 1e-4 * fmax(q12->dd, fmax(q13->dd, q23->dd));
    int nsol = 0;
    for (int k = 0; k < nroots && nsol < MFNS_GP3P_MAX_SOLUTIONS; k++) {
        double l[3];
        back_substitute(&g, &pa, &pb, roots[k], l);
        /* most roots of the elimination put a beacon behind its camera:
         * drop them before the polish (a margin of 1 % of the range) */
        if (!(l[0] > -0.01 && l[1] > -0.01)) {
            continue;
        }
        polish(&g, l);
        double fe[3];
        dist_eqs(&g, l, fe, NULL);
        /* the range interval bounds the third depth only (it is the third
         * beacon's); the first two need only be in front (1 mm) */
        const double front = (double)MFNS_CAM_MIN_DEPTH_MM * s;
        if (!(fnorm(fe) < tol) || !(l[0] > front && l[1] > front && l[2] > 0.5 * lo) ||
            !(l[0] < 2.0 && l[1] < 2.0 && l[2] < 2.0)) {
            continue;
        }
        dv3_t pb3[3];
        for (int i = 0; i < 3; i++) {
            const dv3_t along = dscale(&g.d[i], l[i] / s);
            pb3[i] = dadd(&cd[i], &along);
        }
        /* solved in the next free slot, which a duplicate leaves free */
        mfns_pose_t *pose = &out[nsol];
        if (!triad(pb3, xd, pose)) {
            continue;
        }
        bool dup = false;
        for (int q = 0; q < nsol && !dup; q++) {
            dup = mfns_v3_norm(mfns_v3_sub(out[q].r_bw_b, pose->r_bw_b)) < 1e-3f * max_range_mm &&
                  mfns_rot_angle_between_at(&out[q].C_w_b, &pose->C_w_b) < 1e-3f;
        }
        if (!dup) {
            nsol++;
        }
    }
    return nsol;
}
