/* integrity_lag.h -- the per-camera time-offset (lag) monitor: a camera
 * whose frames are older than their stamps (a driver that stamps on arrival,
 * a stale buffer re-queued) shows the scene where it was tau cycles ago.
 * Its error is proportional to motion, so neither the frame-health checks
 * (frame_health.h: only an exact repeat or a real arrival clock) nor the
 * solution separation (integrity.h: a one-frame bias is below its
 * threshold when the other cameras' geometry is weak) see it.
 *
 * The test (docs/pose.md "Time-offset monitor"): the measurement model of
 * camera c gets one more parameter, its lag tau_c (cycles). A lag moves each
 * of c's observations by -tau_c times its image velocity; linearised at the
 * fix, with the whitened residual e = L^-1 (predicted - measured), the
 * whitened Jacobian J (all inliers) and
 *   f_c = L^-1 (h(x) - h(x_back))   on camera c's inlier rows, 0 elsewhere,
 * x_back being the fix moved back by one cycle of the track's own motion
 * (the last two fixes), E[e] = tau_c f_c + J dx. The least-squares estimate
 * of tau_c with the pose free (a GLRT for one added column) is
 *   tau_c = f_c^T M e / f_c^T M f_c,  M = I - J P0 J^T, P0 = (J^T J)^-1,
 *   var(tau_c) = (f_c^T M f_c + var_calib) / (f_c^T M f_c)^2
 *   (unit whitened noise, which carries the survey error; var_calib the
 *   table's calibration covariance seen through the test, static_var in
 *   integrity_lag.c),
 * and z_c = tau_c / sd(tau_c) is N(0, 1) without a lag: the camera is
 * lagging when |z_c| > K, K = Q^-1(P_fa / (2 N_tested)) (two-sided: a frame
 * stamped early is a fault too; P_fa the table's per-fix budget, spent a
 * second time here, so a fix's total false-alarm probability is <= 2 P_fa).
 * Missed detection: a lag tau is found with probability 1 - P_md when
 * |tau| >= (K + K_md) sd(tau_c) (the minimum detectable lag, reported).
 *
 * What it misses (say it in every report):
 *   - no motion: f_c = 0, nothing to test; a stale frame of a still robot
 *     shows the scene as it is, so it is harmless (its error is tau times
 *     the motion per cycle: below 1 sigma of the fix whenever sd(tau_c) > 1
 *     cycle would be the minimum detectable lag -- the camera is then
 *     untested and reported as such, never certified);
 *   - a lag of the same size on every camera (a common clock error): the
 *     pose absorbs it (M f ~ 0 only in that direction; the other cameras
 *     see it as a fix moved on by tau cycles of motion, a time-stamp error
 *     the fix's own stamp carries);
 *   - a lag smaller than the minimum detectable lag;
 *   - motion that changed within the cycle (the velocity is the last
 *     cycle's: an acceleration mis-scales tau but does not bias z under H0);
 *   - a calibration error beyond the table's calibration covariance: the
 *     covariance Sigma_c is in var(tau_c) as a static error (g^T Sigma_c g,
 *     g = J_c^T L^-T M f_c: what a calibration error of that size can put
 *     into f^T M e), so a calibration inside its stated uncertainty is not
 *     read as a lag, but one outside it can be (and the test loses power
 *     in proportion to Sigma_c: the minimum detectable lag says how much).
 * Work: one pass of two projections per inlier, a 6x6 Cholesky; no heap.
 */
#ifndef MFNS_INTEGRITY_LAG_H
#define MFNS_INTEGRITY_LAG_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/integrity/integrity.h"
#include "firmware/nav/pose/pose.h"

/* A camera is tested when at least this many of its beacons are inliers
 * (one is enough: M removes what the pose absorbs; den says what is left). */
#define MFNS_LAG_MIN_OBS 1
/* A held camera's passing test counts towards its release only when the
 * window's minimum detectable lag is at most this (cycles): the test could
 * then have caught a frame one period stale (the fault a driver that stamps
 * on arrival produces) with probability 1 - P_md. */
#define MFNS_LAG_CERT_CYCLES 1.0f
/* ... or when the largest lag the window can miss moves this fix by at most
 * this many of its own sigmas (Mahalanobis, with the pose free: a lag tau
 * of camera c shifts the fix by tau P0 J^T f_c, whose Mahalanobis length is
 * tau sqrt(f_c^T f_c - f_c^T M f_c) = tau * shift_sigma): a lag the test
 * cannot see is then one the fix does not feel. Without it a camera whose
 * lag is mostly absorbed by the pose (few beacons, or beacons that move
 * with the pose) could never be released while the robot moves. */
#define MFNS_LAG_HARMLESS_SIGMA 1.0f

typedef struct {
    uint8_t tested[MFNS_NUM_CAMERAS];  /* 1: camera had inliers and a motion to test against */
    float lag_cycles[MFNS_NUM_CAMERAS]; /* tau_c estimate (cycles), 0 when untested */
    float sd_cycles[MFNS_NUM_CAMERAS];  /* its 1-sigma (cycles), INFINITY when untested */
    float z[MFNS_NUM_CAMERAS];          /* tau_c / sd: N(0, 1) without a lag */
    float z_fix[MFNS_NUM_CAMERAS];      /* the monitor's: this fix's z alone (an onset) */
    float mdl_cycles[MFNS_NUM_CAMERAS]; /* minimum detectable lag (K + K_md) sd (cycles) */
    float num[MFNS_NUM_CAMERAS];        /* this fix's f^T M e (whitened) */
    float den[MFNS_NUM_CAMERAS];        /* this fix's f^T M f: the information on tau_c */
    float var_survey[MFNS_NUM_CAMERAS]; /* the part of var(num) = den due to the beacons' survey errors */
    float var_calib[MFNS_NUM_CAMERAS];  /* var(num) due to the table's calibration covariance (beyond den) */
    float shift_sigma[MFNS_NUM_CAMERAS]; /* this fix's shift per cycle of c's lag, in its sigmas */
    float k;                            /* the threshold on |z| */
    int8_t worst;                       /* camera of the largest |z| above k, -1 none */
} mfns_lag_eval_t;

