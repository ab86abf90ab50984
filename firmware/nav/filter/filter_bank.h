/* filter_bank.h -- integrity over time (issue 42): solution separation
 * between the full navigation filter and a bank of subset filters, one per
 * single-fault hypothesis (Brenner, ION GPS 1995/96; docs/pose.md
 * "Navigation filter and integrity over time").
 *
 * Hypotheses, with equal standing:
 *   - camera k (always, MFNS_NUM_CAMERAS of them), PARAMETRIC: its filter
 *     takes camera k's frames with the camera's fault parameters ELIMINATED
 *     (nav_filter.h mfns_filter_update_invariant): a pointing bias b_k (3,
 *     C_k_b(true) = exp([b_k]x) C_k_b) and a time offset tau_k (1, the frame
 *     stamped t was captured at t - tau_k), fitted afresh at every frame as
 *     the linearisation point and then projected out of the frame's data.
 *     What a camera fault can do is a change of b_k or tau_k (a knocked
 *     mount, a lag, a drifting clock, a frozen scene); what it cannot do is
 *     change the part of camera k's frame those 4 parameters do not reach:
 *     the beacons' relative geometry (2n - 4 numbers for n beacons, 2n - 3
 *     on a robot at rest, whose timing has no effect). Only that part
 *     informs x_k, which is what a subset that drops the camera threw away
 *     (module seed 2: PL 120-320 mm dropped). The elimination is exact
 *     within the linearisation, whatever the fault's size or time profile
 *     (a step at any time, a ramp of any slope, a drift): x_k does not move
 *     with camera k's fault (test_nav_filter: 0.0002-0.015 sigma for a
 *     0.3-1 deg knock or a one-period lag, noise-free; NEES chi-square(6)
 *     with the camera knocked, stale or drifting). Its misses: the second
 *     order of a long offset on a turning robot (0.36 sigma at 0.27 s and
 *     0.05 rad/s; such a frame fails the full filter's gate and reaches no
 *     filter), and the velocity error times the offset (the timing column
 *     is taken at the predicted velocity). A per-frame prior on b_k and
 *     tau_k (1 deg, 60 ms: the model of before) kept more information but
 *     let a fault beyond it leak (a frozen scene's offset grows a period a
 *     frame); a constant-bias or rate-bounded model would keep more still
 *     but is unsound for a step after the start or a ramp beyond the bound.
 *     Under no fault x_k is the estimate from a linear function of the same
 *     data, so cov(x_0 - x_k) = P_k - P_0 and the separation test below holds.
 *     A camera with one or two beacons in view gives nothing invariant (2 or
 *     4 numbers): its hypothesis coasts on the motion model for that frame.
 *   - beacon b in view: started as a copy of the full filter just before
 *     b's first observation is applied, it takes every observation but b's.
 *     A step or a ramp on b moves the full filter only. (Kept as before: not
 *     parametric; a beacon's 3-D offset free would leave its observation
 *     nothing to say, the same as dropping it.)
 * A beacon with no free hypothesis slot is not used by any filter (counted in
 * unmonitored_obs): nothing enters the full filter that no hypothesis covers.
 *
 * A camera's clock in doubt (mfns_bank_doubt_timing, below): the camera
 * hypothesis bounds a timing fault, but the full filter, which took the
 * camera's frames at their stamps, is moved by it, and its covariance does
 * not say so (a camera a period stale after a dropped frame: usable fixes
 * 7-25 sigma off, within their PL, grown campaign). When the caller has
 * seen something wrong with a camera's frames, every filter takes them
 * with the time offset eliminated instead (nav_filter.h
 * mfns_filter_update_timing_free, the one direction from the full filter's
 * velocity): a lag moves no filter to first order, and the frames keep all
 * they say of the geometry but one number. The camera's own hypothesis is
 * unchanged (pointing and timing eliminated).
 *
 * Memory: a filter is 784 B on x86-64 (12 x 12 floats of covariance and the
 * nominal state; a camera's fault parameters are no states).
 * MFNS_BANK_MAX_BEACON_HYP = 12: the original module layout keeps 4-7 beacons
 * in view over two cameras, the planned 60-LED layout up to ~10; 12 leaves
 * room for the beacons that just left view and whose effect has not decayed
 * yet. 1 + 3 + 12 filters = 12,856 B of caller-owned RAM (20,152 B when the
 * fault parameters were states), and an observation costs at most 1 +
 * MFNS_BANK_MAX_HYP filter updates (6-wide in H), a camera's frame one
 * projected update of its hypothesis (MFNS_FILTER_INV_MAX_OBS observations).
 *
 * Eviction: the hypothesis of a beacon out of view this cycle ends once its
 * effect on the full filter has decayed: max over the six pose axes of
 * (P_k - P_0)_jj / P_0_jj <= MFNS_BANK_EVICT_RATIO (0.01). P_k - P_0 is the
 * covariance of the separation x_0 - x_k, i.e. of everything b's data put
 * into x_0; at 1 % of P_0's variance, b's influence on the current state is
 * 0.1 sigma_0 per sigma of b's own data, and a fault on b large enough to
 * matter after that was gated (nav_filter.h) or detected while b was in view.
 *
 * Detection, per hypothesis k and pose axis j (position mm, attitude rad,
 * world axes), at a common time:
 *   s_kj = (x_0 - x_k)_j,  T_kj = K_fa sqrt((P_k - P_0)_jj),  test |s_kj| <= T_kj
 *   K_fa = Q^-1(P_fa / (2 * 6 * N_hyp)), K_md = Q^-1(P_md), K_ff = Q^-1(P_md / 2)
 * with P_fa, P_md the table's integrity settings (mfns_integrity_settings_t,
 * nav_settings.h) and Q^-1 integrity.h's: the same allocation as the snapshot
 * FDE (integrity.h). Protection level per axis:
 *   PL_j = max( K_ff sigma_0j, max_k (|s_kj| + K_ff sigma_kj) )
 * with sigma including the map datum's term (added once, common to all
 * filters, so not in the separation): the observed separation's bound
 * (integrity.h mfns_integrity_pl_axis) for every hypothesis. Its subset is
 * unmoved by its fault (a beacon's never took the beacon, a camera's took
 * its frames with the camera's pointing and timing eliminated), so x_0 - x
 * = s_k + (x_k - x) and the triangle inequality bounds the error with no
 * test outcome, except with probability P_md per axis. Before the
 * elimination was exact the camera hypotheses kept the a-priori form, T_kj
 * + K_md sigma_kj, whose margin T - |s| covered the leak of a per-frame
 * prior of the fault parameters (the observed form had then let 25 usable
 * fixes beyond their PL through, up to 3.09 x, on the grown campaign).
 * Measured (grown campaign, filter on, seeds 2-5, 7 Dec 2026): at the
 * table's P_md 1e-3, 2 usable fixes of 14,024 were beyond their PL (1.03 x,
 * a clock drifting 0.5 ms a frame; 1.06 x, a stale camera): the rate the
 * allocation allows under a fault; at P_md 1e-5 (K_ff 4.4) none, worst 0.85.
 * PL_pos_mm / PL_att_deg are the largest position / attitude axis (per
 * axis: compare with a per-axis alert limit).
 * A hypothesis whose subset filter cannot follow (a camera that alone sees
 * the beacons coasts its subset beyond max_coast_s) is unmonitorable: the
 * PLs are infinite, status UNMONITORED.
 *
 * Exclusion: the gate of the full filter (nav_filter.h) names an observation
 * inconsistent with the motion-bounded prediction: a camera whose frame
 * failed as a whole (two or more observations gated against the prediction,
 * mfns_bank_observe_frame) while another camera's passed is excluded (a
 * single beacon fault fails one observation per frame; two cameras against
 * the prediction in one cycle are the motion, MOTION_EXCEEDED: two frames
 * failed as a whole, or one and another camera whose every observation
 * failed, a camera with one beacon in view); a beacon whose every
 * observation was gated in MFNS_BANK_GATE_EXCLUDE_RUN consecutive cycles is
 * excluded. Otherwise, when a separation test fails (|s|/T > 1), the failed
 * hypothesis whose subset is the most consistent with its observations is
 * excluded (MFNS_BANK_CONSIST_FORGET below).
 * Excluding k replaces the full filter by k's subset filter (the one that
 * never took k's data, or took camera k's only with its pointing and timing
 * eliminated: the fault leaves the solution with it; the camera is then held
 * out: simplest, and a pointing estimated from a knocked camera's own frames
 * is not trusted to fly on), restarts it
 * from its own state under the start's diffuse prior (MFNS_BANK_START_SIGMA_*:
 * a subject named wrongly leaves the fault in that subset, and a copy of it
 * would carry the fault with zero separation, which the observed-separation
 * PL would not see) and every other hypothesis as a copy of it: every filter
 * then rests on what it takes after the exclusion. An excluded beacon or camera is
 * tested every cycle against the full filter (not applied): a beacon's
 * observation is clean with its NIS below chi-square(2) at
 * MFNS_BANK_READMIT_P, a camera's frame with the sum of its NIS below
 * chi-square(2n) at the same level (a late camera's observations are each
 * only a little off, all together clearly); re-admitted after hold_cycles
 * consecutive clean cycles (the table's integrity hold), a cycle counting
 * only when the previous one was usable (a filter whose PL is beyond the
 * alert limit has no power to call anything clean); its hypothesis then
 * starts afresh.
 *
 * Status: OK (reason NONE), DEGRADED EXCLUDED (something held out), NO_FIX
 * PL_EXCEEDS_AL, UNMONITORED, FAULT_DETECTED (more excluded than the bank
 * holds), MOTION_EXCEEDED (the full filter's gate: restart from acquisition).
 *
 * What it misses:
 *   - two simultaneous faults (single-fault hypotheses only);
 *   - a fault present in the prior the bank started from (the first PLs are
 *     only as good as that prior: nav_filter_cycle.h starts it from a
 *     diffuse prior around the snapshot fix, so that none of the snapshot's
 *     error is trusted);
 *   - the cycles after an exclusion: the diffuse restart leaves the PL
 *     beyond the alert limit until the new observations outweigh the prior
 *     (not a miss, a cost: a camera excluded of three with the remaining
 *     two weak about one axis stayed unusable, test_filter_bank's ramp on
 *     camera 1);
 *   - a camera that alone sees the beacons: its hypothesis keeps that
 *     camera's inter-beacon geometry, but its attitude and position along
 *     the pointing are the motion model's only: the PL grows past the alert
 *     limit; a camera with one beacon in view is the same for its hypothesis;
 *   - two cameras seeing beacons and a slow pointing ramp of one: a change
 *     of their relative pointing that either camera's hypothesis explains
 *     (only the motion model could tell them apart, and its bound allows
 *     the body rotation): detected, but the other camera was named in one
 *     of the two runs measured (both with the per-frame prior; camera 1's
 *     ramp names camera 0, test_filter_bank, two-camera ramp);
 *   - a one-frame lag of a 3-beacon camera in a two-camera scene: a beacon
 *     hypothesis's separation can fail first and the beacon is blamed
 *     (test_filter_bank comment; not yet handled);
 *   - faults common to every camera and beacon (datum, common clock).
 *
 * Work per observation: one test against the prediction and at most 1 +
 * MFNS_BANK_MAX_HYP filter updates; per
 * evaluation at most 1 + MFNS_BANK_MAX_HYP propagations and separations; the
 * bank counts them (work) so tests assert the bound.
 */
