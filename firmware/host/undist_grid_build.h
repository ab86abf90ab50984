/* undist_grid_build.h -- the ground side of the correction grid (math/undistort.h):
 * building a table's grid and sizing its node spacing. Host-only: linked into
 * libmfns_core.so, the unit tests and the benches, never into a flight image (the
 * flight path loads grids from the table). */
#ifndef MFNS_UNDIST_GRID_BUILD_H
#define MFNS_UNDIST_GRID_BUILD_H

#include <stdbool.h>
#include <stddef.h>

#include "math/undistort.h"

/* Fill a grid of nx x ny nodes covering k's whole image: origin at pixel
 * (-0.5, -0.5) (the image corner), step = ceil(256 * W / (nx - 1)) in q8, same
 * for v. Nodes are computed with the iterative inverse in double. For
 * tools and tests (the flight path loads grids from the table). Fails with
 * BAD_INPUT when nx*ny > node_cap or a step is out of range, with the
 * status of the inverse when a node does not converge. */
mfns_undist_status_t mfns_undist_grid_build(const mfns_intrinsics_t *k, uint16_t nx, uint16_t ny,
                                            q16_16_t (*node)[2], size_t node_cap, mfns_undist_grid_t *g);

/* The builder's node spacing: *step_q8 = ceil(256 * size_px / (n - 1)), so
 * that n nodes from the corner span size_px. False (step_q8 untouched) when
 * n < 2 or the spacing is outside [MIN_STEP_Q8, MAX_STEP_Q8]. Host-only, as
 * the builder (the table tools size their grids with it). */
bool mfns_undist_grid_step(uint16_t size_px, uint16_t n, px_q8_t *step_q8);

#endif /* MFNS_UNDIST_GRID_BUILD_H */
