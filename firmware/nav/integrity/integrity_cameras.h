/* integrity_cameras.h -- a camera whose observations the fix keeps leaving
 * out, reported (docs/pose.md "Cameras inconsistent with the fix"):
 *
 *   INCONSISTENT: a camera that gave an image, whose image the fix predicts
 *   beacons in, but none of whose spots is associated with a beacon and used
 *   as an inlier (or no spot at all: while tracking, a stale camera's spots
 *   fall outside the windows around the predicted beacons), while the fix
 *   comes from the other cameras. Each such fix adds the number of beacons predicted in the
 *   camera's image to the camera's evidence; a fix in which the camera has an
 *   inlier clears it. Reported once the evidence reaches
 *   MFNS_CAMERA_INCONSISTENT_EVIDENCE: a working camera finds each beacon in
 *   view with probability p_d >= 0.5 (the beacon watch's assumption,
 *   integrity_beacons.h), so it misses every one of E predicted beacons
 *   (independently) with probability <= 2^-E ~ 1e-6 for E = 20; with three
 *   beacons predicted per fix that is 7 fixes, with one, 20.
 *   This catches what the time-offset monitor (integrity_lag.h) cannot test:
 *   a camera whose frames are so stale (two periods and more at speed), or
 *   whose mount moved so far, that none of its spots falls inside the
 *   association gate; the fix then goes on without it (DEGRADED
 *   CAMERA_UNUSED) and nothing else names it.
 * Whose fault: when the fix comes from two or more other cameras, they
 *   agree with each other and the camera is the odd one out (INCONSISTENT).
 *   When it comes from one other camera, two cameras disagree and nothing
 *   says which is wrong (a stale camera that carries the track alone makes a
 *   healthy one look wrong): that is counted apart and reported as
 *   DISAGREES, naming both cameras, never as the camera's fault.
 * The episode ends when the camera has had an inlier in
 *   MFNS_CAMERA_CONSISTENT_FIXES fixes in a row; it is reported once per
 *   episode. Counted over the cycles with a pose good enough to predict from
 *   (a fix, or a pose that carries the track: the caller says); others leave
 *   the evidence alone.
 *
 * It only reports: the camera contributes nothing to the fix already (no
 *   inlier), and a spot that later falls inside the gate is the solver's,
 *   FDE's and the time-offset monitor's to judge.
 *
 * What it misses (say it in every report):
 *   - a camera whose stale or displaced spots still fall inside the
 *     association gate (they are inliers: the time-offset monitor and FDE
 *     test them);
 *   - a camera that sees no beacon where the fix predicts one (nothing
 *     predicted: no evidence; its faults are harmless to the fix);
 *   - a camera without an image (dark: refused by the frame-health checks,
 *     timed out, dead: they report it);
 *   - occlusion of every beacon in a camera's view looks the same, and so
 *     does a beacon whose LED faces away from the camera (the map has no
 *     normals): a report, never a diagnosis;
 *   - a wrong fix: the prediction is the fix's, so when the fix is wrong a
 *     right camera is the one that disagrees (FDE's protection level bounds
 *     that case).
 * Work: one projection per beacon and camera per cycle; no heap.
 */
#ifndef MFNS_INTEGRITY_CAMERAS_H
#define MFNS_INTEGRITY_CAMERAS_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/pose/pose.h"

#define MFNS_CAMERA_INCONSISTENT_EVIDENCE 20 /* beacons predicted and missed: 2^-20 ~ 1e-6 */
#define MFNS_CAMERA_CONSISTENT_FIXES 10      /* fixes with an inlier that end an episode */

typedef struct {
    uint16_t evidence[MFNS_NUM_CAMERAS]; /* beacons predicted in view and missed since its last inlier,
                                            in fixes from two or more other cameras */
    uint16_t fixes[MFNS_NUM_CAMERAS];    /* counted fixes of that run */
    uint16_t pair_evidence[MFNS_NUM_CAMERAS]; /* the same in fixes from one other camera, pair_with */
    uint16_t pair_fixes[MFNS_NUM_CAMERAS];
    int8_t pair_with[MFNS_NUM_CAMERAS];   /* the camera of those fixes, -1 none */
    uint8_t consistent[MFNS_NUM_CAMERAS]; /* consecutive counted fixes with an inlier (capped) */
    uint8_t miss_run[MFNS_NUM_CAMERAS];   /* consecutive counted cycles with an image and beacons
                                             predicted in it, none an inlier (capped): the gap the
                                             time-offset monitor verifies a camera after */
    uint8_t reported[MFNS_NUM_CAMERAS];   /* bit 0 INCONSISTENT, bit 1 DISAGREES sent (this episode) */
} mfns_camera_watch_t;