#ifndef MFNS_FILTER_BANK_H
#define MFNS_FILTER_BANK_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/filter/nav_filter.h"
#include "firmware/nav/settings/nav_settings.h"
#include "firmware/nav/pose/pose.h"

#define MFNS_BANK_MAX_BEACON_HYP 12
/* The diffuse prior every start of the bank takes (nav_filter_cycle.c start,
 * and the restart after an exclusion, filter_bank.c exclude), the pose's per
 * axis: large against any snapshot error that passed its tests (the
 * module's: well under a millimetre and 0.01 deg), small enough for the
 * error-state linearisation (small attitude errors, nav_filter.h); the
 * velocity's: Astrobee-class top speeds (0.5 m/s, 0.5 rad/s). */
#define MFNS_BANK_START_SIGMA_MM 20.0f
#define MFNS_BANK_START_SIGMA_RAD 0.0175f /* 1 deg */
#define MFNS_BANK_SIGMA_V0_MM_S 500.0f
#define MFNS_BANK_SIGMA_W0_RAD_S 0.5f
#define MFNS_BANK_CAM_HYP MFNS_NUM_CAMERAS
#define MFNS_BANK_MAX_HYP (MFNS_BANK_CAM_HYP + MFNS_BANK_MAX_BEACON_HYP)
#define MFNS_BANK_EVICT_RATIO 0.01f
#define MFNS_BANK_MAX_EXCLUDED_BEACONS 4
#define MFNS_BANK_AXES 6
/* a beacon whose observations fail the full filter's gate in this many
 * consecutive cycles is excluded by the gate; one gated cycle is not enough,
 * so that a camera fault that fails one of its beacons first (a late frame on
 * a slow turn) shows as the camera it is before a healthy beacon is blamed */
