/* integrity_beacons.h -- the beacons the fixes keep leaving out, reported
 * with their survey id (docs/pose.md "Beacons missing or rejected"):
 *
 *   - MISSING: a beacon the fix predicts in view of a camera that gave an
 *     image (its projection inside the image, in front of the camera) but
 *     that no observation of that camera is associated with, in
 *     MFNS_BEACON_MISSING_FIXES consecutive fixes: a dead LED, a beacon
 *     knocked off, or moved beyond the association gate. A working LED in
 *     view is found with probability p_d per frame; taking p_d >= 0.5 (a
 *     dim or partly hidden spot), the chance of a false report is
 *     (1 - p_d)^20 <= 1e-6 per episode.
 *   - REJECTED: a beacon that is associated but gated out as an outlier by
 *     the solver, or held out by FDE (integrity.h), more often than it is
 *     used: a leaky count (+1 rejected, -1 used as an inlier) reaching
 *     MFNS_BEACON_REJECT_COUNT. A beacon moved beyond the solver's outlier
 *     gate is never a fault FDE sees (it is not in the fix), so it is
 *     reported here. A healthy beacon is gated only by a mis-association or
 *     a noise draw beyond the gate (~0 for a Gaussian at the gate): ten
 *     more such than clean uses is not seen on clean data.
 * Each is reported once per episode; the episode ends when the beacon has
 * been used as an inlier MFNS_BEACON_CLEAR_FIXES times in a row.
 * Counted over the cycles with a pose good enough to predict from (a fix,
 * or a pose that carries the track: the caller says); other cycles leave the
 * counts alone.
 *
 * What it misses (say it in every report):
 *   - occlusion looks the same as a dead LED (an arm, a bag, a person in
 *     front of the beacon: MISSING is "not seen where predicted", never a
 *     diagnosis);
 *   - whether the LED faces the camera: the map has no normals, so a beacon
 *     behind its own mount is predicted visible (a false MISSING where the
 *     map holds such beacons);
 *   - a beacon biased below the outlier gate: FDE excludes it when its
 *     separation shows (BEACON_EXCLUDED), else it is the slow bias monitor's
 *     (beacon_monitor.h), not this one's.
 * Work: one projection per beacon and camera per cycle; no heap.
 */
#ifndef MFNS_INTEGRITY_BEACONS_H
#define MFNS_INTEGRITY_BEACONS_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/pose/pose.h"

#define MFNS_BEACON_MISSING_FIXES 20 /* (1 - 0.5)^20 ~ 1e-6 */
#define MFNS_BEACON_REJECT_COUNT 10
#define MFNS_BEACON_CLEAR_FIXES 10

typedef struct {
    uint16_t unseen[MFNS_MAX_BEACONS];   /* consecutive counted cycles predicted in view, not associated */
    uint16_t rejected[MFNS_MAX_BEACONS]; /* leaky count of rejections */
    uint16_t used[MFNS_MAX_BEACONS];     /* consecutive counted cycles used as an inlier */
    uint8_t reported[MFNS_MAX_BEACONS];  /* bit 0 MISSING sent, bit 1 REJECTED sent (this episode) */
} mfns_beacon_watch_t;

typedef struct {
    int16_t missing;         /* map index newly found missing this cycle, -1 none */
    int16_t rejected;        /* map index newly found rejected this cycle, -1 none */
    uint16_t missing_fixes;  /* its count */
    uint16_t rejected_count;
} mfns_beacon_watch_report_t;

void mfns_beacon_watch_reset(mfns_beacon_watch_t *w);

/* One cycle. sol: the fix as output (after FDE: its assoc and inlier marks);
 * pose_known: sol's pose predicts well enough (a fix, or a pose that
 * carries the track), else nothing is counted; held, n_held: the map
 * indices FDE holds out this cycle (rejected, not missing). At most one new
 * report of each kind per cycle (the lowest index first; the others follow
 * in the next cycles). */
void mfns_beacon_watch_update(mfns_beacon_watch_t *w, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                              const mfns_obs_frame_t *frame, const mfns_pose_solution_t *sol, bool pose_known,
                              const int16_t *held, int n_held, mfns_beacon_watch_report_t *rep);

#endif /* MFNS_INTEGRITY_BEACONS_H */
