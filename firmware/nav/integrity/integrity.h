/* integrity.h -- fault detection and exclusion (FDE) and a protection level
 * for every pose fix, after GNSS RAIM/ARAIM solution separation
 * (docs/pose.md "Integrity: fault detection, exclusion and protection level").
 *
 * The pose solver (pose.h) gives the maximum-likelihood pose x0 from the
 * inlier observations. Linearised at x0 with the whitened Jacobian J (2 rows
 * per observation, 6 columns: the solver's increment dtheta rad, dt mm) and
 * the whitened residuals e, each single-fault hypothesis k removes a set F_k
 * of rows:
 *   - one beacon: every inlier observation of that beacon (a knocked LED or a
 *     wrong survey moves all of them; seen once, that is its 2 rows);
 *   - one camera: every inlier row of that camera (a stale or late frame,
 *     a mount that moved).
 * With I0 = J^T J, P0 = I0^-1 and I_k = I0 - J_F^T J_F (computed directly
 * from the rows kept), P_k = I_k^-1:
 *   separation      s_k  = G (dx_k - dx_0),  dx = -P J^T e  (Gauss-Newton step
 *                   of the subset and of the whole set from x0; dx_0 ~ 0 at the ML)
 *   its covariance  S_k  = G (P_k - P0) G^T  (+ calibration term, below)
 * G maps the increment to the 6 output axes: r_wb_w (x, y, z, mm, world) and
 * the attitude error phi_w about the world axes (rad; pose.h cov_ros). Test:
 *   |s_k,j| <= T_k,j = K_fa sqrt(S_k,jj)   for every hypothesis k, axis j,
 *   K_fa = Q^-1(P_fa / (2 * 6 * N_hyp))     (two-sided, P_fa split evenly).
 * Protection level per axis (a single fault of any size, or no fault, with
 * probability at most P_md of an error beyond it):
 *   PL_j = max( K_ff sqrt(P0f_jj),  max_k (|s_k,j| + K_ff sqrt(Pkf_jj)) ),
 *   K_ff = Q^-1(P_md / 2)  (two-sided),
 * Pkf / P0f being P_k / P0 with the calibration term. The hypothesis term is
 * the observed separation's (mfns_integrity_pl_axis: under hypothesis k the
 * subset never took the faulty rows, so x0 - x = s_k + (x_k - x) with x_k - x
 * ~ N(0, Pkf) whatever the fault's size; the triangle inequality does the
 * rest, no test outcome needed), not ARAIM's a-priori T_k,j + K_md
 * sqrt(Pkf_jj), which has to cover every separation the test lets through.
 * The beacon-only PL (pl_beacon_*: the gate of a fix usable with camera
 * faults unbounded, DEGRADED CAMERA_UNMONITORED, require_camera_monitor 0)
 * keeps the a-priori form, deliberately: such a fix is exposed to every
 * camera fault whatever its beacon bound, and the tighter bound widened that
 * class (grown campaign, filter off, seeds 2-5, 7 Dec 2026: misleading fixes
 * 1,922 -> 2,143, among them a one-camera fix of swapped streams 64 mm off
 * under a 16 mm PL). The observed form serves the fixes whose every
 * hypothesis, cameras too, is bounded. PL_pos_mm is the
 * largest of the three position axes (per axis, not a 3-D radius: compare it
 * with a per-axis alert limit), PL_att_deg the largest attitude axis.
 *
 * Calibration covariance (pose.h cov): the solver adds A Sigma_c A^T, A = P
 * J^T J_c. A calibration error is common to all fixes and moves the subset
 * solutions differently, so it enters both the separation's covariance, as
 * (A_k - A_0) Sigma_c (A_k - A_0)^T, and the P_k, P0 of the protection level,
 * as A Sigma_c A^T. Without a table calibration covariance both terms are 0.
 *
 * A hypothesis whose I_k is rank-deficient or below the solver's min_rcond
 * (the same conditioning limit as a fix's, spd.h) is UNMONITORABLE: no
 * subset is left to check it (three beacons; all beacons from one camera; a
 * camera whose removal leaves fewer than three beacons). A fix with any
 * unmonitorable hypothesis is not usable (MFNS_POSE_R_UNMONITORED).
 *
 * What it misses (say it in every report):
 *   - a fault below the threshold: its effect is bounded by the PL only at
 *     the P_md probability, never absolutely;
 *   - two simultaneous faults (two beacons moved, a beacon and a camera): the
 *     hypotheses are single faults;
 *   - a fault common to all cameras and beacons (a wrong map datum, a rig
 *     moved as a whole, a common clock error): every subset agrees with it;
 *   - a fault on the only camera that sees enough beacons: unmonitorable,
 *     the fix is refused rather than certified;
 *   - non-linearity: the test is linearised at the fix; a fault that pulls
 *     the ML solution far (tens of pixels) is usually caught by the solver's
 *     own outlier gate first.
 *
 * Work is bounded: at most MFNS_INTEGRITY_MAX_HYP hypotheses, each one pass
 * over at most MFNS_POSE_MAX_MEAS observations (one projection each) and a
 * 6x6 Cholesky; with a calibration covariance, 2 x 6 x 45 x 45 multiply-adds
 * more per hypothesis. No heap, no OS call. Stack: mfns_integrity_evaluate
 * about 12.4 KB on the Cortex-M7 (the gathered observations, 6 x 45
 * calibration matrices), mfns_integrity_fde 1.8 KB above it; the deepest
 * chain of the navigation cycle stays the acquisition's (17 KB).
 */
