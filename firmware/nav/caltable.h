/* caltable.h -- the calibration table: the flight loader of the binary format
 * of docs/caltable.md (written by `mfns table build`).
 *
 * mfns_caltable_load validates a table held in memory the way a cFS table
 * validation function does, and only when every check passes copies it into
 * the caller's storage: a table that fails is never partly used (*out is left
 * untouched, so a previously loaded table stays valid). No heap, no OS; the
 * caller provides the (large, static) mfns_caltable_t. Checks, in order, each
 * with its own status: header (size, magic, version, header size, total size),
 * CRC-32 of the body, counts within the compile-time maxima of nav_config.h,
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

#include "beacon_index.h"
#include "camera.h"
#include "fixed.h"
#include "nav_config.h"
#include "undistort.h"

#define MFNS_CALTABLE_MAGIC "MFTB"
#define MFNS_CALTABLE_VERSION 3u     /* the newest format this loader reads */
/* the oldest: version 1 had no map index, version 2 no calibration covariance
 * and a pixel sigma meant as the whole noise (rebuild it) */
#define MFNS_CALTABLE_MIN_VERSION 3u
#define MFNS_CALTABLE_HEADER_SIZE 16u
#define MFNS_CALTABLE_GLOBALS_SIZE 60u /* counts, pixel sigma, centroid + solver settings */
#define MFNS_CALTABLE_CAMERA_FIXED_SIZE 116u
#define MFNS_CALTABLE_NODE_SIZE 8u
#define MFNS_CALTABLE_BEACON_SIZE 20u
#define MFNS_CALTABLE_COV_HEADER_SIZE 4u /* calibration covariance: count, reserved */
#define MFNS_CALTABLE_COV_MAX_SIZE \
    (MFNS_CALTABLE_COV_HEADER_SIZE + 4u * MFNS_CALIB_PARAMS * (MFNS_CALIB_PARAMS + 1u) / 2u)
/* Largest table this build accepts (bytes): all maxima of nav_config.h used. */
#define MFNS_CALTABLE_MAX_BYTES                                                                           \
    (MFNS_CALTABLE_HEADER_SIZE + MFNS_CALTABLE_GLOBALS_SIZE +                                             \
     MFNS_NUM_CAMERAS * (MFNS_CALTABLE_CAMERA_FIXED_SIZE + MFNS_CALTABLE_NODE_SIZE * MFNS_MAX_GRID_NODES) + \
     MFNS_CALTABLE_BEACON_SIZE * MFNS_MAX_BEACONS + MFNS_CALTABLE_COV_MAX_SIZE + MFNS_BIDX_MAX_SECTION_SIZE)

/* Acceptance limits (docs/caltable.md "Validation"). */
#define MFNS_CALTABLE_ROT_TOL 1e-5f      /* max |C^T C - I| entry */
#define MFNS_CALTABLE_GRID_TOL_PX 0.01f  /* node re-distorted vs its pixel */
#define MFNS_CALTABLE_COV_PSD_TOL 1e-4f  /* pivot of the calibration correlation matrix taken as zero */

