/* pose_init_poly.c -- the real roots of the gP3P's elimination polynomial
 * (pose_init_internal.h): root isolation in the Bernstein basis and a
 * bracketed Newton iteration, in double precision (pose_init.c says why). */
#include <math.h>
#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/pose/pose_init_internal.h"

#define POLY_ROOT_ITERS 60 /* safeguarded Newton steps per root: ~4 suffice; bisection alone needs 34 for 1e-10 */
/* estrin and the binomial table are written for degree 8 */
_Static_assert(MFNS_POLY_COEFS == 9, "the polynomials are of degree <= 8");

double mfns_poly_eval(const mfns_poly_t *p, double x)
{
    double v = p->c[p->deg];
    for (int i = p->deg - 1; i >= 0; i--) {
        v = v * x + p->c[i];
    }
    return v;
}

/* sum c[i] x^i over all MFNS_POLY_COEFS coefficients (those above the degree are zero),
 * by Estrin's scheme: a dependency chain of 4 multiply-adds instead of
 * Horner's 8 (the root polish is latency-bound). */
static double estrin(const double c[MFNS_POLY_COEFS], double x)
{
    const double x2 = x * x, x4 = x2 * x2;
    const double a0 = c[0] + c[1] * x, a1 = c[2] + c[3] * x, a2 = c[4] + c[5] * x, a3 = c[6] + c[7] * x;
    return (a0 + a1 * x2) + (a2 + a3 * x2) * x4 + c[8] * (x4 * x4);
}

/* p(x) and p'(x); dc: the derivative's coefficients. */
static double peval_d(const mfns_poly_t *p, const double dc[MFNS_POLY_COEFS], double x, double *dp)
{
    *dp = estrin(dc, x);
    return estrin(p->c, x);
}

/* The root of p in [a, b], an interval holding exactly one, where p(a) = fa
 * and p(b) differ in sign: Newton's iteration kept inside the bracket (a step that would leave it, or
 * that shrinks it too slowly, is replaced by bisection; "rtsafe"), bounded.
 * Newton converges quadratically where Illinois regula falsi needed ~11
 * evaluations per root; this is the gP3P's inner loop. */
static double bracket_root(const mfns_poly_t *p, const double dc[MFNS_POLY_COEFS], double a, double b, double fa, double tol)
{
    /* xl: the end where p < 0 */
    double xl = fa < 0.0 ? a : b, xh = fa < 0.0 ? b : a;
    double x = 0.5 * (a + b), dxold = fabs(b - a), dx = dxold;
    double df;
    double f = peval_d(p, dc, x, &df);
    for (int it = 0; it < POLY_ROOT_ITERS && f != 0.0; it++) {
        if (((x - xh) * df - f) * ((x - xl) * df - f) > 0.0 || fabs(2.0 * f) > fabs(dxold * df)) {
            dxold = dx;
            dx = 0.5 * (xh - xl);
            x = xl + dx;
        } else {
            dxold = dx;
            dx = f / df;
            x -= dx;
        }
        if (fabs(dx) < tol) {
            break;
        }
        f = peval_d(p, dc, x, &df);
        if (f < 0.0) {
            xl = x;
        } else {
            xh = x;
        }
    }
    return x;
}

/* Root isolation in the Bernstein basis (Descartes' rule of signs with
 * subdivision, the Collins-Akritas / Vincent method). On an interval, the
 * sign variations V of the Bernstein coefficients bound the real roots inside
 * (with multiplicity) from above, with the same parity: V = 0 means none,
 * V = 1 exactly one simple root, which Newton finds inside the bracket. V >= 2
 * splits the interval in halves (de Casteljau) until the roots are isolated.
 * Two roots closer than the smallest interval (a double root, or a complex
 * pair next to the axis: the "danger cylinder" poses of P3P, where noise
 * decides between two real roots and none) are reported once, at the
 * interval's midpoint, when f is at rounding level there.
 * Typical gP3P polynomial: 1-2 roots in range and V = 2 on [lo, hi]: a few
 * splits of 36 multiply-adds each, where isolation by the derivatives
 * (the previous method) bracketed ~5 roots of f and its derivatives. */
#define BZ_MAX_DEPTH 22     /* smallest interval (hi - lo) / 2^22 */
/* Intervals examined per call. Typical: 8.5 (3.8 splits). Each of at most 8
 * root clusters costs at most 2 per level below the depth where it is
 * separated from the rest. */
#define BZ_MAX_INTERVALS 160

typedef struct {
    double b[MFNS_POLY_COEFS];
    double t0, t1; /* sub-interval of [0, 1] */
    int depth;
} bz_t;

static int sign_variations(const double *b, int n)
{
    int var = 0, sign = 0;
    for (int i = 0; i <= n; i++) {
        const int sb = b[i] > 0.0 ? 1 : (b[i] < 0.0 ? -1 : 0);
        if (sb != 0) {
            var += (sign != 0 && sb != sign) ? 1 : 0;
            sign = sb;
        }
    }
    return var;
}

/* Bernstein coefficients of degree n = MFNS_POLY_COEFS - 1 of f on [lo, hi]. The basis of
 * degree 8 holds every polynomial of lower degree too (zero leading
 * coefficients), and Descartes' rule holds in it, so one degree serves all. */
