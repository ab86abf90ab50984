/* spd.h -- dense solver for the small symmetric positive definite systems of
 * the pose solve (the 6x6 normal equations J^T W J dx = -J^T W r) and the
 * inverse that gives the pose covariance.
 *
 * Method: Jacobi equilibration (A -> S A S with S = diag(1/sqrt(a_ii))) then
 * Cholesky A = L L^T. Equilibration makes the conditioning test independent of
 * units: rotations in rad and translations in mm give diagonals 1e6 apart.
 * A system is refused, never solved into garbage, when
 *  - an input is not finite or a diagonal is <= 0             (NOT_POSITIVE),
 *  - a pivot of the equilibrated matrix is <= MFNS_SPD_PIVOT_MIN
 *    (singular or indefinite to float precision)               (NOT_POSITIVE),
 *  - the reciprocal condition estimate (min/max pivot of L)^2 of the
 *    equilibrated matrix is below the caller's min_rcond         (ILL_CONDITIONED).
 * The estimate is within a factor n of the true 2-norm rcond for the
 * equilibrated matrix in the cases that matter here (rank deficiency drives a
 * pivot to zero); it is a gate, not a precise measurement.
 */
#ifndef MFNS_SPD_H
#define MFNS_SPD_H

#include <stdbool.h>

#define MFNS_SPD_MAX_N 6
#define MFNS_SPD_PIVOT_MIN 1e-12f

typedef enum {
    MFNS_SPD_OK = 0,
    MFNS_SPD_BAD_ARG,         /* n outside 1..MFNS_SPD_MAX_N or NULL pointer */
    MFNS_SPD_NOT_POSITIVE,    /* singular, indefinite or not finite */
    MFNS_SPD_ILL_CONDITIONED, /* rcond estimate below the requested minimum */
} mfns_spd_status_t;

typedef struct {
    int n;
    float l[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N]; /* lower factor of S A S */
    float s[MFNS_SPD_MAX_N];                 /* equilibration S */
    float rcond;                             /* estimate, see above */
} mfns_chol_t;

/* Factor the n x n SPD matrix a (only its lower triangle is read). On any
 * status but OK, *f is cleared so it cannot be used by mistake. */
mfns_spd_status_t mfns_chol_factor(const float a[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N], int n,
                                   float min_rcond, mfns_chol_t *f);
/* x = A^-1 b. x may alias b. */
void mfns_chol_solve(const mfns_chol_t *f, const float b[MFNS_SPD_MAX_N], float x[MFNS_SPD_MAX_N]);
/* inv = A^-1 (symmetric, full matrix written). */
void mfns_chol_inverse(const mfns_chol_t *f, float inv[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N]);
const char *mfns_spd_strerror(mfns_spd_status_t s);

#endif /* MFNS_SPD_H */