typedef enum {
    MFNS_CALTABLE_OK = 0,
    MFNS_CALTABLE_E_ARG,              /* NULL pointer */
    MFNS_CALTABLE_E_TRUNCATED,        /* buffer shorter than the header or than total_size */
    MFNS_CALTABLE_E_MAGIC,            /* not a calibration table */
    MFNS_CALTABLE_E_VERSION_NEWER,    /* format newer than this loader: refused */
    MFNS_CALTABLE_E_VERSION_BAD,      /* format version 0 (never valid) */
    MFNS_CALTABLE_E_HEADER_SIZE,      /* header size field is not 16 */
    MFNS_CALTABLE_E_SIZE,             /* total_size below the minimum or above MFNS_CALTABLE_MAX_BYTES */
    MFNS_CALTABLE_E_CRC,              /* body CRC-32 mismatch */
    MFNS_CALTABLE_E_CAMERA_COUNT,     /* camera count is not MFNS_NUM_CAMERAS */
    MFNS_CALTABLE_E_BEACON_COUNT,     /* 0 beacons or more than MFNS_MAX_BEACONS */
    MFNS_CALTABLE_E_RESERVED,         /* a reserved field is not zero */
    MFNS_CALTABLE_E_NOT_FINITE,       /* a float is NaN or infinite */
    MFNS_CALTABLE_E_PIXEL_SIGMA,      /* pixel noise sigma outside (0, 10] px */
    MFNS_CALTABLE_E_CENTROID_SETTINGS,/* a centroid setting out of range */
    MFNS_CALTABLE_E_SOLVER_SETTINGS,  /* a solver setting out of range */
    MFNS_CALTABLE_E_CAMERA_ID,        /* camera id does not match its position (0, 1, 2) */
    MFNS_CALTABLE_E_IMAGE_SIZE,       /* zero image width or height */
    MFNS_CALTABLE_E_FOCAL,            /* focal length not positive (or absurd) */
    MFNS_CALTABLE_E_PRINCIPAL_POINT,  /* principal point outside the image */
    MFNS_CALTABLE_E_LENS,             /* skew or distortion coefficient absurd */
    MFNS_CALTABLE_E_ROTATION,         /* C_k_b not a proper rotation to 1e-5 */
    MFNS_CALTABLE_E_EXTRINSICS,       /* camera offset absurd (> 10 m) */
    MFNS_CALTABLE_E_GRID_DIMS,        /* grid nx or ny < 2, or nx*ny > MFNS_MAX_GRID_NODES */
    MFNS_CALTABLE_E_GRID_STEP,        /* grid step outside 1..255.996 px */
    MFNS_CALTABLE_E_GRID_COVERAGE,    /* grid does not cover the whole image */
    MFNS_CALTABLE_E_GRID_VALUES,      /* a node disagrees with the lens model */
    MFNS_CALTABLE_E_SIZE_MISMATCH,    /* contents do not end exactly at total_size */
    MFNS_CALTABLE_E_BEACON_VALUE,     /* beacon sigma not positive or position absurd */
    MFNS_CALTABLE_E_BEACON_DUPLICATE, /* two beacons share an id */
    MFNS_CALTABLE_E_FILE_OPEN,        /* (caltable_file.h) cannot open the file */
    MFNS_CALTABLE_E_FILE_READ,        /* (caltable_file.h) read error */
    MFNS_CALTABLE_E_FILE_TOO_BIG,     /* (caltable_file.h) file larger than the buffer */
    MFNS_CALTABLE_E_VERSION_OLD,      /* format older than MFNS_CALTABLE_MIN_VERSION: rebuild the table */
    MFNS_CALTABLE_E_INDEX_COUNT,      /* map index: beacon count differs from the map, or k_nbr out of range */
    MFNS_CALTABLE_E_INDEX_POLICY,     /* map index: certificate, missing or budget out of range */
    MFNS_CALTABLE_E_INDEX_WORKSPACE,  /* map index: workspace box empty */
    MFNS_CALTABLE_E_INDEX_GEOMETRY,   /* map index: emission axis/cone or range interval invalid */
    MFNS_CALTABLE_E_INDEX_NEIGHBOUR,  /* map index: neighbour count, index, self or repeated entry */
    MFNS_CALTABLE_E_INDEX_PAIR,       /* map index: pair angle interval reversed */
    MFNS_CALTABLE_E_CALIB_COV_COUNT,  /* calibration covariance: parameter count neither 0 nor MFNS_CALIB_PARAMS */
    MFNS_CALTABLE_E_CALIB_COV_PSD,    /* calibration covariance: negative variance or not positive semi-definite */
    MFNS_CALTABLE_STATUS_COUNT
} mfns_caltable_status_t;

typedef struct {
    mfns_rig_t rig;                        /* camera k = rig.cam[k] (x, y, z) */
    mfns_undist_grid_t grid[MFNS_NUM_CAMERAS]; /* grid[k].node -> grid_node[k] */
    q16_16_t grid_node[MFNS_NUM_CAMERAS][MFNS_MAX_GRID_NODES][2];
    mfns_beacon_map_t beacons;
    mfns_beacon_index_t index;             /* the map's index for acquisition */
    mfns_calib_cov_t calib_cov;            /* the calibration's uncertainty (present = 0: unknown) */
    mfns_centroid_settings_t centroid;
    mfns_solver_settings_t solver;
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
