/* spd.c -- see spd.h. */
#include "math/spd.h"
#include "math/core_text.h"

#include <math.h>
#include <stddef.h>

/* math/ uses no libc beyond <math.h>: struct assignment clears the factor. */
static void clear(mfns_chol_t *f)
{
    mfns_chol_t zero = {0};
    *f = zero;
}

const char *mfns_spd_strerror(mfns_spd_status_t s)
{
    switch (s) {
    case MFNS_SPD_OK:
        return MFNS_MSG("ok");
    case MFNS_SPD_BAD_ARG:
        return MFNS_MSG("bad argument: dimension outside 1..6 or null pointer");
    case MFNS_SPD_NOT_POSITIVE:
        return MFNS_MSG("matrix singular, indefinite or not finite");
    case MFNS_SPD_ILL_CONDITIONED:
        return MFNS_MSG("matrix ill-conditioned (rcond below limit)");
    }
    return MFNS_MSG("unknown spd status");
}

mfns_spd_status_t mfns_chol_factor(const float a[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N], int n,
                                   float min_rcond, mfns_chol_t *f)
{
    if (f == NULL) {
        return MFNS_SPD_BAD_ARG;
    }
    clear(f);
    if (a == NULL || n < 1 || n > MFNS_SPD_MAX_N) {
        return MFNS_SPD_BAD_ARG;
    }
    for (int i = 0; i < n; i++) {
        if (!(a[i][i] > 0.0f) || !isfinite(a[i][i])) {
            return MFNS_SPD_NOT_POSITIVE;
        }
        f->s[i] = 1.0f / sqrtf(a[i][i]);
    }
    float dmin = INFINITY, dmax = 0.0f;
    for (int j = 0; j < n; j++) {
        float d = a[j][j] * f->s[j] * f->s[j];
        for (int k = 0; k < j; k++) {
            d -= f->l[j][k] * f->l[j][k];
        }
        if (!(d > MFNS_SPD_PIVOT_MIN)) { /* also catches NaN */
            clear(f);
            return MFNS_SPD_NOT_POSITIVE;
        }
        const float ljj = sqrtf(d);
        f->l[j][j] = ljj;
        dmin = fminf(dmin, ljj);
        dmax = fmaxf(dmax, ljj);
        for (int i = j + 1; i < n; i++) {
            float v = a[i][j] * f->s[i] * f->s[j];
            for (int k = 0; k < j; k++) {
                v -= f->l[i][k] * f->l[j][k];
            }
            if (!isfinite(v)) {
                clear(f);
                return MFNS_SPD_NOT_POSITIVE;
            }
            f->l[i][j] = v / ljj;
        }
    }
    f->n = n;
    f->rcond = (dmin / dmax) * (dmin / dmax);
    if (f->rcond < min_rcond) {
        clear(f);
        return MFNS_SPD_ILL_CONDITIONED;
    }
    return MFNS_SPD_OK;
}

void mfns_chol_solve(const mfns_chol_t *f, const float b[MFNS_SPD_MAX_N], float x[MFNS_SPD_MAX_N])
{
    const int n = f->n;
    float y[MFNS_SPD_MAX_N];
    /* (S A S) y' = S b, x = S y' */
    for (int i = 0; i < n; i++) {
        float v = b[i] * f->s[i];
        for (int k = 0; k < i; k++) {
            v -= f->l[i][k] * y[k];
        }
        y[i] = v / f->l[i][i];
    }
    for (int i = n - 1; i >= 0; i--) {
        float v = y[i];
        for (int k = i + 1; k < n; k++) {
            v -= f->l[k][i] * y[k];
        }
        y[i] = v / f->l[i][i];
    }
    for (int i = 0; i < n; i++) {
        x[i] = y[i] * f->s[i];
    }
}

void mfns_chol_inverse(const mfns_chol_t *f, float inv[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N])
{
    const int n = f->n;
    for (int j = 0; j < n; j++) {
        float e[MFNS_SPD_MAX_N] = {0};
        float col[MFNS_SPD_MAX_N];
        e[j] = 1.0f;
        mfns_chol_solve(f, e, col);
        for (int i = 0; i < n; i++) {
            inv[i][j] = col[i];
        }
    }
    /* Symmetrize: the two triangles differ by rounding only. */
    for (int i = 0; i < n; i++) {
        for (int j = 0; j < i; j++) {
            const float m = 0.5f * (inv[i][j] + inv[j][i]);
            inv[i][j] = m;
            inv[j][i] = m;
        }
    }
}