#define MFNS_BANK_GATE_EXCLUDE_RUN 2U
/* Attribution after a failed separation test: several hypotheses' tests can
 * fail for one fault (every subset but the faulty one's took the fault, with
 * its own gain). The subject is the hypothesis whose subset filter is the
 * most consistent with the observations it took, among the failed ones and
 * every camera's (a camera's subset is the one a camera fault leaves where
 * it was, and its test has the least power, having lost the camera's
 * pointing and timing: another subset's test often fails first): the
 * smallest excess of its innovations, z = (sum NIS - dof) / sqrt(2 dof),
 * the sums forgotten by MFNS_BANK_CONSIST_FORGET per cycle (~10 cycles of
 * memory). A faulty beacon's subset never took the fault; every other subset
 * did, a camera's subset the part of it its elimination leaves (half or more
 * of a single beacon's offset for up to 4 beacons). The beacon (the smaller
 * exclusion) is preferred unless the camera's z is lower by
 * MFNS_BANK_CAMERA_PREF_Z (3 when a camera's subset absorbed its frames
 * through a per-frame prior, and with it a beacon's fault; 1 now: measured,
 * test_filter_bank's camera ramps and dominant late camera named rightly,
 * its beacon faults too). */
#define MFNS_BANK_CONSIST_FORGET 0.9f
/* The full filter's innovation window (nav_filter.h mfns_filter_end_cycle)
 * failing is the motion unless one hypothesis explains it: its subset's
 * consistency z at most this (a slow ramp on one beacon: every subset but
 * the beacon's took it) */
