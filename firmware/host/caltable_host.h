/* caltable_host.h -- what the host tools (Python, ctypes) need beside the
 * flight API to use the calibration-table loader and the correction grid
 * through the shared library (`make lib`), so that `mfns table show/build`
 * validate with mfns_caltable_load itself and measure grids with
 * mfns_undistort_grid_px itself, never with a copy. Not used by the flight path.
 */
#ifndef MFNS_CALTABLE_HOST_H
#define MFNS_CALTABLE_HOST_H

#include <stdint.h>

#include "firmware/nav/table/caltable.h"
#include "math/undistort.h"

/* sizeof(mfns_caltable_t): the caller allocates the loader's output. */
uint32_t mfns_caltable_host_table_size(void);

/* MFNS_CALTABLE_MAX_BYTES of this build (the flight program's load buffer). */
uint32_t mfns_caltable_host_max_bytes(void);

/* MFNS_MAX_GRID_NODES of this build (nodes per camera). */
uint32_t mfns_caltable_host_max_grid_nodes(void);

/* MFNS_MAX_BEACONS of this build (beacons in the map). */
uint32_t mfns_caltable_host_max_beacons(void);

/* Evaluate a correction grid at n pixels: uv_q16[2i], uv_q16[2i+1] receive the
 * undistorted pixel of (u_q8[i], v_q8[i]) and status[i] the status of
 * mfns_undistort_grid_px (outputs of a point that fails are 0). nodes holds
 * nx*ny {u', v'} pairs, row-major. Returns BAD_GRID (nothing evaluated) when
 * the grid header fails mfns_undist_grid_check or an argument is NULL. */
mfns_undist_status_t mfns_caltable_host_grid_eval(uint16_t nx, uint16_t ny, int32_t origin_u_q8, int32_t origin_v_q8,
                                                  int32_t step_u_q8, int32_t step_v_q8, const int32_t *nodes,
                                                  uint32_t n, const int32_t *u_q8, const int32_t *v_q8,
                                                  int32_t *uv_q16, uint8_t *status);

#endif /* MFNS_CALTABLE_HOST_H */