#ifndef MFNS_INTEGRITY_H
#define MFNS_INTEGRITY_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/integrity/integrity_beacons.h"
#include "firmware/nav/integrity/integrity_cameras.h"
#include "firmware/nav/pose/pose.h"

/* The settings (mfns_integrity_settings_t, nav_settings.h) come from the
 * calibration table's integrity section; mfns_integrity_settings_default
 * (nav_defaults_gen.c) gives its defaults: alert limits 20 mm and 1 deg,
 * P_fa 1e-5 per fix, P_md 1e-3, hold 19 cycles, camera faults not required
 * to be bounded (docs/caltable.md "Default settings" gives the reasons). */
bool mfns_integrity_settings_valid(const mfns_integrity_settings_t *s);

/* Upper-tail Gaussian quantile: z with Q(z) = P(N(0,1) > z) = p, p in
 * (0, 0.5]; NaN outside. Wichura's AS 241 PPND7 (relative error ~1e-7, in
 * float: enough for a threshold), evaluated on p itself (never 1 - p), so
 * tails down to 1e-30 keep their precision. */
float mfns_integrity_q_inv(float p);

/* One single-fault hypothesis's protection level on one axis, from its
 * observed separation s = (x_0 - x_k)_j, the variance var_k of its subset
 * estimate's error on that axis (everything the subset's error has: noise,
 * calibration, map datum) and k_ff = Q^-1(P_md / 2): |s| + k_ff sqrt(var_k).
 * Why it bounds the error: under the hypothesis the subset x_k took none of
 * the faulty data, so x_0 - x = s + (x_k - x) exactly and x_k - x ~ N(0,
 * var_k) whatever the fault's size or profile; |x_0 - x| <= |s| + |x_k - x|
 * <= |s| + k_ff sqrt(var_k) except with probability P_md. No test outcome
 * enters (the threshold only decides detection), so it holds on every
 * cycle. ARAIM's a-priori form T + K_md sqrt(var_k) (T = K_fa sqrt(var_ss),
 * the largest separation the test lets through, K_md = Q^-1(P_md)) is the
 * bound for a PL computed before the measurement; this one is lower whenever
 * |s| < T - (k_ff - K_md) sqrt(var_k), i.e. in nearly every fault-free
 * cycle, by about half where the subset is weak (var_k >> var_0: T ~ 5.3
 * sqrt(var_k) against |s| ~ sqrt(var_k)), and a fault raises it with the
 * separation it causes before the test trips. What it misses: what the
 * subset itself misses (a fault the subset took: two simultaneous faults;
 * beyond the linearisation). */
float mfns_integrity_pl_axis(float s, float var_k, float k_ff);

/* The a-priori form of the same bound, t + k_md sqrt(var_k), with t the
 * hypothesis's test threshold on that axis and k_md = Q^-1(P_md): for the
 * PLs that keep it (the beacon-only PL above, the filter bank's camera
 * hypotheses, filter_bank.h). */
float mfns_integrity_pl_axis_apriori(float t, float var_k, float k_md);

#define MFNS_INTEGRITY_MAX_HYP (MFNS_NUM_CAMERAS * MFNS_MAX_OBS_PER_CAMERA + MFNS_NUM_CAMERAS)
#define MFNS_INTEGRITY_AXES 6

