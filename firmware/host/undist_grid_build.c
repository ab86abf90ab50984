/* undist_grid_build.c -- the ground side of undistort.h (b): the builder of
 * a correction grid from the lens model (`mfns table build` through the shared
 * library, and the tests). Host-only (firmware/host): the flight image only
 * interpolates grids loaded from the table (math/undistort.c). */
#include <math.h>

#include "firmware/host/undist_grid_build.h"

bool mfns_undist_grid_step(uint16_t size_px, uint16_t n, px_q8_t *step)
{
    if (step == NULL || n < 2) {
        return false;
    }
    const uint32_t span = (uint32_t)size_px * (uint32_t)MFNS_PX_Q8_ONE;
    const uint32_t s = (span + (uint32_t)n - 2u) / ((uint32_t)n - 1u); /* ceil */
    if (s < MFNS_UNDIST_GRID_MIN_STEP_Q8 || s > MFNS_UNDIST_GRID_MAX_STEP_Q8) {
        return false;
    }
    *step = (px_q8_t)s;
    return true;
}

mfns_undist_status_t mfns_undist_grid_build(const mfns_intrinsics_t *k, uint16_t nx, uint16_t ny,
                                            q16_16_t (*node)[2], size_t node_cap, mfns_undist_grid_t *g)
{
    px_q8_t su, sv;
    if (k == NULL || node == NULL || g == NULL || (size_t)nx * ny > node_cap ||
        !mfns_undist_grid_step(k->width, nx, &su) || !mfns_undist_grid_step(k->height, ny, &sv)) {
        return MFNS_UNDIST_BAD_INPUT;
    }
    const px_q8_t origin = MFNS_UNDIST_GRID_ORIGIN_Q8;
    for (uint32_t j = 0; j < ny; j++) {
        for (uint32_t i = 0; i < nx; i++) {
            const double u = ((double)origin + (double)i * (double)su) / (double)MFNS_PX_Q8_ONE;
            const double v = ((double)origin + (double)j * (double)sv) / (double)MFNS_PX_Q8_ONE;
            double x, y;
            const mfns_undist_status_t s = mfns_undistort_d(k, u, v, MFNS_UNDIST_MAX_ITER, MFNS_UNDIST_GRID_TOL_PX, &x, &y, NULL);
            if (s != MFNS_UNDIST_OK) {
                return s;
            }
            const double up = (double)k->fx * x + (double)k->skew * y + (double)k->cx;
            const double vp = (double)k->fy * y + (double)k->cy;
            if (!(fabs(up) < 32767.0 && fabs(vp) < 32767.0)) {
                return MFNS_UNDIST_BAD_INPUT; /* beyond Q16.16 */
            }
            const size_t idx = (size_t)j * nx + i;
            node[idx][0] = (q16_16_t)lround(up * (double)MFNS_Q16_16_ONE);
            node[idx][1] = (q16_16_t)lround(vp * (double)MFNS_Q16_16_ONE);
        }
    }
    g->nx = nx;
    g->ny = ny;
    g->origin_u_q8 = origin;
    g->origin_v_q8 = origin;
    g->step_u_q8 = su;
    g->step_v_q8 = sv;
    g->node = (const q16_16_t(*)[2])node;
    return MFNS_UNDIST_OK;
}
