/* beacon_index_build.h -- the ground side of the map index (firmware/nav/map/beacon_index.h):
 * its build over a workspace and its serialisation as the table's map-index section.
 * Host-only: linked into libmfns_core.so and the unit tests, never into a flight image
 * (mk/include_graph.py --check fails a flight module that includes this header). */
#ifndef MFNS_BEACON_INDEX_BUILD_H
#define MFNS_BEACON_INDEX_BUILD_H

#include <stdint.h>

#include "firmware/nav/map/beacon_index.h"

/* Build the index of map for rig over the workspace box. emit may be NULL
 * (every beacon emits everywhere); else one entry per beacon. */
mfns_bidx_status_t mfns_bidx_build(const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                   const mfns_beacon_emit_t *emit, mfns_v3_t ws_min_w, mfns_v3_t ws_max_w,
                                   const mfns_bidx_params_t *par, mfns_beacon_index_t *out);

/* Serialize the index as the table's map-index section (little-endian).
 * *written receives the size; MFNS_BIDX_E_SPACE when cap is too small. */
mfns_bidx_status_t mfns_bidx_encode(const mfns_beacon_index_t *idx, uint8_t *buf, uint32_t cap, uint32_t *written);

/* MFNS_BIDX_SECTION_SIZE(n, k) as a function, for the host tools (ctypes). */
uint32_t mfns_bidx_section_size(uint32_t n, uint32_t k);

/* The widest angle between two pixels of any camera of the rig (rad). */
float mfns_bidx_rig_fov_diag_rad(const mfns_rig_t *rig);

#endif /* MFNS_BEACON_INDEX_BUILD_H */