typedef enum {
    MFNS_INTEGRITY_HYP_NONE = 0,
    MFNS_INTEGRITY_HYP_BEACON = 1, /* id: map index */
    MFNS_INTEGRITY_HYP_CAMERA = 2, /* id: camera 0..2 */
} mfns_integrity_hyp_kind_t;

typedef struct {
    uint8_t kind; /* mfns_integrity_hyp_kind_t */
    int16_t id;
} mfns_integrity_hyp_t;

typedef enum {
    MFNS_INTEGRITY_OK = 0,   /* evaluated: see the result */
    MFNS_INTEGRITY_E_ARG,    /* NULL, bad settings, or a solution that is not a fix */
    MFNS_INTEGRITY_E_GEOM,   /* the full information is singular or an inlier is behind its camera */
} mfns_integrity_status_t;

/* One evaluation of a fix. */
typedef struct {
    float pl_pos_mm;        /* protection level, largest position axis (mm); INFINITY when a
                               camera hypothesis is unmonitorable */
    float pl_att_deg;       /* protection level, largest attitude axis (deg) */
    float pl_beacon_pos_mm; /* over the fault-free and beacon hypotheses only, in the a-priori
                               form T + K_md sigma (the gate and the PL of a DEGRADED
                               CAMERA_UNMONITORED fix: see "Protection level" above) */
    float pl_beacon_att_deg;
    float max_norm_sep;     /* max over monitored hypotheses and axes of |s| / T (> 1: a test failed) */
    float k_fa, k_md;       /* the multipliers used */
    uint16_t hypotheses;    /* hypotheses formed (monitored + unmonitorable) */
    uint16_t unmonitorable; /* of them, not monitorable */
    uint16_t unmonitorable_cameras; /* of those, camera hypotheses */
    bool tests_passed;      /* every monitored test passed */
    mfns_integrity_hyp_t worst;      /* the hypothesis of max_norm_sep */
    mfns_integrity_hyp_t unmonitored; /* the first unmonitorable one (diagnostics) */
    float probe_norm_sep;   /* the probe's normalised separation (0 without a probe or when absent) */
} mfns_integrity_eval_t;

/* Evaluate the fix sol (status OK or DEGRADED, its assoc and inlier marks)
 * made from frame with map, rig and cfg. probe may be NULL, else the
 * hypothesis whose normalised separation is also returned alone
 * (probe_norm_sep; used to re-admit an excluded beacon or camera). */
mfns_integrity_status_t mfns_integrity_evaluate(const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                                const mfns_obs_frame_t *frame, const mfns_pose_solution_t *sol,
                                                const mfns_pose_config_t *cfg,
                                                const mfns_integrity_settings_t *set,
                                                const mfns_integrity_hyp_t *probe, mfns_integrity_eval_t *ev);

/* ------------------------------------------------------------------------
 * Exclusion with memory (integrity_fde.c).
 *
 * Per cycle, on a fix from the solver:
 *  1. beacons and cameras still held out from earlier cycles are removed and
 *     the fix re-solved without them (mfns_pose_refine from the fix);
 *  2. the fix is evaluated; a fix with an unmonitorable hypothesis is NO_FIX
 *     UNMONITORED; tests passed and PL within the alert limits: usable (its
 *     reason EXCLUDED while something is held out), else NO_FIX PL_EXCEEDS_AL;
 *  3. a failed test: the hypothesis of the largest normalised separation is
 *     removed, the fix re-solved and evaluated again (at most one new
 *     exclusion per cycle); passing and within the limits it is DEGRADED
 *     EXCLUDED and the beacon or camera is held out for hold_cycles; else
 *     NO_FIX FAULT_DETECTED (or the reduced fix's own reason).
 * A held item whose hold has run out is tested again (the fix with it,
 * probe): it is re-admitted when its separation passes, else held again.
 * The hold counts cycles with a fix from the solver (without one there is
 * nothing to test it against).
 * Bound per cycle: 2 re-solves, 4 evaluations.
 * ---------------------------------------------------------------------- */
#define MFNS_INTEGRITY_MAX_HELD_BEACONS 4
#define MFNS_INTEGRITY_LAG_WINDOW 8 /* cycles of the lag test's moving sum (integrity_lag.h) */
#define MFNS_INTEGRITY_LAG_VERIFY 4 /* passing tested fixes before a camera is used again */
#define MFNS_INTEGRITY_LAG_OUTAGE 2 /* cycles without an image that make an outage (a single dropped
                                       or refused frame is none; a health hold is >= 10) */

