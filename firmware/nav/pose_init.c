/* pose_init.c -- generalized three-point pose (see pose_init.h). Lengths are
 * scaled by 1/max_range so depths lie in (0, 1].
 *
 * Double precision, by necessity: the elimination polynomial is built by
 * products that cancel heavily, and the true root often sits next to a
 * second one (a nearly double root); in float its values near the root are
 * rounding noise (measured: 2% of random configurations lost). Both flight
 * targets have double-precision FPUs (Cortex-M7 fpv5-d16, aarch64). Only this
 * solver uses double; its output pose is float. */
#include "pose_init.h"

#include <math.h>
#include <stddef.h>

#include "rotation.h"

#define PD 9          /* coefficients of a polynomial of degree <= 8 */
#define ROOT_ITERS 40 /* bracketing iterations per root (Illinois: ~10 suffice) */
#define POLISH 4      /* Newton steps on the distance equations */

typedef struct {
    double c[PD];
    int deg;
} poly_t;

typedef struct {
    double x, y, z;
} dv3_t;

static dv3_t dv(mfns_v3_t a) { return (dv3_t){(double)a.x, (double)a.y, (double)a.z}; }
static dv3_t dsub(dv3_t a, dv3_t b) { return (dv3_t){a.x - b.x, a.y - b.y, a.z - b.z}; }
static dv3_t dadd(dv3_t a, dv3_t b) { return (dv3_t){a.x + b.x, a.y + b.y, a.z + b.z}; }
static dv3_t dscale(dv3_t a, double s) { return (dv3_t){a.x * s, a.y * s, a.z * s}; }
static double ddot(dv3_t a, dv3_t b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static dv3_t dcross(dv3_t a, dv3_t b)
{
    return (dv3_t){a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
static bool dnormalize(dv3_t a, dv3_t *out)
{
    const double n = sqrt(ddot(a, a));
    if (!(n > 1e-300)) {
        return false;
    }
    *out = dscale(a, 1.0 / n);
    return true;
}

static poly_t pconst(double a)
{
    poly_t p = {{0}, 0};
    p.c[0] = a;
    return p;
}

static poly_t plin(double a0, double a1)
{
    poly_t p = {{0}, 1};
    p.c[0] = a0;
    p.c[1] = a1;
    return p;
}

static poly_t pquad(double a0, double a1, double a2)
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
static void pacc(poly_t *a, const poly_t *b, double s)
{
    for (int i = 0; i <= b->deg; i++) {
        a->c[i] += s * b->c[i];
    }
    if (b->deg > a->deg) {
        a->deg = b->deg;
    }
}

static double peval(const poly_t *p, double x)
{
    double v = p->c[p->deg];
    for (int i = p->deg - 1; i >= 0; i--) {
        v = v * x + p->c[i];
    }
    return v;
}

/* Root of p in [a, b] where p(a), p(b) differ in sign and p is monotonic:
 * Illinois regula falsi, bounded. */
static double bracket_root(const poly_t *p, double a, double b, double fa, double fb, double tol)
{
    double x = 0.5 * (a + b);
    int side = 0;
    for (int it = 0; it < ROOT_ITERS && b - a > tol; it++) {
        x = (a * fb - b * fa) / (fb - fa);
        if (!(x > a && x < b)) {
            x = 0.5 * (a + b);
        }
        const double fx = peval(p, x);
        if (fx == 0.0) {
            break;
        }
        if ((fx < 0.0) == (fa < 0.0)) {
            a = x;
            fa = fx;
            if (side == -1) {
                fb *= 0.5;
            }
            side = -1;
        } else {
            b = x;
            fb = fx;
            if (side == 1) {
                fa *= 0.5;
            }
            side = 1;
        }
    }
    return x;
}

/* All real roots of f in (lo, hi), by isolation with the derivatives: the
 * roots of f^(k+1) split [lo, hi] into intervals where f^(k) is monotonic,
 * hence holds at most one root, found by a bracketing iteration. Unlike a
 * sampling grid this cannot step over two close roots. */
static int real_roots(const poly_t *f, double lo, double hi, double roots[PD - 1])
{
    poly_t der[PD];
    der[0] = *f;
    while (der[0].deg > 0 && der[0].c[der[0].deg] == 0.0) {
        der[0].deg--;
    }
    const int n = der[0].deg;
    for (int k = 1; k <= n; k++) {
        der[k].deg = der[k - 1].deg - 1;
        for (int i = 0; i <= der[k].deg; i++) {
            der[k].c[i] = (double)(i + 1) * der[k - 1].c[i + 1];
        }
    }
    /* |f| is at most scale on [0, 1]; values below near_zero are at the level
     * of the float rounding of the inputs (relative 1e-7) */
    double scale = 0.0;
    for (int i = 0; i <= n; i++) {
        scale += fabs(der[0].c[i]);
    }
    const double near_zero = 1e-7 * scale;
    /* der[n] is a nonzero constant: no roots */
    double crit[PD + 1];
    int nc = 0;
    for (int k = n - 1; k >= 0; k--) {
        double pts[PD + 1];
        int np = 0;
        pts[np++] = lo;
        for (int i = 0; i < nc; i++) {
            pts[np++] = crit[i];
        }
        pts[np++] = hi;
        double val[PD + 1];
        for (int i = 0; i < np; i++) {
            val[i] = peval(&der[k], pts[i]);
        }
        int nr = 0;
        for (int i = 1; i < np && nr < PD - 1; i++) {
            if (val[i - 1] == 0.0 && i == 1) {
                crit[nr++] = pts[0];
            } else if (val[i] == 0.0) {
                crit[nr++] = pts[i];
            } else if ((val[i - 1] < 0.0) != (val[i] < 0.0) && val[i - 1] != 0.0) {
                /* critical points only separate intervals: 1e-7 is ample */
                crit[nr++] = bracket_root(&der[k], pts[i - 1], pts[i], val[i - 1], val[i], k == 0 ? 1e-10 : 1e-6);
            }
        }
        /* (nearly) double roots of f: it touches zero at its own extremum,
         * without a sign change on either side */
        for (int i = 1; k == 0 && i < np - 1 && nr < PD - 1; i++) {
            if (fabs(val[i]) <= near_zero && (val[i - 1] < 0.0) == (val[i] < 0.0) &&
                (val[i + 1] < 0.0) == (val[i] < 0.0)) {
                crit[nr++] = pts[i];
            }
        }
        nc = nr;
    }
    for (int i = 0; i < nc; i++) {
        roots[i] = crit[i];
    }
    return nc;
}

void mfns_pose_ray(const mfns_camera_t *cam, float x, float y, mfns_v3_t *origin, mfns_v3_t *dir)
{
    *origin = cam->r_bk_b;
    if (!mfns_v3_normalize(mfns_m3_mul_v3(cam->C_k_b, mfns_v3(x, y, 1.0f)), dir)) {
        *dir = mfns_v3(0.0f, 0.0f, 1.0f);
    }
}

typedef struct {
    dv3_t e12, e13, e23; /* c_i - c_j, scaled */
    dv3_t d[3];
    double dd12, dd13, dd23;  /* squared beacon distances, scaled */
} gp3p_t;

/* The three distance equations at depths l, and their Jacobian. */
static void dist_eqs(const gp3p_t *g, const double l[3], double f[3], double jac[3][3])
{
    const dv3_t v12 = dadd(g->e12, dsub(dscale(g->d[0], l[0]), dscale(g->d[1], l[1])));
    const dv3_t v13 = dadd(g->e13, dsub(dscale(g->d[0], l[0]), dscale(g->d[2], l[2])));
    const dv3_t v23 = dadd(g->e23, dsub(dscale(g->d[1], l[1]), dscale(g->d[2], l[2])));
    f[0] = ddot(v12, v12) - g->dd12;
    f[1] = ddot(v13, v13) - g->dd13;
    f[2] = ddot(v23, v23) - g->dd23;
    if (jac != NULL) {
        jac[0][0] = 2.0 * ddot(v12, g->d[0]);
        jac[0][1] = -2.0 * ddot(v12, g->d[1]);
        jac[0][2] = 0.0;
        jac[1][0] = 2.0 * ddot(v13, g->d[0]);
        jac[1][1] = 0.0;
        jac[1][2] = -2.0 * ddot(v13, g->d[2]);
        jac[2][0] = 0.0;
        jac[2][1] = 2.0 * ddot(v23, g->d[1]);
        jac[2][2] = -2.0 * ddot(v23, g->d[2]);
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

static void polish(const gp3p_t *g, double l[3])
{
    for (int it = 0; it < POLISH; it++) {
        double f[3], j[3][3];
        dist_eqs(g, l, f, j);
        if (fnorm(f) < 1e-15) {
            return;
        }
        const double det = j[0][0] * (j[1][1] * j[2][2] - j[1][2] * j[2][1]) -
                          j[0][1] * (j[1][0] * j[2][2] - j[1][2] * j[2][0]) +
                          j[0][2] * (j[1][0] * j[2][1] - j[1][1] * j[2][0]);
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
static void back_substitute(const gp3p_t *g, const poly_t *pa, const poly_t *pb, double l3, double l[3])
{
    const double k12 = ddot(g->d[0], g->d[1]), k13 = ddot(g->d[0], g->d[2]);
    const double a = peval(pa, l3), b = peval(pb, l3);
    l[2] = l3;
    double best = INFINITY;
    if (fabs(a) > 1e-6) {
        const double l2 = -b / a;
        /* lambda1 from the difference of eq12 and eq13 (both monic in lambda1) */
        const double pr = (2.0 * ddot(g->d[0], g->e12) - 2.0 * k12 * l2) -
                         (2.0 * ddot(g->d[0], g->e13) - 2.0 * k13 * l3);
        const double qs = (l2 * l2 - 2.0 * ddot(g->d[1], g->e12) * l2 + ddot(g->e12, g->e12) - g->dd12) -
                         (l3 * l3 - 2.0 * ddot(g->d[2], g->e13) * l3 + ddot(g->e13, g->e13) - g->dd13);
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
    const double k23 = ddot(g->d[1], g->d[2]);
    double r2[2];
    const int n2 = quad_roots(2.0 * ddot(g->d[1], g->e23) - 2.0 * k23 * l3,
                              l3 * l3 - 2.0 * ddot(g->d[2], g->e23) * l3 + ddot(g->e23, g->e23) - g->dd23,
                              r2);
    for (int i = 0; i < n2; i++) {
        double r1[2];
        const int n1 = quad_roots(2.0 * ddot(g->d[0], g->e12) - 2.0 * k12 * r2[i],
                                  r2[i] * r2[i] - 2.0 * ddot(g->d[1], g->e12) * r2[i] +
                                      ddot(g->e12, g->e12) - g->dd12,
                                  r1);
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
    dv3_t e1, e3, f1, f3;
    if (!dnormalize(dsub(x[1], x[0]), &e1) ||
        !dnormalize(dcross(e1, dsub(x[2], x[0])), &e3) ||
        !dnormalize(dsub(p[1], p[0]), &f1) ||
        !dnormalize(dcross(f1, dsub(p[2], p[0])), &f3)) {
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
    const dv3_t pm = dscale(dadd(dadd(p[0], p[1]), p[2]), 1.0 / 3.0);
    const dv3_t xm = dscale(dadd(dadd(x[0], x[1]), x[2]), 1.0 / 3.0);
    const dv3_t rx = {rm[0][0] * xm.x + rm[0][1] * xm.y + rm[0][2] * xm.z,
                      rm[1][0] * xm.x + rm[1][1] * xm.y + rm[1][2] * xm.z,
                      rm[2][0] * xm.x + rm[2][1] * xm.y + rm[2][2] * xm.z};
    const dv3_t t = dsub(pm, rx);
    pose->r_bw_b = mfns_v3((float)t.x, (float)t.y, (float)t.z);
    return true;
}

int mfns_gp3p(const mfns_v3_t c[3], const mfns_v3_t d[3], const mfns_v3_t x_w[3], float min_range_mm,
              float max_range_mm, mfns_pose_t out[MFNS_GP3P_MAX_SOLUTIONS])
{
    if (!(max_range_mm > 0.0f) || !(min_range_mm >= 0.0f) || !(min_range_mm < max_range_mm)) {
        return 0;
    }
    const double s = 1.0 / (double)max_range_mm;
    gp3p_t g;
    dv3_t cd[3], xd[3];
    for (int i = 0; i < 3; i++) {
        if (!dnormalize(dv(d[i]), &g.d[i])) {
            return 0;
        }
        cd[i] = dv(c[i]);
        xd[i] = dv(x_w[i]);
    }
    g.e12 = dscale(dsub(cd[0], cd[1]), s);
    g.e13 = dscale(dsub(cd[0], cd[2]), s);
    g.e23 = dscale(dsub(cd[1], cd[2]), s);
    const dv3_t x12 = dscale(dsub(xd[0], xd[1]), s);
    const dv3_t x13 = dscale(dsub(xd[0], xd[2]), s);
    const dv3_t x23 = dscale(dsub(xd[1], xd[2]), s);
    g.dd12 = ddot(x12, x12);
    g.dd13 = ddot(x13, x13);
    g.dd23 = ddot(x23, x23);
    if (!(g.dd12 > 1e-12 && g.dd13 > 1e-12 && g.dd23 > 1e-12)) {
        return 0;
    }
    const double k12 = ddot(g.d[0], g.d[1]), k13 = ddot(g.d[0], g.d[2]), k23 = ddot(g.d[1], g.d[2]);
    /* eq12: l1^2 + P(l2) l1 + Q(l2); eq13: l1^2 + R(l3) l1 + S(l3); eq23: l2^2 + M(l3) l2 + N(l3) */
    const double p0 = 2.0 * ddot(g.d[0], g.e12), p1 = -2.0 * k12;
    const double q0 = ddot(g.e12, g.e12) - g.dd12, q1 = -2.0 * ddot(g.d[1], g.e12);
    const poly_t rp = plin(2.0 * ddot(g.d[0], g.e13), -2.0 * k13);
    const poly_t sp = pquad(ddot(g.e13, g.e13) - g.dd13, -2.0 * ddot(g.d[2], g.e13), 1.0);
    const poly_t mp = plin(2.0 * ddot(g.d[1], g.e23), -2.0 * k23);
    const poly_t np = pquad(ddot(g.e23, g.e23) - g.dd23, -2.0 * ddot(g.d[2], g.e23), 1.0);
    /* Bivariate polynomials: index = power of l2, entries polynomials in l3. */
    poly_t qs[3], pr[2], psqr[3];
    qs[0] = pconst(q0);
    pacc(&qs[0], &sp, -1.0);
    qs[1] = pconst(q1);
    qs[2] = pconst(1.0);
    pr[0] = pconst(p0);
    pacc(&pr[0], &rp, -1.0);
    pr[1] = pconst(p1);
    /* P S - Q R */
    psqr[0] = pconst(0.0);
    pacc(&psqr[0], &sp, p0);
    pacc(&psqr[0], &rp, -q0);
    psqr[1] = pconst(0.0);
    pacc(&psqr[1], &sp, p1);
    pacc(&psqr[1], &rp, -q1);
    psqr[2] = pconst(0.0);
    pacc(&psqr[2], &rp, -1.0);
    /* G = (Q - S)^2 + (P - R)(P S - Q R): the resultant in l1, quartic in l2 */
    poly_t gq[5];
    for (int i = 0; i < 5; i++) {
        gq[i] = pconst(0.0);
    }
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            const poly_t t = pmul(&qs[i], &qs[j]);
            pacc(&gq[i + j], &t, 1.0);
        }
    }
    for (int i = 0; i < 2; i++) {
        for (int j = 0; j < 3; j++) {
            const poly_t t = pmul(&pr[i], &psqr[j]);
            pacc(&gq[i + j], &t, 1.0);
        }
    }
    /* G mod (l2^2 + M l2 + N) = A l2 + B */
    for (int i = 4; i >= 2; i--) {
        const poly_t tm = pmul(&gq[i], &mp), tn = pmul(&gq[i], &np);
        pacc(&gq[i - 1], &tm, -1.0);
        pacc(&gq[i - 2], &tn, -1.0);
        gq[i] = pconst(0.0);
    }
    const poly_t pa = gq[1], pb = gq[0];
    /* resultant in l2: A^2 N - A B M + B^2 */
    const poly_t aa = pmul(&pa, &pa), ab = pmul(&pa, &pb);
    poly_t f = pmul(&pb, &pb);
    const poly_t t1 = pmul(&aa, &np), t2 = pmul(&ab, &mp);
    pacc(&f, &t1, 1.0);
    pacc(&f, &t2, -1.0);

    const double lo = (double)min_range_mm * s, hi = 1.0;
    double roots[PD - 1];
    const int nroots = real_roots(&f, lo, hi, roots);
    const double tol = 1e-4 * fmax(g.dd12, fmax(g.dd13, g.dd23));
    int nsol = 0;
    for (int k = 0; k < nroots && nsol < MFNS_GP3P_MAX_SOLUTIONS; k++) {
        double l[3];
        back_substitute(&g, &pa, &pb, roots[k], l);
        polish(&g, l);
        double fe[3];
        dist_eqs(&g, l, fe, NULL);
        if (!(fnorm(fe) < tol) || !(l[0] > 0.5 * lo && l[1] > 0.5 * lo && l[2] > 0.5 * lo) ||
            !(l[0] < 2.0 && l[1] < 2.0 && l[2] < 2.0)) {
            continue;
        }
        dv3_t pb3[3];
        for (int i = 0; i < 3; i++) {
            pb3[i] = dadd(cd[i], dscale(g.d[i], l[i] / s));
        }
        mfns_pose_t pose;
        if (!triad(pb3, xd, &pose)) {
            continue;
        }
        bool dup = false;
        for (int q = 0; q < nsol && !dup; q++) {
            dup = mfns_v3_norm(mfns_v3_sub(out[q].r_bw_b, pose.r_bw_b)) < 1e-3f * max_range_mm &&
                  mfns_rot_angle_between(out[q].C_w_b, pose.C_w_b) < 1e-3f;
        }
        if (!dup) {
            out[nsol++] = pose;
        }
    }
    return nsol;
}