#define MFNS_BANK_EXPLAIN_Z 3.0f
#define MFNS_BANK_CAMERA_PREF_Z 1.0f
/* A subset is a candidate of attribution only after this many degrees of
 * freedom of its own (forgotten sums, ~3 cycles of a 3-camera scene): a
 * hypothesis started a cycle ago is a copy of the full filter, fault and
 * all, and its z is mostly noise. */
#define MFNS_BANK_CONSIST_MIN_DOF 40.0f
/* Re-admission test: an excluded item's observation is clean when its NIS
 * against the full filter is below chi-square(2) at this tail probability
 * (9.21): stricter than the gate, so that a fault near the gate's size does
 * not count as healed. */
#define MFNS_BANK_READMIT_P 0.01f
/* the separation's variance floor, relative to P_0's: P_k - P_0 is a small
 * difference of two float covariances that went through hundreds of updates
 * (rounding of ~1e-4 of P_0 measured: a beacon seen once gave P_k - P_0 =
 * -9e-5 P_0); a hypothesis just started has a real P_k - P_0 below that. The
 * floor, 1e-3 P_0, sets T_k >= 0.17 sigma_0 at K_fa = 5.3: nothing for the PL */
#define MFNS_BANK_VAR_FLOOR_REL 1e-3f
/* and an absolute floor from the start: the start's prior variance times
 * this many float epsilons (the rounding a covariance cut from the prior by
 * a factor of 1e5 or more in its first frame leaves in P_k - P_0: a 20 mm
 * prior cut to 0.04 mm left separations of beacon hypotheses beyond
 * K_fa sqrt(P_k - P_0) in the start cycle, test_nav_filter_cycle). 256 eps of
 * a (20 mm)^2 / (1 deg)^2 prior: T >= 0.6 mm / 0.03 deg, for the PL nothing
 * against the alert limits. */
