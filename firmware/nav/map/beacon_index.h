/* beacon_index.h -- the beacon map's index for lost-in-space acquisition:
 * what can be computed from the map, the rig and the workspace once, offline
 * (`mfns table build`), so that the online search (acquire.h) looks it up.
 * tetra3's split: an offline database, an online solve.
 *
 * Contents, per map of N <= MFNS_MAX_BEACONS beacons:
 *   - the workspace: the box the body origin can be in (world frame, mm);
 *   - per beacon: its emission axis and cone (optional: zero axis = emits
 *     everywhere) and the range of distances at which a camera can see it
 *     from the workspace (camera centres = workspace grown by the largest
 *     camera offset);
 *   - per unordered beacon pair: the interval of angles the pair can subtend
 *     at a camera centre in the workspace where both beacons emit toward it
 *     ("ang_u8" codes, MFNS_BIDX_ANGLE_LSB_RAD each, floor/ceil so that the
 *     stored interval contains the computed one); an empty interval
 *     (min > max) marks a pair never seen together;
 *   - per beacon: up to k_nbr neighbours, nearest in space first, restricted
 *     to beacons that one camera can see together with it (the pair's
 *     smallest angle fits in the widest image diagonal of the rig). The blob
 *     nearest to a blob in an image is, in the measured maps, the beacon
 *     nearest in space at the median and within rank 7 at the 99th
 *     percentile (docs/pose.md): the search grows hypotheses along these lists.
 *   - the acquisition's policy numbers: the certificate (consistent inliers
 *     that make a fix unique, from the map analysis, acquire_certify.c), how
 *     many predicted beacons may lack a blob and how many blobs may lack a
 *     beacon in a certified fix, and the work budget per cycle.
 *
 * The angle intervals come from the extremes of the subtended angle over the
 * faces of the camera-centre box (the angle has no extremum inside free
 * space: its level sets are nested spindle tori around the segment), found
 * on a face grid and polished by a bounded pattern search, then widened by
 * MFNS_BIDX_ANGLE_PAD_RAD; the segment (angle pi) and the line beyond it
 * (angle 0) are tested exactly. An interval that is too narrow can only cost
 * a missed hypothesis, never a wrong fix: verification decides.
 *
 * Sizes: the table section is MFNS_BIDX_SECTION_SIZE(N, k) bytes (for 256
 * beacons and k = 32: 79,916 B). Build time is O(N^2) pair evaluations times
 * the face samples (bounded loops); no heap.
 */
#ifndef MFNS_BEACON_INDEX_H
#define MFNS_BEACON_INDEX_H

#include <stdbool.h>
#include <stdint.h>

#include "math/lens.h"
#include "firmware/nav/settings/nav_settings.h"
#include "math/units.h"

#define MFNS_BIDX_MAX_NBR 32u
#define MFNS_BIDX_MAX_PAIRS ((MFNS_MAX_BEACONS * (MFNS_MAX_BEACONS - 1)) / 2)
/* Angle codes: an ang_u8 value q stands for q * MFNS_BIDX_ANGLE_LSB_RAD, 0 .. pi. */
#define MFNS_BIDX_ANGLE_CODES 255u
#define MFNS_BIDX_ANGLE_LSB_RAD (MFNS_PI_F / (float)MFNS_BIDX_ANGLE_CODES)
#define MFNS_BIDX_ANGLE_PAD_RAD 0.02f /* ~1.1 deg on each side of a computed interval */
/* Certificate bounds: 3 inliers make a hypothesis and a 4th alone is matched
 * by chance even in the paper's 10-beacon map (a recorded frame: a pose
 * 400 mm off fits 4 blobs at 0.42 px, tests/unit/test_acquire.c), so an
 * early stop needs at least 5; a frame with 4 blobs is certified only by
 * completion (acquire.h). More than 16 would exclude most frames. */
#define MFNS_BIDX_MIN_CERT 5u
#define MFNS_BIDX_MAX_CERT 16u
/* Missing beacons a certified fix may have: the certificate is a table of
 * required inliers per missing count 0 .. this. */
#define MFNS_BIDX_MAX_MISSING 3u

/* The invariants the layout and the comments above rely on. */
_Static_assert(MFNS_MAX_BEACONS <= 256, "nbr[][] holds beacon indices in a u8");
_Static_assert(MFNS_BIDX_MAX_NBR <= 255u, "nbr_count and k_nbr are u8");
_Static_assert(MFNS_BIDX_ANGLE_CODES <= 255u, "pair_lo/pair_hi are ang_u8 codes");
_Static_assert(MFNS_BIDX_MIN_CERT >= 5u && MFNS_BIDX_MIN_CERT <= MFNS_BIDX_MAX_CERT,
               "an early stop needs at least 5 inliers; the table's bounds are ordered");
_Static_assert(MFNS_BIDX_MAX_CERT <= 255u, "cert_inliers[] is u8");