/* Test each camera of the fix sol (OK or DEGRADED, its assoc and inlier
 * marks) for a lag against back (mfns_motion_step_back, motion.h: the motion from the
 * last two fixes undone on the fix). MFNS_INTEGRITY_E_ARG
 * for NULLs, bad settings or a sol that is not a fix; E_GEOM when its
 * information is singular. */
mfns_integrity_status_t mfns_integrity_lag(const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                           const mfns_obs_frame_t *frame, const mfns_pose_solution_t *sol,
                                           const mfns_pose_config_t *cfg, const mfns_integrity_settings_t *set,
                                           const mfns_pose_t *back, mfns_lag_eval_t *ev);

/* One cycle of the monitor on the solver's fix sol (every camera's
 * inliers), before FDE. The motion is the solver's own last two fixes (kept
 * in mem; a cycle without a fix restarts it). A lag is persistent, so the
 * test is on the moving sum over the camera's last MFNS_INTEGRITY_LAG_WINDOW
 * tested fixes: tau = sum num / sum den, z = sum num / sqrt(sum den)
 * where the window's var(sum num) counts the pixel noise as independent from
 * fix to fix and the survey errors' and calibration's parts (var_survey,
 * var_calib: static) as fully correlated: sum (den - var_survey) +
 * (sum sqrt(var_survey))^2 + (sum sqrt(var_calib))^2, so z is
 * N(0, 1), or narrower, without a lag; beside it
 * this fix's z alone (z_fix = num / sqrt(den + var_calib): a sudden lag is
 * seen at once, undiluted), the
 * two tests sharing P_fa: K = Q^-1(P_fa / (2 * 2 * N_tested)). ev's tau,
 * sd, z and mdl are the window's. A fix where
 * camera c is untested (no inlier, no motion) clears c's window.
 * Holds (mem->cam_lag, FDE leaves a held camera out of the fix):
 *   - the camera of the largest |z| above K: held as LAGGING (1) until the
 *     lag has left the window and MFNS_INTEGRITY_LAG_WINDOW more tested
 *     fixes have passed;
 *   - a camera that gave no image for MFNS_INTEGRITY_LAG_OUTAGE cycles or
 *     more (an outage: dead, timed out, held out by the frame-health
 *     checks; obs dark; a single dropped frame is none) while another
 *     camera gave one
 *     (every camera dark at once: no reference, none held, so a still robot
 *     fixes again after a blackout): held as VERIFYING (2) until
 *     MFNS_INTEGRITY_LAG_VERIFY tested fixes with it have passed (a camera
 *     coming back stale is then caught before it is used: one fix has too
 *     little power, the window has it). Without motion nothing is tested
 *     and the camera stays out (availability, never integrity);
 *   - a camera that comes back after a gap of MFNS_INTEGRITY_LAG_OUTAGE
 *     cycles or more in which it gave images but none of its spots was an
 *     inlier while the fix predicted beacons in them (the camera watch's
 *     miss run, integrity_cameras.h: frames two periods stale fall outside
 *     the association gate until one spot falls inside it), while another
 *     camera not held for its lag has an inlier to verify it against: held
 *     as VERIFYING (2) like an outage.
 * A pass counts only with the power to see a one-period lag
 * (MFNS_LAG_CERT_CYCLES), or when the lag it could miss is harmless to the
 * fix (mdl * shift_sigma <= MFNS_LAG_HARMLESS_SIGMA). So with motion and the
 * camera's beacons in the fix, a camera is released after
 * MFNS_INTEGRITY_LAG_VERIFY such fixes; it stays held (LAG_VERIFY, never
 * certified) while the robot is still (nothing tested), while it has no
 * inlier, and while its lag is both unseen and harmful -- two cameras alone
 * cannot tell which one lags (a lag of one is the opposite lag of the
 * other): the window's power falls, and a held camera then stays held.
 * Returns the camera of a new lag episode (report it), else -1. */
int mfns_integrity_lag_monitor(mfns_integrity_memory_t *mem, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                               const mfns_obs_frame_t *frame, const mfns_pose_solution_t *sol,
                               const mfns_pose_config_t *cfg, const mfns_integrity_settings_t *set,
                               mfns_lag_eval_t *ev);

/* True when the monitor has the motion of two consecutive solver fixes to
 * test the next fix's cameras against (a fix without it is not usable:
 * MFNS_POSE_R_LAG_UNTESTED, nav_cycle.c). */
bool mfns_integrity_lag_motion_known(const mfns_integrity_memory_t *mem);

/* The number of cameras with an inlier in the fix sol (0 for NULLs). A fix
 * on one camera is never testable for a lag, motion or not: its lag is a
 * pose change (f_c in the span of J, M f_c = 0), the case of a lag common to
 * every camera above, a stamp error the fix's stamp carries. So only a fix
 * on two or more cameras is held for want of a motion (nav_cycle.c): that
 * is the fix the monitor would have tested. */
int mfns_integrity_lag_cameras(const mfns_pose_solution_t *sol, const mfns_obs_frame_t *frame);

#endif /* MFNS_INTEGRITY_LAG_H */
