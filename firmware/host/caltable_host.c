/* caltable_host.c -- see caltable_host.h. */
#include "firmware/host/caltable_host.h"

#include <stddef.h>

uint32_t mfns_caltable_host_table_size(void) { return (uint32_t)sizeof(mfns_caltable_t); }

uint32_t mfns_caltable_host_max_bytes(void) { return (uint32_t)MFNS_CALTABLE_MAX_BYTES; }

uint32_t mfns_caltable_host_max_grid_nodes(void) { return (uint32_t)MFNS_MAX_GRID_NODES; }

uint32_t mfns_caltable_host_max_beacons(void) { return (uint32_t)MFNS_MAX_BEACONS; }

mfns_undist_status_t mfns_caltable_host_grid_eval(uint16_t nx, uint16_t ny, int32_t origin_u_q8, int32_t origin_v_q8,
                                                  int32_t step_u_q8, int32_t step_v_q8, const int32_t *nodes,
                                                  uint32_t n, const int32_t *u_q8, const int32_t *v_q8,
                                                  int32_t *uv_q16, uint8_t *status)
{
    if (nodes == NULL || u_q8 == NULL || v_q8 == NULL || uv_q16 == NULL || status == NULL) {
        return MFNS_UNDIST_BAD_GRID;
    }
    const mfns_undist_grid_t g = {nx, ny, origin_u_q8, origin_v_q8, step_u_q8, step_v_q8,
                                  (const q16_16_t(*)[2])nodes};
    if (mfns_undist_grid_check(&g) != MFNS_UNDIST_OK) {
        return MFNS_UNDIST_BAD_GRID;
    }
    for (uint32_t i = 0; i < n; i++) {
        q16_16_t a = 0, b = 0;
        const mfns_undist_status_t st = mfns_undistort_grid_px(&g, u_q8[i], v_q8[i], &a, &b);
        uv_q16[2u * i] = st == MFNS_UNDIST_OK ? a : 0;
        uv_q16[2u * i + 1u] = st == MFNS_UNDIST_OK ? b : 0;
        status[i] = (uint8_t)st;
    }
    return MFNS_UNDIST_OK;
}