#define MFNS_BANK_VAR_FLOOR_EPS 256.0f
/* Timing in doubt (mfns_bank_doubt_timing). A camera's clock is read at each
 * of its frames by the full filter's timing-free update (nav_filter.h
 * mfns_filter_update_timing_free: tau and its sigma at the predicted state,
 * which the camera's timing no longer moves; the sigma carries the state's
 * covariance, so it is honest and wide: 12 ms for a camera of one beacon,
 * 21-29 ms for one of ten, module seed 5 at about 80 mm/s). A frame is a
 * clean reading when |tau| <= MFNS_BANK_TIMING_K sigma, a dirty one beyond;
 * a clean reading counts toward clearing the doubt only when it could have
 * seen an offset of the doubt's resolve_s (K sigma at most that; the flight
 * passes the frame period, the lag of a camera stale after a dropped frame:
 * a robot at rest reads no clock, and its frames neither clear nor
 * condemn). The table's hold_cycles clean readings in a row clear the
 * doubt; a dirty one starts the count again. K = 3, the readmission's
 * (chi-square(1) at about MFNS_BANK_READMIT_P's tail). Misses: an offset
 * below K sigma (a fraction of a period: the camera's hypothesis bounds
 * it, and an offset the reading cannot see moves the pose by about as
 * many of its sigmas, since both come from the same image motion). */
#define MFNS_BANK_TIMING_K 3.0f

/* A frame that passed the gate but is unlikely as a whole (FRAME_SUSPECT).
 * Each observation is gated alone at the table's gate_p (1e-5): a camera
 * fault at its onset moves every observation of the camera's frame a little
 * (a mount knocked 0.3 deg: 8.5 px against a prediction of about 2 px, every
 * observation inside the gate; a frozen scene re-delivered with fresh noise:
 * a period of image motion), the full filter takes the frame, and until the
 * separation tests see the fault (the next cycle or two) the fix is inside
 * its PL but beyond 5 sigma of its covariance. The full filter's NIS of the
 * observations it took of one camera's frame is chi-square(2 m) under no
 * fault; beyond the upper MFNS_BANK_FRAME_SUSPECT_P point the cycle's fix is
 * refused (NO_FIX FRAME_SUSPECT, out.suspect_camera; the frame stays taken:
 * a fault that persists is named by the tests, a noise excursion is gone the
 * next cycle). Cost: at most MFNS_BANK_FRAME_SUSPECT_P of the frames of each
 * camera on a noise model that holds (0.3 % of cycles with three cameras);
 * none where the model overstates the noise. Misses: a frame whose fault the
 * prediction's uncertainty explains (a joint NIS below the point: a knock
 * along the prediction's loosest direction, a lag on a slow robot); a fault
 * that grows slowly (each frame consistent with the last); a one-beacon
 * frame (2 degrees of freedom: a beacon fault's and a camera's look alike;
 * it is tested all the same). Measured (module seed 5, filter on): the
 * onset frame of camera x knocked 0.3 deg had NIS 46.8 on 22 degrees of
 * freedom (p 1.6e-3 over every camera; over camera x's own rows alone
 * smaller), a frozen scene's first frame 62.0 on 24 (p 3e-5); clean frames
 * 0.0-0.3 (the simulator's noise is a tenth of the model's). */