/* Table section layout (docs/caltable.md "Map index"), offsets in the section. */
#define MFNS_BIDX_HEADER_SIZE 44u
#define MFNS_BIDX_GEOM_SIZE 24u
#define MFNS_BIDX_SECTION_SIZE(n, k) \
    (MFNS_BIDX_HEADER_SIZE + MFNS_BIDX_GEOM_SIZE * (uint32_t)(n) + (uint32_t)(n) * (1u + (uint32_t)(k)) + \
     (uint32_t)(n) * ((uint32_t)(n) - 1u))
#define MFNS_BIDX_MAX_SECTION_SIZE MFNS_BIDX_SECTION_SIZE(MFNS_MAX_BEACONS, MFNS_BIDX_MAX_NBR)
_Static_assert(MFNS_BIDX_SECTION_SIZE(256u, 32u) == 79916u, "the size quoted at the top of this file");

/* Emission of one LED: axis (unit, or zero for "all directions") and the
 * cosine of its half-angle (visible where cos(angle to the axis) >= it). */
typedef struct {
    mfns_v3_t axis_w;
    float cos_half_angle;
} mfns_beacon_emit_t;

typedef struct {
    mfns_beacon_emit_t emit;
    float range_min_mm, range_max_mm; /* camera centre to beacon, over the workspace */
} mfns_beacon_geom_t;

typedef struct {
    uint16_t count;          /* beacons: equals the map's count */
    uint8_t k_nbr;           /* neighbour list capacity used (1 .. MFNS_BIDX_MAX_NBR) */
    uint8_t max_missing;     /* predicted beacons no blob explains that a certified fix may have */
    uint8_t max_unexplained; /* blobs it explains with no beacon (reflections) that it may leave */
    uint32_t budget_units;   /* acquisition work per cycle (acquire.h "Work units") */
    mfns_v3_t ws_min_w, ws_max_w; /* workspace of the body origin (world, mm) */
    uint32_t analysis_samples;    /* poses the certificate was derived from */
    uint16_t analysis_max_rival;  /* most inliers of a wrong identification seen (0: none) */
    /* consistent inliers that make a fix unique, by its missing count
     * (0 .. max_missing; 0 beyond): non-decreasing */
    uint8_t cert_inliers[MFNS_BIDX_MAX_MISSING + 1u];
    mfns_beacon_geom_t geom[MFNS_MAX_BEACONS];
    uint8_t nbr_count[MFNS_MAX_BEACONS];
    uint8_t nbr[MFNS_MAX_BEACONS][MFNS_BIDX_MAX_NBR];
    uint8_t pair_lo[MFNS_BIDX_MAX_PAIRS]; /* ang_u8 */
    uint8_t pair_hi[MFNS_BIDX_MAX_PAIRS];
} mfns_beacon_index_t;

typedef enum {
    MFNS_BIDX_OK = 0,
    MFNS_BIDX_E_ARG,       /* NULL pointer, counts outside the maxima, k_nbr out of range */
    MFNS_BIDX_E_WORKSPACE, /* workspace not finite or empty (min >= max on an axis) */
    MFNS_BIDX_E_EMIT,      /* an emission axis neither unit nor zero, or cosine outside [-1, 1] */
    MFNS_BIDX_E_SPACE,     /* output buffer too small */
} mfns_bidx_status_t;

typedef struct {
    uint8_t k_nbr;         /* neighbours kept per beacon */
    uint8_t cert_inliers;  /* written for every missing count; acquire_certify.c derives the table */
    uint8_t max_missing;
    uint8_t max_unexplained;
    uint32_t budget_units;
} mfns_bidx_params_t;

/* The defaults `mfns table build` writes (nav_defaults_gen.c, generated from
 * caltable_layout.toml with the other defaults). */
void mfns_bidx_params_default(mfns_bidx_params_t *p);

/* The index's build and serialisation (mfns_bidx_build, mfns_bidx_encode,
 * mfns_bidx_section_size, mfns_bidx_rig_fov_diag_rad): firmware/host/beacon_index_build.h. */

/* ---- Flight side: the look-ups of the acquisition (beacon_index.c). */

/* Position of the unordered pair (a, b), a != b, in pair_lo/pair_hi. */
static inline uint32_t mfns_bidx_pair_slot(uint32_t n, uint32_t a, uint32_t b)
{
    const uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
    return lo * (2u * n - lo - 1u) / 2u + (hi - lo - 1u);
}

/* Can the pair (a, b) subtend angle_rad (+- pad_rad) at a camera centre in the workspace? */
bool mfns_bidx_pair_admits(const mfns_beacon_index_t *idx, uint32_t a, uint32_t b, float angle_rad, float pad_rad);

/* Is beacon b (emission cone) facing the point p_w? */
bool mfns_bidx_emits_toward(const mfns_beacon_geom_t *g, mfns_v3_t p_beacon_w, mfns_v3_t p_w);

const char *mfns_bidx_strerror(mfns_bidx_status_t s);


#endif /* MFNS_BEACON_INDEX_H */
