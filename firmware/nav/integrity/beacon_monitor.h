/* beacon_monitor.h -- the in-flight residual monitor of the self-survey
 * (docs/self_survey.md): a slow bias of one beacon (moved, knocked) or of
 * one camera (its mount shifted), below what a single fix's fault test can
 * see, found from the residuals of many fixes.
 *
 * For every usable fix, each association's residual (projected beacon minus
 * measured centroid, at the fix's pose) is whitened by the covariance
 * the solver weighs it with (mfns_pose_obs_cov: centroid, pixel floor and the
 * beacon's survey sigma). Per beacon an exponentially weighted mean m_b of
 * its whitened residuals, inliers and outliers alike: a blob the solver gated
 * out, and for a beacon integrity holds out of the fix (its association
 * removed) the free blob nearest its projection within the tracking gate, each
 * clipped to MFNS_BMON_CLIP. A beacon moved beyond the gates is thus measured
 * at the fix it no longer spoils, and one a fix keeps using is measured too:
 * the monitor sees a moved beacon whether or not integrity does. Weight
 * MFNS_BMON_ALPHA per fix, about 1/MFNS_BMON_ALPHA fixes of memory. Per camera the same of the mean
 * whitened residual of its beacons in each fix, c_k, with the mean number of
 * beacons n_k behind it.
 *
 * Tests (stated levels, not tuned to a run): with the map as good as it says,
 * a beacon's whitened residual is its survey error seen through the lens
 * (persistent, at most unit variance per axis) plus centroid noise, so
 * |m_b|^2 is at most chi-square with 2 degrees of freedom; a beacon is
 * reported when |m_b|^2 > MFNS_BMON_CHI2_2 (P_fa 1e-4) after at least
 * MFNS_BMON_MIN_FIXES of its fixes. A camera's mean over n_k independent
 * beacons has variance at most 1/n_k: reported when n_k |c_k|^2 >
 * MFNS_BMON_CHI2_2 after MFNS_BMON_MIN_FIXES fixes. Each is reported once
 * (latched until mfns_bmon_reset: a new map or table).
 *
 * Down-weighting: a reported beacon gets a sigma scale (1 + |m_b|): the map
 * position is that much less certain than its survey said. The caller applies
 * it to the beacon's sigma_mm until the map is refined (nav_loop.c).
 *
 * What it misses: a bias along the line of sight (a beacon moved towards the
 * camera that sees it shows no image residual); a bias the pose absorbs (one
 * camera alone in view: its shift is a pose change); anything faster than
 * MFNS_BMON_MIN_FIXES fixes (the integrity tests' job: gated outliers and
 * missing LEDs are theirs, integrity.h); a beacon whose survey error is large
 * but within its stated sigma (that is what the refinement is for); a held
 * beacon moved beyond the tracking gate, or whose LED is dark (no blob near
 * its projection: integrity's MISSING). A spurious blob near a held beacon's
 * projection enters its mean (clipped: it takes a persistent one to report).
 *
 * Portable core: caller-owned state, no statics, no allocation, loops
 * bounded by MFNS_MAX_BEACONS and the observation table.
 */
#ifndef MFNS_BEACON_MONITOR_H
#define MFNS_BEACON_MONITOR_H

#include <stdbool.h>
#include <stdint.h>

#include "math/lens.h"
#include "firmware/nav/settings/nav_settings.h"
#include "firmware/nav/pose/pose.h"

#define MFNS_BMON_ALPHA (1.0f / 32.0f) /* EWMA weight per fix: ~32 fixes of memory */
#define MFNS_BMON_MIN_FIXES 32u        /* fixes of a beacon (camera) before it can be reported */
#define MFNS_BMON_CHI2_2 18.42f        /* chi-square, 2 dof, P_fa 1e-4 */
/* An outlier's whitened residual is clipped to this norm before it enters its
 * beacon's mean: twice the reporting radius sqrt(18.42) = 4.29, so a beacon
 * biased beyond the gates still drives its mean over the level, while one
 * wild association moves a mean by at most CLIP * ALPHA = 0.27. */
#define MFNS_BMON_CLIP 8.58f

typedef struct {
    float m[MFNS_MAX_BEACONS][2];   /* EWMA of the whitened residual (u, v) */
    uint16_t n[MFNS_MAX_BEACONS];   /* fixes seen (saturates) */
    uint8_t flagged[MFNS_MAX_BEACONS];
    float sigma_scale[MFNS_MAX_BEACONS]; /* 1, or the down-weight of a reported beacon */
    float c[MFNS_NUM_CAMERAS][2];   /* EWMA of the camera's mean whitened residual */
    float c_n[MFNS_NUM_CAMERAS];    /* EWMA of its beacons per fix */
    uint16_t cn[MFNS_NUM_CAMERAS];  /* fixes seen */
    uint8_t cam_flagged[MFNS_NUM_CAMERAS];
    uint16_t n_flagged;             /* beacons reported (housekeeping) */
} mfns_bmon_t;

/* What one update found: at most one new beacon and one new camera (the worst). */
typedef struct {
    int16_t new_beacon;     /* map index reported this fix, -1 none */
    float beacon_chi2;      /* its |m|^2 */
    int8_t new_camera;      /* camera reported this fix, -1 none */
    float camera_chi2;      /* its n |c|^2 */
} mfns_bmon_report_t;

void mfns_bmon_reset(mfns_bmon_t *mon);

/* One fix (sol usable: OK or DEGRADED; otherwise nothing is updated). The
 * residuals are recomputed at sol's pose from frame's observations and map.
 * sigma_px: the table's pixel floor. gate_px: the tracking gate; held, n_held:
 * the map indices integrity holds out of this fix (NULL, 0 for none; entries
 * < 0 are skipped). Returns false on a NULL argument. */
bool mfns_bmon_update(mfns_bmon_t *mon, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                      const mfns_obs_frame_t *frame, const mfns_pose_solution_t *sol, float sigma_px, float gate_px,
                      const int16_t *held, int n_held, mfns_bmon_report_t *rep);

#endif /* MFNS_BEACON_MONITOR_H */