typedef struct {
    int16_t beacon[MFNS_INTEGRITY_MAX_HELD_BEACONS];      /* map index, -1 = free slot */
    uint16_t beacon_hold[MFNS_INTEGRITY_MAX_HELD_BEACONS]; /* cycles left */
    uint16_t cam_hold[MFNS_NUM_CAMERAS];                   /* cycles left; held while cam_held */
    uint8_t cam_held[MFNS_NUM_CAMERAS];
    /* the time-offset monitor (integrity_lag.h): 0 no lag hold, 1 held out
     * because its frames lag, 2 held out until its lag is verified after an
     * outage; lag_verify the passing tested fixes still needed */
    uint8_t cam_lag[MFNS_NUM_CAMERAS];
    uint8_t lag_verify[MFNS_NUM_CAMERAS];
    mfns_pose_t lag_last, lag_prev; /* the solver's last two fixes (the motion) */
    uint8_t lag_fixes;              /* consecutive solver fixes, capped at 2 */
    uint8_t dark_run[MFNS_NUM_CAMERAS]; /* consecutive cycles without an image, capped */
    uint8_t lag_tested_motion;      /* this cycle's fix was tested against a known motion */
    mfns_beacon_watch_t watch;      /* beacons missing or rejected (integrity_beacons.h) */
    mfns_camera_watch_t camwatch;   /* cameras inconsistent with the fix (integrity_cameras.h) */
    /* the time-offset monitor's moving window (integrity_lag.h): per camera
     * and tested cycle, f^T M e and f^T M f; lag_pos the next slot */
    float lag_num[MFNS_NUM_CAMERAS][MFNS_INTEGRITY_LAG_WINDOW];
    float lag_den[MFNS_NUM_CAMERAS][MFNS_INTEGRITY_LAG_WINDOW];
    float lag_vs[MFNS_NUM_CAMERAS][MFNS_INTEGRITY_LAG_WINDOW]; /* the survey part of lag_den */
    float lag_vc[MFNS_NUM_CAMERAS][MFNS_INTEGRITY_LAG_WINDOW]; /* the calibration part, beyond lag_den */
    uint8_t lag_pos[MFNS_NUM_CAMERAS];
} mfns_integrity_memory_t;

void mfns_integrity_memory_reset(mfns_integrity_memory_t *mem);

/* Hold camera cam out for cycles for the time-offset monitor
 * (integrity_lag.h): why 1 (its frames lag) or 2 (verifying after an
 * outage). Returns the previous cam_lag. The monitor releases it. */
uint8_t mfns_integrity_hold_lagging(mfns_integrity_memory_t *mem, int cam, uint8_t why, uint16_t cycles);

/* What the nav output carries. */
typedef struct {
    bool evaluated;           /* a fix was evaluated this cycle (else the rest is zero / -1) */
    bool tests_passed;
    float pl_pos_mm, pl_att_deg;
    float max_norm_sep;       /* of the fix as output (after any exclusion) */
    float detect_norm_sep;    /* of the fix before this cycle's new exclusion (= max_norm_sep without one) */
    uint16_t hypotheses;      /* monitored hypotheses of the output fix */
    uint16_t unmonitorable;
    int16_t excluded_beacon;  /* map index held out of this fix, -1 none (the first if several) */
    int8_t excluded_camera;   /* camera held out of this fix, -1 none */
    bool camera_unmonitored;  /* usable with camera faults unbounded (require_camera_monitor 0):
                                 the PLs then cover the fault-free and beacon hypotheses only */
    bool new_beacon_exclusion; /* excluded_beacon entered the memory this cycle: report once */
    bool new_camera_exclusion;
    int16_t readmitted_beacon; /* map index re-admitted this cycle, -1 none */
    int8_t readmitted_camera;  /* -1 none */
} mfns_integrity_result_t;

/* Run FDE on sol (in/out: replaced by the re-solved fix after an exclusion;
 * its status and reason set as above; a NO_FIX keeps its pose for
 * diagnostics). A sol that is not a fix is left alone (res->evaluated
 * false). Returns true when the fix is usable afterwards. */
bool mfns_integrity_fde(mfns_integrity_memory_t *mem, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                        const mfns_obs_frame_t *frame, const mfns_pose_config_t *cfg,
                        const mfns_integrity_settings_t *set, mfns_pose_solution_t *sol,
                        mfns_integrity_result_t *res);

#endif /* MFNS_INTEGRITY_H */
