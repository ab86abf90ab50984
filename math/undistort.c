/* undistort.c -- see undistort.h. */
#include "math/undistort.h"
#include "math/core_text.h"

#include <math.h>

const char *mfns_undist_strerror(mfns_undist_status_t s)
{
    switch (s) {
    case MFNS_UNDIST_OK:
        return MFNS_MSG("ok");
    case MFNS_UNDIST_BAD_INPUT:
        return MFNS_MSG("bad input (NULL, not finite, or iteration cap outside 1..MFNS_UNDIST_MAX_ITER)");
    case MFNS_UNDIST_NOT_CONVERGED:
        return MFNS_MSG("distortion inverse did not converge within the iteration cap");
    case MFNS_UNDIST_SINGULAR:
        return MFNS_MSG("distortion model folds over (Jacobian not positive): no inverse");
    case MFNS_UNDIST_OUTSIDE:
        return MFNS_MSG("pixel outside the correction grid");
    case MFNS_UNDIST_BAD_GRID:
        return MFNS_MSG("correction grid header inconsistent");
    default:
        return MFNS_MSG("unknown undistortion status");
    }
}

/* Forward model in double (same expressions as mfns_cam_distort). */
static void distort_d(const double c[5], double x, double y, double *xd, double *yd, double j[2][2])
{
    const double k1 = c[0], k2 = c[1], p1 = c[2], p2 = c[3], k3 = c[4];
    const double r2 = x * x + y * y;
    const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const double dr = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);
    *xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
    *yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
    j[0][0] = radial + 2.0 * x * x * dr + 2.0 * p1 * y + 6.0 * p2 * x;
    j[0][1] = 2.0 * x * y * dr + 2.0 * p1 * x + 2.0 * p2 * y;
    j[1][0] = j[0][1];
    j[1][1] = radial + 2.0 * y * y * dr + 6.0 * p1 * y + 2.0 * p2 * x;
}

mfns_undist_status_t mfns_undistort_d(const mfns_intrinsics_t *k, double u, double v, int max_iter, double tol_px,
                                      double *x_out, double *y_out, int *iters)
{
    if (k == NULL || x_out == NULL || y_out == NULL || !(tol_px > 0.0)) {
        return MFNS_UNDIST_BAD_INPUT;
    }
    const double fx = (double)k->fx, fy = (double)k->fy, skew = (double)k->skew;
    const double c[5] = {(double)k->dist[0], (double)k->dist[1], (double)k->dist[2], (double)k->dist[3],
                         (double)k->dist[4]};
    if (!(fx > 0.0 && fy > 0.0) || !isfinite(fx) || !isfinite(fy) || !isfinite(skew) || !isfinite(u) ||
        !isfinite(v) || !isfinite(c[0] + c[1] + c[2] + c[3] + c[4]) || !isfinite((double)k->cx) ||
        !isfinite((double)k->cy)) {
        return MFNS_UNDIST_BAD_INPUT;
    }
    /* target distorted normalized coordinates */
    const double ty = (v - (double)k->cy) / fy;
    const double tx = (u - (double)k->cx - skew * ty) / fx;
    double x = tx, y = ty;
    for (int it = 0; it <= max_iter; it++) {
        double xd, yd, j[2][2];
        distort_d(c, x, y, &xd, &yd, j);
        const double rx = xd - tx, ry = yd - ty;
        /* residual in pixels: the same K maps both points */
        const double ru = fx * rx + skew * ry, rv = fy * ry;
        if (!isfinite(ru) || !isfinite(rv)) {
            return MFNS_UNDIST_NOT_CONVERGED;
        }
        if (fabs(ru) <= tol_px && fabs(rv) <= tol_px) {
            *x_out = x;
            *y_out = y;
            if (iters != NULL) {
                *iters = it;
            }
            return MFNS_UNDIST_OK;
        }
        if (it == max_iter) {
            break;
        }
        const double det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        if (!(det > 1e-9)) {
            return MFNS_UNDIST_SINGULAR;
        }
        x -= (j[1][1] * rx - j[0][1] * ry) / det;
        y -= (-j[1][0] * rx + j[0][0] * ry) / det;
    }
    return MFNS_UNDIST_NOT_CONVERGED;
}

mfns_undist_status_t mfns_undistort_iter(const mfns_intrinsics_t *k, float u, float v, int max_iter,
                                         float *x, float *y, int *iters)
{
    if (k == NULL || x == NULL || y == NULL || max_iter < 1 || max_iter > MFNS_UNDIST_MAX_ITER) {
        return MFNS_UNDIST_BAD_INPUT;
    }
    double xd, yd;
    const mfns_undist_status_t s = mfns_undistort_d(k, (double)u, (double)v, max_iter, MFNS_UNDIST_TOL_PX, &xd, &yd, iters);
    if (s == MFNS_UNDIST_OK) {
        *x = (float)xd;
        *y = (float)yd;
    }
    return s;
}