typedef struct {
    int8_t inconsistent;       /* camera newly found inconsistent this cycle, -1 none */
    uint16_t evidence;         /* its evidence */
    uint16_t fixes;            /* its counted fixes without an inlier */
    int8_t disagrees;          /* camera newly found disagreeing with the one camera of the fix, -1 none */
    int8_t disagrees_with;     /* that camera */
    uint16_t pair_evidence;
    uint16_t pair_fixes;
    uint8_t state[MFNS_NUM_CAMERAS]; /* 0; 1 in a reported INCONSISTENT episode, 2 in a reported
                                        DISAGREES one, and without an inlier this cycle */
} mfns_camera_watch_report_t;

void mfns_camera_watch_reset(mfns_camera_watch_t *w);

/* Camera c has an observation in frame associated with a beacon and used as
 * an inlier of sol (one test for the camera watch, the time-offset monitor
 * and the navigation cycle). */
bool mfns_camera_has_inlier(const mfns_pose_solution_t *sol, const mfns_obs_frame_t *frame, int c);

/* One cycle. sol: the fix as output (after FDE: its assoc and inlier
 * marks); pose_known: sol's pose predicts well enough (a fix, or a pose
 * that carries the track), else nothing is counted; rep->state still says
 * which cameras are in a reported episode. At most one new report per cycle
 * (the lowest camera first). solver_inlier (NULL: none): per camera, 1 when
 * it had an inlier in the solver's fix before FDE -- a camera FDE or the
 * time-offset monitor holds out is missing from sol for their reasons, not
 * because its spots disagree (they report it), so it counts as consistent. */
void mfns_camera_watch_update(mfns_camera_watch_t *w, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                              const mfns_obs_frame_t *frame, const mfns_pose_solution_t *sol, bool pose_known,
                              const uint8_t solver_inlier[MFNS_NUM_CAMERAS], mfns_camera_watch_report_t *rep);

/* The camera that contradicts a fix made from one camera's observations
 * alone, or -1 (docs/pose.md "One-camera fixes"). With two cameras seeing
 * beacons and one of them stale (its frames older than their stamps), the
 * fix the stale one carries alone is wrong by its lag times the motion, and
 * the healthy camera's spots fall outside the association gate: geometry
 * cannot say which one is wrong, and the camera-fault protection level of a
 * one-camera fix is unbounded (integrity.h), so the fix is not usable
 * (MFNS_POSE_R_CAMERAS_CONTRADICT) when another camera gave an image
 * (frame->dark 0: not refused by the frame-health checks, not timed out)
 * in which sol's pose predicts a beacon at least margin_px inside the
 * image and none of its observations is an inlier of sol. The margin keeps
 * a beacon on the image's edge, whose blob may be cut off, from counting.
 * verifying (NULL: none): per camera, 1 when it is held out only until its
 * lag is verified after an outage or a gap (integrity_lag.h LAG_VERIFY)
 * and has inliers in the solver's fix before the holds: its spots agree
 * with the fix within the solver's outlier gate, it is out for want of a
 * verification, so it does not contradict (under a single fault the camera
 * that was out is the suspect, not the one that carries the fix). A camera
 * held as LAGGING, or one excluded by FDE, still contradicts: with two
 * cameras neither test can tell which one is wrong.
 * Returns -1 when sol is not a fix (status OK or DEGRADED), when its
 * inliers span no camera or two or more, or for NULLs.
 * What it misses: a second camera that sees no beacon the fix predicts in
 * its image (nothing to contradict: its faults are harmless to the fix); a
 * stale camera whose spots still fall in the gate (inliers: a two-camera
 * fix, the time-offset monitor's); a camera without an image. Availability
 * cost: a one-camera fix while another camera's predicted beacon is occluded
 * or faces away (the map has no normals) is refused too. */
int mfns_camera_watch_contradicting(const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                    const mfns_obs_frame_t *frame, const mfns_pose_solution_t *sol,
                                    float margin_px, const uint8_t verifying[MFNS_NUM_CAMERAS]);

#endif /* MFNS_INTEGRITY_CAMERAS_H */
