/* caltable.h -- the calibration table: the flight loader of the binary format
 * of docs/caltable.md (written by `mfns table build`).
 *
 * mfns_caltable_load validates a table held in memory the way a cFS table
 * validation function does, and only when every check passes copies it into
 * the caller's storage: a table that fails is never partly used (*out is left
 * untouched, so a previously loaded table stays valid). No heap, no OS; the
 * caller provides the (large, static) mfns_caltable_t. Checks, in order, each
 * with its own status: header (size, magic, version, header size, total size),
 * CRC-32 of the body, counts within the compile-time maxima of nav_settings.h,
 * settings finite and in range, per camera: id, image size, every float
 * finite, focal lengths positive, principal point inside the image, C_k_b a
 * rotation to MFNS_CALTABLE_ROT_TOL, grid dimensions/steps/coverage and every
 * node consistent with the lens model to MFNS_CALTABLE_GRID_TOL_PX; beacons:
 * finite, sigma positive, ids unique; the calibration covariance (count,
 * finite, positive semi-definite); the map index (beacon_index.h):
 * counts, policy, workspace, per-beacon geometry, neighbour lists, pair
 * intervals; finally no bytes left over.
 *
 * The loaded table is not relocatable: grid[k].node points into grid_node[k]
 * of the same object. Use it where it was loaded (do not copy it by value).
 */
#ifndef MFNS_CALTABLE_H
#define MFNS_CALTABLE_H

#include <stddef.h>
#include <stdint.h>

#include "firmware/nav/map/beacon_index.h"
#include "math/lens.h"
#include "math/fixed.h"
#include "firmware/nav/settings/nav_settings.h"
#include "math/undistort.h"

/* The layout (format version, record sizes, field offsets), the status codes
 * mfns_caltable_status_t with their values and messages, and the default
 * settings are generated from the one definition, caltable_layout.toml
 * (contract/gen_caltable.py), into caltable_layout_gen.h: */
#include "firmware/nav/generated/caltable_layout_gen.h"

#define MFNS_CALTABLE_COV_MAX_SIZE \
    (MFNS_CALTABLE_COV_HEADER_SIZE + 4u * MFNS_CALIB_PARAMS * (MFNS_CALIB_PARAMS + 1u) / 2u)
#define MFNS_CALTABLE_DATUM_MAX_SIZE \
    (MFNS_CALTABLE_DATUM_HEADER_SIZE + 4u * MFNS_MAP_DATUM_PARAMS * (MFNS_MAP_DATUM_PARAMS + 1u) / 2u)
/* Largest table this build accepts (bytes): all maxima of nav_settings.h used. */
#define MFNS_CALTABLE_MAX_BYTES                                                                           \
    (MFNS_CALTABLE_HEADER_SIZE + MFNS_CALTABLE_GLOBALS_SIZE +                                             \
     MFNS_NUM_CAMERAS * (MFNS_CALTABLE_CAMERA_FIXED_SIZE + MFNS_CALTABLE_NODE_SIZE * MFNS_MAX_GRID_NODES) + \
     MFNS_CALTABLE_BEACON_SIZE * MFNS_MAX_BEACONS + MFNS_CALTABLE_COV_MAX_SIZE + MFNS_CALTABLE_DATUM_MAX_SIZE + \
     MFNS_CALTABLE_INTEGRITY_SIZE + MFNS_CALTABLE_MOTION_SIZE + \
     MFNS_BIDX_MAX_SECTION_SIZE)

/* Acceptance limits (docs/caltable.md "Validation"). */
#define MFNS_CALTABLE_ROT_TOL 1e-5f      /* max |C^T C - I| entry */
#define MFNS_CALTABLE_GRID_TOL_PX 0.01f  /* node re-distorted vs its pixel */
#define MFNS_CALTABLE_COV_PSD_TOL 1e-4f  /* pivot of the calibration correlation matrix taken as zero */

typedef struct {
    mfns_rig_t rig;                        /* camera k = rig.cam[k] (x, y, z) */
    mfns_undist_grid_t grid[MFNS_NUM_CAMERAS]; /* grid[k].node -> grid_node[k] */
    q16_16_t grid_node[MFNS_NUM_CAMERAS][MFNS_MAX_GRID_NODES][2];
    mfns_beacon_map_t beacons;
    mfns_beacon_index_t index;             /* the map's index for acquisition */
    mfns_calib_cov_t calib_cov;            /* the calibration's uncertainty (present = 0: unknown) */
    mfns_map_datum_t datum;                /* the map's shared error (present = 0: none; nav_settings.h) */
    mfns_centroid_settings_t centroid;
    mfns_solver_settings_t solver;
    mfns_integrity_settings_t integrity;   /* fault detection and exclusion (integrity.h) */
    mfns_filter_settings_t motion;         /* the motion bound of the navigation filter (nav_filter.h) */
    float pixel_sigma_px;                  /* 1-sigma unmodelled pixel error (pose.h mfns_pose_config_t) */
    uint16_t format_version;
    uint32_t size_bytes;
    uint32_t crc32;                        /* body CRC: the table's identity for telemetry */
} mfns_caltable_t;

/* Validate buf[0..len) and, when valid, load it into *out. err_offset
 * (nullable) receives the byte offset of the offending field on failure. */
mfns_caltable_status_t mfns_caltable_load(const uint8_t *buf, size_t len, mfns_caltable_t *out,
                                          uint32_t *err_offset);

/* One-line message for a status (static string, never NULL). */
const char *mfns_caltable_strerror(mfns_caltable_status_t s);

/* CRC-32 of the format: CRC-32/ISO-HDLC (zlib's crc32: reflected polynomial
 * 0xEDB88320, init 0xFFFFFFFF, final xor 0xFFFFFFFF). crc = 0 starts a new
 * sum; pass a previous result to continue it. */
uint32_t mfns_crc32(uint32_t crc, const uint8_t *p, size_t n);

#endif /* MFNS_CALTABLE_H */