mfns_undist_status_t mfns_undist_grid_check(const mfns_undist_grid_t *g)
{
    if (g == NULL || g->node == NULL || g->nx < 2 || g->ny < 2 || g->step_u_q8 < MFNS_UNDIST_GRID_MIN_STEP_Q8 ||
        g->step_u_q8 > MFNS_UNDIST_GRID_MAX_STEP_Q8 || g->step_v_q8 < MFNS_UNDIST_GRID_MIN_STEP_Q8 ||
        g->step_v_q8 > MFNS_UNDIST_GRID_MAX_STEP_Q8) {
        return MFNS_UNDIST_BAD_GRID;
    }
    return MFNS_UNDIST_OK;
}

/* Cell index and Q16.16 weight along one axis; false when outside. The span
 * (n-1)*step < 2^16 * 2^16 fits uint32, and t << 16 fits since t <= step < 2^16. */
static bool axis_cell(px_q8_t p, px_q8_t origin, px_q8_t step, uint16_t n, uint32_t *cell, q16_16_t *w)
{
    const int64_t d = (int64_t)p - (int64_t)origin;
    const int64_t span = (int64_t)(n - 1) * (int64_t)step;
    if (d < 0 || d > span) {
        return false;
    }
    const uint32_t du = (uint32_t)d, s = (uint32_t)step;
    uint32_t i = du / s;
    if (i > (uint32_t)n - 2u) {
        i = (uint32_t)n - 2u; /* the far edge itself: last cell, weight 1 */
    }
    const uint32_t t = du - i * s;
    *cell = i;
    *w = (q16_16_t)(((t << MFNS_Q16_16_FRAC_BITS) + s / 2u) / s);
    return true;
}

mfns_undist_status_t mfns_undistort_grid_px(const mfns_undist_grid_t *g, px_q8_t u_q8, px_q8_t v_q8,
                                            q16_16_t *u_und_q16, q16_16_t *v_und_q16)
{
    if (u_und_q16 == NULL || v_und_q16 == NULL) {
        return MFNS_UNDIST_BAD_INPUT;
    }
    if (mfns_undist_grid_check(g) != MFNS_UNDIST_OK) {
        return MFNS_UNDIST_BAD_GRID;
    }
    uint32_t i, j;
    q16_16_t wx, wy;
    if (!axis_cell(u_q8, g->origin_u_q8, g->step_u_q8, g->nx, &i, &wx) ||
        !axis_cell(v_q8, g->origin_v_q8, g->step_v_q8, g->ny, &j, &wy)) {
        return MFNS_UNDIST_OUTSIDE;
    }
    const size_t k00 = (size_t)j * g->nx + i, k01 = k00 + g->nx;
    q16_16_t out[2];
    for (int c = 0; c < 2; c++) {
        const q16_16_t top = mfns_q16_lerp(g->node[k00][c], g->node[k00 + 1][c], wx);
        const q16_16_t bot = mfns_q16_lerp(g->node[k01][c], g->node[k01 + 1][c], wx);
        out[c] = mfns_q16_lerp(top, bot, wy);
    }
    *u_und_q16 = out[0];
    *v_und_q16 = out[1];
    return MFNS_UNDIST_OK;
}

mfns_undist_status_t mfns_undistort_grid(const mfns_undist_grid_t *g, const mfns_intrinsics_t *k,
                                         px_q8_t u_q8, px_q8_t v_q8, float *x, float *y)
{
    if (k == NULL || x == NULL || y == NULL || !(k->fx > 0.0f && k->fy > 0.0f)) {
        return MFNS_UNDIST_BAD_INPUT;
    }
    q16_16_t uq, vq;
    const mfns_undist_status_t s = mfns_undistort_grid_px(g, u_q8, v_q8, &uq, &vq);
    if (s != MFNS_UNDIST_OK) {
        return s;
    }
    /* Subtract the principal point before going to float so the integer part
     * of a ~1000 px coordinate does not eat the fraction's bits. */
    const float du = (float)((int64_t)uq - (int64_t)mfns_q16_from_float(k->cx)) * (1.0f / (float)MFNS_Q16_16_ONE);
    const float dv = (float)((int64_t)vq - (int64_t)mfns_q16_from_float(k->cy)) * (1.0f / (float)MFNS_Q16_16_ONE);
    const float yy = dv / k->fy;
    *y = yy;
    *x = (du - k->skew * yy) / k->fx;
    return MFNS_UNDIST_OK;
}