#define MFNS_BANK_FRAME_SUSPECT_PPM 1000u /* 1e-3 */
#define MFNS_BANK_FRAME_SUSPECT_P ((float)MFNS_BANK_FRAME_SUSPECT_PPM * 1e-6f)
_Static_assert(MFNS_BANK_FRAME_SUSPECT_PPM > 0u && MFNS_BANK_FRAME_SUSPECT_PPM < 50000u,
               "the frame test refuses rare frames only");

typedef enum {
    MFNS_BANK_HYP_NONE = 0,
    MFNS_BANK_HYP_BEACON = 1, /* id: map index */
    MFNS_BANK_HYP_CAMERA = 2, /* id: camera */
} mfns_bank_hyp_kind_t;

typedef struct {
    mfns_filter_t full;
    mfns_filter_t sub[MFNS_BANK_MAX_HYP]; /* 0..2 cameras, then beacon slots */
    int16_t slot_beacon[MFNS_BANK_MAX_BEACON_HYP]; /* map index, -1 free */
    uint8_t slot_seen[MFNS_BANK_MAX_BEACON_HYP];   /* observed this cycle */
    uint8_t slot_gated[MFNS_BANK_MAX_BEACON_HYP];  /* gated this cycle, none passed */
    uint8_t slot_passed[MFNS_BANK_MAX_BEACON_HYP]; /* an observation passed this cycle */
    uint8_t slot_gate_run[MFNS_BANK_MAX_BEACON_HYP]; /* consecutive cycles all gated */
    int16_t excl_beacon[MFNS_BANK_MAX_EXCLUDED_BEACONS]; /* -1 free */
    uint16_t excl_beacon_clean[MFNS_BANK_MAX_EXCLUDED_BEACONS];
    uint8_t excl_beacon_dirty[MFNS_BANK_MAX_EXCLUDED_BEACONS]; /* failed its test this cycle */
    uint8_t excl_beacon_tested[MFNS_BANK_MAX_EXCLUDED_BEACONS];
    uint8_t cam_excluded[MFNS_NUM_CAMERAS];
    uint16_t cam_clean[MFNS_NUM_CAMERAS];
    uint8_t cam_dirty[MFNS_NUM_CAMERAS];
    uint8_t cam_tested[MFNS_NUM_CAMERAS];
    float cam_held_nis[MFNS_NUM_CAMERAS]; /* a held camera's frame: sum of NIS this cycle */
    float frame_nis[MFNS_NUM_CAMERAS];    /* the full filter's NIS of the observations it took of the camera's frame */
    uint16_t frame_dof[MFNS_NUM_CAMERAS]; /* their degrees of freedom */
    uint16_t cam_held_dof[MFNS_NUM_CAMERAS];
    /* this cycle's gate outcomes in the full filter */
    uint16_t cam_gated[MFNS_NUM_CAMERAS], cam_passed[MFNS_NUM_CAMERAS];
    uint8_t frame_rejected[MFNS_NUM_CAMERAS]; /* the frame failed as a whole this cycle */
    float cons_nis[MFNS_BANK_MAX_HYP], cons_dof[MFNS_BANK_MAX_HYP]; /* forgetting sums (attribution) */
    uint8_t det_kind;    /* this cycle's exclusion (mfns_bank_hyp_kind_t), reported by evaluate */
    int16_t det_id;
    uint8_t det_by_gate;
    uint32_t unmonitored_obs; /* observations used by no filter: no free slot */
    uint32_t work;            /* filter updates + propagations + separations this cycle */
    float var_floor[MFNS_BANK_AXES]; /* MFNS_BANK_VAR_FLOOR_EPS x the start's prior variance, per pose axis */
    uint8_t last_usable; /* the last evaluation was usable: re-admission tests count */
    int8_t told_suspect; /* this cycle: the caller's checks found this camera's frame suspect (-1 none) */
    uint8_t timing_doubt[MFNS_NUM_CAMERAS]; /* its clock in doubt: its frames timing-free everywhere */
    uint16_t timing_clean[MFNS_NUM_CAMERAS]; /* consecutive clean readings of its clock with power */
    float timing_resolve_s[MFNS_NUM_CAMERAS]; /* the offset a reading must resolve to count (the doubt's) */
    uint8_t timing_read[MFNS_NUM_CAMERAS];   /* this cycle: 0 none, 1 clean with power, 2 dirty */
    uint8_t initialised;
} mfns_filter_bank_t;

