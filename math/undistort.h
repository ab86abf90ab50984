/* undistort.h -- distortion correction: pixel -> undistorted coordinates, the
 * inverse of the lens model of lens.h (docs/system.md §3), in two forms.
 *
 * (a) mfns_undistort_iter: Newton iteration on the forward model, capped at
 *     max_iter updates (the cap is the caller's, at most MFNS_UNDIST_MAX_ITER).
 *     Converged means the re-distorted result is within MFNS_UNDIST_TOL_PX of
 *     the input pixel; otherwise NOT_CONVERGED and the outputs are untouched.
 *     The iteration runs in double: a float 1280-px coordinate alone carries
 *     6e-5 px of rounding and the float forward model several ulps more, so
 *     float cannot guarantee the 1e-4 px this form promises (the Cortex-M7
 *     fpv5-d16 and aarch64 have double in hardware). Inputs and outputs are
 *     float; the float output adds at most ~3e-5 px.
 *
 * (b) mfns_undistort_grid_px: the correction grid of the calibration table,
 *     bilinear interpolation in fixed point; constant time, no iteration.
 *     Nodes sit at pixel (origin_u + i*step_u, origin_v + j*step_v),
 *     i < nx, j < ny, and hold the UNDISTORTED (ideal pinhole) pixel position
 *     of that pixel, u' = fx*x + skew*y + cx, v' = fy*y + cy, in Q16.16 pixels
 *     (resolution 1.5e-5 px; Q16.16 of normalized coordinates would only give
 *     0.024 px at f = 1600). Input pixels are px_q8_t (the centroider output).
 *     Points outside the nodes' span give MFNS_UNDIST_OUTSIDE, never a value.
 *     Accuracy is set by the node spacing (docs/distortion-grid.md).
 *
 * Pixel convention: integer coordinates are pixel centres (docs/conventions.md).
 */
#ifndef MFNS_UNDISTORT_H
#define MFNS_UNDISTORT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "math/lens.h"
#include "math/fixed.h"

/* (a): hard upper bound of the caller's iteration cap, the recommended cap
 * (the paper's lenses converge in <= 2 updates over the whole image, measured
 * in tests/unit/test_undistort.c; 10 leaves room for stronger lenses), and the
 * convergence criterion on the re-distortion residual (px). */
#define MFNS_UNDIST_MAX_ITER 50
#define MFNS_UNDIST_DEFAULT_ITER 10
#define MFNS_UNDIST_TOL_PX 1e-6
/* The grid builder's criterion: a node is the exact inverse to double
 * precision (about 1e-12 px above the ~4e-13 px rounding floor of a 2,000 px
 * focal length), so its Q16.16 rounding does not depend on where the
 * iteration stopped (at 1e-6 px, 0.1 % of the nodes of the paper's lenses
 * rounded to the neighbouring 1.5e-5 px value: measured against the double
 * Newton of host_tools/mfns/model/camera.py, which the tables were built with). */
#define MFNS_UNDIST_GRID_TOL_PX 1e-11

/* (b): the span between nodes is limited to [1, 256) px so that the cell
 * weights are computed in 32-bit integers. */
#define MFNS_UNDIST_GRID_MIN_STEP_Q8 256
#define MFNS_UNDIST_GRID_MAX_STEP_Q8 65535
/* Where a built grid's first node lies: pixel -0.5, the image corner under the
 * pixel-centre convention, on both axes. */
#define MFNS_UNDIST_GRID_ORIGIN_Q8 (-MFNS_PX_Q8_ONE / 2)
_Static_assert(MFNS_UNDIST_GRID_MIN_STEP_Q8 == MFNS_PX_Q8_ONE, "the smallest node spacing is 1 px");
_Static_assert(MFNS_UNDIST_GRID_MAX_STEP_Q8 < (1 << 16), "cell weights: t << 16 with t < step fits uint32");
_Static_assert(MFNS_UNDIST_DEFAULT_ITER <= MFNS_UNDIST_MAX_ITER, "the recommended cap is within the bound");

typedef enum {
    MFNS_UNDIST_OK = 0,
    MFNS_UNDIST_BAD_INPUT,     /* NULL pointer, non-finite input, cap outside 1..MAX_ITER */
    MFNS_UNDIST_NOT_CONVERGED, /* (a) residual above tolerance after the cap */
    MFNS_UNDIST_SINGULAR,      /* (a) the model folds over (Jacobian det <= 0) on the way */
    MFNS_UNDIST_OUTSIDE,       /* (b) pixel outside the grid */
    MFNS_UNDIST_BAD_GRID,      /* (b) grid header inconsistent (dims, steps, no nodes) */
} mfns_undist_status_t;

/* One-line description of a status (static string, never NULL). */
const char *mfns_undist_strerror(mfns_undist_status_t s);

/* The correction grid of one camera. node points to nx*ny nodes, row-major
 * (node[j*nx + i], j the row = v index), each {u'_q16, v'_q16}. The grid does
 * not own its nodes (the calibration table holds them). */
typedef struct {
    uint16_t nx, ny;                  /* nodes per row / per column, >= 2 */
    px_q8_t origin_u_q8, origin_v_q8; /* pixel of node (0, 0) */
    px_q8_t step_u_q8, step_v_q8;     /* node spacing, MIN_STEP..MAX_STEP */
    const q16_16_t (*node)[2];
} mfns_undist_grid_t;

/* (a) pixel (u, v) -> undistorted normalized (x, y). iters (nullable)
 * receives the Newton updates used. */
mfns_undist_status_t mfns_undistort_iter(const mfns_intrinsics_t *k, float u, float v, int max_iter,
                                         float *x, float *y, int *iters);

/* (a) in double throughout: the iteration of mfns_undistort_iter (which
 * rounds its result to float, tol_px = MFNS_UNDIST_TOL_PX) and of the grid
 * builder's nodes (MFNS_UNDIST_GRID_TOL_PX). Converged: the re-distortion
 * residual is within tol_px (> 0) on both axes. Outputs are written only
 * on OK. */
mfns_undist_status_t mfns_undistort_d(const mfns_intrinsics_t *k, double u, double v, int max_iter, double tol_px,
                                      double *x, double *y, int *iters);

/* (b) pixel -> undistorted pixel (Q16.16). */
mfns_undist_status_t mfns_undistort_grid_px(const mfns_undist_grid_t *g, px_q8_t u_q8, px_q8_t v_q8,
                                            q16_16_t *u_und_q16, q16_16_t *v_und_q16);

/* (b) pixel -> undistorted normalized (x, y) = K^-1 (u', v') with the grid's
 * camera intrinsics k (float: adds ~1e-4 px of rounding). */
mfns_undist_status_t mfns_undistort_grid(const mfns_undist_grid_t *g, const mfns_intrinsics_t *k,
                                         px_q8_t u_q8, px_q8_t v_q8, float *x, float *y);

/* The grid builder (mfns_undist_grid_build, mfns_undist_grid_step) is host-only:
 * firmware/host/undist_grid_build.h. */

/* Grid header checks shared with the table loader: dims >= 2, steps in range,
 * node not NULL. */
mfns_undist_status_t mfns_undist_grid_check(const mfns_undist_grid_t *g);

#endif /* MFNS_UNDISTORT_H */