static void to_bernstein(const mfns_poly_t *f, double lo, double hi, double b[MFNS_POLY_COEFS])
{
    /* C(i, j) for i <= 8: exact small integers, so a byte each (81 B of
     * flash where doubles took 648) */
    static const uint8_t binom[MFNS_POLY_COEFS][MFNS_POLY_COEFS] = {
        {1}, {1, 1}, {1, 2, 1}, {1, 3, 3, 1}, {1, 4, 6, 4, 1}, {1, 5, 10, 10, 5, 1}, {1, 6, 15, 20, 15, 6, 1},
        {1, 7, 21, 35, 35, 21, 7, 1}, {1, 8, 28, 56, 70, 56, 28, 8, 1}};
    const int n = MFNS_POLY_COEFS - 1;
    double g[MFNS_POLY_COEFS];
    for (int i = 0; i <= n; i++) {
        g[i] = f->c[i];
    }
    /* g(t) = f(lo + (hi - lo) t): Taylor shift by lo, then scaling */
    for (int i = 0; i < n; i++) {
        for (int j = n - 1; j >= i; j--) {
            g[j] += lo * g[j + 1];
        }
    }
    double wp = 1.0;
    for (int j = 0; j <= n; j++) {
        g[j] *= wp;
        wp *= hi - lo;
    }
    for (int j = 0; j <= n; j++) {
        g[j] /= (double)binom[n][j];
    }
    for (int i = 0; i <= n; i++) {
        double acc = 0.0;
        for (int j = 0; j <= i; j++) {
            acc += (double)binom[i][j] * g[j];
        }
        b[i] = acc;
    }
}

/* de Casteljau at t = 1/2: b -> left half l, right half r (constant bounds:
 * the compiler unrolls it). */
static void bz_split(const double *b, double *l, double *r)
{
    double w[MFNS_POLY_COEFS];
    for (int i = 0; i < MFNS_POLY_COEFS; i++) {
        w[i] = b[i];
    }
    l[0] = w[0];
    r[MFNS_POLY_COEFS - 1] = w[MFNS_POLY_COEFS - 1];
    for (int k = 1; k < MFNS_POLY_COEFS; k++) {
        for (int i = 0; i < MFNS_POLY_COEFS - k; i++) {
            w[i] = 0.5 * (w[i] + w[i + 1]);
        }
        l[k] = w[0];
        r[MFNS_POLY_COEFS - 1 - k] = w[MFNS_POLY_COEFS - 1 - k];
    }
}

int mfns_poly_real_roots(const mfns_poly_t *f, double lo, double hi, double roots[MFNS_POLY_COEFS - 1])
{
    /* every coefficient, in degree MFNS_POLY_COEFS - 1 (those above f->deg are zero) */
    mfns_poly_t p = *f;
    p.deg = MFNS_POLY_COEFS - 1;
    const int n = MFNS_POLY_COEFS - 1;
    /* |f| is at most scale on [0, 1]; values below near_zero are at the level
     * of the float rounding of the inputs (relative 1e-7) */
    double scale = 0.0;
    for (int i = 0; i <= n; i++) {
        scale += fabs(p.c[i]);
    }
    const double near_zero = 1e-7 * scale;
    double dc[MFNS_POLY_COEFS] = {0};
    for (int i = 0; i < n; i++) {
        dc[i] = (double)(i + 1) * p.c[i + 1];
    }
    /* depth-first: at most one pending interval per level, plus one */
    bz_t stack[BZ_MAX_DEPTH + 2];
    int top = 0, nr = 0;
    to_bernstein(&p, lo, hi, stack[0].b);
    stack[0].t0 = 0.0;
    stack[0].t1 = 1.0;
    stack[0].depth = 0;
    top = 1;
    for (int visited = 0; top > 0 && visited < BZ_MAX_INTERVALS && nr < MFNS_POLY_COEFS - 1; visited++) {
        const bz_t iv = stack[--top];
        const int var = sign_variations(iv.b, n);
        if (var == 0) {
            continue;
        }
        const double a = lo + (hi - lo) * iv.t0, b = lo + (hi - lo) * iv.t1;
        /* b[0], b[n] are f at the ends */
        const bool opposite = iv.b[0] != 0.0 && iv.b[n] != 0.0 && (iv.b[0] < 0.0) != (iv.b[n] < 0.0);
        if (var == 1 && opposite) {
            roots[nr++] = bracket_root(&p, dc, a, b, iv.b[0], 1e-10);
            continue;
        }
        if (iv.depth >= BZ_MAX_DEPTH) {
            if (opposite) {
                roots[nr++] = bracket_root(&p, dc, a, b, iv.b[0], 1e-10);
            } else if (fabs(mfns_poly_eval(&p, 0.5 * (a + b))) <= near_zero) {
                roots[nr++] = 0.5 * (a + b);
            }
            continue;
        }
        bz_t left, right;
        bz_split(iv.b, left.b, right.b);
        const double tm = 0.5 * (iv.t0 + iv.t1);
        left.t0 = iv.t0;
        left.t1 = tm;
        right.t0 = tm;
        right.t1 = iv.t1;
        left.depth = right.depth = iv.depth + 1;
        if (right.b[0] == 0.0 && nr < MFNS_POLY_COEFS - 1) {
            roots[nr++] = lo + (hi - lo) * tm; /* exact root at the split point */
        }
        /* right first, so roots come out ascending */
        stack[top++] = right;
        stack[top++] = left;
    }
    return nr;
}