typedef struct {
    mfns_pose_status_t status;
    mfns_pose_reason_t reason;
    bool usable;
    bool restart; /* the caller re-acquires: motion bound exceeded or the filter lost */
    mfns_pose_t pose;
    float cov_ros[6][6];      /* with the datum term */
    float pl_pos_mm, pl_att_deg;
    float pl_beacon_pos_mm, pl_beacon_att_deg; /* the same over the fault-free and beacon hypotheses only
                                                  (diagnostics: what camera faults cost) */
    float max_norm_sep;       /* max |s|/T over hypotheses and axes (before any exclusion) */
    float k_fa, k_md;
    uint16_t hypotheses;      /* active hypotheses tested */
    uint16_t unmonitorable;
    uint8_t detected_kind;    /* mfns_bank_hyp_kind_t of this cycle's exclusion, NONE */
    int16_t detected_id;
    uint8_t by_gate;          /* the exclusion came from the innovation gate */
    int16_t readmitted_beacon; /* -1 none */
    int8_t readmitted_camera;  /* -1 none */
    int8_t timing_trusted;     /* a camera whose clock doubt this cycle cleared, -1 none */
    int8_t suspect_camera;     /* the camera of this cycle's most unlikely frame beyond the FRAME_SUSPECT point
                                  (-1 none); the reason is FRAME_SUSPECT when no other refused the fix first */
    uint8_t timing_doubt_mask; /* bit c: camera c's clock still in doubt after this cycle */
    uint32_t work;
} mfns_bank_output_t;

/* Start (or restart) from a certified snapshot fix, as mfns_filter_init.
 * Exclusions are cleared (a restart from acquisition re-verifies all). */
mfns_filter_status_t mfns_bank_init(mfns_filter_bank_t *b, const mfns_pose_t *pose, const float cov_ros[6][6],
                                    mfns_v3_t v_w, float sigma_v_mm_s, mfns_v3_t w_w, float sigma_w_rad_s,
                                    int64_t t_us);

/* One camera's frame: n observations (n <= MFNS_MAX_OBS_PER_CAMERA) of one
 * camera at one capture time, beacon[i] the map index of obs[i]. Frames in
 * time order across calls (the caller orders a cycle's frames by capture
 * time). Each observation is first tested against the full filter's
 * prediction: two or more failing the gate reject the frame as a whole
 * (GATED: a camera fault or the motion; nothing of it is applied);
 * otherwise each is applied to the full filter (its own gate: a single
 * faulty beacon is GATED alone) and, when the full filter took it, to every
 * subset but its hypotheses'. An excluded beacon's or camera's observations
 * are only tested (for re-admission). E_TIME: the full filter coasted beyond
 * max_coast_s (evaluate asks for a restart); E_ARG: bad input. */
mfns_filter_status_t mfns_bank_observe_frame(mfns_filter_bank_t *b, const mfns_filter_settings_t *fs,
                                             const mfns_rig_t *rig, float sigma_px, int n, const int16_t beacon[],
                                             const mfns_filter_obs_t obs[]);

