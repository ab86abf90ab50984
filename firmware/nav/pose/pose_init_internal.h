/* pose_init_internal.h -- what the gP3P solver's files share (pose_init.c:
 * the elimination and the pose; pose_init_poly.c: the polynomial's real
 * roots). Not part of the contract: callers use pose_init.h. Double
 * precision, as pose_init.c explains. */
#ifndef MFNS_POSE_INIT_INTERNAL_H
#define MFNS_POSE_INIT_INTERNAL_H

#define MFNS_POLY_COEFS 9 /* coefficients of a polynomial of degree <= 8 */

/* c[0] + c[1] x + ... + c[deg] x^deg; coefficients above deg are zero. */
typedef struct {
    double c[MFNS_POLY_COEFS];
    int deg;
} mfns_poly_t;

/* out += s a b, for polynomials of degrees da and db (out has da + db + 1
 * coefficients). */
static inline void mfns_poly_macc(double *out, const double *a, int da, const double *b, int db, double s)
{
    for (int i = 0; i <= da; i++) {
        const double sa = s * a[i];
        for (int j = 0; j <= db; j++) {
            out[i + j] += sa * b[j];
        }
    }
}

/* p(x), by Horner's scheme over its degree. */
double mfns_poly_eval(const mfns_poly_t *p, double x);

/* The real roots of f in [lo, hi], ascending, at most 8 (its degree); returns
 * their number. A cluster of roots closer than (hi - lo) / 2^22 (a double
 * root, or a complex pair next to the axis) is reported once. Bounded: at
 * most 160 intervals examined, 60 Newton steps per root. */
int mfns_poly_real_roots(const mfns_poly_t *f, double lo, double hi, double roots[MFNS_POLY_COEFS - 1]);

#endif /* MFNS_POSE_INIT_INTERNAL_H */