/* Close a cycle at t_us (>= every observation's time): propagate the bank,
 * test, exclude, re-admit, evict, and output the pose with its PL and status. */
mfns_filter_status_t mfns_bank_evaluate(mfns_filter_bank_t *b, const mfns_filter_settings_t *fs,
                                        const mfns_integrity_settings_t *is, const mfns_map_datum_t *datum,
                                        int64_t t_us, mfns_bank_output_t *out);

/* The start's diffuse prior on the pose (MFNS_BANK_START_SIGMA_MM / _RAD):
 * per axis of var_ros (pose.h cov_ros order, position first) the larger of
 * that variance and the diffuse sigma squared, uncorrelated; the one rule
 * of a start from a snapshot fix (nav_filter_cycle.c) and of the restart
 * after an exclusion (filter_bank.c). A NaN variance gives the floor
 * (fmaxf): a caller that must refuse one checks first. */
void mfns_bank_diffuse_prior(const float var_ros[6], float prior[6][6]);

/* After mfns_bank_init: hold out what `from` held out (a restart that follows
 * an exclusion, nav_filter_cycle.h); the re-admission counts start afresh. */
void mfns_bank_keep_exclusions(mfns_filter_bank_t *b, const int16_t excl_beacon[MFNS_BANK_MAX_EXCLUDED_BEACONS],
                               const uint8_t cam_excluded[MFNS_NUM_CAMERAS]);

/* Camera cam's clock is in doubt (the caller's frame checks saw a dropped,
 * held, late, frozen or stepped frame: firmware/frames/frame_health.h):
 * from its next frame on, every filter of the bank takes camera cam's frames
 * with their time offset eliminated (mfns_filter_update_timing_free; the
 * camera's own hypothesis as before, pointing and timing eliminated), the
 * frame gated as a whole on its rows' chi-square, and the full filter reads
 * the camera's clock from each of them (MFNS_BANK_TIMING_K above). A stale
 * or drifting camera then moves no filter through its timing, and keeps
 * what its frames say of the geometry (one number a frame less: along the
 * image motion of the robot's velocity). The doubt clears after hold_cycles
 * clean readings that resolve resolve_s (> 0: the frame period; evaluate:
 * out->timing_trusted). resolve_s is also the bound on the camera's offset
 * that the timing-free updates take (nav_filter.h tau_bound_s: the offset
 * times the velocity's error enters each filter's covariance; the frame
 * checks leave a camera out once it is half a period out of step, a stale
 * frame is a period late). Misses: a clock fault the
 * caller's checks did not see (a drift from the start of the bank, a stale
 * frame that came without a dropped or held one): the camera's hypothesis
 * bounds it, with no doubt its timing moves the full filter (usable fixes
 * beyond 5 sigma, within the PL). Also a clock that reads clean while the
 * robot moves too slowly to show it (no power: the doubt holds). E_ARG
 * for a bad camera or resolve_s not in (0, MFNS_FILTER_CONSIDER_TAU_MAX_S]. */
mfns_filter_status_t mfns_bank_doubt_timing(mfns_filter_bank_t *b, int cam, float resolve_s);

/* Before mfns_bank_evaluate: the caller's own checks (the snapshot's time-
 * offset monitor, integrity_lag.h) find this cycle's frame of camera `cam`
 * suspect. The evaluation then refuses its fix as for a frame beyond the
 * FRAME_SUSPECT point (above): NO_FIX FRAME_SUSPECT naming `cam`, and the
 * refused cycle does not count towards re-admission (last_usable). The frame
 * stays taken. Cleared by the evaluation. E_ARG for a bad camera. */
mfns_filter_status_t mfns_bank_suspect_frame(mfns_filter_bank_t *b, int cam);

/* Is beacon (map index) / camera held out now. */
bool mfns_bank_beacon_excluded(const mfns_filter_bank_t *b, int16_t beacon);
bool mfns_bank_camera_excluded(const mfns_filter_bank_t *b, int cam);

#endif /* MFNS_FILTER_BANK_H */
